"""Virtual constraints, Lie derivatives, input-output linearisation and the zero dynamics of
the five-link walker (the shipped 0.8 m/s gait).

Oracles: hand-derived derivatives of simple outputs; the chain rule written out with the
Bézier polynomials from numpy.polynomial (y = H0 q - h_d(c q) gives
ydd = (H0 - h_d' c^T) qdd - h_d'' (c qd)^2); the stance dynamics' own accelerations; and
invariance of Z = {y = 0, yd = 0} under u* in time simulation (with u = 0 as the control
case that must leave Z)."""
from __future__ import annotations

from math import comb

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from numpy.polynomial import Polynomial

from bipedlab.control import hzd
from bipedlab.gait import gaitfile
from bipedlab.mechanics import stance as stm
from bipedlab.robots.five_link import robot as five_link
from bipedlab.sim.integrators import rk4


@pytest.fixture(scope="module")
def gait():
    vc, z_minus, _ = gaitfile.shipped("bipedlab.robots.five_link", "five_link_0.8")
    return vc, z_minus


@pytest.fixture(scope="module")
def st():
    return five_link.stance()


def _hd_polys(vc):
    """h_d and its first two theta-derivatives as numpy polynomial oracles, per output."""
    alpha = np.asarray(vc.alpha)
    M = alpha.shape[1] - 1
    tp, tm = float(vc.theta_plus), float(vc.theta_minus)
    w = tm - tp
    # Bernstein basis in theta directly: s = (theta - tp) / w
    s = Polynomial([-tp / w, 1.0 / w])
    polys = []
    for row in alpha:
        p = Polynomial([0.0])
        for k, a in enumerate(row):
            p = p + a * comb(M, k) * s**k * (1 - s) ** (M - k)
        polys.append(p)
    return polys


def _chain_rule(vc, q, qd, qdd):
    """(y, yd, ydd) of y = H0 q - h_d(c q) from the oracle polynomials."""
    H0, c = np.asarray(vc.H0), np.asarray(vc.c)
    th, thd, thdd = c @ q, c @ qd, c @ qdd
    P = _hd_polys(vc)
    hd = np.array([p(th) for p in P])
    d1 = np.array([p.deriv()(th) for p in P])
    d2 = np.array([p.deriv(2)(th) for p in P])
    return H0 @ q - hd, H0 @ qd - d1 * thd, H0 @ qdd - d1 * thdd - d2 * thd**2


@pytest.fixture(scope="module")
def off_manifold_states(gait):
    """States near the gait but off Z (random offsets of the lifted states)."""
    vc, z_minus = gait
    rng = np.random.default_rng(17)
    tp, tm = float(vc.theta_plus), float(vc.theta_minus)
    thd = float(vc.c @ z_minus[5:])
    zs = []
    for th in np.linspace(tp, tm, 5):
        q, qd = hzd.lift(vc, jnp.asarray(th), jnp.asarray(thd))
        z = np.r_[np.asarray(q), np.asarray(qd)]
        z += np.r_[0.05 * rng.standard_normal(5), 0.3 * rng.standard_normal(5)]
        zs.append(z)
    return jnp.asarray(np.array(zs))


# ---- generic Lie derivatives -------------------------------------------------------------

