"""Table I (Section VI-B, impact scaling) and Exp. 4 (Section V-D) as the paper ran them.

- dv/deta: the steady speed's sensitivity to the impact scaling eta, the slope of the
  least-squares line through (eta, speed), for the paper's Table I and for the model.
- Exp. 4: the experiments' gait (paper-575, the paper's nominal step) under the compliant-HZD controller (I/O linearisation with the
  corrections) on 14-bit encoders at 1 kHz, with the experiment's torque saturation of 6 N m
  (leg-angle motors) and 10 N m (leg-shape motors).
"""
from __future__ import annotations

import numpy as np
import pytest

from bipedlab.robots.mabel.walking import experiments as wx
from bipedlab.robots.mabel.walking import study as wm

TABLE1_ETA = (1.0, 0.99, 0.98, 0.97, 0.966, 0.96)
TABLE1_SPEED = (0.80, 0.86, 0.92, 0.98, 1.00, 1.04)


# ----------------------------------------------------------------------------- Table I


def test_table1_speed_sensitivity_by_hand():
    """The paper's Table I (eta 1.0 ... 0.96 -> 0.80 ... 1.04 m/s) as data, and its dv/deta by
    hand: mean eta = 5.866 / 6, mean speed = 5.60 / 6; the slope sum((e - e_bar)(v - v_bar)) /
    sum((e - e_bar)^2) = -0.0069333... / 0.0011633... = -5.9599 m/s per unit eta (about -6: a
    1 % smaller eta walks 0.06 m/s faster). The function and the experiment's paper value equal
    it to rounding (1e-12 relative: the same sums in floating point); a fit through three of the
    rows (the --quick etas) differs by under 2 %, Table I being nearly a straight line."""
    assert {float(k): v for k, v in wm.PAPER["impact_scaling"].items()} == dict(zip(TABLE1_ETA, TABLE1_SPEED))
    e, v = np.asarray(TABLE1_ETA), np.asarray(TABLE1_SPEED)
    eb, vb = 5.866 / 6, 5.60 / 6
    sxy = sum((a - eb) * (b - vb) for a, b in zip(TABLE1_ETA, TABLE1_SPEED))
    sxx = sum((a - eb) ** 2 for a in TABLE1_ETA)
    assert sxy == pytest.approx(-0.0069333333, rel=1e-6) and sxx == pytest.approx(0.0011633333, rel=1e-6)
    hand = sxy / sxx
    assert hand == pytest.approx(-5.95989, abs=1e-5)
    assert wx.speed_sensitivity(e, v) == pytest.approx(hand, rel=1e-12)
    assert wx.paper_speed_sensitivity() == pytest.approx(hand, rel=1e-12)
    assert wx.speed_sensitivity(e, v) == pytest.approx(np.polyfit(e, v, 1)[0], rel=1e-10)
    three = wx.speed_sensitivity([1.0, 0.98, 0.966], [0.80, 0.92, 1.00])
    assert three == pytest.approx(hand, rel=0.02)


def test_speed_sensitivity_leaves_out_fallen_runs():
    """A fallen eta (speed None) drops out of the line: the slope through the others is the
    line through them (two points: their secant, (1.04 - 0.80) / (0.96 - 1.0) = -6 m/s per
    unit eta); with one point left, or one eta only, there is no slope."""
    assert wx.speed_sensitivity([1.0, 0.98, 0.96], [0.80, None, 1.04]) == pytest.approx(-6.0, rel=1e-12)
    assert wx.speed_sensitivity([1.0, 0.98], [0.80, None]) is None
    assert wx.speed_sensitivity([0.98, 0.98], [0.9, 0.92]) is None


@pytest.mark.slow
def test_impact_scaling_reports_the_model_and_paper_sensitivity():
    """The reduced Table I (eta 1.0, 0.98, 0.966; 12 steps, the speed of the last 5, the
    compliant-HZD controller with exact sensing): the record's ``dv_deta`` is the line through
    its own rows and ``dv_deta_paper`` the paper's -5.96. The model's speed rises as eta falls
    (dv/deta < 0, the paper's direction); its magnitude is the model's own (the experiments' gait
    paper-575 is the paper's design model at the paper's step, not the paper's gait itself; measured
    -4.30 here, 0.72 of the paper's), and is asserted only to lie within a factor of four of the
    paper's, the same order of effect."""
    r = wx.run("impact-scaling", steps=12, etas=[1.0, 0.98, 0.966], average=5, pdff_column=False,
               gait_factor=["paper-nominal"])
    assert r["gait"] == wx.GAIT
    # the gait as a factor: the same column on the paper model's torque optimum, its own line
    (f,) = r["gait_factor"]
    assert f["gait"] == "paper-nominal" and all(s is not None for s in f["steady_speed_mps"])
    assert f["dv_deta"] == pytest.approx(wx.speed_sensitivity([1.0, 0.98, 0.966], f["steady_speed_mps"]), rel=1e-12)
    assert f["dv_deta"] != pytest.approx(r["dv_deta"], rel=0.05)  # another gait, another slope (-7.1 vs -4.7 at 40 steps)
    speeds = [x["steady_speed_mps"] for x in r["rows"]]
    assert all(s is not None for s in speeds)
    assert r["dv_deta"] == pytest.approx(wx.speed_sensitivity([1.0, 0.98, 0.966], speeds), rel=1e-12)
    assert r["dv_deta_paper"] == pytest.approx(-5.95989, abs=1e-5)
    assert r["dv_deta"] < 0.0
    assert 0.25 < r["dv_deta"] / r["dv_deta_paper"] < 4.0


