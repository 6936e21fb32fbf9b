"""The controller's simplified model of the running robot (running paper, Section III-A) and
the three linear solves built on it: flight LQR (III-C), stance inverse dynamics (eq. 8,
III-D) and the sliding transition (III-E).

All functions take the *local* coordinates q6 = (x, y, theta, g_a, g_b, l_a), leg a being the
stance (or landing) leg and b the other, with the conventions of
:mod:`bipedlab.robots.atrias.robot`. Feet are massless (m_f dropped), so the COM is the trunk COM
and the stance dynamics are eq. (3): M6 = diag(m, m, I_t, I_m, I_m, 0).
"""
from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import scipy.linalg

from bipedlab.pytree import pytree


@pytree
class ModelParams:
    """What the controller believes (scaled by the model-error draws)."""

    m: float
    I_t: float
    I_m: float
    d: float
    mu: float
    g: float = 9.81
    m_f: float = 0.0   # foot point mass per leg: only for the whole-robot COM energy estimate


def system_com(mp, q, qd):
    """Whole-robot COM position and velocity (trunk plus the two foot point masses) from the
    7 coordinates in either leg order. Ballistic in flight, so its translational energy at
    lift-off is exactly the apex energy; the controller's stance model stays massless-foot."""
    th, thd = q[2], qd[2]
    hip = jnp.array([q[0] - mp.d * jnp.sin(th), q[1] - mp.d * jnp.cos(th)])
    hipd = jnp.array([qd[0] - mp.d * jnp.cos(th) * thd, qd[1] + mp.d * jnp.sin(th) * thd])
    pos, vel = mp.m * q[:2], mp.m * qd[:2]
    for gi, li in ((3, 5), (4, 6)):
        g, l, gd, ld = q[gi], q[li], qd[gi], qd[li]
        e = jnp.array([jnp.sin(g), jnp.cos(g)])
        ed = jnp.array([jnp.cos(g), -jnp.sin(g)]) * gd
        pos = pos + mp.m_f * (hip + l * e)
        vel = vel + mp.m_f * (hipd + ld * e + l * ed)
    mt = mp.m + 2 * mp.m_f
    return pos / mt, vel / mt


def mass6(mp):
    return jnp.diag(jnp.array([mp.m, mp.m, mp.I_t, mp.I_m, mp.I_m, 0.0]))


def bias6(mp):
    return jnp.array([0.0, mp.m * mp.g, 0.0, 0.0, 0.0, 0.0])


def select6():
    """S (6x3): (tau_a, tau_b, F_a) -> generalised forces."""
    S = np.zeros((6, 3))
    S[2, 0] = S[2, 1] = -1.0
    S[3, 0] = S[4, 1] = S[5, 2] = 1.0
    return jnp.asarray(S)


def jac6(mp, q6):
    """Eq. (4): the stance foot Jacobian (2x6)."""
    th, g, l = q6[2], q6[3], q6[5]
    return jnp.array([[1.0, 0.0, -mp.d * jnp.cos(th), l * jnp.cos(g), 0.0, jnp.sin(g)],
                      [0.0, 1.0, mp.d * jnp.sin(th), -l * jnp.sin(g), 0.0, jnp.cos(g)]])


def jdot_qd6(mp, q6, qd6):
    th, g, l = q6[2], q6[3], q6[5]
    thd, gd, ld = qd6[2], qd6[3], qd6[5]
    return jnp.array([mp.d * jnp.sin(th) * thd ** 2 + 2 * ld * jnp.cos(g) * gd - l * jnp.sin(g) * gd ** 2,
                      mp.d * jnp.cos(th) * thd ** 2 - 2 * ld * jnp.sin(g) * gd - l * jnp.cos(g) * gd ** 2])


def virtual_leg(mp, q6):
    """Vector from the stance foot to the COM (eq. 7's direction times l_v)."""
    th, g, l = q6[2], q6[3], q6[5]
    return jnp.array([mp.d * jnp.sin(th) - l * jnp.sin(g), mp.d * jnp.cos(th) - l * jnp.cos(g)])


