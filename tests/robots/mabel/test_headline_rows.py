"""The headline comparison on the 13-DoF plant (HZD paper, Sec. V-D) as report rows: PD +
feedforward's stance leg-shape and torso RMS errors over the compliant controller's, and the
fewest steps the eq. 42 controllers walk; from stand-in records of experiment full-plant."""
from __future__ import annotations

import pytest

from bipedlab.report import Failed, Measured, Skip, values
from bipedlab.robots.mabel import reproduce as R
from bipedlab.robots.mabel.walking import experiments as wx

IDS = ("fullplant_exp4_mls_st_rms_ratio", "fullplant_exp4_tor_rms_ratio", "fullplant_hzd_steps")


def _run(mls, tor, steps=100, fell=False):
    return dict(fell=fell, steps_completed=steps, tracking_rms_deg=dict(mLS_st=mls, Tor=tor),
                mLS_st_rms_joint_deg=mls / 31.42)


def _records(io_fell=False, steps=100):
    hzd = {"paper-nominal": dict(pdff=_run(6.8, 0.7), iolin=_run(2.5, 0.09, 1 if io_fell else steps, io_fell),
                                 decentralized=_run(2.4, 0.33, steps)),
           "nominal": dict(pdff=_run(30.0, 0.8), iolin=_run(2.6, 0.06, steps), decentralized=_run(6.3, 0.2, steps))}
    return {"full-plant": dict(steps=steps, hzd_runs=hzd)}


def _rows(records, quick=False):
    out = {}
    R._headline(records.get("full-plant"), quick, out)
    return out


def test_ratios_are_pd_over_the_compliant_controller_with_their_figures():
    out = _rows(_records())
    m = out[IDS[0]]
    assert isinstance(m, Measured) and m.value == pytest.approx(6.8 / 2.5)
    assert m.facts["pdff"] == 6.8 and m.facts["hzd"] == 2.5 and m.facts["hzd_joint"] == pytest.approx(2.5 / 31.42)
    assert out[IDS[1]].value == pytest.approx(0.7 / 0.09)
    assert out[IDS[2]].value == 100 and out[IDS[2]].facts["which"] == "none"


def test_a_fall_fails_the_ratios_and_names_the_run_in_the_steps_row():
    out = _rows(_records(io_fell=True))
    assert isinstance(out[IDS[0]], Failed) and "compliant controller fell" in out[IDS[0]].reason
    assert out[IDS[2]].value == 1 and out[IDS[2]].facts["which"] == "iolin on paper-nominal"


def test_the_quick_run_cannot_judge_78_steps_and_a_missing_experiment_is_skipped():
    assert isinstance(_rows(_records(steps=8), quick=True)[IDS[2]], Skip)
    assert all(isinstance(v, Skip) for v in _rows({}).values())


def test_the_rows_judge_the_order_of_magnitude_and_the_paper_shortest_walk():
    rows = {r["id"]: r for r in values.load(R.DATA / "paper_hzd.json")["rows"]}
    assert values.agrees(10.0, rows[IDS[0]]["tolerance"], rows[IDS[0]]["paper"]) is True
    assert values.agrees(9.9, rows[IDS[0]]["tolerance"], rows[IDS[0]]["paper"]) is False
    assert values.agrees(77, rows[IDS[2]]["tolerance"]) is False and rows[IDS[2]]["survival_only"] is True


def test_the_experiment_keeps_the_joint_side_at_the_leg_shape_gear():
    x = dict(tracking_rms_deg=dict(mLS_st=31.42), tracking_peak_deg=dict(mLS_st=62.84))
    assert wx._joint_side(x) == dict(mLS_st_rms_joint_deg=pytest.approx(1.0), mLS_st_peak_joint_deg=pytest.approx(2.0))
