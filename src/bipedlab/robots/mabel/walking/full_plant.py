"""MABEL walking on the 13-DoF model: the design-to-robot gap in simulation (compliant-HZD
paper, Sections V-A, V-C and VI-C).

The gaits are designed, and the walking controllers written, on the stance model of
:mod:`.stance` (rigid cables, a pinned stance toe, the swing spring held at rest, a rigid
impact). Here the same controllers, sampled at 1 kHz on 14-bit encoders, drive the 13-DoF
model of the identification paper instead (:func:`bipedlab.robots.mabel.model.hopping_model`):

- cable stretch in both drives of each leg (eqs. 25-27), so the leg shape and leg angle differ
  from what the motor angles imply;
- the swing leg's spring is free: it deflects during the swing (Fig. 15), with its hard stop;
- both toes meet the compliant ground (Marhefka-Orin normal force, LuGre friction, the
  constants of ``tables.GROUND``): the stance toe may slip, the impact takes a few
  milliseconds, and the old stance toe is not lifted by the model;
- Table V's viscous motor friction and the spring damping Kd_B, as on the stance model.

A push (Exp. 2) acts on the hip as on the stance plant; there a toe force outside the friction
cone makes the toe slip on the ground (LuGre), it is no fall.

The amplifiers are ideal as in the stance plant (K_T = 1, no bias): the gap measured here is
that of the mechanics and the ground, not of the current loop.

Integration: :func:`bipedlab.robots.mabel.dynamics.step` (semi-implicit Euler with the hard
stop's and the ground's stiff dampers implicit) at ``SUBSTEPS`` = 20 steps per 1 ms sample,
the step of the hopping study (:mod:`bipedlab.robots.mabel.hopping.study`).

The controller is the one of :mod:`.loop` unchanged (its model is the stance model). It reads
the six stance coordinates ``(q_LA_st, q_mLS_st, q_Bsp_st, q_LA_sw, q_mLS_sw, q_Tor)`` from the
joint, motor and spring-pulley encoders of whichever leg is in stance, and learns of a
touchdown when the swing toe reaches the ground (a contact switch): the plant then relabels
the legs, as the robot's software does. Its torques ``(mLA_st, mLS_st, mLA_sw, mLS_sw)`` go to
the motors of the corresponding legs.

Falls: as in :mod:`.loop` (hip below ``MIN_HIP_HEIGHT``, torso beyond ``MAX_TORSO_PITCH``, a
step longer than ``MAX_STEP_TIME``), and theta_s running backwards once the step is under way
(``ROLLBACK_AFTER`` of the nominal period, past the few milliseconds of the compliant impact).
"""
from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.pytree import pytree
from bipedlab.robots.mabel import dynamics as md
from bipedlab.robots.mabel import model as mm
from bipedlab.robots.mabel import transmission as tr
from bipedlab.robots.mabel.walking import constraints as vcm
from bipedlab.robots.mabel.walking import loop as sw
from bipedlab.robots.mabel.walking import stance as wk
from bipedlab.sim import loop as sl

SUBSTEPS = 20
#: fraction of the nominal period after a touchdown before theta_s running backwards counts
#: as a fall, and before the swing toe can touch down again
ROLLBACK_AFTER = 0.2
TOUCHDOWN_AFTER = 0.1
#: height (m) the swing toe must first rise to after a touchdown before its next contact with
#: the ground counts as a touchdown: the old stance toe leaves the compliant ground only when
#: the controller lifts it, and a toe still pressed into the ground is no touchdown
LIFT_CLEARANCE = 0.002
_H = {c: i for i, c in enumerate(mm.COORDS_13)}
#: 13-DoF indices of the stance coordinates (q_LA_st, q_mLS_st, q_Bsp_st, q_LA_sw, q_mLS_sw,
#: q_Tor) with the left leg, and with the right leg, in stance
STANCE_INDEX = np.array([[_H[c.replace("_L", "_X").replace("_R", "_L").replace("_X", "_R") if side else c]
                          for c in wk.STANCE] for side in (0, 1)])
#: 13-DoF index of each leg's spring pulley, and of each actuator's motor (tables.ACTUATORS)
SPRING_INDEX = np.array([_H["bsp_L"], _H["bsp_R"]])
MOTOR_INDEX = np.array(mm.MOTOR_INDEX)
#: controller torque order (st, sw) -> actuators (mLA_L, mLS_L, mLA_R, mLS_R), per stance side
_TO_ACTUATORS = np.array([[0, 1, 2, 3], [2, 3, 0, 1]])


