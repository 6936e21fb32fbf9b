"""Closed-loop walking of MABEL as in the experiments (compliant-HZD paper, Section V): the
stance model of Section II-B under a controller sampled at 1 kHz.

Plant: the 6-DoF stance dynamics (rigid cables, swing spring at rest) integrated by RK4 with
``SUBSTEPS`` steps per sample under a zero-order-held torque; touchdown is located inside a
substep by regula falsi on the swing-toe height, the transition map (with the impact scaling
eta) applied there and the rest of the substep integrated. An optional horizontal force on the
hip (the push of Exp. 2) acts over the second half of a chosen step.

Controller: every 1 ms it reads the encoders (quantised to ``2 pi / counts``, or exact with
``sensing="ideal"``), differentiates them backward with a first-order filter, advances the
sub-phase by the guards of eq. 37 with the guard of eq. 50, and computes the torque of the
chosen controller, saturated. The controllers' model leaves out the spring's hard stop (the
stop is a plant property the gaits are designed to avoid): with it, the stop's stiff damper
entered Lf^2 h and a pulley reaching its stop at speed drew a saturated one-sample torque
spike that lifted the stance toe. It learns of a touchdown at the next sample: it then restarts
MC and, for the I/O-linearising controllers, updates the constraints at the measured
post-impact state (eqs. 45-47). A backward difference across the touchdown would mix the
pre- and post-impact rates, so at that sample the rate estimate is the model's transition map
applied to the last pre-impact estimate.

Falls: hip lower than ``MIN_HIP_HEIGHT``, the stance toe pulling on the ground, |F_T / F_N|
above ``MU``, theta_s running backwards, or a step lasting more than ``MAX_STEP_TIME``.
"""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.robots.mabel.walking import constraints as vcm
from bipedlab.robots.mabel.walking import controllers as ctl
from bipedlab.robots.mabel.walking.zero_dynamics import motor_power
from bipedlab.mechanics import coupled as cp
from bipedlab.robots.mabel.walking import stance as wk
from bipedlab.sim.integrators import rk4

SAMPLE = 1e-3
SUBSTEPS = 4
COUNTS = 2**14
MIN_HIP_HEIGHT = 0.6
MU = 0.8
MAX_STEP_TIME = 2.0
VELOCITY_FILTER = 0.3
#: weight of the model's prediction in the observer's velocity estimate (Setup.observer)
OBSERVER_GAIN = 0.9
#: eq. 50: the SC -> SI transition is forced by theta_sc + gamma (rad)
GAMMA = 0.03


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Setup:
    """A run's fixed data: nominal constraints, controller gains, impact scaling, push force
    (N, positive forward) and its step index (-1 for none), the nominal step period,
    whether the encoders are quantised (1.0) or exact (0.0), and a forward torso lean (rad,
    :func:`~bipedlab.robots.mabel.walking.constraints.lean`) reached in ``lean_steps`` equal increments, one
    per touchdown (Exp. 5); ``observer`` 1.0 estimates the rates with the model-based observer
    of :func:`_rate_estimate` instead of the filtered difference (0.0)."""

    vc: vcm.Constraints
    gains: ctl.Gains
    eta: jax.Array
    push_force: jax.Array
    push_step: jax.Array
    period: jax.Array
    quantised: jax.Array
    lean: jax.Array = 0.0
    lean_steps: jax.Array = 1
    observer: jax.Array = 0.0


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class State:
    z: jax.Array
    t: jax.Array
    t_step: jax.Array
    step: jax.Array
    phase: jax.Array
    vc: vcm.Constraints
    q_prev: jax.Array
    v_est: jax.Array
    u_prev: jax.Array
    impacted: jax.Array
    fell: jax.Array
    work_pos: jax.Array
    distance: jax.Array


def _measure(setup: Setup, z):
    res = 2 * jnp.pi / COUNTS
    q = z[:6]
    return jnp.where(setup.quantised > 0, jnp.round(q / res) * res, q)


def _hip_force(setup: Setup, s: State):
    on = (s.step == setup.push_step) & (s.t_step >= 0.5 * setup.period)
    return jnp.stack([jnp.where(on, setup.push_force, 0.0), 0.0])


