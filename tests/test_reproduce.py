"""``bipedlab reproduce``: the registered papers, their shipped paper-values files, the rows
each paper's measure fills, and bad input (exit 2, one line, nothing run)."""
from __future__ import annotations

import pytest

from bipedlab import cli
from bipedlab.cli import main
from bipedlab.report import Skip, registry, values

PAPERS = ("identification", "hzd", "running", "seven-link")


def test_the_four_papers_are_registered_in_report_order():
    assert tuple(registry.papers()) == PAPERS
    assert "reproduce" in [c.name for c in cli.commands()]


@pytest.mark.parametrize("key", PAPERS)
def test_paper_values_file_is_well_formed(key):
    paper = registry.papers()[key]
    data = values.load(paper.values)   # checks the format: source, tolerance and its why on every row
    assert data["paper"] == key
    for row in data["rows"]:
        assert row["source"].strip() and row["tolerance"]["why"].strip()
        if row["tolerance"]["kind"] != "report":
            assert row.get("departs_why"), row["id"]


@pytest.mark.parametrize("key", PAPERS)
def test_measure_without_records_fills_only_known_rows(key):
    paper = registry.papers()[key]
    ids = {r["id"] for r in values.load(paper.values)["rows"]}
    for quick in (True, False):
        got = paper.measure({e.name: None for e in paper.experiments}, quick)
        assert set(got) <= ids, set(got) - ids
        assert all(v is None or isinstance(v, Skip) for v in got.values())


@pytest.mark.parametrize("key", PAPERS)
def test_every_experiment_has_full_arguments_and_says_what_quick_does(key):
    paper = registry.papers()[key]
    names = [e.name for e in paper.experiments]
    assert len(names) == len(set(names))
    for e in paper.experiments:
        assert e.full_args is not None and e.command.startswith("bipedlab ")
        assert e.reduction if e.quick_args is not None else e.skip_reason
    for f in paper.figures + paper.animations:
        assert f.experiment in names and "Fig" in f.caption or f.kind == "animation" or f.caption


@pytest.mark.parametrize("argv, words", [
    (["reproduce", "walking"], "unknown paper 'walking'"),
    (["reproduce", "hzd", "nonsense"], "unknown paper 'nonsense'"),
    (["reproduce", "--quick", "--only", "hzd/somersault"], "--only 'hzd/somersault'"),
    (["reproduce", "running", "--only", "hzd/nominal"], "--only 'hzd/nominal'"),
    (["reproduce", "--out", ""], "--out"),
    (["reproduce", "--fast"], "unrecognized arguments"),
])
def test_bad_input_is_one_line_and_status_2(argv, words, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    out, err = capsys.readouterr()
    assert out == "" and len(err.splitlines()) == 1
    assert err.startswith("bipedlab: error: ") and words in err
    assert list(tmp_path.iterdir()) == []  # nothing written


def test_out_that_is_a_file_is_refused_before_any_work(capsys, tmp_path):
    target = tmp_path / "file"
    target.write_text("x")
    with pytest.raises(SystemExit) as e:
        main(["reproduce", "seven-link", "--out", str(target)])
    assert e.value.code == 2
    assert capsys.readouterr().err.startswith("bipedlab: error: reproduce: ")
