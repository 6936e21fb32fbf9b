"""One animation writer for every robot: stick-figure frames to a self-contained file.

Input: ``frames``, an array (frames, segments, 2, 2) of line segments in metres (the format
of :mod:`bipedlab.viz.stick`), the time of each frame in seconds, and optionally the ground
(a height, or a terrain polyline (points, 2)). Output, by the file's suffix:

* ``.svg`` - an animated SVG: one ``<g class="frame" data-t=...>`` of ``<line>`` elements per
  frame, shown in turn by SMIL ``<animate>`` of ``visibility`` (no script), world y up, coordinates in metres;
* ``.html`` / ``.htm`` - a page with an inline ``<canvas>``, the frames as JSON in
  ``<script type="application/json" id="bipedlab-animation">`` and a small inline player;
* and, with ``gif=True``, an animated GIF beside it through matplotlib's PillowWriter when
  Pillow is installed (skipped otherwise).

Nothing is fetched from the network; the files play offline in any browser. ``follow=True``
keeps a walking robot in view: the window is one frame's width and moves with the frames'
mean x. Widths are in pixels; colours are any matplotlib colour. Subsample long logs first
(some 25-50 frames per second of motion suffice).
"""
from __future__ import annotations

from html import escape
from pathlib import Path

import numpy as np

from bipedlab.outputs import dumps_json
from bipedlab.viz.stick import as_frames

DECIMALS = 6
"""Coordinates and times are written with this many decimals (1 micrometre, 1 microsecond)."""
GROUND_COLOR = "#808080"


def _num(v: float) -> str:
    s = f"{float(v):.{DECIMALS}f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def _hex(color) -> str:
    from matplotlib.colors import to_hex

    return to_hex(color)


def scene(frames, times, ground=None, colors="k", widths=2.0, follow: bool = False, margin: float = 0.1) -> dict:
    """Checked, writer-independent description of an animation: frames (F, S, 2, 2), times
    (F,) from 0, duration, ground polyline or None, per-frame x shift, the view (x0, y0, x1,
    y1) in shifted world coordinates, and per-segment hex colours and widths."""
    from bipedlab.viz.stick import per_segment

    fr = as_frames(frames)
    t = np.asarray(times, dtype=float).reshape(-1)
    if len(t) != len(fr):
        raise ValueError(f"{len(fr)} frames but {len(t)} times")
    if not (np.all(np.isfinite(fr)) and np.all(np.isfinite(t))):
        raise ValueError("frames and times must be finite")
    if np.any(np.diff(t) < 0):
        raise ValueError("times must be non-decreasing")
    steps = np.diff(t)
    dt = float(np.median(steps[steps > 0])) if np.any(steps > 0) else 0.04
    x = fr[..., 0].reshape(len(fr), -1)
    y = fr[..., 1]
    shift = -x.mean(axis=1) if follow else np.zeros(len(fr))
    xs = x + shift[:, None]
    x0, x1 = float(xs.min()), float(xs.max())
    y0, y1 = float(y.min()), float(y.max())
    if ground is not None and np.ndim(ground) == 0:
        y0, y1 = min(y0, float(ground)), max(y1, float(ground))
        wx0, wx1 = float(x.min()), float(x.max())
        half = (x1 - x0) / 2 + margin * max(x1 - x0, y1 - y0, 1e-3) if follow else 0.0
        pad = margin * max(x1 - x0, y1 - y0, 1e-3) + half
        ground = np.array([[wx0 - pad, float(ground)], [wx1 + pad, float(ground)]])
    elif ground is not None:
        ground = np.asarray(ground, dtype=float)
        if ground.ndim != 2 or ground.shape[1] != 2 or not np.all(np.isfinite(ground)):
            raise ValueError(f"ground must be a height or a finite polyline (points, 2), got shape {ground.shape}")
        inside = (ground[:, 0] >= x.min()) & (ground[:, 0] <= x.max())
        if np.any(inside):
            y0, y1 = min(y0, ground[inside, 1].min()), max(y1, ground[inside, 1].max())
    pad = margin * max(x1 - x0, y1 - y0, 1e-3)
    n = fr.shape[1]
    return dict(frames=fr, times=t - t[0], duration=float(t[-1] - t[0] + dt), dt=dt, ground=ground, shift=shift,
                view=(x0 - pad, y0 - pad, x1 + pad, y1 + pad),
                colors=[_hex(c) for c in per_segment(colors, n, "colors")],
                widths=[float(w) for w in per_segment(widths, n, "widths")])


