"""The seven-link biped of Braun, Mitchell and Goldfarb (Table I): parameters, coordinates,
contact points, and its mass matrix and bias against an independent Lagrangian written here
from the link geometry in absolute angles."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bipedlab.robots.seven_link import robot as sl

MA = 0.84  # actuator mass (Table I)


def _u(a):
    return jnp.stack([jnp.cos(a), jnp.sin(a)])


def _n(a):
    return jnp.stack([-jnp.sin(a), jnp.cos(a)])


def _parts(q):
    """[(mass, inertia, position (2,), angle)] of every rigid part and point mass, written
    directly from Fig. 1 / Table I (not from the package's tree)."""
    hip = q[:2]
    th = q[2]
    B, Th, Sh, F = sl.BODY, sl.THIGH, sl.SHANK, sl.FOOT
    parts = [(B["mass"], B["inertia"], hip + B["com"] * _u(th), th), (2 * MA, 0.0, hip, th)]
    for leg in range(2):
        t1, t2, t3 = q[3 + 3 * leg], q[4 + 3 * leg], q[5 + 3 * leg]
        knee = hip - Th["length"] * _u(t1)
        ankle = knee - Sh["length"] * _u(t2)
        parts += [(Th["mass"], Th["inertia"], hip - Th["com"] * _u(t1), t1), (MA, 0.0, knee, t1),
                  (Sh["mass"], Sh["inertia"], knee - Sh["com"] * _u(t2), t2), (MA, 0.0, ankle, t2),
                  (F["mass"], F["inertia"], ankle + F["c_x"] * _u(t3) - F["c_y"] * _n(t3), t3)]
    return parts


def _toe_heel(q):
    out = []
    F = sl.FOOT
    for leg in range(2):
        t1, t2, t3 = q[3 + 3 * leg], q[4 + 3 * leg], q[5 + 3 * leg]
        ankle = q[:2] - sl.THIGH["length"] * _u(t1) - sl.SHANK["length"] * _u(t2)
        out += [ankle + F["a"] * _u(t3) - F["h"] * _n(t3), ankle - F["b"] * _u(t3) - F["h"] * _n(t3)]
    return jnp.stack(out)


def _phi(q):
    return jnp.stack([q[3] - q[2], q[4] - q[3], q[5] - q[4] + jnp.pi / 2,
                      q[6] - q[2], q[7] - q[6], q[8] - q[7] + jnp.pi / 2])


J_ROTOR = jnp.array([0.0067, 0.0022, 0.0067, 0.0067, 0.0022, 0.0067])


def _coords(q):
    """Positions (k, 2) and angles (k,) of all parts, and the joint angles."""
    parts = _parts(q)
    return jnp.stack([p[2] for p in parts]), jnp.stack([p[3] for p in parts]), _phi(q)


_MASS = jnp.array([p[0] for p in _parts(jnp.zeros(9))])
_INERTIA = jnp.array([p[1] for p in _parts(jnp.zeros(9))])


def _kinetic(q, qd):
    _, (v, w, phid) = jax.jvp(_coords, (q,), (qd,))
    return 0.5 * (_MASS @ jnp.sum(v**2, axis=1) + _INERTIA @ w**2 + J_ROTOR @ phid**2)


def _potential(q):
    return sum(m * 9.81 * p[1] for m, _, p, _ in _parts(q))


@jax.jit
def _oracle_M(q):
    return jax.hessian(_kinetic, argnums=1)(q, jnp.zeros(9))


@jax.jit
def _oracle_bias(q, qd):
    dTdqd = lambda qq: jax.grad(_kinetic, argnums=1)(qq, qd)  # noqa: E731
    return (jax.jacfwd(dTdqd)(q) @ qd - jax.grad(_kinetic, argnums=0)(q, qd) + jax.grad(_potential)(q))


@pytest.fixture(scope="module")
def robot():
    return sl.model()


def _states(n, seed=0):
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, (n, 9))
    q[:, :2] = rng.uniform(-1, 1, (n, 2))
    return q, 1.5 * rng.standard_normal((n, 9))


def test_table_i_parameters(robot):
    # links 6.12 + 2 (0.67 + 0.55 + 0.36) plus six 0.84 kg actuators: the stated 14.3 kg
    assert float(sl.total_mass(robot)) == pytest.approx(14.32, abs=1e-12)
    assert abs(float(sl.total_mass(robot)) - sl.TOTAL_MASS) < 0.05
    assert sl.FOOT["a"] + sl.FOOT["b"] == pytest.approx(sl.FOOT["length"])
    np.testing.assert_allclose(np.asarray(robot.gear_ratio), [21, 12, 21, 21, 12, 21])
    np.testing.assert_allclose(np.asarray(robot.coupled.rotor_inertia), J_ROTOR)
    np.testing.assert_allclose(np.asarray(robot.damping), [0.13, 0.11, 0.05, 0.13, 0.11, 0.05])
    # standing straight: hip at thigh + shank + ankle height; head 0.39 m above the hip
    q = sl.configuration(np.pi / 2, np.zeros(6), anchor="heel_1")
    assert float(q[1]) == pytest.approx(0.295 + 0.298 + 0.055, abs=1e-12)
    assert float(sl.point_position(robot, q, "head")[1]) == pytest.approx(q[1] + 0.39)


