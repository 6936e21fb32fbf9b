"""The "nonkinematic" walking controller of the seven-link biped (Braun, Mitchell, Goldfarb).

1. Generalised control forces (eq. 4): seven spring-damper couples with fixed equilibria on
   ``phi_c = [theta, theta_1, phi_2, phi_3, theta_4, phi_5, phi_6]`` (body and thighs against
   the inertial frame, knees and ankles against their links),
   ``Q_d = -C^T (K_d (phi_c - phi_d) + B_d phi_c_dot)`` with ``phi_c = C q + c0`` (the forces of
   the couples as generalised forces in q, :func:`desired_forces`).
2. Per-leg states S1 stance, S2 push-off, S3 swing, S4 late swing, switched on the
   configuration only (Fig. 2b; the figure's logic is reconstructed from the text: states
   depend on whether toe and/or heel touch and whether the knee is at full extension):
   S1 -> S2 when the heel leaves the ground with the toe still on it (heel-off, the
   "preemptive push-off"); S2 -> S3 when the foot leaves the ground; S3 -> S4 when the knee
   reaches full extension; S4 -> S1 when the foot touches down (also from S3, a touchdown
   before the knee has extended). Each state selects the
   stiffness, damping and equilibrium of the thigh, knee and ankle couples of that leg
   (Table II); the body couple is the same in every state.
3. Torque map (eq. 7): ``u = (N R^-T E)^+ N R^-T Q_d`` with ``M = R^T R`` (Cholesky) and
   ``N = I - (A R^-1)^+ (A R^-1)``, A the active constraint rows (contact heights and no-slip
   rows of the touching toes and heels, the locked knees; others zeroed),
   :func:`torque_map`. It gives exactly the constrained acceleration ``R^-1 N R^-T Q_d`` when
   that is realisable and otherwise the least acceleration energy
   ``(qdd_d - qdd_u)^T M (qdd_d - qdd_u)``, with the least-norm u among equals.
   Unilateral check (``Params.unilateral_check``, on by default): the contact and knee
   stop forces that the model predicts under u are checked, and an element that would have
   to pull is left out of A and u recomputed (up to :data:`UNILATERAL_ITERATIONS` elements
   per sample). Without it, a foot flat on the ground in early stance gets an ankle torque
   that would need the toe to pull; the toe lifts, the next sample (toe off) presses it back,
   and the contact flickers at the sample rate (about 70 make/release events per step, each
   toe re-impact dissipating energy, with torque spikes); likewise the knee stops.
4. As in the experiment (Fig. 8 caption), a small constant torque presses a locked knee
   into its stop while its leg is in S1, so the knee unlocks only past that threshold. The
   controller reads a stance (S1) knee as locked while it is within
   :data:`STANCE_KNEE_LATCH_DEG` of its stop (``Params.stance_knee_latch``, on with the lock
   torque, i.e. on the boom setup): its stop row stays in A and the lock torque on. Read exactly (``phi_knee = 0``), the stance knee of Table II
   on the boom setup was lost at the first swing knee lock (0.384 s): the swing knee's impact
   lifts the stance knee 0.001 deg off its stop (below the knee encoder's 7.3e-3 deg), the
   controller read it as unlocked, the lock torque went off and eq. 7 with the knee free
   asked -4.5 N m of it, so it flexed to 30 deg by 0.61 s and the robot fell after 2
   touchdowns (with the latch the knee is back on its stop 1 ms later).

Sensing (Section V-A, optional): joint encoders quantised to 4.2e-3 deg (hip, ankle) and
7.3e-3 deg (knee); the body angle from the kinematics of the contact points when at least
two toes or heels touch (exact with two, least squares with more: the best-fit line through
them is made horizontal), else integrated from a gyro (white noise 0.05 deg/s/sqrt(Hz),
50 Hz first-order low-pass), blended back in over ``blend_time`` when the kinematics return;
velocities by backward differences of the reconstructed angles.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.pytree import pytree
from bipedlab.robots.seven_link import robot as sl
from bipedlab.robots.seven_link import contact as sc

S1, S2, S3, S4 = 0, 1, 2, 3
STATE_NAMES = ("S1 stance", "S2 push-off", "S3 swing", "S4 late swing")
#: Rows of phi_c = C q + c0.
C = np.zeros((7, 9))
C[0, 2] = 1.0
C[1, 3] = 1.0
C[2] = sl.JOINT_MAP[1]
C[3] = sl.JOINT_MAP[2]
C[4, 6] = 1.0
C[5] = sl.JOINT_MAP[4]
C[6] = sl.JOINT_MAP[5]
C0 = np.array([0.0, 0.0, 0.0, np.pi / 2, 0.0, 0.0, np.pi / 2])
PINV_RTOL = 1e-10
#: Elements the unilateral check of :func:`policy` may leave out of A per sample.
UNILATERAL_ITERATIONS = 2
#: A stance (S1) knee within this angle of its stop reads as locked (the Fig. 8 lock torque's
#: threshold; :func:`make_params`). Boom setup, Table II, 30 steps: 0.5, 1 and 2 deg walk
#: alike (0.892 m/s, 0.716-0.717 m, 1.245 Hz); one knee encoder count (7.3e-3 deg) falls after
#: 6 touchdowns. 1 deg shortens the hip-ankle distance by under 0.05 mm
#: (:data:`bipedlab.robots.seven_link.study.KNEE_EXTENDED_DEG`). The planar walks, which apply no
#: lock torque, read the knee exactly (the tuned gait with a 1 deg latch falls after 19
#: touchdowns, with 7.3e-3 deg it walks as before).
STANCE_KNEE_LATCH_DEG = 1.0


@pytree
class Gains:
    """Per state (rows S1-S4) and couple (columns body, thigh, knee, ankle): stiffness k
    (N m/rad), damping b (N m s/rad) and equilibrium ref (rad: body and thigh absolute angles,
    knee and ankle joint angles); knee_lock_torque (N m) on a locked knee in S1."""

    k: jax.Array
    b: jax.Array
    ref: jax.Array
    knee_lock_torque: jax.Array


def gains_from_table(k, b, ref_deg, knee_lock_torque: float = 0.0) -> Gains:
    f = lambda a: jnp.asarray(np.asarray(a, float))  # noqa: E731
    return Gains(f(k), f(b), f(np.deg2rad(np.asarray(ref_deg, float))), f(knee_lock_torque))


#: Table II as printed (k: N m, b: N m s, references in degrees; "-" entries, whose stiffness
#: is zero, as 0).
TABLE_II = dict(
    k=[[32, 80, 6, 0], [32, 15, 6, 40], [32, 15, 0.5, 10], [32, 0, 6, 10]],
    b=[[0.75, 4.9, 1, 1.25], [0.75, 0.6, 1, 1.25], [0.75, 0.6, 0.05, 0.5], [0.75, 1.2, 1, 0.5]],
    ref=[[87.5, 82, 0, 0], [87.5, 128, 0, -10], [87.5, 128, 0, 10], [87.5, 0, 0, 0]],
)


def paper_gains(knee_lock_torque: float = 0.0) -> Gains:
    """Table II (the hardware's parameters, tuned walking in a circle on a boom)."""
    return gains_from_table(TABLE_II["k"], TABLE_II["b"], TABLE_II["ref"], knee_lock_torque)


#: Table II retuned for the planar model (same layout and units), following Section III-A3:
#: see :func:`tuned_gains` for what changed and why.
TABLE_TUNED = dict(
    k=[[32, 72, 6, 0], [32, 15, 6, 20], [32, 15, 0.5, 10], [32, 0, 6, 10]],
    b=[[0.75, 4.9, 1, 1.5], [0.75, 1.5, 1, 1.25], [0.75, 1.5, 0.05, 0.5], [0.75, 1.2, 1, 0.5]],
    ref=[[87.5, 90, 0, 0], [87.5, 128, 0, -10], [87.5, 128, 0, 10], [87.5, 0, 0, 0]],
)


def tuned_gains(knee_lock_torque: float = 0.0) -> Gains:
    """Table II retuned for the planar model (:data:`TABLE_TUNED`); five entries differ
    (six numbers: the swing thigh damping is changed in S2 and S3 alike). Used with the
    unilateral check of :func:`policy` (``make_params(..., unilateral_check=True)``).

    With Table II and without the unilateral check the planar model walked, but at about
    twice the paper's speed (about 1.05 m/s, 0.76 m steps, 1.39 Hz), its chattering contacts
    dissipating energy in toe re-impacts; with the check (no chatter) Table II falls on the
    planar model after 5 touchdowns and walks on the boom setup (0.89 m/s,
    :mod:`bipedlab.robots.seven_link.setup`), whose foot turning and boom the planar model
    lacks. Following Section III-A3 (the stance thigh
    couple drives hip extension and so the energy entering each step; the push-off ankle
    stiffness delivers the push-off energy; the swing thigh couple shapes the swing):

    * stance thigh equilibrium theta_d1 (S1) 82 -> 90 deg: the stance spring drives hip
      extension less, so less energy enters each step (the main speed change);
    * stance thigh stiffness k_d1 (S1) 80 -> 72 N m/rad: the same effect, finer: speed
      0.58 -> 0.53 m/s and c_mt 0.306 -> 0.287 (70 gives 0.49 m/s, 0.45 m steps and c_mt
      0.263 but walks only from start speeds near 0.5 m/s; 65 falls);
    * stance ankle damping b_d3 (S1) 1.25 -> 1.5 N m s/rad: the ankle resists the roll over
      the stance foot a little more (Section III-A3's human-like ankle impedance): speed 0.53
      -> 0.50 m/s, 1.09 -> 1.06 Hz, c_mt 0.287 -> 0.284, and the start-speed basin widens
      from 0.45-0.55 to 0.40-0.55 m/s;
    * push-off ankle stiffness k_d3 (S2) 40 -> 20 N m/rad: less energy at push-off;
    * swing thigh damping b_d1 (S2, S3) 0.6 -> 1.5 N m s/rad: a smoother swing and a
      wider basin (back at 0.6 with the other changes the robot falls within 10 steps).

    Result (ideal sensing, default start, 30 and 60 steps alike): 0.495 m/s, 0.465 m steps,
    1.06 Hz, c_mt 0.284, about 6 contact/knee-stop events per step (one make per toe, heel
    and knee stop); it also walks 30 steps from start speeds 0.40-0.55 m/s (0.35 and 0.6
    fall) and with the Section V-A sensing (0.50 m/s, c_mt 0.287). Body, knee and the other
    ankle entries are Table II's.
    """
    return gains_from_table(TABLE_TUNED["k"], TABLE_TUNED["b"], TABLE_TUNED["ref"], knee_lock_torque)


# ----------------------------------------------------------------------------- eq. 4
def couple_coordinates(q):
    """phi_c (7,) from q."""
    return jnp.asarray(C) @ q + jnp.asarray(C0)


def couple_parameters(g: Gains, states):
    """(k (7,), b (7,), ref (7,)) for leg states (2,) int; the body couple from leg 1's row
    (identical in every state of Table II)."""
    s1, s2 = states[0], states[1]
    k = jnp.concatenate([g.k[s1, :1], g.k[s1, 1:], g.k[s2, 1:]])
    b = jnp.concatenate([g.b[s1, :1], g.b[s1, 1:], g.b[s2, 1:]])
    ref = jnp.concatenate([g.ref[s1, :1], g.ref[s1, 1:], g.ref[s2, 1:]])
    return k, b, ref


def desired_forces(g: Gains, states, q, qd):
    """Q_d of eq. 4 as generalised forces in q (9,)."""
    k, b, ref = couple_parameters(g, states)
    Cm = jnp.asarray(C)
    return -Cm.T @ (k * (couple_coordinates(q) - ref) + b * (Cm @ qd))


# ----------------------------------------------------------------------------- eq. 7
def cholesky_upper(M):
    """R upper triangular with M = R^T R."""
    return jnp.linalg.cholesky(M).T


def null_projector(M, A):
    """(R^-T, N): N = I - (A R^-1)^+ (A R^-1)."""
    R = cholesky_upper(M)
    Rinv_T = jax.scipy.linalg.solve_triangular(R.T, jnp.eye(M.shape[0]), lower=True)
    AR = A @ Rinv_T.T
    N = jnp.eye(M.shape[0]) - jnp.linalg.pinv(AR, rtol=PINV_RTOL) @ AR
    return Rinv_T, N


def torque_map(M, A, Qd, E=None):
    """u of eq. 7: ``(N R^-T E)^+ N R^-T Q_d``."""
    E = jnp.asarray(sl.E) if E is None else E
    Rinv_T, N = null_projector(M, A)
    NRE = N @ Rinv_T @ E
    return jnp.linalg.pinv(NRE, rtol=PINV_RTOL) @ (N @ Rinv_T @ Qd)


def constrained_acceleration(M, A, Q):
    """R^-1 N R^-T Q (eqs. 5, 6): the acceleration component that a generalised force Q
    produces on the constrained system."""
    Rinv_T, N = null_projector(M, A)
    return Rinv_T.T @ (N @ (Rinv_T @ Q))


def active_rows(r: sl.SevenLink, q, contacts, knees):
    """A of eq. 3 with inactive rows zeroed: per contact point its y and x rows, then the
    knee stops (12 x 9)."""
    J = jnp.stack([sl.point_jacobian(r, q, n) for n in sl.CONTACTS])  # (4, 2, 9)
    rows = jnp.concatenate([J[:, 1, :], J[:, 0, :]]) * jnp.concatenate([contacts, contacts])[:, None]
    kn = jnp.stack([jnp.asarray(sl.JOINT_MAP[sl.KNEES[0]]), jnp.asarray(sl.JOINT_MAP[sl.KNEES[1]])])
    return jnp.concatenate([rows, kn * knees[:, None]])


# ----------------------------------------------------------------------------- switching
def next_states(states, flat_seen, contacts, knees):
    """Fig. 2b per leg: (states (2,), flat_seen (2,)) after reading the contact switches
    (toe_1, heel_1, toe_2, heel_2) and the knee extension switches (2,)."""
    toe = contacts[0::2]
    heel = contacts[1::2]
    any_c = toe | heel
    s = states
    to2 = (s == S1) & flat_seen & ~heel
    to3 = (s == S2) & ~any_c
    to4 = (s == S3) & knees & ~any_c
    to1 = ((s == S4) | (s == S3)) & any_c
    new = jnp.where(to2, S2, jnp.where(to3, S3, jnp.where(to4, S4, jnp.where(to1, S1, s))))
    # heel-off counts only after the foot has been flat (heel down) in this stance
    flat = jnp.where(new == S1, (flat_seen & (s == S1)) | heel, False)
    return new, flat


# ----------------------------------------------------------------------------- the policy
@pytree
class Params:
    """Everything the policy needs, as a pytree: the robot model used by the controller,
    the gains, and the sensing options (sensing: 0 ideal, 1 Section V-A)."""

    robot: sl.SevenLink
    gains: Gains
    sensing: jax.Array
    sample: jax.Array
    blend_time: jax.Array
    velocity_cutoff_hz: jax.Array
    knee_tolerance: jax.Array
    knee_rows_in_stance_only: jax.Array
    unilateral_check: jax.Array
    stance_knee_latch: jax.Array


@pytree
class State:
    """Controller state: leg states (2,), flat_seen (2,), and the estimator's: body angle from
    the gyro, blend weight, previous angles (7,), filtered rates (7,), gyro filter, PRNG key,
    the first-sample flag, and the last Q_d (9,) for logging."""

    states: jax.Array
    flat_seen: jax.Array
    theta_gyro: jax.Array
    blend: jax.Array
    angles_prev: jax.Array
    rates: jax.Array
    gyro_filt: jax.Array
    key: jax.Array
    first: jax.Array
    Qd: jax.Array
    theta_est: jax.Array


def make_params(r: sl.SevenLink, gains: Gains, sensing: bool = False, sample: float = 1e-3,
                blend_time: float = 0.02, velocity_cutoff_hz: float = 100.0,
                knee_tolerance_deg: float = 0.0, knee_rows_in_stance_only: bool = False,
                unilateral_check: bool = True, stance_knee_latch_deg: float = 0.0) -> Params:
    """Controller parameters. knee_tolerance_deg: the knee counts as fully extended (its
    stop row enters A, its leg may switch S3 -> S4, the lock torque acts) within this angle
    of the stop, as an encoder threshold would; 0 reads the stop contact exactly.
    unilateral_check: leave out of A the elements whose predicted force would pull (see
    the module docstring); False is eq. 7 with every touching element in A.
    stance_knee_latch_deg: a knee whose leg is in S1 counts as locked within this angle of
    its stop (the lock torque's threshold, module docstring item 4; the boom setup's walks use
    :data:`STANCE_KNEE_LATCH_DEG` with the lock torque); 0 reads it exactly."""
    if stance_knee_latch_deg < 0.0 or knee_tolerance_deg < 0.0:
        raise ValueError(f"seven-link: knee thresholds must be >= 0 deg, got latch {stance_knee_latch_deg}, "
                         f"tolerance {knee_tolerance_deg}")
    f = lambda v: jnp.asarray(v, jnp.float64)  # noqa: E731
    return Params(r, gains, jnp.asarray(1 if sensing else 0), f(sample), f(blend_time), f(velocity_cutoff_hz),
                  f(np.deg2rad(knee_tolerance_deg)), jnp.asarray(bool(knee_rows_in_stance_only)),
                  jnp.asarray(bool(unilateral_check)), f(np.deg2rad(stance_knee_latch_deg)))


def initial_state(x0, states=(S1, S3), seed: int = 0) -> State:
    q, qd = x0[:9], x0[9:]
    return State(jnp.asarray(states, jnp.int32), jnp.asarray([s == S1 for s in states]), q[2], jnp.asarray(1.0),
                 q[2:9], qd[2:9], qd[2], jax.random.PRNGKey(seed), jnp.asarray(True), jnp.zeros(9), q[2])


def _quantise(v, res):
    return res * jnp.round(v / res)


def kinematic_body_angle(r: sl.SevenLink, phi, contacts, theta0):
    """Body angle that puts the touching toes/heels on a horizontal line (eq. 8): exact with
    two points, total least squares with more; theta0 is a nearby guess (the previous value)."""
    q0 = jnp.concatenate([jnp.zeros(2), sl.absolute_angles(theta0, phi)])
    P = jnp.stack([sl.point_position(r, q0, n) for n in sl.CONTACTS])
    w = contacts.astype(jnp.float64)
    n = jnp.maximum(jnp.sum(w), 1.0)
    c = (w @ P) / n
    D = (P - c) * w[:, None]
    S = D.T @ D
    # principal direction of the 2x2 scatter: angle = 0.5 atan2(2 Sxy, Sxx - Syy)
    ang = 0.5 * jnp.arctan2(2.0 * S[0, 1], S[0, 0] - S[1, 1])
    return theta0 - ang


def _measure(p: Params, c: State, x, contacts):
    """(q, qd, cstate) seen by the controller: exact, or the Section V-A estimate."""
    q_true, qd_true = x[:9], x[9:]

    def ideal(_):
        return q_true, qd_true, c.theta_gyro, c.blend, c.gyro_filt, c.key, q_true[2]

    def sensors(_):
        dt = p.sample
        phi = _quantise(sl.joint_angles(q_true), jnp.asarray(sl.ENCODER_RESOLUTION))
        key, sub = jax.random.split(c.key)
        sigma = sl.GYRO_NOISE_DENSITY * jnp.sqrt(0.5 / dt)
        alpha = dt / (dt + 1.0 / (2 * jnp.pi * sl.GYRO_CUTOFF_HZ))
        gyro = c.gyro_filt + alpha * (qd_true[2] + sigma * jax.random.normal(sub) - c.gyro_filt)
        theta_g = jnp.where(c.first, q_true[2], c.theta_gyro + dt * gyro)
        supported = jnp.sum(contacts) >= 2
        theta_k = kinematic_body_angle(p.robot, phi, contacts, c.theta_est)
        blend = jnp.where(supported, jnp.minimum(c.blend + dt / p.blend_time, 1.0), 0.0)
        blend = jnp.where(c.first, 1.0, blend)
        theta = jnp.where(supported, theta_g + blend * (theta_k - theta_g), theta_g)
        theta = jnp.where(c.first, q_true[2], theta)
        theta_g = jnp.where(blend >= 1.0, theta, theta_g)
        angles = sl.absolute_angles(theta, phi)
        beta = dt / (dt + 1.0 / (2 * jnp.pi * p.velocity_cutoff_hz))
        raw = (angles - c.angles_prev) / dt
        rates = jnp.where(c.first, qd_true[2:], c.rates + beta * (raw - c.rates))
        q = jnp.concatenate([jnp.zeros(2), angles])
        qd = jnp.concatenate([jnp.zeros(2), rates])
        return q, qd, theta_g, blend, gyro, key, theta

    return jax.lax.cond(p.sensing > 0, sensors, ideal, None)


def knees_locked(p: Params, states, active, phi):
    """(2,) whether the controller reads each knee as locked: on its stop (the active element),
    within ``p.knee_tolerance`` of it, or, for a leg in S1 (``states`` of the previous sample),
    within ``p.stance_knee_latch`` of it."""
    flex = jnp.stack([phi[sl.KNEES[0]], phi[sl.KNEES[1]]])
    return active[4:] | (flex > -p.knee_tolerance) | ((flex > -p.stance_knee_latch) & (states == S1))


def policy(p: Params, c: State, t, x, active):
    """One controller sample: sense, switch, eq. 4, eq. 7, knee lock torque.
    Returns (u (6,), new controller state)."""
    contacts = active[:4]
    q, qd, theta_g, blend, gyro, key, theta = _measure(p, c, x, contacts)
    phi = sl.joint_angles(q)
    knees = knees_locked(p, c.states, active, phi)
    states, flat = next_states(c.states, c.flat_seen, contacts, knees)
    Qd = desired_forces(p.gains, states, q, qd)
    qa = q.at[:2].set(0.0)  # A and M need only the angles
    M = sl.mass_matrix(p.robot, qa)
    knees_A = knees & (~p.knee_rows_in_stance_only | (states == S1) | (states == S4))
    lock = p.gains.knee_lock_torque * ((states == S1) & knees).astype(jnp.float64)

    def u_for(elements):
        A = active_rows(p.robot, qa, elements[:4].astype(jnp.float64), elements[4:].astype(jnp.float64))
        u = torque_map(M, A, Qd)
        return u.at[1].add(lock[0]).at[4].add(lock[1])

    elements = jnp.concatenate([contacts, knees_A])
    u = u_for(elements)

    def check(_, carry):
        # the unilateral check: the constraint forces the model predicts under u for the
        # elements kept in A; one that would have to pull is left out of A (most negative
        # first) and u recomputed, so the torque map never asks a toe, heel or knee stop to
        # pull (which the contact would answer by releasing, and the next sample by
        # pressing it back: chatter)
        el, u = carry
        xa = jnp.concatenate([qa, qd])
        _, lam = sc.solve(p.robot, xa, u, el)
        F = jnp.where(el, sc.element_forces(lam), 0.0)
        i = jnp.argmin(F)
        drop = (F[i] < 0.0) & p.unilateral_check
        el2 = jnp.where(drop, el.at[i].set(False), el)
        return el2, jnp.where(drop, u_for(el2), u)

    _, u = jax.lax.fori_loop(0, UNILATERAL_ITERATIONS, check, (elements, u))
    new = State(states, flat, theta_g, blend, q[2:9], qd[2:9], gyro, key, jnp.asarray(False), Qd, theta)
    return u, new


def log_vector(c: State):
    """What the simulation logs of the controller: leg states (2,) and the body-angle estimate."""
    return jnp.concatenate([c.states.astype(jnp.float64), c.theta_est[None]])
