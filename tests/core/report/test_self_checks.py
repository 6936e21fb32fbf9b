"""Self-check rows: the method against its own target (or a number it was fitted to) is shown
as a self-check, met or not, and never counted as agreement with the paper; the counts, the
page and the command's summary say so."""
from __future__ import annotations

import json

import pytest

from bipedlab.report import Paper, Skip, build, cli, html, values
from bipedlab.report.runner import Result

SELF = "the method against its own accuracy target on a synthetic robot"


def _rows():
    own = dict(kind="at_most", value=0.02, derivation="own_target", why="the study's own target")
    return [
        dict(id="kt", quantity="K_T error", paper="identified from logs", source="Table IV", self_check=SELF,
             tolerance=own, departs_why="misses its target ({value:.1%})"),
        dict(id="ground", quantity="ground error", paper="roughly estimated", source="Table VI", self_check=SELF,
             tolerance=dict(own, value=0.1), departs_why="the hop does not determine it ({value:.0%})"),
        dict(id="fit", quantity="eigenvalue at the chosen gains", paper=0.6921, source="Sec. IV-A",
             self_check="a fit: the gains are chosen for their closeness to the paper's value",
             tolerance=dict(kind="abs", value=0.05, derivation="own_target", why="half a grid step"),
             departs_why="no grid point comes near"),
        dict(id="speed", quantity="speed", paper=0.9, unit="m/s", source="Sec. V-D",
             tolerance=dict(kind="abs", value=0.05, derivation="precision", why="printed to a tenth"),
             departs_why="walks at {value:.3f} m/s"),
        dict(id="travel", quantity="torso travel", paper="less than 2 deg", source="Sec. III-E",
             tolerance=dict(kind="at_most", value=2.0, derivation="claim", why="the claim, tested as at most 2"),
             departs_why="travels more"),
        dict(id="hops", quantity="hops", paper=92, source="Sec. VIII-D",
             tolerance=dict(kind="at_least", value=92, derivation="claim", why="no fall"), departs_why="falls"),
    ]


MEASURED = dict(kt=0.002, ground=0.44, fit=0.663, speed=0.837, travel=1.1, hops=Skip("not run in --quick"))


@pytest.fixture
def report(tmp_path):
    path = tmp_path / "toy.json"
    path.write_text(json.dumps(dict(paper="toy", title="Toy", citation="c", rows=_rows())))
    paper = Paper("toy", "Toy", str(path), (), lambda r, q: dict(MEASURED))
    rep = build.build([paper], {"toy": [Result("toy", "run", "toy", {}, dict(x=1))]}, quick=True,
                      out_dir=tmp_path / "out", wall_s=0.0, cpu_s=0.0)
    return rep, tmp_path / "out"


def test_self_checks_are_counted_apart_and_never_as_agreement(report):
    rep, _ = report
    p = rep["papers"]["toy"]
    rows = {r["id"]: r for r in p["rows"]}
    assert p["counts"] == dict(rows=6, matches=0, agrees=0, departs=1, departs_within_uncertainty=0, departs_implementation=0, claims_hold=1, claims_hold_survival_only=0, claims_fail=0, self_checks=3,
                               self_checks_not_met=1, not_identifiable=0, not_judged=1)
    for i in ("kt", "ground", "fit"):
        assert rows[i]["agrees"] is None and rows[i]["self_check"]
    assert rows["kt"]["met"] is True and rows["kt"]["verdict"] == "self-check met"
    assert rows["fit"]["met"] is True and rows["fit"]["verdict"] == "self-check met"
    assert rows["ground"]["met"] is False and rows["ground"]["verdict"] == "self-check not met"
    assert rows["ground"]["why"] == "self-check not met: the hop does not determine it (44%)"
    assert rows["kt"]["why"].startswith("self-check met at most 0.02")
    assert rows["speed"]["verdict"] == "departs" and rows["speed"]["why"] == "walks at 0.837 m/s"
    assert rows["travel"]["verdict"] == "claim holds" and rows["hops"]["verdict"] == "not judged"  # a claim, apart