@functools.lru_cache(maxsize=32)
def plant_model(scale: tuple = ()) -> mm.Mabel:
    """The 13-DoF model with ideal amplifiers (K_T = 1, no bias), one object per process and
    ``scale`` (pairs (name, factor) of :data:`bipedlab.robots.mabel.model.SCALABLE`)."""
    m = mm.hopping_model(scale=scale)
    d = m.drive
    return m.replace(drive=d.replace(kt=jnp.ones_like(d.kt), bias=jnp.zeros_like(d.bias)))


@pytree
class Plant:
    """The plant's state: the 13-DoF state x = (q_h, qd_h, bristles) (28,), the stance leg
    (0 left, 1 right), time since the last touchdown (s), touchdown count, positive motor work
    (J), distance walked (m, between stance toes), the stance toe's position (x, m) when it
    touched down, and whether the swing toe has risen LIFT_CLEARANCE since then."""

    x: jax.Array
    stance: jax.Array
    t_step: jax.Array
    step: jax.Array
    work_pos: jax.Array
    distance: jax.Array
    toe_x: jax.Array
    lifted: jax.Array


def stance_state(x, stance):
    """(q_s, qd_s) of the stance coordinates for the stance leg ``stance`` (0 L, 1 R)."""
    idx = jnp.asarray(STANCE_INDEX)[stance]
    return x[:13][idx], x[13:26][idx]


def actuator_torques(u, stance):
    """Controller torques (st, sw) in actuator order (mLA_L, mLS_L, mLA_R, mLS_R)."""
    return u[jnp.asarray(_TO_ACTUATORS)[stance]]


def scaled_plant(m: mm.Mabel, setup: sw.Setup) -> mm.Mabel:
    """The plant ``m`` with its ground's stiffness and damping scaled by ``setup.ground``, its
    cables' by ``setup.cable`` and its motors' viscous friction by ``setup.friction`` (data of the
    compiled loop: one program for every scale); ``setup.plant``, where given, is the 13-DoF
    model scaled instead of ``m`` (:func:`plant_model` with other values)."""
    m = sw.plant_of(m, setup)
    g, k, c, d = m.ground, setup.ground, setup.cable, m.drive
    return m.replace(ground=g.replace(stiffness=k * g.stiffness, damping_in=k * g.damping_in,
                                      damping_out=k * g.damping_out),
                     drive=d.replace(cable_k=c * d.cable_k, cable_d=c * d.cable_d,
                                     friction=setup.friction * d.friction))


def sensor(setup: sw.Setup, last_step, p: Plant, t):
    """Encoders of the stance coordinates, the exact rates (``sensing="ideal"``) and the
    touchdown switch."""
    q, qd = stance_state(p.x, p.stance)
    return p.step, sw.Reading(q=sw.measure(setup, q), qd=qd, impacted=p.step != last_step, step=p.step)


def plant_step(m, setup: sw.Setup, p: Plant, u, d, h, t) -> Plant:
    """One step of the 13-DoF model under the held torques; a touchdown of the swing toe
    (once it has risen LIFT_CLEARANCE, ahead of the stance toe, after ``TOUCHDOWN_AFTER`` of
    the nominal period, one per sample) relabels the legs; a swing toe scuffing the ground
    behind the stance toe is dragged by the ground's friction and is no step."""
    m = scaled_plant(m, setup)
    act = jnp.clip(actuator_torques(u, p.stance), -m.drive.torque_limit, m.drive.torque_limit)
    push = jnp.where(p.step != d.step0, 0.0, 1.0) * d.force  # the push stops at a touchdown
    xn = md.step(m, p.x, act, h, push)
    power = act * xn[13:26][jnp.asarray(MOTOR_INDEX)]
    toes = md.toe_positions(m, xn[:13])
    swing = 1 - p.stance
    lifted = p.lifted | (toes[swing, 1] > LIFT_CLEARANCE)
    ahead = toes[swing, 0] > toes[p.stance, 0]
    touched = (lifted & ahead & (toes[swing, 1] <= 0.0) & (p.t_step > TOUCHDOWN_AFTER * setup.period)
               & (p.step == d.step0))
    return Plant(x=xn, stance=jnp.where(touched, swing, p.stance), t_step=jnp.where(touched, 0.0, p.t_step + h),
                 step=p.step + touched, work_pos=p.work_pos + h * jnp.sum(jnp.maximum(power, 0.0)),
                 distance=p.distance + jnp.where(touched, toes[swing, 0] - p.toe_x, 0.0),
                 toe_x=jnp.where(touched, toes[swing, 0], p.toe_x), lifted=lifted & ~touched)


