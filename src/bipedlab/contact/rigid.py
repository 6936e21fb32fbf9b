"""Active-set constrained dynamics: bilateral rows switched on and off by a mask.

A robot with m candidate constraints ``g(q) = 0`` (contact heights, anchored contact
positions, joint stops) keeps all m rows in fixed-shape arrays; ``mask (m,)`` (1 active,
0 inactive) selects the active set. Every solve uses the one KKT matrix

    K = [[M, -A^T], [A, D]],   A = mask * dg/dq,   D = diag(1 - mask)

whose inactive rows read ``lambda_i = 0``, so shapes never change under ``jit``:

* :func:`accelerations`: ``M qdd = f + A^T lambda``, ``A qdd + Adot qd = 0``
  (the constrained equations of motion; lambda are the constraint forces, a unilateral row
  pushes when lambda > 0);
* :func:`project_velocity`: ``M (qd+ - qd) = A^T Lambda``, ``A qd+ = 0``, the plastic impact
  over the active set (an M-orthogonal projection, so kinetic energy never increases) and the
  velocity-drift correction;
* :func:`project_position`: one Newton step ``q <- q - M^-1 A^T (A M^-1 A^T)^-1 g``, the
  M-weighted least-change correction of the position drift.

:func:`release` (drop the active unilateral element with the most negative force, repeatedly)
and :func:`impact` (drop previously active unilateral elements whose impulse would pull) are the
LCP-like checks of the force and impulse signs. Active rows must be independent (the caller
leaves redundant rows out of the mask).

Point contacts (any planar robot; the robot supplies positions, Jacobians and which rows an
element owns):

* :func:`point_constraint_values` / :func:`point_constraint_jacobian`: the rows of ``k``
  contact points ``P (k, 2)`` - heights ``y_i = 0`` (unilateral, force >= 0), ``x_i - anchor_i = 0``
  (no slip) - followed by linear joint rows ``L q = 0`` (e.g. hyperextension stops);
* :func:`element_values`: an element's normal force (or gap acceleration, impulse) from the
  row vector;
* :func:`plastic_impact`: the impact over ``active | new`` with the impulse-sign check of
  :func:`impact`;
* :func:`project_state` / :func:`constraint_residual`: Newton position steps and the velocity
  projection onto the active rows, and the drift of a state, for any ``constraint_fn(q, qd) ->
  (M, g, A)``.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp


def kkt_matrix(M, A, mask):
    """K = [[M, -A^T], [A, D]] with the inactive rows of A zeroed and D = diag(1 - mask)."""
    Am = A * mask[:, None]
    D = jnp.diag(1.0 - mask)
    return jnp.block([[M, -Am.T], [Am, D]])


def accelerations(M, f, A, a_bias, mask):
    """(qdd, lambda) of ``M qdd = f + A^T lambda`` with ``A qdd = -a_bias`` on the active rows
    (f: all applied generalised forces minus the bias; a_bias: Adot qd plus any stabilisation)."""
    n = M.shape[0]
    K = kkt_matrix(M, A, mask)
    sol = jnp.linalg.solve(K, jnp.concatenate([f, -a_bias * mask]))
    return sol[:n], sol[n:] * mask


def project_velocity(M, A, qd, mask):
    """(qd+, impulse): the plastic impact / velocity projection onto ``A qd+ = 0``."""
    n = M.shape[0]
    K = kkt_matrix(M, A, mask)
    sol = jnp.linalg.solve(K, jnp.concatenate([M @ qd, jnp.zeros(A.shape[0])]))
    return sol[:n], sol[n:] * mask


def project_position(M, A, g, mask):
    """Correction dq (add to q) removing the first-order residual of the active g(q) = 0 with
    the least M-weighted change."""
    n = M.shape[0]
    K = kkt_matrix(M, A, mask)
    sol = jnp.linalg.solve(K, jnp.concatenate([jnp.zeros(n), -g * mask]))
    return sol[:n]


def release(force_fn, active, iterations: int, tol: float = 1e-9, force_tol=0.0):
    """Drop active unilateral elements with negative force, most negative first, up to
    ``iterations`` times. ``active (k,)`` bool; ``force_fn(active) -> (forces (k,), gap
    accelerations (k,))`` under that active set. An element is dropped only if, once dropped,
    its gap does not accelerate into the constraint (else it stays active: with no-slip
    contacts a pulling force and a penetrating free motion can coexist, and keeping the contact
    is the consistent choice). Forces above ``-force_tol`` count as non-negative (a small
    hysteresis against zero-force contacts flickering on and off).
    Returns (active, forces, released (k,) bool)."""

    def body(_, carry):
        act, lam, stuck, dropped = carry
        neg = jnp.where(act & ~stuck, lam, 0.0)
        i = jnp.argmin(neg)
        try_drop = neg[i] < -force_tol
        cand = act.at[i].set(False)
        lam2, acc2 = jax.lax.cond(try_drop, force_fn, lambda a: (lam, jnp.zeros_like(lam)), cand)
        ok = try_drop & (acc2[i] >= -tol)
        act = jnp.where(ok, cand, act)
        lam = jnp.where(ok, lam2, lam)
        stuck = stuck | (try_drop & ~ok & (jnp.arange(act.shape[0]) == i))
        return act, lam, stuck, dropped | (ok & (jnp.arange(act.shape[0]) == i))

    lam0, _ = force_fn(active)
    z = jnp.zeros(active.shape, bool)
    act, lam, _, dropped = jax.lax.fori_loop(0, iterations, body, (active, lam0, z, z))
    return act, lam, dropped


def impact(impulse_fn, active, keep, iterations: int, min_separation: float = 0.0):
    """Plastic impact over the active set, dropping active elements not in ``keep`` (those that
    just made contact) whose normal impulse would pull, most negative first, when, once
    dropped, they separate faster than ``min_separation`` (slower separations stick, which
    stops two coupled stops from trading impacts without end).
    ``impulse_fn(active) -> (qd+, normal impulses (k,), gap velocities (k,))``.
    Returns (qd+, impulses, active)."""

    def body(_, carry):
        act, qdp, imp, stuck = carry
        neg = jnp.where(act & ~keep & ~stuck, imp, 0.0)
        i = jnp.argmin(neg)
        try_drop = neg[i] < 0.0
        cand = act.at[i].set(False)
        qdp2, imp2, vel2 = jax.lax.cond(try_drop, impulse_fn, lambda a: (qdp, imp, jnp.zeros_like(imp)), cand)
        ok = try_drop & (vel2[i] > min_separation)
        stuck = stuck | (try_drop & ~ok & (jnp.arange(act.shape[0]) == i))
        return (jnp.where(ok, cand, act), jnp.where(ok, qdp2, qdp), jnp.where(ok, imp2, imp), stuck)

    qdp, imp, _ = impulse_fn(active)
    active, qdp, imp, _ = jax.lax.fori_loop(0, iterations, body, (active, qdp, imp, jnp.zeros(active.shape, bool)))
    return qdp, imp, active


# ----------------------------------------------------------------------------- point contacts
def point_constraint_values(P, anchors, L, q):
    """g (2k + j,): heights ``P[:, 1]``, ``P[:, 0] - anchors`` (no slip), then ``L q`` (j linear
    joint rows)."""
    return jnp.concatenate([P[:, 1], P[:, 0] - anchors, jnp.asarray(L) @ q])


def point_constraint_jacobian(J, Jd, L):
    """(A (2k + j, n), Adot qd (2k + j,)) of :func:`point_constraint_values` from the point
    Jacobians ``J (k, 2, n)`` and their ``Jdot qd (k, 2)``."""
    L = jnp.asarray(L)
    A = jnp.concatenate([J[:, 1, :], J[:, 0, :], L])
    ab = jnp.concatenate([Jd[:, 1], Jd[:, 0], jnp.zeros(L.shape[0])])
    return A, ab


def element_values(rows, element_rows):
    """(e,) the entries of a row vector (forces, impulses, gap accelerations) that belong to the
    elements: ``element_rows`` is a tuple of static slices or indices, concatenated in order."""
    return jnp.concatenate([rows[i] if isinstance(i, slice) else rows[i:i + 1] for i in element_rows])


def plastic_impact(M, A, qd, active, new, row_mask, element_rows, iterations: int, min_separation: float = 0.0):
    """Plastic impact when the elements ``new`` make contact (see :func:`impact`):
    ``row_mask(active) -> (m,)`` float mask of the rows. Returns (qd+, impulses (e,), active)."""
    def impulse_fn(a):
        qdp, imp = project_velocity(M, A, qd, row_mask(a))
        return qdp, element_values(imp, element_rows), element_values(A @ qdp, element_rows)

    return impact(impulse_fn, active | new, new, iterations, min_separation)


def constraint_residual(g, A, qd, mask):
    """(max |g|, max |A qd|) over the active rows."""
    return jnp.max(jnp.abs(g * mask)), jnp.max(jnp.abs((A @ qd) * mask))


def project_state(constraint_fn, q, qd, mask, newton: int = 2):
    """(q, qd) projected onto the active rows - ``newton`` M-weighted Newton steps on the
    positions (:func:`project_position`), then the exact velocity projection - and the
    residual (position, velocity) before. ``constraint_fn(q, qd) -> (M, g, A)``.

    The ``newton + 1`` evaluations of ``constraint_fn`` are one loop whose body holds it once
    (a Newton step, or on the last pass the velocity projection), so a program holds the
    constraint kinematics once however many steps are taken."""
    def body(k, carry):
        q, qd, res = carry
        M, g, A = constraint_fn(q, qd)
        res = jax.tree.map(lambda a, b: jnp.where(k == 0, a, b), constraint_residual(g, A, qd, mask), res)
        last = k == newton
        qd_last, _ = project_velocity(M, A, qd, mask)
        q = jnp.where(last, q, q + project_position(M, A, g, mask))
        return q, jnp.where(last, qd_last, qd), res

    zero = jnp.zeros((), jnp.result_type(q))
    q, qd, res0 = jax.lax.fori_loop(0, newton + 1, body, (q, qd, (zero, zero)))
    return q, qd, res0
