"""The hybrid step of bipedlab.sim.hybrid against closed-form oracles.

A ball in free fall is a quadratic in time, which RK4 integrates exactly, so the located
impact and the state after it are exact to the locating's convergence; a 1-D linear flow
with a jump has a closed-form event time, whose dependence on the initial state the
forward-mode derivative of the post-event state must include."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bipedlab.sim import FELL, OK, hybrid
from bipedlab.sim.integrators import rk4, rk4_scan

G = 9.81
E = 0.8  # coefficient of restitution


def _ball(armed=lambda x: x[1] < 0.0, iterations=6, integrator=None):
    """State (height m, velocity m/s); the impact reverses and scales the velocity and reports
    the impact speed."""
    kw = {} if integrator is None else dict(integrator=integrator)
    return hybrid.Transition(flow=lambda x, u: jnp.stack([x[1], -G + 0.0 * x[0]]), guard=lambda x: x[0],
                             armed=armed, reset=lambda x: (jnp.stack([x[0], -E * x[1]]), -x[1]),
                             iterations=iterations, **kw)


def _ball_oracle(y0, v0, h):
    """Impact time, pre-impact speed and the state at h after a bounce (closed form)."""
    t = (v0 + np.sqrt(v0**2 + 2 * G * y0)) / G
    v_minus = v0 - G * t
    vp = -E * v_minus
    r = h - t
    return t, -v_minus, np.array([vp * r - 0.5 * G * r**2, vp - G * r])


@pytest.fixture(scope="module")
def ball_step():
    return jax.jit(lambda x, h: hybrid.substep(_ball(), x, None, h))


@pytest.mark.parametrize("y0,v0,h,n", [(0.01, -1.0, 0.02, 6), (0.003, -0.2, 0.05, 6), (1e-4, -3.0, 1e-4, 6),
                                       (0.02, 0.5, 0.2, 10), (0.5, -2.0, 0.3, 10)])
def test_bouncing_ball_event_time_and_state(y0, v0, h, n):
    """Substeps from 0.1 ms to 0.3 s; the longest, where the guard bends most over the
    substep (the ball rising and falling inside it), with more iterations."""
    x, ev = jax.jit(lambda x: hybrid.substep(_ball(iterations=n), x, None, h))(jnp.array([y0, v0]))
    t, speed, after = _ball_oracle(y0, v0, h)
    assert bool(ev.event)
    assert float(ev.fraction) * h == pytest.approx(t, abs=1e-10)
    assert float(ev.info) == pytest.approx(speed, abs=1e-10)
    np.testing.assert_allclose(np.asarray(x), after, atol=1e-10)


def test_without_a_crossing_the_substep_is_the_integrator_step(ball_step):
    x0 = jnp.array([1.0, -0.5])
    x, ev = ball_step(x0, 0.01)
    assert not bool(ev.event) and float(ev.fraction) == 1.0 and float(ev.info) == 0.0
    np.testing.assert_allclose(np.asarray(x), np.asarray(rk4(_ball().flow, x0, None, 0.01)), rtol=1e-15, atol=0)


def test_no_event_when_not_armed():
    step = jax.jit(lambda x: hybrid.substep(_ball(armed=lambda x: jnp.asarray(False)), x, None, 0.02))
    x, ev = step(jnp.array([0.01, -1.0]))
    assert not bool(ev.event)
    # the ball passes through the ground: the plain step
    np.testing.assert_allclose(np.asarray(x), [0.01 - 0.02 - 0.5 * G * 0.02**2, -1.0 - G * 0.02], atol=1e-14)


def test_event_at_the_very_end_of_the_substep():
    """A substep whose end lies exactly on the guard (guard = 0 there) fires with fraction 1."""
    h = 0.75  # y = 3 - 4 t hits 0 at t = h exactly, in binary too (h / 6 = 1 / 8; no gravity)
    tr = hybrid.Transition(flow=lambda x, u: jnp.stack([x[1], 0.0 * x[0]]), guard=lambda x: x[0],
                           armed=lambda x: jnp.asarray(True), reset=lambda x: (jnp.stack([x[0], -x[1]]), x[1]))
    x, ev = hybrid.substep(tr, jnp.array([3.0, -4.0]), None, h)
    assert bool(ev.event)
    assert float(ev.fraction) == 1.0
    np.testing.assert_allclose(np.asarray(x), [0.0, 4.0], atol=1e-15)


def test_event_at_the_very_start_of_the_substep(ball_step):
    """A guard just above zero fires at a fraction ~0; a state on the guard moving away (the
    state just after a reset) does not fire again."""
    y0, v0, h = 1e-13, -2.0, 0.01
    x, ev = ball_step(jnp.array([y0, v0]), h)
    t, _, after = _ball_oracle(y0, v0, h)
    assert bool(ev.event) and float(ev.fraction) * h == pytest.approx(t, abs=1e-15)
    np.testing.assert_allclose(np.asarray(x), after, atol=1e-12)
    x, ev = ball_step(jnp.array([0.0, 1.6]), h)
    assert not bool(ev.event)
    x, ev = ball_step(jnp.array([0.0, -1.6]), h)  # on the guard, moving in: no crossing from > 0
    assert not bool(ev.event)


def test_another_integrator_locates_the_same_event():
    y0, v0, h = 0.01, -1.0, 0.02
    x, ev = jax.jit(lambda x: hybrid.substep(_ball(integrator=rk4_scan), x, None, h))(jnp.array([y0, v0]))
    t, _, after = _ball_oracle(y0, v0, h)
    assert float(ev.fraction) * h == pytest.approx(t, abs=1e-10)
    np.testing.assert_allclose(np.asarray(x), after, atol=1e-10)


def test_input_after_the_event():
    """The held input changes at the event (a force that stops at a touchdown)."""
    tr = hybrid.Transition(flow=lambda x, u: jnp.stack([x[1], u - G + 0.0 * x[0]]), guard=lambda x: x[0],
                           armed=lambda x: jnp.asarray(True), reset=lambda x: (jnp.stack([x[0], -E * x[1]]), 0.0),
                           input_after=lambda u: 0.0 * u)
    y0, v0, h, a = 0.01, -1.0, 0.02, 3.0
    x, ev = hybrid.substep(tr, jnp.array([y0, v0]), jnp.asarray(a), h)
    g = G - a  # net downward acceleration before the impact
    t = (v0 + np.sqrt(v0**2 + 2 * g * y0)) / g
    vp = -E * (v0 - g * t)
    r = h - t
    assert float(ev.fraction) * h == pytest.approx(t, abs=1e-10)
    np.testing.assert_allclose(np.asarray(x), [vp * r - 0.5 * G * r**2, vp - G * r], atol=1e-10)


# 1-D linear flow x' = -L (x - XS), the guard x - 1 crossed from above, the reset x -> x + J
L, XS, J, H1 = 2.0, 0.2, 2.0, 0.01


def _linear():
    return hybrid.Transition(flow=lambda x, u: -L * (x - XS), guard=lambda x: x[0] - 1.0,
                             armed=lambda x: jnp.asarray(True), reset=lambda x: (x + J, x[0]), iterations=8)


def _linear_oracle(x0):
    tau = np.log((x0 - XS) / (1.0 - XS)) / L
    after = XS + (1.0 + J - XS) * np.exp(-L * (H1 - tau))
    return tau, after, (after - XS) / (x0 - XS)  # state at H1 and its derivative d x(H1) / d x0


def test_plain_false_position_converges_slowly_on_a_long_substep():
    """The plain method, kept for results recorded with it, is linear: on a substep where the
    guard bends strongly it is still far off after the iterations the Illinois method needs."""
    y0, v0, h = 0.003, -0.2, 0.05
    t, _, _ = _ball_oracle(y0, v0, h)
    fp = hybrid.substep(_ball().replace(method="false_position"), jnp.array([y0, v0]), None, h)[1]
    il = hybrid.substep(_ball(), jnp.array([y0, v0]), None, h)[1]
    assert abs(float(il.fraction) * h - t) < 1e-12 < 1e-6 < abs(float(fp.fraction) * h - t)


def test_linear_flow_post_event_state_and_its_derivative():
    post = jax.jit(lambda x0: hybrid.substep(_linear(), x0, None, H1)[0])
    frac = jax.jit(lambda x0: hybrid.substep(_linear(), x0, None, H1)[1].fraction)
    x0 = 1.01  # the event 6.2 ms into the 10 ms substep
    tau, after, slope = _linear_oracle(x0)
    assert float(frac(jnp.array([x0]))) * H1 == pytest.approx(tau, abs=1e-11)
    assert float(post(jnp.array([x0]))[0]) == pytest.approx(after, abs=1e-10)
    d = float(jax.jacfwd(post)(jnp.array([x0]))[0, 0])
    eps = 1e-6
    fd = (float(post(jnp.array([x0 + eps]))[0]) - float(post(jnp.array([x0 - eps]))[0])) / (2 * eps)
    assert d == pytest.approx(fd, rel=1e-7)
    assert d == pytest.approx(slope, rel=1e-8)
    # without the event's shift the derivative would be the flow's exp(-L H1): far off
    assert abs(d - np.exp(-L * H1)) > 1.0
    # the event time's own derivative: d tau / d x0 = 1 / (L (x0 - XS))
    dtau = float(jax.jacfwd(frac)(jnp.array([x0]))[0]) * H1
    assert dtau == pytest.approx(1.0 / (L * (x0 - XS)), rel=1e-8)


def test_linear_flow_derivative_without_sensitivity_misses_the_shift():
    """The check above can fail: with the tangent of the event time switched off the
    derivative is not the finite difference."""
    tr = _linear().replace(sensitivity=False)
    post = jax.jit(lambda x0: hybrid.substep(tr, x0, None, H1)[0])
    d = float(jax.jacfwd(post)(jnp.array([1.01]))[0, 0])
    _, _, slope = _linear_oracle(1.01)
    assert abs(d - slope) > 1.0


def test_substep_vmaps_over_states_with_and_without_events(ball_step):
    xs = jnp.array([[0.01, -1.0], [1.0, -0.5], [0.003, -0.2]])
    x, ev = jax.vmap(lambda x: hybrid.substep(_ball(), x, None, 0.02))(xs)
    for i in range(3):
        xi, evi = ball_step(xs[i], 0.02)
        np.testing.assert_allclose(np.asarray(x[i]), np.asarray(xi), atol=1e-15)
        assert bool(ev.event[i]) == bool(evi.event)
    assert [bool(e) for e in ev.event] == [True, False, True]


def test_flow_until_event_secant_bounces_the_ball():
    y0, v0 = 1.0, 0.5
    r, xp, info = jax.jit(lambda x: hybrid.flow_until_event(_ball(), x, None, 0.01, 5.0))(jnp.array([y0, v0]))
    t, speed, _ = _ball_oracle(y0, v0, 0.0)
    assert int(r.status) == OK
    assert float(r.t) == pytest.approx(t, abs=1e-10)
    np.testing.assert_allclose(np.asarray(xp), [0.0, E * speed], atol=1e-10)
    assert float(info) == pytest.approx(speed, abs=1e-10)


def test_flow_until_event_linear_and_its_status():
    """The linear locate interpolates the state inside the last step: exact for a flow linear
    in time; no event within max_time, or a fall, is a status."""
    tr = hybrid.Transition(flow=lambda x, u: jnp.stack([x[1], 0.0 * x[0]]), guard=lambda x: x[0],
                           armed=lambda x: jnp.asarray(True), reset=lambda x: (jnp.stack([x[0], -x[1]]), x[1]))
    r, xp, info = hybrid.flow_until_event(tr, jnp.array([1.0, -0.7]), None, 0.1, 5.0, locate="linear")
    assert int(r.status) == OK
    assert float(r.t) == pytest.approx(1.0 / 0.7, abs=1e-12)
    np.testing.assert_allclose(np.asarray(xp), [0.0, 0.7], atol=1e-12)
    r, xp, info = hybrid.flow_until_event(tr, jnp.array([1.0, -0.1]), None, 0.1, 5.0, locate="linear")
    assert int(r.status) == FELL and float(info) == 0.0
    r, *_ = hybrid.flow_until_event(tr, jnp.array([1.0, -0.7]), None, 0.1, 5.0, locate="linear",
                                    fell=lambda x: x[0] < 0.5)
    assert int(r.status) == FELL
    with pytest.raises(ValueError, match="locate"):
        hybrid.flow_until_event(tr, jnp.array([1.0, -0.7]), None, 0.1, 5.0, locate="bisect")


def test_first_event_time_of_a_closed_form_flight():
    """A fall from 1 m (closed form), a guard that jumps (a step in the ground), one that
    starts below zero (ignored before t_min), and one that never fires."""
    t_max, n = 2.0, 1000
    tol = t_max / (n - 1) * 2.0**-40
    t, found = hybrid.first_event_time(lambda t: 1.0 - 0.5 * G * t * t, t_max, n)
    assert bool(found) and float(t) == pytest.approx(np.sqrt(2.0 / G), abs=2 * tol)
    t, found = hybrid.first_event_time(lambda t: jnp.where(t < 0.3, 1.0, -1.0), t_max, n)
    assert bool(found) and float(t) == pytest.approx(0.3, abs=2 * tol)
    t, found = hybrid.first_event_time(lambda t: jnp.where(t < 0.01, -1.0, 1.0 - t), t_max, n, t_min=0.02)
    assert bool(found) and float(t) == pytest.approx(1.0, abs=2 * tol)
    _, found = hybrid.first_event_time(lambda t: 1.0 + t, t_max, n)
    assert not bool(found)


def test_step_to_guard_closes_a_flow_at_its_event_with_the_exact_derivative():
    """The ball's fall closed by one step from a point near the impact: the step length is the
    impact time (RK4 is exact on the quadratic), and its forward-mode derivative in the
    starting height is the closed form's d t / d y0 = 1 / sqrt(v0^2 + 2 G y0)."""
    flow = lambda s, w: (jnp.stack([w[1], -G + 0.0 * w[0]]), w[0])  # noqa: E731
    guard = lambda s, w: w[0]  # noqa: E731
    v0 = -1.0

    def event(y0):
        return hybrid.step_to_guard(flow, jnp.asarray(0.0), jnp.stack([y0, v0]), guard, jnp.asarray(0.0),
                                    iterations=6)

    y0 = 0.02
    s, w = jax.jit(event)(jnp.asarray(y0))
    t, speed, _ = _ball_oracle(y0, v0, 0.0)
    assert float(s) == pytest.approx(t, abs=1e-14)
    np.testing.assert_allclose(np.asarray(w), [0.0, -speed], atol=1e-13)
    dt = float(jax.jacfwd(lambda y: event(y)[0])(jnp.asarray(y0)))
    assert dt == pytest.approx(1.0 / np.sqrt(v0**2 + 2 * G * y0), rel=1e-10)
    with pytest.raises(ValueError, match="method"):
        hybrid.step_to_guard(flow, 0.0, jnp.stack([y0, v0]), guard, 0.0, method="bisection")


