"""The anchor scenario (five-link standing under joint PD on the penalty ground) against an
independent implementation built on the autodiff Lagrangian of tests/oracles.py."""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bipedlab import mechanics as mech
from bipedlab.contact.penalty import contact_forces
from bipedlab.sim import FELL, OK, rollout
from bipedlab.robots.five_link import scenario as scenarios
import oracles

SECONDS = 0.2
DT, SUBSTEPS = 2.5e-4, 4
KP, KD, K_GROUND, D_GROUND, C_GROUND = 400.0, 20.0, 2e5, 2e3, 3e3
Q_REF = np.array([-0.3, 0.6, 0.3, 0.0])


def oracle_flow(x, u):
    q, qd = x[:7], x[7:]
    L = oracles.FIVE_LINK
    tau = jnp.concatenate([jnp.zeros(3), u])
    for leg in (0, 1):
        J = jax.jacfwd(oracles.five_link_foot)(q, leg)
        p, v = oracles.five_link_foot(q, leg), J @ qd
        pen = -p[1]
        fy = jnp.where(pen > 0, jnp.maximum(K_GROUND * pen - D_GROUND * v[1], 0.0), 0.0)
        fx = jnp.where(pen > 0, -C_GROUND * v[0], 0.0)
        tau = tau + J.T @ jnp.stack([fx, fy])
    return jnp.concatenate([qd, L.accel(q, qd, tau)])


@jax.jit
def oracle_trajectory(x0):
    def rk4(x, u):
        k1 = oracle_flow(x, u)
        k2 = oracle_flow(x + DT / 2 * k1, u)
        k3 = oracle_flow(x + DT / 2 * k2, u)
        k4 = oracle_flow(x + DT * k3, u)
        return x + DT / 6 * (k1 + 2 * k2 + 2 * k3 + k4)

    def control(x, _):
        u = KP * (Q_REF - x[3:7]) - KD * x[10:14]
        x = jax.lax.fori_loop(0, SUBSTEPS, lambda i, x: rk4(x, u), x)
        return x, x

    return jax.lax.scan(control, x0, None, length=int(round(SECONDS / (DT * SUBSTEPS))))[1]


@pytest.fixture(scope="module")
def scenario():
    params, x0, spec = scenarios.standing(seconds=SECONDS)
    return params, x0, dataclasses.replace(spec, record=True)


@pytest.fixture(scope="module")
def run(scenario):
    """The scenario's rollout, compiled once; params and x0 are arguments."""
    _, _, spec = scenario
    return jax.jit(lambda p, x: rollout(scenarios.flow, scenarios.pd_policy, scenarios.fell, spec, p, x))


@pytest.fixture(scope="module")
def healthy(scenario, run):
    params, x0, _ = scenario
    return run(params, x0)


def test_scenario_definition(scenario):
    params, x0, spec = scenario
    assert (spec.dt, spec.substeps, spec.steps, spec.integrator) == (DT, SUBSTEPS, 200, "rk4")
    assert (float(params.kp), float(params.kd)) == (KP, KD)
    np.testing.assert_array_equal(params.q_ref, Q_REF)
    np.testing.assert_array_equal(x0, np.r_[0.0, 0.78, 0.0, Q_REF, np.zeros(7)])
    g = params.ground
    assert (float(g.stiffness), float(g.damping), float(g.tangential_damping)) == (K_GROUND, D_GROUND, C_GROUND)
    # policy: u = kp (q_ref - q) - kd qd on the joints
    x = jnp.asarray(np.random.default_rng(0).standard_normal(14))
    np.testing.assert_allclose(scenarios.pd_policy(params, x, 0), KP * (Q_REF - x[3:7]) - KD * x[10:14], rtol=1e-15)


def test_matches_independent_implementation(scenario, healthy):
    params, x0, _ = scenario
    ref = np.asarray(oracle_trajectory(x0))
    states = np.asarray(healthy.states)
    assert int(healthy.status) == OK and int(healthy.failed_at) == 200
    assert states.shape == ref.shape == (200, 14)
    # the feet really are on the ground by the end (the penalty contact is exercised)
    feet = np.asarray(jax.vmap(oracles.five_link_geometry)(jnp.asarray(ref[:, :7]))[2])
    assert feet[-1, :, 1].max() < 0 and feet[0, :, 1].min() > 0
    np.testing.assert_allclose(healthy.final, ref[-1], rtol=0, atol=1e-9)
    np.testing.assert_allclose(states, ref, rtol=0, atol=1e-9)


def test_contact_forces_formula(scenario, healthy):
    params, _, _ = scenario
    x = np.asarray(healthy.final)
    q, qd = x[:7], x[7:]
    F = np.asarray(contact_forces(params.model, params.ground, q, qd, ["foot_1", "foot_2"]))
    for leg in (0, 1):
        p = np.asarray(oracles.five_link_foot(jnp.asarray(q), leg))
        v = np.asarray(jax.jacfwd(oracles.five_link_foot)(jnp.asarray(q), leg)) @ qd
        pen = -p[1]
        assert pen > 0
        np.testing.assert_allclose(F[leg], [-C_GROUND * v[0], max(K_GROUND * pen - D_GROUND * v[1], 0.0)],
                                   rtol=1e-10, atol=1e-9)
    up = q.copy()
    up[1] += 1.0  # lifted clear of the ground: no force
    np.testing.assert_array_equal(contact_forces(params.model, params.ground, up, qd, ["foot_1", "foot_2"]), 0.0)


def test_fall_is_reported_and_freezes_the_state(scenario, run, healthy):
    params, x0, _ = scenario
    threshold = 0.77  # the hip drops below it while the robot settles onto its feet
    res = run(dataclasses.replace(params, min_height=jnp.asarray(threshold, dtype=jnp.float64)), x0)
    ys = np.asarray(healthy.states)[:, 1]
    k = int(np.argmax(ys < threshold))
    assert 0 < k < 199 and ys[k] < threshold <= ys[:k].min()
    assert int(res.status) == FELL and int(res.failed_at) == k
    states = np.asarray(res.states)
    np.testing.assert_array_equal(states[: k + 1], np.asarray(healthy.states)[: k + 1])
    np.testing.assert_array_equal(states[k + 1:], np.broadcast_to(states[k], states[k + 1:].shape))
    np.testing.assert_array_equal(res.final, states[k])
