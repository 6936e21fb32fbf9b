"""One way to make, style and save a figure: matplotlib on the Agg backend (no display), PNG
files written into a directory that is created on demand.

The house style is matplotlib's defaults, a tight layout and 110 dpi; every robot's plots
module goes through this module, so a change here restyles every study::

    from bipedlab.viz import figures

    fig, ax = figures.subplots(figsize=(6, 3.5))
    ax.plot(t, y)
    path = figures.save(fig, out / "torques.png")       # tight layout, 110 dpi, closed

``save`` also appends the path to a list when one is given (the plots modules collect the
files they write), and :func:`output_dir` creates a study's ``--out`` directory.
"""
from __future__ import annotations

from pathlib import Path

DPI = 110
"""Resolution of every saved figure (dots per inch)."""

FORMAT = "png"


def pyplot():
    """matplotlib.pyplot on the non-interactive Agg backend (selected on every call, so that a
    study never opens a window whatever was imported before)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def subplots(nrows: int = 1, ncols: int = 1, **kwargs):
    """``plt.subplots`` in the house style: returns (figure, axes) exactly as matplotlib does
    (``squeeze``, ``sharex``, ``figsize`` ... pass through)."""
    return pyplot().subplots(nrows, ncols, **kwargs)


def output_dir(out) -> Path:
    """The directory ``out`` as a Path, created (with its parents) if missing."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    return out


def save(fig, path, paths: list | None = None, tight: bool = True, dpi: int = DPI) -> str:
    """Lay out (``tight_layout`` unless tight is False), write fig to path at dpi, close it and
    return the path as a string; the parent directory is created if needed and, when a list
    ``paths`` is given, the path is appended to it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if tight:
        fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    pyplot().close(fig)
    if paths is not None:
        paths.append(str(path))
    return str(path)


def close(fig) -> None:
    """Close a figure without saving it."""
    pyplot().close(fig)
