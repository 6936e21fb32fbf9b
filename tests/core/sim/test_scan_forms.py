"""The scan forms of RK4 and of false-position event location give the results of the
unrolled forms (they exist to hold a large flow once in a compiled program)."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.sim.events import regula_falsi, regula_falsi_with
from bipedlab.sim.integrators import rk4, rk4_scan


def _pendulum(x, u):
    return jnp.stack([x[1], -9.81 * jnp.sin(x[0]) - 0.3 * x[1] + u])


def test_rk4_scan_matches_rk4_and_is_fourth_order():
    x = jnp.array([1.2, -0.4])
    a, b = rk4(_pendulum, x, 0.7, 0.01), rk4_scan(_pendulum, x, 0.7, 0.01)
    np.testing.assert_allclose(np.asarray(b), np.asarray(a), rtol=1e-15, atol=1e-15)

    # fourth order: halving h divides the one-step error against a fine reference by ~32
    def err(h):
        ref = x
        for _ in range(64):
            ref = rk4(_pendulum, ref, 0.7, h / 64)
        return float(jnp.max(jnp.abs(jax.jit(lambda z: rk4_scan(_pendulum, z, 0.7, h))(x) - ref)))
    ratio = err(0.1) / err(0.05)
    assert 25.0 < ratio < 40.0


def test_regula_falsi_with_returns_the_point_and_its_state():
    z0 = jnp.array([0.3, 0.0])

    def at(t):
        z = rk4_scan(_pendulum, z0, 0.0, t)  # the angle crosses zero within 0.8 s
        return z[0], z

    g0, g1 = at(0.0)[0], at(0.8)[0]
    assert g0 > 0 >= g1
    x1 = regula_falsi(lambda t: at(t)[0], 0.0, 0.8, g0, g1, 6)
    x2, z = jax.jit(lambda: regula_falsi_with(at, 0.0, 0.8, g0, g1, 6))()
    assert float(x1) == float(x2)
    np.testing.assert_allclose(np.asarray(z), np.asarray(at(x2)[1]), rtol=1e-14, atol=1e-15)
    assert abs(float(z[0])) < 1e-6
