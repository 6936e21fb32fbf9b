"""Closed-loop running of the ATRIAS-like robot over unobserved terrain (running paper, IV),
on the core's sampled-data loop (:mod:`bipedlab.sim.loop`).

The plant (:mod:`bipedlab.robots.atrias.robot`, full model with foot masses and the Geyer-Herr
ground) is integrated by semi-implicit Euler with implicit ground damping at ``DT`` = 0.2 ms,
``SUBSTEPS`` = 5 steps per 1 kHz controller sample (zero-order hold). Step choice measured in
the study's report (apex statistics at 0.2 ms agree with 0.1 ms within the run-to-run noise;
explicit integration of the same ground would need steps below about 1e-5 s).

The loop's stages (one plant step of :class:`SampledLoop` per control sample, ``substeps`` = 1:
it runs the ``RunConfig.substeps`` Euler steps and then the per-sample apex bookkeeping):

* :func:`sensor` - the controller sees q, q' (optionally with uniform noise of +-3 deg,
  +-3 deg/s, +-3 cm, +-3 cm/s, redrawn every 3 ms: drawn each sample from the trial's key
  folded with the sample index // 3, so no held value; :func:`bipedlab.sim.sensors.held_noise`
  gives the same draws but its select changes the compiled arithmetic, by 1e-11 in the apex
  records; the draw is scaled by ``Sensing.noise``, 0 or 1, so 0 adds exact zeros) and the
  foot contact switches, all delayed by a whole number of samples
  (:func:`bipedlab.sim.sensors.delay_read`: a delay line of fixed length read ``Sensing.delay``
  samples back, exact);
* :func:`controller` - :func:`bipedlab.robots.atrias.controller.control` with its
  :class:`~bipedlab.robots.atrias.controller.CtrlState`, keeping the leg-angle target and the
  previous stance leg for the log;
* :func:`plant_step` - the sub-steps and the bookkeeping on the true state (:class:`Plant`);
* :func:`fell` - the COM less than 0.45 m above the ground below it, or the trunk pitched
  beyond 60 deg; the core adds NONFINITE and freezes the plant at the first failure.

Apexes (recorded up to MAX_APEX per trial) are those of the whole robot's COM, trunk and feet:
the bounce height is its apex above the ground of the last stance foot, the speed its forward
velocity there. Time is computed from sample counters ((k + 1) dt substeps), not from the loop's
accumulated ``LoopState.t``.

The loop's parameters are :class:`Params`: per trial a :class:`Trial` (terrain, random key),
shared by the batch the controller parameters and the :class:`Sensing` (noise amplitude,
delay in samples), all traced, so energy options, model errors, noise and delays up to the
delay line's length run on one compiled program. Only :class:`Program` (the static part of a
:class:`RunConfig`: log, step, sub-steps, delay-line length) and the robot parameters are
closed over. :func:`make_chunk` builds one compiled function advancing a batch of trials by a
fixed number of samples; the caller loops over chunks (progress bar) re-using it.
"""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.robots.atrias import controller as rc
from bipedlab.robots.atrias import robot as at
from bipedlab.contact import stick_slip as ss
from bipedlab.contact import terrain as tr
from bipedlab.pytree import pytree
from bipedlab.sim import loop as sl
from bipedlab.sim import sensors

DT = 2e-4
SUBSTEPS = 5
CONTROL_DT = DT * SUBSTEPS
NOISE_EVERY = 3
OK, FELL, NONFINITE = sl.OK, sl.FELL, sl.NONFINITE
STATUS_NAMES = sl.STATUS_NAMES
MAX_APEX = 96
NOISE_AMP = np.array([0.03, 0.03, np.deg2rad(3), np.deg2rad(3), np.deg2rad(3), 0.03, 0.03,
                      0.03, 0.03, np.deg2rad(3), np.deg2rad(3), np.deg2rad(3), 0.03, 0.03])


DELAY_LINE = 16  # samples of the delay line: delays up to DELAY_LINE - 1 share a program


@dataclasses.dataclass(frozen=True)
class RunConfig:
    """Settings of a run: noise on/off, delay in samples, whether to log every sample,
    integration step and steps per sample. Noise and delay enter the compiled program as
    traced :class:`Sensing`; the rest is its static :class:`Program`."""

    noise: bool = False
    delay: int = 0
    log: bool = False
    dt: float = DT
    substeps: int = SUBSTEPS


@dataclasses.dataclass(frozen=True)
class Program:
    """The static part of a :class:`RunConfig`, what fixes the compiled program: logging,
    integration step, sub-steps per sample and the delay line's length (samples, above the
    delay)."""

    log: bool = False
    dt: float = DT
    substeps: int = SUBSTEPS
    delay_line: int = DELAY_LINE


def program(cfg: RunConfig) -> Program:
    """The compiled program of ``cfg``: a delay line of DELAY_LINE samples, or longer for a
    longer delay."""
    return Program(cfg.log, cfg.dt, cfg.substeps, max(DELAY_LINE, int(cfg.delay) + 1))


