"""A tree driven through a linear transmission: coordinates that are not joint angles.

Some robots (a cable-differential drivetrain, for one) are described by coordinates that are not the joints of any kinematic
tree: the thigh and shin angles are sums and differences of a leg angle and a leg shape, and
motor angles drive pulleys but no link. A :class:`Coupled` model holds

* a :class:`~bipedlab.mechanics.Model` tree whose coordinates are ``q_tree = T q`` for a
  constant matrix ``T`` (the rigid linkage; its joints need not be independent),
* rotor inertias whose absolute rates are ``R q_dot`` (pulleys, gears, motor rotors), and
* a constant generalised weight ``w`` adding the potential ``w . q`` (a boom's weight).

Lagrange's equations in ``q`` then read ``M qdd + bias = tau`` with
``M = T^T M_tree T + R^T diag(J) R`` and ``bias = T^T bias_tree + w``; ``T`` and ``R`` are
constant, so the rotors add no velocity-product terms. Everything is written on scalars with
the structural zeros known at trace time, so a solve costs what the sparsity allows.
Composing with a further constant map ``q = E p`` (:func:`restrict`) gives a rigidly
constrained variant in coordinates ``p``.
"""
from __future__ import annotations

from typing import Sequence

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.pytree import pytree, static_field
from bipedlab.mechanics import arrays as ar
from bipedlab.mechanics import dynamics as dyn
from bipedlab.mechanics import kinematics as kin
from bipedlab.mechanics.tree import Model


def static_matrix(a) -> tuple:
    """A constant matrix as nested tuples of floats (hashable: a static pytree field)."""
    return tuple(tuple(float(v) for v in row) for row in np.asarray(a, float))


_static = static_matrix


@pytree
class Coupled:
    """Tree + linear transmission (a frozen pytree).

    Leaves: ``tree`` (its physical numbers), ``rotor_inertia (nr,)`` kg m^2 and
    ``weight (n,)`` (N or N m per unit coordinate). Static: ``T (n_tree, n)``,
    ``R (nr, n)`` as nested tuples, the names of coordinates and rotors, and ``kernel``: which
    form computes the dynamics and points, ``"auto"`` (:func:`array_form`'s rule), ``"array"``
    or ``"scalar"``. The array form makes the smaller program (shorter compilation: the choice
    for single runs and Jacobians); the scalar form runs faster when trials are batched with
    ``vmap``, where the array form's small matrix products become batched ones (measured on
    a 9-DoF walker's push trials: 0.95 -> 2.5 trials/s in batches of 8; :func:`batched`).
    """

    tree: Model
    rotor_inertia: jax.Array
    weight: jax.Array
    T: tuple = static_field()
    R: tuple = static_field()
    coord_names: tuple[str, ...] = static_field()
    rotor_names: tuple[str, ...] = static_field()
    kernel: str = static_field(default="auto")

    @property
    def n(self) -> int:
        return len(self.coord_names)

    def coord_index(self, name: str) -> int:
        try:
            return self.coord_names.index(name)
        except ValueError:
            raise ValueError(f"unknown coordinate {name!r}; known: {', '.join(self.coord_names)}") from None



def coupled(tree: Model, T, rotors: Sequence[tuple[str, float, Sequence[float]]], coord_names: Sequence[str],
            weight=None) -> Coupled:
    """Build a :class:`Coupled` model. ``rotors``: (name, inertia kg m^2, ratios over q)."""
    T = np.asarray(T, float)
    n = len(coord_names)
    if T.shape != (tree.nq, n):
        raise ValueError(f"T must have shape ({tree.nq}, {n}), got {T.shape}")
    R = np.array([r[2] for r in rotors], float).reshape(-1, n)
    w = np.zeros(n) if weight is None else np.asarray(weight, float)
    return Coupled(tree, jnp.asarray([float(r[1]) for r in rotors]).reshape(-1), jnp.asarray(w),
                   _static(T), _static(R), tuple(coord_names), tuple(r[0] for r in rotors))


