"""Section V: the leg rig is the hopping model's mechanism, and eqs. 19-20 recover friction and
bias exactly from noise-free leg experiments (exact JAX Jacobians through RK4)."""
from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

import bipedlab  # noqa: F401
from bipedlab.robots.mabel import sysid
from bipedlab.mechanics import coupled as cp
from bipedlab.robots.mabel.sysid import friction, rigs
from bipedlab.robots.mabel.sysid import params as P


@pytest.mark.parametrize("side", ["L", "R"])
def test_leg_rig_is_the_hopping_models_mechanism(side):
    """Mass matrix and gravity of the rig equal E^T M E and E^T G of the 13-DoF model (torso
    and hip fixed, B_spring blocked) on that leg's own coordinates, for both legs."""
    truth = sysid.perturbed(2)
    rig = rigs.leg_rig(truth, side)
    full = P.model(truth)
    E = rigs.leg_map(side)
    rng = np.random.default_rng(0)
    for _ in range(3):
        p = np.array(rigs.leg_motor_angles(np.pi + rng.uniform(-0.5, 0.5), rng.uniform(0.05, 0.6)))
        pd = rng.standard_normal(2) * 20.0
        q, qd = jnp.asarray(E @ p), jnp.asarray(E @ pd)
        M = E.T @ np.asarray(cp.mass_matrix(full.body, q)) @ E
        h = E.T @ np.asarray(cp.bias(full.body, q, qd))
        np.testing.assert_allclose(np.asarray(cp.mass_matrix(rig.body, jnp.asarray(p))), M, rtol=1e-12)
        np.testing.assert_allclose(np.asarray(cp.bias(rig.body, jnp.asarray(p), jnp.asarray(pd))), h, rtol=1e-10,
                                   atol=1e-12)
    assert rig.body.rotor_names.index("mLA_L") >= 0
    k = [P.actuator_index(a) for a in rigs.LEG_ACTUATORS[side]]
    np.testing.assert_allclose(np.asarray(rig.kt), truth.kt[k])


def test_locked_coordinate_does_not_move():
    truth = sysid.perturbed(2)
    rig = rigs.leg_rig(truth, "L")
    x0 = jnp.asarray(np.r_[rigs.leg_motor_angles(np.pi, 0.3), 0.0, 0.0])
    U = jnp.full((200, 2), 0.5)
    Y = np.asarray(rigs.simulate_leg(rig, x0, U, (True, False), 2))
    assert np.all(Y[:, 1] == float(x0[1])) and np.ptp(Y[:, 0]) > 0.1


def test_friction_and_bias_recovered_exactly_from_noise_free_leg_data():
    """Exact encoders, the estimator's integrator: eqs. 19-20 over the three experiments of a
    leg give back both frictions and both biases from the published values."""
    truth = sysid.perturbed(4)
    exps = sysid.leg_experiments(truth, "R", sysid.sensors.exact(), sysid.quick_design(), substeps=1)
    start = truth.replace(friction=P.published().friction, bias=P.published().bias)
    f = sysid.fit_leg(rigs.leg_rig(start, "R"), exps, friction.VARIABLES)
    k = [P.actuator_index(a) for a in rigs.LEG_ACTUATORS["R"]]
    np.testing.assert_allclose(f.values[:2], truth.friction[k], rtol=1e-7)
    np.testing.assert_allclose(f.values[2:], truth.bias[k], atol=1e-9)
    assert max(f.rms_deg.values()) < 1e-8
    assert {e.meta["mode"] for e in exps} == {"siso", "mimo"}
