"""Static description of a planar kinematic tree with a floating base.

A :class:`Model` holds the structure of the tree (which body hangs from which, the joint
types, the index of each joint's coordinate) as static metadata, and the physical numbers
(masses, lengths, inertias) as array leaves, so a model can be passed through ``jit``, batched
with ``vmap`` over parameters, or differentiated with ``grad``.

Conventions
-----------
* The plane is (x, y) with y up; angles are counter-clockwise positive.
* The root body is attached to the world by a planar floating joint with coordinates
  ``q[0] = x``, ``q[1] = y`` (world position of the root's frame origin, m) and
  ``q[2]`` (absolute angle of the root body, rad).
* Every other body has one joint to its parent, whose coordinate is ``q[3 + k]`` for the
  k-th non-root body in declaration order. A revolute joint adds its angle to the parent's
  absolute angle; a prismatic joint slides the body along an axis fixed in the parent frame.
* A body's frame origin is its joint; ``com`` is given in the body's own frame.
* A rotor is a rigid inertia whose absolute angular velocity is ``ratios @ qd``, a fixed
  linear combination of the generalised velocities (gear trains, cable differentials).
  It contributes ``inertia * outer(ratios, ratios)`` to the mass matrix and nothing to the
  bias (its coefficients are constant); its own mass is part of the body that carries it.
"""
from __future__ import annotations

import dataclasses
from typing import Sequence

import jax

from bipedlab.pytree import replace as pytree_replace
import jax.numpy as jnp
import numpy as np

REVOLUTE = "revolute"
PRISMATIC = "prismatic"
FLOATING = "floating"


@dataclasses.dataclass(frozen=True)
class Body:
    """One rigid body of the tree.

    name: unique name. parent: name of the parent body, or None for the root.
    joint: "revolute" or "prismatic" ("floating" for the root).
    offset: joint position in the parent frame, m (for the root: ignored).
    axis: unit sliding direction in the parent frame (prismatic joints only).
    mass: kg. com: centre of mass in the body frame, m. inertia: about the COM, kg m^2.
    """

    name: str
    parent: str | None
    mass: float
    com: tuple[float, float]
    inertia: float
    joint: str = REVOLUTE
    offset: tuple[float, float] = (0.0, 0.0)
    axis: tuple[float, float] = (1.0, 0.0)


@dataclasses.dataclass(frozen=True)
class Point:
    """A named point fixed to a body (a toe, a heel, a hip), given in the body frame, m."""

    name: str
    body: str
    offset: tuple[float, float]


@dataclasses.dataclass(frozen=True)
class Rotor:
    """A rotor or pulley inertia (kg m^2) with absolute angular velocity ``ratios . qd``."""

    name: str
    inertia: float
    ratios: tuple[float, ...]


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Model:
    """A planar floating-base kinematic tree (a frozen pytree).

    Array leaves (all float64): ``mass (nb,)`` kg, ``com (nb, 2)`` m, ``inertia (nb,)`` kg m^2,
    ``offset (nb, 2)`` m, ``axis (nb, 2)``, ``point_offset (np, 2)`` m,
    ``rotor_inertia (nr,)`` kg m^2, ``rotor_ratios (nr, n)``, ``gravity ()`` m/s^2.
    Static fields: names, parent indices, joint types and the actuation matrix pattern.
    """

    mass: jax.Array
    com: jax.Array
    inertia: jax.Array
    offset: jax.Array
    axis: jax.Array
    point_offset: jax.Array
    rotor_inertia: jax.Array
    rotor_ratios: jax.Array
    gravity: jax.Array
    body_names: tuple[str, ...] = dataclasses.field(metadata=dict(static=True))
    parents: tuple[int, ...] = dataclasses.field(metadata=dict(static=True))
    joints: tuple[str, ...] = dataclasses.field(metadata=dict(static=True))
    point_names: tuple[str, ...] = dataclasses.field(metadata=dict(static=True))
    point_bodies: tuple[int, ...] = dataclasses.field(metadata=dict(static=True))
    rotor_names: tuple[str, ...] = dataclasses.field(metadata=dict(static=True))
    coord_names: tuple[str, ...] = dataclasses.field(metadata=dict(static=True))
    actuated: tuple[int, ...] = dataclasses.field(metadata=dict(static=True))
    rotor_support: tuple[tuple[int, ...], ...] = dataclasses.field(metadata=dict(static=True))

    # ----- static structure -------------------------------------------------------------
    @property
    def nq(self) -> int:
        """Number of generalised coordinates (3 floating-base + one per joint)."""
        return 2 + len(self.parents)

    @property
    def nb(self) -> int:
        return len(self.parents)

    @property
    def nu(self) -> int:
        return len(self.actuated)

    def body_index(self, name: str) -> int:
        return _lookup(self.body_names, name, "body")

    def point_index(self, name: str) -> int:
        return _lookup(self.point_names, name, "point")

    def coord_index(self, name: str) -> int:
        return _lookup(self.coord_names, name, "coordinate")

    def dof_of_body(self, b: int) -> int:
        """Coordinate index of body b's joint (2, the base angle, for the root)."""
        return 2 if b == 0 else 2 + b

    def dof_parents(self) -> tuple[int, ...]:
        """Parent of each coordinate in the kinematic tree of coordinates (-1 for none)."""
        out = [-1, 0, 1]
        for b in range(1, self.nb):
            out.append(self.dof_of_body(self.parents[b]))
        return tuple(out)

    def ancestors(self, b: int) -> tuple[int, ...]:
        """Bodies from the root down to b, inclusive."""
        chain = []
        while b >= 0:
            chain.append(b)
            b = self.parents[b]
        return tuple(reversed(chain))

    def actuation_matrix(self) -> np.ndarray:
        """B in ``M qdd + bias = B u + J^T F``: one column per actuated coordinate."""
        B = np.zeros((self.nq, self.nu))
        for k, i in enumerate(self.actuated):
            B[i, k] = 1.0
        return B

    replace = pytree_replace


