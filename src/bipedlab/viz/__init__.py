"""Plots and animations, written to files (matplotlib on Agg; no display needed).

* :mod:`.figures` - the one way to create, style and save a figure (PNG, 110 dpi, tight layout);
* :mod:`.stick` - planar stick figures from segments (pairs of 2-D points) per frame, with a
  level ground or a terrain polyline;
* :mod:`.animation` - one animation writer for every robot: animated SVG (SMIL) or HTML with an
  inline canvas player, and an optional GIF through Pillow.

Submodules are imported on use, so ``import bipedlab.viz`` does not load matplotlib.
"""
