"""The HZD section names its gaits: every row and every experiment says which shipped gait it
walked or designed, and the gait table sets each gait's designed figures beside the paper's gait
it stands for (HZD paper, Sec. III-E, Fig. 5)."""
from __future__ import annotations

import json

import pytest

from bipedlab.report import build, html, registry, values
from bipedlab.robots.mabel import reproduce as R
from bipedlab.robots.mabel.walking import experiments as wx
from bipedlab.robots.mabel.walking import study as wm


@pytest.fixture(scope="module")
def paper():
    return registry.papers()["hzd"]


@pytest.fixture(scope="module")
def table(paper):
    return {g["name"]: g for g in build.gait_table(paper, {}, quick=False)}


def test_the_experiments_gaits_are_the_walking_experiments_own():
    g = R._GAITS
    assert g["efficient"] == (wx.EXP3_GAIT,)
    for name in ("nominal", "tracking", "exp4"):
        assert g[name] == (wx.GAIT,), name
    for name in ("push", "impact-scaling"):  # the gait as a factor of their departures
        assert g[name] == (wx.GAIT,) + wx.FACTOR_GAITS, name
    assert g["fast"] == (wx.GAIT, "fast")
    assert g["pd-gains"] == tuple(wx.PD_GAITS)
    # the design tier re-designs the paper-model gaits; the plant tier walks the experiments' own
    assert g["sensitivity"] == tuple(wx.PD_GAITS) + (wx.GAIT, wx.EXP3_GAIT)
    assert set(g["full-plant"]) == set(wx.GAP_GAITS) | set(wx.HEADLINE_GAITS)
    assert set(g) == {e.name for e in R.HZD_EXPERIMENTS}
    assert all(name in wm.GAITS for gs in g.values() for name in gs)


def test_every_row_names_a_gait_some_experiment_walks(paper, table):
    rows = values.load(paper.values)["rows"]
    for r in rows:
        names = [n.split(" (")[0].strip() for n in r["gait"].split(",")]
        assert names and all(n in table for n in names), (r["id"], r["gait"])
    byid = {r["id"]: r["gait"] for r in rows}
    # the design rows are the paper-model designs; Exp. 1 walks the paper model's gait at the paper's step
    assert byid["nominal_step_length_m"] == "paper-nominal" and byid["exp1_speed_mps"] == wx.GAIT == "paper-575"
    assert byid["exp3_cmt"] == wx.EXP3_GAIT


def test_the_gait_table_is_each_gait_files_design_beside_the_papers_gait(table):
    for name, g in table.items():
        _, _, rec = wm.load_gait(name)
        d = rec["design"]
        assert (g["speed_mps"], g["step_length_m"], g["cmt"]) == (d["speed"], d["step_length"], d["cmt"])
        # a periodic step: the designed speed is the step over its period
        assert g["step_length_m"] / g["period_s"] == pytest.approx(g["speed_mps"], rel=1e-6)
        assert g["walked_by"], name
    nom = table["nominal"]["paper"]
    assert (nom["speed_mps"], nom["step_length_m"], nom["cmt"]) == (0.8, 0.575, 0.0452)  # Sec. III-E, Fig. 5
    assert table["paper-efficient"]["paper"]["cmt"] == 0.0385 and table["paper-efficient"]["paper"]["step_length_m"] is None
    assert table["fast"]["paper"] is None  # Exp. 5 leans the nominal gait; the paper designs no fast gait
    assert table["paper-nominal"]["design_model"] == "paper" and table["nominal"]["design_model"] == "full"
    assert "tracking" in table["paper-575"]["walked_by"] and "efficient" in table["paper-efficient-clear"]["walked_by"]
    # Exp. 3's gait is the paper model's c_mt gait with a mid-step clearance: the same design
    # problem, its toe kept higher, its designed c_mt a little above the unconstrained optimum's
    clear, free = table["paper-efficient-clear"], table["paper-efficient"]
    assert clear["paper"] == free["paper"] and clear["design_model"] == free["design_model"] == "paper"
    assert free["cmt"] < clear["cmt"] < 1.1 * free["cmt"]


def test_the_page_shows_the_gait_table_and_each_rows_gait(paper, table):
    rows, _ = build.rows_for(paper, {e.name: None for e in paper.experiments}, quick=False)
    exps = [dict(name=e.name, command=e.command, gaits=list(e.gaits), skipped="not run", reduction=None,
                 compile_s=0.0, wall_s=0.0, cached=False) for e in paper.experiments]
    counts = build.counts(rows)
    report = dict(version="0", commit=None, jax="0", python="3", device=dict(description="cpu"), dtype="float64",
                  quick=False, wall_s=0.0, cpu_s=0.0, created="now",
                  papers={"hzd": dict(title="t", citation="c", rows=rows, counts=counts, experiments=exps, figures=[],
                                      animations=[], notes=[], gaits=list(table.values()))})
    page = html.page(json.loads(json.dumps(report)))
    assert "<h3>Gaits</h3>" in page and 'id="gait-paper-nominal"' in page
    assert "gait: paper-nominal</span>" in page and "0.575" in page
    assert page.count('<tr id="gait-') == len(table)


def test_the_gait_table_shows_each_gaits_torso_travel_against_appendix_b(table, paper):
    """Appendix B bounds the torso's travel over a step by 5 deg; the table gives each gait's
    travel on its own design model's orbit (the Bézier range, computed here from the torso
    constraint's coefficients alone on a dense grid, within 0.01 deg) and the page marks the
    gaits over the bound: the paper-model gaits are within it (1.1 and 0.9 deg), the full-model
    nominal and efficient gaits are not (8.4 and 7.3 deg)."""
    import numpy as np

    from bipedlab.control import bezier as bz

    s = np.linspace(0.0, 1.0, 20001)
    for name, g in table.items():
        vc, _, _ = wm.load_gait(name)
        travel = np.degrees(np.ptp(np.asarray(bz.bezier(np.asarray(vc.tor), s))))
        assert g["torso_travel_deg"] == pytest.approx(travel, abs=0.01), name
        assert g["torso_travel_bound_deg"] == pytest.approx(5.0)
    over = {n for n, g in table.items() if g["torso_travel_deg"] > 5.0}
    assert over == {"nominal", "efficient"}
    page = html._gaits([dict(g, walked_by=["x"]) for g in table.values()])
    assert "<th>torso travel (deg)</th>" in page
    assert page.count("over the design&#x27;s bound of 5") == 2 or page.count("over the design's bound of 5") == 2
