"""Status flags of rollouts and batched rollouts, on a 1-D point mass whose flow turns
non-finite above a height: x = [position, velocity], constant acceleration a,
fell when position < 0, NaN once a stage evaluates above `nan_above`."""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bipedlab.sim import FELL, NONFINITE, OK, STATUS_NAMES, RolloutSpec, batched_rollout, rollout


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class P:
    acc: jax.Array
    nan_above: jax.Array


def flow(p, x, u):
    xdot = jnp.stack([x[1], u])
    return jnp.where(x[0] > p.nan_above, jnp.nan, xdot)


def policy(p, x, k):
    return p.acc


def fell(p, x):
    return x[0] < 0.0


SPEC = RolloutSpec(dt=0.01, substeps=10, steps=30, integrator="rk4", record=True)  # 0.1 s per control step
PARAMS = P(jnp.asarray(0.0), jnp.asarray(2.0))


@pytest.fixture(scope="module")
def run():
    return jax.jit(lambda p, x: rollout(flow, policy, fell, SPEC, p, x))


def test_healthy_rollout_is_ok(run):
    r = run(PARAMS, jnp.array([1.0, 0.25]))
    assert int(r.status) == OK and int(r.failed_at) == SPEC.steps
    t = 0.1 * np.arange(1, 31)
    np.testing.assert_allclose(np.asarray(r.states)[:, 0], 1.0 + 0.25 * t, rtol=1e-13)
    np.testing.assert_allclose(r.final, [1.0 + 0.25 * 3.0, 0.25], rtol=1e-13)
    assert STATUS_NAMES[OK] == "ok"


def test_fall_is_reported_with_its_step(run):
    r = run(PARAMS, jnp.array([1.0, -0.95]))  # crosses 0 at t = 1.0526 s: control step 10
    assert int(r.status) == FELL and int(r.failed_at) == 10
    np.testing.assert_allclose(r.final, [1.0 - 0.95 * 1.1, -0.95], rtol=1e-12)
    np.testing.assert_array_equal(np.asarray(r.states)[10:], np.broadcast_to(np.asarray(r.final), (20, 2)))


def test_nonfinite_is_reported_and_last_finite_state_kept(run):
    r = run(PARAMS, jnp.array([1.0, 0.45]))  # passes 2 at t = 2.222 s: control step 22
    assert int(r.status) == NONFINITE and int(r.failed_at) == 22
    assert np.all(np.isfinite(np.asarray(r.states)))
    np.testing.assert_allclose(r.final, [1.0 + 0.45 * 2.2, 0.45], rtol=1e-12)
    assert STATUS_NAMES[NONFINITE] == "non-finite"


def test_nonfinite_at_the_first_step_keeps_x0(run):
    x0 = jnp.array([1.0, -0.95])
    r = run(P(jnp.asarray(0.0), jnp.asarray(-0.5)), x0)  # NaN at once: 1.0 > -0.5
    assert int(r.status) == NONFINITE and int(r.failed_at) == 0
    np.testing.assert_array_equal(r.final, x0)


def test_batched_statuses():
    x0 = jnp.array([[1.0, 0.25], [1.0, -0.95], [1.0, 0.45], [0.5, -0.5]])
    spec = dataclasses.replace(SPEC, record=False)
    r = jax.jit(lambda p, x: batched_rollout(flow, policy, fell, spec, p, x))(PARAMS, x0)
    np.testing.assert_array_equal(r.status, [OK, FELL, NONFINITE, FELL])
    np.testing.assert_array_equal(r.failed_at, [30, 10, 22, 9])
    assert r.states is None
    # batching the parameters too: the NaN ceiling per rollout
    ps = P(jnp.zeros(3), jnp.array([10.0, 2.0, 1.2]))
    x0 = jnp.tile(jnp.array([1.0, 0.45]), (3, 1))
    r = jax.jit(lambda p, x: batched_rollout(flow, policy, fell, spec, p, x, params_axis=0))(ps, x0)
    np.testing.assert_array_equal(r.status, [OK, NONFINITE, NONFINITE])
    np.testing.assert_array_equal(r.failed_at, [30, 22, 4])


def test_unknown_integrator_is_a_value_error():
    spec = dataclasses.replace(SPEC, integrator="euler")
    with pytest.raises(ValueError, match="unknown integrator 'euler'"):
        rollout(flow, policy, fell, spec, PARAMS, jnp.array([1.0, 0.0]))
