"""Figures for MABEL's compliant-HZD walking studies, after the paper's Figs. 5-9, 12, 16, 17
and 20. Figures go through :mod:`bipedlab.viz.figures`.

:func:`walk_animation` draws the logged walk as a stick figure (torso, thighs, shins from the
model's hip, head, knee and toe points) through :mod:`bipedlab.viz.animation`."""
from __future__ import annotations

import numpy as np

from bipedlab.robots.mabel.walking import constraints as vcm
from bipedlab.robots.mabel.walking import design as md
from bipedlab.robots.mabel import tables as tb
from bipedlab.robots.mabel.walking import stance as wk
from bipedlab.viz import figures

PHASE_NAMES = ("mc", "sc", "si", "sd")


def gait_figures(out, m, design: md.Design, prefix: str = "") -> list[str]:
    """Virtual constraints and configuration (Fig. 5), leg shape and B_spring (Fig. 6), torques
    (Fig. 7), swing-toe height and COM height (Fig. 8), power at the stance leg shape from the
    motor and from motor plus spring (Fig. 9), over one designed step; and an NPZ of the orbit."""
    import jax
    import jax.numpy as jnp

    out = figures.output_dir(out)
    th, w, u, z, ph, bounds = md.orbit(m, design)
    t = w[:, 3]
    qs, qds = z[:, :6], z[:, 6:]
    paths = []
    edges = t[np.nonzero(np.diff(ph))[0] + 1]

    def marks(ax):
        for e in edges:
            ax.axvline(e, color="0.8", lw=0.8)

    fig, axs = figures.subplots(2, 3, figsize=(11, 6))
    names = ["q_LA_st (deg)", "q_mLS_st (deg, motor)", "q_Bsp_st (deg)", "q_LA_sw (deg)", "q_mLS_sw (deg, motor)", "q_Tor (deg)"]
    for k, ax in enumerate(axs.ravel()):
        ax.plot(t, np.degrees(qs[:, k]))
        ax.set_title(names[k], fontsize=9)
        marks(ax)
    axs[1, 0].set_xlabel("time (s)")
    figures.save(fig, out / f"{prefix}gait_constraints.png", paths)

    ls = qs[:, 1] / tb.GEAR_LS + qs[:, 2] / tb.GEAR_BSP
    fig, axs = figures.subplots(1, 2, figsize=(9, 3.5))
    axs[0].plot(t, np.degrees(ls))
    axs[0].set_title("stance leg shape q_LS (deg)", fontsize=9)
    axs[1].plot(t, np.degrees(qs[:, 2]))
    axs[1].axhline(5.0, color="0.6", ls=":")
    axs[1].set_title("stance B_spring (deg); 5 deg trigger dotted", fontsize=9)
    for ax in axs:
        marks(ax)
        ax.set_xlabel("time (s)")
    figures.save(fig, out / f"{prefix}gait_spring.png", paths)

    fig, ax = figures.subplots(figsize=(6, 3.5))
    for k, n in enumerate(tb.ACTUATORS):
        ax.plot(t, u[:, k], label=n.replace("_L", " st").replace("_R", " sw"))
    marks(ax)
    _capacities(ax)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("motor torque (N m)")
    ax.legend(fontsize=8)
    figures.save(fig, out / f"{prefix}gait_torques.png", paths)

    toe = np.asarray(jax.vmap(lambda zz: wk.swing_toe(m, zz)[1])(jnp.asarray(z)))
    com = np.asarray(jax.vmap(lambda zz: _com_height(m, zz))(jnp.asarray(z)))
    fig, axs = figures.subplots(1, 2, figsize=(9, 3.5))
    axs[0].plot(t, toe)
    axs[0].set_title("swing toe height (m)", fontsize=9)
    axs[1].plot(t, com)
    axs[1].set_title("COM height (m)", fontsize=9)
    for ax in axs:
        marks(ax)
        ax.set_xlabel("time (s)")
    figures.save(fig, out / f"{prefix}gait_toe_com.png", paths)

    p_motor = u[:, 1] * qds[:, 1]
    p_spring = np.asarray(wk.spring_torque(m, jnp.asarray(qs[:, 2]), jnp.asarray(qds[:, 2]), 0)) * qds[:, 2]
    fig, ax = figures.subplots(figsize=(6, 3.5))
    ax.plot(t, p_motor + p_spring, lw=2.0, label="motor + spring (total at the leg shape)")
    ax.plot(t, p_motor, lw=1.0, label="motor")
    marks(ax)
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("power (W)")
    ax.legend(fontsize=8)
    figures.save(fig, out / f"{prefix}gait_power.png", paths)

    np.savez(out / f"{prefix}gait_orbit.npz", t=t, theta=th, q_s=qs, qd_s=qds, u=u, phase=ph, bounds=bounds)
    paths.append(str(out / f"{prefix}gait_orbit.npz"))
    return paths