def exogenous(setup: sw.Setup, p: Plant, t) -> sw.Held:
    """The push of Exp. 2 on the hip (as on the stance plant), held over the sample, and the
    touchdown count at the sample's start."""
    return sw.Held(force=sw.hip_force(setup, p), step0=p.step)


def fell(m, setup: sw.Setup, p0: Plant, r, u, p: Plant):
    """Hip below MIN_HIP_HEIGHT, torso beyond MAX_TORSO_PITCH, a step over MAX_STEP_TIME, or
    theta_s running backwards after ROLLBACK_AFTER of the nominal period."""
    q, qd = stance_state(p.x, p.stance)
    back = (vcm.theta_rate(qd) < 0.0) & (p.t_step > ROLLBACK_AFTER * setup.period)
    return ((p.x[_H["y"]] < sw.MIN_HIP_HEIGHT) | (jnp.abs(p.x[_H["tor"]]) > sw.MAX_TORSO_PITCH)
            | (p.t_step > sw.MAX_STEP_TIME) | back)


def cable_stretch(x, stance):
    """Cable stretch of the stance and the swing leg, motor angle minus its rigid-cable value
    (rad, motor side; :func:`bipedlab.robots.mabel.transmission.cable_stretch`), in the order
    of the motors they stretch from: (mLA_st, mLS_st, mLA_sw, mLS_sw)."""
    q = x[:13]

    def leg(side):
        return jnp.stack(tr.cable_stretch(*(q[_H[f"{c}_{side}"]] for c in tr.LOCAL)))

    left, right = leg("L"), leg("R")
    return jnp.where(stance == 0, jnp.concatenate([left, right]), jnp.concatenate([right, left]))


def log(m, setup: sw.Setup, p0: Plant, r, u, p: Plant, c: sw.Ctrl) -> dict:
    """One row per sample, the keys of :func:`.loop.log` (``z`` the exact stance state, ``grf``
    the compliant ground's force on the stance toe) and the spring pulleys of the stance and
    swing legs, the stance side, the stance toe's drift from its touchdown point (m) and the
    cable stretch of both legs (:func:`cable_stretch`)."""
    m = scaled_plant(m, setup)
    q, qd = stance_state(p0.x, p0.stance)
    y, yd = vcm.outputs(c.vc, c.phase, q, qd)
    grf = md.ground_forces(m, p0.x)[p0.stance]
    toes = md.toe_positions(m, p0.x[:13])
    bsp = p0.x[jnp.asarray(SPRING_INDEX)]
    return dict(z=jnp.concatenate([q, qd]), u=u, y=y, yd=yd, phase=c.phase, theta=vcm.theta(q), grf=grf,
                step=p0.step, touched=p.step != p0.step, hip=p.x[:2], force=sw.hip_force(setup, p0)[0],
                distance=p.distance,
                work=p.work_pos, bsp_st=bsp[p0.stance], bsp_sw=bsp[1 - p0.stance], stance=p0.stance,
                toe_drift=toes[p0.stance, 0] - p0.toe_x, v_err=c.v_est - qd, stretch=cable_stretch(p0.x, p0.stance))


_LOOPS: dict = {}


def closed_loop(kind: str) -> sl.SampledLoop:
    """The loop on the 13-DoF plant under controller ``kind`` (cached per kind)."""
    loop = _LOOPS.get(kind)
    if loop is None:
        m, mc = plant_model(), wk.walking_model()
        loop = _LOOPS[kind] = sl.SampledLoop(
            plant_step=lambda s, x, u, d, h, t: plant_step(m, s, x, u, d, h, t), sensor=sensor,
            controller=lambda s, c, r, t: sw.controller(mc, kind, s, c, r, t, predict_impact_rates=True),
            fell=lambda s, x0, r, u, x: fell(m, s, x0, r, u, x), sample_time=sw.SAMPLE, substeps=SUBSTEPS,
            log=lambda s, x0, r, u, x, c: log(m, s, x0, r, u, x, c), exogenous=exogenous)
    return loop


