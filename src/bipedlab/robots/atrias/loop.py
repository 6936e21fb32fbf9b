"""Closed-loop running of the ATRIAS-like robot over unobserved terrain (running paper, IV).

The plant (:mod:`bipedlab.robots.atrias.robot`, full model with foot masses and the Geyer-Herr
ground) is integrated by semi-implicit Euler with implicit ground damping at ``DT`` = 0.2 ms,
``SUBSTEPS`` = 5 steps per 1 kHz controller sample (zero-order hold). Step choice measured in
the study's report (apex statistics at 0.2 ms agree with 0.1 ms within the run-to-run noise;
explicit integration of the same ground would need steps below about 1e-5 s).

Sensing: the controller sees q, q' (optionally with uniform noise of +-3 deg, +-3 deg/s,
+-3 cm, +-3 cm/s, redrawn every 3 ms) and the foot contact switches, all delayed by a whole
number of samples. Status: OK, FELL (COM less than 0.45 m above the ground below it, or the
trunk pitched beyond 60 deg), NONFINITE. Apexes (recorded up to MAX_APEX per trial) are those
of the whole robot's COM, trunk and feet: the bounce height is its apex above the ground of the
last stance foot, the speed its forward velocity there.

:func:`make_chunk` builds one compiled function advancing a batch of trials by a fixed number
of samples; the caller loops over chunks (progress bar) re-using it.
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

DT = 2e-4
SUBSTEPS = 5
CONTROL_DT = DT * SUBSTEPS
NOISE_EVERY = 3
OK, FELL, NONFINITE = 0, 1, 2
STATUS_NAMES = {OK: "ok", FELL: "fell", NONFINITE: "non-finite"}
MAX_APEX = 96
NOISE_AMP = np.array([0.03, 0.03, np.deg2rad(3), np.deg2rad(3), np.deg2rad(3), 0.03, 0.03,
                      0.03, 0.03, np.deg2rad(3), np.deg2rad(3), np.deg2rad(3), 0.03, 0.03])


@dataclasses.dataclass(frozen=True)
class RunConfig:
    """Static settings: noise on/off, delay in samples, whether to log every sample,
    integration step and steps per sample."""

    noise: bool = False
    delay: int = 0
    log: bool = False
    dt: float = DT
    substeps: int = SUBSTEPS


@pytree
class Carry:
    s: at.SimState
    cs: rc.CtrlState
    buf: jax.Array          # (delay + 1, 16) measurement buffer
    k: jax.Array
    status: jax.Array
    ydot_prev: jax.Array
    armed: jax.Array        # a foot touched since the last recorded apex
    last_ground: jax.Array
    apex_bounce: jax.Array  # (MAX_APEX,)
    apex_speed: jax.Array
    apex_y: jax.Array
    apex_x: jax.Array
    n_apex: jax.Array
    pitch_sq: jax.Array
    pitch_n: jax.Array


def initial_carry(rp: at.AtriasParams, cp: rc.CtrlParams, cfg: RunConfig, y_apex=1.05, speed=5.0):
    """Start at the target apex with the legs mirrored, leg 0 about to land."""
    th = cp.theta_star
    g0 = rc.landing_hip_angle(cp, th, slip_angle0(cp))
    s = at.initial_state(rp, 0.0, y_apex, speed, th, float(g0), float(2 * np.pi - g0), 0.75, 0.6)
    z = jnp.concatenate([s.q, s.qd, jnp.zeros(2)])
    buf = jnp.tile(z, (cfg.delay + 1, 1))
    zf = jnp.zeros(MAX_APEX)
    i32 = lambda v: jnp.asarray(v, jnp.int32)
    f64 = lambda v: jnp.asarray(v, jnp.float64)
    return Carry(s, rc.init_state(cp, 0), buf, i32(0), i32(OK), f64(0.0), jnp.asarray(False), f64(0.0), zf, zf, zf, zf, i32(0),
                 f64(0.0), f64(0.0))


def slip_angle0(cp):
    from bipedlab.control import slip
    return slip.policy_angle(cp.policy, 0.0)


def _measure(rp, s, grf):
    contact = (grf[:, 1] > 0).astype(s.q.dtype)
    return jnp.concatenate([s.q, s.qd, contact])


def make_step(rp: at.AtriasParams, cp: rc.CtrlParams, cfg: RunConfig):
    """One controller sample for one trial: (carry, terrain, key) -> (carry, log)."""
    gp = at.ground_params(rp)

    def sample(c: Carry, terr, key):
        # measurement (of the state after the previous sample), noise, delay
        grf_now = _grf_of(rp, gp, terr, c.s)
        z = _measure(rp, c.s, grf_now)
        if cfg.noise:
            kk = jax.random.fold_in(key, c.k // NOISE_EVERY)
            n = jax.random.uniform(kk, (14,), minval=-1.0, maxval=1.0) * NOISE_AMP
            z = z.at[:14].add(n)
        buf = jnp.concatenate([c.buf[1:], z[None]], axis=0)
        zd = buf[0]
        meas = rc.Meas(zd[:7], zd[7:14], zd[14:16], jnp.zeros(2))
        cs, u, alpha = rc.control(cp, c.cs, meas)

        def sub(_, carry):
            s, _g = carry
            return at.step(rp, gp, terr, s, u, cfg.dt)

        s, grf = jax.lax.fori_loop(0, cfg.substeps, sub, (c.s, jnp.zeros((2, 2))))
        # bookkeeping on the true state
        q, qd = s.q, s.qd
        com, vcom = system_com(rp, q, qd)
        inc = grf[:, 1] > 0
        gfoot = jnp.stack([tr.ground(terr, at.foot(rp, q, i)[0]) for i in range(2)])
        last_ground = jnp.where(inc[0], gfoot[0], jnp.where(inc[1], gfoot[1], c.last_ground))
        apex = c.armed & (~jnp.any(inc)) & (c.ydot_prev > 0) & (vcom[1] <= 0) & (c.status == OK)
        armed = (c.armed | jnp.any(inc)) & ~apex
        idx = jnp.minimum(c.n_apex, MAX_APEX - 1)
        ab = jnp.where(apex, c.apex_bounce.at[idx].set(com[1] - last_ground), c.apex_bounce)
        asp = jnp.where(apex, c.apex_speed.at[idx].set(vcom[0]), c.apex_speed)
        ay = jnp.where(apex, c.apex_y.at[idx].set(com[1]), c.apex_y)
        ax = jnp.where(apex, c.apex_x.at[idx].set(com[0]), c.apex_x)
        n_apex = c.n_apex + apex.astype(c.n_apex.dtype)
        fell = (q[1] - tr.ground(terr, q[0]) < 0.45) | (jnp.abs(q[2]) > np.deg2rad(60))
        bad = ~(jnp.all(jnp.isfinite(q)) & jnp.all(jnp.isfinite(qd)))
        new_status = jnp.where(bad, NONFINITE, jnp.where(fell, FELL, OK))
        alive = c.status == OK
        status = jnp.where(alive, new_status, c.status)
        keep = alive & ~bad
        s = jax.tree_util.tree_map(lambda a, b: jnp.where(keep, a, b), s, c.s)
        t = (c.k + 1) * cfg.dt * cfg.substeps
        late = (t > 1.0) & alive
        pe = q[2] - cp.theta_star
        c2 = Carry(s, cs, buf, c.k + 1, status, vcom[1], armed, last_ground, ab, asp, ay, ax, n_apex,
                   c.pitch_sq + jnp.where(late, pe * pe, 0.0), c.pitch_n + late.astype(float))
        log = None
        if cfg.log:
            H = at.angular_momentum(rp, q, qd)
            log = dict(t=t, q=q, qd=qd, grf=grf, u=at.clip_input(rp, u), mode=cs.mode, leg=c.cs.leg,
                       alpha=alpha, H=H, ground=tr.ground(terr, q[0]))
        return c2, log

    return sample


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


def make_chunk(rp, cp, cfg: RunConfig, n_samples: int, batched: bool):
    """Compiled: advance (carry, terrain, key) by n_samples; vmapped over trials if batched."""
    sample = make_step(rp, cp, cfg)

    def run(c, terr, key):
        return jax.lax.scan(lambda c, _: sample(c, terr, key), c, None, length=n_samples)

    if batched:
        run = jax.vmap(run, in_axes=(0, tr.Terrain(0, None, None, None), 0))
    return jax.jit(run)