#: Exp. 2 (HZD paper Sec. V-B, Fig. 16): a forward push speeds the robot up by roughly 45 % and
#: the speed converges back over the next ten steps; a backward push slows it by roughly 45 %,
#: back within three steps. (relative change, steps to recover) by the push's sign.
PAPER_PUSH = {1: (0.45, 10), -1: (-0.45, 3)}


def _paper_push_marks(ax, sp, push_step: int, force: float):
    """The paper's Fig. 16 beside a pushed walk: the speed before the push (dotted), the
    paper's roughly +-45 % change from it (dashed) and the step by which the paper's robot was
    back to nominal (dash-dotted)."""
    before = [v for v in sp[:push_step] if v is not None and np.isfinite(v)]
    if not before or force == 0:
        return
    base = float(np.mean(before[-3:]))
    change, recover = PAPER_PUSH[1 if force > 0 else -1]
    ax.axhline(base, color="0.5", ls=":", lw=1, label=f"before the push {base:.3f} m/s")
    ax.axhline(base * (1 + change), color="k", ls="--", lw=1, label=f"paper Fig. 16: {change:+.0%} from nominal")
    ax.axvline(push_step + 1 + recover, color="k", ls="-.", lw=1, label=f"paper: back to nominal within {recover} steps")


def _capacities(ax):
    """The paper's peak torque capacities (Sec. III: 30 N m at u_mLA, 55 N m at u_mLS) as dashed
    lines at +- each, labelled; the axis keeps the data's own range when it lies well inside."""
    lo, hi = ax.get_ylim()
    for name, cap in tb.TORQUE_CAPACITY.items():
        ls = "--" if name == "mLS" else "-."
        for sgn in (-1.0, 1.0):
            ax.axhline(sgn * cap, color="k", ls=ls, lw=0.8, label=f"paper: {name} capacity +-{cap:g} N m" if sgn > 0 else None)
    ax.set_ylim(min(lo, -1.05 * max(tb.TORQUE_CAPACITY.values())), max(hi, 1.05 * max(tb.TORQUE_CAPACITY.values())))


def _com_height(m, z):
    from bipedlab.robots.mabel.dynamics import com_position

    return com_position(m, wk.embed(m, z)[0])[1]


def walk_figures(out, log: dict, r: dict) -> list[str]:
    """Tracking of the virtual constraints (desired vs actual error, Fig. 12), motor torques
    (Fig. 13), speed per step (Fig. 16), stance B_spring and torso over the run (Figs. 14, 20),
    and an NPZ of the logs."""
    out = figures.output_dir(out)
    paths = []
    t = np.arange(len(log["theta"])) * 1e-3
    n = min(len(t), 3000)
    sl = slice(max(0, len(t) - n), len(t))

    fig, axs = figures.subplots(2, 2, figsize=(10, 6))
    for k, ax in enumerate(axs.ravel()):
        ax.plot(t[sl], np.degrees(log["y"][sl, k]))
        ax.set_title(f"tracking error y, {vcm.OUTPUTS[k]} (deg)", fontsize=9)
        ax.set_xlabel("time (s)")
    figures.save(fig, out / "walk_tracking.png", paths)

    fig, ax = figures.subplots(figsize=(7, 3.5))
    for k, name in enumerate(("mLA st", "mLS st", "mLA sw", "mLS sw")):
        ax.plot(t[sl], log["u"][sl, k], label=name, lw=0.8)
    _capacities(ax)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("motor torque (N m)")
    ax.legend(fontsize=8)
    figures.save(fig, out / "walk_torques.png", paths)

    sp = r.get("speed_per_step") or []
    fig, ax = figures.subplots(figsize=(7, 3.5))
    ax.plot(np.arange(1, len(sp) + 1), sp, "o-", ms=3)
    if r.get("push_step") is not None:
        ax.axvline(r["push_step"] + 1, color="r", lw=2, label=f"push {r['push_force_n']:+.0f} N")
        _paper_push_marks(ax, sp, int(r["push_step"]), float(r["push_force_n"]))
        ax.legend(fontsize=8)
    ax.set_xlabel("step")
    ax.set_ylabel("speed (m/s)")
    figures.save(fig, out / "walk_speed.png", paths)

    fig, axs = figures.subplots(1, 2, figsize=(10, 3.5))
    axs[0].plot(t[sl], np.degrees(log["z"][sl, 2]))
    axs[0].set_title("stance B_spring (deg)", fontsize=9)
    axs[1].plot(t[sl], np.degrees(log["z"][sl, 5]))
    axs[1].set_title("torso (deg)", fontsize=9)
    for ax in axs:
        ax.set_xlabel("time (s)")
    figures.save(fig, out / "walk_spring_torso.png", paths)

    paths += walk_animation(out / "walk.html", log, r.get("step_lengths_m") or [])
    np.savez(out / "walk_log.npz", **{k: np.asarray(v) for k, v in log.items()})
    paths.append(str(out / "walk_log.npz"))
    return paths


