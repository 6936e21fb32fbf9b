"""Closed-loop walking of MABEL as in the experiments (compliant-HZD paper, Section V): the
stance model of Section II-B under a controller sampled at 1 kHz.

Plant: the 6-DoF stance dynamics (rigid cables, swing spring at rest) integrated by RK4 with
``SUBSTEPS`` steps per sample under a zero-order-held torque; a substep is the core's hybrid
step (:func:`bipedlab.sim.hybrid.substep` of the transition :func:`touchdown`): touchdown is
located inside it by regula falsi on the swing-toe height, the transition map (with the impact
scaling eta) applied there and the rest of the substep integrated. An optional horizontal force on the
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

The loop is a :class:`bipedlab.sim.loop.SampledLoop` (params = :class:`Setup`): plant state
:class:`Plant` (stance state, time in the step, touchdown count, positive motor work, distance),
sensor stage :func:`sensor` (encoders and the touchdown switch), controller stage
:func:`controller` with its own state :class:`Ctrl`, exogenous input :func:`exogenous` (the
push), plant substep :func:`plant_step`, failure test :func:`fell` and the logged signals
:func:`log`.

Falls: the robot leaving the walking range, i.e. the hip lower than ``MIN_HIP_HEIGHT``, the
torso pitched more than ``MAX_TORSO_PITCH`` from upright, theta_s running backwards, or a step
lasting more than ``MAX_STEP_TIME``. The ground reaction is not part of the test: the stance
model pins the toe (no slip, no rebound, Section II-B2), so a toe force outside the friction
cone |F_T| <= MU F_N, or a toe pulling on the ground (F_N < 0), is a sign that the real foot
would slip or lift, which this model does not represent. Both are recorded from the logged
ground reaction (:func:`contact_record`) and left to the reader of the record.
"""
from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.robots.mabel.walking import catalog
from bipedlab.robots.mabel.walking import constraints as vcm
from bipedlab.robots.mabel.walking import controllers as ctl
from bipedlab.robots.mabel.walking.zero_dynamics import motor_power
from bipedlab.mechanics import coupled as cp
from bipedlab.robots.mabel.walking import stance as wk
from bipedlab.pytree import pytree
from bipedlab.sim import loop as sl
from bipedlab.sim import sensors
from bipedlab.sim import hybrid
from bipedlab.sim.integrators import rk4_scan

SAMPLE = 1e-3
SUBSTEPS = 4
COUNTS = 2**14
MIN_HIP_HEIGHT = 0.6
#: the torso's pitch from upright (|q_Tor|, rad) beyond which the robot has fallen: 75 deg,
#: past the fast experiment's forward lean (0.7 rad on the nominal ~0.3 rad) and short of
#: the torso lying flat
MAX_TORSO_PITCH = float(np.deg2rad(75.0))
#: friction ratio |F_T / F_N| of the stance toe recorded as a friction-cone violation
MU = 0.8
MAX_STEP_TIME = 2.0
VELOCITY_FILTER = 0.3
#: weight of the model's prediction in the observer's velocity estimate (Setup.observer)
OBSERVER_GAIN = 0.9
#: eq. 50: the SC -> SI transition is forced by theta_sc + gamma (rad)
GAMMA = 0.03


@pytree
class Setup:
    """A run's fixed data: nominal constraints, controller gains, impact scaling, push force
    (N, positive forward) and its step index (-1 for none), the nominal step period,
    whether the encoders are quantised (1.0) or exact (0.0), and a forward torso lean (rad,
    :func:`~bipedlab.robots.mabel.walking.constraints.lean`) reached in ``lean_steps`` equal increments, one
    per touchdown (Exp. 5); ``observer`` 1.0 estimates the rates with the model-based observer
    of :func:`_rate_estimate` instead of the filtered difference (0.0); the push starts
    ``push_start`` nominal periods into its step (0.5: the second half, as Exp. 2); ``ground``
    scales the compliant ground's stiffness and damping on the 13-DoF plant (:mod:`.full_plant`;
    1.0: ``tables.GROUND``, the hopping-identified ground; the stance plant pins its toe and
    ignores it); ``cable`` likewise scales the 13-DoF plant's cable stiffness and damping (1.0:
    the identified cables; the stance plant's cables are rigid) and ``friction`` its motors'
    viscous friction (1.0: Table V's; the stance plant keeps Table V's). ``plant``: the model
    the plant runs on where it differs from the one the controller knows (None: the same; a
    model built with other values, :data:`bipedlab.robots.mabel.model.SCALABLE`): data of the
    compiled loop, so every such plant shares one program."""

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
    push_start: jax.Array = 0.5
    ground: jax.Array = 1.0
    cable: jax.Array = 1.0
    friction: jax.Array = 1.0
    plant: Any = None


