"""Exp. 2 on the 13-DoF plant (HZD paper, Sec. V-B): the forces that change the speed by +45 % and
-45 % under PD + feedforward, searched on the plant that stands for the robot, and their
recoveries as report rows (the paper: about 78 N / 71 N, 10 steps back after the forward push and
3 after the backward one)."""
from __future__ import annotations

import numpy as np
import pytest

from bipedlab.report import Failed, Measured, Skip, values
from bipedlab.robots.mabel import reproduce as R
from bipedlab.robots.mabel.walking import experiments as wx

ROWS = R.FULL_PUSH_ROWS


def _search(force, change, back, settle=4, fell=False):
    return dict(force_n=force, speed_change=change, converged=True, fell=fell, steps_completed=30, step=10,
                speed_per_step=[0.8] * 30, steps_to_recover=back, steps_to_recover_5pct=settle)


def _push(plus_back=9, minus_back=2, minus_fell=False):
    return dict(force_for_plus_45pct_n=141.0, force_for_minus_45pct_n=-72.5,
                full_plant=dict(controller="pdff", unpushed_speed_mps=0.87, searches=[
                    _search(160.0, 0.452, plus_back), _search(-90.0, -0.447, minus_back, fell=minus_fell)]))


def test_the_rows_read_the_searches_forces_recoveries_and_their_asymmetry():
    out = R._full_plant_pushes(_push())
    assert out[ROWS[0]].value == 160.0 and out[ROWS[0]].facts["stance"] == 141.0
    assert out[ROWS[1]].value == -90.0 and out[ROWS[1]].facts["change"] == -0.447
    assert out[ROWS[2]].value == 9 and out[ROWS[3]].value == 2 and out[ROWS[2]].facts["settle"] == "4 steps"
    facts = out[ROWS[4]].facts
    assert out[ROWS[4]].value == 7 and (facts["forward"], facts["backward"]) == (9, 2)
    assert facts["gait_recovery"] == "the pushes were not searched on other gaits (--quick)"  # none in this record
    rows = {r["id"]: r for r in values.load(R.DATA / "paper_hzd.json")["rows"]}
    for rid in ROWS:
        assert rows[rid]["gait"] == wx.GAIT
        for key in ("departs_why",):
            text = values.render(rows[rid][key], dict(out[rid].facts, value=out[rid].value), rid)
            assert "{" not in text
    # the claim: the forward recovery takes at least a step more than the backward one
    tol = rows[ROWS[4]]["tolerance"]
    assert values.agrees(1, tol, rows[ROWS[4]]["paper"]) is True and values.agrees(0, tol, rows[ROWS[4]]["paper"]) is False
    assert rows[ROWS[0]]["paper"] == 78 and rows[ROWS[1]]["paper"] == -71
    assert rows[ROWS[2]]["paper"] == 10 and rows[ROWS[3]]["paper"] == 3


def test_a_fall_or_no_recovery_fails_its_rows_and_the_asymmetry_and_the_quick_run_skips():
    out = R._full_plant_pushes(_push(minus_fell=True))
    assert isinstance(out[ROWS[3]], Failed) and "fell" in out[ROWS[3]].reason
    assert isinstance(out[ROWS[4]], Failed)
    out = R._full_plant_pushes(_push(plus_back=None))
    assert isinstance(out[ROWS[2]], Failed) and "not back within 2 %" in out[ROWS[2]].reason
    out = R._full_plant_pushes(dict(force_for_plus_45pct_n=141.0))
    assert all(isinstance(out[k], Skip) for k in ROWS)


@pytest.mark.slow
def test_the_13dof_search_reaches_its_target_on_the_plant_that_stands_for_the_robot():
    """One search on the 13-DoF plant (the backward push, the cheaper one): the force found
    changes the speed by -45 % within the search's tolerance, and the walk at that force
    survives."""
    base = wx._walk(wx.GAIT, "pdff", 14, None, plant="full")
    ref = float(np.mean(base["speed_per_step"][5:]))
    x = wx.search_push("pdff", -0.45, -71.0, ref, 14, plant="full")
    assert x["converged"] and abs(x["speed_change"] + 0.45) <= wx.SEARCH_TOL
    assert not x["fell"]