def test_the_page_and_the_summary_show_self_checks_as_such(report):
    rep, out = report
    page = (out / "index.html").read_text()
    assert page.count('<tr class="selfcheck"') == 3
    assert page.count('<tr class="claimholds"') == 1 and page.count('<tr class="departs"') == 1
    assert page.count('<tr class="agrees"') == 0 and page.count('<tr class="matches"') == 0
    assert "self-check not met" in page and "self-check: a fit" in page
    assert ("6 rows: 0 match the paper&#x27;s printed precision, 0 agree within a band, 1 depart; claims: 1 hold, "
            "0 fail; 3 self-checks (1 not met); 1 not judged.") in page
    assert html.counts_text(dict(rows=2, matches=1, agrees=0, departs=1, not_judged=0)) == (
        "2 rows: 1 match the paper's printed precision, 0 agree within a band, 1 depart; claims: 0 hold, 0 fail; "
        "0 self-checks (0 not met); 0 not judged.")
    rep.update(index_html="i.html", report_json="r.json")
    assert "3 self-checks" in cli.summary(rep)


@pytest.mark.parametrize("self_check, derivation, words", [
    ("", "own_target", "'self_check' must say"),
    (None, "own_target", "belongs to a self-check row"),
])
def test_self_check_rows_are_declared_consistently(self_check, derivation, words):
    row = dict(id="x", quantity="q", paper="identified", source="s",
               tolerance=dict(kind="at_most", value=0.02, derivation=derivation, why="w"))
    if self_check is not None:
        row["self_check"] = self_check
    with pytest.raises(values.ValuesError, match=words):
        values.check(dict(paper="p", title="t", citation="c", rows=[row]))


def test_a_failed_experiment_departs_with_its_reason_and_a_shown_row_stays_unjudged(tmp_path):
    """A row whose experiment failed at what the paper reports working (a fall) departs with
    the reason, also for a claim its value would otherwise meet; a shown-only row says the
    reason and stays unjudged; a Skip stays unjudged."""
    from bipedlab.report import Failed

    rows = [dict(id="speed", quantity="speed", paper=0.5, unit="m/s", source="Sec. VI",
                 tolerance=dict(kind="rel", value=0.1, derivation="precision", why="one digit"),
                 departs_why="walks at {value:.2f} m/s"),
            dict(id="shown", quantity="bipedlab's gains: speed", paper=0.5, source="Sec. VI",
                 tolerance=dict(kind="report", why="shown: {value}")),
            dict(id="later", quantity="hops", paper=92, source="Sec. VIII",
                 tolerance=dict(kind="at_least", value=92, derivation="claim", why="no fall"))]
    path = tmp_path / "toy.json"
    path.write_text(json.dumps(dict(paper="toy", title="Toy", citation="c", rows=rows)))
    measured = dict(speed=Failed("fell after 2 touchdowns"), shown=Failed("fell after 3 touchdowns"),
                    later=Skip("not run in --quick"))
    paper = Paper("toy", "Toy", str(path), (), lambda r, q: dict(measured))
    rep = build.build([paper], {"toy": [Result("toy", "run", "toy", {}, dict(x=1))]}, quick=True,
                      out_dir=tmp_path / "out", wall_s=0.0, cpu_s=0.0)
    got = {r["id"]: r for r in rep["papers"]["toy"]["rows"]}
    assert got["speed"]["verdict"] == "departs" and got["speed"]["why"] == "fell after 2 touchdowns"
    assert got["speed"]["bipedlab"] is None and got["speed"]["agrees"] is False
    assert got["shown"]["verdict"] == "not judged" and got["shown"]["why"] == "fell after 3 touchdowns"
    assert got["later"]["verdict"] == "not judged"
    assert rep["papers"]["toy"]["counts"]["departs"] == 1