def test_lie_derivatives_of_a_hand_differentiated_output():
    """h(q) = [q0 sin q1, q0^2 + q2^3]: y, yd = J qd, Lf2h = qd^T Hess qd + J a, LgLfh = J b."""
    rng = np.random.default_rng(0)
    q, qd, a = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3)
    b = rng.normal(size=(3, 2))

    def h(q):
        return jnp.stack([q[0] * jnp.sin(q[1]), q[0] ** 2 + q[2] ** 3])

    y, yd, L2, LgLf = (np.asarray(v) for v in hzd.lie_derivatives(h, jnp.asarray(q), jnp.asarray(qd),
                                                                   jnp.asarray(a), jnp.asarray(b)))
    J = np.array([[np.sin(q[1]), q[0] * np.cos(q[1]), 0.0], [2 * q[0], 0.0, 3 * q[2] ** 2]])
    H1 = np.array([[0.0, np.cos(q[1]), 0.0], [np.cos(q[1]), -q[0] * np.sin(q[1]), 0.0], [0, 0, 0]])
    H2 = np.diag([2.0, 0.0, 6 * q[2]])
    np.testing.assert_allclose(y, [q[0] * np.sin(q[1]), q[0] ** 2 + q[2] ** 3], rtol=1e-14)
    np.testing.assert_allclose(yd, J @ qd, rtol=1e-13)
    np.testing.assert_allclose(L2, [qd @ H1 @ qd + J[0] @ a, qd @ H2 @ qd + J[1] @ a], rtol=1e-12)
    np.testing.assert_allclose(LgLf, J @ b, rtol=1e-13)


# ---- the walker's outputs ------------------------------------------------------------------

def test_output_matches_the_bezier_oracle(gait, st, off_manifold_states):
    vc, _ = gait
    for z in np.asarray(off_manifold_states):
        q, qd = z[:5], z[5:]
        y_ref, yd_ref, _ = _chain_rule(vc, q, qd, np.zeros(5))
        np.testing.assert_allclose(np.asarray(hzd.output(vc, jnp.asarray(q))), y_ref, atol=1e-12)
        y, yd = hzd.output_state(vc, st, jnp.asarray(z))
        np.testing.assert_allclose(np.asarray(y), y_ref, atol=1e-12)
        np.testing.assert_allclose(np.asarray(yd), yd_ref, atol=1e-11)


@pytest.fixture(scope="module")
def decoupled(gait, st, off_manifold_states):
    vc, _ = gait
    rng = np.random.default_rng(3)
    us = jnp.asarray(15.0 * rng.standard_normal((off_manifold_states.shape[0], 4)))

    def one(z, u):
        y, yd, L2, LgLf = hzd.decoupling(vc, st, z)
        a, b, _, _ = stm.stance_affine(st, z)
        return dict(y=y, yd=yd, L2=L2, LgLf=LgLf, a=a, b=b, u=u,
                    ustar=hzd.u_star(vc, st, z), uio=hzd.io_linearizing(vc, st, z, 0.1, 1.0, 2.0),
                    upd=hzd.pd_control(vc, st, z, 300.0, 20.0))

    return {k: np.asarray(v) for k, v in jax.jit(jax.vmap(one))(off_manifold_states, us).items()}


def test_decoupling_matrix_and_drift_match_the_chain_rule(gait, off_manifold_states, decoupled):
    vc, _ = gait
    d = decoupled
    for i, z in enumerate(np.asarray(off_manifold_states)):
        q, qd = z[:5], z[5:]
        qdd = d["a"][i] + d["b"][i] @ d["u"][i]
        y, yd, ydd = _chain_rule(vc, q, qd, qdd)
        np.testing.assert_allclose(d["y"][i], y, atol=1e-12)
        np.testing.assert_allclose(d["yd"][i], yd, atol=1e-11)
        np.testing.assert_allclose(d["L2"][i] + d["LgLf"][i] @ d["u"][i], ydd, rtol=1e-9, atol=1e-9 * np.abs(ydd).max())
        # the decoupling matrix alone: (H0 - h_d' c^T) b
        _, _, ydd0 = _chain_rule(vc, q, qd, d["a"][i])
        np.testing.assert_allclose(d["L2"][i], ydd0, rtol=1e-9, atol=1e-9 * np.abs(ydd0).max())
        assert np.linalg.cond(d["LgLf"][i]) < 1e4  # invertible along the gait


