"""Figures of MABEL's identification study, after the identification paper's Figs. 13, 15-17,
19, 21 and 23: simulated against measured responses of the identified models. Figures go
through :mod:`bipedlab.viz.figures`."""
from __future__ import annotations

import numpy as np

from bipedlab.robots.mabel import tables as tb
from bipedlab.robots.mabel.sysid import friction, hopping_fit, rigs
from bipedlab.robots.mabel.sysid import params as P
from bipedlab.robots.mabel.sysid.logs import motor_encoder
from bipedlab.robots.mabel.sysid.transmission import simulate_first_order
from bipedlab.viz import figures

SIM = dict(color="tab:red", lw=1.2, label="simulation")
EXP = dict(color="tab:blue", lw=1.0, ls=":", label="experiment")
#: the paper's values drawn beside the fits (Fig. 19's spring lines)
PAPER = P.published()
#: Fig. 17: "All center of mass horizontal distances stay within 6mm."
PAPER_COM_MM = 6.0


def _transmission(ident, out, paths):
    tr = ident.fits.get("transmission")
    if not tr:
        return
    fig, axes = figures.subplots(2, 2, figsize=(10, 6))
    for ax, a in zip(axes[0], ("mLA_L", "mLS_L")):
        if a not in tr:
            continue
        e, f = tr[a][0]
        b = ident.details.get("bias_arx", {}).get(a, {}).get("bias_nm", float(ident.params.bias[P.actuator_index(a)]))
        u = e.u[a] + b
        theta = e.enc[motor_encoder(a)]
        sim = simulate_first_order(f, u, theta[0])
        n = min(len(u), 8000)
        block = 10
        t = e.t[:n:block][:-1]
        ax.plot(t, np.diff(theta[:n:block]) / (block * 1e-3), **EXP)
        ax.plot(t, np.diff(sim[:n:block]) / (block * 1e-3), **SIM)
        ax.set(title=f"{a}, 1 pulley: motor speed (Fig. 13)", xlabel="time (s)", ylabel="rad/s")
        ax.legend(fontsize=8)
    ax = axes[1, 0]
    for a, rows in tr.items():
        J = [f.J_exp for _, f in rows]
        cad = [float(e.meta.get("cad_inertia", P.combination_inertia(a)[int(e.meta["combination"]) - 1]))
               for e, _ in rows]
        k = P.actuator_index(a)
        line = ax.plot(np.array(cad) * 1e4, np.array(J) * 1e4, "o", label=a)[0]
        x = np.linspace(0, max(cad) * 1.1, 10)
        ax.plot(x * 1e4, ident.params.kt[k] * (ident.params.alpha[k] * P.rotor_inertia_manufacturer(a) + x) * 1e4,
                color=line.get_color(), lw=0.8)
    ax.set(title="eq. 11: J_exp = K_T (alpha J_man + J_CAD)", xlabel="J_CAD (1e-4 kg m^2)", ylabel="J_exp (1e-4)")
    ax.legend(fontsize=8)
    ax = axes[1, 1]
    for a, rows in tr.items():
        ax.plot([int(e.meta["combination"]) for e, _ in rows], [f.mu_exp * 1e3 for _, f in rows], "o-", label=a)
    ax.set(title="lumped friction per combination", xlabel="combination", ylabel="mu_exp (mN m s/rad)")
    ax.legend(fontsize=8)
    figures.save(fig, out / "identify_transmission.png", paths)


def _legs(ident, out, paths, mode: str, fig_no: int):
    legs = ident.fits.get("legs")
    if not legs:
        return
    rows = [(s, e) for s, (_, exps) in legs.items() for e in exps if e.meta.get("mode") == mode]
    if not rows:
        return
    fig, axes = figures.subplots(len(rows), 2, figsize=(11, 2.4 * len(rows)), squeeze=False)
    for (s, e), ax_row in zip(rows, axes):
        rig = rigs.leg_rig(ident.params, s)
        Y = np.stack([e.enc[motor_encoder(a)] for a in rigs.LEG_ACTUATORS[s]], axis=1)
        Ys = friction.simulate(rig, e)
        for j, (ax, name, gear) in enumerate(zip(ax_row, ("q_LA", "q_LS"), (tb.GEAR_LA, tb.GEAR_LS))):
            ax.plot(e.t, np.rad2deg(Y[:, j] / gear), **EXP)
            ax.plot(e.t, np.rad2deg(Ys[:, j] / gear), **SIM)
            ax.set(title=f"{e.name}: {name} (deg)", xlabel="time (s)")
        ax_row[0].legend(fontsize=8)
    fig.suptitle(f"{mode.upper()} leg experiments (Fig. {fig_no})")
    figures.save(fig, out / f"identify_legs_{mode}.png", paths)


