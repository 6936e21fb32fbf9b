"""Paper values as data: the file format's checks, the agree / depart logic under each kind
of tolerance, and the tolerance in words."""
from __future__ import annotations

import json

import pytest

from bipedlab.report import values


def _row(**kw):
    row = dict(id="speed", quantity="walking speed", paper=0.8, unit="m/s", source="Sec. III, Fig. 5",
               tolerance=dict(kind="rel", value=0.05, derivation="precision", why="two significant digits"))
    row.update(kw)
    return row


def _data(*rows):
    return dict(paper="p", title="A paper", citation="Someone, 2011", rows=list(rows) or [_row()])


def test_a_well_formed_file_loads(tmp_path):
    path = tmp_path / "p.json"
    path.write_text(json.dumps(_data()))
    assert values.load(path)["rows"][0]["id"] == "speed"


@pytest.mark.parametrize("bad, words", [
    (dict(source=""), "'source'"),
    (dict(tolerance=dict(kind="rel", value=0.05)), "why"),
    (dict(tolerance=dict(kind="close", value=0.05, why="x")), "kind"),
    (dict(tolerance=dict(kind="rel", value=-1, why="x")), "does not fit"),
    (dict(tolerance=dict(kind="range", value=[2, 1], why="x")), "does not fit"),
    (dict(tolerance=dict(kind="report", value=3, why="x")), "does not fit"),
    (dict(paper=[1, 2]), "'paper'"),
    (dict(tolerance=dict(kind="rel", value=0.05, why="x")), "derivation"),
    (dict(tolerance=dict(kind="rel", value=0.05, derivation="guess", why="x")), "derivation"),
    (dict(tolerance=dict(kind="rel", value=0.05, derivation="claim", why="x")), "cannot use kind 'rel'"),
    (dict(tolerance=dict(kind="report", value=None, derivation="claim", why="x")), "no derivation"),
    (dict(tolerance=dict(kind="rel", value=1.2, derivation="precision", why="x")), "does not fit"),
    (dict(tolerance=dict(kind="abs", value=0.9, derivation="precision", why="x")), "farther than |paper|"),
    (dict(tolerance=dict(kind="factor", value=3, derivation="size", why="x")), "does not fit"),
    (dict(sign="+", tolerance=dict(kind="range", value=[-0.1, 1.0], derivation="spread", why="x")), "both signs"),
    (dict(sign="-"), "not the sign"),
    (dict(sign="up"), "'sign'"),
    (dict(paper=float("nan")), "'paper'"),
])
def test_a_row_without_source_or_a_sound_tolerance_is_refused(bad, words):
    with pytest.raises(values.ValuesError, match=words):
        values.check(_data(_row(**bad)))


def test_missing_keys_and_repeated_ids_are_refused():
    row = _row()
    del row["tolerance"]
    with pytest.raises(values.ValuesError, match="missing 'tolerance'"):
        values.check(_data(row))
    with pytest.raises(values.ValuesError, match="twice"):
        values.check(_data(_row(), _row()))
    with pytest.raises(values.ValuesError, match="rows"):
        values.check(dict(paper="p", title="t", citation="c", rows=[]))


def test_unreadable_file_is_one_error_naming_it(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text("{")
    with pytest.raises(values.ValuesError, match="broken.json"):
        values.load(path)


@pytest.mark.parametrize("kind, t, paper, v, expected", [
    ("rel", 0.05, 0.8, 0.84, True),
    ("rel", 0.05, 0.8, 0.8401, False),
    ("rel", 0.05, -0.8, -0.76, True),
    ("abs", 0.02, 0.018, -0.002, True),
    ("abs", 0.02, 0.018, -0.0021, False),
    ("at_least", 92, 92, 100, True),
    ("at_least", 92, 92, 91, False),
    ("at_most", 1.0, "stable", 0.99, True),
    ("at_most", 1.0, "stable", 1.01, False),
    ("range", [0.5, 1.0], "x", 0.5, True),
    ("range", [0.5, 1.0], "x", 1.2, False),
    ("equals", True, True, True, True),
    ("equals", True, True, False, False),
    ("factor", 2.0, 0.018, 0.009, True),
    ("factor", 2.0, 0.018, 0.0089, False),
    ("factor", 2.0, 0.018, 0.036, True),
    ("factor", 2.0, 0.018, 0.0361, False),
    ("factor", 2.0, -0.011, 0.011, False),
    ("factor", 2.0, -0.011, -0.02, True),
])
def test_agrees_follows_the_tolerance(kind, t, paper, v, expected):
    assert values.agrees(v, dict(kind=kind, value=t, why="w"), paper) is expected


def test_a_stated_sign_is_part_of_agreement():
    tol = dict(kind="abs", value=0.05, why="w")
    assert values.agrees(-0.046, tol, 0.05) is False                 # outside anyway
    assert values.agrees(0.0, tol, 0.05) is True and values.agrees(0.0, tol, 0.05, "+") is False
    assert values.agrees(0.01, tol, 0.05, "+") is True and values.agrees(-0.01, dict(kind="at_most", value=0), None, "+") is False
    assert values.band(tol, 0.05, "+") == (0.0, 0.1) and values.band(dict(kind="factor", value=2.0), -0.01) == (-0.02, -0.005)


def test_missing_or_unjudged_values_neither_agree_nor_depart():
    rel = dict(kind="rel", value=0.1, why="w")
    assert values.agrees(None, rel, 1.0) is None
    assert values.agrees("fell", rel, 1.0) is None          # a text where a number is needed
    assert values.agrees(1.0, rel, "a claim") is None       # a relative tolerance needs a number to be relative to
    assert values.agrees(0.5, dict(kind="report", value=None, why="w"), "figure") is None
    assert values.agrees(True, dict(kind="at_least", value=1, why="w")) is None  # yes/no is not a count


def test_tolerance_in_words():
    assert values.tolerance_text(dict(kind="rel", value=0.05)) == "within 5 %"
    assert values.tolerance_text(dict(kind="abs", value=0.02), "m") == "within ±0.02 m"
    assert values.tolerance_text(dict(kind="at_least", value=92), "hops") == "at least 92 hops"
    assert values.tolerance_text(dict(kind="range", value=[1, 2])) == "in [1, 2]"
    assert values.tolerance_text(dict(kind="report", value=None)) == "reported, not judged"
    assert values.tolerance_text(dict(kind="factor", value=2.0)) == "the paper's sign, within a factor 2"
    assert values.tolerance_text(dict(kind="abs", value=0.021), "m", "-") == "within ±0.021 m, negative"
    assert values.tolerance_text(dict(kind="abs", value=0.00005)) == "within ±0.00005"