@pytree
class Plant:
    """The plant's state: stance state z = (q_s, qd_s), time since the last touchdown (s), the
    number of touchdowns, the positive motor work (J) and the distance walked (m)."""

    z: jax.Array
    t_step: jax.Array
    step: jax.Array
    work_pos: jax.Array
    distance: jax.Array


@pytree
class Reading:
    """What the controller reads at a sample: the encoders q (6,), the exact rates qd (6,)
    (used only with ``sensing="ideal"``), whether a touchdown happened during the last
    period, and the touchdown count."""

    q: jax.Array
    qd: jax.Array
    impacted: jax.Array
    step: jax.Array


@pytree
class Ctrl:
    """The controller's state: sub-phase, constraints in force, last encoder reading, rate
    estimate and torque."""

    phase: jax.Array
    vc: vcm.Constraints
    q_prev: jax.Array
    v_est: jax.Array
    u_prev: jax.Array


@pytree
class Held:
    """Exogenous input held over a sample: the hip force (2,) N and the touchdown count at the
    sample's start (the push stops at a touchdown inside the sample)."""

    force: jax.Array
    step0: jax.Array


def measure(setup: Setup, z):
    """The encoders' reading of the stance coordinates z[:6] (exact with ``sensing="ideal"``)."""
    return sensors.encoder(z[:6], COUNTS, exact=~(setup.quantised > 0))


def hip_force(setup: Setup, s: Plant):
    on = (s.step == setup.push_step) & (s.t_step >= setup.push_start * setup.period)
    return jnp.stack([jnp.where(on, setup.push_force, 0.0), 0.0])


def _rk4(m, z, u, f, h):
    """RK4 substep of the stance dynamics under torque u and hip force f, both held."""
    return rk4_scan(lambda x, uf: wk.stance_flow(m, x, uf[0], uf[1]), z, (u, f), h)


def _toe(m, z):
    return wk.swing_toe(m, z)[1]


def touchdown(m, setup: Setup, t_step) -> hybrid.Transition:
    """The stance phase's end as a hybrid transition: the stance dynamics under the held
    (torque, hip force), the swing toe's height (m) as the guard, armed once the step has lasted
    a tenth of the nominal period (``t_step``: s since the last touchdown, at the substep's
    start), the transition map with the impact scaling eta as the reset (info: the step length,
    m), the push ending at the touchdown; located by six plain false-position updates, the
    method the recorded walks were made with."""
    return hybrid.Transition(
        flow=lambda x, uf: wk.stance_flow(m, x, uf[0], uf[1]), guard=lambda x: _toe(m, x),
        armed=lambda x: t_step > 0.1 * setup.period, reset=lambda x: _impact(m, setup, x), integrator=rk4_scan,
        input_after=lambda uf: (uf[0], 0.0 * uf[1]), iterations=6, method="false_position")


def _impact(m, setup, z):
    tr = wk.impact(m, z, setup.eta)
    return tr.z_plus, tr.step[0]


def _substep(m, setup, z, u, f, t_step, h):
    """One substep (:func:`bipedlab.sim.hybrid.substep` of :func:`touchdown`); returns (z,
    touched, fraction of h elapsed before the touchdown, step length)."""
    zt, ev = hybrid.substep(touchdown(m, setup, t_step), z, (u, f), h)
    return zt, ev.event, ev.fraction, ev.info


def _rate_estimate(m, setup: Setup, s: Ctrl, q):
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
    plain = sensors.filtered_difference(s.v_est, q, s.q_prev, SAMPLE, VELOCITY_FILTER)

    def observed(_):
        a = wk.stance_flow(wk.without_stop(m), jnp.concatenate([s.q_prev, s.v_est]), s.u_prev)[6:]
        return sensors.observer_blend(s.v_est, a, q, s.q_prev, SAMPLE, OBSERVER_GAIN)

    return jax.lax.cond(setup.observer > 0, observed, lambda _: plain, None)


