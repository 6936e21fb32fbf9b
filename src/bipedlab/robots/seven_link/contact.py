"""Hybrid simulation of the seven-link biped: unilateral toe/heel contacts without slip and
knee hyperextension stops as an active-set constrained system (Section II-B of the paper).

Elements (``active (6,)`` bool): the four contact points of
:data:`bipedlab.robots.seven_link.robot.CONTACTS` and the two knee stops. Constraint rows (10):

* rows 0-3, ``y_i = 0`` for an active contact (unilateral: force >= 0);
* rows 4-7, ``x_i - anchor_i = 0`` (no slip; the anchor is the point's x at touchdown). A
  foot flat on the ground keeps only its toe's row (the heel's would repeat it);
* rows 8-9, ``-phi_knee = 0`` at an active stop (unilateral).

Flow (:func:`flow`): the constrained equations of motion of
:mod:`bipedlab.contact.rigid` with the joint damping and ``E u``. After every step the
state is projected back onto the active constraints (one M-weighted Newton step on positions,
then the exact velocity projection): the drift before and after is measured and returned
(30 steps of the tuned walk: at most 1.3e-11 m and 6e-10 m/s before a projection, 4e-15 m and
5e-16 m/s after).

Events, all inside one compiled loop (the core's hybrid stage
:func:`bipedlab.sim.hybrid.flow_sample` on :func:`transition`):

* guard: an inactive element's gap (a contact point's height, ``-phi_knee``) crosses below
  ``-gap_tol``; located by bisection on the sub-step to ``event_tol`` seconds;
* reset: the plastic impact over the new active set (:func:`impact`), dropping previously
  active unilateral elements whose impulse would pull;
* release: at every control sample, before integrating, the active unilateral element with
  the most negative force is dropped until none is negative (:func:`release`).

The control runs at a fixed sample time with zero-order hold; the controller is a pure
``policy(params, cstate, t, x, active) -> (u, cstate)`` and everything it needs travels as
the ``params`` pytree, so changing gains does not recompile. Status codes follow
:mod:`bipedlab.sim.rollout` (``OK``, ``FELL``, ``NONFINITE``).
"""
from __future__ import annotations

import dataclasses
from typing import Callable

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.contact import rigid as aset
from bipedlab.robots.seven_link import robot as sl
from bipedlab.pytree import pytree
from bipedlab.sim import hybrid
from bipedlab.sim.integrators import rk4, rk4_scan
from bipedlab.sim.loop import LoopState, SampledLoop
from bipedlab.sim.loop import initial_state as loop_initial_state
from bipedlab.sim.loop import simulate as loop_simulate
from bipedlab.sim.rollout import FELL, NONFINITE, OK

#: Status when the events of one sample do not resolve (more than 400 sub-steps).
STUCK = 3
STATUS_NAMES = {OK: "ok", FELL: "fell", NONFINITE: "non-finite", STUCK: "stuck (unresolved events)"}
N_ELEMENTS = 6
N_ROWS = 10
#: Unilateral elements: all (contacts and knee stops).
_FOOT_OF = (0, 0, 1, 1)


# ----------------------------------------------------------------------------- rows
def row_mask(active) -> jax.Array:
    """Active constraint rows (10,) as floats from the active elements (6,)."""
    c = active[:4]
    toe_x = jnp.stack([c[0], c[0] & False, c[2], c[2] & False])
    heel_x = jnp.stack([c[0] & False, c[1] & ~c[0], c[2] & False, c[3] & ~c[2]])
    x_rows = toe_x | heel_x
    return jnp.concatenate([c, x_rows, active[4:]]).astype(jnp.float64)


_KNEE_ROWS = np.zeros((2, 9))
_KNEE_ROWS[0] = -sl.JOINT_MAP[sl.KNEES[0]]
_KNEE_ROWS[1] = -sl.JOINT_MAP[sl.KNEES[1]]


#: The rows of each element (6,) in the row vector (10,): contact heights 0-3, knee stops 8-9.
ELEMENT_ROWS = (slice(0, 4), slice(8, 10))


def constraint_values(P, q, anchors) -> jax.Array:
    """g (10,): contact heights, contact x minus anchors, and -phi_knee."""
    return aset.point_constraint_values(P, anchors, _KNEE_ROWS, q)


