"""Gait design on the hybrid zero dynamics and Poincaré stability analysis."""
from . import optimize

__all__ = ["optimize"]