def test_controllers_produce_their_closed_loop_output_dynamics(gait, off_manifold_states, decoupled):
    """u* gives ydd = 0; I/O linearisation gives ydd = -(kp/eps^2) y - (kd/eps) yd;
    the PD law is u* - Kp y - Kd yd."""
    vc, _ = gait
    d = decoupled
    for i, z in enumerate(np.asarray(off_manifold_states)):
        q, qd = z[:5], z[5:]
        scale = np.abs(d["L2"][i]).max()
        _, _, ydd = _chain_rule(vc, q, qd, d["a"][i] + d["b"][i] @ d["ustar"][i])
        np.testing.assert_allclose(ydd, 0.0, atol=1e-9 * scale)
        y, yd, ydd = _chain_rule(vc, q, qd, d["a"][i] + d["b"][i] @ d["uio"][i])
        target = -(1.0 / 0.1**2) * y - (2.0 / 0.1) * yd
        assert np.abs(target).max() > 1.0  # the states really are off Z
        np.testing.assert_allclose(ydd, target, rtol=1e-9, atol=1e-9 * np.abs(target).max())
        np.testing.assert_allclose(d["upd"][i], d["ustar"][i] - 300.0 * y - 20.0 * yd, rtol=1e-10, atol=1e-9)


def test_lift_puts_the_state_on_the_manifold(gait, st):
    vc, z_minus = gait
    for th, thd in ((float(vc.theta_plus), 1.2), (0.03, 0.9), (float(vc.theta_minus), 1.5), (0.5, -0.3)):
        q, qd = hzd.lift(vc, jnp.asarray(th), jnp.asarray(thd))
        y, yd = hzd.output_state(vc, st, jnp.concatenate([q, qd]))
        np.testing.assert_allclose(np.asarray(y), 0.0, atol=1e-13)
        np.testing.assert_allclose(np.asarray(yd), 0.0, atol=1e-13)
        assert float(vc.c @ q) == pytest.approx(th, abs=1e-14)
        assert float(vc.c @ qd) == pytest.approx(thd, abs=1e-14)
    # the pre-impact fixed point is the lift of its own phase and rate
    q, qd = hzd.lift(vc, vc.theta_minus, vc.c @ z_minus[5:])
    np.testing.assert_allclose(np.r_[np.asarray(q), np.asarray(qd)], np.asarray(z_minus), atol=1e-12)


def test_impact_maps_the_fixed_point_onto_the_manifold(gait, st):
    """Hybrid invariance: the impact of z- lands on Z at theta+ (the design makes
    alpha_0, alpha_1 follow from the post-impact state)."""
    vc, z_minus = gait
    z_plus, _, _, _ = stm.impact(st, z_minus)
    y, yd = hzd.output_state(vc, st, z_plus)
    np.testing.assert_allclose(np.asarray(y), 0.0, atol=1e-12)
    np.testing.assert_allclose(np.asarray(yd), 0.0, atol=1e-12)
    assert float(vc.c @ z_plus[:5]) == pytest.approx(float(vc.theta_plus), abs=1e-13)
    assert float(vc.c @ z_plus[5:]) > 0


