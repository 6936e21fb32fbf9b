"""The shipped five-link gait: a periodic orbit of the hybrid closed loop, its Poincaré
analysis, and the gait-design problem around it.

Independent checks: the fixed point found by optimisation (RK4 in the phase, the step ending
exactly on the guard) is re-found by a time simulation (RK4 in time, events located); the
autodiff Poincaré Jacobian against central finite differences; the restricted map's
eigenvalue against its finite difference and against the closed form (sigma+ / sigma-)^2 of
the zero dynamics written in the angular momentum sigma about the stance toe (Westervelt,
Grizzle & Koditschek 2003): on Z, d(sigma^2/2)/dtheta = -m g x_com(theta) I(theta) does not
depend on sigma, so the restricted map is affine in sigma^2 with slope delta^2, the impact's
ratio of angular momenta."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bipedlab import mechanics as mech
from bipedlab.control import hzd
from bipedlab.gait import gaitfile
from bipedlab.gait import optimize as go
from bipedlab.gait import walking as gw
from bipedlab.mechanics import stance as stm
from bipedlab.robots.five_link import robot as five_link
from bipedlab.sim import OK
from bipedlab.robots.five_link import study as hz
import oracles

IOLIN = hz.CONTROLLERS["iolin"]


@pytest.fixture(scope="module")
def shipped():
    vc, z_minus, record = gaitfile.shipped("bipedlab.robots.five_link", "five_link_0.8")
    return vc, z_minus, record["design"]


@pytest.fixture(scope="module")
def st():
    return five_link.stance()


@pytest.fixture(scope="module")
def prob():
    return hz.problem(0.8, "torque")


@pytest.fixture(scope="module")
def evaluate(prob):
    return go.evaluator(prob)  # the solver's own program for this problem: compiled once


@pytest.fixture(scope="module")
def x_star(shipped, prob):
    vc, z_minus, _ = shipped
    M = vc.order
    return go.pack(z_minus, np.asarray(vc.alpha)[:, 2:M - 1])


# ---- the orbit is periodic ---------------------------------------------------------------

def test_design_residuals_vanish_at_the_shipped_gait(shipped, prob, evaluate, x_star):
    vc, z_minus, design = shipped
    cost, eq, ineq, met = evaluate(jnp.asarray(x_star))
    eq, ineq = np.asarray(eq), np.asarray(ineq)
    assert np.abs(eq).max() < 1e-8  # toe on the ground, periodic, at the speed
    assert ineq.min() > -1e-8        # all inequalities hold
    assert float(met["speed"]) == pytest.approx(0.8, abs=1e-8)
    # the coefficients derived from the state reproduce the shipped ones exactly
    np.testing.assert_allclose(np.asarray(met["vc"].alpha), np.asarray(vc.alpha), atol=1e-12)
    assert float(met["vc"].theta_plus) == pytest.approx(float(vc.theta_plus), abs=1e-13)
    assert float(met["vc"].theta_minus) == pytest.approx(float(vc.theta_minus), abs=1e-13)
    # the figures recorded in the file are the ones the problem computes
    assert float(met["step_length"]) == pytest.approx(design["step_length_m"], rel=1e-10)
    assert float(met["period"]) == pytest.approx(design["period_s"], rel=1e-10)
    assert float(met["cmt"]) == pytest.approx(design["cmt"], rel=1e-9)
    np.testing.assert_allclose(np.max(np.abs(np.asarray(met["u"])), 0), design["peak_torques_nm"], rtol=1e-9)


def test_step_period_is_the_integral_of_dtheta_over_thetadot(evaluate, x_star):
    """Independent quadrature of T = int dtheta / thetadot over the node samples (Simpson)."""
    import scipy.integrate

    _, _, _, met = evaluate(jnp.asarray(x_star))
    th, thd = np.asarray(met["thetas"]), np.asarray(met["theta_dot"])
    T = scipy.integrate.simpson(1.0 / thd, x=th)
    assert T == pytest.approx(float(met["period"]), rel=1e-6)
    # torque cost per step length: int |u|^2 dt / L with the node torques (the torques vary
    # faster than the phase rate, so Simpson on 40 intervals is only good to ~1e-4)
    u = np.asarray(met["u"])
    J = scipy.integrate.simpson(np.sum(u**2, 1) / thd, x=th) / float(met["step_length"])
    assert J == pytest.approx(float(met["torque_cost"]), rel=1e-3)


@pytest.fixture(scope="module")
def step_and_jacobian(shipped, st):
    """(the closed-loop step from z-, its autodiff Poincaré Jacobian): one forward-mode pass of
    the walk's own compiled analysis (the gait traced)."""
    vc, z_minus, _ = shipped
    s, J = gw.poincare_step_program(vc, st, IOLIN, jnp.asarray(z_minus))
    return jax.tree_util.tree_map(np.asarray, s), np.asarray(J)


