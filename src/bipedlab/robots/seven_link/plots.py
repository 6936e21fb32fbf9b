"""Figures for the seven-link walking studies: joint angles and torques (cf. Fig. 8), a
stick-figure sequence (cf. Fig. 9), the free-swing responses (cf. Fig. 6) and the low-gain PD
experiment (cf. Fig. 7); and stick-figure frames for :mod:`bipedlab.viz.animation`
(:func:`segments`, :func:`frames`, :func:`animate`). Figures go through
:mod:`bipedlab.viz.figures`."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from bipedlab.robots.seven_link import robot as sl
from bipedlab.viz import animation, figures, stick


def skeleton_points(q: np.ndarray) -> dict:
    """World positions of the drawing points for configurations q (n, 9), numpy."""
    import jax
    import jax.numpy as jnp

    r = sl.model()
    f = jax.jit(jax.vmap(lambda qq: sl.skeleton(r, qq)))
    return {k: np.asarray(v) for k, v in f(jnp.asarray(q)).items()}


def segments(P: dict, i: int) -> np.ndarray:
    """Frame i of skeleton points P (from :func:`skeleton_points`) as eleven segments
    (11, 2, 2) in metres: hip-head, then each leg (1, then 2) as hip-knee, knee-ankle,
    ankle-heel, heel-toe, toe-ankle."""
    pts = lambda s: [P["hip"][i], P[f"knee_{s}"][i], P[f"ankle_{s}"][i], P[f"heel_{s}"][i], P[f"toe_{s}"][i],  # noqa: E731
                     P[f"ankle_{s}"][i]]
    segs = [[P["hip"][i], P["head"][i]]]
    for s in ("1", "2"):
        chain = pts(s)
        segs += [[a, b] for a, b in zip(chain[:-1], chain[1:])]
    return np.asarray(segs, dtype=float)[..., :2]


def frames(q: np.ndarray) -> np.ndarray:
    """Segments (F, 11, 2, 2) of the configurations q (F, 9)."""
    q = np.asarray(q)
    P = skeleton_points(q[:, :9])
    return np.array([segments(P, i) for i in range(len(q))], dtype=float).reshape(-1, 11, 2, 2)


def _styles(color="k", lw=1.5):
    """Colours and widths of :func:`segments`: body thicker, leg 2 blue beside a black leg 1."""
    c2 = "C0" if color == "k" else color
    return [color] + [color] * 5 + [c2] * 5, [lw + 1] + [lw] * 10


def animate(path, t, x, gif: bool = False, fps: float = 30.0, window=None) -> list[str]:
    """Write an animation (.svg or .html by path's suffix; a GIF beside it with gif=True) of
    the logged states x (n, >= 9) at times t over window (default: all), subsampled to about
    fps frames per second, the view following the robot."""
    t, x = np.asarray(t), np.asarray(x)
    lo, hi = window or (t[0], t[-1])
    idx = np.unique(np.searchsorted(t, np.arange(lo, hi + 1e-12, 1.0 / fps)).clip(0, len(t) - 1))
    colors, widths = _styles("k", 2.0)
    return animation.write(path, frames(x[idx, :9]), t[idx], ground=0.0, colors=colors, widths=widths, follow=True,
                           gif=gif, title="seven-link walking")


def _draw(ax, P, i, color="k", lw=1.5, alpha=1.0):
    colors, widths = _styles(color, lw)
    stick.draw(ax, segments(P, i), colors=colors, widths=widths, alpha=alpha)


def stick_figure(t, x, out, name="stick_figures.png", frames: int = 12, window=None, title=None) -> str:
    """A frame sequence (cf. Fig. 9): ``frames`` evenly spaced configurations over the time
    window (default: the last two seconds), offset along x so the frames do not overlap."""
    t = np.asarray(t)
    x = np.asarray(x)
    if window is None:
        window = (max(t[0], t[-1] - 2.0), t[-1])
    idx = np.flatnonzero((t >= window[0]) & (t <= window[1]))
    idx = idx[np.linspace(0, len(idx) - 1, frames).astype(int)] if len(idx) else idx
    P = skeleton_points(x[idx, :9])
    fig, ax = figures.subplots(figsize=(12, 3.2))
    for k in range(len(idx)):
        _draw(ax, P, k, alpha=0.35 + 0.65 * (k + 1) / len(idx))
    stick.draw_ground(ax, 0.0)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_title(title or f"seven-link walking, {window[0]:.2f}-{window[1]:.2f} s (leg 1 black, leg 2 blue)")
    return figures.save(fig, Path(out) / name)


def angles_and_torques(t, x, u, states, out, name="angles_torques.png", window=None) -> str:
    """Body and thigh absolute angles, knee and ankle joint angles and the six joint torques
    over a window (cf. Fig. 8); leg 1 solid, leg 2 dashed; the leg states S1-S4 below."""
    t = np.asarray(t)
    if window is None:
        window = (max(t[0], t[-1] - 3.0), t[-1])
    w = (t >= window[0]) & (t <= window[1])
    t, x, u, states = t[w], np.asarray(x)[w], np.asarray(u)[w], np.asarray(states)[w]
    phi = x[:, :9] @ sl.JOINT_MAP.T + sl.JOINT_OFFSET
    fig, ax = figures.subplots(5, 2, figsize=(11, 10), sharex=True)
    d = np.rad2deg
    ax[0, 0].plot(t, d(x[:, 2]), "k")
    ax[0, 0].set_ylabel("body θ (deg)")
    ax[0, 1].plot(t, x[:, 9], "k")
    ax[0, 1].set_ylabel("hip speed (m/s)")
    ax[1, 0].plot(t, d(x[:, 3]), "k", t, d(x[:, 6]), "b--")
    ax[1, 0].set_ylabel("thigh θ1, θ4 (deg)")
    ax[2, 0].plot(t, d(phi[:, 1]), "k", t, d(phi[:, 4]), "b--")
    ax[2, 0].set_ylabel("knee φ2, φ5 (deg)")
    ax[3, 0].plot(t, d(phi[:, 2]), "k", t, d(phi[:, 5]), "b--")
    ax[3, 0].set_ylabel("ankle φ3, φ6 (deg)")
    for k, nm in enumerate(("hip", "knee", "ankle")):
        ax[1 + k, 1].plot(t, u[:, k], "k", t, u[:, 3 + k], "b--")
        ax[1 + k, 1].set_ylabel(f"{nm} torque (N m)")
    ax[4, 0].step(t, states[:, 0] + 1, "k", where="post")
    ax[4, 0].step(t, states[:, 1] + 1, "b--", where="post")
    ax[4, 0].set_yticks([1, 2, 3, 4])
    ax[4, 0].set_ylabel("state S")
    ax[4, 1].plot(t, d(phi[:, 0]), "k", t, d(phi[:, 3]), "b--")
    ax[4, 1].set_ylabel("hip φ1, φ4 (deg)")
    for a in ax[-1]:
        a.set_xlabel("time (s)")
    fig.suptitle("seven-link walking: angles and torques (cf. Fig. 8)")
    return figures.save(fig, Path(out) / name)


def free_swing(curves: dict, out, name="free_swing.png") -> str:
    """Fig. 6: free-swing angle against time for each joint, Table I gearing and the highly
    geared alternative. curves: {joint: {label: (t, angle_deg)}}."""
    fig, ax = figures.subplots(1, len(curves), figsize=(5 * len(curves), 3.5))
    ax = np.atleast_1d(ax)
    for a, (joint, c) in zip(ax, curves.items()):
        for k, (label, (t, y)) in enumerate(c.items()):
            a.plot(t, y, ls="-" if k == 0 else ":", color="C0" if k == 0 else "0.5", label=label)
        a.set_title(f"{joint} free swing")
        a.set_xlabel("time (s)")
        a.set_ylabel("joint angle (deg)")
        a.legend(fontsize=8)
    return figures.save(fig, Path(out) / name)


def pd_experiment(t, phi, phi_d, out, name="pd_experiment.png") -> str:
    """Fig. 7: hip, knee and ankle angles of the low-gain PD experiment with their references."""
    fig, ax = figures.subplots(3, 1, figsize=(8, 7), sharex=True)
    for k, nm in enumerate(("hip φ1", "knee φ2", "ankle φ3")):
        ax[k].plot(t, np.rad2deg(phi[:, k]), "k", label="model response")
        ax[k].plot(t, np.rad2deg(phi_d[:, k]), "b--", label="reference φ_d")
        ax[k].set_ylabel(f"{nm} (deg)")
    ax[0].legend(fontsize=8)
    ax[-1].set_xlabel("time (s)")
    fig.suptitle("low-gain PD experiment (cf. Fig. 7)")
    return figures.save(fig, Path(out) / name)