@pytree
class Trial:
    """Per-trial parameters of the loop: the terrain and the noise key."""

    terrain: tr.Terrain
    key: jax.Array


@pytree
class Sensing:
    """The sensing of a run, traced: the noise amplitude (0 none, 1 :data:`NOISE_AMP`) and the
    delay (whole samples, below the program's delay line)."""

    noise: jax.Array
    delay: jax.Array


@pytree
class Params:
    """The loop's parameters: the trial's (batched), the controller's and the sensing (shared
    by a batch)."""

    trial: Trial
    cp: rc.CtrlParams
    sensing: Sensing


def sensing(cfg: RunConfig) -> Sensing:
    return Sensing(jnp.asarray(1.0 if cfg.noise else 0.0, jnp.float64), jnp.asarray(int(cfg.delay), jnp.int32))


def params(trial: Trial, cp: rc.CtrlParams, cfg: RunConfig) -> Params:
    """The loop's parameters for ``trial``: the controller parameters as strongly typed arrays
    (a Python float is weakly typed, and a different typing would compile the program again)
    and the sensing of ``cfg``."""
    return Params(trial, sl.strongly_typed(cp), sensing(cfg))


@pytree
class Plant:
    """The plant state: the robot (:class:`~bipedlab.robots.atrias.robot.SimState`), the GRFs
    of the last sub-step (N, for the log), the sample counter and the apex bookkeeping."""

    s: at.SimState
    grf: jax.Array          # (2, 2) GRF of each foot at the last sub-step (N)
    k: jax.Array            # samples done
    ydot_prev: jax.Array    # COM vertical velocity at the previous sample (m/s)
    armed: jax.Array        # a foot touched since the last recorded apex
    last_ground: jax.Array  # ground height below the last stance foot (m)
    apex_bounce: jax.Array  # (MAX_APEX,) COM apex above last_ground (m)
    apex_speed: jax.Array   # (MAX_APEX,) forward COM speed at the apex (m/s)
    apex_y: jax.Array       # (MAX_APEX,) COM apex height (m)
    apex_x: jax.Array       # (MAX_APEX,) COM x at the apex (m)
    n_apex: jax.Array
    pitch_sq: jax.Array     # sum of squared pitch errors after 1 s (rad^2)
    pitch_n: jax.Array      # number of samples in pitch_sq


@pytree
class SensorState:
    """Sample counter (for the noise) and the delay line of the measurements."""

    k: jax.Array
    delay: sensors.Delay


@pytree
class Sensed:
    """What the controller receives: the (delayed, noisy) measurement and the sample index."""

    meas: rc.Meas
    k: jax.Array


@pytree
class Ctrl:
    """Controller state: the controller's own, the last leg-angle target alpha (rad), the
    stance leg before the last sample and the samples done (for the log's time)."""

    cs: rc.CtrlState
    alpha: jax.Array
    leg: jax.Array
    k: jax.Array


def slip_angle0(cp):
    from bipedlab.control import slip
    return slip.policy_angle(cp.policy, 0.0)


def initial_state(rp: at.AtriasParams, cp: rc.CtrlParams, cfg: RunConfig, y_apex=rc.APEX_HEIGHT,
                  speed=rc.SPEED) -> sl.LoopState:
    """Start at the target apex with the legs mirrored, leg 0 about to land."""
    th = cp.theta_star
    g0 = rc.landing_hip_angle(cp, th, slip_angle0(cp))
    s = at.initial_state(rp, 0.0, y_apex, speed, th, float(g0), float(2 * np.pi - g0), 0.75, 0.6)
    z = jnp.concatenate([s.q, s.qd, jnp.zeros(2)])
    zf = jnp.zeros(MAX_APEX)
    i32 = lambda v: jnp.asarray(v, jnp.int32)
    f64 = lambda v: jnp.asarray(v, jnp.float64)
    x = Plant(s, jnp.zeros((2, 2)), i32(0), f64(0.0), jnp.asarray(False), f64(0.0), zf, zf, zf, zf, i32(0),
              f64(0.0), f64(0.0))
    sens = SensorState(i32(0), sensors.delay_init(z, program(cfg).delay_line))
    cs = rc.init_state(cp, 0)
    ctrl = Ctrl(cs, f64(0.0), cs.leg, i32(0))
    return sl.initial_state(x, sens, ctrl)


def _measure(rp, s, grf):
    contact = (grf[:, 1] > 0).astype(s.q.dtype)
    return jnp.concatenate([s.q, s.qd, contact])


