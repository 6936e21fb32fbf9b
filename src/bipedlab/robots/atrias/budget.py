"""Step-by-step budget of a logged run: where a step's apex error arises (running paper,
Sec. III-E and IV-A).

For each step from apex to apex, :func:`step_budget` records the translational energy of the
whole robot's COM (trunk and feet, the quantity that is ballistic in flight) against the gait's
target M (g y* + v*^2 / 2) at the apex, at touchdown, at the end of the sliding transition
(plus the virtual spring's energy about the stance point), at lift-off and at the next apex;
the landing angle the policy commanded against the one realised (the controller's virtual leg,
trunk COM to foot); the distance the foot slid forward before the controller switched to
stance; and two spring-mass replays of the step with the controller's own model (mass m,
stiffness k0, the stance's rest length): from the touchdown state about the touchdown foot
point, from the same state about the stance point (the foot's x where it stopped sliding, its
height at touchdown), and from the state at the end of the slide about the stance point. If
the stance realises the spring-mass model, the last replay lands on the robot's next apex; the
first is the apex the step would reach had the foot not slid, the second the effect of the
slide's geometry alone.

Measured on flat ground with the paper's controller (``run atrias --controller paper``, 8 s,
means over the last six steps; the whole study in the controller's module docstring):
energy -1.9 J at the apex, -3.5 J at touchdown (the landing foot's 0.2 kg at 4.0 m/s), -4.3 J
at the end of the slide, -1.8 J at lift-off, -1.9 J at the next apex (the lift-off state holds
the next apex's energy to 0.1 J); landing angle 74.33 deg for 74.51 deg commanded; the foot slid
2.3 cm forward in 12 ms; replay from touchdown 1.055 m and 4.99 m/s, from the end of the slide
1.084 m and 4.94 m/s, the robot 1.082 m and 4.93 m/s.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.control import slip
from bipedlab.robots.atrias import controller as rc
from bipedlab.robots.atrias import loop as ar
from bipedlab.robots.atrias import robot as at


def _com_and_feet(rp, q, qd):
    """Whole-robot COM, its velocity, the feet and their velocities at every sample (the
    robot's parameters are static: the tree model is built from their values)."""
    def one(a, b):
        com, vcom = ar.system_com(rp, a, b)
        feet = jnp.stack([at.foot(rp, a, 0), at.foot(rp, a, 1)])
        vfeet = jnp.stack([at.foot_jac(rp, a, 0) @ b, at.foot_jac(rp, a, 1) @ b])
        return com, vcom, feet, vfeet
    return jax.jit(jax.vmap(one))(q, qd)


def smm_apex(smm: slip.SlipParams, rel_state, ground_y: float):
    """Apex (height above y = 0, forward speed) the spring-mass model ``smm`` reaches from the
    stance state ``rel_state`` = (x, y, x', y') relative to its foot point at height
    ``ground_y``."""
    s_lo, _, _ = slip.stance(smm, jnp.asarray(rel_state, float))
    s_lo = np.asarray(s_lo)
    return float(s_lo[1] + max(s_lo[3], 0.0) ** 2 / (2 * smm.g) + ground_y), float(s_lo[2])


def step_budget(log: dict, rp: at.AtriasParams, cp: rc.CtrlParams, gait) -> list[dict]:
    """One record per complete step of one trial's log (``simulate(..., log=True)["log"]``
    with the trial axis removed): energies relative to the target (J), landing angles (deg),
    slide (m, s), the two spring-mass replays and the next apex (m, m/s). Sample k of the log
    holds the state after sample k; the controller's switch at sample k acted on the state
    after sample k - 1, which is the state recorded for the switch."""
    q, qd, mode, leg = (np.asarray(log[k]) for k in ("q", "qd", "mode", "leg"))
    com, vcom, feet, vfeet = (np.asarray(a) for a in _com_and_feet(rp, jnp.asarray(q), jnp.asarray(qd)))
    M, g = rp.m + 2 * rp.m_f, rp.g
    e_star = M * (g * gait.y_apex + 0.5 * gait.speed ** 2)
    energy = 0.5 * M * np.sum(vcom ** 2, axis=1) + M * g * com[:, 1] - e_star
    touchdown = np.nonzero((mode[1:] != rc.FLIGHT) & (mode[:-1] == rc.FLIGHT))[0] + 1
    to_stance = np.nonzero((mode[1:] == rc.STANCE) & (mode[:-1] == rc.SLIDING))[0] + 1
    lift_off = np.nonzero((mode[1:] == rc.FLIGHT) & (mode[:-1] != rc.FLIGHT))[0] + 1
    apex = np.nonzero((vcom[1:, 1] <= 0) & (vcom[:-1, 1] > 0))[0] + 1
    k0, l0, m = float(cp.smm.k0), float(cp.smm.l0), float(cp.smm.m)
    rows = []
    for t0 in touchdown:
        before = apex[apex < t0]
        after = [a[a > t0] for a in (to_stance, lift_off, apex)]
        if not before.size or not all(a.size for a in after):
            continue
        a0, (e1, l1, a1) = before[-1], (int(a[0]) for a in after)
        if not (e1 < l1 < a1):
            continue
        i, td, se = int(leg[t0]), t0 - 1, e1 - 1
        foot_td = feet[td, i]
        r_td = q[td, :2] - foot_td
        l_rest = float(np.clip(np.linalg.norm(r_td), cp.l_rest_min * l0, l0))
        smm = slip.SlipParams(m=m, k0=k0, l0=l_rest, g=g)
        point = np.array([feet[se, i][0], foot_td[1]])
        r_se = q[se, :2] - point
        spring = 0.5 * k0 * max(l_rest - float(np.linalg.norm(r_se)), 0.0) ** 2
        rows.append(dict(
            e_apex=energy[a0], e_touchdown=energy[td], e_slide_end=energy[se] + spring, e_lift_off=energy[l1 - 1],
            e_next=energy[a1],
            alpha_cmd_deg=float(np.rad2deg(slip.policy_angle(cp.policy, (td - a0) * ar.CONTROL_DT))),
            alpha_real_deg=float(np.rad2deg(np.arctan2(r_td[1], -r_td[0]))),
            foot_speed_touchdown=float(vfeet[td - 1, i][0]),
            slide_m=float(feet[se, i][0] - foot_td[0]), slide_s=(e1 - t0) * ar.CONTROL_DT,
            smm_touchdown=smm_apex(smm, np.concatenate([r_td, qd[td, :2]]), float(foot_td[1])),
            smm_slide_end=smm_apex(smm, np.concatenate([r_se, qd[se, :2]]), float(foot_td[1])),
            smm_touchdown_slid=smm_apex(smm, np.concatenate([q[td, :2] - point, qd[td, :2]]), float(foot_td[1])),
            next_apex=(float(com[a1, 1]), float(vcom[a1, 0]))))
    return rows


def mean_budget(rows: list[dict], last: int = 6) -> dict:
    """The mean of each entry over the last ``last`` steps (pairs element by element)."""
    tail = rows[-last:]
    return {k: tuple(np.mean([r[k] for r in tail], axis=0)) if isinstance(tail[0][k], tuple)
            else float(np.mean([r[k] for r in tail])) for k in tail[0]}
