"""Figures of the running study (like the running paper's Figs. 5, 7 and 8), through
:mod:`bipedlab.viz.figures`. No stick-figure frames yet: a ``segments`` function over the
robot's trunk and leg points (robot.py) would feed :mod:`bipedlab.viz.animation` with the
terrain as its ground polyline."""
from __future__ import annotations

import os

import numpy as np

from bipedlab.viz import figures


def write_all(out_dir, out, sr, cp, gait, paper_sd=None) -> list:
    """Write the figures available from a study output; returns the file paths. paper_sd: the
    paper's s.d. to mark on the apex figure (see :func:`apex_figure`)."""
    files = [apex_figure(os.path.join(out_dir, "apex.png"), out, sr, gait, paper_sd)]
    if "log" in out:
        files.append(time_figure(os.path.join(out_dir, "gait_time_series.png"), out["log"], cp))
        files.append(grf_figure(os.path.join(out_dir, "grf_first_stance.png"), out["log"]))
    return files


def _paper_band(ax, target, sd, label):
    if sd is not None:
        ax.axhspan(target - sd, target + sd, color="0.5", alpha=0.18, lw=0, label=label)


def apex_figure(path, out, sr, gait, paper_sd=None):
    """Fig. 8: bounce heights and apex speeds of the robot and of the spring-mass model, with
    the target (dashed) and, where the paper gives them (``paper_sd``: ((robot height s.d.,
    speed s.d.), (model height s.d., speed s.d.) or None), Sec. IV-B), the band target +- the
    paper's s.d. (grey) beside this run's s.d. in the titles."""
    fig, ax = figures.subplots(2, 2, figsize=(10, 6), sharex="col")
    k = int(min(out["n_apex"][0], len(out["bounce"][0])))
    x = out["apex_x"][0, :k]
    ax[0, 0].plot(x, out["apex_y"][0, :k], "k-", lw=1, label="global apex height")
    ax[0, 0].plot(x, out["bounce"][0, :k], "o", color="tab:cyan", ms=4, label="bounce height")
    ax[0, 0].axhline(gait.y_apex, ls="--", color="g")
    ax[1, 0].plot(x, out["speed"][0, :k], "o", color="tab:cyan", ms=4)
    ax[1, 0].axhline(gait.speed, ls="--", color="g")
    robot_sd, smm_sd = paper_sd if paper_sd is not None else (None, None)
    for col, sd in ((0, robot_sd), (1, smm_sd)):
        for row in (0, 1):
            _paper_band(ax[row, col], (gait.y_apex, gait.speed)[row], None if sd is None else sd[row],
                        "paper: target \u00b1 its s.d. (Sec. IV-B)")
    ax[0, 0].set_title(f"robot model (trial 0): s.d. {100 * np.std(out['bounce'][0, :k]):.1f} cm, "
                       f"{100 * np.std(out['speed'][0, :k]):.1f} cm/s"
                       + (f" (paper {100 * robot_sd[0]:.1f} cm, {100 * robot_sd[1]:.1f} cm/s)" if robot_sd else ""),
                       fontsize=9)
    n = int(sr.steps_done[0])
    ax[0, 1].plot(sr.x[0, :n], sr.apex_y[0, :n], "k-", lw=1)
    ax[0, 1].plot(sr.x[0, :n], sr.bounce[0, :n], "o", color="tab:blue", ms=4)
    ax[0, 1].axhline(gait.y_apex, ls="--", color="g")
    ax[1, 1].plot(sr.x[0, :n], sr.speed[0, :n], "o", color="tab:blue", ms=4)
    ax[1, 1].axhline(gait.speed, ls="--", color="g")
    ax[0, 1].set_title("spring-mass model, same terrain"
                       + (f" (paper s.d. {100 * smm_sd[0]:.1f} cm, {100 * smm_sd[1]:.1f} cm/s)" if smm_sd else ""),
                       fontsize=9)
    ax[0, 0].set_ylabel("apex height (m)")
    ax[1, 0].set_ylabel("apex speed (m/s)")
    ax[1, 0].set_xlabel("x (m)")
    ax[1, 1].set_xlabel("x (m)")
    ax[0, 0].legend(fontsize=8)
    figures.save(fig, path)
    return path


