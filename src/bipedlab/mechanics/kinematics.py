"""Planar forward kinematics, velocities and point Jacobians of a :class:`Model`.

The recursions are unrolled over the (static) tree at trace time and written on scalars,
so XLA fuses a whole evaluation into a handful of elementwise kernels; under ``vmap`` every
scalar becomes a batch vector. Public functions take ``q`` (and ``qd``) of shape ``(nq,)``.
"""
from __future__ import annotations

import dataclasses

from typing import Union

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.mechanics.planar import Vec, add, dot, perp, rot, scale, sub
from bipedlab.mechanics.tree import PRISMATIC, Model


@dataclasses.dataclass(frozen=True)
class Frames:
    """Per-body world kinematics: cos/sin of the absolute angle, joint origin, COM, and the
    world direction of each body's joint axis (the sliding direction, for prismatic joints)."""

    angle: list
    cs: list
    origin: list
    com: list
    axis: list


@dataclasses.dataclass(frozen=True)
class Velocities:
    """Per-body angular velocity, joint-origin velocity and velocity-product acceleration of
    the joint origin (the acceleration it would have with qdd = 0, gravity excluded)."""

    omega: list
    v_origin: list
    a_origin: list


def angle_map(model: Model) -> np.ndarray:
    """Constant matrix A with body absolute angles = A q (revolute joints add angles)."""
    A = np.zeros((model.nb, model.nq))
    for b in range(model.nb):
        A[b, 2] = 1.0
        for a in model.ancestors(b)[1:]:
            if model.joints[a] != PRISMATIC:
                A[b, model.dof_of_body(a)] = 1.0
    return A


def frames(model: Model, q) -> Frames:
    """World positions and orientations of every body for coordinates q."""
    angles = jnp.asarray(angle_map(model)) @ q
    # one vector sin/cos, held behind a barrier so XLA does not recompute it per consumer
    trig = jax.lax.optimization_barrier(jnp.stack([jnp.cos(angles), jnp.sin(angles)]))
    angle, cs, origin, com, axis = [], [], [], [], []
    for b, p in enumerate(model.parents):
        if p < 0:
            th = q[2]
            o = (q[0], q[1])
            ax = (0.0, 0.0)
        else:
            qj = q[model.dof_of_body(b)]
            cp, sp = cs[p]
            off = (model.offset[b, 0], model.offset[b, 1])
            if model.joints[b] == PRISMATIC:
                th = angle[p]
                ax = rot(cp, sp, (model.axis[b, 0], model.axis[b, 1]))
                o = add(add(origin[p], rot(cp, sp, off)), scale(qj, ax))
            else:
                th = angle[p] + qj
                ax = (0.0, 0.0)
                o = add(origin[p], rot(cp, sp, off))
        c, s = trig[0, b], trig[1, b]
        angle.append(angles[b])
        cs.append((c, s))
        origin.append(o)
        com.append(add(o, rot(c, s, (model.com[b, 0], model.com[b, 1]))))
        axis.append(ax)
    return Frames(angle, cs, origin, com, axis)


def velocities(model: Model, fr: Frames, qd) -> Velocities:
    """Angular velocities, joint-origin velocities and velocity-product accelerations."""
    omega, vo, ao = [], [], []
    for b, p in enumerate(model.parents):
        if p < 0:
            w = qd[2]
            v = (qd[0], qd[1])
            a = (0.0 * qd[0], 0.0 * qd[1])
        else:
            qdj = qd[model.dof_of_body(b)]
            r = sub(fr.origin[b], fr.origin[p])
            wp = omega[p]
            v = add(vo[p], scale(wp, perp(r)))
            a = sub(ao[p], scale(wp * wp, r))
            if model.joints[b] == PRISMATIC:
                w = wp
                v = add(v, scale(qdj, fr.axis[b]))
                a = add(a, scale(2.0 * wp * qdj, perp(fr.axis[b])))
            else:
                w = wp + qdj
        omega.append(w)
        vo.append(v)
        ao.append(a)
    return Velocities(omega, vo, ao)


def _point_world(model: Model, fr: Frames, body: int, offset: Vec) -> Vec:
    c, s = fr.cs[body]
    return add(fr.origin[body], rot(c, s, offset))


def _point_offset(model: Model, k: int) -> Vec:
    return (model.point_offset[k, 0], model.point_offset[k, 1])