def _lookup(names: Sequence[str], name: str, what: str) -> int:
    try:
        return names.index(name)
    except ValueError:
        raise ValueError(f"unknown {what} {name!r}; known: {', '.join(names)}") from None


def build_model(
    bodies: Sequence[Body],
    points: Sequence[Point] = (),
    rotors: Sequence[Rotor] = (),
    actuated: Sequence[str] | None = None,
    gravity: float = 9.81,
    base_names: tuple[str, str, str] = ("x", "y", "theta"),
) -> Model:
    """Build a :class:`Model` from bodies (root first, parents before children).

    ``actuated`` names the coordinates driven by the input u (default: every joint, none
    of the floating base). Coordinates are named ``base_names`` then the body names.
    Raises ValueError with one clear message on inconsistent input.
    """
    if not bodies:
        raise ValueError("a model needs at least one body")
    names = [b.name for b in bodies]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"body names must be unique; repeated: {', '.join(dup)}")
    parents = []
    for k, b in enumerate(bodies):
        if k == 0:
            if b.parent is not None:
                raise ValueError(f"the first body {b.name!r} must be the root (parent=None)")
            parents.append(-1)
            continue
        if b.parent not in names[:k]:
            raise ValueError(f"body {b.name!r}: parent {b.parent!r} must be declared before it")
        if b.joint not in (REVOLUTE, PRISMATIC):
            raise ValueError(f"body {b.name!r}: joint must be 'revolute' or 'prismatic', got {b.joint!r}")
        parents.append(names.index(b.parent))
    for b in bodies:
        if not (b.mass >= 0 and b.inertia >= 0):
            raise ValueError(f"body {b.name!r}: mass and inertia must be non-negative")
    coord_names = tuple(base_names) + tuple(names[1:])
    if actuated is None:
        act = tuple(range(3, len(coord_names)))
    else:
        act = tuple(_lookup(coord_names, a, "coordinate") for a in actuated)
    nq = len(coord_names)
    for r in rotors:
        if len(r.ratios) != nq:
            raise ValueError(f"rotor {r.name!r}: needs {nq} ratios, got {len(r.ratios)}")
    for p in points:
        if p.body not in names:
            raise ValueError(f"point {p.name!r}: unknown body {p.body!r}")
    axes = np.array([b.axis for b in bodies], float)
    axes /= np.maximum(np.linalg.norm(axes, axis=1, keepdims=True), 1e-300)
    f64 = lambda a: jnp.asarray(np.asarray(a, dtype=np.float64))  # noqa: E731
    return Model(
        mass=f64([b.mass for b in bodies]),
        com=f64([b.com for b in bodies]).reshape(-1, 2),
        inertia=f64([b.inertia for b in bodies]),
        offset=f64([b.offset for b in bodies]).reshape(-1, 2),
        axis=f64(axes).reshape(-1, 2),
        point_offset=f64([p.offset for p in points]).reshape(-1, 2),
        rotor_inertia=f64([r.inertia for r in rotors]).reshape(-1),
        rotor_ratios=f64([r.ratios for r in rotors]).reshape(-1, nq),
        gravity=f64(gravity),
        body_names=tuple(names),
        parents=tuple(parents),
        joints=(FLOATING,) + tuple(b.joint for b in bodies[1:]),
        point_names=tuple(p.name for p in points),
        point_bodies=tuple(names.index(p.body) for p in points),
        rotor_names=tuple(r.name for r in rotors),
        coord_names=coord_names,
        actuated=act,
        rotor_support=tuple(tuple(int(i) for i in np.flatnonzero(r.ratios)) for r in rotors),
    )
