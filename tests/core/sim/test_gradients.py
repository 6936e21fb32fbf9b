"""Derivatives through short rollouts of the standing scenario, started with both feet
pressed into the ground, against central finite differences.

Forward mode (jvp, RK4) and reverse mode (grad, semi-implicit Euler) are each compiled once;
the same compiled function supplies the primal values for the finite differences."""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bipedlab.sim import OK, rollout
from bipedlab.robots.five_link import scenario as scenarios
import oracles

# theta = [x0 hip height, x0 knee_1, kp, torso mass, ground stiffness]
THETA0 = np.array([0.76, 0.6, 400.0, 12.0, 2e5])
NAMES = ("x0[y_hip]", "x0[knee_1]", "kp", "torso mass", "ground stiffness")


def _final_state(spec):
    params, x0, _ = scenarios.standing(seconds=0.1)

    def final(th):
        model = params.model.replace(mass=params.model.mass.at[0].set(th[3]))
        ground = dataclasses.replace(params.ground, stiffness=th[4])
        p = dataclasses.replace(params, model=model, ground=ground, kp=th[2])
        x = x0.at[1].set(th[0]).at[4].set(th[1])
        r = rollout(scenarios.flow, scenarios.pd_policy, scenarios.fell, spec, p, x)
        return r.final, r.status

    return final


def test_start_is_in_contact():
    q = np.r_[0.0, THETA0[0], 0.0, -0.3, THETA0[1], 0.3, 0.0]
    feet = np.asarray(oracles.five_link_geometry(jnp.asarray(q))[2])
    assert np.all(feet[:, 1] < -1e-3)  # both feet ~4 mm into the ground


def _central_differences(f, th, rel=1e-6):
    cols = []
    for i in range(th.size):
        e = np.zeros_like(th)
        e[i] = rel * max(abs(th[i]), 1.0)
        cols.append((np.asarray(f(th + e)) - np.asarray(f(th - e))) / (2 * e[i]))
    return np.stack(cols, axis=-1)


def _assert_close_columns(ad, fd, rtol=1e-5):
    for i, name in enumerate(NAMES):
        a, b = np.atleast_1d(ad[..., i]), np.atleast_1d(fd[..., i])
        err = np.linalg.norm(a - b) / np.linalg.norm(b)
        assert np.linalg.norm(b) > 0, name
        print(f"d/d {name}: relative error {err:.2e}")
        assert err < rtol, f"d/d {name}: relative error {err:.2e}"


def test_forward_mode_through_rk4_rollout():
    """The Jacobian's columns one tangent at a time on one compiled jvp, which also gives the
    primal values of the differences (the tangents batched with vmap compiled twice as long)."""
    spec = dataclasses.replace(scenarios.standing(seconds=0.1)[2], dt=5e-4, substeps=1, steps=40)  # 20 ms
    final = _final_state(spec)

    @jax.jit
    def value_and_derivative(th, t):
        (y, status), (dy, _) = jax.jvp(final, (th,), (t,))
        return y, dy, status

    th = jnp.asarray(THETA0)
    cols = [value_and_derivative(th, e) for e in jnp.eye(th.size)]
    assert all(int(status) == OK for _, _, status in cols)
    J = np.stack([np.asarray(dy) for _, dy, _ in cols], axis=-1)
    assert np.all(np.isfinite(J))
    zero = jnp.zeros(th.size)
    fd = _central_differences(lambda t: value_and_derivative(jnp.asarray(t), zero)[0], THETA0)
    _assert_close_columns(J, fd)


def test_reverse_mode_through_semi_implicit_euler_rollout():
    spec = dataclasses.replace(scenarios.standing(seconds=0.1)[2], integrator="semi_implicit_euler",
                               dt=2.5e-4, substeps=1, steps=40)  # 10 ms
    final = _final_state(spec)
    w = jnp.asarray(np.random.default_rng(9).standard_normal(14))
    loss = lambda th: w @ final(th)[0]  # noqa: E731
    value_and_grad = jax.jit(jax.value_and_grad(loss))
    _, g = value_and_grad(jnp.asarray(THETA0))
    fd = _central_differences(lambda t: value_and_grad(jnp.asarray(t))[0], THETA0)
    _assert_close_columns(np.asarray(g)[None], fd[None])


@pytest.mark.slow
def test_reverse_mode_through_rk4_rollout():
    """jax.grad through the scenario's own integrator (RK4); ~40 s of compilation on a CPU."""
    spec = dataclasses.replace(scenarios.standing(seconds=0.1)[2], dt=5e-4, substeps=1, steps=40)
    final = _final_state(spec)
    w = jnp.asarray(np.random.default_rng(10).standard_normal(14))
    value_and_grad = jax.jit(jax.value_and_grad(lambda th: w @ final(th)[0]))
    _, g = value_and_grad(jnp.asarray(THETA0))
    fd = _central_differences(lambda t: value_and_grad(jnp.asarray(t))[0], THETA0)
    _assert_close_columns(np.asarray(g)[None], fd[None])
