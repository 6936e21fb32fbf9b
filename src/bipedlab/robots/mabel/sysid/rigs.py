"""The small plants of the identification experiments, shared by the data generators and the
estimators.

* :func:`motor_rig` - a rotor (plus a lumped chain of pulleys) with viscous friction,
  ``J w_dot + mu w = tau`` (eq. 7 in physical units), sampled exactly under a torque held over
  each 1 ms sample (zero-order hold): ``w[k+1] = a w[k] + (1 - a) tau[k] / mu`` with ``a =
  exp(-mu h / J)``, and the angle advanced by the exact integral of w over the sample.
* :class:`LegRig` - one leg with the torso fixed upright, the hip fixed and B_spring blocked
  (Section V): coordinates ``(q_mLA, q_mLS)`` with rigid cables, ``q_LA = q_mLA / -23.53`` and
  ``q_LS = q_mLS / 31.42``. It is the 13-DoF model's coupled mechanism restricted by a
  constant map, so the links (Table VII), pulleys (Table VIII) and rotors (alpha J^rotor,man)
  are exactly the hopping model's. ``D(q) qdd + C(q, qd) qd + G(q) = (u + b) / K_T - mu qd``
  (eqs. 17-18). A locked coordinate (SISO experiments) keeps zero velocity.
* :func:`rotor_cable` - the rotor of one motor pulled by its stretching cable (Section VII-B)
  and driven by the commanded torque, with the joint-side motion (the rigid-cable motor angle
  r(t) from the joint encoders, and the torso angle) as measured inputs. This is the motor's
  own equation of the 13-DoF model, exactly: only the rotor turns with q_m (the compliant
  segment sits between the rotor and its step-down pulley), so with psi = q_tor + q_m::

      J psi_ddot = (u + b) / K_T - mu q_m_dot - K_C (q_m - r) - Kd_C (q_m_dot - r_dot).

  It is integrated with the momentum-like state ``z = J psi_dot - mu q_tor - Kd_C s`` (``s =
  q_tor + r``), in which no derivative of a measured input appears: ``psi_dot = (z + mu q_tor
  + Kd_C s) / J``, ``z_dot = F - (mu + Kd_C) psi_dot - K_C (psi - s)``. Measured inputs are
  interpolated linearly between samples; RK4 (:func:`bipedlab.sim.integrators.rk4`) with
  ``substeps`` steps per sample, its stages reading the inputs at the nodes t, t + h/2, t + h.

Sample convention everywhere: row k of a log holds the readings at t_k = k h and the command
u_k applied over [t_k, t_k+1).
"""
from __future__ import annotations


import jax
import jax.numpy as jnp
import numpy as np
from scipy import signal

from bipedlab.pytree import pytree
from bipedlab.mechanics import coupled as cp
from bipedlab.robots.mabel import model as mm
from bipedlab.robots.mabel import tables as tb
from bipedlab.sim import integrators
from bipedlab.robots.mabel.sysid import params as P
from bipedlab.robots.mabel.sysid.sensors import PERIOD

_H = {c: i for i, c in enumerate(mm.COORDS_13)}


# ----- motor and pulley chain -------------------------------------------------------------
def motor_rig(J: float, mu: float, tau, h: float = PERIOD, omega0: float = 0.0, theta0: float = 0.0) -> np.ndarray:
    """Angles (N,) at t_0..t_N-1 of ``J w_dot + mu w = tau`` under the torques tau (N,), held
    over each sample (exact discretisation; any J, mu > 0)."""
    tau = np.asarray(tau, float)
    a = np.exp(-mu * h / J)
    beta = (1.0 - a) / mu
    gamma = (J / mu) * (1.0 - a)
    delta = (h - gamma) / mu
    k = np.arange(len(tau))
    omega = signal.lfilter([0.0, beta], [1.0, -a], tau) + omega0 * a**k
    step = gamma * omega + delta * tau
    return theta0 + np.concatenate([[0.0], np.cumsum(step[:-1])])