def _springs(ident, out, paths):
    sp = ident.fits.get("springs")
    if not sp:
        return
    fig, ax = figures.subplots(figsize=(6, 4))
    for s, f in sp.items():
        pts = ax.plot(f.deflection, f.torque, "o", label=f"{s}: K_B {f.stiffness:.1f} N m/rad, tau_0 {f.preload:.2f} N m")[0]
        x = np.linspace(0.0, f.deflection.max() * 1.05, 10)
        ax.plot(x, f.stiffness * x + f.preload, color=pts.get_color(), lw=0.8)
        k = P.SIDES.index(s) if s in P.SIDES else None
        if k is not None:  # the paper's Fig. 19 line for this leg
            ax.plot(x, PAPER.spring_k[k] * x + PAPER.spring_preload[k], color=pts.get_color(), lw=1.0, ls="--",
                    label=f"{s}, paper Fig. 19: {PAPER.spring_k[k]:.1f} q + {PAPER.spring_preload[k]:.3f}")
    ax.set(title="spring torque against deflection (Fig. 19; dashed: the paper's fits)", xlabel="q_Bsp (rad)",
           ylabel="tau_Bsp (N m)")
    ax.legend(fontsize=8)
    figures.save(fig, out / "identify_springs.png", paths)


def _com(ident, out, paths):
    cc = ident.fits.get("com_check")
    if not cc:
        return
    fig, axes = figures.subplots(1, len(cc.distance_mm), figsize=(5 * len(cc.distance_mm), 3.5), squeeze=False)
    for ax, (name, d) in zip(axes[0], cc.distance_mm.items()):
        ax.bar(np.arange(1, len(d) + 1), d)
        ax.axhline(0.0, color="k", lw=0.5)
        for sgn in (-1.0, 1.0):  # the paper: every distance within 6 mm
            ax.axhline(sgn * PAPER_COM_MM, color="k", ls="--", lw=0.8,
                       label=f"paper Fig. 17: within {PAPER_COM_MM:g} mm" if sgn > 0 else None)
        ax.legend(fontsize=8)
        ax.set(title=f"{name}: COM - {cc.support[name]} (Fig. 17)", xlabel="posture", ylabel="mm")
    figures.save(fig, out / "identify_com.png", paths)


def _hopping(ident, out, paths):
    if "hopping" not in ident.fits:
        return
    e, hf = ident.fits["hopping"]
    k0 = hopping_fit.release_index(e)
    t = e.t[k0:] - e.t[k0]
    q = hopping_fit.measured_coordinates(e)[k0:]
    qs = hopping_fit.replay_log(e, ident.params)
    H = hopping_fit.INDEX
    names = ("tor", "la_L", "ls_L", "la_R", "ls_R", "bsp_L", "bsp_R", "y")
    fig, axes = figures.subplots(4, 2, figsize=(11, 9))
    for ax, c in zip(axes.ravel(), names):
        f = 1.0 if c == "y" else np.rad2deg(1.0)
        ax.plot(t, q[:, H[c]] * f, **EXP)
        ax.plot(t, qs[:, H[c]] * f, **SIM)
        ax.set(title=("hip height (m)" if c == "y" else f"{c} (deg)"), xlabel="time (s)")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle("hopping: the identified 13-DoF model replayed under the logged commands (Fig. 21)")
    figures.save(fig, out / "identify_hop_joints.png", paths)
    fig, axes = figures.subplots(2, 2, figsize=(10, 6))
    for ax, a in zip(axes.ravel(), P.ACTUATORS):
        _, r, _, qm = hopping_fit.cable_inputs(e, a)
        sim = hopping_fit.simulate_cable(e, ident.params, a)
        ax.plot(t, np.rad2deg(qm - r), **EXP)
        ax.plot(t, np.rad2deg(sim - r), **SIM)
        ax.set(title=f"cable stretch {a} (deg, motor side)", xlabel="time (s)")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle("cable stretch (Fig. 23)")
    figures.save(fig, out / "identify_hop_cable.png", paths)


def write_figures(ident, out, say=None) -> list[str]:
    """Every figure the identification has data for; returns the written paths. ``say`` (a
    one-argument callable) is told, one line each, which figures were not drawn and why."""
    out = figures.output_dir(out)
    paths: list[str] = []
    for what, draw in (("transmission (Fig. 13)", _transmission),
                       ("SISO leg validation (Fig. 15)", lambda i, o, p: _legs(i, o, p, "siso", 15)),
                       ("MIMO leg validation (Fig. 16)", lambda i, o, p: _legs(i, o, p, "mimo", 16)),
                       ("springs (Fig. 19)", _springs), ("centre of mass (Fig. 17)", _com),
                       ("hopping (Figs. 21, 23)", _hopping)):
        before = len(paths)
        draw(ident, out, paths)
        if len(paths) == before and say is not None:
            say(f"no {what} figure: the logs hold no experiment of that kind")
    return paths
