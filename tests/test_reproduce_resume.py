"""``bipedlab reproduce --rerun`` stopped for real (SIGINT with worker processes, SIGKILL in one
process) once an experiment has finished, then the same command again: it names the
experiments it resumes, computes only the others, leaves no worker behind, and its report's
rows are those of the next, uninterrupted run. Three cheap experiments of the quick
reproduction (the seven-link free swing and low-gain PD, ATRIAS on flat ground), in one folder
(four processes, where two tests with a shared reference run took six).

Slow tier: four real processes. Their fast counterparts, each failing for the same defects, run
by default: the resume logic on a made-up paper (tests/core/report/test_resume.py), SIGINT and
SIGTERM ending a study with 130 / 143, one line and no partial output
(tests/test_cli_reliability.py), and a dead worker ending the run with an error
(tests/test_reproduce_workers.py)."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

SWING, PD, FLAT = "seven-link/free-swing", "seven-link/low-gain-pd", "running/flat"


def _argv(out: Path, only, jobs: int):
    argv = [sys.executable, "-m", "bipedlab.cli", "reproduce", "--quick", "--rerun", "--json", "--jobs", str(jobs),
            "--out", str(out)]
    for o in only:
        argv += ["--only", o]
    return argv


def _env(cache: Path):
    return dict(os.environ, JAX_PLATFORMS="cpu", BIPEDLAB_CACHE_DIR=str(cache))


def _finish(argv, env, timeout=400):
    p = subprocess.run(argv, capture_output=True, text=True, env=env, timeout=timeout)
    assert p.returncode == 0, p.stderr[-3000:]
    return json.loads(p.stdout), p.stderr


def _children(pid: int) -> list:
    kids = []
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                stat = Path(f"/proc/{d}/stat").read_text()
            except OSError:
                continue
            if int(stat.rpartition(")")[2].split()[1]) == pid:
                kids.append(int(d))
    return kids


def _gone(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()[0] == "Z"
    except OSError:
        return True


def _interrupt(argv, env, sig, after: str, timeout=400):
    """Run the command until its stderr says ``after`` finished, send ``sig``; the exit code,
    stderr and the worker processes it had."""
    p = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env)
    err, kids = [], set()
    deadline = time.monotonic() + timeout
    try:
        for line in p.stderr:
            err.append(line)
            kids.update(_children(p.pid))
            if f"{after}: done in" in line:
                kids.update(_children(p.pid))
                p.send_signal(sig)
                break
            assert time.monotonic() < deadline
        err += p.stderr.readlines()
        p.wait(timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    return p.returncode, "".join(err), kids


def _rows(report: dict) -> dict:
    return {(k, r["id"]): (r["bipedlab"], r["agrees"]) for k, p in report["papers"].items() for r in p["rows"]
            if r["bipedlab"] is not None}


def _stored(err: str) -> set:
    """The experiments a resumed run names as taken as stored."""
    lines = [line for line in err.splitlines() if "taken as stored: " in line]
    assert len(lines) == 1, err[-3000:]
    return set(lines[0].split("taken as stored: ", 1)[1].strip().split(", "))


def _check(report: dict, reference: dict, resumed: set):
    rows = _rows(report)
    assert rows and all(reference[k] == v for k, v in rows.items())
    got = {f"{k}/{e['name']}" for k, p in report["papers"].items() for e in p["experiments"] if e.get("resumed")}
    assert got == resumed


def test_interrupted_reruns_resume_what_they_finished_and_leave_no_worker(tmp_path):
    """One folder, four runs of the same command (jobs is not part of a run's arguments): in two
    worker processes, interrupted (SIGINT) once the free swing is done; in one process, killed
    (SIGKILL) once ATRIAS on flat ground is done; in one process to the end, computing only the
    low-gain PD; then again, computing everything: the reference the resumed report's rows are
    compared with."""
    env, out, only = _env(tmp_path / "cache"), tmp_path / "report", (SWING, PD, FLAT)
    # SIGINT with worker processes (seven-link's two experiments in one, ATRIAS's in the other)
    code, err, kids = _interrupt(_argv(out, only, jobs=2), env, signal.SIGINT, "seven-link: free-swing")
    # (multiprocessing's resource tracker may add its warning about the queues' semaphores)
    assert code == 130 and "bipedlab: interrupted" in err.splitlines(), err[-2000:]
    assert kids, "the run had no worker processes"
    deadline = time.monotonic() + 20
    while not all(_gone(k) for k in kids):
        assert time.monotonic() < deadline, "a worker outlived the interrupted run"
        time.sleep(0.2)
    assert json.loads((out / "progress.json").read_text())["complete"] is False
    # the same command in one process: it resumes the free swing, computes ATRIAS and is killed
    code, err, _ = _interrupt(_argv(out, only, jobs=1), env, signal.SIGKILL, "running: flat")
    assert code == -signal.SIGKILL, err[-2000:]
    assert "resuming the interrupted run" in err and _stored(err) == {SWING}, err[-2000:]
    assert "flat: done in" in err and "free-swing: done in" not in err
    assert json.loads((out / "progress.json").read_text())["complete"] is False
    # again: it resumes both and computes only the rest
    report, err = _finish(_argv(out, only, jobs=1), env)
    assert "resuming the interrupted run" in err and _stored(err) == {SWING, FLAT}, err[-2000:]
    assert "free-swing: done in" not in err and "flat: done in" not in err and "low-gain-pd: done in" in err
    assert json.loads((out / "progress.json").read_text())["complete"] is True
    # a finished --rerun: the next one computes everything (uninterrupted: the reference)
    again, err = _finish(_argv(out, only, jobs=2), env)
    assert "resuming" not in err and all(f"{e}: done in" in err for e in ("free-swing", "low-gain-pd", "flat")), \
        err[-2000:]
    _check(again, _rows(again), set())
    _check(report, _rows(again), {SWING, FLAT})