def constraint_jacobian(J, Jd):
    """(A (10, 9), Adot qd (10,))."""
    return aset.point_constraint_jacobian(J, Jd, _KNEE_ROWS)


def gaps(r: sl.SevenLink, q) -> jax.Array:
    """(6,) distance of each element from its constraint: contact heights and -phi_knee."""
    P = jnp.stack([sl.point_position(r, q, n) for n in sl.CONTACTS])
    return jnp.concatenate([P[:, 1], jnp.asarray(_KNEE_ROWS) @ q])


def element_forces(lam) -> jax.Array:
    """(6,) normal forces of the elements from the row multipliers (10,)."""
    return aset.element_values(lam, ELEMENT_ROWS)


# ----------------------------------------------------------------------------- dynamics
def applied_forces(r: sl.SevenLink, q, qd, u, h) -> jax.Array:
    """E u + damping - bias."""
    return sl.actuation(u) + sl.damping_force(r, qd) - h


#: Rows of the normal contact forces (the heights of the four contact points).
_NORMAL_ROWS = np.concatenate([np.ones(4), np.zeros(6)])


def turn_drag_direction(r: sl.SevenLink, qd) -> jax.Array:
    """(9,) the generalised force per newton of total normal foot force of the setup's
    foot-turning loss: ``-turn_drag tanh(x_dot / turn_rate)`` on the hip's x (zero for the
    planar model)."""
    if r.setup is None:
        return jnp.zeros(9)
    s = r.setup
    return jnp.zeros(9).at[0].set(-s.turn_drag * jnp.tanh(qd[0] / s.turn_rate))


def accelerations_with_drag(M, f, A, a_bias, mask, d):
    """(qdd, lambda) of ``M qdd = f + A^T lambda + d (n . lambda)`` with ``A qdd = -a_bias``
    on the active rows, n selecting the normal rows: a force d per newton of total normal
    force, solved exactly with the constraint forces (one non-symmetric KKT system)."""
    n = M.shape[0]
    Am = A * mask[:, None]
    G = Am.T + d[:, None] * (jnp.asarray(_NORMAL_ROWS) * mask)[None, :]
    K = jnp.block([[M, -G], [Am, jnp.diag(1.0 - mask)]])
    sol = jnp.linalg.solve(K, jnp.concatenate([f, -a_bias * mask]))
    return sol[:n], sol[n:] * mask


def solve(r: sl.SevenLink, x, u, active, gap_acc: bool = False):
    """(qdd, lambda rows (10,)) of the constrained motion under input u; with gap_acc also
    the elements' gap accelerations (6,). With a setup (:class:`~bipedlab.robots.seven_link.robot.Setup`)
    the foot-turning loss acts in proportion to the normal forces
    (:func:`accelerations_with_drag`)."""
    q, qd = x[:9], x[9:]
    M, h, P, V, J, Jd = sl.dynamics_terms(r, q, qd)
    A, ab = constraint_jacobian(J, Jd)
    if r.setup is None:
        qdd, lam = aset.accelerations(M, applied_forces(r, q, qd, u, h), A, ab, row_mask(active))
    else:
        qdd, lam = accelerations_with_drag(M, applied_forces(r, q, qd, u, h), A, ab, row_mask(active),
                                           turn_drag_direction(r, qd))
    if not gap_acc:
        return qdd, lam
    return qdd, lam, element_forces(A @ qdd + ab)


def flow(r: sl.SevenLink, x, u, active) -> jax.Array:
    """xdot of the constrained dynamics with the active set held."""
    qdd, _ = solve(r, x, u, active)
    return jnp.concatenate([x[9:], qdd])


def constraint_forces(r: sl.SevenLink, x, u, active) -> jax.Array:
    """Row multipliers (10,) (N, N m): normal forces, friction forces, knee stop torques."""
    return solve(r, x, u, active)[1]


def release(r: sl.SevenLink, x, u, active, iterations: int = 6, force_tol: float = 0.0):
    """(active, element forces (6,), released (6,)) after dropping pulling unilateral elements."""
    def force_fn(a):
        _, lam, acc = solve(r, x, u, a, gap_acc=True)
        return element_forces(lam), acc

    return aset.release(force_fn, active, iterations, force_tol=force_tol)