def restrict(model: Coupled, E, coord_names: Sequence[str]) -> Coupled:
    """The model in new coordinates p with ``q = E p`` (a rigid constraint, E constant)."""
    E = np.asarray(E, float)
    T = np.asarray(model.T) @ E
    R = np.asarray(model.R).reshape(-1, model.n) @ E
    return Coupled(model.tree, model.rotor_inertia, jnp.asarray(E.T) @ model.weight, _static(T), _static(R),
                   tuple(coord_names), model.rotor_names, model.kernel)


# ----- maps ---------------------------------------------------------------------------------
def tree_coordinates(model: Coupled, q) -> jax.Array:
    """q_tree = T q."""
    return jnp.asarray(np.asarray(model.T)) @ q


def _columns(M) -> list:
    """Per row a of a constant matrix (nested tuples): [(i, M[a][i]) for nonzero entries]."""
    return [[(i, v) for i, v in enumerate(row) if v != 0.0] for row in M]


def pull_back(M, vec) -> list:
    """M^T vec for a constant matrix M (nested tuples, one row per entry of vec) and a list
    or dict of scalars; None entries and structural zeros of the result are None."""
    out = [None] * len(M[0])
    items = vec.items() if isinstance(vec, dict) else enumerate(vec)
    cols = _columns(M)
    for a, val in items:
        if val is None:
            continue
        for i, t in cols[a]:
            term = t * val
            out[i] = term if out[i] is None else out[i] + term
    return out


def mass_matrix_entries(model: Model, fr: kin.Frames) -> list:
    """Lower triangle of M as nested lists of scalars (None = structural zero)."""
    Ht = dyn.mass_matrix_entries(model.tree, fr)
    n = model.n
    cols = _columns(model.T)
    H = [[None] * (i + 1) for i in range(n)]

    def add(i, j, val):
        H[i][j] = val if H[i][j] is None else H[i][j] + val

    nt = len(Ht)
    for a in range(nt):
        for b in range(nt):
            m = Ht[max(a, b)][min(a, b)]
            if m is None:
                continue
            for i, ta in cols[a]:
                for j, tb in cols[b]:
                    if j <= i:
                        add(i, j, (ta * tb) * m)
    R = model.R
    for r in range(len(R)):
        J = model.rotor_inertia[r]
        nz = [i for i in range(n) if R[r][i] != 0.0]
        for i in nz:
            for j in nz:
                if j <= i:
                    add(i, j, J * (R[r][i] * R[r][j]))
    return H


def bias_entries(model: Coupled, fr: kin.Frames, vel: kin.Velocities) -> list:
    """T^T bias_tree + weight, as a list of scalars."""
    out = pull_back(model.T, dyn.bias_entries(model.tree, fr, vel))
    zero = 0.0 * fr.origin[0][0]
    return [(zero if v is None else v) + model.weight[i] for i, v in enumerate(out)]


def state_frames(model: Coupled, q, qd):
    """Tree frames and velocities for the coupled state."""
    fr = kin.frames(model.tree, tree_coordinates(model, q))
    return fr, kin.velocities(model.tree, fr, tree_coordinates(model, qd))


def dense(H: list, like) -> jax.Array:
    """Symmetric dense matrix from a lower triangle of scalars."""
    return dyn.dense(H, like)


#: The values of :attr:`Coupled.kernel`.
KERNELS = ("auto", "array", "scalar")


def array_form(model: Coupled) -> bool:
    """Whether the model's dynamics take the array form of :mod:`bipedlab.mechanics.arrays`:
    a tree of revolute joints every one of which moves with the coordinates. A model that
    locks joints of its tree (a rig restricted to a few coordinates) keeps the scalar
    entries, whose structural zeros skip the locked bodies: for a two-coordinate leg of an
    eleven-joint tree the scalar form runs 4x faster."""
    if model.kernel not in KERNELS:
        raise ValueError(f"Coupled.kernel must be one of {', '.join(KERNELS)}, got {model.kernel!r}")
    if model.kernel != "auto":
        return model.kernel == "array" and ar.applies(model.tree)
    return ar.applies(model.tree) and bool(np.all(np.any(np.asarray(model.T) != 0.0, axis=1)))