def _rk4(m, z, u, f, h):
    """RK4 substep of the stance dynamics under torque u and hip force f, both held."""
    return rk4(lambda x, uf: wk.stance_flow(m, x, uf[0], uf[1]), z, (u, f), h)


def _toe(m, z):
    return wk.swing_toe(m, z)[1]


def _substep(m, setup, z, u, f, t_step, h):
    """One substep; returns (z, touched, fraction of h elapsed before the touchdown, step
    length)."""
    zn = _rk4(m, z, u, f, h)
    g0, g1 = _toe(m, z), _toe(m, zn)
    touched = (g0 > 0.0) & (g1 <= 0.0) & (t_step > 0.1 * setup.period)

    def locate(_):
        def body(c, _):
            a, b, ga, gb = c
            x = a - ga * (b - a) / (gb - ga)
            gx = _toe(m, _rk4(m, z, u, f, x * h))
            left = gx > 0.0
            return (jnp.where(left, x, a), jnp.where(left, b, x), jnp.where(left, gx, ga), jnp.where(left, gb, gx)), None

        a, b, ga, gb = jax.lax.scan(body, (0.0, 1.0, g0, g1), None, length=6)[0]
        x = a - ga * (b - a) / (gb - ga)
        zm = _rk4(m, z, u, f, x * h)
        tr = wk.impact(m, zm, setup.eta)
        zp = _rk4(m, tr.z_plus, u, 0.0 * f, (1.0 - x) * h)
        return zp, x, tr.step[0]

    zt, x, length = jax.lax.cond(touched, locate, lambda _: (zn, 1.0, 0.0), None)
    return zt, touched, x, length


def _rate_estimate(m, setup: Setup, s: State, q):
    """Velocity from the encoders between touchdowns.

    ``setup.observer == 0``: the filtered backward difference of the experiments,
    v = F v_prev + (1 - F) (q - q_prev) / T.

    ``setup.observer > 0``: a model-based observer. The controller's model (no push, no hard
    stop) predicts the acceleration a over the last period from the previous estimate and
    the torque held over it; the prediction v_prev + a T is blended with the backward
    difference moved from the middle to the end of the period, (q - q_prev) / T + a T / 2, as
    v = O (v_prev + a T) + (1 - O) (...) with O = OBSERVER_GAIN. The model carries the
    estimate between samples, so the blend can smooth the quantisation noise heavily without
    the lag a plain filter of the same strength adds."""
    diff = (q - s.q_prev) / SAMPLE
    plain = VELOCITY_FILTER * s.v_est + (1.0 - VELOCITY_FILTER) * diff

    def observed(_):
        a = wk.stance_flow(wk.without_stop(m), jnp.concatenate([s.q_prev, s.v_est]), s.u_prev)[6:]
        return OBSERVER_GAIN * (s.v_est + SAMPLE * a) + (1.0 - OBSERVER_GAIN) * (diff + 0.5 * SAMPLE * a)

    return jax.lax.cond(setup.observer > 0, observed, lambda _: plain, None)


