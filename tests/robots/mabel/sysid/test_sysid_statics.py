"""Sections VI and VII-A: spring stiffness and preload from the static experiments (eq. 24 on
the CAD model), and the COM check with the torso shift that zeroes it."""
from __future__ import annotations

import numpy as np
import pytest

import bipedlab  # noqa: F401
from bipedlab.robots.mabel import sysid
from bipedlab.robots.mabel.sysid import params as P


@pytest.fixture(scope="module")
def cad():
    return P.model(P.published())


def test_spring_stiffness_and_preload_exact_from_noise_free_statics(cad):
    truth = sysid.perturbed(6)
    for j, side in enumerate(("L", "R")):
        e = sysid.spring_experiment(truth, side, sysid.sensors.exact())
        f = sysid.fit_spring(cad, e)
        assert f.stiffness == pytest.approx(truth.spring_k[j], rel=1e-10)
        assert f.preload == pytest.approx(truth.spring_preload[j], abs=1e-8)
        # eqs. 21-24 treat the leg as a massless strut: the thigh's and shin's weight, 16 N of
        # the scale's 610 N, makes the line through the paper's torques about 3 % too steep
        assert 1.015 < f.eq24_stiffness / truth.spring_k[j] < 1.05


def test_spring_stiffness_within_two_percent_with_realistic_sensors(cad):
    truth = sysid.perturbed(6)
    for j, side in enumerate(("L", "R")):
        f = sysid.fit_spring(cad, sysid.spring_experiment(truth, side, sysid.Sensors(noise=2.0)))
        assert abs(f.stiffness / truth.spring_k[j] - 1) < 0.02


def test_com_check_and_planted_torso_shift(cad):
    """A robot that is its CAD model balances with its COM exactly over the toe / hip; one whose
    torso COM sits elsewhere shows it in the distances, and the least-squares shift recovers it."""
    exact = sysid.sensors.exact()
    same = sysid.balance_experiments(P.published(), exact, sysid.quick_design())
    assert sysid.com_check(cad, same).max_abs_mm < 1e-9
    planted = np.array([2.0e-3, -1.5e-3])
    moved = sysid.balance_experiments(P.published().replace(torso_com_offset=planted), exact, sysid.quick_design())
    check = sysid.com_check(cad, moved)
    assert 0.5 < check.max_abs_mm < 6.0
    np.testing.assert_allclose(sysid.estimate_torso_com(cad, moved), planted, atol=1e-9)
