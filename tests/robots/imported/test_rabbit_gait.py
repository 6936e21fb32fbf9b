"""RABBIT's HZD gait through the imported-model pipeline: the shipped 0.8 m/s gait (designed by
``bipedlab optimize model rabbit.xml``) against the published figures where they exist, its
restricted map's eigenvalue against finite differences; slow: the full Poincaré map's
eigenvalues against finite differences, one closed-loop step back to the fixed point, the
design from the default guess, and the five-link biped's exported MJCF reproducing the
five-link study's gait to 1e-8.

Published figures used: RABBIT's specific mechanical cost of transport, 0.38 (quoted beside
MABEL's, "approximately three times" MABEL's 0.14, in Sreenath et al. 2011), an upper bound
for the designed gait of a frictionless model with no motor losses; the joint torque limit of
150 N m (the rabbit.xml actuators, Chevallereau et al. 2003), a constraint of the design.
"""
from __future__ import annotations

from importlib import resources

import jax
import numpy as np
import pytest

from bipedlab.gait import gaitfile
from bipedlab.gait import walking as gw
from bipedlab.mechanics import stance as stm
from bipedlab.robots.imported import study as imported_study

pytest.importorskip("mujoco")

DATA = resources.files("bipedlab.robots.imported").joinpath("data")
RABBIT = str(DATA.joinpath("rabbit.xml"))
GAIT = str(DATA.joinpath("rabbit_0.8.json"))
RABBIT_CMT = 0.38


@pytest.fixture(scope="module")
def shipped():
    s, vc, z, rec = imported_study.load_gait(RABBIT, GAIT)
    return s, vc, z, rec["design"]


def test_shipped_gait_against_published_figures(shipped):
    s, vc, z, design = shipped
    assert design["success"] and design["stance"] == "left_foot" and design["swing"] == "right_foot"
    assert design["speed_mps"] == pytest.approx(0.8, abs=1e-9)
    assert 0.0 < design["cmt"] < RABBIT_CMT
    assert max(design["peak_torques_nm"]) <= 150.0 * (1 + 1e-9)
    assert design["torque_limits_nm"] == [150.0] * 4
    assert 0.0 < design["max_abs_eigenvalue"] < 1.0


def test_restricted_eigenvalue_against_finite_differences(shipped):
    """The short check: the restricted (zero-dynamics) map's derivative by autodiff against
    central differences, at its fixed point, and against the design's recorded eigenvalue."""
    s, vc, z, design = shipped
    st = s.study.stance
    thd = float(vc.c @ z[st.n:])
    rmap = jax.jit(lambda t: gw.restricted_map(vc, st, t, nodes=s.study.nodes))
    assert float(rmap(thd)) == pytest.approx(thd, abs=1e-8)
    rho = gw.restricted_eigenvalue(vc, st, thd, nodes=s.study.nodes)
    d = 1e-5
    assert rho == pytest.approx((float(rmap(thd + d)) - float(rmap(thd - d))) / (2 * d), abs=1e-7)
    assert rho == pytest.approx(design["restricted_eigenvalue"], abs=1e-12)
    assert 0.0 < rho < 1.0


@pytest.fixture(scope="module")
def jacobians(shipped):
    s, vc, z, _ = shipped
    st, ctrl = s.study.stance, s.study.controllers["iolin"]
    J = np.asarray(jax.jit(lambda x: gw.poincare_jacobian(vc, st, ctrl, x))(z))
    J_fd = gw.poincare_jacobian_fd(vc, st, ctrl, z)
    return J, J_fd


@pytest.mark.slow
def test_poincare_eigenvalues_against_finite_differences(shipped, jacobians):
    J, J_fd = jacobians
    assert np.linalg.norm(J - J_fd) / np.linalg.norm(J_fd) < 1e-5
    ev = np.sort(np.abs(np.linalg.eigvals(J)))[::-1]
    ev_fd = np.sort(np.abs(np.linalg.eigvals(J_fd)))[::-1]
    assert ev[0] == pytest.approx(ev_fd[0], abs=1e-5)
    # the dominant eigenvalue is the restricted map's (the zero dynamics', one dimension)
    s, vc, z, design = shipped
    rho = gw.restricted_eigenvalue(vc, s.study.stance, float(vc.c @ z[s.study.stance.n:]), nodes=s.study.nodes)
    assert ev[0] == pytest.approx(abs(rho), abs=1e-3)
    assert design["max_abs_eigenvalue"] == pytest.approx(ev[0], rel=1e-6)


@pytest.mark.slow
def test_one_closed_loop_step_returns_to_the_fixed_point(shipped):
    s, vc, z, design = shipped
    st = s.study.stance
    step = jax.jit(lambda x: gw.step(vc, st, s.study.controllers["iolin"], x))(z)
    assert int(step.status) == 0
    np.testing.assert_allclose(np.asarray(step.z_minus), np.asarray(z), atol=1e-5)
    assert abs(float(stm.swing_height(st, step.z_minus))) <= 1e-10
    assert float(step.duration) == pytest.approx(design["period_s"], abs=1e-5)
    assert float(step.step_length) == pytest.approx(design["step_length_m"], abs=1e-6)


@pytest.mark.slow
def test_rabbit_gait_from_the_default_guess(tmp_path):
    """The design from the default guess converges, meets the torque limits, and is the shipped
    gait (the cost is flat along the gait family to ~1e-7 in the step length: same cost to
    1e-9, same gait to 1e-5). No clearance bound, as the shipped gait was designed (it clears
    the default's 2.4 cm parabola by 5.4 cm at its closest, so the default leaves it inactive)."""
    save = tmp_path / "rabbit.json"
    rec = imported_study.optimize(RABBIT, "left_foot", "right_foot", 0.8, "torque", save=str(save), clearance=0.0)
    assert rec["success"] and rec["max_constraint_violation"] < 1e-9
    assert max(rec["peak_torques_nm"]) <= 150.0 * (1 + 1e-9)
    vc, z, d = gaitfile.load(save)
    vc0, z0, d0 = gaitfile.load(GAIT)
    assert rec["torque_cost"] == pytest.approx(d0["design"]["torque_cost"], rel=1e-9)
    np.testing.assert_allclose(np.asarray(z), np.asarray(z0), atol=1e-5)


@pytest.mark.slow
def test_exported_five_link_reproduces_the_five_link_gait(tmp_path):
    """The five-link biped's exported MJCF through ``optimize model`` gives the five-link
    study's shipped gait (the same problem derived from the file, with the five-link study's
    default of no clearance bound): to 1e-8."""
    from bipedlab.robots.five_link import robot as five_link

    xml = tmp_path / "five_link.xml"
    xml.write_text(five_link.mjcf(pd_gains=(400.0, 20.0)))
    save = tmp_path / "gait.json"
    imported_study.optimize(str(xml), "foot_1", "foot_2", 0.8, "torque", save=str(save), clearance=0.0)
    vc, z, _ = gaitfile.load(save)
    vc0, z0, _ = gaitfile.shipped("bipedlab.robots.five_link", "five_link_0.8")
    np.testing.assert_allclose(np.asarray(z), np.asarray(z0), atol=1e-8)
    np.testing.assert_allclose(np.asarray(vc.alpha), np.asarray(vc0.alpha), atol=1e-8)
    np.testing.assert_allclose(np.asarray(vc.c), np.asarray(vc0.c), atol=1e-15)
    assert float(vc.theta_minus) == pytest.approx(float(vc0.theta_minus), abs=1e-8)
