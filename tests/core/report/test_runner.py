"""The report's runner and builder on a paper made up here (no robot): the content-hash cache
(a second run reuses the stored record and figures, new arguments run again), skipped
experiments, and the report.json contract."""
from __future__ import annotations

import json

import pytest

from bipedlab.report import Experiment, Figure, Paper, Skip, build, runner

CALLS = []


def _study(args, out, progress):
    CALLS.append(dict(args))
    progress("working")
    with open(f"{out}/curve.png", "wb") as fh:
        fh.write(b"\x89PNG fake")
    with open(f"{out}/bulky.npz", "wb") as fh:
        fh.write(b"data")
    return dict(speed=0.78 * args["scale"], hops=args["hops"], fell=False)


def _measure(records, quick):
    r = records.get("run")
    return dict(speed=r["speed"] if r else Skip("not run"), hops=r["hops"] if r else Skip("not run"),
                top=Skip("not run in --quick") if quick else 1.0)


@pytest.fixture
def paper(tmp_path, monkeypatch):
    monkeypatch.setenv("BIPEDLAB_CACHE_DIR", str(tmp_path / "cache"))
    CALLS.clear()
    data = dict(paper="toy", title="A toy paper", citation="Nobody, 2024", rows=[
        dict(id="speed", quantity="speed", paper=0.8, unit="m/s", source="Fig. 1",
             tolerance=dict(kind="rel", value=0.05, derivation="precision", why="two digits"),
             departs_why="see Fig. 1 below."),
        dict(id="hops", quantity="hops", paper=92, source="Sec. 2",
             tolerance=dict(kind="at_least", value=92, derivation="claim", why="no fall"),
             departs_why="falls early; see the record."),
        dict(id="top", quantity="top speed", paper=1.5, source="Sec. 3",
             tolerance=dict(kind="abs", value=0.1, derivation="precision", why="one digit")),
    ])
    path = tmp_path / "toy.json"
    path.write_text(json.dumps(data))
    exps = (Experiment("run", "toy run", _study, dict(scale=1.0, hops=100), dict(scale=1.0, hops=20),
                       reduction="20 hops", expected_s=3, quick_expected_s=1),
            Experiment("extra", "toy extra", _study, dict(scale=2.0, hops=1), None, expected_s=2))
    return Paper("toy", "A toy paper", str(path), exps, _measure,
                 figures=(Figure("run", "curve.png", "A curve (cf. Fig. 1)"), Figure("run", "gone.png", "Missing")))


def test_second_run_reuses_stored_results(paper, tmp_path):
    lines = []
    first = runner.run_all([paper], quick=True, say=lines.append)
    assert len(CALLS) == 1 and not first["toy"][0].cached
    assert any("expected duration" in m for m in lines) and any("[1/1] toy: run" in m for m in lines)
    again = runner.run_all([paper], quick=True, say=lines.append)
    assert len(CALLS) == 1, "the stored result was not reused"
    r = again["toy"][0]
    assert r.cached and r.record == first["toy"][0].record
    assert [p.rsplit("/", 1)[1] for p in r.files] == ["curve.png"]  # data files are not kept
    runner.run_all([paper], quick=False, say=lines.append)            # other arguments: run again
    assert len(CALLS) == 3
    runner.run_all([paper], quick=True, say=lines.append, use_cache=False)
    assert len(CALLS) == 4


def test_the_key_changes_with_arguments_and_paper():
    k = runner.cache_key("toy", "run", dict(hops=20))
    assert k == runner.cache_key("toy", "run", dict(hops=20))
    assert k != runner.cache_key("toy", "run", dict(hops=21))
    assert k != runner.cache_key("other", "run", dict(hops=20))