def _jacobian_columns(model: Model, fr: Frames, body: int, p: Vec) -> dict:
    """Nonzero columns {coordinate: (dx, dy)} of the Jacobian of world point p on body."""
    cols = {0: (1.0, 0.0), 1: (0.0, 1.0)}
    for b in model.ancestors(body):
        j = model.dof_of_body(b)
        if model.joints[b] == PRISMATIC:
            cols[j] = fr.axis[b]
        else:
            cols[j] = perp(sub(p, fr.origin[b]))
    return cols


def _generalized_force(model: Model, fr: Frames, body: int, p: Vec, F: Vec) -> dict:
    """J(p)^T F as {coordinate: scalar} for a force F applied at world point p on body."""
    out = {}
    for j, col in _jacobian_columns(model, fr, body, p).items():
        out[j] = dot(col, F)
    return out


PointRef = Union[str, int]


def _resolve(model: Model, point: PointRef) -> int:
    return model.point_index(point) if isinstance(point, str) else int(point)


def point_position(model: Model, q, point: PointRef) -> jax.Array:
    """World position (m) of a named point, shape (2,)."""
    k = _resolve(model, point)
    fr = frames(model, q)
    return jnp.stack(_point_world(model, fr, model.point_bodies[k], _point_offset(model, k)))


def point_jacobian(model: Model, q, point: PointRef) -> jax.Array:
    """Jacobian d(position)/dq of a named point, shape (2, nq)."""
    return jacobian_from_frames(model, frames(model, q), _resolve(model, point), jnp.zeros_like(q[0]))


def jacobian_from_frames(model: Model, fr: Frames, k: int, zero) -> jax.Array:
    """Jacobian (2, nq) of point k from computed frames (``zero``: a 0 of q's dtype)."""
    b = model.point_bodies[k]
    p = _point_world(model, fr, b, _point_offset(model, k))
    cols = _jacobian_columns(model, fr, b, p)
    return jnp.stack(
        [jnp.stack([cols[j][i] + zero if j in cols else zero for j in range(model.nq)]) for i in range(2)]
    )


def jdot_qd_from_frames(model: Model, fr: Frames, vel: Velocities, k: int) -> jax.Array:
    """J-dot qd (2,) of point k from computed frames and velocities."""
    return jnp.stack(_point_velocity_accel(model, fr, vel, model.point_bodies[k], _point_offset(model, k))[2])


def _point_velocity_accel(model: Model, fr: Frames, vel: Velocities, body: int, offset: Vec):
    c, s = fr.cs[body]
    r = rot(c, s, offset)
    w = vel.omega[body]
    v = add(vel.v_origin[body], scale(w, perp(r)))
    a = sub(vel.a_origin[body], scale(w * w, r))
    return add(fr.origin[body], r), v, a


def _point_motion(model: Model, q, qd, point: PointRef):
    k = _resolve(model, point)
    fr = frames(model, q)
    vel = velocities(model, fr, qd)
    return _point_velocity_accel(model, fr, vel, model.point_bodies[k], _point_offset(model, k))


def point_velocity(model: Model, q, qd, point: PointRef) -> jax.Array:
    """World velocity (m/s) of a named point, shape (2,)."""
    return jnp.stack(_point_motion(model, q, qd, point)[1])


def point_jdot_qd(model: Model, q, qd, point: PointRef) -> jax.Array:
    """J-dot times qd for a named point (its acceleration when qdd = 0), shape (2,)."""
    return jnp.stack(_point_motion(model, q, qd, point)[2])


def body_poses(model: Model, q) -> tuple[jax.Array, jax.Array, jax.Array]:
    """(angles (nb,), joint origins (nb, 2), centres of mass (nb, 2)) in the world."""
    fr = frames(model, q)
    return (
        jnp.stack(fr.angle),
        jnp.stack([jnp.stack(o) for o in fr.origin]),
        jnp.stack([jnp.stack(c) for c in fr.com]),
    )


#: Public name of :func:`_point_velocity_accel`: world (position, velocity, acceleration) of a
#: point at ``offset`` on ``body``.
point_velocity_accel = _point_velocity_accel
#: Public names of the frame-level building blocks (given :func:`frames` / :func:`velocities`),
#: for contact models and robots that assemble point terms themselves.
point_world = _point_world
point_offset = _point_offset
jacobian_columns = _jacobian_columns
generalized_force = _generalized_force
