"""The nonkinematic controller of the seven-link biped: eq. 4 generalised forces, the eq. 7
torque map (exact when fully actuated, least acceleration energy otherwise, checked against
a direct least-squares solve), the S1-S4 switching and the Section V-A body-angle sensing."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bipedlab.robots.seven_link import controller as ctl
from bipedlab.robots.seven_link import robot as sl


@pytest.fixture(scope="module")
def robot():
    return sl.model()


def _posture(robot, seed=0):
    rng = np.random.default_rng(seed)
    phi = np.deg2rad([8.0, 0.0, 2.0, -15.0, -35.0, 8.0]) + np.deg2rad(4.0) * rng.standard_normal(6)
    phi[1] = 0.0
    phi[2] = np.pi / 2 - (np.deg2rad(86.0) + phi[0] + phi[1])  # foot 1 flat (theta_3 = 0)
    q = sl.configuration(np.deg2rad(86.0), phi, anchor="heel_1", r=robot)
    return q, jnp.asarray(rng.standard_normal(9)), rng


def _lsq_reference(M, A, Qd):
    """u minimising (qdd_d - qdd_u)^T M (qdd_d - qdd_u) by a plain least-squares solve, with the
    constrained accelerations computed from the KKT system (not from N, R)."""
    M, A, Qd = map(np.asarray, (M, A, Qd))
    A = A[np.abs(A).sum(axis=1) > 0]
    # the M-orthogonal projection onto the constraint tangent space, via an orthonormal
    # null-space basis Z of A: qdd = Z (Z^T M Z)^-1 Z^T Q
    _, s, Vt = np.linalg.svd(A) if len(A) else (None, np.zeros(0), np.eye(9))
    rank = int(np.sum(s > 1e-10 * max(s.max(initial=0), 1)))
    Z = Vt[rank:].T
    P = Z @ np.linalg.solve(Z.T @ M @ Z, Z.T)
    qdd_d = P @ Qd
    G = P @ sl.E
    L = np.linalg.cholesky(M)  # M = L L^T: the M-norm is ||L^T v||
    u, *_ = np.linalg.lstsq(L.T @ G, L.T @ qdd_d, rcond=None)
    return u, qdd_d, G


CASES = {
    # (contacts toe_1 heel_1 toe_2 heel_2, knees locked): fully actuated or redundant
    "one foot flat": ([1, 1, 0, 0], [1, 0], True),
    "both feet flat": ([1, 1, 1, 1], [1, 1], True),
    "heel and toe of different feet": ([1, 0, 0, 1], [1, 1], True),
    # underactuated
    "flight": ([0, 0, 0, 0], [0, 0], False),
    "one toe": ([1, 0, 0, 0], [1, 0], False),
}


@pytest.mark.parametrize("case", list(CASES))
def test_torque_map_eq7(robot, case):
    contacts, knees, full = CASES[case]
    q, qd, rng = _posture(robot, seed=len(case))
    M = sl.mass_matrix(robot, q)
    A = ctl.active_rows(robot, q, jnp.asarray(contacts, float), jnp.asarray(knees, float))
    Qd = jnp.asarray(10.0 * rng.standard_normal(9))
    u = np.asarray(ctl.torque_map(M, A, Qd))
    qdd_d = np.asarray(ctl.constrained_acceleration(M, A, Qd))
    qdd_u = np.asarray(ctl.constrained_acceleration(M, A, sl.actuation(u)))
    u_ref, qdd_ref, G = _lsq_reference(M, A, Qd)
    np.testing.assert_allclose(qdd_d, qdd_ref, atol=1e-9 * max(1, np.abs(qdd_ref).max()))
    Mn = np.asarray(M)
    cost = lambda v: float((qdd_d - G @ v) @ Mn @ (qdd_d - G @ v))  # noqa: E731
    if full:
        # fully actuated (or redundant): the desired constrained motion exactly
        np.testing.assert_allclose(qdd_u, qdd_d, atol=1e-9 * np.abs(qdd_d).max())
    else:
        assert cost(u) > 1e-6  # the desired motion is not realisable
    # least acceleration energy: no better than the direct least-squares solve, and no
    # random perturbation improves it; among equals the least-norm torque
    assert cost(u) <= cost(u_ref) * (1 + 1e-9) + 1e-12
    for _ in range(5):
        assert cost(u) <= cost(u + 0.1 * rng.standard_normal(6)) + 1e-12
    np.testing.assert_allclose(u, u_ref, rtol=1e-7, atol=1e-8 * np.abs(u_ref).max())


def test_desired_forces_are_spring_damper_couples(robot):
    """Q_d = -dV/dq - B phi_c_dot for V = sum k (phi_c - phi_d)^2 / 2 over the seven couples."""
    g = ctl.paper_gains()
    states = jnp.array([ctl.S1, ctl.S3])
    q, qd, _ = _posture(robot)
    k, b, ref = ctl.couple_parameters(g, states)
    V = lambda qq: 0.5 * jnp.sum(k * (ctl.couple_coordinates(qq) - ref) ** 2)  # noqa: E731
    Qd = ctl.desired_forces(g, states, q, qd)
    Cq = jnp.asarray(ctl.C)
    np.testing.assert_allclose(Qd, -jax.grad(V)(q) - Cq.T @ (b * (Cq @ qd)), atol=1e-12)
    # couple coordinates: body and thigh absolute, knee and ankle relative
    phc = ctl.couple_coordinates(q)
    phi = sl.joint_angles(q)
    np.testing.assert_allclose(phc, [q[2], q[3], phi[1], phi[2], q[6], phi[4], phi[5]], atol=1e-14)
    # Table II values reach the couples: stance thigh 80 N m/rad at 82 deg, swing 15 at 128
    assert float(k[1]) == 80.0 and float(k[4]) == 15.0
    assert np.rad2deg(float(ref[1])) == pytest.approx(82.0) and np.rad2deg(float(ref[4])) == pytest.approx(128.0)


def test_switching_cycle_s1_to_s4():
    s = jnp.array([ctl.S1, ctl.S3])
    flat = jnp.array([False, False])
    seq = [  # (toe_1, heel_1, toe_2, heel_2), knees extended
        ((1, 1, 0, 0), (1, 0)),  # leg 1 flat: S1 stays, heel seen; leg 2 swings
        ((1, 0, 0, 0), (1, 1)),  # heel 1 lifts: S2 push-off; leg 2 knee extends: S4
        ((1, 0, 0, 1), (1, 1)),  # leg 2 heel strike: S1
        ((0, 0, 1, 1), (0, 1)),  # leg 1 off the ground: S3
        ((0, 0, 1, 1), (1, 1)),  # leg 1 knee extends: S4
        ((0, 1, 1, 1), (1, 1)),  # leg 1 lands: S1
    ]
    got = []
    for c, kn in seq:
        s, flat = ctl.next_states(s, flat, jnp.asarray(c, bool), jnp.asarray(kn, bool))
        got.append(tuple(int(v) for v in s))
    assert got == [(0, 2), (1, 3), (1, 0), (2, 0), (3, 0), (0, 0)]


def test_kinematic_body_angle_from_encoders(robot):
    """Eq. 8: with a foot flat on the ground the body angle follows from the joint angles
    alone, also with the quantised encoders (error of the order of their resolution)."""
    q, _, _ = _posture(robot)
    phi = sl.joint_angles(q)
    contacts = jnp.array([True, True, False, False])
    th = ctl.kinematic_body_angle(robot, phi, contacts, q[2] + 0.05)
    assert abs(float(th - q[2])) < 1e-12
    phq = ctl._quantise(phi, jnp.asarray(sl.ENCODER_RESOLUTION))
    th_q = ctl.kinematic_body_angle(robot, phq, contacts, q[2])
    assert abs(float(th_q - q[2])) < 3 * np.deg2rad(7.3e-3)
    # two contacts of different feet (toe of one, heel of the other) also fix it
    q2 = sl.configuration(np.deg2rad(88.0), np.deg2rad([20.0, 0.0, 10.0, -15.0, 0.0, -5.0]), anchor="toe_1", r=robot)
    heel2 = sl.point_position(robot, q2, "heel_2")
    assert float(heel2[1]) != 0.0
    # tilt the whole robot about toe_1 until heel_2 touches, then recover the body angle
    from scipy.optimize import brentq

    def height(d):
        qq = sl.configuration(np.deg2rad(88.0) + d, sl.joint_angles(q2), anchor="toe_1", r=robot)
        return float(sl.point_position(robot, qq, "heel_2")[1])

    d = brentq(height, -0.6, 0.6)
    qq = sl.configuration(np.deg2rad(88.0) + d, sl.joint_angles(q2), anchor="toe_1", r=robot)
    th2 = ctl.kinematic_body_angle(robot, sl.joint_angles(qq), jnp.array([True, False, False, True]), qq[2] - 0.03)
    assert abs(float(th2 - qq[2])) < 1e-10


def test_unilateral_check_never_asks_an_element_to_pull(robot):
    """The policy's unilateral check: where eq. 7 with every touching element in A would need
    a toe, heel or knee stop to pull, that element is left out of A and u changes; where no
    element pulls, u is eq. 7's exactly."""
    from bipedlab.robots.seven_link import contact as sc

    gains = ctl.tuned_gains()
    u_of = jax.jit(lambda p, x, a: ctl.policy(p, ctl.initial_state(x, (ctl.S1, ctl.S3)), 0.0, x, a)[0])
    p_on, p_off = ctl.make_params(robot, gains), ctl.make_params(robot, gains, unilateral_check=False)
    forces = jax.jit(lambda x, u, a: sc.element_forces(sc.solve(robot, x, u, a)[1]))
    active = jnp.array([True, True, False, False, True, False])
    changed = unchanged = 0
    for seed in range(10):
        q, qd, _ = _posture(robot, seed)
        x = jnp.concatenate([q, 0.3 * qd])
        u_off, u_on = u_of(p_off, x, active), u_of(p_on, x, active)
        F_off = forces(x, u_off, active)[np.asarray(active)]
        if float(F_off.min()) >= 0.0:
            np.testing.assert_allclose(u_on, u_off, atol=1e-12)
            unchanged += 1
        else:
            assert float(jnp.abs(u_on - u_off).max()) > 1e-6
            changed += 1
    assert changed > 0 and unchanged > 0, (changed, unchanged)
