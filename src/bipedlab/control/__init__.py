"""Controllers: Bézier virtual constraints and hybrid zero dynamics."""
from bipedlab.control import bezier, hzd

__all__ = ["bezier", "hzd"]