def _pixels(view, size_px: int) -> tuple[int, int]:
    """Width and height in pixels of the view (x0, y0, x1, y1), its longer side size_px."""
    x0, y0, x1, y1 = view
    s = size_px / max(x1 - x0, y1 - y0)
    return max(1, int(round(s * (x1 - x0)))), max(1, int(round(s * (y1 - y0))))


def _svg(sc: dict, size_px: int, title: str) -> str:
    x0, y0, x1, y1 = sc["view"]
    width_px, height_px = _pixels(sc["view"], size_px)
    T, n = sc["duration"], len(sc["frames"])
    key = lambda v: _num(min(max(v / T, 0.0), 1.0))  # noqa: E731
    anim = f'dur="{_num(T)}s" calcMode="discrete" repeatCount="indefinite"'
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width_px}" height="{height_px}" '
           f'viewBox="{_num(x0)} {_num(-y1)} {_num(x1 - x0)} {_num(y1 - y0)}">',
           f"<title>{escape(title)}</title>",
           f'<rect x="{_num(x0)}" y="{_num(-y1)}" width="{_num(x1 - x0)}" height="{_num(y1 - y0)}" fill="#ffffff"/>',
           '<g transform="scale(1,-1)">', "<g>"]
    if np.any(sc["shift"]) and n > 1:
        vals = ";".join(f"{_num(s)},0" for s in sc["shift"])
        kt = ";".join(key(t) for t in sc["times"])
        out.append(f'<animateTransform attributeName="transform" type="translate" values="{vals}" keyTimes="{kt}" {anim}/>')
    elif np.any(sc["shift"]):
        out[-1] = f'<g transform="translate({_num(sc["shift"][0])},0)">'
    if sc["ground"] is not None:
        pts = " ".join(f"{_num(px)},{_num(py)}" for px, py in sc["ground"])
        out.append(f'<polyline class="ground" points="{pts}" fill="none" stroke="{GROUND_COLOR}" stroke-width="1" '
                   'vector-effect="non-scaling-stroke"/>')
    for k, (seg, t) in enumerate(zip(sc["frames"], sc["times"])):
        end = sc["times"][k + 1] if k + 1 < n else T
        if n == 1:
            show, a = "visible", ""
        elif k == 0:
            show, a = "visible", f'<animate attributeName="visibility" values="visible;hidden" keyTimes="0;{key(end)}" {anim}/>'
        elif k == n - 1:
            show, a = "hidden", f'<animate attributeName="visibility" values="hidden;visible" keyTimes="0;{key(t)}" {anim}/>'
        else:
            show, a = "hidden", (f'<animate attributeName="visibility" values="hidden;visible;hidden" '
                               f'keyTimes="0;{key(t)};{key(end)}" {anim}/>')
        out.append(f'<g class="frame" data-t="{_num(t)}" visibility="{show}">{a}')
        for (p, q), c, w in zip(seg, sc["colors"], sc["widths"]):
            out.append(f'<line x1="{_num(p[0])}" y1="{_num(p[1])}" x2="{_num(q[0])}" y2="{_num(q[1])}" stroke="{c}" '
                       f'stroke-width="{_num(w)}" stroke-linecap="round" vector-effect="non-scaling-stroke"/>')
        out.append("</g>")
    out += ["</g>", "</g>", "</svg>"]
    return "\n".join(out) + "\n"


_PLAYER = """(function () {
  var d = JSON.parse(document.getElementById("bipedlab-animation").textContent);
  var cv = document.getElementById("bipedlab-canvas"), g = cv.getContext("2d");
  var v = d.view, s = cv.width / (v[2] - v[0]), start = null;
  function X(x, k) { return (x + d.shift[k] - v[0]) * s; }
  function Y(y) { return (v[3] - y) * s; }
  function at(t) { var lo = 0, hi = d.times.length - 1;
    while (lo < hi) { var m = (lo + hi + 1) >> 1; if (d.times[m] <= t) lo = m; else hi = m - 1; } return lo; }
  function draw(k) {
    g.fillStyle = "#ffffff"; g.fillRect(0, 0, cv.width, cv.height); g.lineCap = "round";
    if (d.ground) { g.strokeStyle = d.ground_color; g.lineWidth = 1; g.beginPath();
      d.ground.forEach(function (p, i) { if (i) g.lineTo(X(p[0], k), Y(p[1])); else g.moveTo(X(p[0], k), Y(p[1])); });
      g.stroke(); }
    d.frames[k].forEach(function (q, i) { g.strokeStyle = d.colors[i]; g.lineWidth = d.widths[i]; g.beginPath();
      g.moveTo(X(q[0], k), Y(q[1])); g.lineTo(X(q[2], k), Y(q[3])); g.stroke(); });
    g.fillStyle = "#000000"; g.font = "12px sans-serif"; g.fillText("t = " + d.times[k].toFixed(2) + " s", 6, 14);
  }
  function tick(ms) { if (start === null) start = ms;
    draw(at(((ms - start) / 1000) % d.duration)); window.requestAnimationFrame(tick); }
  window.requestAnimationFrame(tick);
})();"""


