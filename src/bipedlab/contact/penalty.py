"""Compliant (penalty) ground contact for point feet on terrain y = h(x).

The anchor's ground: while a point is below the terrain by a depth ``pen > 0``, the vertical
force is ``max(k pen - d vy, 0)`` (a linear spring-damper that can only push) and the
horizontal force is ``-c vx`` (viscous). Forces act at the point and enter the dynamics as
``J^T F``.
"""
from __future__ import annotations

import dataclasses
from typing import Callable, Sequence

import jax
import jax.numpy as jnp

from bipedlab.mechanics import kinematics as kin
from bipedlab.mechanics.fusion import materialize
from bipedlab.mechanics.tree import Model


def flat(x):
    """Flat terrain at height zero."""
    return 0.0 * x


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class PenaltyGround:
    """Linear penalty ground. stiffness N/m, damping N s/m, tangential_damping N s/m;
    terrain: height (m) as a function of x (static, must be traceable)."""

    stiffness: jax.Array
    damping: jax.Array
    tangential_damping: jax.Array
    terrain: Callable = dataclasses.field(default=flat, metadata=dict(static=True))


def anchor_ground(terrain: Callable = flat) -> PenaltyGround:
    """The anchor scenario's ground: k = 2e5 N/m, d = 2e3 N s/m, horizontal 3e3 N s/m."""
    f = lambda v: jnp.asarray(v, dtype=jnp.float64)  # noqa: E731
    return PenaltyGround(f(2e5), f(2e3), f(3e3), terrain)


def penalty_force(ground: PenaltyGround, p, v):
    """(Fx, Fy) on a point at world position p with velocity v (scalars)."""
    pen = ground.terrain(p[0]) - p[1]
    inside = pen > 0
    fy = jnp.where(inside, jnp.maximum(ground.stiffness * pen - ground.damping * v[1], 0.0), 0.0)
    fx = jnp.where(inside, -ground.tangential_damping * v[0], 0.0)
    return fx, fy


def contact_generalized_force(model: Model, ground: PenaltyGround, fr, vel, points: Sequence[int]):
    """Sum of J^T F over the given point indices, as a dict {coordinate: scalar}."""
    out: dict = {}
    for k in points:
        b = model.point_bodies[k]
        p, v, _ = kin.point_velocity_accel(model, fr, vel, b, kin.point_offset(model, k))
        F = penalty_force(ground, p, v)
        for j, val in kin.generalized_force(model, fr, b, p, F).items():
            out[j] = val if j not in out else out[j] + val
    return out


def contact_forces(model: Model, ground: PenaltyGround, q, qd, points: Sequence[str]) -> jax.Array:
    """Ground forces (Fx, Fy) at each named point, shape (len(points), 2)."""
    fr = kin.frames(model, q)
    vel = kin.velocities(model, fr, qd)
    out = []
    for name in points:
        k = model.point_index(name)
        p, v, _ = kin.point_velocity_accel(model, fr, vel, model.point_bodies[k], kin.point_offset(model, k))
        out.append(jnp.stack(penalty_force(ground, p, v)))
    return jnp.stack(out)


def contact_dynamics(model: Model, ground: PenaltyGround, contacts: Sequence[int], q, qd, u) -> jax.Array:
    """qdd of ``M qdd + bias = B u + sum J^T F`` with penalty forces at the contact points
    (point indices). u has one entry per actuated coordinate."""
    from bipedlab.mechanics.dynamics import bias_entries, ltdl_solve, mass_matrix_entries

    fr = kin.frames(model, q)
    vel = kin.velocities(model, fr, qd)
    fr, vel = materialize((fr, vel))
    h = bias_entries(model, fr, vel)
    rhs = [-hi for hi in h]
    for k, i in enumerate(model.actuated):
        rhs[i] = rhs[i] + u[k]
    for j, val in contact_generalized_force(model, ground, fr, vel, contacts).items():
        rhs[j] = rhs[j] + val
    H, rhs = materialize((mass_matrix_entries(model, fr), rhs))
    return jnp.stack(ltdl_solve(H, rhs))