def time_figure(path, log, cp, t_max=2.0):
    """Fig. 7: apex height, speed, trunk pitch, landing angle, mean hip angle, momentum,
    hip torques over the first seconds; stance shaded."""
    t = log["t"][0]
    sel = t <= t_max
    t = t[sel]
    q, qd = log["q"][0][sel], log["qd"][0][sel]
    mode, leg = log["mode"][0][sel], log["leg"][0][sel]
    fig, ax = figures.subplots(6, 1, figsize=(9, 12), sharex=True)
    ax[0].plot(t, q[:, 1], "k")
    ax[0].set_ylabel("trunk y (m)")
    ax[1].plot(t, qd[:, 0], "k")
    ax[1].set_ylabel("x' (m/s)")
    ax[2].plot(t, np.rad2deg(q[:, 2]), "k")
    ax[2].axhline(np.rad2deg(cp.theta_star), ls="--", color="g")
    ax[2].set_ylabel("pitch (deg)")
    # landing leg angle from the horizontal (virtual leg) and its target
    i = leg
    g = np.where(i == 0, q[:, 3], q[:, 4])
    l = np.where(i == 0, q[:, 5], q[:, 6])
    d = cp.mp.d
    fx = -d * np.sin(q[:, 2]) + l * np.sin(g)
    fy = -d * np.cos(q[:, 2]) + l * np.cos(g)
    ax[3].plot(t, np.rad2deg(np.arctan2(-fy, fx)), "k", label="alpha")
    ax[3].plot(t, np.where(mode == 0, np.rad2deg(log["alpha"][0][sel]), np.nan), "g--", label="alpha*(t), flight")
    ax[3].set_ylabel("landing angle (deg)")
    ax[3].legend(fontsize=8)
    ax[4].plot(t, log["H"][0][sel], "k")
    ax[4].set_ylabel("H = I_t th' + I_m (g1' + g2')")
    u = log["u"][0][sel]
    ax[5].plot(t, u[:, 0], label="tau1")
    ax[5].plot(t, u[:, 1], label="tau2")
    ax[5].set_ylabel("hip torque (N m)")
    ax[5].legend(fontsize=8)
    ax[5].set_xlabel("t (s)")
    for a in ax:
        _shade(a, t, mode)
    figures.save(fig, path)
    return path


def _shade(ax, t, mode):
    colors = {1: (1.0, 0.8, 0.8), 2: (0.85, 0.85, 0.85)}
    start = 0
    for k in range(1, len(t) + 1):
        if k == len(t) or mode[k] != mode[start]:
            if mode[start] in colors:
                ax.axvspan(t[start], t[k - 1], color=colors[int(mode[start])], lw=0)
            start = k


def grf_figure(path, log):
    """Fig. 5: simulated GRFs of the first stance."""
    t = log["t"][0]
    grf = log["grf"][0]
    on = np.nonzero(grf[:, :, 1].sum(axis=1) > 0)[0]
    fig, ax = figures.subplots(2, 1, figsize=(7, 5), sharex=True)
    if on.size:
        k0 = on[0]
        k1 = k0 + np.argmax(grf[k0:, :, 1].sum(axis=1) == 0) if np.any(grf[k0:, :, 1].sum(axis=1) == 0) else len(t)
        sl = slice(max(k0 - 5, 0), k1 + 5)
        ax[0].plot(t[sl], grf[sl, :, 1].sum(axis=1), "k--")
        ax[1].plot(t[sl], grf[sl, :, 0].sum(axis=1), "k--")
        _shade(ax[0], t[sl], log["mode"][0][sl])
        _shade(ax[1], t[sl], log["mode"][0][sl])
    ax[0].set_ylabel("F_y (N)")
    ax[1].set_ylabel("F_x (N)")
    ax[1].set_xlabel("t (s)")
    figures.save(fig, path)
    return path