def test_report_json_contract_and_page(paper, tmp_path):
    results = runner.run_all([paper], quick=True, say=lambda m: None)
    out = tmp_path / "report"
    rep = build.build([paper], results, quick=True, out_dir=out, wall_s=1.5, cpu_s=1.0)
    disk = json.loads((out / "report.json").read_text())
    assert disk == json.loads(json.dumps(disk))
    for key in ("papers", "version", "device", "quick", "wall_s"):
        assert key in disk
    assert disk["quick"] is True and disk["wall_s"] == 1.5
    toy = disk["papers"]["toy"]
    rows = {r["id"]: r for r in toy["rows"]}
    for r in toy["rows"]:
        assert {"quantity", "paper", "source", "bipedlab", "tolerance", "agrees", "why"} <= set(r)
    assert rows["speed"]["agrees"] is True and rows["speed"]["bipedlab"] == pytest.approx(0.78)
    assert rows["hops"]["agrees"] is False and rows["hops"]["why"] == "falls early; see the record."
    assert rows["top"]["agrees"] is None and rows["top"]["bipedlab"] is None
    assert rows["top"]["why"] == "not run in --quick"
    assert rows["speed"]["verdict"] == "matches" and rows["hops"]["verdict"] == "claim fails"  # precision; a claim
    assert toy["counts"] == dict(rows=3, matches=1, agrees=0, departs=0, departs_within_uncertainty=0, departs_implementation=0, claims_hold=0, claims_hold_survival_only=0, claims_fail=1, self_checks=0,
                                 self_checks_not_met=0, not_identifiable=0, not_judged=1)
    exps = {e["name"]: e for e in toy["experiments"]}
    assert {"wall_s", "compile_s"} <= set(exps["run"]) and exps["run"]["reduction"] == "20 hops"
    assert exps["extra"]["skipped"] == "not run in --quick"
    figs = toy["figures"]
    assert figs[0]["file"] == "toy/run/curve.png" and (out / figs[0]["file"]).is_file()
    assert figs[1]["file"] is None
    page = (out / "index.html").read_text()
    assert 'id="toy"' in page and page.count('<tr class="') == 3
    assert "http://" not in page and "https://" not in page and "<script" not in page
    assert rep["papers"]["toy"]["counts"] == toy["counts"]


def test_a_measure_that_fails_leaves_every_row_unjudged(paper, tmp_path):
    broken = Paper(paper.key, paper.title, paper.values, paper.experiments, lambda records, quick: 1 / 0)
    results = runner.run_all([broken], quick=True, say=lambda m: None)
    rep = build.build([broken], results, quick=True, out_dir=tmp_path / "r", wall_s=0.0, cpu_s=0.0)
    rows = rep["papers"]["toy"]["rows"]
    assert all(r["agrees"] is None and "ZeroDivisionError" in r["why"] for r in rows)


def test_the_key_follows_the_files_a_result_can_depend_on(tmp_path, monkeypatch):
    """A stored result is keyed by the core and its own robot's package: editing the report's
    modules, another robot or the paper's values file keeps it; editing its robot or the core
    does not."""
    import bipedlab
    from bipedlab import provenance

    root = tmp_path / "bipedlab"
    files = {"__init__.py": "", "sim/loop.py": "x = 1", "report/html.py": "y = 1",
             "robots/alpha/reproduce.py": "z = 1", "robots/alpha/data/paper_alpha.json": "{}",
             "robots/beta/reproduce.py": "w = 1"}
    for rel, text in files.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(text)
    monkeypatch.setattr(bipedlab, "__file__", str(root / "__init__.py"))
    values = str(root / "robots/alpha/data/paper_alpha.json")

    def key():
        monkeypatch.setattr(provenance, "_SOURCE_HASHES", {})
        return runner.cache_key("alpha", "run", dict(n=1), "robots/alpha", values)

    k0 = key()
    for rel in ("report/html.py", "robots/beta/reproduce.py", "robots/alpha/data/paper_alpha.json"):
        (root / rel).write_text((root / rel).read_text() + "\n# edited")
        assert key() == k0, rel
    for rel in ("robots/alpha/reproduce.py", "sim/loop.py"):
        (root / rel).write_text((root / rel).read_text() + "\n# edited")
        k1 = key()
        assert k1 != k0, rel
        k0 = k1
    assert runner.robot_package(test_the_key_follows_the_files_a_result_can_depend_on) is None
    from bipedlab.robots.atrias import reproduce
    assert runner.robot_package(reproduce.EXPERIMENTS[0].run) == "robots/atrias"


def test_paths_in_a_stored_record_name_the_stored_folder(tmp_path, monkeypatch):
    """A study that writes the path of its figure into its record: the stored record names the
    file where it is kept, not the temporary folder the experiment ran in."""
    monkeypatch.setenv("BIPEDLAB_CACHE_DIR", str(tmp_path / "cache"))

    def study(args, out, progress):
        with open(f"{out}/curve.png", "wb") as fh:
            fh.write(b"\x89PNG fake")
        return dict(figure=f"{out}/curve.png", figures=[f"{out}/curve.png"])

    path = tmp_path / "toy.json"
    path.write_text(json.dumps(dict(paper="toy", title="t", citation="c", rows=[])))
    paper = Paper("toy", "t", str(path), (Experiment("run", "toy run", study, dict(a=1), dict(a=1)),), lambda r, q: {})
    res = runner.run_all([paper], quick=True, say=lambda m: None)["toy"][0]
    from pathlib import Path
    assert Path(res.record["figure"]).is_file() and ".tmp-" not in res.record["figure"]
    assert res.record["figures"] == [res.record["figure"]] and res.record["figure"] in res.files