def sample(m, kind: str, setup: Setup, s: State):
    """One 1 ms control period: read, control, integrate. Returns (state, log row)."""
    q = _measure(setup, s.z)
    relabel = s.impacted & (s.t > 0.0)  # the first sample starts from a post-impact state
    # across a touchdown the estimator predicts the post-impact rates with the model's
    # transition map applied to its last (pre-impact) estimate
    # transition map applied to its last (pre-impact) estimate; both maps run only then
    v = jax.lax.cond(
        relabel, lambda _: wk.impact(m, jnp.concatenate([s.q_prev, s.v_est]), setup.eta).z_plus[6:],
        lambda _: _rate_estimate(m, setup, s, q), None)
    v = jnp.where(setup.quantised > 0, v, s.z[6:])
    zm = jnp.concatenate([q, v])
    nominal = vcm.lean(setup.vc, setup.lean * jnp.minimum(s.step / jnp.maximum(setup.lean_steps, 1), 1.0))
    if kind == "pdff":
        vc = jax.tree_util.tree_map(lambda a, b: jnp.where(s.impacted, a, b), nominal, s.vc)
    else:
        vc = jax.lax.cond(s.impacted, lambda _: vcm.update_at_impact(nominal, q, v, nominal, invariant=True),
                          lambda _: s.vc, None)
    phase = jnp.where(s.impacted, vcm.MC, s.phase)
    phase, th_sc = vcm.next_phase(vc, phase, q, v, GAMMA)
    vc = vc.replace(theta_sc=th_sc)
    u = ctl.control(kind, wk.without_stop(m), vc, phase, zm, setup.gains)
    f = _hip_force(setup, s)
    y, yd = vcm.outputs(vc, phase, s.z[:6], s.z[6:])
    grf = wk.ground_reaction(m, s.z, u, f)

    h = SAMPLE / SUBSTEPS

    def sub(c, _):
        z, touched, t_step, step, work, dist = c
        p = motor_power(u, z[6:])
        zn, hit, x, length = _substep(m, setup, z, u, jnp.where(touched, 0.0, 1.0) * f, t_step, h)
        hit = hit & ~touched
        t_step = jnp.where(hit, (1.0 - x) * h, t_step + h)
        return (zn, touched | hit, t_step, step + hit, work + h * jnp.sum(jnp.maximum(p, 0.0)),
                dist + jnp.where(hit, length, 0.0)), None

    (z, touched, t_step, step, work, dist), _ = jax.lax.scan(
        sub, (s.z, jnp.asarray(False), s.t_step, s.step, s.work_pos, s.distance), None, length=SUBSTEPS)
    hip = cp.point_position(m.body, wk.embed(m, z)[0], "hip")
    fell = (s.fell | (hip[1] < MIN_HIP_HEIGHT) | (grf[1] < 0.0) | (jnp.abs(grf[0]) > MU * grf[1])
            | (vcm.theta_rate(z[6:]) < 0.0) | (t_step > MAX_STEP_TIME) | ~jnp.all(jnp.isfinite(z)))
    z = jnp.where(s.fell, s.z, z)
    new = State(z=z, t=s.t + SAMPLE, t_step=t_step, step=step, phase=phase, vc=vc, q_prev=q, v_est=v,
                u_prev=u, impacted=touched, fell=fell, work_pos=work, distance=dist)
    log = dict(z=s.z, u=u, y=y, yd=yd, phase=phase, theta=vcm.theta(s.z[:6]), grf=grf, step=s.step,
               touched=touched, hip=hip, force=f[0], distance=dist, work=work)
    return new, log


def initial_state(setup: Setup, z0, phase=vcm.MC) -> State:
    z0 = jnp.asarray(z0)
    q = _measure(setup, z0)
    f = jnp.zeros(())
    return State(z=z0, t=f, t_step=f, step=jnp.zeros((), int), phase=jnp.asarray(phase), vc=setup.vc,
                 q_prev=q, v_est=z0[6:], u_prev=jnp.zeros(4), impacted=jnp.asarray(True), fell=jnp.asarray(False),
                 work_pos=f, distance=f)


def make_runner(m, kind: str, chunk: int):
    """A compiled function (setup, state) -> (state, logs over ``chunk`` samples)."""

    @jax.jit
    def run(setup, state):
        return jax.lax.scan(lambda s, _: sample(m, kind, setup, s), state, None, length=chunk)

    return run


def simulate(m, kind: str, setup: Setup, z0, steps: int, chunk: int = 500, progress=None):
    """Walk from the post-impact state z0 until ``steps`` touchdowns or a fall. Returns
    (final state, logs concatenated as NumPy arrays)."""
    run = _RUNNERS.get((id(m), kind, chunk))
    if run is None:
        run = _RUNNERS[(id(m), kind, chunk)] = make_runner(m, kind, chunk)
    s = initial_state(setup, z0)
    logs = []
    while True:
        s, log = run(setup, s)
        logs.append(jax.tree_util.tree_map(np.asarray, log))
        if progress is not None:
            progress(int(s.step), steps)
        if bool(s.fell) or int(s.step) >= steps:
            break
    out = {k: np.concatenate([lg[k] for lg in logs]) for k in logs[0]}
    return s, out


_RUNNERS: dict = {}