def initial_plant(z0) -> Plant:
    """The 13-DoF state at the stance model's post-impact state z0 (left leg in stance): the
    rigid-cable configuration and velocities (cables unstretched), the stance toe at the
    origin on the ground's surface, bristles relaxed."""
    mc = wk.walking_model()
    q, qd = wk.embed(mc, jnp.asarray(z0))
    E = jnp.asarray(np.asarray(mc.E))
    x = jnp.concatenate([E @ q, E @ qd, jnp.zeros(2)])
    f = jnp.zeros(())
    return Plant(x=x, stance=jnp.zeros((), int), t_step=f, step=jnp.zeros((), int), work_pos=f, distance=f,
                 toe_x=f, lifted=jnp.asarray(False))


def initial_state(setup: sw.Setup, z0) -> sl.LoopState:
    """The loop's state at the stance model's post-impact state z0 (time 0, no touchdown)."""
    return sl.initial_state(initial_plant(z0), jnp.asarray(-1), sw.initial_ctrl(setup, z0), 0.0)


def simulate(kind: str, setup: sw.Setup, z0, steps: int, chunk: int = 250, progress=None):
    """Walk the 13-DoF plant from the stance model's post-impact state z0 until ``steps``
    touchdowns or a fall; returns (final loop state, logs) as :func:`.loop.simulate`."""
    cb = None if progress is None else (lambda s: progress(int(s.x.step), steps))
    bound = int((steps + 1) * sw.MAX_STEP_TIME / sw.SAMPLE) + 2 * chunk
    return sl.simulate(closed_loop(kind), setup, initial_state(setup, z0), bound, chunk,
                       until=lambda s: int(s.x.step) >= steps, progress=cb)


def steps_of(log):
    """(start, end) sample ranges of the completed steps in a log (touchdown to touchdown)."""
    tch = np.nonzero(np.asarray(log["touched"]))[0]
    return list(zip(np.concatenate([[0], tch[:-1] + 1]), tch + 1))


def gap_record(log, speed_per_step) -> dict:
    """What the 13-DoF plant shows that the stance model cannot, over the completed steps: the
    peak stance and swing spring deflections (Fig. 15: the swing spring is not held at rest),
    the stance toe's largest drift from its touchdown point (slip), the fraction of samples
    with the stance toe off the ground (rebound), and the mean of ``speed_per_step`` (one
    speed per completed step, :func:`.study.metrics`) with each leg in stance (the alternation
    a period-two gait shows); the rms and peak cable stretch of each motor's cable (motor side,
    deg; :func:`cable_stretch`), which a controller with the stance model's rigid cables does
    not see; and the rms of the torque's change from sample to sample per motor (N m), how noisy
    the controller's torques are (Sec. V-D, V-E)."""
    spans = steps_of(log)
    end = spans[-1][1] if spans else len(np.asarray(log["step"]))
    if not end:
        return dict(stance_spring_peak_deg=None, swing_spring_peak_deg=None, max_toe_drift_m=None,
                    stance_toe_airborne_fraction=None, speed_left_stance_mps=None, speed_right_stance_mps=None,
                    cable_stretch_rms_deg=None, cable_stretch_peak_deg=None, torque_noise_rms_nm=None)
    side = np.asarray(log["stance"])[[a for a, _ in spans]]
    speeds = np.asarray(speed_per_step, float)[: len(spans)]
    mean = lambda v: float(np.mean(v)) if v.size else None  # noqa: E731
    stretch = np.asarray(log["stretch"], float)[:end]
    u = np.asarray(log["u"], float)[:end]
    return dict(
        stance_spring_peak_deg=float(np.degrees(np.max(np.asarray(log["bsp_st"])[:end]))),
        swing_spring_peak_deg=float(np.degrees(np.max(np.asarray(log["bsp_sw"])[:end]))),
        max_toe_drift_m=float(np.max(np.abs(np.asarray(log["toe_drift"])[:end]))),
        stance_toe_airborne_fraction=float(np.mean(np.asarray(log["grf"])[:end, 1] <= 0.0)),
        speed_left_stance_mps=mean(speeds[side == 0]), speed_right_stance_mps=mean(speeds[side == 1]),
        cable_stretch_rms_deg=dict(zip(sw.ACTUATORS, np.degrees(np.sqrt(np.mean(stretch**2, 0))).tolist())),
        cable_stretch_peak_deg=dict(zip(sw.ACTUATORS, np.degrees(np.max(np.abs(stretch), 0)).tolist())),
        torque_noise_rms_nm=dict(zip(sw.ACTUATORS, np.sqrt(np.mean(np.diff(u, axis=0) ** 2, 0)).tolist())))
