"""ATRIAS's dynamics from the core's tree model (bipedlab.mechanics) against the hand-written
mass matrix, bias, foot kinematics and Cholesky solve it replaced (tests/robots/atrias/_oracle.py)."""
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bipedlab.robots.atrias import robot as at

from . import _oracle as oracle

P = at.AtriasParams()


def _states(seed, n=5):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        q = np.array([0.3, 1.2, 0.2, np.pi - 0.3, np.pi + 0.4, 0.8, 0.6]) + 0.4 * rng.standard_normal(7)
        yield jnp.asarray(q), jnp.asarray(3.0 * rng.standard_normal(7)), jnp.asarray(50.0 * rng.standard_normal(4))


def _close(a, b, tol=1e-12):
    a, b = np.asarray(a), np.asarray(b)
    np.testing.assert_allclose(a, b, rtol=0, atol=tol * max(1.0, float(np.max(np.abs(b)))))


@pytest.mark.parametrize("params", [P, P.replace(m_f=1.3, d=0.17, I_m=0.4)])
def test_tree_model_equals_the_hand_written_dynamics(params):
    for q, qd, u in _states(0):
        _close(at.mass_matrix(params, q), oracle.mass_matrix(params, q))
        _close(at.free_forces(params, q, qd, u), oracle.free_forces(params, q, qd, u))
        _close(at.hip(params, q), oracle.hip(params, q))
        for i in range(2):
            _close(at.foot(params, q, i), oracle.foot(params, q, i))
            _close(at.foot_jac(params, q, i), oracle.foot_jac(params, q, i))
            _close(at.foot_bias(params, q, qd, i), oracle.foot_bias(params, q, qd, i))


def test_core_solve_equals_the_cholesky_oracle():
    rng = np.random.default_rng(5)
    for q, _, _ in _states(1, 3):
        J = at.foot_jac(P, q, 0)
        A = at.mass_matrix(P, q) + 1e-4 * J.T @ (jnp.array([3e4, 2e5])[:, None] * J)
        b = jnp.asarray(rng.standard_normal(7))
        _close(at.solve(A, b), oracle.spd_solve(A, b), 1e-10)
        _close(A @ at.solve(A, b), b, 1e-10)


def test_tree_model_is_jittable_and_batched():
    qs = jnp.stack([q for q, _, _ in _states(2, 4)])
    M = jax.jit(jax.vmap(lambda q: at.mass_matrix(P, q)))(qs)
    for k in range(4):
        _close(M[k], oracle.mass_matrix(P, qs[k]))
