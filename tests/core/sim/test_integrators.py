"""Integrators on the unactuated five-link in free fall (no ground): energy conservation
and measured convergence orders."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bipedlab import mechanics as mech
from bipedlab.robots.five_link import robot as five_link
from bipedlab.sim import heun, rk4, semi_implicit_euler

MODEL = five_link.model()


def free_fall(x, u):
    q, qd = x[:7], x[7:]
    return jnp.concatenate([qd, mech.forward_dynamics(MODEL, q, qd, jnp.zeros(7))])


def energy(x):
    return mech.kinetic_energy(MODEL, x[:7], x[7:]) + mech.potential_energy(MODEL, x[:7])


@pytest.fixture(scope="module")
def x0():
    rng = np.random.default_rng(2024)
    q = np.concatenate([[0.1, 1.0], rng.uniform(-0.8, 0.8, 5)])
    qd = np.array([0.5, 1.0, 2.0, -3.0, 4.0, 3.5, -2.5])  # sizeable: joints at several rad/s
    return jnp.asarray(np.concatenate([q, qd]))


def _integrate(step):
    @jax.jit
    def run(x0, h, n):
        return jax.lax.fori_loop(0, n, lambda i, x: step(free_fall, x, 0.0, h), x0)

    return run


RUN = {}


def run_with(name):
    if name not in RUN:
        RUN[name] = _integrate({"rk4": rk4, "heun": heun, "sie": semi_implicit_euler}[name])
    return RUN[name]


def test_rk4_conserves_energy_in_free_fall(x0):
    h, n = 2.5e-4, 4000  # 1 s

    @jax.jit
    def energies(x0):
        def body(x, _):
            x = rk4(free_fall, x, 0.0, h)
            return x, energy(x)

        return jax.lax.scan(body, x0, None, length=n)

    xf, E = energies(x0)
    E0 = float(energy(x0))
    T0 = float(mech.kinetic_energy(MODEL, x0[:7], x0[7:]))
    assert T0 > 50.0
    drift = np.abs(np.asarray(E) - E0).max()
    assert drift / T0 < 1e-8, drift / T0
    # it really moved: fell ~4.9 m below its ballistic start and the joints turned
    assert np.all(np.isfinite(np.asarray(xf)))
    assert abs(float(xf[4] - x0[4])) > 1.0
    # and it agrees with the generic fori_loop integration of the same steps
    np.testing.assert_allclose(run_with("rk4")(x0, h, n), xf, rtol=0, atol=1e-12)


def _order(name, x0, ref, T=0.2):
    hs = np.array([4e-3, 2e-3, 1e-3])
    errs = np.array([float(jnp.linalg.norm(run_with(name)(x0, h, int(round(T / h))) - ref)) for h in hs])
    slope = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    return slope, errs


@pytest.fixture(scope="module")
def reference(x0):
    return run_with("rk4")(x0, 1.25e-4, 1600)  # T = 0.2 s


def test_rk4_order(x0, reference):
    order, errs = _order("rk4", x0, reference)
    assert errs.min() > 1e-12  # far above roundoff and the reference's own error
    assert 3.6 < order < 4.4, (order, errs)


def test_heun_order(x0, reference):
    order, errs = _order("heun", x0, reference)
    assert 1.8 < order < 2.2, (order, errs)


def test_semi_implicit_euler_order_and_update(x0, reference):
    order, errs = _order("sie", x0, reference)
    assert 0.8 < order < 1.2, (order, errs)
    # the update itself: qd+ = qd + h qdd(q, qd); q+ = q + h qd+
    h = 1e-3
    x1 = semi_implicit_euler(free_fall, x0, 0.0, h)
    qd1 = x0[7:] + h * free_fall(x0, 0.0)[7:]
    np.testing.assert_allclose(x1, np.concatenate([x0[:7] + h * qd1, qd1]), rtol=1e-15, atol=1e-15)


def test_steps_on_a_linear_oscillator():
    """One step of each scheme against its closed form on x'' = -x (w = 1)."""
    f = lambda x, u: jnp.array([x[1], -x[0] + u])  # noqa: E731
    x, h = jnp.array([1.0, 0.5]), 0.1
    A = np.array([[0.0, 1.0], [-1.0, 0.0]])
    I = np.eye(2)
    rk4_map = I + h * A + (h * A) @ (h * A) / 2 + np.linalg.matrix_power(h * A, 3) / 6 + np.linalg.matrix_power(h * A, 4) / 24
    heun_map = I + h * A + (h * A) @ (h * A) / 2
    np.testing.assert_allclose(rk4(f, x, 0.0, h), rk4_map @ np.asarray(x), rtol=1e-15)
    np.testing.assert_allclose(heun(f, x, 0.0, h), heun_map @ np.asarray(x), rtol=1e-15)
    # the input is held over the step: u = 2 shifts the equilibrium to x = 2
    np.testing.assert_allclose(rk4(f, jnp.array([2.0, 0.0]), 2.0, h), [2.0, 0.0], atol=1e-15)