def make_loop(rp: at.AtriasParams, prog: Program) -> sl.SampledLoop:
    """The closed loop's stages for one trial (params: :class:`Params`)."""
    gp = at.ground_params(rp)

    def sensor(p: Params, ss_: SensorState, x: Plant, t):
        # measurement of the state after the previous sample, noise, delay
        z = _measure(rp, x.s, _grf_of(rp, gp, p.trial.terrain, x.s))
        # redrawn every NOISE_EVERY samples: the same key for the samples between
        n = jax.random.uniform(jax.random.fold_in(p.trial.key, ss_.k // NOISE_EVERY), (14,), minval=-1.0,
                               maxval=1.0) * NOISE_AMP
        z = z.at[:14].add(n * p.sensing.noise)
        delay, z = sensors.delay_read(ss_.delay, z, p.sensing.delay)
        meas = rc.Meas(z[:7], z[7:14], z[14:16], jnp.zeros(2))
        return SensorState(ss_.k + 1, delay), Sensed(meas, ss_.k)

    def controller(p: Params, c: Ctrl, y: Sensed, t):
        cs, u, alpha = rc.control(p.cp, c.cs, y.meas)
        return Ctrl(cs, alpha, c.cs.leg, y.k + 1), u

    def plant_step(p: Params, x: Plant, u, d, h, t):
        terr = p.trial.terrain

        def sub(_, carry):
            s, _g = carry
            return at.step(rp, gp, terr, s, u, prog.dt)

        s, grf = jax.lax.fori_loop(0, prog.substeps, sub, (x.s, jnp.zeros((2, 2))))
        # bookkeeping on the true state
        q, qd = s.q, s.qd
        com, vcom = system_com(rp, q, qd)
        inc = grf[:, 1] > 0
        gfoot = jnp.stack([tr.ground(terr, at.foot(rp, q, i)[0]) for i in range(2)])
        last_ground = jnp.where(inc[0], gfoot[0], jnp.where(inc[1], gfoot[1], x.last_ground))
        apex = x.armed & (~jnp.any(inc)) & (x.ydot_prev > 0) & (vcom[1] <= 0)
        armed = (x.armed | jnp.any(inc)) & ~apex
        idx = jnp.minimum(x.n_apex, MAX_APEX - 1)
        ab = jnp.where(apex, x.apex_bounce.at[idx].set(com[1] - last_ground), x.apex_bounce)
        asp = jnp.where(apex, x.apex_speed.at[idx].set(vcom[0]), x.apex_speed)
        ay = jnp.where(apex, x.apex_y.at[idx].set(com[1]), x.apex_y)
        ax = jnp.where(apex, x.apex_x.at[idx].set(com[0]), x.apex_x)
        n_apex = x.n_apex + apex.astype(x.n_apex.dtype)
        late = (x.k + 1) * prog.dt * prog.substeps > 1.0
        pe = q[2] - p.cp.theta_star
        return Plant(s, grf, x.k + 1, vcom[1], armed, last_ground, ab, asp, ay, ax, n_apex,
                     x.pitch_sq + jnp.where(late, pe * pe, 0.0), x.pitch_n + late.astype(float))

    def fell(p: Params, x_before, y, u, x: Plant):
        q = x.s.q
        return (q[1] - tr.ground(p.trial.terrain, q[0]) < 0.45) | (jnp.abs(q[2]) > np.deg2rad(60))

    def log(p: Params, x_before, y, u, x: Plant, c: Ctrl):
        q, qd = x.s.q, x.s.qd
        return dict(t=c.k * prog.dt * prog.substeps, q=q, qd=qd, grf=x.grf, u=at.clip_input(rp, u), mode=c.cs.mode,
                    leg=c.leg, alpha=c.alpha, H=at.angular_momentum(rp, q, qd),
                    ground=tr.ground(p.trial.terrain, q[0]))

    return sl.SampledLoop(plant_step=plant_step, sensor=sensor, controller=controller, fell=fell,
                          sample_time=prog.dt * prog.substeps, substeps=1, log=log if prog.log else None)


def system_com(rp, q, qd):
    """Position and velocity of the whole robot's COM (trunk and feet): ballistic in flight,
    so its apex (vertical velocity zero) and forward speed are the gait's apex state."""
    mt = rp.m + 2 * rp.m_f
    pos = rp.m * q[:2] + sum(rp.m_f * at.foot(rp, q, i) for i in range(2))
    vel = rp.m * qd[:2] + sum(rp.m_f * (at.foot_jac(rp, q, i) @ qd) for i in range(2))
    return pos / mt, vel / mt


def _grf_of(rp, gp, terr, s):
    """Contact force estimate at the current state (for the contact switches)."""
    out = []
    for i in range(2):
        pf = at.foot(rp, s.q, i)
        vf = at.foot_jac(rp, s.q, i) @ s.qd
        out.append(jnp.stack([0.0, ss.normal_force(gp, terr, pf, vf)]))
    return jnp.stack(out)


def make_chunk(rp, prog: Program, n_samples: int, batched: bool):
    """Compiled: advance (loop state, :class:`Params`) by n_samples with
    :func:`bipedlab.sim.loop.run`; vmapped over trials (the state and ``Params.trial``; the
    controller parameters and the sensing shared) if batched. Returns (state, logs or None)."""
    loop = make_loop(rp, prog)

    def run(s, p):
        return sl.run(loop, p, s, n_samples)

    if batched:
        run = jax.vmap(run, in_axes=(0, Params(Trial(tr.Terrain(0, None, None, None), 0), None, None)))
    return jax.jit(run)