# ----- one leg, torso fixed ---------------------------------------------------------------
@pytree
class LegRig:
    """One leg on the fixed torso, B_spring blocked, rigid cables (a frozen pytree).

    body: the coupled mechanism in (q_mLA, q_mLS) of one leg; kt, bias (N m), friction
    (N m s/rad) for (mLA, mLS) of that leg. The two legs are built alike (Tables VII-VIII give
    one set of links and pulleys), so both sides share one structure - the left leg's tree
    with the side's rotor inertias - and one compiled simulation."""

    body: cp.Coupled
    kt: jax.Array
    bias: jax.Array
    friction: jax.Array



#: Actuators of each leg in rig order (q_mLA, q_mLS).
LEG_ACTUATORS = {s: (f"mLA_{s}", f"mLS_{s}") for s in tb.SIDES}


def leg_map(side: str) -> np.ndarray:
    """E (13 x 2) with q_h = E (q_mLA, q_mLS): hip and torso fixed, B_spring blocked at 0."""
    E = np.zeros((13, 2))
    E[_H[f"mla_{side}"], 0] = 1.0
    E[_H[f"la_{side}"], 0] = 1.0 / tb.GEAR_LA
    E[_H[f"mls_{side}"], 1] = 1.0
    E[_H[f"ls_{side}"], 1] = 1.0 / tb.GEAR_LS
    return E


def leg_rig(p: P.MabelParams, side: str) -> LegRig:
    """The leg rig of one side of a parameter set (the 13-DoF model's mechanism, restricted
    to the left leg's coordinates, with the side's rotor inertias and drivetrain values)."""
    idx = [P.ACTUATORS.index(a) for a in LEG_ACTUATORS[side]]
    left = [P.ACTUATORS.index(a) for a in LEG_ACTUATORS["L"]]
    alpha = np.asarray(p.alpha, float).copy()
    alpha[left] = np.asarray(p.alpha, float)[idx]
    m = P.model(p.replace(alpha=alpha))
    body = cp.restrict(m.body, leg_map("L"), ("mla", "mls"))
    f = lambda v: jnp.asarray(np.asarray(v, float)[idx])  # noqa: E731
    return LegRig(body, f(p.kt), f(p.bias), f(p.friction))


def leg_coordinates(q_mla, q_mls):
    """(q_LA, q_LS) of motor angles with rigid cables and B_spring blocked (eqs. 5-6)."""
    return q_mla / tb.GEAR_LA, q_mls / tb.GEAR_LS


def leg_motor_angles(la, ls):
    return tb.GEAR_LA * la, tb.GEAR_LS * ls


def leg_flow(rig: LegRig, x, u, active):
    """xdot for x = (q (2), qd (2)) under commands u (2,); ``active`` (2,) is 1 for a moving
    coordinate and 0 for a locked one, which keeps zero velocity (its equation is replaced by
    q_ddot = 0, the constraint force taking up the rest)."""
    q, qd = x[:2], x[2:]
    M = cp.mass_matrix(rig.body, q)
    h = cp.bias(rig.body, q, qd)
    tau = (u + rig.bias) / rig.kt - rig.friction * qd
    a = jnp.asarray(active, dtype=jnp.float64)
    both = a[:, None] * a[None, :]
    Mc = both * M + jnp.diag(1.0 - a)
    b = a * (tau - h)
    det = Mc[0, 0] * Mc[1, 1] - Mc[0, 1] * Mc[1, 0]   # two coordinates: Cramer's rule, no LAPACK call
    qdd = jnp.stack([Mc[1, 1] * b[0] - Mc[0, 1] * b[1], Mc[0, 0] * b[1] - Mc[1, 0] * b[0]]) / det
    return jnp.concatenate([qd, qdd])


def simulate_leg(rig: LegRig, x0, U, active=(True, True), substeps: int = 4, h: float = PERIOD) -> jax.Array:
    """Motor angles (N, 2) at t_0..t_N-1 from x0 under the held commands U (N, 2) (RK4);
    active (2,): which coordinates move (a locked one keeps its initial value)."""
    dt = h / substeps
    active = jnp.asarray(active, dtype=jnp.float64)

    def sample(x, u):
        x_next = jax.lax.fori_loop(0, substeps, lambda _, x: integrators.rk4(
            lambda x, u: leg_flow(rig, x, u, active), x, u, dt), x)
        return x_next, x[:2]

    return jax.lax.scan(sample, jnp.asarray(x0), jnp.asarray(U))[1]