#: drawing points of the stick figure and the segments between them (torso, stance leg, swing leg)
DRAW_POINTS = ("hip", "head", "knee_L", "toe_L", "knee_R", "toe_R")
DRAW_SEGMENTS = ((0, 1), (0, 2), (2, 3), (0, 4), (4, 5))


def walk_animation(path, log: dict, step_lengths, seconds: float = 6.0, fps: float = 40.0) -> list[str]:
    """The first ``seconds`` of a logged walk (1 kHz samples of the stance state z) as an offline
    HTML animation; each step's stance toe is placed at the sum of the earlier step lengths."""
    import jax
    import jax.numpy as jnp

    from bipedlab.mechanics import coupled as cp
    from bipedlab.viz import animation

    m = wk.walking_model()
    z = np.asarray(log["z"])
    t = np.arange(len(z)) * 1e-3
    keep = np.nonzero(t <= seconds)[0][:: max(1, int(round(1.0 / (fps * 1e-3))))]
    if keep.size < 2:
        return []
    pts = jax.jit(jax.vmap(lambda zz: jnp.stack([cp.point_position(m.body, wk.embed(m, zz)[0], n)
                                                 for n in DRAW_POINTS])))(jnp.asarray(z[keep]))
    pts = np.array(pts)  # a writable copy
    offsets = np.concatenate([[0.0], np.cumsum(np.asarray(step_lengths, float))])
    step = np.clip(np.asarray(log["step"])[keep].astype(int), 0, len(offsets) - 1)
    pts[:, :, 0] += offsets[step][:, None]
    frames = np.stack([np.stack([pts[:, a], pts[:, b]], axis=1) for a, b in DRAW_SEGMENTS], axis=1)
    return animation.write(path, frames, t[keep], ground=0.0, colors=["#444444", "#1f77b4", "#1f77b4", "#d62728", "#d62728"],
                           widths=[5.0, 2.5, 2.5, 2.5, 2.5], follow=True, title="MABEL walking")


def pd_gain_figure(out, rec: dict) -> str:
    """``experiment mabel pd-gains``: dominant |eigenvalue| of the PD + feedforward map (eq. 44)
    against the common factor on kd, one line per factor on kp, one panel per gait; the paper's
    value (Sec. IV-A) and the unit circle as horizontal lines, the studies' gains circled."""
    out = figures.output_dir(out)
    grid = rec["gains_grid"]
    gaits = list(grid["points"])
    fig, axs = figures.subplots(1, len(gaits), figsize=(5.2 * len(gaits), 4.0), squeeze=False)
    for ax, gait in zip(axs[0], gaits):
        rows = grid["points"][gait]
        for a in grid["kp_scales"]:
            pts = [(x["kd_scale"], x["dominant_eigenvalue"]["abs"]) for x in rows
                   if x["kp_scale"] == a and x["dominant_eigenvalue"] is not None and x["kd_scale"] in grid["kd_scales"]]
            if pts:
                b, v = np.asarray(sorted(pts)).T
                ax.plot(b, v, "o-", ms=4, label=f"kp x {a:g}")
        ax.axhline(rec["paper"][gait], color="k", ls="--", lw=1, label=f"paper {rec['paper'][gait]:.4f}")
        ax.axhline(1.0, color="r", ls=":", lw=1, label="|eig| = 1")
        own = rec["studies_gains"][gait]["dominant_eigenvalue"]
        if own is not None:
            ax.plot([1.0], [own["abs"]], "ks", ms=9, mfc="none", label="studies' gains")
        ax.set_xscale("log")
        ax.set_xticks(grid["kd_scales"])
        ax.set_xticklabels([f"{b:g}" for b in grid["kd_scales"]])
        ax.minorticks_off()
        ax.set_xlabel("factor on the shipped kd")
        ax.set_ylabel("dominant |eigenvalue|")
        top = max([x["dominant_eigenvalue"]["abs"] for x in rows if x["dominant_eigenvalue"] is not None] + [1.2])
        ax.set_ylim(0.0, min(3.0, 1.05 * top))
        ax.set_title(f"{gait} gait: PD + feedforward, full map (eq. 44)", fontsize=9)
        ax.legend(fontsize=7)
    return figures.save(fig, out / "pd_gains_eigenvalues.png")