# ----------------------------------------------------------------------------- Exp. 4


def test_exp4_saturates_at_the_papers_limits_and_never_exceeds_them():
    """Exp. 4 (4 steps, the experiments' gait paper-575 under the compliant-HZD controller on
    14-bit encoders at 1 kHz) with the paper's saturation, 6 N m on the leg-angle motors and
    10 N m on the leg-shape motors: a motor spends samples at its limit (the paper's Fig. 13b:
    'significant saturation'; here the stance leg-angle motor, which holds the torso through
    eq. 42's loop at the shipped eps, 7.2 % of the samples, the swing one 3.7 %; every motor below
    a tenth), no torque ever exceeds its limit (clipped in the controller: exact up to rounding,
    1e-9 N m), and the same run at the drivetrain's 30 / 55 N m asks both leg-angle motors for
    more than 6 N m (so the limits bind: measured 10.8 and 13.3 N m). Both walk without a fall,
    near the designed 0.8 m/s (0.801 m/s over these first steps from the fixed point; the robot's
    Exp. 4 walked 0.9, which the report's exp4_speed_mps row compares); c_mt 0.237, above the
    robot's 0.18 by more than the 25 % band of the report's exp4_cmt row, which departs."""
    r = wx.run("exp4", steps=4)
    assert r["gait"] == wx.GAIT
    assert r["torque_limits_nm"] == list(wx.EXP4_LIMITS) == [6.0, 10.0, 6.0, 10.0]
    assert r["fell"] is False and r["steps_completed"] == 4
    assert r["saturation_fraction"]["mLA_st"] > 0.0
    assert all(0.0 <= f < 0.1 for f in r["saturation_fraction"].values())
    assert all(t <= lim + 1e-9 for t, lim in zip(r["peak_torques_nm"], wx.EXP4_LIMITS))
    free = r["without_limits"]
    assert free["fell"] is False and free["torque_limits_nm"] == list(wx.DRIVE_LIMITS)
    assert free["peak_torques_nm"][0] > 6.0 and free["peak_torques_nm"][2] > 6.0
    assert all(f == 0.0 for f in free["saturation_fraction"].values())
    assert r["speed_mps"] == pytest.approx(wm.load_gait(wx.GAIT)[2]["design"]["speed"], rel=0.05)
    # the stiffer loop's c_mt lies above the robot's 0.18 (0.237): the report's exp4_cmt row shows the departure
    assert r["cmt"] > wx.EXP4_PAPER["cmt"] * 1.25


@pytest.mark.slow
def test_exp4_thirty_steps_speed_cmt_and_tracking():
    """Exp. 4 over 30 steps (the experiment's default) on paper-575: the simulated robot walks at
    0.804 m/s, within 5 % of the designed 0.8 m/s (the robot's Exp. 4 walked 0.9; the report's
    exp4_speed_mps row departs). At the shipped eps (controllers.EPS) c_mt is 0.237, above the
    0.18 realised on the robot by more than a quarter (the report's exp4_cmt row departs).
    Tracking: the torso's rms error is far below the robot's 0.89 deg (asserted below 0.5 deg;
    measured 0.045) while the stance motor leg shape's is above the robot's 0.28 deg (measured
    0.81 deg, 0.74 deg without the limits). The limits change the speed by under 2 % (measured
    0.804 against 0.805 m/s)."""
    r = wx.run("exp4", steps=30)
    assert r["fell"] is False and r["steps_completed"] == 30
    assert r["speed_mps"] == pytest.approx(wm.load_gait(wx.GAIT)[2]["design"]["speed"], rel=0.05)
    assert r["cmt"] > 0.18 * 1.25
    assert r["tracking_rms_deg"]["Tor"] < 0.5
    assert r["tracking_rms_deg"]["mLS_st"] > 0.28
    assert r["speed_mps"] == pytest.approx(r["without_limits"]["speed_mps"], rel=0.02)
