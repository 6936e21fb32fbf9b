"""What the imported-biped study derives from a file: the legs and their swap, the outputs,
the phase (the stance leg's absolute angle), the torque limits and the initial guess, checked
against the shipped five-link biped's hand-written ones and against RABBIT's geometry."""
from __future__ import annotations

from importlib import resources

import numpy as np
import pytest

from bipedlab import mechanics as mech
from bipedlab.io import read
from bipedlab.robots.five_link import robot as five_link
from bipedlab.robots.imported import robot as imported

pytest.importorskip("mujoco")


def _data(name: str) -> str:
    return str(resources.files("bipedlab.robots.imported").joinpath("data", name))


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """The five-link biped exported to MJCF with an actuator on every joint."""
    path = tmp_path_factory.mktemp("five") / "five_link.xml"
    path.write_text(five_link.mjcf(pd_gains=(400.0, 20.0)))
    return path


@pytest.mark.parametrize("name", ["rabbit.xml", "rabbit.urdf"])
def test_rabbit_legs_outputs_phase(name):
    s = imported.load(_data(name), "left_foot", "right_foot")
    assert s.study.stance.swap == (0, 1, 2, 5, 6, 3, 4)
    np.testing.assert_array_equal(s.study.H0, np.eye(5)[1:])
    # equal femur and tibia: the hip-to-toe line's angle is root + hip + knee / 2 exactly
    np.testing.assert_allclose(s.study.c, [-1.0, -1.0, -0.5, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(s.c_swing, [-1.0, 0.0, 0.0, -1.0, -0.5], atol=1e-15)
    assert s.study.torque_limits == (150.0,) * 4
    assert s.leg == pytest.approx(0.8, abs=1e-15)


def test_phase_is_the_stance_leg_angle():
    """theta = c . q_s equals minus the hip-to-toe line's angle from the vertical, to first
    order about the reference configuration (a finite check of the linearisation)."""
    s = imported.load(_data("rabbit.xml"), "left_foot", "right_foot")
    m = s.desc.model
    rng = np.random.default_rng(4)
    for _ in range(5):
        qs = 1e-4 * rng.standard_normal(5)
        q = np.concatenate([np.zeros(2), qs])
        toe = np.asarray(mech.point_position(m, q, "left_foot"))
        hip = np.asarray(mech.point_position(m, q, "hip"))
        psi = np.arctan2(toe[0] - hip[0], -(toe[1] - hip[1]))
        assert abs(s.study.c @ qs + psi) < 1e-7


def test_exported_five_link_gives_the_five_link_study(exported):
    """On the five-link biped's own MJCF, the derived study is the hand-written one: outputs,
    phase, leg swap, and the initial guess of the gait design to 1e-15."""
    from bipedlab.robots.five_link import study as hz

    s = imported.load(exported, "foot_1", "foot_2")
    H0, c = five_link.hzd_outputs()
    np.testing.assert_array_equal(s.study.H0, H0)
    np.testing.assert_allclose(s.study.c, c, atol=1e-15)
    assert s.study.stance.swap == five_link.LEG_SWAP
    assert s.study.torque_limits is None
    np.testing.assert_allclose(imported.gait_guess(s, 0.8), five_link.gait_guess(0.8), atol=1e-15)
    from bipedlab.gait import study as hzd_study

    prob = hzd_study.problem(s.study, 0.8, "torque")
    np.testing.assert_allclose(imported.initial_guess(s, prob), hz.initial_guess(hz.problem(0.8, "torque")),
                               atol=1e-14)


def test_missing_site_names_file_and_site():
    with pytest.raises(ValueError, match=r"rabbit\.xml: site 'left_toe' \(the stance point\) is not in the file"):
        imported.load(_data("rabbit.xml"), "left_toe", "right_foot")


def test_asymmetric_legs_rejected(tmp_path):
    text = open(_data("rabbit.xml")).read()
    i = text.index('name="right_tibia"')
    text = text[:i] + text[i:].replace('mass="3.2"', 'mass="3.3"', 1)
    p = tmp_path / "lopsided.xml"
    p.write_text(text)
    with pytest.raises(ValueError, match="bodies 'left_tibia' and 'right_tibia' pair up as left and right but "
                                         "differ in mass"):
        imported.load(p, "left_foot", "right_foot")


def test_same_leg_rejected():
    with pytest.raises(ValueError, match="not on two different legs"):
        imported.load(_data("rabbit.xml"), "left_foot", "hip")


def test_underactuation_checked(tmp_path):
    text = open(_data("rabbit.xml")).read()
    text = text.replace('<motor name="right_knee_motor" joint="right_knee" gear="50" ctrlrange="-3 3"/>', "")
    p = tmp_path / "three_motors.xml"
    p.write_text(text)
    with pytest.raises(ValueError, match="3 actuated joints of 4"):
        imported.load(p, "left_foot", "right_foot")


def test_motor_limits_through_gear(tmp_path):
    """Joint torque limit = gear x motor torque limit (ctrlrange x gain), or forcerange x gear."""
    text = open(_data("rabbit.xml")).read()
    text = text.replace('joint="left_hip" gear="50" ctrlrange="-3 3"', 'joint="left_hip" gear="20" ctrlrange="-3 3"')
    text = text.replace('joint="left_knee" gear="50" ctrlrange="-3 3"',
                        'joint="left_knee" gear="50" forcerange="-2 2" forcelimited="true"')
    p = tmp_path / "geared.xml"
    p.write_text(text)
    d = read(p)
    assert d.torque_limits == (60.0, 100.0, 150.0, 150.0)
    assert d.gear == (20.0, 50.0, 50.0, 50.0)