def batched(model: Coupled) -> Coupled:
    """The model with the kernel that runs fastest for trials batched with ``vmap`` (the
    scalar form; see :class:`Coupled`)."""
    return model.replace(kernel="scalar")


def _matrices(model: Coupled):
    return jnp.asarray(np.asarray(model.T)), jnp.asarray(np.asarray(model.R).reshape(-1, model.n))


def mass_matrix(model: Coupled, q) -> jax.Array:
    """M(q) (n, n); in the array form of :mod:`bipedlab.mechanics.arrays` (a few matrix
    products) where :func:`array_form` holds, otherwise from the scalar entries."""
    if array_form(model):
        T, R = _matrices(model)
        return T.T @ ar.mass_matrix(model.tree, T @ q) @ T + R.T @ (model.rotor_inertia[:, None] * R)
    fr = kin.frames(model.tree, tree_coordinates(model, q))
    return dense(mass_matrix_entries(model, fr), q[0])


def bias(model: Coupled, q, qd) -> jax.Array:
    """Coriolis, centrifugal, gravity and constant-weight forces (n,) (array form where
    :func:`array_form` holds, as :func:`mass_matrix`)."""
    if array_form(model):
        T, _ = _matrices(model)
        return T.T @ ar.bias(model.tree, T @ q, T @ qd) + model.weight
    fr, vel = state_frames(model, q, qd)
    return jnp.stack(bias_entries(model, fr, vel))


def point_force(model: Coupled, fr: kin.Frames, point: int, F) -> list:
    """Generalised force T^T J^T F of a world force F = (Fx, Fy) at tree point index."""
    tree = model.tree
    b = tree.point_bodies[point]
    p = kin.point_world(tree, fr, b, kin.point_offset(tree, point))
    return pull_back(model.T, kin.generalized_force(tree, fr, b, p, F))


def point_motion(model: Coupled, fr: kin.Frames, vel: kin.Velocities, point: int):
    """(position, velocity) of a tree point as tuples of scalars."""
    tree = model.tree
    p, v, _ = kin.point_velocity_accel(tree, fr, vel, tree.point_bodies[point], kin.point_offset(tree, point))
    return p, v


def point_position(model: Coupled, q, point: str) -> jax.Array:
    if array_form(model):
        return ar.point_position(model.tree, tree_coordinates(model, q), model.tree.point_index(point))
    return kin.point_position(model.tree, tree_coordinates(model, q), point)


def point_jacobian(model: Coupled, q, point: str) -> jax.Array:
    T = jnp.asarray(np.asarray(model.T))
    if array_form(model):
        return ar.point_jacobian(model.tree, T @ q, model.tree.point_index(point)) @ T
    return kin.point_jacobian(model.tree, tree_coordinates(model, q), point) @ T


def kinetic_energy(model: Coupled, q, qd) -> jax.Array:
    T = dyn.kinetic_energy(model.tree, tree_coordinates(model, q), tree_coordinates(model, qd))
    rates = jnp.asarray(np.asarray(model.R).reshape(-1, model.n)) @ qd
    return T + 0.5 * jnp.sum(model.rotor_inertia * rates**2)


def potential_energy(model: Coupled, q) -> jax.Array:
    """Gravity of the tree plus the constant-weight term ``w . q``."""
    return dyn.potential_energy(model.tree, tree_coordinates(model, q)) + model.weight @ q


def solve(H: list, rhs: list) -> list:
    """Solve M x = rhs for M given by its lower triangle (sparse LTDL, unrolled)."""
    return dyn.ltdl_solve(H, rhs)
