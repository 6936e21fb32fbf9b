"""Robots with their published parameters and coordinates."""
from . import five_link, mabel

__all__ = ["five_link", "mabel"]
