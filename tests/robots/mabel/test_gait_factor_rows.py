"""Measured factors of HZD departures in the report's rows: the gait, of Exp. 2's forces and
recovery and of Table I's slope (Secs. V-B, VI-B: each gait's forces, force ratio, recovery and
slope, and whether the paper's slope lies within the gaits' spread, from stand-in records of
experiments push and impact-scaling); the design model, of the spring's share of the negative
work (Sec. III-E: the full design model's shipped gaits beside the paper model's)."""
from __future__ import annotations

import pytest

from bipedlab.report import Measured, values
from bipedlab.robots.mabel import reproduce as R
from bipedlab.robots.mabel.walking import experiments as wx


def _search(force, back):
    return dict(force_n=force, steps_to_recover=back)


def _push(factor=True):
    rec = dict(gait=wx.GAIT, force_for_plus_45pct_n=140.0, force_for_minus_45pct_n=-70.0,
               searches=[_search(140.0, 7), _search(-70.0, None)],
               paper=dict(forward=dict(force_n=78, steps_to_recover=10), backward=dict(force_n=-71, steps_to_recover=3)),
               runs=[dict(controller="pdff", force_n=78.0, steps_to_recover=8, peak_speed_change=0.27, fell=False),
                     dict(controller="pdff", force_n=-71.0, steps_to_recover=7, peak_speed_change=-0.45, fell=False)])
    if factor:
        rec["gait_factor"] = [dict(gait="paper-nominal", step_length_m=0.457, force_for_plus_45pct_n=135.0,
                                   force_for_minus_45pct_n=-81.0, steps_to_recover_plus=11, steps_to_recover_minus=11),
                              dict(gait="nominal", step_length_m=0.656, force_for_plus_45pct_n=206.0,
                                   force_for_minus_45pct_n=-103.0, steps_to_recover_plus=2, steps_to_recover_minus=3)]
    return rec


def _impact(slopes=(-7.09, -4.61)):
    return dict(gait=wx.GAIT, dv_deta=-4.65, dv_deta_paper=-5.96, rows=[],
                gait_factor=[dict(gait=g, dv_deta=v) for g, v in zip(wx.FACTOR_GAITS, slopes)])


def test_push_texts_give_each_gaits_forces_ratio_and_recovery():
    text = R._push_gait_text(_push())
    assert f"{wx.GAIT} +140 / -70 N (2.00)" in text
    assert "paper-nominal (0.457 m steps) +135 / -81 N (1.67)" in text and "nominal (0.656 m steps) +206 / -103 N (2.00)" in text
    assert text.endswith("against the paper's +78 / -71 N (1.10)")
    rec = R._push_recovery_text(_push())
    assert f"7 / never steps on {wx.GAIT}" in rec and "11 / 11 steps on paper-nominal" in rec and "2 / 3 steps on nominal" in rec
    assert rec.endswith("(paper: 10 / 3)")
    assert R._push_gait_text(_push(factor=False)) == "no other gait was searched"


def test_the_slope_text_says_whether_the_papers_slope_lies_within_the_gaits_spread():
    assert R._slope_gait_text(_impact()).endswith("the paper's -5.96 lies within that spread")
    assert R._slope_gait_text(_impact((-4.5, -4.61))).endswith("the paper's -5.96 lies outside that spread")
    assert f"{wx.GAIT} -4.65, paper-nominal -7.09, nominal -4.61" in R._slope_gait_text(_impact())
    assert R._slope_gait_text(dict(_impact(), gait_factor=[])) == "no other gait was walked (--quick)"


@pytest.mark.parametrize("factor", [True, False], ids=["full", "no factor"])
def test_the_rows_render_from_the_records(factor):
    out = R.measure_hzd({"push": _push(factor), "impact-scaling": _impact() if factor else dict(_impact(), gait_factor=[])},
                        quick=False)
    rows = {r["id"]: r for r in values.load(R.DATA / "paper_hzd.json")["rows"]}
    for rid in ("push_force_plus_45pct_n", "push_force_minus_45pct_n", "push_backward_steps", "table1_dv_deta"):
        m = out[rid]
        assert isinstance(m, Measured), rid
        text = values.render(rows[rid]["departs_why"], dict(m.facts, value=m.value), rid)
        assert "{" not in text and "}" not in text, text
        if rid in ("push_force_plus_45pct_n", "push_backward_steps"):
            assert "not found" in text, text
        if factor:
            assert "paper-nominal" in text and "nominal" in text, text
    assert out["table1_dv_deta"].value == -4.65 and out["push_backward_steps"].value == 7


