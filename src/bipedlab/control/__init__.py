"""Controllers: Bézier virtual constraints and hybrid zero dynamics."""
from . import bezier, hzd

__all__ = ["bezier", "hzd"]
