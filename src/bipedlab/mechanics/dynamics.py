"""Mass matrix, bias forces, energies and momenta of a planar tree.

Convention: ``M(q) qdd + bias(q, qd) = B u + J^T F``.

* The mass matrix comes from the composite-rigid-body algorithm written with planar
  composite inertias (mass, centre of mass, inertia about it): entry (j, k) for k an ancestor
  of j is ``I_c + m_c (C - o_j).(C - o_k)`` for two revolute joints, with the analogous
  sliding-axis forms for prismatic ones; entries between different branches are zero.
* The bias comes from the recursive Newton-Euler algorithm with qdd = 0 and gravity as a
  fictitious upward acceleration of the base.
* ``forward_dynamics`` solves with a sparse ``L^T D L`` factorisation that follows the tree
  (no fill-in for tree-sparse matrices, Featherstone's LTDL), unrolled at trace time.
Nothing here differentiates inside the time step.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp

from bipedlab.mechanics import kinematics as kin
from bipedlab.mechanics.kinematics import Frames, Velocities
from bipedlab.mechanics.planar import add, cross, dot, perp, scale, sub
from bipedlab.mechanics.tree import PRISMATIC, Model


def _dof_kinds(model: Model, fr: Frames):
    """Per coordinate: (owner body, 'P' with world axis | 'R' with world origin)."""
    out = [(0, "P", (1.0, 0.0)), (0, "P", (0.0, 1.0)), (0, "R", fr.origin[0])]
    for b in range(1, model.nb):
        if model.joints[b] == PRISMATIC:
            out.append((b, "P", fr.axis[b]))
        else:
            out.append((b, "R", fr.origin[b]))
    return out


def _composites(model: Model, fr: Frames):
    """Composite (mass, COM, inertia about that COM) of every body's subtree."""
    nb = model.nb
    mc = [model.mass[b] for b in range(nb)]
    C = [fr.com[b] for b in range(nb)]
    Ic = [model.inertia[b] for b in range(nb)]
    for b in reversed(range(1, nb)):
        p = model.parents[b]
        m1, m2 = mc[p], mc[b]
        m = m1 + m2
        safe = jnp.where(m > 0, m, 1.0)  # a massless subtree's COM is irrelevant (weight 0)
        Cn = scale(1.0 / safe, add(scale(m1, C[p]), scale(m2, C[b])))
        d1, d2 = sub(C[p], Cn), sub(C[b], Cn)
        Ic[p] = Ic[p] + Ic[b] + m1 * dot(d1, d1) + m2 * dot(d2, d2)
        mc[p], C[p] = m, Cn
    return mc, C, Ic


def _dof_ancestry(model: Model):
    """For each coordinate j, its ancestors in the coordinate tree (inclusive), j first."""
    par = model.dof_parents()
    out = []
    for j in range(model.nq):
        chain, k = [], j
        while k >= 0:
            chain.append(k)
            k = par[k]
        out.append(chain)
    return out


def mass_matrix_entries(model: Model, fr: Frames) -> list:
    """Lower triangle of M as nested lists of scalars; None marks a structural zero."""
    n = model.nq
    H = [[None] * (j + 1) for j in range(n)]
    mc, C, Ic = _composites(model, fr)
    kinds = _dof_kinds(model, fr)
    for j, chain in enumerate(_dof_ancestry(model)):
        bj, tj, sj = kinds[j]
        m, c, I = mc[bj], C[bj], Ic[bj]
        for k in chain:
            _, tk, sk = kinds[k]
            if tj == "R" and tk == "R":
                val = I + m * dot(sub(c, sj), sub(c, sk))
            elif tj == "R":
                val = m * dot(perp(sub(c, sj)), sk)
            elif tk == "R":
                val = m * dot(sj, perp(sub(c, sk)))
            else:
                val = m * dot(sj, sk)
            H[j][k] = val  # k <= j because parents precede children
    for r, support in enumerate(model.rotor_support):
        J = model.rotor_inertia[r]
        for a in support:
            for b in support:
                if b <= a:
                    term = J * model.rotor_ratios[r, a] * model.rotor_ratios[r, b]
                    H[a][b] = term if H[a][b] is None else H[a][b] + term
    return H


def bias_entries(model: Model, fr: Frames, vel: Velocities) -> list:
    """Bias forces (Coriolis, centrifugal, gravity) as a list of scalars, by RNEA."""
    nb = model.nb
    g = (0.0, model.gravity)
    F, N = [None] * nb, [None] * nb
    for b in range(nb):
        w = vel.omega[b]
        rc = sub(fr.com[b], fr.origin[b])
        ac = add(sub(vel.a_origin[b], scale(w * w, rc)), g)
        f = scale(model.mass[b], ac)
        F[b] = f
        N[b] = cross(rc, f)
    for b in reversed(range(1, nb)):
        p = model.parents[b]
        F[p] = add(F[p], F[b])
        N[p] = N[p] + N[b] + cross(sub(fr.origin[b], fr.origin[p]), F[b])
    out = [F[0][0], F[0][1], N[0]]
    for b in range(1, nb):
        out.append(dot(fr.axis[b], F[b]) if model.joints[b] == PRISMATIC else N[b])
    return out


