"""Virtual constraints, input-output linearisation and the hybrid zero dynamics.

Outputs ``y = H0 q - h_d(theta)`` on the stance coordinates q, with the phase
``theta = c . q`` strictly increasing over a step and ``h_d`` one Bézier polynomial per output
in ``s = (theta - theta_plus) / (theta_minus - theta_plus)``. With ``qdd = a + b u`` (from
:func:`bipedlab.mechanics.stance.stance_affine`), the Lie derivatives come from forward-mode
autodiff of the output function (any ``h(q)`` works, see :func:`lie_derivatives`):

    ydd = Lf2h + LgLfh u,   u* = -LgLfh^-1 Lf2h                         (eq. 32)
    u = u* - LgLfh^-1 (Kp / eps^2 y + Kd / eps yd)                         (eq. 42)

On the zero dynamics manifold Z = {y = 0, yd = 0} the state is fixed by (theta, thetadot):
``q = A^-1 [h_d(theta); theta]`` and ``qd = A^-1 [h_d'(theta); 1] thetadot`` with A = [H0; c].
"""
from __future__ import annotations

import dataclasses
from typing import Callable

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.mechanics.stance import Stance, ground_reaction, pinned_terms, stance_affine
from bipedlab.control import bezier as bz


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class VirtualConstraints:
    """H0 (m, n), c (n,), alpha (m, M+1) Bézier coefficients, theta_plus / theta_minus (rad)
    the phase at the start and the end of the step."""

    H0: jax.Array
    c: jax.Array
    alpha: jax.Array
    theta_plus: jax.Array
    theta_minus: jax.Array

    @property
    def order(self) -> int:
        return self.alpha.shape[-1] - 1


def phase(vc: VirtualConstraints, q):
    return vc.c @ q


def desired(vc: VirtualConstraints, theta):
    """(h_d, dh_d/dtheta, d2h_d/dtheta2) at theta, each (m,)."""
    w = vc.theta_minus - vc.theta_plus
    s = (theta - vc.theta_plus) / w
    return bz.bezier(vc.alpha, s), bz.bezier_d(vc.alpha, s) / w, bz.bezier_dd(vc.alpha, s) / (w * w)


def output(vc: VirtualConstraints, q):
    """y = H0 q - h_d(theta(q))."""
    return vc.H0 @ q - desired(vc, phase(vc, q))[0]


def lie_derivatives(h: Callable, q, qd, a, b):
    """(y, yd, Lf2h, LgLfh) of an output y = h(q) for qdd = a + b u, by forward-mode autodiff."""
    y, yd = jax.jvp(h, (q,), (qd,))
    _, curv = jax.jvp(lambda q_: jax.jvp(h, (q_,), (qd,))[1], (q,), (qd,))
    dh = jax.jacfwd(h)(q)
    return y, yd, curv + dh @ a, dh @ b


def _split(st: Stance, z):
    return z[: st.n], z[st.n:]


def output_state(vc: VirtualConstraints, st: Stance, z):
    """(y, yd) at stance state z."""
    q, qd = _split(st, z)
    return jax.jvp(lambda q_: output(vc, q_), (q,), (qd,))


def decoupling(vc: VirtualConstraints, st: Stance, z):
    """(y, yd, Lf2h, LgLfh) at stance state z."""
    q, qd = _split(st, z)
    a, b, _, _ = stance_affine(st, z)
    return lie_derivatives(lambda q_: output(vc, q_), q, qd, a, b)


def u_star(vc: VirtualConstraints, st: Stance, z):
    """The input that keeps y identically zero on Z (eq. 32)."""
    _, _, L2, LgLf = decoupling(vc, st, z)
    return -jnp.linalg.solve(LgLf, L2)


def io_linearizing(vc: VirtualConstraints, st: Stance, z, eps=0.1, kp=1.0, kd=2.0):
    """Input-output linearising control (eq. 42): ydd = -(kp/eps^2) y - (kd/eps) yd."""
    y, yd, L2, LgLf = decoupling(vc, st, z)
    return -jnp.linalg.solve(LgLf, L2 + (kp / eps**2) * y + (kd / eps) * yd)


def pd_control(vc: VirtualConstraints, st: Stance, z, kp, kd, feedforward=None):
    """u = u_ff - Kp y - Kd yd; with ``feedforward=None`` the exact u* is used as u_ff."""
    y, yd = output_state(vc, st, z)
    ff = u_star(vc, st, z) if feedforward is None else feedforward
    return ff - kp * y - kd * yd


def lift(vc: VirtualConstraints, theta, theta_dot):
    """The state on Z with phase theta and rate theta_dot: (q, qd)."""
    theta = jnp.asarray(theta, dtype=float)
    A = jnp.concatenate([vc.H0, vc.c[None, :]], 0)
    hd, dhd, _ = desired(vc, theta)
    q = jnp.linalg.solve(A, jnp.concatenate([hd, theta[None]]))
    qd = jnp.linalg.solve(A, jnp.concatenate([dhd, jnp.ones(1)])) * theta_dot
    return q, qd


