"""Gait design on the hybrid zero dynamics and Poincaré stability analysis."""
from bipedlab.gait import optimize

__all__ = ["optimize"]