def ltdl_solve(H: list, rhs: list) -> list:
    """Solve M x = rhs with M = L^T D L (lower triangle H, None = zero), unrolled.

    Factorising from the last coordinate to the first creates no fill-in when the
    coordinates are ordered parents-before-children, so a branched robot costs O(n d^2)
    for tree depth d rather than O(n^3).
    """
    n = len(H)
    H = [list(row) for row in H]
    for k in reversed(range(n)):
        dk = H[k][k]
        for i in reversed(range(k)):  # deepest first: H[k][j<i] must still be unscaled
            hki = H[k][i]
            if hki is None:
                continue
            a = hki / dk
            for j in range(i + 1):
                hkj = H[k][j]
                if hkj is None:
                    continue
                H[i][j] = -a * hkj if H[i][j] is None else H[i][j] - a * hkj
            H[k][i] = a
    y = list(rhs)
    for k in reversed(range(n)):  # L^T y = rhs
        for i in range(k):
            if H[k][i] is not None:
                y[i] = y[i] - H[k][i] * y[k]
    x = [y[i] / H[i][i] for i in range(n)]
    for i in range(n):  # L x = D^-1 y
        for j in range(i):
            if H[i][j] is not None:
                x[i] = x[i] - H[i][j] * x[j]
    return x


def dense(H: list, like) -> jax.Array:
    """Symmetric dense matrix from a lower triangle of scalars (``None``: zero), each entry
    broadcast like ``like`` (so a batch of matrices under ``vmap``)."""
    n = len(H)
    zero = jnp.zeros_like(like)

    def get(i, j):
        v = H[i][j] if j <= i else H[j][i]
        return zero if v is None else v + zero

    return jnp.stack([jnp.stack([get(i, j) for j in range(n)]) for i in range(n)])


def mass_matrix(model: Model, q) -> jax.Array:
    """Joint-space inertia matrix M(q), shape (nq, nq), symmetric positive definite."""
    return dense(mass_matrix_entries(model, kin.frames(model, q)), q[0])


def bias(model: Model, q, qd) -> jax.Array:
    """Bias vector h(q, qd) = C(q, qd) qd + g(q), shape (nq,)."""
    fr = kin.frames(model, q)
    vel = kin.velocities(model, fr, qd)
    return jnp.stack([e + jnp.zeros_like(q[0]) for e in bias_entries(model, fr, vel)])


def gravity_forces(model: Model, q) -> jax.Array:
    """Gravity part of the bias, dV/dq, shape (nq,)."""
    return bias(model, q, jnp.zeros_like(q))


def forward_dynamics(model: Model, q, qd, tau) -> jax.Array:
    """qdd solving M qdd = tau - bias for a generalised force tau of shape (nq,)."""
    fr = kin.frames(model, q)
    vel = kin.velocities(model, fr, qd)
    h = bias_entries(model, fr, vel)
    rhs = [tau[i] - h[i] for i in range(model.nq)]
    return jnp.stack(ltdl_solve(mass_matrix_entries(model, fr), rhs))


def _body_velocities(model: Model, fr: Frames, vel: Velocities):
    """World COM velocity of every body."""
    return [
        add(vel.v_origin[b], scale(vel.omega[b], perp(sub(fr.com[b], fr.origin[b]))))
        for b in range(model.nb)
    ]


def _rotor_rates(model: Model, qd):
    return [
        sum(model.rotor_ratios[r, i] * qd[i] for i in support)
        for r, support in enumerate(model.rotor_support)
    ]


def kinetic_energy(model: Model, q, qd) -> jax.Array:
    """Kinetic energy (J) of bodies and rotors."""
    fr = kin.frames(model, q)
    vel = kin.velocities(model, fr, qd)
    vc = _body_velocities(model, fr, vel)
    T = 0.0
    for b in range(model.nb):
        T = T + 0.5 * (model.mass[b] * dot(vc[b], vc[b]) + model.inertia[b] * vel.omega[b] ** 2)
    for r, w in enumerate(_rotor_rates(model, qd)):
        T = T + 0.5 * model.rotor_inertia[r] * w**2
    return jnp.asarray(T)


def potential_energy(model: Model, q) -> jax.Array:
    """Gravitational potential energy (J), zero at y = 0."""
    fr = kin.frames(model, q)
    return jnp.asarray(sum(model.gravity * model.mass[b] * fr.com[b][1] for b in range(model.nb)))


def total_mass(model: Model) -> jax.Array:
    return jnp.sum(model.mass)


def com_position(model: Model, q) -> jax.Array:
    """Centre of mass of the whole robot (m), shape (2,)."""
    fr = kin.frames(model, q)
    mc, C, _ = _composites(model, fr)
    return jnp.stack(C[0])


def com_velocity(model: Model, q, qd) -> jax.Array:
    """Velocity of the centre of mass (m/s), shape (2,)."""
    fr = kin.frames(model, q)
    vel = kin.velocities(model, fr, qd)
    vc = _body_velocities(model, fr, vel)
    m = sum(model.mass[b] for b in range(model.nb))
    return jnp.stack([sum(model.mass[b] * vc[b][i] for b in range(model.nb)) / m for i in range(2)])


def angular_momentum(model: Model, q, qd, point) -> jax.Array:
    """Angular momentum (kg m^2/s) about a fixed world point (2,), rotors included."""
    fr = kin.frames(model, q)
    vel = kin.velocities(model, fr, qd)
    vc = _body_velocities(model, fr, vel)
    P = (point[0], point[1])
    L = 0.0
    for b in range(model.nb):
        L = L + model.mass[b] * cross(sub(fr.com[b], P), vc[b]) + model.inertia[b] * vel.omega[b]
    for r, w in enumerate(_rotor_rates(model, qd)):
        L = L + model.rotor_inertia[r] * w
    return jnp.asarray(L)