def impact(r: sl.SevenLink, x, active, new, iterations: int = 4, min_separation: float = 1e-2):
    """Plastic impact when the elements ``new`` make contact: (x+, impulses (6,), active).
    A previously active element whose impulse would pull is released only if it then
    separates faster than min_separation (m/s or rad/s)."""
    q, qd = x[:9], x[9:]
    M, _, _, _, J, Jd = sl.dynamics_terms(r, q, qd)
    A, _ = constraint_jacobian(J, Jd)
    qdp, imp, act = aset.plastic_impact(M, A, qd, active, new, row_mask, ELEMENT_ROWS, iterations, min_separation)
    return jnp.concatenate([q, qdp]), imp, act


def _constraints(r: sl.SevenLink, anchors):
    """constraint_fn(q, qd) -> (M, g, A) of the rigid-contact core."""
    def fn(q, qd):
        M, _, P, _, J, Jd = sl.dynamics_terms(r, q, qd)
        A, _ = constraint_jacobian(J, Jd)
        return M, constraint_values(P, q, anchors), A

    return fn


def project(r: sl.SevenLink, x, active, anchors, newton: int = 2):
    """(x projected onto the active constraints, residual (position, velocity) before)."""
    q, qd, res0 = aset.project_state(_constraints(r, anchors), x[:9], x[9:], row_mask(active), newton)
    return jnp.concatenate([q, qd]), res0


def residual(r: sl.SevenLink, x, active, anchors):
    """(max |g|, max |A qd|) over the active rows: the constraint drift of a state."""
    q, qd = x[:9], x[9:]
    _, g, A = _constraints(r, anchors)(q, qd)
    return aset.constraint_residual(g, A, qd, row_mask(active))


def step(r, x, u, active, h):
    """One RK4 step (:func:`bipedlab.sim.integrators.rk4`) of :func:`flow` with the active set held."""
    return rk4(lambda x, u: flow(r, x, u, active), x, u, h)


# ----------------------------------------------------------------------------- simulation
@dataclasses.dataclass(frozen=True)
class Settings:
    """Static settings. sample: control period (s, zero-order hold, one RK4 step per sample
    unless substeps > 1); max_time: s; steps: stop after this many touchdowns; log_every:
    log every n-th sample; gap_tol (m or rad) and event_tol (s): event location;
    max_step_time: a fall is declared when no foot lands for this long (s); min_flight: a
    touchdown counts as a step when that foot was off the ground at least this long (s);
    release_force_tol (N or N m): an element is released only when its force is below minus
    this (hysteresis against zero-force contacts flickering)."""

    sample: float = 1e-3
    substeps: int = 1
    max_time: float = 40.0
    steps: int = 30
    log_every: int = 5
    gap_tol: float = 1e-12
    event_tol: float = 1e-10
    max_step_time: float = 3.0
    min_flight: float = 0.05
    min_hip_height: float = 0.40
    release_force_tol: float = 0.0
    max_body_tilt: float = 1.0

    @property
    def n_samples(self) -> int:
        return int(round(self.max_time / self.sample))

    @property
    def n_log(self) -> int:
        return self.n_samples // self.log_every + 1


@pytree
class SimResult:
    """Outcome of :func:`simulate` (arrays; logs padded past ``n_log_used``).

    status, t_end, x_end, active_end, cstate_end (the controller state); touchdowns: count, times (steps+1,), foot (0/1),
    heel x of the landing foot (m), hip x (m), cumulative actuator work (|.| and positive, J);
    work_abs (6,) and work_pos (6,) J: integrals of
    |u phi_dot| and max(u phi_dot, 0) per joint; drift_before / drift_after: max position and
    velocity residual of the active constraints before and after each projection;
    impact_energy_gain: max kinetic energy change over all impacts (J, <= 0 expected);
    friction_ratio: max |F_t| / F_n of a foot carrying more than 10 N; n_events, n_releases
    (totals) and element_events, element_releases (6,) per element;
    logs: t, x, u, active, cstate_log (the policy's logged vector), element forces."""

    status: jax.Array
    t_end: jax.Array
    x_end: jax.Array
    active_end: jax.Array
    cstate_end: object
    n_touchdowns: jax.Array
    td_time: jax.Array
    td_foot: jax.Array
    td_heel_x: jax.Array
    td_hip_x: jax.Array
    td_work: jax.Array
    work_abs: jax.Array
    work_pos: jax.Array
    drift_before: jax.Array
    drift_after: jax.Array
    impact_energy_gain: jax.Array
    friction_ratio: jax.Array
    n_events: jax.Array
    n_releases: jax.Array
    element_events: jax.Array
    element_releases: jax.Array
    n_log_used: jax.Array
    log_t: jax.Array
    log_x: jax.Array
    log_u: jax.Array
    log_active: jax.Array
    log_ctrl: jax.Array
    log_force: jax.Array


