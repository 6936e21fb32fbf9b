"""ATRIAS-like running robot: full-model dynamics and the Geyer-Herr ground."""
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bipedlab.robots.atrias import robot as at
from bipedlab.contact import terrain as tr

P = at.AtriasParams()


def _random_state(rng):
    q = np.array([0.3, 1.2, 0.2, np.pi - 0.3, np.pi + 0.4, 0.8, 0.6]) + 0.1 * rng.standard_normal(7)
    qd = rng.standard_normal(7)
    return jnp.asarray(q), jnp.asarray(qd)


def test_jacobian_and_bias_match_autodiff():
    rng = np.random.default_rng(1)
    for _ in range(3):
        q, qd = _random_state(rng)
        for i in range(2):
            J = at.foot_jac(P, q, i)
            np.testing.assert_allclose(J, jax.jacfwd(lambda x: at.foot(P, x, i))(q), atol=1e-12)
            Jdot_qd = jax.jvp(lambda x: at.foot_jac(P, x, i) @ qd, (q,), (qd,))[1]
            np.testing.assert_allclose(at.foot_bias(P, q, qd, i), Jdot_qd, atol=1e-12)


def test_mass_matrix_spd_and_solver():
    rng = np.random.default_rng(2)
    q, _ = _random_state(rng)
    M = np.asarray(at.mass_matrix(P, q))
    np.testing.assert_allclose(M, M.T, atol=1e-14)
    assert np.linalg.eigvalsh(M).min() > 0
    b = rng.standard_normal(7)
    np.testing.assert_allclose(at.solve(jnp.asarray(M), jnp.asarray(b)), np.linalg.solve(M, b), rtol=1e-10)


def _flow(q, qd, u):
    return at.solve(at.mass_matrix(P, q), at.free_forces(P, q, qd, u))


def _rk4(q, qd, u, h, n):
    x = jnp.concatenate([q, qd])
    f = lambda x: jnp.concatenate([x[7:], _flow(x[:7], x[7:], u)])
    step = jax.jit(lambda x: (lambda k1: (lambda k2: (lambda k3: (lambda k4: x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4))(
        f(x + h * k3)))(f(x + 0.5 * h * k2)))(f(x + 0.5 * h * k1)))(f(x)))
    out = [x]
    for _ in range(n):
        x = step(x)
        out.append(x)
    return out


def test_unactuated_flight_conserves_energy():
    rng = np.random.default_rng(3)
    q, qd = _random_state(rng)
    xs = _rk4(q, qd, jnp.zeros(4), 1e-4, 300)
    e = [float(at.energy(P, x[:7], x[7:])) for x in xs[::30]]
    assert max(abs(v - e[0]) for v in e) < 1e-8 * abs(e[0])


def _angular_momentum_about_com(q, qd):
    """Total angular momentum of the full model (trunk, hip inertias, feet) about its COM."""
    mt = P.m + 2 * P.m_f
    pts = [(P.m, q[:2], qd[:2])] + [(P.m_f, at.foot(P, q, i), at.foot_jac(P, q, i) @ qd) for i in range(2)]
    c = sum(m * r for m, r, _ in pts) / mt
    v = sum(m * w for m, _, w in pts) / mt
    L = P.I_t * qd[2] + P.I_m * (qd[3] + qd[4])  # clockwise positive
    for m, r, w in pts:
        d, dv = r - c, w - v
        L = L - m * (d[0] * dv[1] - d[1] * dv[0])
    return L


def test_hip_torques_and_leg_forces_are_internal():
    rng = np.random.default_rng(4)
    q, qd = _random_state(rng)
    u = jnp.array([40.0, -25.0, 30.0, -20.0])
    xs = _rk4(q, qd, u, 1e-4, 300)
    L = [float(_angular_momentum_about_com(x[:7], x[7:])) for x in xs[::50]]
    assert max(abs(v - L[0]) for v in L) < 1e-7 * max(1.0, abs(L[0]))
    # and the paper's H changes only through the foot masses: with hip torques alone it moves
    assert abs(float(at.angular_momentum(P, xs[-1][:7], xs[-1][7:])) - float(at.angular_momentum(P, q, qd))) > 1e-3


def test_ground_model_vertical_and_friction_laws():
    gp = at.ground_params(P)
    w = P.total_mass * P.g
    assert gp.k_y == pytest.approx(w / 0.01) and gp.k_x == pytest.approx(w / 0.1)
    terr = tr.flat()
    # foot 0 pressed 5 mm into the ground, at rest in stiction with the anchor 2 cm behind
    q = jnp.array([0.0, 0.0, 0.0, np.pi, np.pi, 0.0, 0.0])
    q = q.at[1].set(P.d + 0.9 - 0.005).at[5].set(0.9).at[6].set(0.5)
    s = at.SimState(q, jnp.zeros(7), jnp.array([-0.02, 0.0]), jnp.ones(2))
    F0, C, on = at._contact_terms(P, gp, terr, s, 0)
    assert bool(on)
    assert float(F0[1]) == pytest.approx(gp.k_y * 0.005)
    assert float(C[1]) == pytest.approx(gp.k_y * 0.005 / gp.v_max)      # GRF_y = k dy (1 - y'/v_max)
    assert float(F0[0]) == pytest.approx(-gp.k_x * 0.02)                 # stiction spring
    assert float(C[0]) == pytest.approx(gp.k_x * 0.02 / gp.v_max)
    # sliding: friction opposes the motion with mu_slide GRF_y
    qd = jnp.zeros(7).at[0].set(0.5)
    s2 = at.SimState(q, qd, jnp.zeros(2), jnp.zeros(2))
    F0, C, _ = at._contact_terms(P, gp, terr, s2, 0)
    assert float(F0[0]) == pytest.approx(-gp.mu_slide * gp.k_y * 0.005)
    assert float(C[0]) == 0.0
    # unilateral: a foot leaving faster than v_max gets no force
    qd = jnp.zeros(7).at[1].set(0.1)
    F0, C, on = at._contact_terms(P, gp, terr, at.SimState(q, qd, jnp.zeros(2), jnp.ones(2)), 0)
    assert not bool(on) and float(F0[1]) == 0.0


def test_stick_slip_switching_in_a_step():
    gp = at.ground_params(P)
    terr = tr.flat()
    q = jnp.array([0.0, P.d + 0.9 - 0.005, 0.0, np.pi, np.pi, 0.9, 0.5])
    # anchor 0.2 m away: the stiction force exceeds mu_stick GRF_y -> slip
    s = at.SimState(q, jnp.zeros(7), jnp.array([-0.2, 0.0]), jnp.ones(2))
    s1, grf = at.step(P, gp, terr, s, jnp.zeros(4), 1e-4)
    assert float(s1.stick[0]) == 0.0
    # slipping foot slower than 0.01 m/s sticks again at its current position
    s2, _ = at.step(P, gp, terr, at.SimState(q, jnp.zeros(7), jnp.zeros(2), jnp.zeros(2)), jnp.zeros(4), 1e-4)
    assert float(s2.stick[0]) == 1.0
    assert float(s2.anchor[0]) == pytest.approx(float(at.foot(P, s2.q, 0)[0]))
