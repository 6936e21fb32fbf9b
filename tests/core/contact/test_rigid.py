"""Active-set constrained dynamics (bipedlab.contact.rigid) and the seven-link contact
model built on it: constrained equations of motion, constraint forces that hold a supported
foot, plastic impacts that never add kinetic energy, force-sign releases."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bipedlab.contact import rigid as aset
from bipedlab.robots.seven_link import robot as sl
from bipedlab.robots.seven_link import contact as sc


def _spd(rng, n):
    X = rng.standard_normal((n, n))
    return X @ X.T + n * np.eye(n)


def test_accelerations_solve_the_constrained_equations():
    rng = np.random.default_rng(0)
    M, A = _spd(rng, 7), rng.standard_normal((4, 7))
    f, ab = rng.standard_normal(7), rng.standard_normal(4)
    mask = jnp.array([1.0, 0.0, 1.0, 1.0])
    qdd, lam = aset.accelerations(jnp.asarray(M), jnp.asarray(f), jnp.asarray(A), jnp.asarray(ab), mask)
    qdd, lam = np.asarray(qdd), np.asarray(lam)
    act = np.asarray(mask) > 0
    np.testing.assert_allclose(M @ qdd, f + A.T @ lam, atol=1e-12)
    np.testing.assert_allclose(A[act] @ qdd, -ab[act], atol=1e-12)
    assert lam[~act] == pytest.approx(0.0)
    # the same as Gauss's principle: least M-weighted deviation from the free acceleration
    Minv = np.linalg.inv(M)
    Aa = A[act]
    lam_a = np.linalg.solve(Aa @ Minv @ Aa.T, -ab[act] - Aa @ Minv @ f)
    np.testing.assert_allclose(lam[act], lam_a, rtol=1e-10)


def test_velocity_projection_is_plastic_and_never_adds_energy():
    rng = np.random.default_rng(1)
    for _ in range(20):
        M, A, qd = _spd(rng, 6), rng.standard_normal((3, 6)), rng.standard_normal(6)
        mask = jnp.asarray(rng.integers(0, 2, 3).astype(float))
        qdp, imp = aset.project_velocity(jnp.asarray(M), jnp.asarray(A), jnp.asarray(qd), mask)
        qdp = np.asarray(qdp)
        act = np.asarray(mask) > 0
        np.testing.assert_allclose(A[act] @ qdp, 0.0, atol=1e-12)
        np.testing.assert_allclose(M @ (qdp - qd), A.T @ np.asarray(imp), atol=1e-12)
        assert 0.5 * qdp @ M @ qdp <= 0.5 * qd @ M @ qd + 1e-12


def test_release_drops_the_pulling_element_only():
    # a unit point mass (q = [x, y]) resting on two unilateral supports, y >= 0 (row 0) and
    # x >= 0 (row 1), under the applied force F = (+1, -2): pressed into y = 0, pulled off x = 0
    M = jnp.eye(2)
    A = jnp.array([[0.0, 1.0], [1.0, 0.0]])
    F = jnp.array([1.0, -2.0])

    def force_fn(active):
        qdd, lam = aset.accelerations(M, F, A, jnp.zeros(2), active.astype(jnp.float64))
        return lam, A @ qdd

    act, lam, dropped = aset.release(force_fn, jnp.array([True, True]), 3)
    # the x support would have to pull (lam = -1): released; the y support pushes with 2 N
    assert bool(dropped[1]) and not bool(dropped[0])
    np.testing.assert_allclose(np.asarray(lam), [2.0, 0.0], atol=1e-12)
    assert list(np.asarray(act)) == [True, False]


@pytest.fixture(scope="module")
def robot():
    return sl.model()


@jax.jit
def _points(robot, q):
    return jnp.stack([sl.point_position(robot, q, n) for n in sl.CONTACTS])


@jax.jit
def _project(robot, x, active, anchors):
    return sc.project(robot, x, active, anchors)[0]


@jax.jit
def _terms(robot, q, qd):
    """(M, h, P, J, Jd, A) at (q, qd): compiled once, the same values as op by op."""
    M, h, P, _, J, Jd = sl.dynamics_terms(robot, q, qd)
    return M, h, P, J, Jd, sc.constraint_jacobian(J, Jd)[0]


_kinetic_energy = jax.jit(sl.kinetic_energy)


def _stance_state(robot, rng):
    phi = np.deg2rad([10.0, 0.0, 0.0, -20.0, -40.0, 5.0]) + np.deg2rad(3.0) * rng.standard_normal(6)
    phi[1] = 0.0
    q = sl.configuration(np.pi / 2 - 0.05, phi, anchor="heel_1", r=robot)
    qd = jnp.asarray(rng.standard_normal(9))
    active = jnp.array([True, True, False, False, True, False])
    P = _points(robot, q)
    anchors = P[:, 0]
    x = jnp.concatenate([q, qd])
    for _ in range(4):  # the foot starts tilted by a few degrees: Newton to convergence
        x = _project(robot, x, active, anchors)
    return x, active, anchors


def test_constraint_forces_keep_a_supported_foot_fixed(robot):
    rng = np.random.default_rng(2)
    x, active, anchors = _stance_state(robot, rng)
    u = jnp.asarray(5.0 * rng.standard_normal(6))
    qdd, lam = jax.jit(sc.solve)(robot, x, u, active)
    M, h, P, J, Jd, A = _terms(robot, x[:9], x[9:])
    # the constrained equations of motion: M qdd + h = E u + damping + A^T lambda
    np.testing.assert_allclose(M @ qdd + h, sl.actuation(u) + sl.damping_force(robot, x[9:]) + A.T @ lam, atol=1e-10)
    # toe and heel of the supported foot do not accelerate; the knee stays on its stop
    for k in (0, 1):
        np.testing.assert_allclose(J[k] @ qdd + Jd[k], 0.0, atol=1e-10)
    assert abs(float(sl.joint_rates(qdd)[1])) < 1e-10
    # integrate 0.2 s with the projection: the foot stays where it was to far below 1e-8 m
    step = jax.jit(lambda x: sc.project(robot, sc.step(robot, x, u, active, 1e-3), active, anchors)[0])
    P0 = np.asarray(P[:2])
    xs = x
    for _ in range(200):
        xs = step(xs)
    Pn = np.asarray(_points(robot, xs[:9]))[:2]
    assert np.abs(Pn - P0).max() < 1e-10
    assert float(sc.residual(robot, xs, active, anchors)[0]) < 1e-10


def test_impacts_never_increase_kinetic_energy(robot):
    rng = np.random.default_rng(3)
    imp = jax.jit(lambda x, a, n: sc.impact(robot, x, a, n))
    checked = 0
    for trial in range(12):
        x, active, _ = _stance_state(robot, rng)
        q, qd = x[:9], x[9:]
        # leg 2 lands: toe, heel, or both, or leg 2's knee reaches its stop
        new = [jnp.array([0, 0, 1, 0, 0, 0], bool), jnp.array([0, 0, 0, 1, 0, 0], bool),
               jnp.array([0, 0, 1, 1, 0, 0], bool), jnp.array([0, 0, 0, 0, 0, 1], bool)][trial % 4]
        qd = qd.at[1].add(-1.0)  # moving into the ground
        xe = jnp.concatenate([q, qd])
        x1, imps, act = imp(xe, active, new)
        ke0 = float(_kinetic_energy(robot, q, qd))
        ke1 = float(_kinetic_energy(robot, x1[:9], x1[9:]))
        assert ke1 <= ke0 + 1e-12
        # post-impact velocities satisfy the new active constraints
        A = _terms(robot, x1[:9], x1[9:])[5]
        np.testing.assert_allclose((A @ x1[9:]) * sc.row_mask(act), 0.0, atol=1e-10)
        assert np.all(np.asarray(act)[np.asarray(new)])
        checked += 1
    assert checked == 12