def test_gear_ratio_scales_reflected_inertia_and_damping():
    r = sl.model(gear_ratios=(105.0, 60.0, 21.0))
    J = np.asarray(r.coupled.rotor_inertia)
    assert J[0] == pytest.approx(105**2 * sl.MOTOR_INERTIA) and J[1] == pytest.approx(60**2 * sl.MOTOR_INERTIA)
    assert J[0] / 0.0067 == pytest.approx(25.0, rel=2e-3)
    np.testing.assert_allclose(np.asarray(r.damping)[:3], [0.13 * 25, 0.11 * 25, 0.05])


def test_joint_angle_maps_and_E():
    q, qd = _states(4)
    for qq in q:
        phi = sl.joint_angles(jnp.asarray(qq))
        np.testing.assert_allclose(phi, _phi(jnp.asarray(qq)), atol=1e-14)
        np.testing.assert_allclose(sl.absolute_angles(qq[2], phi), qq[2:], atol=1e-13)
        # E = (d phi / d q)^T: the virtual work of joint torques u is u . dphi
        np.testing.assert_allclose(sl.E, np.asarray(jax.jacfwd(_phi)(jnp.asarray(qq))).T, atol=1e-15)


def test_toe_and_heel_points_match_geometry(robot):
    q, _ = _states(5, seed=1)
    for qq in q:
        P = jnp.stack([sl.point_position(robot, jnp.asarray(qq), n) for n in sl.CONTACTS])
        np.testing.assert_allclose(P, _toe_heel(jnp.asarray(qq)), atol=1e-13)
        J = sl.point_jacobian(robot, jnp.asarray(qq), "toe_2")
        np.testing.assert_allclose(J, jax.jacfwd(lambda z: _toe_heel(z)[2])(jnp.asarray(qq)), atol=1e-12)


def test_mass_matrix_spd_and_matches_lagrangian_oracle(robot):
    q, qd = _states(4, seed=2)
    for qq, vv in zip(q, qd):
        qq = jnp.asarray(qq)
        M = np.asarray(sl.mass_matrix(robot, qq))
        np.testing.assert_allclose(M, M.T, atol=1e-14)
        assert np.linalg.eigvalsh(M).min() > 1e-4
        Mo = np.asarray(_oracle_M(qq))
        assert np.linalg.norm(M - Mo) / np.linalg.norm(Mo) < 1e-12
        h = np.asarray(sl.bias(robot, qq, jnp.asarray(vv)))
        ho = np.asarray(_oracle_bias(qq, jnp.asarray(vv)))
        assert np.linalg.norm(h - ho) / np.linalg.norm(ho) < 1e-11
        assert float(sl.kinetic_energy(robot, qq, vv)) == pytest.approx(0.5 * vv @ M @ vv, rel=1e-12)


def test_energy_conserved_in_unactuated_undamped_flight():
    from bipedlab.robots.seven_link import contact as sc

    r = sl.model(damping=(0.0, 0.0, 0.0))
    q = sl.configuration(1.4, np.deg2rad([20.0, -40.0, 10.0, -25.0, -10.0, -5.0]), anchor="heel_1",
                         anchor_xy=(0.0, 0.5), r=r)
    qd = jnp.array([0.4, 0.5, 1.0, -2.0, 3.0, 1.0, 2.0, -1.0, 4.0])
    x0 = jnp.concatenate([q, qd])
    none = jnp.zeros(6, bool)
    step = jax.jit(lambda x, h: sc.step(r, x, jnp.zeros(6), none, h))

    def drift(h, T=0.25):
        x = x0
        for _ in range(int(round(T / h))):
            x = step(x, h)
        return abs(float(sl.energy(r, x[:9], x[9:]) - sl.energy(r, q, qd)))

    e1, e2 = drift(2e-3), drift(1e-3)
    assert e2 < 1e-7
    assert e1 / max(e2, 1e-16) > 8.0  # fourth-order convergence (ideal 16)


def test_knee_stop_sign(robot):
    from bipedlab.robots.seven_link import contact as sc

    # a flexed knee (phi_2 < 0) is away from its stop: positive gap
    q = sl.configuration(np.pi / 2, np.deg2rad([0.0, -30.0, 0.0, 0.0, 10.0, 0.0]))
    g = np.asarray(sc.gaps(robot, q))
    assert g[4] == pytest.approx(np.deg2rad(30.0)) and g[5] == pytest.approx(-np.deg2rad(10.0))