def _fell(x, settings: Settings):
    q = x[:9]
    return (q[1] < settings.min_hip_height) | (jnp.abs(q[2] - jnp.pi / 2) > settings.max_body_tilt)


def _friction_ratio(lam):
    """max over feet of |F_t| / F_n (feet carrying > 10 N)."""
    out = 0.0
    for f in range(2):
        fn = lam[2 * f] + lam[2 * f + 1]
        ft = lam[4 + 2 * f] + lam[4 + 2 * f + 1]
        out = jnp.maximum(out, jnp.where(fn > 10.0, jnp.abs(ft) / jnp.maximum(fn, 1e-9), 0.0))
    return out


@pytree
class Plant:
    """The plant state of the sampled loop (:func:`closed_loop`): time t (s), x (18,), active
    elements (6,), no-slip anchors (4,) (m), sample index k, status, and the records of
    :class:`SimResult` (touchdowns, work, drift, events, logs every ``log_every`` samples).
    Entries of td_* and log_t past their counts hold 0 (NaN in :class:`SimResult`), and dke
    the most negative float while no event happened (-inf in :class:`SimResult`): the loop's
    finiteness check looks at every leaf."""

    t: jax.Array
    x: jax.Array
    active: jax.Array
    anchors: jax.Array
    k: jax.Array
    status: jax.Array
    ntd: jax.Array
    last_td: jax.Array
    last_contact: jax.Array
    td_time: jax.Array
    td_foot: jax.Array
    td_heel_x: jax.Array
    td_hip_x: jax.Array
    td_work: jax.Array
    work_abs: jax.Array
    work_pos: jax.Array
    drift_before: jax.Array
    drift_after: jax.Array
    dke: jax.Array
    events: jax.Array
    releases: jax.Array
    friction: jax.Array
    el_rel: jax.Array
    el_ev: jax.Array
    n_log: jax.Array
    log_t: jax.Array
    log_x: jax.Array
    log_u: jax.Array
    log_active: jax.Array
    log_ctrl: jax.Array
    log_force: jax.Array


_NO_EVENT = float(np.finfo(np.float64).min)


def running(S: Settings, pl: Plant) -> jax.Array:
    """Whether the walk goes on: no failure, time left, fewer than ``S.steps`` touchdowns."""
    return (pl.status == OK) & (pl.k < S.n_samples) & (pl.ntd < S.steps)


def initial_plant(r: sl.SevenLink, x0, active0, nlog_c: int, S: Settings) -> Plant:
    """The plant at t = 0: x0 projected onto active0, anchors at the contact points' x."""
    n_td = S.steps + 2
    P0 = jnp.stack([sl.point_position(r, x0[:9], n) for n in sl.CONTACTS])
    anchors0 = P0[:, 0]
    x0, _ = project(r, jnp.asarray(x0, jnp.float64), active0, anchors0)
    zero = jnp.zeros((), jnp.float64)
    nl = S.n_log
    return Plant(t=zero, x=x0, active=jnp.asarray(active0), anchors=anchors0, k=jnp.asarray(0),
                 status=jnp.asarray(OK), ntd=jnp.asarray(0, jnp.int32), last_td=zero,
                 last_contact=jnp.where(jnp.stack([active0[0] | active0[1], active0[2] | active0[3]]), 0.0, -1.0),
                 td_time=jnp.zeros(n_td), td_foot=jnp.full(n_td, -1), td_heel_x=jnp.zeros(n_td),
                 td_hip_x=jnp.zeros(n_td), td_work=jnp.zeros((n_td, 2)),
                 work_abs=jnp.zeros(6), work_pos=jnp.zeros(6), drift_before=jnp.zeros(2), drift_after=jnp.zeros(2),
                 dke=jnp.full((), _NO_EVENT), events=jnp.asarray(0, jnp.int32), releases=jnp.asarray(0), friction=zero,
                 el_rel=jnp.zeros(N_ELEMENTS, jnp.int32), el_ev=jnp.zeros(N_ELEMENTS, jnp.int32),
                 n_log=jnp.asarray(0), log_t=jnp.zeros(nl), log_x=jnp.zeros((nl, 18)),
                 log_u=jnp.zeros((nl, 6)), log_active=jnp.zeros((nl, N_ELEMENTS), bool),
                 log_ctrl=jnp.zeros((nl, nlog_c)), log_force=jnp.zeros((nl, N_ELEMENTS)))