def test_push_on_gait_searches_both_ways_on_that_gait(monkeypatch):
    """push_on_gait's record from its walks (stand-ins): the unpushed speed and step over the
    steps from ``reference_from`` on, and each direction's search on the gait it was given."""
    walked, searched = [], []

    def walk(gait, controller, steps, progress, **kw):
        walked.append((gait, controller, steps, kw))
        return dict(speed_per_step=[0.5] * 5 + [0.8] * 25, step_lengths_m=[0.3] * 5 + [0.46] * 25)

    def search(controller, target, f0, ref, steps, push_step, progress, gait):
        searched.append((controller, target, f0, ref, gait))
        return dict(force_n=2 * f0, speed_change=target, steps_to_recover=4, steps_to_recover_5pct=3, converged=True)

    monkeypatch.setattr(wx, "_walk", walk)
    monkeypatch.setattr(wx, "search_push", search)
    r = wx.push_on_gait("paper-nominal", 30)
    assert walked == [("paper-nominal", "pdff", 30, {})]
    assert searched == [("pdff", 0.45, 78.0, pytest.approx(0.8), "paper-nominal"),
                        ("pdff", -0.45, -71.0, pytest.approx(0.8), "paper-nominal")]
    assert r["unpushed_speed_mps"] == pytest.approx(0.8) and r["step_length_m"] == pytest.approx(0.46)
    assert r["force_for_plus_45pct_n"] == 156.0 and r["force_for_minus_45pct_n"] == -142.0
    assert r["steps_to_recover_plus"] == r["steps_to_recover_minus"] == 4 and r["converged_minus"] is True


def test_the_spring_share_rows_cite_the_full_design_models_gaits():
    """The design model as a factor of the spring's share of the negative work (Sec. III-E):
    the shipped full-design-model gaits' shares, read from their files, beside the paper
    model's in the rows' texts."""
    full = R.full_model_gaits()
    assert set(full) == {"nominal", "efficient"}
    for g, x in full.items():
        assert x["gait"] == R.FULL_MODEL_GAITS[g] and 0.0 < x["negative_work_fraction_spring"] <= 1.0
    des = {"nominal": dict(negative_work_fraction_spring=0.73), "efficient": dict(negative_work_fraction_spring=0.68),
           "full_model": full}
    out = R.measure_hzd({"design": des}, quick=False)
    rows = {r["id"]: r for r in values.load(R.DATA / "paper_hzd.json")["rows"]}
    for g in ("nominal", "efficient"):
        rid = f"{g}_negative_work_fraction_spring"
        m = out[rid]
        assert m.value == des[g]["negative_work_fraction_spring"]
        text = values.render(rows[rid]["departs_why"], dict(m.facts, value=m.value), rid)
        share = f"{full[g]['negative_work_fraction_spring']:.0%}"
        assert f"the same cost's gait {full[g]['gait']} (" in text and text.endswith(f"gives the spring {share}."), text


def test_exp3_against_exp1_cites_the_designed_change():
    """The design gap as the factor of Exp. 3's c_mt against Exp. 1's on the 13-DoF plant: the
    row cites both gaits' designed c_mt and their relative change beside the realised one."""
    def run(cmt, designed, speed):
        return dict(fell=False, cmt=cmt, cmt_designed=designed, cmt_ratio=cmt / designed, speed_mps=speed,
                    tracking_rms_deg=dict(mLS_st=6.8, Tor=0.1))

    runs = {"paper-nominal": run(0.142, 0.0617, 0.873), R.EXP3_GAIT: run(0.090, 0.0410, 0.916)}
    out = R.measure_hzd({"full-plant": dict(runs=runs)}, quick=False)
    rid = "fullplant_exp3_vs_exp1_cmt_change"
    m = out[rid]
    assert m.value == pytest.approx(0.090 / 0.142 - 1) and m.facts["designed_change"] == pytest.approx(0.0410 / 0.0617 - 1)
    rows = {r["id"]: r for r in values.load(R.DATA / "paper_hzd.json")["rows"]}
    text = values.render(rows[rid]["departs_why"], dict(m.facts, value=m.value), rid)
    assert "differ by -34% (0.0410 against 0.0617)" in text and "walk 0.916 and 0.873 m/s" in text, text


def test_the_13_dof_asymmetry_row_cites_each_gaits_recovery():
    def search(force, back):
        return dict(force_n=force, speed_change=0.45 if force > 0 else -0.45, converged=True, fell=False,
                    steps_to_recover=back, steps_to_recover_5pct=back - 1, speed_per_step=[0.8] * 30, step=10)

    push = dict(_push(), full_plant=dict(searches=[search(166.0, 7), search(-90.0, 7)]))
    out = R._full_plant_pushes(push)
    rid = R.FULL_PUSH_ROWS[4]
    m = out[rid]
    assert m.value == 0
    rows = {r["id"]: r for r in values.load(R.DATA / "paper_hzd.json")["rows"]}
    text = values.render(rows[rid]["departs_why"], dict(m.facts, value=m.value), rid)
    assert "11 / 11 steps on paper-nominal" in text and "2 / 3 steps on nominal" in text, text