def sensor(setup: Setup, last_step, x: Plant, t):
    """The encoders and the touchdown switch; the sensor's state is the touchdown count at the
    previous sample (-1 at the start: the first sample starts from a post-impact state)."""
    return x.step, Reading(q=measure(setup, x.z), qd=x.z[6:], impacted=x.step != last_step, step=x.step)


def controller(m, kind: str, setup: Setup, s: Ctrl, r: Reading, t, predict_impact_rates: bool = False):
    """Rate estimate, constraints and sub-phase update, torque (saturated).

    ``predict_impact_rates``: at the touchdown sample the exact rates (``quantised`` 0) are
    replaced by the model's prediction, as the encoders' estimate always is. A plant whose
    impact takes time (the 13-DoF model's compliant ground, :mod:`.full_plant`) reports the
    touchdown at the first contact, when the exact rates are still the pre-impact ones; the
    step-start update (:func:`~bipedlab.robots.mabel.walking.constraints.update_at_impact`)
    built from them leaves the outputs with the whole velocity jump of the impact as an
    error once it has happened (measured: eq. 42 at the outer-loop stiffness of PD + FF on the
    stance leg-shape motor, eps = 0.0173, lifted the stance toe and fell in the first step of
    ``paper-nominal``; with the prediction it walks, stance leg-shape rms 2.1 deg). The stance
    model's rigid impact has happened by the touchdown sample, so its exact rates are read."""
    q = r.q
    relabel = r.impacted & (t > 0.0)  # the first sample starts from a post-impact state
    # across a touchdown the estimator predicts the post-impact rates with the model's
    # transition map applied to its last (pre-impact) estimate; both maps run only then
    v = jax.lax.cond(
        relabel, lambda _: wk.impact(m, jnp.concatenate([s.q_prev, s.v_est]), setup.eta).z_plus[6:],
        lambda _: _rate_estimate(m, setup, s, q), None)
    exact = (setup.quantised <= 0) & ~relabel if predict_impact_rates else setup.quantised <= 0
    v = jnp.where(exact, r.qd, v)
    zm = jnp.concatenate([q, v])
    nominal = vcm.lean(setup.vc, setup.lean * jnp.minimum(r.step / jnp.maximum(setup.lean_steps, 1), 1.0))
    if kind == "pdff":
        vc = jax.tree_util.tree_map(lambda a, b: jnp.where(r.impacted, a, b), nominal, s.vc)
    else:
        vc = jax.lax.cond(r.impacted, lambda _: vcm.update_at_impact(nominal, q, v, nominal, invariant=True),
                          lambda _: s.vc, None)
    phase = jnp.where(r.impacted, vcm.MC, s.phase)
    phase, th_sc = vcm.next_phase(vc, phase, q, v, GAMMA)
    vc = vc.replace(theta_sc=th_sc)
    u = ctl.control(kind, wk.without_stop(m), vc, phase, zm, setup.gains)
    return Ctrl(phase=phase, vc=vc, q_prev=q, v_est=v, u_prev=u), u


def exogenous(setup: Setup, x: Plant, t) -> Held:
    """The push of Exp. 2, held over the sample."""
    return Held(force=hip_force(setup, x), step0=x.step)


def plant_of(m, setup: Setup):
    """The model the plant runs on: ``setup.plant`` where given, else m (the controller's)."""
    return m if setup.plant is None else setup.plant


def plant_step(m, setup: Setup, x: Plant, u, d: Held, h, t) -> Plant:
    """One substep (:func:`_substep`); the push stops once the sample has seen a touchdown, and
    only one touchdown counts per sample."""
    m = plant_of(m, setup)
    touched = x.step != d.step0
    p = motor_power(u, x.z[6:])
    zn, hit, frac, length = _substep(m, setup, x.z, u, jnp.where(touched, 0.0, 1.0) * d.force, x.t_step, h)
    hit = hit & ~touched
    t_step = jnp.where(hit, (1.0 - frac) * h, x.t_step + h)
    return Plant(z=zn, t_step=t_step, step=x.step + hit, work_pos=x.work_pos + h * jnp.sum(jnp.maximum(p, 0.0)),
                 distance=x.distance + jnp.where(hit, length, 0.0))