def transition(r: sl.SevenLink, S: Settings) -> hybrid.MultiTransition:
    """The contacts as a :class:`bipedlab.sim.hybrid.MultiTransition` over the discrete state
    ``d = dict(active (6,), anchors (4,), drift_before (2,), dke)``: the constrained flow with
    the active set held; the guard: the inactive elements whose gap is below ``-S.gap_tol``;
    the reset: anchors of the new contacts at their x, the plastic impact (:func:`impact`),
    the projection onto the new active set, and the largest kinetic energy change so far
    (``dke``); after every accepted step the projection (:func:`project`) with the largest drift
    before it (``drift_before``, position and velocity). RK4's four stages are one scan
    (:func:`bipedlab.sim.integrators.rk4_scan`): the sample loop holds the contact solve once."""

    def flow_(x, u, d):
        return flow(r, x, u, d["active"])

    def guard(x, d):
        return ~d["active"] & (gaps(r, x[:9]) < -S.gap_tol)

    def project_(x, d):
        xp, res = project(r, x, d["active"], d["anchors"])
        return xp, dict(d, drift_before=jnp.maximum(d["drift_before"], jnp.stack(res)))

    def reset(x, d, new):
        q = x[:9]
        P = jnp.stack([sl.point_position(r, q, n) for n in sl.CONTACTS])
        anchors = jnp.where(new[:4], P[:, 0], d["anchors"])
        ke0 = sl.kinetic_energy(r, q, x[9:])
        xe, _, act = impact(r, x, d["active"], new)
        xe, _ = project(r, xe, act, anchors)
        ke1 = sl.kinetic_energy(r, xe[:9], xe[9:])
        return xe, dict(d, active=act, anchors=anchors, dke=jnp.maximum(d["dke"], ke1 - ke0))

    return hybrid.MultiTransition(flow=flow_, guard=guard, reset=reset, project=project_, tol=S.event_tol,
                                  max_iterations=400, integrator=rk4_scan)


def integrate(r: sl.SevenLink, S: Settings, t0, x, u, active, anchors, stats):
    """One sample interval [t0, t0 + S.sample] under the held u, with event location and
    impacts: the core's :func:`bipedlab.sim.hybrid.flow_sample` on :func:`transition`, RK4
    sub-steps of ``S.sample / S.substeps`` (each accepted one projected onto the active
    constraints); a sub-step that crosses a guard is bisected to ``S.event_tol`` s, then the
    impact applies. Returns (t_end, x, active, anchors, stats)."""
    d = dict(active=active, anchors=anchors, drift_before=stats["drift_before"], dke=stats["dke"])
    x, d, seen = hybrid.flow_sample(transition(r, S), x, d, u, t0, S.sample, S.sample / S.substeps)
    stats = dict(stats, drift_before=d["drift_before"], dke=d["dke"], events=stats["events"] + seen.events,
                 new=stats["new"] | seen.crossed, nonfinite=stats["nonfinite"] | ~seen.finite, stuck=~seen.resolved)
    return t0 + S.sample, x, d["active"], d["anchors"], stats


