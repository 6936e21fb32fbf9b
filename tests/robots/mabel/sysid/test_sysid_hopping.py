"""Section VIII-C: cable stretch from the rotor-and-cable equation, and the hard stop and ground
from an open-loop replay of the 13-DoF model, both by least squares with JAX Jacobians."""
from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

import bipedlab  # noqa: F401
from bipedlab.robots.mabel import sysid
from bipedlab.robots.mabel import tables as tb
from bipedlab.robots.mabel.sysid import hopping_fit as hf
from bipedlab.robots.mabel.sysid import rigs
from bipedlab.robots.mabel.sysid.logs import Experiment


def _cable_log(truth, actuator):
    """A log whose joint side moves smoothly and whose motor follows the rotor-and-cable model."""
    t = np.arange(800) * 1e-3
    la = np.pi + 0.2 * np.sin(2 * np.pi * 1.3 * t) + 0.05 * np.sin(2 * np.pi * 7.0 * t)
    tor = 0.1 + 0.05 * np.sin(2 * np.pi * 0.8 * t)
    u = 6.0 * np.sin(2 * np.pi * 3.1 * t) + 2.0 * np.cos(2 * np.pi * 9.0 * t)
    r = rigs.rigid_motor_angle(actuator, la, 0.0, 0.0)
    qm = np.asarray(rigs.rotor_cable(hf.rotor_cable_params(truth, actuator), u, r, tor, float(r[0]), 4))
    enc = {"la_L": la, "ls_L": np.zeros_like(t), "bsp_L": np.zeros_like(t), "tor": tor, "mla_L": qm}
    return Experiment("cable", "hopping", t, {actuator: u}, enc, meta={})


def test_cable_fit_recovers_exact_parameters():
    truth = sysid.perturbed(8)
    k = sysid.params.actuator_index("mLA_L")
    f = sysid.fit_cable(_cable_log(truth, "mLA_L"), truth, "mLA_L", guess=(1.0, 0.01))
    assert f.stiffness == pytest.approx(truth.cable_k[k], rel=1e-8)
    assert f.damping == pytest.approx(truth.cable_d[k], rel=1e-7)
    assert f.rms_deg < 1e-9


def test_rotor_cable_is_the_hopping_models_motor_equation():
    """Driven by the joint side of a 13-DoF hop, the rotor-and-cable model predicts the motor
    angle of that hop to within the integrators' difference (a few encoder counts on motor
    angles that move by radians)."""
    truth = sysid.perturbed(0)
    e = sysid.hopping_experiment(truth, sysid.sensors.exact(), sysid.quick_design())
    for a in ("mLA_R", "mLS_L"):
        sim = hf.simulate_cable(e, truth, a)
        meas = hf.cable_inputs(e, a)[3]
        stretch = np.max(np.abs(hf.measured_stretch(e, a)))
        assert stretch > 0.1                                        # the cables do stretch
        assert np.max(np.abs(sim - meas)) < 0.01 * stretch


@pytest.mark.slow
def test_hopping_fit_recovers_ground_and_spring_damping_from_noise_free_data():
    """Exact encoders and the estimator's own integrator: from 20 % off, the replay fit of the
    landing and stance brings the ground's stiffness and damping and the spring damping back
    to the truth. Slow (its own Jacobian program, about a minute to compile on two cores); by
    default the identify command's test (tests/robots/mabel/sysid/test_sysid_cli.py) runs the
    same fit on the quick design with noisy encoders and checks the spring damping identified."""
    truth = sysid.perturbed(0)
    e = sysid.hopping_experiment(truth, sysid.sensors.exact(), sysid.quick_design())
    free = ("spring_d", "ground_stiffness", "ground_damping")
    values = hf.hop_values(truth)
    prior = {k: v * (1.2 if k in free else 1.0) for k, v in values.items()}
    fit = sysid.fit_hopping(e, truth, prior=prior, prior_sd=100.0, free=free, windows=(0.6,),
                            max_nfev=30)
    for k in free:
        assert fit.values[k] == pytest.approx(values[k], rel=1e-6)
    assert fit.rms_deg < 1e-6
    assert not fit.identified("kd1")     # its cubic term is nil at millimetre penetrations


def test_standard_errors_flag_an_unseen_direction():
    J = np.array([[1.0, 0.0], [2.0, 0.0], [0.5, 0.0]])
    se = hf.standard_errors(J, np.array([0.1, -0.1, 0.05]))
    assert np.isfinite(se[0]) and np.isinf(se[1])


def test_hop_log_starts_at_rest_and_the_robot_lands():
    truth = sysid.perturbed(0)
    e = sysid.hopping_experiment(truth, sysid.sensors.exact(), sysid.quick_design())
    k0 = hf.release_index(e)
    q = hf.measured_coordinates(e)
    assert k0 > 0 and np.ptp(q[: k0 + 1], axis=0).max() == 0.0
    assert np.all(e.U(sysid.params.ACTUATORS)[:k0] == 0.0)
    assert q[:, hf.INDEX["bsp_L"]].max() > 0.1                        # the spring compresses on landing
    assert q[:, hf.INDEX["y"]].min() < q[0, hf.INDEX["y"]] - 0.03
    assert float(e.meta["boom_radius"]) == tb.BOOM["radius"]
    np.testing.assert_allclose(hf.initial_coordinates(e), q[0])
    assert jnp.asarray(q).shape[1] == 13
