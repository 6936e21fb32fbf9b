"""Verdicts that follow from the numbers. Each shipped values file is judged on made-up values
(the paper's number, just inside and just outside its band, the wrong sign, the claim's bound
either side) through the report's own build, with a synthetic records dict that holds every
number the rows' texts cite; each row's verdict, ``met`` and ``agrees`` are checked against
arithmetic done here, and the counts against the verdicts."""
from __future__ import annotations

import json
import math
import pytest

from bipedlab.report import Measured, Paper, build, registry, values
from bipedlab.report.runner import Result

KEYS = tuple(registry.papers())


def _num(x):
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def expected(v, tol, paper, sign):
    """True / False / None, worked out here from the row's numbers."""
    kind, t = tol["kind"], tol.get("value")
    if v is None or kind == "report":
        return None
    if kind == "equals":
        return v == t
    if not _num(v):
        return None
    if sign == "+" and not v > 0 or sign == "-" and not v < 0:
        return False
    if kind == "at_least":
        return v >= t
    if kind == "at_most":
        return v <= t
    if kind == "range":
        return t[0] <= v <= t[1]
    if not _num(paper):
        return None
    if kind == "factor":
        return v * paper > 0 and 1 / t <= v / paper <= t
    w = t * abs(paper) if kind == "rel" else t
    return abs(v - paper) <= w * (1 + 1e-9)


def candidates(row) -> list:
    """Values that probe the row's tolerance: inside, at the edge, outside, the wrong sign."""
    tol, p = row["tolerance"], row["paper"]
    kind, t = tol["kind"], tol.get("value")
    if kind == "equals":
        return [t, not t] if isinstance(t, bool) else [t, t - 1 if _num(t) else "no"]
    if kind == "report":
        return [1.0]
    if kind in ("at_least", "at_most"):
        return [t * 1.001 + 0.001, t * 0.999 - 0.001, t]
    if kind == "range":
        lo, hi = t
        return [0.5 * (lo + hi), lo - 0.01 * abs(lo) - 1e-6, hi + 0.01 * abs(hi) + 1e-6]
    if kind == "factor":
        return [p, p * t * 0.999, p * t * 1.01, p / t * 0.99, -p]
    w = t * abs(p) if kind == "rel" else t
    return [p, p + 0.999 * w, p - 0.999 * w, p + 1.01 * w + 1e-9, p - 1.01 * w - 1e-9, -p]


def _synthetic(rows):
    """(records, facts) holding a number for every name the rows' texts cite."""
    records, facts = {}, {}
    for r in rows:
        for text in (r["tolerance"]["why"], r.get("departs_why") or ""):
            for name in values.fields(text):
                if name in ("value", "paper"):
                    continue
                if "." not in name:
                    facts[name] = 1.0
                    continue
                head, *rest = name.split(".")
                d = records.setdefault(head, {})
                for part in rest[:-1]:
                    d = d.setdefault(part, {})
                d[rest[-1]] = 1.0
    return records, facts


@pytest.mark.parametrize("key", KEYS)
def test_every_verdict_of_a_built_report_follows_from_its_numbers(key, tmp_path):
    real = registry.papers()[key]
    rows = values.load(real.values)["rows"]
    records, facts = _synthetic(rows)
    n = max(len(candidates(r)) for r in rows)
    for k in range(n):
        chosen = {r["id"]: candidates(r)[k % len(candidates(r))] for r in rows}
        paper = Paper(key, real.title, real.values, (),
                      lambda recs, quick, chosen=chosen: {i: Measured(v, facts) for i, v in chosen.items()})
        results = {key: [Result(key, name, "synthetic", {}, rec) for name, rec in records.items()]}
        report = build.build([paper], results, quick=True, out_dir=tmp_path / f"r{k}", wall_s=0.0, cpu_s=0.0)
        out = json.loads((tmp_path / f"r{k}" / "report.json").read_text())["papers"][key]
        assert out["counts"] == report["papers"][key]["counts"]
        tally = dict(matches=0, agrees=0, departs=0, claims_hold=0, claims_fail=0, self_checks=0,
                     self_checks_not_met=0, not_identifiable=0, not_judged=0, claims_hold_survival_only=0,
                     departs_within_uncertainty=0, departs_implementation=0)  # no row here has a sensitivity
        for src, got in zip(rows, out["rows"]):
            assert got["id"] == src["id"]
            v = chosen[src["id"]]
            want = expected(v, src["tolerance"], src["paper"], src.get("sign"))
            assert got["met"] == want, (src["id"], v, src["tolerance"], got["met"])
            assert got["met"] == values.agrees(got["bipedlab"], got["tolerance_spec"], got["paper"],
                                               got["tolerance_spec"]["sign"])
            sc = bool(src.get("self_check"))
            assert got["agrees"] == (None if sc else want), src["id"]
            # the class follows from the outcome and what the tolerance is derived from: the printed
            # precision -> matches, a spread or a size -> agrees, a stated claim -> holds / fails
            derivation = src["tolerance"].get("derivation")
            word = ("not judged" if want is None else
                    ("self-check met" if want else "self-check not met") if sc else
                    ("claim holds" if want else "claim fails") if derivation == "claim" else
                    "departs" if not want else "matches" if derivation == "precision" else "agrees")
            assert got["verdict"] == word, (src["id"], v)
            if want is False and not sc:
                assert got["why"] and "{" not in got["why"]
            tally[{"matches": "matches", "agrees": "agrees", "departs": "departs", "claim holds": "claims_hold",
                   "claim fails": "claims_fail", "not judged": "not_judged"}.get(word, "self_checks")] += 1
            tally["self_checks_not_met"] += word == "self-check not met"
            assert got["survival_only"] is bool(src.get("survival_only"))
            tally["claims_hold_survival_only"] += word == "claim holds" and bool(src.get("survival_only"))
        assert out["counts"] == dict(rows=len(rows), **tally)
        page = (tmp_path / f"r{k}" / "index.html").read_text()
        for cls, n in (("selfcheck", tally["self_checks"]), ("matches", tally["matches"]), ("agrees", tally["agrees"]),
                       ("departs", tally["departs"]), ("claimholds", tally["claims_hold"]),
                       ("claimfails", tally["claims_fail"])):
            assert page.count(f'<tr class="{cls}"') == n, cls


def test_the_oracle_checks_what_the_row_adds():
    """The sign a row states decides the verdict at the band's edge: zero is inside an
    |paper|-wide band but has no sign; the worked-out verdict and agrees() say so alike."""
    tol = dict(kind="abs", value=0.17, derivation="spread", why="w")
    assert expected(0.0, tol, 0.17, None) is True
    assert expected(0.0, tol, 0.17, "+") is False
    assert values.agrees(0.0, tol, 0.17, "+") is False and values.agrees(0.0, tol, 0.17) is True
    assert expected(0.3, dict(kind="factor", value=2.0), 0.17, None) is True
    assert expected(0.35, dict(kind="factor", value=2.0), 0.17, None) is False