def _html(sc: dict, size_px: int, title: str) -> str:
    width_px, height_px = _pixels(sc["view"], size_px)
    r = lambda a: np.round(np.asarray(a, dtype=float), DECIMALS).tolist()  # noqa: E731
    data = dict(times=r(sc["times"]), duration=sc["duration"], frames=r(sc["frames"].reshape(len(sc["frames"]), -1, 4)),
                ground=None if sc["ground"] is None else r(sc["ground"]), ground_color=GROUND_COLOR,
                shift=r(sc["shift"]), view=r(sc["view"]), colors=sc["colors"], widths=sc["widths"])
    blob = dumps_json(data, separators=(",", ":")).replace("</", "<\\/")  # strict: JSON.parse takes no NaN
    return (f'<!DOCTYPE html>\n<html lang="en">\n<head><meta charset="utf-8"><title>{escape(title)}</title></head>\n'
            f'<body>\n<canvas id="bipedlab-canvas" width="{width_px}" height="{height_px}"></canvas>\n'
            f'<script type="application/json" id="bipedlab-animation">{blob}</script>\n'
            f"<script>\n{_PLAYER}\n</script>\n</body>\n</html>\n")


def pillow_available() -> bool:
    """Whether Pillow (needed for GIFs) can be imported."""
    import importlib.util

    return importlib.util.find_spec("PIL") is not None


def write_gif(path, sc: dict, size_px: int = 640, max_fps: float = 50.0) -> str | None:
    """Write the scene as an animated GIF through matplotlib's PillowWriter at the frames'
    median rate (at most max_fps); returns the path, or None when Pillow is missing."""
    if not pillow_available():
        return None
    from matplotlib.animation import FuncAnimation, PillowWriter

    from bipedlab.viz import figures, stick

    x0, y0, x1, y1 = sc["view"]
    w, h = _pixels(sc["view"], size_px)
    fig = figures.pyplot().figure(figsize=(w / 100, h / 100), dpi=100)
    ax = fig.add_axes((0, 0, 1, 1))
    lw = [w * 0.72 for w in sc["widths"]]

    def show(k):
        ax.cla()
        ax.set_axis_off()
        if sc["ground"] is not None:
            ax.plot(sc["ground"][:, 0] + sc["shift"][k], sc["ground"][:, 1], color=GROUND_COLOR, lw=0.72)
        stick.draw(ax, sc["frames"][k], colors=sc["colors"], widths=lw, offset=(sc["shift"][k], 0.0))
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        return []

    fps = float(np.clip(1.0 / sc["dt"], 1.0, max_fps))
    FuncAnimation(fig, show, frames=len(sc["frames"]), blit=False).save(str(path), writer=PillowWriter(fps=fps))
    figures.close(fig)
    return str(path)


def write(path, frames, times, ground=None, colors="k", widths=2.0, follow: bool = False, gif: bool = False,
          size_px: int = 640, title: str = "bipedlab animation") -> list[str]:
    """Write an animation of frames (F, S, 2, 2, metres) at times (F,) to path (.svg, .html or
    .htm; the directory is created) and, with gif=True and Pillow installed, to path with the
    suffix .gif; the longer side of the picture is size_px pixels. Returns the paths written."""
    path = Path(path)
    kind = path.suffix.lower()
    if kind not in (".svg", ".html", ".htm"):
        raise ValueError(f"animation file must end in .svg, .html or .htm, got {path.name!r}")
    sc = scene(frames, times, ground=ground, colors=colors, widths=widths, follow=follow)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text((_svg if kind == ".svg" else _html)(sc, int(size_px), title), encoding="utf-8")
    paths = [str(path)]
    if gif:
        g = write_gif(path.with_suffix(".gif"), sc, int(size_px))
        if g is not None:
            paths.append(g)
    return paths
