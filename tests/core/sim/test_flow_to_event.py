"""Exact event location of bipedlab.sim.events.flow_to_event on problems with closed-form
event times, and forward-mode derivatives of the event state (event-time sensitivity).

A ball in free fall is a quadratic in time, which RK4 integrates exactly, so the located
event is exact to rounding; the harmonic oscillator checks a non-polynomial flow."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bipedlab.sim import FELL, NONFINITE, OK
from bipedlab.sim.events import flow_to_event

G = 9.81
H = 0.01


def _fall(y0, v0, h=H, armed=lambda z: jnp.asarray(True), max_time=5.0, integrand=None, fell=None):
    f = lambda z: jnp.stack([z[1], -G * jnp.ones_like(z[1])])  # noqa: E731
    return flow_to_event(f, lambda z: z[0], armed, jnp.stack([y0, v0]), h, max_time, integrand, fell)


def _t_hit(y0, v0):
    return (v0 + np.sqrt(v0**2 + 2 * G * y0)) / G


@pytest.fixture(scope="module")
def fall():
    return jax.jit(lambda y0, v0: _fall(y0, v0, integrand=lambda z: jnp.stack([jnp.ones(()), z[0]])))


@pytest.mark.parametrize("y0,v0", [(1.0, 0.0), (0.37, 0.0), (2.5, 0.0), (1.0, 1.3), (0.8, -2.0), (1.234, 0.0071)])
def test_free_fall_event_time_and_state(fall, y0, v0):
    r = fall(jnp.asarray(y0), jnp.asarray(v0))
    t = _t_hit(y0, v0)
    assert int(r.status) == OK
    assert float(r.t) == pytest.approx(t, abs=1e-10)
    assert abs(float(r.guard)) <= 1e-12
    np.testing.assert_allclose(np.asarray(r.z), [0.0, v0 - G * t], atol=1e-10)
    # the integrals are rectangle sums at the RK4 steps: within one step (times the
    # integrand's size) of the exact integrals of 1 and of y(t) = y0 + v0 t - g t^2 / 2
    ymax = y0 + max(v0, 0.0) ** 2 / (2 * G)
    assert abs(float(r.integrals[0]) - t) <= H + 1e-12
    exact = y0 * t + v0 * t**2 / 2 - G * t**3 / 6
    assert abs(float(r.integrals[1]) - exact) <= H * ymax + 1e-12


def test_integral_of_a_constant_is_the_event_time(fall):
    y0 = 1.0
    r = fall(jnp.asarray(y0), jnp.asarray(0.0))
    t = _t_hit(y0, 0.0)
    # rectangle rule with the last, partial step weighted by its length: exact for constants
    assert float(r.integrals[0]) == pytest.approx(t, abs=1e-12)


def test_event_is_located_inside_the_step_for_any_step_size():
    """A step that does not divide the fall time still ends on the event (located, not stepped)."""
    y0 = 1.0
    for h in (0.013, 0.05, 0.1):
        r = _fall(jnp.asarray(y0), jnp.asarray(0.0), h=h)
        assert float(r.t) == pytest.approx(_t_hit(y0, 0.0), abs=1e-10)


def test_event_state_derivatives_include_event_time_sensitivity():
    """d/dy0 of (t*, y(t*), v(t*)): t* = (v0 + s)/g with s = sqrt(v0^2 + 2 g y0), so
    dt*/dy0 = 1/s, dv*/dy0 = -g/s, dy*/dy0 = 0 (the state stays on the guard); likewise
    dt*/dv0 = (1 + v0/s)/g and dv*/dv0 = -v0/s."""
    def event(p):
        r = _fall(p[0], p[1])
        return jnp.concatenate([r.t[None], r.z])

    for y0, v0 in ((1.0, 0.0), (0.6, 1.1), (1.7, -0.4)):
        Jac = np.asarray(jax.jit(jax.jacfwd(event))(jnp.asarray([y0, v0])))
        s = np.sqrt(v0**2 + 2 * G * y0)
        expected = np.array([
            [1.0 / s, (1.0 + v0 / s) / G],
            [0.0, 0.0],
            [-G / s, -v0 / s],
        ])
        np.testing.assert_allclose(Jac, expected, rtol=1e-9, atol=1e-10)


def test_start_on_the_guard_moving_up_ends_at_the_next_downward_crossing():
    """Like a step that starts with the swing foot on the ground: z0 on the guard, g rising."""
    v0 = 2.0
    r = _fall(jnp.asarray(0.0), jnp.asarray(v0))
    assert int(r.status) == OK
    assert float(r.t) == pytest.approx(2 * v0 / G, abs=1e-10)
    assert float(r.z[1]) == pytest.approx(-v0, abs=1e-10)


def test_unarmed_crossings_are_ignored():
    """A ball bouncing on a floor at y = 0 from y0 = 1 crosses y = 0.5 twice on the way down
    and up; with the guard y - 0.5 armed only after t > t1 (encoded in the state as v < -4),
    the first crossing (v = -3.13) is skipped and nothing else happens: FELL at max_time.
    With the guard armed for v < -3, the first crossing is found."""
    f = lambda z: jnp.stack([z[1], -G * jnp.ones_like(z[1])])  # noqa: E731
    z0 = jnp.asarray([1.0, 0.0])
    r = flow_to_event(f, lambda z: z[0] - 0.5, lambda z: z[1] < -4.0, z0, H, 0.6)
    assert int(r.status) == FELL
    r = flow_to_event(f, lambda z: z[0] - 0.5, lambda z: z[1] < -3.0, z0, H, 0.6)
    assert int(r.status) == OK
    assert float(r.t) == pytest.approx(np.sqrt(2 * 0.5 / G), abs=1e-10)


def test_fell_and_nonfinite_statuses():
    # fell: the ball is declared fallen below y = 0.2 before the guard y + 1 = 0 is reached
    f = lambda z: jnp.stack([z[1], -G * jnp.ones_like(z[1])])  # noqa: E731
    r = flow_to_event(f, lambda z: z[0] + 1.0, lambda z: jnp.asarray(True), jnp.asarray([1.0, 0.0]), H, 5.0,
                      fell=lambda z: z[0] < 0.2)
    assert int(r.status) == FELL
    assert float(r.t) == pytest.approx(np.ceil(np.sqrt(2 * 0.8 / G) / H) * H, abs=1e-9)
    # a blow-up (xdot = x^2 from 1 reaches infinity at t = 1) is reported, not raised
    r = flow_to_event(lambda z: z**2, lambda z: -z[0], lambda z: jnp.asarray(False), jnp.asarray([1.0]), 0.05, 5.0)
    assert int(r.status) == NONFINITE


def test_harmonic_oscillator_event_time_and_its_frequency_derivative():
    """y'' = -w^2 y from (1, 0) first crosses y = 0 downwards at t* = pi / (2 w), where
    v = -w; dt*/dw = -pi / (2 w^2) and dv*/dw = -1."""
    def event(w):
        f = lambda z: jnp.stack([z[1], -(w**2) * z[0]])  # noqa: E731
        r = flow_to_event(f, lambda z: z[0], lambda z: jnp.asarray(True), jnp.asarray([1.0, 0.0]), 1e-3, 10.0)
        return jnp.stack([r.t, r.z[0], r.z[1]]), r.status

    for w in (1.0, 2.7):
        (vals, status) = jax.jit(event)(jnp.asarray(w))
        assert int(status) == OK
        np.testing.assert_allclose(np.asarray(vals), [np.pi / (2 * w), 0.0, -w], atol=1e-10)
        d = np.asarray(jax.jit(jax.jacfwd(lambda w_: event(w_)[0]))(jnp.asarray(w)))
        np.testing.assert_allclose(d, [-np.pi / (2 * w**2), 0.0, -1.0], rtol=1e-8, atol=1e-9)