@pytest.fixture(scope="module")
def one_step(step_and_jacobian):
    return step_and_jacobian[0]


def test_one_closed_loop_step_in_time_returns_to_the_fixed_point(shipped, st, one_step):
    """RK4 in time (h = 1 ms) with the touchdown located: a different discretisation from the
    design's RK4 in the phase, so agreement is to the integrators' accuracy."""
    vc, z_minus, design = shipped
    s = one_step
    assert int(s.status) == OK
    np.testing.assert_allclose(s.z_minus, np.asarray(z_minus), atol=1e-5)
    assert abs(float(stm.swing_height(st, jnp.asarray(s.z_minus)))) <= 1e-10
    assert float(s.duration) == pytest.approx(design["period_s"], abs=1e-5)
    assert float(s.step_length) == pytest.approx(design["step_length_m"], abs=1e-6)
    # the step started on Z and the controller kept it there
    assert float(s.y_sq) < 1e-15
    # u_sq is the time integral of |u|^2: torque cost times step length
    assert float(s.u_sq) == pytest.approx(design["torque_cost"] * design["step_length_m"], rel=1e-2)


# ---- Poincaré analysis -------------------------------------------------------------------

@pytest.fixture(scope="module")
def jacobians(shipped, st, step_and_jacobian):
    vc, z_minus, _ = shipped
    J = step_and_jacobian[1]
    J_fd = gw.poincare_jacobian_fd(vc, st, IOLIN, z_minus)
    return J, J_fd


def test_poincare_jacobian_matches_finite_differences(jacobians):
    J, J_fd = jacobians
    assert np.linalg.norm(J - J_fd) / np.linalg.norm(J_fd) < 1e-5
    assert np.abs(J - J_fd).max() < 1e-4 * np.abs(J_fd).max()


def test_poincare_map_lands_on_the_impact_surface(shipped, st, jacobians):
    """P maps into {swing height = 0}: the height's gradient annihilates the columns of dP,
    and one eigenvalue is zero (the direction across the section)."""
    vc, z_minus, _ = shipped
    J, _ = jacobians
    g = np.asarray(jax.jit(jax.grad(lambda z: stm.swing_height(st, z)))(z_minus))  # one program, not op by op
    assert np.abs(g @ J).max() < 1e-7 * np.abs(g).max() * np.abs(J).max()
    ev = np.abs(np.linalg.eigvals(J))
    assert ev.min() < 1e-6


@pytest.fixture(scope="module")
def restricted(shipped, st):
    vc, z_minus, _ = shipped
    thd = float(vc.c @ z_minus[5:])
    rho = gw.restricted_eigenvalue(vc, st, thd, nodes=hz.NODES)
    rmap = jax.jit(lambda t: gw.restricted_map(vc, st, t, hz.NODES))
    return thd, rho, rmap


def test_gait_is_stable_and_the_dominant_eigenvalue_is_the_restricted_one(jacobians, restricted):
    J, _ = jacobians
    _, rho, _ = restricted
    ev = np.abs(np.linalg.eigvals(J))
    assert ev.max() < 1.0
    assert 0.0 < rho < 1.0
    assert ev.max() == pytest.approx(abs(rho), abs=1e-3)
    # the other eigenvalues belong to the fast output dynamics (eps = 0.1): much smaller
    assert np.sort(ev)[-2] < 0.5 * ev.max()


def test_restricted_map_fixed_point_and_derivative(restricted):
    thd, rho, rmap = restricted
    assert float(rmap(thd)) == pytest.approx(thd, abs=1e-9)
    d = 1e-5
    fd = (float(rmap(thd + d)) - float(rmap(thd - d))) / (2 * d)
    assert rho == pytest.approx(fd, abs=1e-7)
    # affine in thetadot^2 near the fixed point (zero dynamics are linear in thetadot^2/2)
    for dt in (0.05, -0.1):
        r2 = float(rmap(thd + dt)) ** 2
        assert r2 == pytest.approx(thd**2 + rho * ((thd + dt) ** 2 - thd**2), rel=1e-6)


