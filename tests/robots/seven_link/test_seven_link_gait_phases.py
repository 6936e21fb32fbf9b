"""The gait-phase analysis behind the Fig. 8 / Fig. 9 rows (:func:`study.gait_phases`), on
hand-built contact logs whose phases are known: a pre-emptive push-off (the trailing foot on
its toe alone before the leading heel strikes), a rolling double support (trailing toe and
leading heel on the ground together), and a walk whose trailing toe leaves at the strike."""
from __future__ import annotations

import numpy as np
import pytest

from bipedlab.robots.seven_link import study as w

DT, STEP = 0.005, 0.5


def _log(lead=0.1, double=0.05, heel_first=0.05, steps=4):
    """A walk of ``steps`` steps of STEP s: the stance foot flat, its heel lifting ``lead`` s
    before the other foot strikes heel first, its toe leaving ``double`` s after the strike;
    straight knees, both ankles at 1 rad/s under 2 N m (2 W each)."""
    td = np.arange(steps + 1) * STEP
    foot = np.arange(steps + 1) % 2
    t = np.arange(0.0, td[-1] + 0.2, DT)
    act = np.zeros((len(t), 6), bool)
    for k, tk in enumerate(td):
        f = foot[k]
        end = td[k + 1] if k + 1 < len(td) else t[-1] + 1.0
        on = (t >= tk - 1e-9) & (t < end + double - 1e-9)
        heel = on & (t < end - lead - 1e-9)
        toe = on & (t >= tk + heel_first - 1e-9)
        act[:, 2 * f] |= toe
        act[:, 2 * f + 1] |= heel
    x = np.zeros((len(t), 18))
    x[:, 2] = np.pi / 2
    x[:, 3:9] = np.pi / 2  # thighs and shanks along the body: knees straight
    x[:, [5, 8]] = 0.0  # feet flat
    x[:, 9 + 5] = x[:, 9 + 8] = 1.0  # ankle rates phi_3, phi_6 = 1 rad/s
    u = np.zeros((len(t), 6))
    u[:, [2, 5]] = 2.0
    return t, x, u, act, td, foot


def test_preemptive_push_off_and_rolling_double_support():
    g = w.gait_phases(*_log(), transient=0)
    assert len(g["steps"]) == 4
    for s in g["steps"]:
        assert s["heel_strike"] and s["toe_only_before_strike"] and s["rolling_double_support"]
        assert s["heel_off_lead_s"] == pytest.approx(0.1, abs=DT)
        assert s["double_support_s"] == pytest.approx(0.05, abs=DT)
        # 2 W from the heel lift to the toe-off (0.15 s): positive push-off work
        assert s["push_off_ankle_work_j"] == pytest.approx(2.0 * 0.15, abs=2.0 * 2 * DT)
    assert g["heel_on_knee_extended_fraction"] == 1.0 and g["max_heel_on_knee_flexion_deg"] == pytest.approx(0.0)
    assert g["ranges"]["ankle"]["torque_min_nm"] == g["ranges"]["ankle"]["torque_max_nm"] == 2.0


def test_toe_off_at_the_strike_is_no_double_support():
    g = w.gait_phases(*_log(lead=0.1, double=0.0), transient=0)
    for s in g["steps"]:
        assert s["toe_only_before_strike"] and not s["rolling_double_support"]
        assert s["double_support_s"] < DT


def test_heel_lift_after_the_strike_is_not_preemptive():
    # the trailing heel lifts 30 ms after the strike: no pre-emptive push-off, and the
    # trailing foot lies flat at the start of the double support (not rolling throughout)
    g = w.gait_phases(*_log(lead=-0.03, double=0.1), transient=0)
    for s in g["steps"]:
        assert not s["toe_only_before_strike"] and not s["rolling_double_support"]
        assert s["heel_off_lead_s"] == pytest.approx(-0.03, abs=DT)
        assert s["double_support_s"] == pytest.approx(0.1, abs=DT)


def test_too_short_a_walk_has_no_gait_window():
    assert w.gait_phases(*_log(steps=1), transient=6) is None