def test_flow_until_event_on_the_section_before_the_reset():
    """section="pre": the ball at an impact is bounced first, then flown to the next impact
    (the map of the pre-impact section); the reset reported is the one it started with."""
    v = 2.0
    r, xp, info = jax.jit(lambda x: hybrid.flow_until_event(_ball(), x, None, 0.01, 5.0, section="pre"))(
        jnp.array([0.0, -v]))
    assert int(r.status) == OK
    assert float(r.t) == pytest.approx(2.0 * E * v / G, abs=1e-10)
    np.testing.assert_allclose(np.asarray(r.z), [0.0, -E * v], atol=1e-10)
    np.testing.assert_allclose(np.asarray(xp), [0.0, E * v], atol=0)
    assert float(info) == v
    with pytest.raises(ValueError, match="section"):
        hybrid.flow_until_event(_ball(), jnp.array([0.0, -v]), None, 0.01, 5.0, section="mid")


def _two_balls(tol=1e-12):
    """Two balls in free fall, state (y1, v1, y2, v2); each bounces when below the ground
    moving down; the discrete state counts the bounces of each and the accepted steps."""
    def flow(x, u, d):
        return jnp.stack([x[1], -G + 0.0 * x[0], x[3], -G + 0.0 * x[2]])

    def guard(x, d):
        return (x[0::2] < -1e-15) & (x[1::2] < 0.0)

    def reset(x, d, crossed):
        v = jnp.where(crossed, -E * x[1::2], x[1::2])
        return x.at[1::2].set(v), dict(d, bounces=d["bounces"] + crossed.astype(jnp.int32))

    def project(x, d):
        return x, dict(d, steps=d["steps"] + 1)

    return hybrid.MultiTransition(flow=flow, guard=guard, reset=reset, project=project, tol=tol)


