"""Robots with their published parameters and coordinates."""
from . import five_link

__all__ = ["five_link"]