def zero_dynamics(vc: VirtualConstraints, st: Stance, theta, theta_dot):
    """(theta_ddot, u*, ground reaction, z) on Z at (theta, theta_dot).

    On Z the stance accelerations are ``qdd = s1 theta_ddot + s2 theta_dot^2`` with
    ``s1 = A^-1 [h_d'; 1]`` and ``s2 = A^-1 [h_d''; 0]`` (A = [H0; c]), and the pinned point's
    constraint gives the base's, so ``M qdd + bias = B u + J^T lambda`` is one square system in
    (theta_ddot, u, lambda). The same solution as eliminating u through the decoupling matrix
    (``u* = -LgLfh^-1 Lf2h``, :func:`u_star`), at a fraction of the operations: the design
    evaluates this at every RK4 stage, inside its forward-mode Jacobian."""
    theta = jnp.asarray(theta, dtype=float)
    A = jnp.concatenate([vc.H0, vc.c[None, :]], 0)
    hd, dhd, ddhd = desired(vc, theta)
    one, zero = jnp.ones(1), jnp.zeros(1)
    sol = jnp.linalg.solve(A, jnp.stack([jnp.concatenate([hd, theta[None]]), jnp.concatenate([dhd, one]),
                                         jnp.concatenate([ddhd, zero])], 1))
    q, s1, s2 = sol[:, 0], sol[:, 1], sol[:, 2]
    z = jnp.concatenate([q, s1 * theta_dot])
    model = st.model
    M, h, J, jd = pinned_terms(st, z)
    Js = J[:, 2:]  # d(point)/d(base x, y) is the identity
    td2 = theta_dot * theta_dot
    p1 = jnp.concatenate([-(Js @ s1), s1])
    p0 = jnp.concatenate([-jd - (Js @ s2) * td2, s2 * td2])
    # the unactuated rows N (N B = 0) hold (theta_ddot, lambda); B's pseudo-inverse then gives u
    N, Bp = _actuation_split(model)
    rhs = M @ p0 + h
    K = jnp.concatenate([(N @ (M @ p1))[:, None], -(N @ J.T)], 1)
    w = _solve_small(K, -(N @ rhs))
    lam = w[1:]
    u = Bp @ (M @ p1 * w[0] + rhs - J.T @ lam)
    return w[0], u, lam, z


def _actuation_split(model):
    """(N, B+): an orthonormal basis of the rows annihilating the actuation matrix B and B's
    pseudo-inverse (constants of the model)."""
    B = np.asarray(model.actuation_matrix(), float)
    U, sv, _ = np.linalg.svd(B)
    rank = int(np.sum(sv > 1e-12 * max(sv.max(initial=0.0), 1.0)))
    return U[:, rank:].T, np.linalg.pinv(B)


def _solve_small(K, b):
    """K^-1 b for the 3 x 3 system of a point-foot stance (Cramer's rule written out: no
    factorisation call per evaluation); any other size by LU."""
    if K.shape != (3, 3):
        return jnp.linalg.solve(K, b)
    c0 = jnp.cross(K[:, 1], K[:, 2])
    det = K[:, 0] @ c0
    return jnp.stack([b @ c0, K[:, 0] @ jnp.cross(b, K[:, 2]), K[:, 0] @ jnp.cross(K[:, 1], b)]) / det


def closed_loop_flow(vc: VirtualConstraints, st: Stance, control: Callable):
    """zdot = f(z) + g(z) control(z) as a function of z."""

    def f(z, _u=None):
        a, b, _, _ = stance_affine(st, z)
        u = control(z)
        return jnp.concatenate([z[st.n:], a + b @ u])

    return f


# ------------------------------------------------------------------ pieces on given terms
# For models written as D qdd + H = B u (a robot's own reduced stance dynamics) and outputs
# y = H0 q - h_d(theta) with a linear phase theta = c . q, the Lie derivatives follow from the
# output's Jacobian and curvature without differentiating the dynamics again.


def linear_phase_output_jacobian(H0, c, dh):
    """dy/dq (m, n) of y = H0 q - h_d(c . q), given dh_d/dtheta (m,)."""
    return H0 - dh[:, None] * c[None, :]


def affine_decoupling(Jy, curvature, D, H, B):
    """(LgLfh (m, nu), Lf2h (m,)) of outputs with Jacobian Jy (m, n) and curvature
    ``d(Jy)/dt qd`` (m,) along ``D qdd + H = B u``: ydd = Lf2h + LgLfh u."""
    nu = B.shape[1]
    DiB = jnp.linalg.solve(D, jnp.concatenate([B, H[:, None]], 1))
    return Jy @ DiB[:, :nu], -Jy @ DiB[:, nu] + curvature


def outer_loop(y, yd, eps, kp, kd):
    """The linear outer loop of eq. 42: v = -(kp/eps^2) y - (kd/eps) yd."""
    return -(kp / eps**2) * y - (kd / eps) * yd


def linearizing_input(LgLf, Lf2h, v):
    """The input giving ydd = v: u = LgLfh^-1 (v - Lf2h)."""
    return jnp.linalg.solve(LgLf, v - Lf2h)


def feedforward_input(LgLf, Lf2h):
    """u* of eq. 32 from given terms: LgLfh^-1 (-Lf2h)."""
    return jnp.linalg.solve(LgLf, -Lf2h)


__all__ = [
    "VirtualConstraints", "phase", "desired", "output", "lie_derivatives", "output_state",
    "decoupling", "u_star", "io_linearizing", "pd_control", "lift", "zero_dynamics",
    "closed_loop_flow", "ground_reaction", "linear_phase_output_jacobian", "affine_decoupling", "outer_loop",
    "linearizing_input", "feedforward_input",
]
