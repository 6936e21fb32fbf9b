"""Figures for HZD gaits: virtual constraints against phase, torques, stick figures, and
stick-figure frames for :mod:`bipedlab.viz.animation` (:func:`segments`, :func:`frames`,
:func:`animate`). Figures go through :mod:`bipedlab.viz.figures`."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.control import hzd
from bipedlab.mechanics.kinematics import body_poses, point_position
from bipedlab.mechanics.stance import embed
from bipedlab.sim.integrators import rk4
from bipedlab.viz import animation, figures, stick

SEGMENT_WIDTHS = (1.5, 1.5, 1.5, 1.5, 2.5)
"""Line widths of :func:`segments`' five segments (legs thin, torso thick)."""


def trace_step(vc, st, ctrl, z_minus, h: float = 1e-3, duration: float | None = None):
    """(t, z, u) sampled every h over one step from the pre-impact state z_minus."""
    from bipedlab.gait.walking import control_law
    from bipedlab.mechanics.stance import impact

    zp, _, _, _ = impact(st, z_minus)
    u_of = control_law(vc, st, ctrl)
    f = hzd.closed_loop_flow(vc, st, u_of)
    n = int(np.ceil((duration or 1.0) / h))

    def body(z, _):
        return rk4(lambda x, _u: f(x), z, None, h), (z, u_of(z))

    _, (zs, us) = jax.jit(lambda z: jax.lax.scan(body, z, None, length=n))(zp)
    return np.arange(n) * h, np.asarray(zs), np.asarray(us)


def segments(model, q, x_off: float = 0.0) -> np.ndarray:
    """The five-link biped at configuration q as five segments (5, 2, 2) in metres: hip-knee
    and knee-foot of leg 1, the same of leg 2, hip-torso top; shifted along x by x_off."""
    _, origins, _ = body_poses(model, q)
    hip = np.asarray(origins)[0, :2]
    p = {n: np.asarray(point_position(model, q, n))[:2] for n in ("knee_1_point", "foot_1", "knee_2_point", "foot_2",
                                                                   "torso_top")}
    segs = np.array([[hip, p["knee_1_point"]], [p["knee_1_point"], p["foot_1"]],
                     [hip, p["knee_2_point"]], [p["knee_2_point"], p["foot_2"]], [hip, p["torso_top"]]], dtype=float)
    segs[..., 0] += x_off
    return segs


def frames(st, zs, offsets=None) -> np.ndarray:
    """Segments (F, 5, 2, 2) of the stance states zs (F, 2n) embedded in the full model; frame
    k shifted along x by offsets[k] (e.g. the distance walked before its step)."""
    out = []
    for k, z in enumerate(zs):
        q, _ = embed(st, jnp.asarray(z))
        out.append(segments(st.model, q, 0.0 if offsets is None else float(offsets[k])))
    return np.array(out, dtype=float).reshape(-1, 5, 2, 2)


def animate(path, st, t, zs, offsets=None, gif: bool = False, fps: float = 30.0) -> list[str]:
    """Write an animation (.svg or .html by path's suffix; a GIF beside it with gif=True) of the
    stance states zs (F, 2n) at times t, subsampled to about fps frames per second; e.g.
    ``animate(out / "step.svg", st, *trace_step(vc, st, ctrl, z_minus)[:2])``."""
    t = np.asarray(t)
    idx = np.unique(np.searchsorted(t, np.arange(t[0], t[-1] + 1e-12, 1.0 / fps)).clip(0, len(t) - 1))
    fr = frames(st, np.asarray(zs)[idx], None if offsets is None else np.asarray(offsets)[idx])
    return animation.write(path, fr, t[idx], ground=0.0, widths=[2.0, 2.0, 2.0, 2.0, 3.5], gif=gif,
                           title="five-link walking")


def _stick(ax, model, q, x_off, color):
    stick.draw(ax, segments(model, q, x_off), colors=color, widths=SEGMENT_WIDTHS)