def test_flow_sample_resolves_several_events_in_one_interval():
    """Both balls bounce inside one 50 ms interval of 10 ms steps, at different times; the state
    at its end is the closed form's to the bisection's tolerance, each reset applied once."""
    x0 = jnp.array([0.01, -1.0, 0.02, -0.5])
    d0 = dict(bounces=jnp.zeros(2, jnp.int32), steps=jnp.asarray(0))
    T, h = 0.05, 0.01
    x, d, seen = jax.jit(lambda x, d: hybrid.flow_sample(_two_balls(), x, d, None, 0.0, T, h))(x0, d0)
    assert bool(seen.resolved) and bool(seen.finite)
    assert int(seen.events) == 2 and [bool(c) for c in seen.crossed] == [True, True]
    assert [int(b) for b in d["bounces"]] == [1, 1]
    # impacts at 9.6 and 30.7 ms: steps accepted to 19.6, 29.6, 40.7 ms and the remainder to 50 ms
    assert int(d["steps"]) == 4
    for i, (y0, v0) in enumerate([(0.01, -1.0), (0.02, -0.5)]):
        t, _, after = _ball_oracle(y0, v0, T)
        assert t < T
        np.testing.assert_allclose(np.asarray(x[2 * i:2 * i + 2]), after, atol=1e-10)


def test_flow_sample_without_events_and_unresolved():
    """No event: the plain steps, each projected; too few iterations: not resolved."""
    x0 = jnp.array([1.0, 0.0, 2.0, 0.0])
    d0 = dict(bounces=jnp.zeros(2, jnp.int32), steps=jnp.asarray(0))
    x, d, seen = hybrid.flow_sample(_two_balls(), x0, d0, None, 0.0, 0.05, 0.01)
    assert bool(seen.resolved) and int(seen.events) == 0 and int(d["steps"]) == 5
    np.testing.assert_allclose(np.asarray(x), [1.0 - 0.5 * G * 0.05**2, -G * 0.05, 2.0 - 0.5 * G * 0.05**2,
                                               -G * 0.05], atol=1e-14)
    _, _, seen = hybrid.flow_sample(_two_balls().replace(max_iterations=3), x0, d0, None, 0.0, 0.05, 0.01)
    assert not bool(seen.resolved)
