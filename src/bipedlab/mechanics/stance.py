"""Single-support stance model derived from the floating model by pinning a named point.

Any floating :class:`Model` becomes a stance model by holding one point (the stance toe) fixed
at the origin: the constrained dynamics

    M qdd + bias = B u + J^T lambda,    J qdd + Jdot qd = 0

give the accelerations and the ground reaction lambda, both affine in u. The stance state is
reduced to ``z = [q[2:], qd[2:]]`` (orientation and joints, with their rates): the base
position and velocity follow from the pinned point. A step ends when the swing point reaches
the ground; the rigid impact of that point, then the relabelling that swaps the legs, gives
the next stance state, with the new stance point again at the origin.
"""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from bipedlab.mechanics import kinematics as kin
from bipedlab.mechanics.dynamics import bias, bias_entries, dense, mass_matrix, mass_matrix_entries
from bipedlab.mechanics.impact import impact_map, relabel
from bipedlab.mechanics.kinematics import point_jacobian, point_jdot_qd, point_position, point_velocity
from bipedlab.mechanics.tree import Model


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Stance:
    """A model in single support on ``stance`` (point index) with ``swing`` the other foot;
    ``swap`` relabels full coordinate vectors so that the swing leg becomes the stance leg."""

    model: Model
    stance: int = dataclasses.field(metadata=dict(static=True))
    swing: int = dataclasses.field(metadata=dict(static=True))
    swap: tuple[int, ...] = dataclasses.field(metadata=dict(static=True))

    @property
    def n(self) -> int:
        """Number of stance coordinates (nq - 2)."""
        return self.model.nq - 2


def stance_from_names(model: Model, stance: str, swing: str, swap) -> Stance:
    return Stance(model, model.point_index(stance), model.point_index(swing), tuple(int(i) for i in swap))


def embed(st: Stance, z):
    """Full floating (q, qd) of stance state z, with the stance point at the origin, at rest."""
    n = st.n
    qs, qds = z[:n], z[n:]
    q0 = jnp.concatenate([jnp.zeros(2), qs])
    r = point_position(st.model, q0, st.stance)
    q = q0.at[:2].set(-r)
    J = point_jacobian(st.model, q, st.stance)
    qd = jnp.concatenate([-(J[:, 2:] @ qds), qds])
    return q, qd


def pinned_terms(st: Stance, z):
    """(M, bias, J, Jdot qd) of the floating model at stance state z with the stance point
    pinned, from one kinematic pass: none of them depends on the base's position, so the pass
    runs at the base's origin (the same values as ``mass_matrix``, ``bias``, ``point_jacobian``
    and ``point_jdot_qd`` at :func:`embed`'s full state)."""
    model, n = st.model, st.n
    qs, qds = z[:n], z[n:]
    q0 = jnp.concatenate([jnp.zeros(2), qs])
    fr = kin.frames(model, q0)
    zero = jnp.zeros_like(qs[0])
    J = kin.jacobian_from_frames(model, fr, st.stance, zero)
    qd = jnp.concatenate([-(J[:, 2:] @ qds), qds])
    vel = kin.velocities(model, fr, qd)
    jd = kin.jdot_qd_from_frames(model, fr, vel, st.stance)
    M = dense(mass_matrix_entries(model, fr), zero)
    h = jnp.stack([e + zero for e in bias_entries(model, fr, vel)])
    return M, h, J, jd


def reduce(q, qd):
    """Stance state z from full floating coordinates."""
    return jnp.concatenate([q[2:], qd[2:]])


def constrained_affine(model: Model, point: int, q, qd):
    """(a, b, lam_a, lam_b): qdd = a + b u and ground reaction lambda = lam_a + lam_b u
    (N, in world x and y) with the point held fixed."""
    return _affine_from_terms(model, mass_matrix(model, q), bias(model, q, qd), point_jacobian(model, q, point),
                              point_jdot_qd(model, q, qd, point))


def _affine_from_terms(model: Model, M, h, J, jd):
    n = model.nq
    K = jnp.block([[M, -J.T], [J, jnp.zeros((2, 2))]])
    rhs = jnp.concatenate(
        [jnp.concatenate([-h, -jd])[:, None],
         jnp.concatenate([jnp.asarray(model.actuation_matrix()), jnp.zeros((2, model.nu))])], axis=1)
    sol = jnp.linalg.solve(K, rhs)
    return sol[:n, 0], sol[:n, 1:], sol[n:, 0], sol[n:, 1:]


def stance_affine(st: Stance, z):
    """(a, b, lam_a, lam_b) in stance coordinates: d(qd_s)/dt = a + b u."""
    a, b, la, lb = _affine_from_terms(st.model, *pinned_terms(st, z))
    return a[2:], b[2:], la, lb


def stance_flow(st: Stance, z, u):
    """zdot of the stance dynamics under input u."""
    a, b, _, _ = stance_affine(st, z)
    return jnp.concatenate([z[st.n:], a + b @ u])


def ground_reaction(st: Stance, z, u):
    """Ground reaction (Fx, Fy) at the stance point under input u, N."""
    _, _, la, lb = stance_affine(st, z)
    return la + lb @ u


def swing_height(st: Stance, z):
    """Height of the swing point above the ground (the stance point's level), m."""
    q, _ = embed(st, z)
    return point_position(st.model, q, st.swing)[1]


def swing_position(st: Stance, z):
    q, _ = embed(st, z)
    return point_position(st.model, q, st.swing)


def impact(st: Stance, z_minus):
    """Touchdown of the swing point: (z_plus, impulse (2,) N s, step vector (2,) m, velocity
    of the lifting foot after impact (2,) m/s). The new stance point is put at the origin."""
    q, qd = embed(st, z_minus)
    step = point_position(st.model, q, st.swing)
    qd_plus, impulse = impact_map(st.model, q, qd, st.swing)
    lift = point_velocity(st.model, q, qd_plus, st.stance)
    qn = relabel(q, st.swap)
    qdn = relabel(qd_plus, st.swap)
    return reduce(qn, qdn), impulse, step, lift