def plant_sample(r: sl.SevenLink, S: Settings, c: Plant, u, ctrl_log) -> Plant:
    """One control sample of the plant under the held torques u (6,): release pulling
    elements, integrate with events (:func:`integrate`), then the records (work, drift,
    touchdowns, status, the log row with the controller's ``ctrl_log``)."""
    n_td = S.steps + 2
    t, x, active, anchors = c.t, c.x, c.active, c.anchors
    active, forces, released = release(r, x, u, active, force_tol=S.release_force_tol)
    lam = constraint_forces(r, x, u, active)
    stats = dict(drift_before=c.drift_before, dke=c.dke, events=c.events,
                 new=jnp.zeros(N_ELEMENTS, bool), nonfinite=jnp.asarray(False))
    phid0 = sl.joint_rates(x[9:])
    t1, x1, active1, anchors1, stats = integrate(r, S, t, x, u, active, anchors, stats)
    phid1 = sl.joint_rates(x1[9:])
    power = u * 0.5 * (phid0 + phid1)  # trapezoid over the sample (u held)
    drift_after = jnp.maximum(c.drift_after, jnp.stack(residual(r, x1, active1, anchors1)))
    # touchdowns: a contact made by a foot that had been off the ground for min_flight
    feet_before = jnp.stack([active[0] | active[1], active[2] | active[3]])
    feet_after = jnp.stack([active1[0] | active1[1], active1[2] | active1[3]])
    feet_new = jnp.stack([stats["new"][0] | stats["new"][1], stats["new"][2] | stats["new"][3]])
    airborne = t - c.last_contact >= S.min_flight
    td = feet_new & ~feet_before & airborne
    last_contact = jnp.where(feet_before | feet_after | feet_new, t1, c.last_contact)
    ntd = c.ntd
    rec = {}
    work_abs = c.work_abs + S.sample * jnp.abs(power)
    work_pos = c.work_pos + S.sample * jnp.maximum(power, 0.0)
    rec.update(td_time=c.td_time, td_foot=c.td_foot, td_heel_x=c.td_heel_x, td_hip_x=c.td_hip_x, td_work=c.td_work)
    for f in range(2):
        heel = sl.point_position(r, x1[:9], sl.CONTACTS[2 * f + 1])
        i = jnp.minimum(ntd, n_td - 1)
        rec["td_time"] = jnp.where(td[f], rec["td_time"].at[i].set(t1), rec["td_time"])
        rec["td_foot"] = jnp.where(td[f], rec["td_foot"].at[i].set(f), rec["td_foot"])
        rec["td_heel_x"] = jnp.where(td[f], rec["td_heel_x"].at[i].set(heel[0]), rec["td_heel_x"])
        rec["td_hip_x"] = jnp.where(td[f], rec["td_hip_x"].at[i].set(x1[0]), rec["td_hip_x"])
        rec["td_work"] = jnp.where(td[f], rec["td_work"].at[i].set(jnp.stack([jnp.sum(work_abs),
                                                                              jnp.sum(work_pos)])),
                                   rec["td_work"])
        ntd = ntd + td[f].astype(jnp.int32)
    last_td = jnp.where(jnp.any(td), t1, c.last_td)
    stalled = (t1 - last_td) > S.max_step_time
    fell = _fell(x1, S) | stalled
    bad = stats["nonfinite"] | ~jnp.all(jnp.isfinite(x1))
    status = jnp.where(bad, NONFINITE, jnp.where(stats["stuck"], STUCK, jnp.where(fell, FELL, OK)))
    k = c.k
    li = k // S.log_every
    do_log = (k % S.log_every) == 0
    for key, val in (("log_t", t), ("log_x", x), ("log_u", u), ("log_active", active),
                     ("log_ctrl", ctrl_log), ("log_force", forces)):
        rec[key] = jnp.where(do_log, getattr(c, key).at[li].set(val), getattr(c, key))
    return c.replace(t=t1, x=jnp.where(bad, x, x1), active=active1, anchors=anchors1, k=k + 1,
                     status=status, ntd=ntd, last_td=last_td, last_contact=last_contact, work_abs=work_abs,
                     work_pos=work_pos, drift_before=stats["drift_before"], drift_after=drift_after, dke=stats["dke"],
                     events=stats["events"], releases=c.releases + jnp.sum(released),
                     el_rel=c.el_rel + released.astype(jnp.int32), el_ev=c.el_ev + stats["new"].astype(jnp.int32),
                     friction=jnp.maximum(c.friction, _friction_ratio(lam)),
                     n_log=jnp.where(do_log, li + 1, c.n_log), **rec)


