"""Kinematics and dynamics of a planar tree of revolute joints in array form.

The scalar kernels (:mod:`bipedlab.mechanics.kinematics`, :mod:`bipedlab.mechanics.dynamics`)
unroll the tree's recursions into one expression per entry; their programs grow with the
square of the number of coordinates, and a flow that holds them several times (a closed loop,
a Poincaré map and its forward-mode Jacobian) compiles for minutes. For a tree whose joints are
all revolute (any floating base, any branching) every quantity is instead a few products of
constant structure matrices with vectors of the body angles, so a program holds a handful of
small matrix products whatever the tree:

* body angles ``phi = A q`` (``A`` constant: each revolute joint adds its angle);
* a point fixed to body ``b`` at ``r`` (a centre of mass, a toe) sits at
  ``p = base + sum_k Rot(phi_k) C[p, k]``, where ``C[p, k]`` is, for every strict ancestor
  ``k`` of ``b``, the offset in ``k``'s frame of the joint of ``k``'s child on the way to ``b``,
  and ``r`` for ``k = b`` (built from the model's offsets by a constant selection tensor, so
  the offsets stay traced leaves);
* its Jacobian ``dp/dq = e_base + (dp/dphi) A`` with ``dp/dphi_k = Rot'(phi_k) C[p, k]``, and
  its velocity-product acceleration ``sum_k Rot''(phi_k) C[p, k] phidot_k^2``, since every
  term depends on one angle;
* ``M = Jx^T diag(m) Jx + Jy^T diag(m) Jy + A^T diag(I) A + R^T diag(J_r) R`` over the
  bodies' centres of mass, and ``bias = Jx^T (m a_x) + Jy^T (m (a_y + g))`` (a planar body's
  angular momentum about its centre of mass, ``I phidot``, adds no velocity product).

:func:`applies` says whether a model is of this kind; :mod:`bipedlab.mechanics.coupled` uses
these forms for such trees. The two kernels agree to rounding (tests compare them and
MuJoCo on random states).
"""
from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from bipedlab.mechanics import kinematics as kin
from bipedlab.mechanics.tree import PRISMATIC, Model


def applies(model: Model) -> bool:
    """Whether every joint of the tree is revolute (the floating base apart)."""
    return PRISMATIC not in model.joints[1:]


def _selection(model: Model) -> np.ndarray:
    """S (nb, nb, nb) with S[b, k, c] = 1 where c is the child of k on the way from the root
    to b (k a strict ancestor of b)."""
    S = np.zeros((model.nb,) * 3)
    for b in range(model.nb):
        chain = model.ancestors(b)
        for k, c in zip(chain[:-1], chain[1:]):
            S[b, k, c] = 1.0
    return S


#: the constant A with body angles ``phi = A q``
angle_map = kin.angle_map


def _com_coefficients(model: Model):
    S = _selection(model)
    eye = jnp.eye(model.nb)
    cx = jnp.einsum("bkc,c->bk", S, model.offset[:, 0]) + eye * model.com[:, 0]
    cy = jnp.einsum("bkc,c->bk", S, model.offset[:, 1]) + eye * model.com[:, 1]
    return cx, cy


def _point_coefficients(model: Model, point: int):
    b = model.point_bodies[point]
    Sb = _selection(model)[b]
    onehot = jnp.asarray(np.eye(model.nb)[b])
    cx = Sb @ model.offset[:, 0] + onehot * model.point_offset[point, 0]
    cy = Sb @ model.offset[:, 1] + onehot * model.point_offset[point, 1]
    return cx, cy


def _trig(model: Model, q):
    phi = jnp.asarray(angle_map(model)) @ q
    return jnp.cos(phi), jnp.sin(phi)


def _base(model: Model, like):
    ex = jnp.zeros(model.nq, like.dtype).at[0].set(1.0)
    ey = jnp.zeros(model.nq, like.dtype).at[1].set(1.0)
    return ex, ey


def _jacobians(model: Model, cx, cy, c, s, q):
    """Jacobians (Jx, Jy) (..., nq) of points with coefficients (cx, cy) (..., nb)."""
    A = jnp.asarray(angle_map(model))
    ex, ey = _base(model, q)
    return ex + (-(cx * s) - cy * c) @ A, ey + (cx * c - cy * s) @ A


def _accel(cx, cy, c, s, w2):
    """Velocity-product accelerations (a_x, a_y) of points with coefficients (cx, cy)."""
    return -(cx @ (c * w2)) + cy @ (s * w2), -(cx @ (s * w2)) - cy @ (c * w2)


def mass_matrix(model: Model, q):
    """M(q) (nq, nq) of a revolute tree, rotors included."""
    A = jnp.asarray(angle_map(model))
    c, s = _trig(model, q)
    cx, cy = _com_coefficients(model)
    jx, jy = _jacobians(model, cx, cy, c, s, q)
    m = model.mass[:, None]
    M = jx.T @ (m * jx) + jy.T @ (m * jy) + A.T @ (model.inertia[:, None] * A)
    R = model.rotor_ratios
    return M + R.T @ (model.rotor_inertia[:, None] * R)


def bias(model: Model, q, qd):
    """Coriolis, centrifugal and gravity forces (nq,) of a revolute tree."""
    A = jnp.asarray(angle_map(model))
    c, s = _trig(model, q)
    cx, cy = _com_coefficients(model)
    jx, jy = _jacobians(model, cx, cy, c, s, q)
    w = A @ qd
    ax, ay = _accel(cx, cy, c, s, w * w)
    return jx.T @ (model.mass * ax) + jy.T @ (model.mass * (ay + model.gravity))


def point_position(model: Model, q, point: int):
    """World position (2,) of the model's point with index ``point``."""
    c, s = _trig(model, q)
    cx, cy = _point_coefficients(model, point)
    return jnp.stack([q[0] + cx @ c - cy @ s, q[1] + cx @ s + cy @ c])


def point_jacobian(model: Model, q, point: int):
    """Jacobian (2, nq) of the model's point with index ``point``."""
    c, s = _trig(model, q)
    cx, cy = _point_coefficients(model, point)
    jx, jy = _jacobians(model, cx, cy, c, s, q)
    return jnp.stack([jx, jy])


def point_jdot_qd(model: Model, q, qd, point: int):
    """J-dot qd (2,) of the model's point with index ``point``."""
    c, s = _trig(model, q)
    cx, cy = _point_coefficients(model, point)
    w = jnp.asarray(angle_map(model)) @ qd
    return jnp.stack(_accel(cx, cy, c, s, w * w))