def fell(m, setup: Setup, x0: Plant, r: Reading, u, x: Plant):
    """The robot leaves the walking range: hip too low, torso pitched beyond MAX_TORSO_PITCH,
    theta_s running backwards, or a step too long. The toe's ground reaction is not tested
    (the stance model pins the toe; see the module docstring and :func:`contact_record`)."""
    m = plant_of(m, setup)
    hip = cp.point_position(m.body, wk.embed(m, x.z)[0], "hip")
    return ((hip[1] < MIN_HIP_HEIGHT) | (jnp.abs(x.z[5]) > MAX_TORSO_PITCH)
            | (vcm.theta_rate(x.z[6:]) < 0.0) | (x.t_step > MAX_STEP_TIME))


def friction_ratio(grf):
    """|F_T / F_N| of the stance toe's ground reaction(s) (..., 2); infinite where the toe
    pulls on the ground (F_N <= 0)."""
    grf = np.asarray(grf, float)
    fn = grf[..., 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(fn > 0.0, np.abs(grf[..., 0]) / np.where(fn > 0.0, fn, 1.0), np.inf)


def contact_record(log, n_samples=None) -> dict:
    """What the pinned-toe model leaves out, read from the logged ground reaction over the
    first ``n_samples`` samples (default all): whether and when (step index, time in s) the
    stance toe's friction ratio first exceeded MU, its largest value while the toe pressed on
    the ground, and whether and when the toe pulled on the ground (F_N < 0)."""
    grf = np.asarray(log["grf"], float)[:n_samples]
    steps = np.asarray(log["step"])[:n_samples]
    ratio = friction_ratio(grf)
    pressing = grf[:, 1] > 0.0
    over = np.nonzero(pressing & (ratio > MU))[0]
    pulled = np.nonzero(~pressing)[0]
    first = lambda idx: (int(steps[idx[0]]), float(idx[0] * SAMPLE)) if idx.size else (None, None)  # noqa: E731
    (k_over, t_over), (k_pull, _) = first(over), first(pulled)
    return dict(friction_cone_exceeded=bool(over.size), max_friction_ratio=float(np.max(ratio[pressing]))
                if pressing.any() else None, friction_cone_exceeded_step=k_over, friction_cone_exceeded_s=t_over,
                toe_pulled=bool(pulled.size), toe_pulled_step=k_pull, min_normal_force_n=float(np.min(grf[:, 1]))
                if grf.size else None)


#: the controller's torques, in its order
ACTUATORS = catalog.ACTUATORS
#: the stance coordinates whose rates the controller estimates, in the state's order
RATES = ("LA_st", "mLS_st", "Bsp_st", "LA_sw", "mLS_sw", "Tor")


def record_samples(s, log) -> int:
    """The samples a walk's figures are taken over: up to the fall, else up to the last
    touchdown (all samples when there was none)."""
    touched = np.nonzero(np.asarray(log["touched"]))[0]
    if fell_flag(s) and int(s.failed_at) >= 0:
        return int(s.failed_at) + 1
    return int(touched[-1]) + 1 if touched.size else len(np.asarray(log["u"]))


def drive_record(log, limit, n: int) -> dict:
    """How hard the controller drove the motors and how well it knew the rates, over the first
    ``n`` samples: per actuator (:data:`ACTUATORS`) the fraction of samples at the torque
    ``limit`` (N m) and the time of the first (s, None if never); per stance coordinate
    (:data:`RATES`) the rms of the rate estimate's error, estimate minus exact (rad/s; 0 with
    ``sensing="ideal"``)."""
    u = np.asarray(log["u"], float)[:n]
    at = np.abs(u) >= np.asarray(limit, float) * (1 - 1e-9)
    err = np.asarray(log["v_err"], float)[:n]
    first = [float(np.argmax(a) * SAMPLE) if a.any() else None for a in at.T]
    return dict(saturation_fraction={a: float(f) for a, f in zip(ACTUATORS, np.mean(at, 0))},
                first_saturation_s=dict(zip(ACTUATORS, first)),
                rate_estimate_error_rms={k: float(v) for k, v in zip(RATES, np.sqrt(np.mean(err**2, 0)))})


def log(m, setup: Setup, x0: Plant, r: Reading, u, x: Plant, c: Ctrl) -> dict:
    """One row per sample: state at its start, torque, outputs, sub-phase, theta, ground
    reaction, step count, touchdown flag, hip position, push force, distance, positive work,
    and the error of the controller's rate estimate (estimate minus exact)."""
    m = plant_of(m, setup)
    f = hip_force(setup, x0)
    y, yd = vcm.outputs(c.vc, c.phase, x0.z[:6], x0.z[6:])
    grf = wk.ground_reaction(m, x0.z, u, f)
    hip = cp.point_position(m.body, wk.embed(m, x.z)[0], "hip")
    return dict(z=x0.z, u=u, y=y, yd=yd, phase=c.phase, theta=vcm.theta(x0.z[:6]), grf=grf, step=x0.step,
                touched=x.step != x0.step, hip=hip, force=f[0], distance=x.distance, work=x.work_pos,
                v_err=c.v_est - x0.z[6:])


def closed_loop(m, kind: str) -> sl.SampledLoop:
    """MABEL's walking loop with model m and controller ``kind`` (cached per (m, kind))."""
    key = (id(m), kind)
    loop = _LOOPS.get(key)
    if loop is None:
        loop = _LOOPS[key] = sl.SampledLoop(
            plant_step=lambda p, x, u, d, h, t: plant_step(m, p, x, u, d, h, t), sensor=sensor,
            controller=lambda p, c, r, t: controller(m, kind, p, c, r, t),
            fell=lambda p, x0, r, u, x: fell(m, p, x0, r, u, x), sample_time=SAMPLE, substeps=SUBSTEPS,
            log=lambda p, x0, r, u, x, c: log(m, p, x0, r, u, x, c), exogenous=exogenous)
    return loop


def initial_state(setup: Setup, z0, phase=vcm.MC) -> sl.LoopState:
    """The loop's state at the post-impact state z0 (time 0, no touchdown yet)."""
    z0 = jnp.asarray(z0)
    f = jnp.zeros(())
    x = Plant(z=z0, t_step=f, step=jnp.zeros((), int), work_pos=f, distance=f)
    return sl.initial_state(x, jnp.asarray(-1), initial_ctrl(setup, z0, phase), 0.0)


def initial_ctrl(setup: Setup, z0, phase=vcm.MC) -> Ctrl:
    """The controller's state at the post-impact stance state z0: the encoders read there, the
    rates known, no torque yet."""
    z0 = jnp.asarray(z0)
    return Ctrl(phase=jnp.asarray(phase), vc=setup.vc, q_prev=measure(setup, z0), v_est=z0[6:], u_prev=jnp.zeros(4))


def make_runner(m, kind: str, chunk: int):
    """A compiled function (setup, state) -> (state, logs over ``chunk`` samples)."""
    return sl.compiled_runner(closed_loop(m, kind), chunk)


def simulate(m, kind: str, setup: Setup, z0, steps: int, chunk: int = 500, progress=None):
    """Walk from the post-impact state z0 until ``steps`` touchdowns or a fall. Returns
    (final :class:`~bipedlab.sim.loop.LoopState`, its plant state ``.x`` a :class:`Plant` and
    ``.status`` non-zero after a fall; logs concatenated as NumPy arrays). ``progress(step,
    steps)`` is called after each chunk."""
    cb = None if progress is None else (lambda s: progress(int(s.x.step), steps))
    # a step lasting more than MAX_STEP_TIME is a fall, so the sample bound is never reached
    bound = int((steps + 1) * MAX_STEP_TIME / SAMPLE) + 2 * chunk
    return sl.simulate(closed_loop(m, kind), setup, initial_state(setup, z0), bound, chunk,
                       until=lambda s: int(s.x.step) >= steps, progress=cb)


def fell_flag(s: sl.LoopState) -> bool:
    """Whether the run ended by a fall (or a non-finite state)."""
    return int(s.status) != sl.OK


_LOOPS: dict = {}
