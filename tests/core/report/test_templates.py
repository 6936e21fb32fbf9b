"""Texts computed from the run: a why or departs_why cites its numbers as placeholders filled
from the row's value, the facts its measure gives and the experiments' records; a name the run
does not hold is one clear error naming the file, the row and what there is."""
from __future__ import annotations

import json

import pytest

from bipedlab.report import Measured, Paper, Skip, build, values

NS = dict(value=-0.0257, paper=-0.072, delay=dict(fell=1, trials=4, delay_ms=10.0, runs=[dict(fell=True)]),
          how="fell")


@pytest.mark.parametrize("text, out", [
    ("{delay.fell} of {delay.trials} fell", "1 of 4 fell"),
    ("measured {value*100:+.1f} cm against {paper*100:+.1f} cm", "measured -2.6 cm against -7.2 cm"),
    ("at {delay.delay_ms:g} ms; {how}", "at 10 ms; fell"),
    ("{delay.runs.0.fell}", "True"),
    ("a literal {{brace}}", "a literal {brace}"),
    ("no placeholder", "no placeholder"),
])
def test_placeholders_are_filled_from_the_run(text, out):
    assert values.render(text, NS, "row") == out


@pytest.mark.parametrize("text, words", [
    ("{delay.fel} of {delay.trials}", ["row 'x'", "{delay.fel}", "delay has no 'fel'", "fell, runs, trials"]),
    ("{dely.fell}", ["the run has no 'dely'", "delay"]),
    ("{speed}", ["the run has no 'speed'"]),
    ("{delay.runs.3.fell}", ["delay.runs has no '3'"]),
    ("{value:d}", ["cannot format"]),
    ("{how*100}", ["scales 'fell'"]),
])
def test_a_name_the_run_does_not_hold_is_a_clear_error(text, words):
    with pytest.raises(values.TemplateError) as e:
        values.render(text, NS, "paper.json: row 'x'")
    for w in words:
        assert w in str(e.value)


def test_stray_braces_and_bad_scales_are_refused_when_the_file_loads():
    def data(text):
        return dict(paper="p", title="t", citation="c", rows=[dict(
            id="x", quantity="q", paper=1.0, source="s", departs_why=text,
            tolerance=dict(kind="rel", value=0.1, derivation="precision", why="w"))])
    values.check(data("fine {value:.2f} and {{literal}}"))
    with pytest.raises(values.ValuesError, match="stray"):
        values.check(data("an open { brace"))
    with pytest.raises(values.ValuesError, match="scale"):
        values.check(data("{value*ten}"))
    assert values.fields("{a.b} {value*100:.1f} {{x}} {c:g}") == ["a.b", "value", "c"]


def _paper(tmp_path, rows, measure):
    path = tmp_path / "toy.json"
    path.write_text(json.dumps(dict(paper="toy", title="Toy", citation="c", rows=rows)))
    return Paper("toy", "Toy", str(path), (), measure)


def test_the_build_fills_departs_and_agrees_texts_and_stops_on_a_missing_name(tmp_path):
    rows = [dict(id="fall", quantity="share run through", paper="keeps running", source="s",
                 tolerance=dict(kind="at_least", value=0.9, derivation="claim",
                                why="{delay.trials} draws, all of them ran"),
                 departs_why="{delay.fell} of {delay.trials} terrain draws fell ({note})"),
            dict(id="err", quantity="mean error", paper=-0.072, unit="m", source="s", sign="-",
                 tolerance=dict(kind="abs", value=0.021, derivation="spread", why="two standard errors"),
                 departs_why="measured {value*100:+.1f} cm over {delay.trials} draws")]
    recs = dict(delay=dict(fell=1, trials=4))
    paper = _paper(tmp_path, rows, lambda r, q: dict(fall=Measured(0.75, dict(note="a fact")), err=-0.0257))
    got = {r["id"]: r for r in build.rows_for(paper, recs, True)[0]}
    assert got["fall"]["why"] == "1 of 4 terrain draws fell (a fact)"
    assert got["err"]["why"] == "measured -2.6 cm over 4 draws"
    ok = _paper(tmp_path, rows, lambda r, q: dict(fall=1.0, err=Skip("not run")))
    got = {r["id"]: r for r in build.rows_for(ok, recs, True)[0]}
    assert got["fall"]["why"].endswith("4 draws, all of them ran")
    assert got["err"]["why"] == "not run"          # an unmeasured row renders no template
    with pytest.raises(values.TemplateError, match=r"toy.json: row 'fall' departs_why: \{note\}"):
        build.rows_for(_paper(tmp_path, rows, lambda r, q: dict(fall=0.5, err=-0.07)), recs, True)
    with pytest.raises(values.TemplateError, match="the run has no 'delay'"):
        build.rows_for(_paper(tmp_path, rows, lambda r, q: dict(fall=Measured(0.5, dict(note="n")), err=-0.07)),
                       dict(delay=None), True)