def inverse_dynamics(mp, q6, qd6, F, thdd=0.0):
    """Eq. (8): actuation (tau_a, tau_b, F_a) and accelerations (xdd, ydd, g_a dd, g_b dd, l dd)
    that produce the GRF F = (F_x, F_y) with pitch acceleration thdd on the constrained model
    (stationary foot). Returns z (8,)."""
    M, h, S, J = mass6(mp), bias6(mp), select6(), jac6(mp, q6)
    keep = jnp.array([0, 1, 3, 4, 5])
    P = jnp.zeros((8, 8))
    P = P.at[:6, :3].set(-S).at[:6, 3:].set(M[:, keep]).at[6:, 3:].set(J[:, keep])
    rhs = jnp.concatenate([J.T @ F - M[:, 2] * thdd - h, -J[:, 2] * thdd - jdot_qd6(mp, q6, qd6)])
    return jnp.linalg.solve(P, rhs)


def sliding_dynamics(mp, q6, qd6, tau_a, F_y, ldd, slide_dir):
    """Section III-E: with tau_a, the vertical GRF F_y and the leg acceleration ldd given,
    sliding friction F_x = -mu F_y slide_dir and the foot held vertically, solve for
    w = (tau_b, F_a, xdd, ydd, thdd, g_a dd, g_b dd, F_x)."""
    M, h, S, J = mass6(mp), bias6(mp), select6(), jac6(mp, q6)
    # unknown accelerations: x, y, th, g_a, g_b (l dd known)
    P = jnp.zeros((8, 8))
    P = P.at[:6, 0].set(-S[:, 1]).at[:6, 1].set(-S[:, 2]).at[:6, 2:7].set(M[:, :5]).at[:6, 7].set(-J[0])
    P = P.at[6, 2:7].set(J[1, :5])
    P = P.at[7, 7].set(1.0)
    rhs6 = S[:, 0] * tau_a + J[1] * F_y - M[:, 5] * ldd - h
    rhs = jnp.concatenate([rhs6, jnp.array([-J[1, 5] * ldd - jdot_qd6(mp, q6, qd6)[1],
                                            -mp.mu * F_y * slide_dir])])
    return jnp.linalg.solve(P, rhs)


# ---------------------------------------------------------------- flight LQR (III-C)

def flight_reduced_system(I_t: float, I_m: float):
    """(A_r, B_r) of the controllable subsystem x_r = (theta, g_a, theta', g_a'), u = (tau_a,
    tau_b); the other leg angle follows from the conserved angular momentum."""
    A = np.zeros((4, 4))
    A[0, 2] = A[1, 3] = 1.0
    B = np.zeros((4, 2))
    B[2, :] = -1.0 / I_t
    B[3, 0] = 1.0 / I_m
    return A, B


def lqr_gain(A, B, Q, R):
    """K = R^-1 B^T X with X the continuous algebraic Riccati solution (SciPy)."""
    return np.linalg.solve(R, B.T @ scipy.linalg.solve_continuous_are(A, B, Q, R))


def compensated_reference(mp, theta_star, C, H, w_theta, w_phi):
    """Best reachable trunk reference under the momentum constraint
    I_t th + I_m (g_a + g_b) = C (C' = H): minimises w_theta (th - th*)^2 +
    w_phi (phi - pi)^2 with phi = (C - I_t th) / (2 I_m). Returns (theta_dag, theta_dag')."""
    kap = mp.I_t / (2.0 * mp.I_m)
    th_phi = (C - 2.0 * jnp.pi * mp.I_m) / mp.I_t
    wp = w_phi * kap ** 2
    th = (w_theta * theta_star + wp * th_phi) / (w_theta + wp)
    thd = wp / (w_theta + wp) * H / mp.I_t
    return th, thd
