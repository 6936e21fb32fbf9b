"""Fig. 20 of the compliant-HZD paper on the 13-DoF plant: the stance B_spring and the torso
over each step, left and right leg in stance apart, against the stance model's fixed point with
the impact scaling eta = 0.966 that made the paper's simulation walk at the robot's speed."""
from __future__ import annotations

import numpy as np

from bipedlab.robots.mabel.walking import full_plant as fp
from bipedlab.viz import figures

#: the paper's impact scaling for Fig. 20 (Section VI-B, Table I)
FIG20_ETA = 0.966


def _normalised_steps(log, skip: int):
    """[(side, s in [0, 1], B_spring deg, torso deg)] for the completed steps after ``skip``."""
    out = []
    side = np.asarray(log.get("stance", np.zeros(len(log["step"]), int)))
    for a, b in fp.steps_of(log)[skip:]:
        s = np.linspace(0.0, 1.0, b - a)
        z = np.asarray(log["z"])[a:b]
        out.append((int(side[a]), s, np.degrees(z[:, 2]), np.degrees(z[:, 5])))
    return out


def fig20(out, log: dict, reference_log: dict, skip: int = 2) -> list[str]:
    """Stance B_spring and torso per step against normalised step time, one column per stance
    leg, the 13-DoF plant's steps (after the first ``skip``) thin, the reference (the stance
    model at eta = FIG20_ETA, its last step) thick."""
    out = figures.output_dir(out)
    paths: list[str] = []
    ref = _normalised_steps(reference_log, 0)[-1]
    fig, axs = figures.subplots(2, 2, figsize=(10, 6), sharex=True)
    for side, s, b, tor in _normalised_steps(log, skip):
        axs[0, side].plot(s, b, color="#1f77b4", lw=0.6, alpha=0.6)
        axs[1, side].plot(s, tor, color="#1f77b4", lw=0.6, alpha=0.6)
    for col, name in enumerate(("left", "right")):
        axs[0, col].plot(ref[1], ref[2], "k", lw=2, label=f"stance model, fixed point at eta = {FIG20_ETA}")
        axs[1, col].plot(ref[1], ref[3], "k", lw=2)
        axs[0, col].set_title(f"{name} leg in stance: B_spring (deg)", fontsize=9)
        axs[1, col].set_title(f"{name} leg in stance: torso (deg)", fontsize=9)
        axs[1, col].set_xlabel("fraction of the step")
    axs[0, 0].plot([], [], color="#1f77b4", lw=0.6, label="13-DoF plant, each step")
    axs[0, 0].legend(fontsize=8)
    figures.save(fig, out / "walk_fig20_spring_torso.png", paths)
    return paths
