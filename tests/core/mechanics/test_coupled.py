"""bipedlab.mechanics.coupled (a tree seen through q_tree = T q, rotors with rates R q_dot and a
constant generalised weight) on MABEL's 13-DoF hopping body and its 9-DoF restriction.

Oracles are autodiff of the model's own energies, which are simple sums (link kinetic energy,
0.5 J (R qd)^2, m g y_com + w.q): the mass matrix is the Hessian of the kinetic energy, the bias
is Lagrange's (d/dq (M qd)) qd - dT/dq + dV/dq, the restriction q = E p is the chain rule, and
point Jacobians are forward-mode derivatives of point positions.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bipedlab.mechanics import coupled as cp
from bipedlab.robots.mabel import model as mm
from helpers import random_states, rel_err

N_STATES = 6


@pytest.fixture(scope="module")
def bodies():
    full = mm.hopping_model().body
    rigid = mm.rigid_model().body
    return full, rigid, mm.rigid_map()


@pytest.fixture(scope="module")
def states13():
    rng = np.random.default_rng(3)
    q, qd = random_states(rng, N_STATES, 13, qd_scale=2.0)
    qd[:, 9:] *= 10.0  # motors turn fast
    return jnp.asarray(q), jnp.asarray(qd)


@pytest.fixture(scope="module")
def states9():
    rng = np.random.default_rng(4)
    q, qd = random_states(rng, N_STATES, 9, qd_scale=2.0)
    q[:, 7:] *= 20.0  # leg-shape motor angles span tens of radians
    qd[:, 7:] *= 10.0
    return jnp.asarray(q), jnp.asarray(qd)


def _lagrangian_bias(body, q, qd):
    """b = (d/dq (M qd)) qd - dT/dq + dV/dq from autodiff of kinetic and potential energy."""
    p = lambda q: jax.grad(cp.kinetic_energy, argnums=2)(body, q, qd)  # noqa: E731
    dp_dq = jax.jacfwd(p)(q)
    return dp_dq @ qd - jax.grad(cp.kinetic_energy, argnums=1)(body, q, qd) + jax.grad(cp.potential_energy, argnums=1)(body, q)


def test_mass_matrix_is_kinetic_energy_hessian(bodies, states13):
    """M(q) = d^2 T / d qd^2 (T computed link by link plus rotor terms), T = 0.5 qd^T M qd,
    and M is symmetric positive definite (every coordinate carries inertia: motors and
    pulleys through their rotors, the hip through the boom). 13-DoF body; the 9-DoF one
    follows through test_restrict_is_chain_rule."""
    body = bodies[0]
    q, qd = states13

    @jax.jit
    def f(q, qd):
        one = lambda q, qd: (cp.mass_matrix(body, q), jax.hessian(cp.kinetic_energy, argnums=2)(body, q, qd),  # noqa: E731
                             cp.kinetic_energy(body, q, qd))
        return jax.vmap(one)(q, qd)

    M, Hess, T = (np.asarray(a) for a in f(q, qd))
    assert rel_err(M, Hess) < 1e-12
    np.testing.assert_allclose(M, np.swapaxes(M, 1, 2), rtol=0, atol=1e-13 * np.abs(M).max())
    np.testing.assert_allclose(T, 0.5 * np.einsum("ni,nij,nj->n", qd, M, qd), rtol=1e-12)
    eig = np.linalg.eigvalsh(M)
    assert np.all(eig > 0.0)
    assert eig.min() > 1e-5  # smallest: a motor rotor (alpha J ~ 3e-4 kg m^2) and its pulleys


def test_bias_is_lagrangian(bodies, states13):
    """bias(q, qd) = C(q, qd) qd + g(q) equals Lagrange's (d/dq (dT/dqd)) qd - dT/dq + dV/dq
    by autodiff of the energies; the potential includes the boom's constant weight w.q, so
    bias(q, 0) = dV/dq (gravity forces)."""
    body = bodies[0]
    q, qd = states13

    @jax.jit
    def f(q, qd):
        one = lambda q, qd: (cp.bias(body, q, qd), _lagrangian_bias(body, q, qd), cp.bias(body, q, 0.0 * qd),  # noqa: E731
                             jax.grad(cp.potential_energy, argnums=1)(body, q))
        return jax.vmap(one)(q, qd)

    b, b_ref, g, g_ref = (np.asarray(a) for a in f(q, qd))
    for k in range(len(b)):
        assert rel_err(b[k], b_ref[k]) < 1e-11
        assert rel_err(g[k], g_ref[k]) < 1e-12
    # the boom's weight acts on y only: m_boom g r_com / R, on top of the links' weight
    assert float(body.weight[1]) > 0.0 and np.count_nonzero(np.asarray(body.weight)) == 1


def test_restrict_is_chain_rule(bodies, states9):
    """restrict(model, E): with q = E p the 9-DoF model has M_e = E^T M_h(E p) E,
    bias_e = E^T bias_h(E p, E pd), the same kinetic and potential energy, weight E^T w."""
    full, rigid, E = bodies
    Ej = jnp.asarray(E)
    q, qd = states9

    @jax.jit
    def f(q, qd):
        def one(q, qd):
            qh, qdh = Ej @ q, Ej @ qd
            return (cp.mass_matrix(rigid, q), Ej.T @ cp.mass_matrix(full, qh) @ Ej,
                    cp.bias(rigid, q, qd), Ej.T @ cp.bias(full, qh, qdh),
                    cp.kinetic_energy(rigid, q, qd), cp.kinetic_energy(full, qh, qdh),
                    cp.potential_energy(rigid, q), cp.potential_energy(full, qh))
        return jax.vmap(one)(q, qd)

    out = [np.asarray(a) for a in f(q, qd)]
    for k in range(len(q)):
        assert rel_err(out[0][k], out[1][k]) < 1e-13
        assert rel_err(out[2][k], out[3][k]) < 1e-12
    np.testing.assert_allclose(out[4], out[5], rtol=1e-13)
    np.testing.assert_allclose(out[6], out[7], rtol=1e-13)
    np.testing.assert_allclose(np.asarray(rigid.weight), E.T @ np.asarray(full.weight), rtol=1e-15)
    np.testing.assert_allclose(np.asarray(rigid.T), np.asarray(full.T) @ E, rtol=1e-15)


@pytest.mark.parametrize("point", ["toe_L", "toe_R", "knee_L", "head"])
def test_point_jacobian_is_derivative_of_position(bodies, states13, states9, point):
    """point_jacobian(q) = d point_position / dq (jacfwd) in both coordinate sets, and the
    toe really is the sum of two 0.5 m segments: |toe - hip| = cos(q_LS) (with unit length
    1 m), independent of the leg angle (eq. 1 geometry)."""
    full, rigid, E = bodies
    for body, (q, _) in ((full, states13), (rigid, states9)):
        @jax.jit
        def f(q):
            one = lambda q: (cp.point_jacobian(body, q, point), jax.jacfwd(cp.point_position, argnums=1)(body, q, point))  # noqa: E731
            return jax.vmap(one)(q)

        J, J_ref = (np.asarray(a) for a in f(q))
        for k in range(len(q)):
            assert rel_err(J[k], J_ref[k]) < 1e-13
    if point == "toe_L":
        q = states13[0]
        hip = np.asarray(jax.vmap(lambda q: cp.point_position(full, q, "hip"))(q))
        toe = np.asarray(jax.vmap(lambda q: cp.point_position(full, q, "toe_L"))(q))
        np.testing.assert_allclose(hip, np.asarray(q[:, :2]), rtol=1e-15)
        ls = np.asarray(q[:, mm.COORDS_13.index("ls_L")])
        np.testing.assert_allclose(np.linalg.norm(toe - hip, axis=1), np.abs(np.cos(ls)), rtol=1e-12)


def test_sparse_solve_matches_dense(bodies, states13):
    """coupled.solve (unrolled sparse LTDL on the lower triangle) solves M x = rhs."""
    full, _, _ = bodies
    q = states13[0][0]
    rhs = jnp.asarray(np.random.default_rng(5).normal(size=13))

    @jax.jit
    def f(q, rhs):
        from bipedlab.mechanics import kinematics as kin
        fr = kin.frames(full.tree, cp.tree_coordinates(full, q))
        H = cp.mass_matrix_entries(full, fr)
        return jnp.stack(cp.solve(H, list(rhs))), cp.dense(H, q[0])

    x, M = f(q, rhs)
    np.testing.assert_allclose(np.asarray(M) @ np.asarray(x), np.asarray(rhs), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(np.asarray(M), np.asarray(cp.mass_matrix(full, q)), rtol=1e-12, atol=1e-13)
