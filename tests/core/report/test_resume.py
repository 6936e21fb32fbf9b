"""Resuming a reproduction on a paper made up here (no robot): each experiment's entry is
stored before the next starts and carries the run's id; ``--rerun`` (``use_cache=False``)
recomputes all but what the same run stored; ``progress.json`` resumes the run of the same
arguments, starts a new one otherwise, and is complete only when the report is. The command
line killed for real is tests/test_reproduce_resume.py."""
from __future__ import annotations

import json
import os

import pytest

from bipedlab.report import Experiment, Paper, resume, runner

CALLS = []
STOP = {"at": None}  # the call at which the run is interrupted (once)


class Interrupted(BaseException):
    pass


def _study(args, out, progress):
    CALLS.append(args["n"])
    if STOP["at"] == len(CALLS):
        STOP["at"] = None
        raise Interrupted  # the process stops here: the entries already stored stay
    return dict(n=args["n"], square=args["n"] ** 2)


def _paper(tmp_path):
    values = tmp_path / "toy.json"
    values.write_text(json.dumps(dict(paper="toy", title="Toy", citation="Nobody", rows=[])))
    exps = tuple(Experiment(f"e{i}", f"toy e{i}", _study, dict(n=i), dict(n=i))
                 for i in range(3))
    return Paper("toy", "Toy", str(values), exps, lambda records, quick: {})


@pytest.fixture(autouse=True)
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("BIPEDLAB_CACHE_DIR", str(tmp_path / "cache"))
    CALLS.clear()
    STOP["at"] = None


def test_an_interrupted_rerun_resumes_what_it_stored(tmp_path):
    """e0 and e1 finish, e2 is interrupted; the same run again computes e2 only, the
    experiments it reuses are 'resumed'; another run under --rerun computes everything."""
    paper = _paper(tmp_path)
    STOP["at"] = 3
    with pytest.raises(Interrupted):
        runner.run_all([paper], quick=False, say=lambda m: None, use_cache=False, run_id="A")
    assert CALLS == [0, 1, 2]
    stored = {e.name: json.loads((runner.cache_root() / runner.cache_key("toy", e.name, e.full_args) /
                                  "record.json").read_text()) for e in paper.experiments[:2]}
    assert {k: v["run"] for k, v in stored.items()} == {"e0": "A", "e1": "A"}
    assert not [p for p in runner.cache_root().iterdir() if p.name.startswith(".")]  # no temporary folder left
    assert runner.stored_by("A", [paper], quick=False) == ["toy/e0", "toy/e1"]
    CALLS.clear()
    lines = []
    res = runner.run_all([paper], quick=False, say=lines.append, use_cache=False, run_id="A")["toy"]
    assert CALLS == [2]
    assert [(r.resumed, r.cached) for r in res] == [(True, True), (True, True), (False, False)]
    assert any("e0: finished before the interruption" in m for m in lines)
    assert res[2].record == dict(n=2, square=4)
    CALLS.clear()
    runner.run_all([paper], quick=False, say=lambda m: None, use_cache=False, run_id="B")
    assert CALLS == [0, 1, 2]  # a new --rerun recomputes everything
    CALLS.clear()
    runner.run_all([paper], quick=False, say=lambda m: None, use_cache=True, run_id="C")
    assert CALLS == []  # without --rerun every stored result is reused


def test_progress_file_resumes_the_same_arguments_only(tmp_path):
    paper = _paper(tmp_path)
    out = tmp_path / "report"
    args = resume.arguments([paper], quick=False, rerun=True, only=None)
    first = resume.begin(out, args, [paper], False, None)
    assert first.note is None and first.resumed == []
    disk = json.loads((out / resume.FILE).read_text())
    assert disk["run"] == first.id and disk["complete"] is False and disk["arguments"] == args
    runner.run_experiment(paper, paper.experiments[0], False, lambda m: None, use_cache=False, run_id=first.id)
    again = resume.begin(out, args, [paper], False, None)  # interrupted, the same command
    assert again.id == first.id and again.resumed == ["toy/e0"]
    assert "resuming the interrupted run" in again.note and "toy/e0" in again.note
    other = resume.begin(out, dict(args, quick=True), [paper], True, None)
    assert other.id != first.id and "other arguments (quick: false then, true now)" in other.note
    assert "computed again (--rerun)" in other.note
    staged = tmp_path / "staged"
    staged.mkdir()
    resume.finish(staged, other)  # staged with the report: the complete file replaces the other at commit
    os.replace(staged / resume.FILE, out / resume.FILE)
    assert json.loads((out / resume.FILE).read_text())["complete"] is True
    new = resume.begin(out, dict(args, quick=True), [paper], True, None)
    assert new.id != other.id and new.note is None  # a finished run is not resumed


def test_a_dead_processs_temporary_entry_is_removed(tmp_path):
    root = runner.cache_root()
    root.mkdir(parents=True)
    dead = root / runner._tmp_name("k").replace(str(os.getpid()), "999999999")
    dead.mkdir()
    mine = root / runner._tmp_name("k")
    mine.mkdir()
    runner.clean_stale()
    assert not dead.exists() and mine.exists()
