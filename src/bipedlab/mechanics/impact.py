"""Rigid impact of a point foot (Hurmuzlu-Marghitu) and stance/swing relabelling.

At touchdown the ground applies an impulse Lambda at the foot; joint torques, being finite,
do not act over the instant. The post-impact velocity solves

    M (qd+ - qd-) = J^T Lambda,    J qd+ = 0        (no slip, no rebound)

so qd+ = qd- - M^-1 J^T (J M^-1 J^T)^-1 J qd-. This conserves angular momentum about the
impact point and never adds kinetic energy.
"""
from __future__ import annotations

from typing import Sequence

import jax.numpy as jnp

from bipedlab.mechanics.dynamics import mass_matrix
from bipedlab.mechanics.kinematics import PointRef, point_jacobian
from bipedlab.mechanics.tree import Model


def impact_map(model: Model, q, qd_minus, point: PointRef):
    """(qd_plus, impulse) for a plastic impact of the named point; impulse in N s, (2,)."""
    M = mass_matrix(model, q)
    J = point_jacobian(model, q, point)
    MinvJt = jnp.linalg.solve(M, J.T)
    impulse = -jnp.linalg.solve(J @ MinvJt, J @ qd_minus)
    return qd_minus + MinvJt @ impulse, impulse


def relabel(x, permutation: Sequence[int], sign: Sequence[float] | None = None):
    """Swap stance and swing labels: ``x[..., i] <- sign[i] * x[..., permutation[i]]`` for
    a configuration or a velocity vector."""
    perm = jnp.asarray(permutation)
    out = jnp.take(x, perm, axis=-1)
    if sign is not None:
        out = out * jnp.asarray(sign)
    return out
