"""``bipedlab reproduce --check``: a published quick report against the code at hand, row by
row (the seven-link free swing, a few seconds), and the comparison's rules on their own."""
from __future__ import annotations

import copy
import json

import pytest

from bipedlab.cli import main
from bipedlab.report import check

ONLY = ["--only", "seven-link/free-swing"]


def _report(rows, quick=True, commit="abc"):
    return dict(quick=quick, commit=commit, created="2026-12-04",
                papers={"toy": dict(rows=[dict(id=i, bipedlab=v, verdict=w) for i, v, w in rows])})


def test_rows_match_to_the_tolerance_and_every_difference_is_named():
    pub = _report([("a", 1.0, "agrees"), ("b", 0.5, "departs"), ("c", None, "not judged"), ("d", 3, "agrees")])
    now = copy.deepcopy(pub)
    assert check.compare(pub, now)["matches"]
    now["papers"]["toy"]["rows"][0]["bipedlab"] = 1.0 * (1 + 0.5 * check.RTOL)   # rounding: still the same
    assert check.compare(pub, now)["matches"]
    now["papers"]["toy"]["rows"][0]["bipedlab"] = 1.0 * (1 + 3 * check.RTOL)     # a change of the code
    now["papers"]["toy"]["rows"][1]["verdict"] = "agrees"                         # same value, other verdict
    now["papers"]["toy"]["rows"].pop(2)                                           # a row gone
    now["papers"]["toy"]["rows"].append(dict(id="e", bipedlab=2.0, verdict="agrees"))  # a row added
    c = check.compare(pub, now)
    assert not c["matches"] and c["rows"] == 4 and c["matched"] == 1
    assert [d["id"] for d in c["differs"]] == ["a", "b"]
    assert [d["id"] for d in c["missing"]] == ["c"] and [d["id"] for d in c["new"]] == ["e"]
    text = check.summary(c)
    assert "1 of 4 quick rows match" in text and "differs  toy/a" in text and "missing  toy/c" in text
    assert check.same(float("nan"), float("nan")) and not check.same(True, 1) and not check.same(None, 0.0)


def test_a_published_report_is_checked_and_a_changed_value_exits_1(tmp_path, capsys):
    pub = tmp_path / "published"
    pub.mkdir()
    assert main(["reproduce", "seven-link", "--quick", "--json", "--out", str(tmp_path / "a"), *ONLY]) == 0
    capsys.readouterr()
    (pub / check.QUICK_FILE).write_text((tmp_path / "a" / "report.json").read_text())
    argv = ["reproduce", "seven-link", "--check", "--published", str(pub), "--json", "--out", str(tmp_path / "b"), *ONLY]
    assert main(argv) == 0
    rec = json.loads(capsys.readouterr().out)
    assert rec["quick"] and rec["check"]["matches"] and rec["check"]["rows"] == rec["check"]["matched"] > 0
    assert rec["check"]["stale"] is None  # no full run's report.json in the folder: no key comparison
    data = json.loads((pub / check.QUICK_FILE).read_text())
    row = next(r for r in data["papers"]["seven-link"]["rows"] if r["id"] == "free_swing_hip_half_cycles")
    row["bipedlab"] += 1
    (pub / check.QUICK_FILE).write_text(json.dumps(data))
    assert main(argv[:-2 - len(ONLY)] + ["--out", str(tmp_path / "c"), *ONLY]) == 1
    rec = json.loads(capsys.readouterr().out)
    assert [d["id"] for d in rec["check"]["differs"]] == ["free_swing_hip_half_cycles"]


@pytest.mark.parametrize("content, words", [
    (None, "no published quick report"),
    ("{not json", "is not a report's JSON"),
    (json.dumps(dict(quick=False, papers={})), "not the report.json of a quick reproduction"),
])
def test_an_unreadable_published_report_is_one_line_and_status_2(tmp_path, capsys, content, words):
    if content is not None:
        (tmp_path / check.QUICK_FILE).write_text(content)
    with pytest.raises(SystemExit) as e:
        main(["reproduce", "--check", "--published", str(tmp_path), "--out", str(tmp_path / "o")])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert words in err[-1] and "--check" in err[-1]
    assert not (tmp_path / "o").exists()