def _constraint_plot(path, vc, thetas, q_actual, names):
    th = np.linspace(float(vc.theta_plus), float(vc.theta_minus), 200)
    hd = np.asarray(jax.vmap(lambda t: hzd.desired(vc, t)[0])(jnp.asarray(th)))
    fig, axes = figures.subplots(len(names), 1, figsize=(6, 2 * len(names)), sharex=True)
    for i, ax in enumerate(axes):
        ax.plot(th, hd[:, i], "k-", lw=2, label="virtual constraint h_d")
        if q_actual is not None:
            ax.plot(thetas, q_actual[:, i], "r--", lw=1, label="closed loop")
        ax.set_ylabel(f"{names[i]} (rad)")
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("phase theta (rad)")
    figures.save(fig, path)


OUTPUT_NAMES = ("hip_st", "knee_st", "hip_sw", "knee_sw")


def _torque_plot(path, x, u, xlabel, ylabel):
    fig, ax = figures.subplots(figsize=(6, 3.5))
    for i in range(u.shape[1]):
        ax.plot(x, u[:, i], label=OUTPUT_NAMES[i])
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.legend(fontsize=8)
    figures.save(fig, path)


def gait_figures(out, prob, met) -> list[str]:
    """Figures of a designed gait (virtual constraints, torques along the step, stick figure)."""
    out = figures.output_dir(out)
    vc = met["vc"]
    zs = np.asarray(met["states"])
    thetas = np.asarray(met["thetas"])
    _constraint_plot(out / "virtual_constraints.png", vc, thetas, (np.asarray(vc.H0) @ zs[:, :prob.n].T).T,
                     OUTPUT_NAMES)
    u = np.asarray(met["u"])
    _torque_plot(out / "torques.png", thetas, u, "phase theta (rad)", "u* (N m)")
    _sticks(out / "stick_figure.png", prob.stance, zs[:: max(1, len(zs) // 8)], 0.0)
    np.savez(out / "gait.npz", thetas=thetas, states=zs, u=u, grf=np.asarray(met["grf"]))
    return [str(out / n) for n in ("virtual_constraints.png", "torques.png", "stick_figure.png", "gait.npz")]


def _sticks(path, st, zs, step_length, offsets=None):
    fig, ax = figures.subplots(figsize=(7, 3.5))
    stick.sequence(ax, frames(st, zs, offsets), colors=figures.pyplot().get_cmap("viridis"), widths=SEGMENT_WIDTHS)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    figures.save(fig, path)


def walk_figures(out, vc, st, ctrl, z0, w) -> list[str]:
    """Virtual constraints tracked in the first step, torques, a stick-figure sequence."""
    out = figures.output_dir(out)
    dur = float(w.duration[0]) if w.status[0] == 0 else 1.0
    t, zs, us = trace_step(vc, st, ctrl, z0, duration=dur)
    thetas = zs[:, : st.n] @ np.asarray(vc.c)
    _constraint_plot(out / "virtual_constraints.png", vc, thetas, (np.asarray(vc.H0) @ zs[:, : st.n].T).T,
                     OUTPUT_NAMES)
    _torque_plot(out / "torques.png", t, us, "time in the first step (s)", "torque (N m)")
    ok = np.asarray(w.status) == 0
    steps = int(np.sum(ok))
    pick = list(range(min(steps, 6)))
    offsets = np.concatenate([[0.0], np.cumsum(np.asarray(w.step_length)[:steps])])
    _sticks(out / "stick_figure.png", st, [np.asarray(w.z_minus)[k] for k in pick], 0.0,
            offsets=[offsets[k] for k in pick])
    np.savez(out / "walk.npz", t=t, states=zs, u=us, z_minus=np.asarray(w.z_minus),
             duration=np.asarray(w.duration), step_length=np.asarray(w.step_length))
    animate(out / "walk.html", st, t, zs)  # the first step, playable offline in a browser
    return [str(out / n) for n in ("virtual_constraints.png", "torques.png", "stick_figure.png", "walk.npz",
                                   "walk.html")]