def test_restricted_eigenvalue_is_the_squared_momentum_ratio(shipped, st, restricted):
    """Closed form: rho' = (sigma+ / sigma-)^2 with sigma- the angular momentum about the stance
    toe before the impact and sigma+ that about the new stance toe after it (equal to the
    momentum about the swing toe before it, which the impact conserves). Computed with the
    oracle Lagrangian."""
    vc, z_minus, _ = shipped
    _, rho, _ = restricted
    q, qd = stm.embed(st, z_minus)
    toe_sw = oracles.five_link_foot(q, 1)
    sigma_minus = float(oracles.FIVE_LINK.angular_momentum(q, qd, jnp.zeros(2)))
    sigma_plus = float(oracles.FIVE_LINK.angular_momentum(q, qd, toe_sw))
    z_plus, _, _, _ = stm.impact(st, z_minus)
    qn, qdn = stm.embed(st, z_plus)
    assert float(mech.angular_momentum(st.model, qn, qdn, jnp.zeros(2))) == pytest.approx(sigma_plus, rel=1e-10)
    assert sigma_minus < 0 and sigma_plus < 0  # forward walking turns clockwise (CCW positive)
    assert abs(sigma_plus) < abs(sigma_minus)  # the impact loses momentum about the toe
    assert rho == pytest.approx((sigma_plus / sigma_minus) ** 2, abs=1e-6)


# ---- the design problem --------------------------------------------------------------------

def test_pack_unpack_round_trip(prob, x_star):
    z, free = go.unpack(prob, jnp.asarray(x_star))
    np.testing.assert_array_equal(go.pack(z, free), x_star)
    assert prob.size == x_star.size == 2 * prob.n + prob.m * (prob.order - 3)


def test_constraints_from_state_give_hybrid_invariance_for_any_state(prob, st):
    """For any pre-impact state and free coefficients, the derived Bézier end coefficients put
    z- on Z at theta- and the post-impact state on Z at theta+: y and yd vanish at both."""
    rng = np.random.default_rng(8)
    _, z_star, _ = gaitfile.shipped("bipedlab.robots.five_link", "five_link_0.8")
    for _ in range(3):
        z = np.asarray(z_star) + np.r_[0.05 * rng.standard_normal(5), 0.3 * rng.standard_normal(5)]
        free = rng.normal(scale=0.5, size=(prob.m, prob.order - 3))
        vc, zp, imp = go.constraints_from_state(prob, jnp.asarray(z), jnp.asarray(free))
        np.testing.assert_allclose(np.asarray(vc.alpha)[:, 2:prob.order - 1], free, atol=0)
        for state in (jnp.asarray(z), zp):
            y, yd = hzd.output_state(vc, st, state)
            np.testing.assert_allclose(np.asarray(y), 0.0, atol=1e-12)
            np.testing.assert_allclose(np.asarray(yd), 0.0, atol=1e-11)
        assert float(vc.c @ zp[:5]) == pytest.approx(float(vc.theta_plus), abs=1e-14)
        assert float(vc.c @ z[:5]) == pytest.approx(float(vc.theta_minus), abs=1e-14)
        z_imp, impulse, _, _ = stm.impact(st, jnp.asarray(z))
        np.testing.assert_allclose(np.asarray(zp), np.asarray(z_imp), atol=0)
        np.testing.assert_allclose(np.asarray(imp["impulse"]), np.asarray(impulse), atol=0)


def test_solver_reduces_the_constraint_violation_from_the_initial_guess(prob, evaluate):
    """A few SLSQP iterations from the study's initial guess (the full solve runs in the slow
    CLI test): the equality violation drops by orders of magnitude."""
    x0 = hz.initial_guess(prob)
    _, eq0, ineq0, _ = evaluate(jnp.asarray(x0))
    viol0 = float(np.abs(np.asarray(eq0)).max())
    assert viol0 > 0.1
    res = go.solve(prob, x0, maxiter=15, warm_start_runs=0)
    _, eq1, ineq1, _ = evaluate(jnp.asarray(res.x))
    viol1 = float(np.abs(np.asarray(eq1)).max())
    assert res.max_eq_violation == pytest.approx(viol1, rel=1e-9)
    assert viol1 < 0.05 * viol0
    assert float(np.min(np.asarray(ineq1))) > float(np.min(np.asarray(ineq0)))


# ---- slow: the other controller --------------------------------------------------------------

@pytest.mark.slow
def test_pd_controller_orbit_is_stable(shipped, st):
    """With u* feedforward and PD on y, the same orbit is a fixed point (it lies on Z, where
    the PD terms vanish) and it is stable; its dominant eigenvalue is again the restricted one."""
    vc, z_minus, _ = shipped
    pd = hz.CONTROLLERS["pd"]
    s = jax.jit(lambda z: gw.step(vc, st, pd, z))(z_minus)
    assert int(s.status) == OK
    np.testing.assert_allclose(np.asarray(s.z_minus), np.asarray(z_minus), atol=1e-5)
    J = np.asarray(jax.jit(lambda z: gw.poincare_jacobian(vc, st, pd, z))(z_minus))
    ev = np.abs(np.linalg.eigvals(J))
    rho = gw.restricted_eigenvalue(vc, st, float(vc.c @ z_minus[5:]), nodes=hz.NODES)
    assert ev.max() < 1.0
    assert ev.max() == pytest.approx(rho, abs=1e-2)