def test_published_needs_check(capsys, tmp_path):
    with pytest.raises(SystemExit) as e:
        main(["reproduce", "--published", str(tmp_path)])
    assert e.value.code == 2
    assert "--published applies with --check" in capsys.readouterr().err


def _key_copy(tmp_path, edit):
    """docs/report's report.json and quick.json copied to tmp_path, ``edit`` applied to both."""
    src = check.default_folder()
    for name in ("report.json", check.QUICK_FILE):
        data = json.loads((src / name).read_text())
        edit(data)
        (tmp_path / name).write_text(json.dumps(data))
    return tmp_path


def test_stale_names_each_experiment_whose_stored_key_is_not_the_codes(tmp_path):
    """The currency check computes every experiment's result key from the source, without
    running it, and names each one the published page holds under another key, or lacks."""
    from bipedlab.report import registry, runner

    papers = registry.papers()
    exp = papers["seven-link"].experiment("free-swing")
    current = runner.cache_key("seven-link", exp.name, exp.args(False), runner.robot_package(exp.run),
                               papers["seven-link"].values)

    def edit(data):
        data["papers"]["seven-link"]["experiments"] = [
            dict(e, cache_key=current if e["name"] == "free-swing" else "0" * 32)
            for e in data["papers"]["seven-link"]["experiments"] if e["name"] != "walk"]

    named = {(s["report"], s["paper"], s["experiment"]) for s in check.stale(_key_copy(tmp_path, edit))}
    assert ("report.json", "seven-link", "free-swing") not in named     # its key is the code's
    assert ("report.json", "seven-link", "walk") in named               # missing from the page
    others = [e.name for e in papers["seven-link"].experiments if e.name not in ("free-swing", "walk")]
    assert others and all(("report.json", "seven-link", n) in named for n in others)  # other keys
    gone = next(s for s in check.stale(_key_copy(tmp_path, lambda d: d["papers"]["seven-link"]["experiments"].append(
        dict(name="no-such-experiment", cache_key="1" * 32)))) if s["experiment"] == "no-such-experiment")
    assert gone["current"] is None and gone["published"] == "1" * 32
    line = check.summary(dict(published={}, matched=1, rows=1, matches=True, differs=[], missing=[], new=[],
                              stale=["seven-link/walk", "seven-link/free-swing"]))
    assert line.splitlines()[-1] == ("the published report's results were computed from other source than the code "
                                     "at hand for 2 experiments (seven-link/walk, seven-link/free-swing): regenerate it")


def test_the_published_report_is_the_codes():
    """docs/report was produced from the code at hand: every experiment's stored key (full run
    and quick run) is the key the source gives it. When this fails, regenerate the published
    report (README, "The published report") and rerun the experiments named."""
    stale = check.stale()
    assert not stale, "docs/report is stale; rerun: " + ", ".join(
        sorted({f"{s['paper']}/{s['experiment']}" for s in stale}))


def test_the_published_page_links_every_file_it_was_built_with():
    """Every figure, animation and data file under docs/report is reachable from its page (an
    image, an animation or a link in its experiment's file list)."""
    assert check.unlinked(check.default_folder()) == []


def test_unlinked_names_a_file_the_page_does_not_reach(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "fig 1.png").write_bytes(b"x")
    (tmp_path / "a" / "data.json").write_text("{}")
    (tmp_path / "report.json").write_text("{}")
    (tmp_path / "index.html").write_text('<img src="a/fig 1.png"><a href="a/x.html#top">x</a>')
    assert check.unlinked(tmp_path) == ["a/data.json"]
    (tmp_path / "index.html").write_text('<img src="a/fig 1.png"><a href="a/data.json">data</a>')
    assert check.unlinked(tmp_path) == []


def test_the_currency_check_reads_the_jax_the_report_records(monkeypatch):
    """Another JAX installed here does not make a page computed from the same source stale: the
    keys are computed for the JAX version the report records."""
    import jax

    monkeypatch.setattr(jax, "__version__", "9.9.9")
    assert check.stale() == []
