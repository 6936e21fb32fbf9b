"""Figures for HZD gaits: virtual constraints against phase, torques, stick figures."""
from __future__ import annotations

from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.control import hzd
from bipedlab.mechanics.kinematics import body_poses, point_position
from bipedlab.mechanics.stance import embed
from bipedlab.sim.integrators import rk4


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


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


def _stick(ax, model, q, x_off, color):
    _, origins, _ = body_poses(model, q)
    o = np.asarray(origins)
    for leg in (("knee_1_point", "foot_1"), ("knee_2_point", "foot_2")):
        k = np.asarray(point_position(model, q, leg[0]))
        f = np.asarray(point_position(model, q, leg[1]))
        ax.plot([o[0, 0] + x_off, k[0] + x_off, f[0] + x_off], [o[0, 1], k[1], f[1]], color=color, lw=1.5)
    top = np.asarray(point_position(model, q, "torso_top"))
    ax.plot([o[0, 0] + x_off, top[0] + x_off], [o[0, 1], top[1]], color=color, lw=2.5)


def _constraint_plot(plt, path, vc, thetas, q_actual, names):
    th = np.linspace(float(vc.theta_plus), float(vc.theta_minus), 200)
    hd = np.asarray(jax.vmap(lambda t: hzd.desired(vc, t)[0])(jnp.asarray(th)))
    fig, axes = plt.subplots(len(names), 1, figsize=(6, 2 * len(names)), sharex=True)
    for i, ax in enumerate(axes):
        ax.plot(th, hd[:, i], "k-", lw=2, label="virtual constraint h_d")
        if q_actual is not None:
            ax.plot(thetas, q_actual[:, i], "r--", lw=1, label="closed loop")
        ax.set_ylabel(f"{names[i]} (rad)")
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("phase theta (rad)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


OUTPUT_NAMES = ("hip_st", "knee_st", "hip_sw", "knee_sw")


def _torque_plot(plt, path, x, u, xlabel, ylabel):
    fig, ax = plt.subplots(figsize=(6, 3.5))
    for i in range(u.shape[1]):
        ax.plot(x, u[:, i], label=OUTPUT_NAMES[i])
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def gait_figures(out, prob, met) -> list[str]:
    """Figures of a designed gait (virtual constraints, torques along the step, stick figure)."""
    plt = _plt()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    vc = met["vc"]
    zs = np.asarray(met["states"])
    thetas = np.asarray(met["thetas"])
    _constraint_plot(plt, out / "virtual_constraints.png", vc, thetas, (np.asarray(vc.H0) @ zs[:, :prob.n].T).T,
                     OUTPUT_NAMES)
    u = np.asarray(met["u"])
    _torque_plot(plt, out / "torques.png", thetas, u, "phase theta (rad)", "u* (N m)")
    _sticks(plt, out / "stick_figure.png", prob.stance, zs[:: max(1, len(zs) // 8)], 0.0)
    np.savez(out / "gait.npz", thetas=thetas, states=zs, u=u, grf=np.asarray(met["grf"]))
    return [str(out / n) for n in ("virtual_constraints.png", "torques.png", "stick_figure.png", "gait.npz")]


def _sticks(plt, path, st, zs, step_length, offsets=None):
    fig, ax = plt.subplots(figsize=(7, 3.5))
    cmap = plt.get_cmap("viridis")
    for k, z in enumerate(zs):
        q, _ = embed(st, jnp.asarray(z))
        off = 0.0 if offsets is None else offsets[k]
        _stick(ax, st.model, q, off, cmap(k / max(1, len(zs) - 1)))
    ax.axhline(0.0, color="0.5", lw=1)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def walk_figures(out, vc, st, ctrl, z0, w) -> list[str]:
    """Virtual constraints tracked in the first step, torques, a stick-figure sequence."""
    plt = _plt()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    dur = float(w.duration[0]) if w.status[0] == 0 else 1.0
    t, zs, us = trace_step(vc, st, ctrl, z0, duration=dur)
    thetas = zs[:, : st.n] @ np.asarray(vc.c)
    _constraint_plot(plt, out / "virtual_constraints.png", vc, thetas, (np.asarray(vc.H0) @ zs[:, : st.n].T).T,
                     OUTPUT_NAMES)
    _torque_plot(plt, out / "torques.png", t, us, "time in the first step (s)", "torque (N m)")
    ok = np.asarray(w.status) == 0
    steps = int(np.sum(ok))
    pick = list(range(min(steps, 6)))
    offsets = np.concatenate([[0.0], np.cumsum(np.asarray(w.step_length)[:steps])])
    _sticks(plt, out / "stick_figure.png", st, [np.asarray(w.z_minus)[k] for k in pick], 0.0,
            offsets=[offsets[k] for k in pick])
    np.savez(out / "walk.npz", t=t, states=zs, u=us, z_minus=np.asarray(w.z_minus),
             duration=np.asarray(w.duration), step_length=np.asarray(w.step_length))
    return [str(out / n) for n in ("virtual_constraints.png", "torques.png", "stick_figure.png", "walk.npz")]