def closed_loop(r: sl.SevenLink, policy: Callable, settings: Settings, log_fn: Callable,
                robot_of: Callable | None = None) -> SampledLoop:
    """The walk as a :class:`bipedlab.sim.loop.SampledLoop` over ``params = policy params``
    (with ``robot_of``, the plant's robot is ``robot_of(params)`` instead of r, so plants of
    one structure share the compiled program):
    the sensor hands the controller the plant (exact state and contact switches; the
    Section V-A estimation is the policy's), the controller runs ``policy(params, cstate, t,
    x, active) -> (u, cstate)`` and hands the plant (u, ``log_fn(cstate)``); the plant step is
    :func:`plant_sample` (the event-driven sub-stepping is its own, so one plant step per
    sample). Once the walk stops (:func:`running`), plant and controller hold their states."""
    S = settings

    def controller(p, cstate, pl, t):
        def go(_):
            u, c1 = policy(p, cstate, pl.t, pl.x, pl.active)
            return c1, (u, log_fn(c1))

        def hold(_):
            return cstate, (jnp.zeros(6), log_fn(cstate))

        return jax.lax.cond(running(S, pl), go, hold, None)

    robot = (lambda p: r) if robot_of is None else robot_of

    def plant_step(p, pl, u, d, h, t):
        return jax.lax.cond(running(S, pl), lambda _: plant_sample(robot(p), S, pl, *u), lambda _: pl, None)

    return SampledLoop(plant_step=plant_step, sensor=lambda p, s, pl, t: (s, pl), controller=controller,
                       fell=lambda p, pl0, y, u, pl: pl.status != OK, sample_time=S.sample)


def result(s: LoopState, settings: Settings) -> SimResult:
    """:class:`SimResult` from the loop's final state."""
    c = s.x
    td = lambda a: jnp.where((jnp.arange(a.shape[0]) < c.ntd).reshape((-1,) + (1,) * (a.ndim - 1)), a, jnp.nan)  # noqa: E731
    log_t = jnp.where(jnp.arange(c.log_t.shape[0]) < c.n_log, c.log_t, jnp.nan)
    dke = jnp.where(c.events > 0, c.dke, -jnp.inf)
    return SimResult(c.status, c.t, c.x, c.active, s.ctrl, c.ntd, td(c.td_time), c.td_foot, td(c.td_heel_x),
                     td(c.td_hip_x), td(c.td_work), c.work_abs, c.work_pos, c.drift_before, c.drift_after, dke,
                     c.friction, c.events, c.releases, c.el_ev, c.el_rel, c.n_log, log_t, c.log_x, c.log_u,
                     c.log_active, c.log_ctrl, c.log_force)


#: :func:`initial_plant` compiled once per (log width, settings), the robot a traced argument
#: (a jit of a fresh closure per walk compiled it again on every call).
_initial_plant = jax.jit(initial_plant, static_argnums=(3, 4))


def simulate(r: sl.SevenLink, policy: Callable, params, cstate0, x0, active0, settings: Settings = Settings(),
             log_fn: Callable | None = None, loop: SampledLoop | None = None, chunk: int = 250) -> SimResult:
    """Run the closed loop from (x0, active0) (x0 is projected onto active0 first) with
    :func:`bipedlab.sim.loop.simulate`, in compiled chunks of ``chunk`` samples until the
    walk stops (:func:`running`).

    ``policy(params, cstate, t, x, active) -> (u (6,), cstate)`` is called once per sample;
    ``log_fn(cstate) -> (k,)`` picks what of the controller state is logged; pass ``loop``
    (:func:`closed_loop` of the same arguments) to reuse its compiled chunks."""
    log_fn = log_fn or (lambda c: jnp.zeros(0))
    loop = loop or closed_loop(r, policy, settings, log_fn)
    nlog_c = jax.eval_shape(log_fn, cstate0).shape[0]
    plant0 = _initial_plant(r, jnp.asarray(x0, jnp.float64), jnp.asarray(active0), nlog_c, settings)
    s0 = loop_initial_state(plant0, None, cstate0)
    s, _ = loop_simulate(loop, params, s0, settings.n_samples, chunk=chunk,
                         until=lambda s: not bool(running(settings, s.x)))
    return result(s, settings)