def test_a_parameter_the_data_cannot_determine_is_not_identifiable(tmp_path):
    """A self-check row whose parameter the run's data do not determine (NotIdentifiable, with
    its 1-sigma error) is neither met nor departed: its own class, counted apart, shown with
    the reason, and named in the counts line."""
    from bipedlab.report import NotIdentifiable

    path = tmp_path / "toy.json"
    path.write_text(json.dumps(dict(paper="toy", title="Toy", citation="c", rows=_rows())))
    measured = dict(MEASURED, ground=NotIdentifiable("the hop does not determine it (1-sigma 253%)"))
    paper = Paper("toy", "Toy", str(path), (), lambda r, q: dict(measured))
    rep = build.build([paper], {"toy": [Result("toy", "run", "toy", {}, dict(x=1))]}, quick=True,
                      out_dir=tmp_path / "out", wall_s=0.0, cpu_s=0.0)
    p = rep["papers"]["toy"]
    row = {r["id"]: r for r in p["rows"]}["ground"]
    assert row["verdict"] == "not identifiable" and row["met"] is None and row["agrees"] is None
    assert row["why"] == "the hop does not determine it (1-sigma 253%)" and row["bipedlab"] is None
    assert p["counts"] == dict(rows=6, matches=0, agrees=0, departs=1, departs_within_uncertainty=0, departs_implementation=0, claims_hold=1, claims_hold_survival_only=0, claims_fail=0, self_checks=2,
                               self_checks_not_met=0, not_identifiable=1, not_judged=1)
    assert set(p["counts"]) == set(values.COUNT_KEYS)
    page = (tmp_path / "out" / "index.html").read_text()
    assert page.count('<tr class="notidentifiable"') == 1
    assert "2 self-checks (0 not met); 1 not identifiable from the data; 1 not judged." in page


def test_a_survival_only_claim_says_so_and_is_counted_apart(tmp_path):
    """A claim whose test is only that the robot did not fall (``survival_only``) keeps its
    verdict class, is marked in its row and on the page, and the counts line says how many
    holding claims rest on survival alone; the flag belongs to claim rows only."""
    rows = _rows()
    rows[5] = dict(rows[5], survival_only=True)  # hops: 'no fall'
    rows[4] = dict(rows[4], survival_only=True)  # torso travel: a bound, flagged here to be counted
    path = tmp_path / "toy.json"
    path.write_text(json.dumps(dict(paper="toy", title="Toy", citation="c", rows=rows)))
    paper = Paper("toy", "Toy", str(path), (), lambda r, q: dict(MEASURED, hops=95))
    rep = build.build([paper], {"toy": [Result("toy", "run", "toy", {}, dict(x=1))]}, quick=True,
                      out_dir=tmp_path / "out", wall_s=0.0, cpu_s=0.0)
    p = rep["papers"]["toy"]
    got = {r["id"]: r for r in p["rows"]}
    assert got["hops"]["verdict"] == "claim holds" and got["hops"]["survival_only"] is True
    assert got["speed"]["survival_only"] is False
    assert p["counts"]["claims_hold"] == 2 and p["counts"]["claims_hold_survival_only"] == 2
    assert set(p["counts"]) == set(values.COUNT_KEYS)
    page = (tmp_path / "out" / "index.html").read_text()
    assert page.count("survival only</span>") == 2
    assert "claims: 2 hold (2 of them on survival alone), 0 fail;" in page
    bad = dict(rows[0], survival_only=True)  # a self-check, not a claim
    with pytest.raises(values.ValuesError, match="survival_only"):
        values.check(dict(paper="p", title="t", citation="c", rows=[bad]))
    with pytest.raises(values.ValuesError, match="survival_only"):
        values.check(dict(paper="p", title="t", citation="c", rows=[dict(rows[5], survival_only="yes")]))
