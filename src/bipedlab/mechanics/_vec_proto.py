"""Prototype: vectorised (over bodies/dofs) dynamics, for speed comparison."""
from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from .tree import PRISMATIC, Model


class Plan:
    def __init__(self, model: Model, contacts):
        nb, nq = model.nb, model.nq
        self.nb, self.nq = nb, nq
        A = np.zeros((nb, nq))
        P = np.zeros((nb, nb))
        for b in range(nb):
            A[b, 2] = 1.0
            for a in model.ancestors(b)[1:]:
                if model.joints[a] != PRISMATIC:
                    A[b, model.dof_of_body(a)] = 1.0
                P[b, a] = 1.0
        self.A, self.P, self.S = A, P, P.T.copy()
        self.S[0, :] = 1.0  # root subtree = all
        for b in range(nb):
            self.S[b, b] = 1.0
        self.par = np.array([max(p, 0) for p in model.parents])
        self.nonroot = np.array([0.0] + [1.0] * (nb - 1))
        self.prism = np.array([1.0 if model.joints[b] == PRISMATIC else 0.0 for b in range(nb)])
        self.body_dof = np.array([0] + [model.dof_of_body(b) for b in range(1, nb)])
        # dof descriptors
        owner = [0, 0, 0] + list(range(1, nb))
        self.owner = np.array(owner)
        Wrev = np.array([0.0, 0.0, 1.0] + [0.0 if model.joints[b] == PRISMATIC else 1.0 for b in range(1, nb)])
        self.W = Wrev
        dpar = model.dof_parents()
        anc = np.zeros((nq, nq), bool)  # anc[j,k]: k ancestor-or-self of j
        for j in range(nq):
            k = j
            while k >= 0:
                anc[j, k] = True
                k = dpar[k]
        self.mask = (anc | anc.T).astype(float)
        desc = np.zeros((nq, nq), int)
        for j in range(nq):
            for k in range(nq):
                if anc[j, k]:
                    desc[j, k] = owner[j]
                elif anc[k, j]:
                    desc[j, k] = owner[k]
        self.desc = desc
        self.contacts = np.array(contacts, int)
        cb = [model.point_bodies[k] for k in contacts]
        self.cbody = np.array(cb, int)
        canc = np.zeros((len(contacts), nq))
        for i, b in enumerate(cb):
            canc[i, 0] = canc[i, 1] = canc[i, 2] = 1.0
            for a in model.ancestors(b)[1:]:
                canc[i, model.dof_of_body(a)] = 1.0
        self.canc = canc


def _perp(v):
    return jnp.stack([-v[..., 1], v[..., 0]], -1)


def _rot(c, s, v):
    return jnp.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], -1)


def _cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def contact_dynamics_vec(model: Model, ground, plan: Plan, q, qd, u, solver="solve"):
    A = plan.A
    ang = A @ q
    c, s = jnp.cos(ang), jnp.sin(ang)
    cp, sp = c[plan.par], s[plan.par]
    qb = q[plan.body_dof] * plan.prism
    qdb = qd[plan.body_dof] * plan.prism
    loc = model.offset + qb[:, None] * model.axis
    d = _rot(cp, sp, loc) * plan.nonroot[:, None]
    axw = _rot(cp, sp, model.axis) * plan.prism[:, None]
    o = plan.P @ d  # relative to root origin
    r = _rot(c, s, model.com)
    com = o + r
    w = A @ qd
    wp = w[plan.par]
    vd = wp[:, None] * _perp(d) + qdb[:, None] * axw
    ad = -(wp * wp)[:, None] * d + (2.0 * wp * qdb)[:, None] * _perp(axw)
    vo = qd[:2] + plan.P @ vd
    ao = plan.P @ ad
    ac = ao - (w * w)[:, None] * r + jnp.stack([0.0, model.gravity])
    f = model.mass[:, None] * ac
    n = _cross(com, f)
    F = plan.S @ f
    N = plan.S @ n
    # dof descriptors: t = -w perp(o_owner) + axis
    oo = o[plan.owner]
    T = -plan.W[:, None] * _perp(oo)
    T = T.at[0, 0].add(1.0).at[1, 1].add(1.0)
    T = T + jnp.concatenate([jnp.zeros((3, 2)), axw[1:]], 0)
    h = plan.W * N[plan.owner] + jnp.sum(T * F[plan.owner], -1)
    # composite inertias about the root origin
    mc = plan.S @ model.mass
    s1 = plan.S @ (model.mass[:, None] * com)
    J0 = plan.S @ (model.inertia + model.mass * jnp.sum(com * com, -1))
    D = plan.desc
    Wj, Wk = plan.W[:, None], plan.W[None, :]
    ps1 = _perp(s1)[D]  # (nq,nq,2)
    M = plan.mask * (Wj * Wk * J0[D] + Wj * jnp.sum(ps1 * T[None, :, :], -1)
                     + Wk * jnp.sum(ps1 * T[:, None, :], -1) + mc[D] * jnp.sum(T[:, None, :] * T[None, :, :], -1))
    # contacts
    cb = plan.cbody
    pr = _rot(c[cb], s[cb], model.point_offset[plan.contacts])
    prel = o[cb] + pr
    pw = prel + q[:2]
    pv = vo[cb] + w[cb][:, None] * _perp(pr)
    pen = ground.terrain(pw[:, 0]) - pw[:, 1]
    inside = pen > 0
    fy = jnp.where(inside, jnp.maximum(ground.stiffness * pen - ground.damping * pv[:, 1], 0.0), 0.0)
    fx = jnp.where(inside, -ground.tangential_damping * pv[:, 0], 0.0)
    Fc = jnp.stack([fx, fy], -1)
    Qc = jnp.sum(plan.canc * (plan.W[None, :] * _cross(prel, Fc)[:, None] + Fc @ T.T), 0)
    rhs = Qc - h + jnp.asarray(model.actuation_matrix()) @ u
    if solver == "solve":
        return jnp.linalg.solve(M, rhs)
    if solver == "chol":
        L = jnp.linalg.cholesky(M)
        return jax.scipy.linalg.cho_solve((L, True), rhs)
    from .dynamics import ltdl_solve
    n = plan.nq
    H = [[M[i, j] if plan.mask[i, j] else None for j in range(i + 1)] for i in range(n)]
    return jnp.stack(ltdl_solve(H, [rhs[i] for i in range(n)]))
