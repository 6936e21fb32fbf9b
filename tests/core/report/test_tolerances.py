"""Every shipped paper-values file, read as raw JSON and checked here without the validator's
own helpers: no relative, absolute or factor band reaches farther from the paper's number than
the number's magnitude, no band holds both signs where the row states a sign, every judged row
says how its tolerance was derived, a derivation fits its kind, and a self-check's tolerance is
the method's own target."""
from __future__ import annotations

import json
import math

import pytest

from bipedlab.report import registry

KEYS = tuple(registry.papers())
DERIVATION_KINDS = {"precision": {"rel", "abs", "range", "at_least", "at_most"},
                    "spread": {"rel", "abs", "range", "at_least", "at_most"},
                    "size": {"factor"},
                    "claim": {"at_least", "at_most", "range", "equals"},
                    "own_target": {"rel", "abs", "at_least", "at_most", "range", "equals"}}


def _raw(key):
    with open(registry.papers()[key].values, encoding="utf-8") as fh:
        return json.load(fh)["rows"]


def _is_number(x):
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _accepted(tol, paper):
    """The interval of values the tolerance accepts (before any sign), or None."""
    kind, t = tol["kind"], tol.get("value")
    if kind == "range":
        return tuple(t)
    if kind == "at_least":
        return t, math.inf
    if kind == "at_most":
        return -math.inf, t
    if not _is_number(paper):
        return None
    if kind == "rel":
        return paper - t * abs(paper), paper + t * abs(paper)
    if kind == "abs":
        return paper - t, paper + t
    if kind == "factor":
        return min(paper / t, paper * t), max(paper / t, paper * t)
    return None


def too_wide(row) -> list:
    """What is wrong with a row's tolerance width, in words (empty when nothing)."""
    tol, p = row["tolerance"], row["paper"]
    out = []
    kind = tol["kind"]
    if kind in ("rel", "abs", "factor"):
        if not _is_number(p):
            out.append(f"a {kind} tolerance needs a number to be relative to, the paper gives {p!r}")
        else:
            lo, hi = _accepted(tol, p)
            reach = max(p - lo, hi - p)
            if reach > abs(p) * (1 + 1e-9):
                out.append(f"{kind} {tol['value']!r} accepts values {reach:g} from the paper's {p!r}, "
                           f"wider than |paper| = {abs(p):g}")
    if row.get("sign") in ("+", "-"):
        band = _accepted(tol, p)
        if band is not None and band[0] < 0 < band[1]:
            out.append(f"sign {row['sign']} stated, but [{band[0]:g}, {band[1]:g}] holds both signs")
        if _is_number(p) and (p > 0) != (row["sign"] == "+"):
            out.append(f"sign {row['sign']} is not the sign of the paper's {p!r}")
    return out


@pytest.mark.parametrize("key", KEYS)
def test_no_tolerance_is_wider_than_the_paper_value(key):
    bad = {r["id"]: w for r in _raw(key) if (w := too_wide(r))}
    assert not bad, "\n".join(f"{k}: {'; '.join(v)}" for k, v in bad.items())


@pytest.mark.parametrize("key", KEYS)
def test_every_judged_row_says_how_its_tolerance_was_derived(key):
    bad = []
    for r in _raw(key):
        tol = r["tolerance"]
        d = tol.get("derivation")
        if tol["kind"] == "report":
            continue
        if d not in DERIVATION_KINDS:
            bad.append(f"{r['id']}: no derivation ({d!r})")
        elif tol["kind"] not in DERIVATION_KINDS[d]:
            bad.append(f"{r['id']}: a {d} derivation with kind {tol['kind']}")
        if (d == "own_target") != bool(r.get("self_check")):
            bad.append(f"{r['id']}: own_target tolerances belong to self-check rows and only to them")
        if not tol.get("why", "").strip():
            bad.append(f"{r['id']}: no why")
    assert not bad, "\n".join(bad)


def test_the_check_itself_can_fail():
    """The checks above on rows made to fail (so the test is not one that cannot fail)."""
    wide = dict(id="x", paper=0.008, tolerance=dict(kind="abs", value=0.05))
    assert too_wide(wide) and "wider than" in too_wide(wide)[0]
    assert too_wide(dict(id="x", paper=0.1, tolerance=dict(kind="rel", value=1.5)))
    assert too_wide(dict(id="x", paper=0.17, sign="+", tolerance=dict(kind="range", value=[-0.1, 0.4])))
    assert too_wide(dict(id="x", paper=-0.05, sign="+", tolerance=dict(kind="abs", value=0.01)))
    assert not too_wide(dict(id="x", paper=0.05, sign="+", tolerance=dict(kind="abs", value=0.05)))
    assert not too_wide(dict(id="x", paper=-0.011, sign="-", tolerance=dict(kind="factor", value=2.0)))