def gravity_equilibrium_command(rig: LegRig, q) -> jax.Array:
    """Commands (2,) that hold the rig at rest at q: (u + b) / K_T = G(q)."""
    g = cp.bias(rig.body, jnp.asarray(q), jnp.zeros(2))
    return g * rig.kt - rig.bias


def linearisation(rig: LegRig, q):
    """(M, K) of the rig at rest at q: mass matrix and gravity stiffness dG/dq."""
    q = jnp.asarray(q)
    M = cp.mass_matrix(rig.body, q)
    K = jax.jacfwd(lambda q: cp.bias(rig.body, q, jnp.zeros(2)))(q)
    return np.asarray(M), np.asarray(K)


# ----- one rotor and its cable, joint side measured ----------------------------------------
@pytree
class RotorCable:
    """Parameters of one motor's rotor and cable: J (kg m^2, alpha J^rotor,man), kt, bias
    (N m), mu (N m s/rad), K (cable_k, N m/rad), D (cable_d, N m s/rad), torque limit (N m)."""

    J: jax.Array
    kt: jax.Array
    bias: jax.Array
    mu: jax.Array
    K: jax.Array
    D: jax.Array
    limit: jax.Array



def rotor_cable(rc: RotorCable, u, r, tor, qm0, substeps: int = 4, h: float = PERIOD) -> jax.Array:
    """Motor angles (N,) at t_0..t_N-1 (relative to the torso), starting at rest at qm0, under
    the commands u (N,), with the rigid-cable motor angle r (N,) and the torso angle tor (N,)
    measured at the samples (linearly interpolated between them)."""
    u, r, tor = (jnp.asarray(v, dtype=jnp.float64) for v in (u, r, tor))
    s = tor + r
    F = (jnp.clip(u, -rc.limit, rc.limit) + rc.bias) / rc.kt
    psi0 = qm0 + tor[0]
    z0 = -rc.mu * tor[0] - rc.D * s[0]
    dt = h / substeps

    def f(x, inp):
        psi, z = x[0], x[1]
        Fk, s_, tor_ = inp
        psid = (z + rc.mu * tor_ + rc.D * s_) / rc.J
        return jnp.stack([psid, Fk - (rc.mu + rc.D) * psid - rc.K * (psi - s_)])

    def staged(xc, nodes):
        # x augmented with a stage clock c (dc/dt = 1, 0 at the substep's start): RK4's
        # stages see c = 0, h/2, h/2, h exactly, and read the inputs interpolated at those nodes
        c = xc[2]
        inp = jax.tree_util.tree_map(lambda a, b, d: jnp.where(c < 0.25 * dt, a, jnp.where(c < 0.75 * dt, b, d)),
                                     *nodes)
        return jnp.concatenate([f(xc[:2], inp), jnp.ones(1)])

    def sample(x, k):
        s0, s1, t0, t1, Fk = s[k], s[k + 1], tor[k], tor[k + 1], F[k]

        def sub(j, x):
            a0 = j / substeps
            a1 = (j + 0.5) / substeps
            a2 = (j + 1.0) / substeps
            i0 = (Fk, s0 + a0 * (s1 - s0), t0 + a0 * (t1 - t0))
            i1 = (Fk, s0 + a1 * (s1 - s0), t0 + a1 * (t1 - t0))
            i2 = (Fk, s0 + a2 * (s1 - s0), t0 + a2 * (t1 - t0))
            return integrators.rk4(staged, jnp.concatenate([x, jnp.zeros(1)]), (i0, i1, i2), dt)[:2]

        x_next = jax.lax.fori_loop(0, substeps, sub, x)
        return x_next, x[0]

    x_last, psi = jax.lax.scan(sample, jnp.stack([psi0, z0]), jnp.arange(len(u) - 1))
    return jnp.concatenate([psi, x_last[:1]]) - tor


def rigid_motor_angle(actuator: str, la, ls, bsp):
    """The motor angle rigid cables would give (eqs. 5-6) from joint-side angles."""
    if actuator.startswith("mLA"):
        return tb.GEAR_LA * la
    return tb.GEAR_LS * ls - (tb.GEAR_LS / tb.GEAR_BSP) * bsp