def test_zero_dynamics_agree_with_the_full_dynamics_on_the_manifold(gait, st):
    vc, _ = gait

    @jax.jit
    def both(th, thd):
        thdd, u, grf, z = hzd.zero_dynamics(vc, st, th, thd)
        q, qd = hzd.lift(vc, th, thd)
        return dict(thdd=thdd, u=u, grf=grf, z=z, q=q, qd=qd, qdd=stm.stance_flow(st, z, u)[5:],
                    u_ref=hzd.u_star(vc, st, z), grf_ref=stm.ground_reaction(st, z, u))

    for th, thd in ((float(vc.theta_plus), 1.3), (0.0, 1.0), (0.25, 1.6)):
        d = {k: np.asarray(v) for k, v in both(jnp.asarray(th), jnp.asarray(thd)).items()}
        np.testing.assert_allclose(d["z"], np.r_[d["q"], d["qd"]], atol=0)
        assert float(d["thdd"]) == pytest.approx(float(np.asarray(vc.c) @ d["qdd"]), rel=1e-12, abs=1e-12)
        np.testing.assert_allclose(d["u"], d["u_ref"], rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(d["grf"], d["grf_ref"], rtol=1e-12)
        # on Z the accelerations keep y identically zero: ydd = 0 by the chain rule
        _, _, ydd = _chain_rule(vc, d["q"], d["qd"], d["qdd"])
        np.testing.assert_allclose(ydd, 0.0, atol=1e-9)
        # and the ground pushes up along the gait
        assert d["grf"][1] > 0


# ---- invariance of Z in time simulation -----------------------------------------------------

H = 1e-3
STEPS = 350  # 0.35 s of the 0.50 s step


@pytest.fixture(scope="module")
def runs(gait, st):
    """Full-order RK4 runs from a state on Z under u* and under u = 0, and the RK4 solution of
    the two-dimensional zero dynamics from the same (theta, thetadot)."""
    vc, z_minus = gait
    z_plus, _, _, _ = stm.impact(st, z_minus)
    zd = lambda x: jnp.stack([x[1], hzd.zero_dynamics(vc, st, x[0], x[1])[0]])  # noqa: E731
    # the gait's (theta, thetadot) at the start of the step
    x_imp = jnp.stack([vc.theta_plus, vc.c @ z_plus[5:]])

    @jax.jit
    def simulate(x_start):
        # start on Z at the zero-dynamics state x_start = (theta, thetadot)
        q, qd = hzd.lift(vc, x_start[0], x_start[1])
        z0 = jnp.concatenate([q, qd])
        f_star = hzd.closed_loop_flow(vc, st, lambda z: hzd.u_star(vc, st, z))
        f_zero = hzd.closed_loop_flow(vc, st, lambda z: jnp.zeros(4))

        def body(carry, _):
            zs, zz, x = carry
            zs = rk4(f_star, zs, None, H)
            zz = rk4(f_zero, zz, None, H)
            x = rk4(lambda x_, _u: zd(x_), x, None, H)
            ys, yds = hzd.output_state(vc, st, zs)
            yz, ydz = hzd.output_state(vc, st, zz)
            out = dict(y_star=jnp.max(jnp.abs(ys)), yd_star=jnp.max(jnp.abs(yds)),
                       y_zero=jnp.max(jnp.abs(yz)), yd_zero=jnp.max(jnp.abs(ydz)),
                       theta=vc.c @ zs[:5], theta_dot=vc.c @ zs[5:], theta_zd=x[0], theta_dot_zd=x[1],
                       height=stm.swing_height(st, zs))
            return (zs, zz, x), out

        _, out = jax.lax.scan(body, (z0, z0, x_start), None, length=STEPS)
        return out

    out = simulate(x_imp)
    return {k: np.asarray(v) for k, v in out.items()}


def test_zero_dynamics_manifold_is_invariant_under_u_star(runs):
    assert runs["y_star"].max() < 1e-8
    assert runs["yd_star"].max() < 1e-8
    # the run is a real part of a step: the phase advances and the swing toe stays up
    assert runs["theta"][-1] - runs["theta"][0] > 0.3
    assert np.all(runs["theta_dot"] > 0)
    assert np.all(runs["height"][10:] > 0)


def test_without_control_the_state_leaves_the_manifold(runs):
    """The control case: the same start under u = 0 leaves Z within the same time."""
    assert runs["y_zero"].max() > 1e-2
    assert runs["yd_zero"].max() > 1e-1


def test_full_order_phase_follows_the_two_dimensional_zero_dynamics(runs):
    """On Z the ten-state closed loop reduces to theta_ddot = zero_dynamics(theta, thetadot)."""
    np.testing.assert_allclose(runs["theta"], runs["theta_zd"], atol=1e-9)
    np.testing.assert_allclose(runs["theta_dot"], runs["theta_dot_zd"], atol=1e-8)


def test_lift_accepts_python_scalars(gait):
    vc, _ = gait
    q, qd = hzd.lift(vc, 0.1, 1.0)
    q_ref, qd_ref = hzd.lift(vc, jnp.asarray(0.1), jnp.asarray(1.0))
    np.testing.assert_array_equal(np.asarray(q), np.asarray(q_ref))
    np.testing.assert_array_equal(np.asarray(qd), np.asarray(qd_ref))
