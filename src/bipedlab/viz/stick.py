"""Planar stick figures: a robot drawn as line segments, one configuration per frame.

A frame is a sequence of segments, each a pair of 2-D points ``((x0, y0), (x1, y1))`` in
metres, i.e. an array of shape (segments, 2, 2); a sequence of frames has shape
(frames, segments, 2, 2). The same arrays feed :mod:`bipedlab.viz.animation`. Each robot's
plots module turns its configurations into segments (its ``segments`` / ``frames``
functions); this module only draws them.

Consecutive segments that share an end point and a style are drawn as one polyline, so a leg
given as hip-knee, knee-foot looks exactly like the polyline hip-knee-foot.

The ground is ``None`` (not drawn), a number (a level line at that height across the axes)
or a terrain polyline of shape (points, 2).
"""
from __future__ import annotations

import numpy as np

GROUND_STYLE = dict(color="0.5", lw=1)


def as_frames(segments) -> np.ndarray:
    """Segments of one frame (S, 2, 2) or of many (F, S, 2, 2) as a float array (F, S, 2, 2)."""
    a = np.asarray(segments, dtype=float)
    if a.ndim == 3:
        a = a[None]
    if a.ndim != 4 or a.shape[2:] != (2, 2):
        raise ValueError(f"segments must have shape (frames, segments, 2, 2) or (segments, 2, 2), got {a.shape}")
    return a


def _single(value) -> bool:
    """True for one style value: None, a number, a colour name or an RGB(A) tuple / array."""
    if value is None or isinstance(value, (str, int, float, np.number)):
        return True
    a = np.asarray(value, dtype=object)
    return a.ndim == 1 and len(a) in (3, 4) and all(isinstance(v, (int, float, np.number)) for v in a)


def per_segment(value, n: int, name: str) -> list:
    """A style given once (a width, a colour) or per segment, as a list of n entries."""
    if _single(value) if name == "colors" else (value is None or np.ndim(value) == 0):
        return [value] * n
    value = list(value)
    if len(value) != n:
        raise ValueError(f"{name}: expected one value or {n}, got {len(value)}")
    return value


def chains(segments, colors=None, widths=None):
    """Group one frame's segments into polylines: yields (points (k, 2), color, width) with
    consecutive segments merged where one ends where the next starts and the style agrees."""
    seg = np.asarray(segments, dtype=float)
    cs = [tuple(c) if isinstance(c, np.ndarray) else c for c in per_segment(colors, len(seg), "colors")]
    ws = per_segment(widths, len(seg), "widths")
    pts, style = None, None
    for s, c, w in zip(seg, cs, ws):
        if pts is not None and style == (c, w) and np.array_equal(pts[-1], s[0]):
            pts.append(s[1])
            continue
        if pts is not None:
            yield np.array(pts), style[0], style[1]
        pts, style = [s[0], s[1]], (c, w)
    if pts is not None:
        yield np.array(pts), style[0], style[1]


def draw(ax, segments, colors="k", widths=1.5, alpha=None, offset=(0.0, 0.0)) -> list:
    """Draw one frame's segments (S, 2, 2) on ax, shifted by offset (metres); colors and
    widths once or per segment. Returns the matplotlib lines."""
    off = np.asarray(offset, dtype=float)
    lines = []
    for pts, c, w in chains(segments, colors, widths):
        kw = dict(color=c, lw=w)
        if alpha is not None:
            kw["alpha"] = alpha
        lines += ax.plot(pts[:, 0] + off[0], pts[:, 1] + off[1], **kw)
    return lines


def draw_ground(ax, ground=0.0, **style):
    """Draw the ground: a level line at height ``ground`` (a number), a terrain polyline
    (points, 2), or nothing for None. Style defaults to a thin grey line."""
    if ground is None:
        return None
    kw = dict(GROUND_STYLE, **style)
    if np.ndim(ground) == 0:
        return ax.axhline(float(ground), **kw)
    g = np.asarray(ground, dtype=float)
    if g.ndim != 2 or g.shape[1] != 2:
        raise ValueError(f"ground polyline must have shape (points, 2), got {g.shape}")
    return ax.plot(g[:, 0], g[:, 1], **kw)[0]


def sequence(ax, frames, colors="k", widths=1.5, alphas=None, offsets=None, ground=0.0, equal: bool = True):
    """Draw a frame sequence (F, S, 2, 2) on one axes: frame k with colour colors(k) when colors
    is callable (e.g. a colormap of k / (F - 1)) else colors, alpha alphas[k], shifted along x by
    offsets[k]; then the ground; equal aspect unless equal is False."""
    fr = as_frames(frames)
    n = len(fr)
    for k in range(n):
        c = colors(k / max(1, n - 1)) if callable(colors) else colors
        off = (0.0 if offsets is None else float(offsets[k]), 0.0)
        draw(ax, fr[k], colors=c, widths=widths, alpha=None if alphas is None else alphas[k], offset=off)
    draw_ground(ax, ground)
    if equal:
        ax.set_aspect("equal")
    return ax
