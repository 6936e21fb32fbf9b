"""Figures for MABEL's hopping study, after the identification paper's Figs. 21-23. Figures go
through :mod:`bipedlab.viz.figures`; no stick-figure frames (MABEL has no drawing-point
routine yet, see :mod:`bipedlab.robots.mabel.walking.plots`)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from bipedlab.robots.mabel import tables as tb
from bipedlab.viz import figures


def _window(run, first_hop: int, hops: int = 2):
    """Sample indices covering ``hops`` hops from touchdown number first_hop (clipped)."""
    td = run.touchdowns
    k0 = min(first_hop, max(len(td) - hops - 1, 0))
    t0 = td[k0] if len(td) else run.t[0]
    t1 = td[k0 + hops] if len(td) > k0 + hops else run.t[-1]
    return (run.t >= t0) & (run.t <= t1)


def write_figures(run, stretch: np.ndarray, out: str | Path, first_hop: int = 30) -> list[str]:
    """Joint angles and hip position (Fig. 21), torques (Fig. 22), cable stretch (Fig. 23) over
    two hops, and the hop period over the run. Returns the written paths."""
    from bipedlab.robots.mabel.hopping.study import INDEX

    out = figures.output_dir(out)
    w = _window(run, first_hop)
    t, x = run.t[w], run.x[w]
    paths = []

    fig, ax = figures.subplots(3, 2, figsize=(10, 8), sharex=True)
    for k, s in enumerate(tb.SIDES):
        ax[0, k].plot(t, np.rad2deg(x[:, INDEX[f"la_{s}"]]), label="q_LA")
        ax[0, k].set_title(f"{'left' if s == 'L' else 'right'} leg")
        ax[1, k].plot(t, np.rad2deg(x[:, INDEX[f"ls_{s}"]]), label="q_LS")
        ax[1, k].plot(t, np.rad2deg(x[:, INDEX[f"bsp_{s}"]]), label="q_Bsp")
        ax[0, k].set_ylabel("leg angle (deg)")
        ax[1, k].set_ylabel("deg")
        ax[1, k].legend(loc="best", fontsize=8)
    ax[2, 0].plot(t, x[:, INDEX["y"]], color="C1")
    ax[2, 0].set_ylabel("hip height (m)", color="C1")
    travel = ax[2, 0].twinx()
    travel.plot(t, x[:, INDEX["x"]] - x[0, INDEX["x"]], color="C0")
    travel.set_ylabel("hip travel (m)", color="C0")
    ax[2, 1].plot(t, np.rad2deg(x[:, INDEX["tor"]]))
    ax[2, 1].set_ylabel("torso angle (deg)")
    for a in ax[2]:
        a.set_xlabel("time (s)")
    fig.suptitle("MABEL hopping: joint angles and hip position (cf. Fig. 21)")
    paths.append(figures.save(fig, out / "hop_joints.png"))

    paths.append(_per_actuator(t, run.u[w], "command (N m)", "Motor torque commands (cf. Fig. 22)",
                               out / "hop_torques.png"))
    paths.append(_per_actuator(t, np.rad2deg(stretch[w]), "stretch, motor side (deg)",
                               "Cable stretch in motor coordinates (cf. Fig. 23)", out / "hop_cable_stretch.png"))

    if len(run.touchdowns) > 2:
        fig, ax = figures.subplots(figsize=(7, 3.5))
        ax.plot(np.arange(1, len(run.touchdowns)), np.diff(run.touchdowns), ".-")
        ax.set_xlabel("hop")
        ax.set_ylabel("period (s)")
        ax.set_title("Hop period, touchdown to touchdown")
        paths.append(figures.save(fig, out / "hop_periods.png"))
    paths += hop_animation(out / "hop.html", run)
    return paths


#: stick figure: torso (hip to head), thighs and shins of both legs
DRAW_POINTS = ("hip", "head", "knee_L", "toe_L", "knee_R", "toe_R")
DRAW_SEGMENTS = ((0, 1), (0, 2), (2, 3), (0, 4), (4, 5))


def hop_animation(path, run, seconds: float = 4.0, fps: float = 40.0) -> list[str]:
    """The first ``seconds`` of a hopping run (13-DoF states at the control samples) as an
    offline HTML stick-figure animation over the ground."""
    import jax
    import jax.numpy as jnp

    from bipedlab.mechanics import coupled as cp
    from bipedlab.robots.mabel import model as mm
    from bipedlab.viz import animation

    t = np.asarray(run.t)
    if len(t) < 2:
        return []
    keep = np.nonzero(t - t[0] <= seconds)[0][:: max(1, int(round(1.0 / (fps * float(t[1] - t[0])))))]
    m = mm.hopping_model()
    n = len(mm.COORDS_13)
    pts = jax.jit(jax.vmap(lambda q: jnp.stack([cp.point_position(m.body, q, p) for p in DRAW_POINTS])))(
        jnp.asarray(np.asarray(run.x)[keep, :n]))
    pts = np.asarray(pts)
    frames = np.stack([np.stack([pts[:, a], pts[:, b]], axis=1) for a, b in DRAW_SEGMENTS], axis=1)
    return animation.write(path, frames, t[keep] - t[keep][0], ground=0.0,
                           colors=["#444444", "#1f77b4", "#1f77b4", "#d62728", "#d62728"],
                           widths=[5.0, 2.5, 2.5, 2.5, 2.5], follow=True, title="MABEL hopping")


def _per_actuator(t, data, ylabel: str, title: str, path: Path) -> str:
    """One panel per actuator (tables.ACTUATORS order) of data (N, 4) against t."""
    fig, ax = figures.subplots(2, 2, figsize=(10, 6), sharex=True)
    for k, a in enumerate(tb.ACTUATORS):
        axk = ax[k % 2, k // 2]
        axk.plot(t, data[:, k])
        axk.set_title(a)
        axk.set_ylabel(ylabel)
    for a in ax[1]:
        a.set_xlabel("time (s)")
    fig.suptitle(title)
    return figures.save(fig, path)
