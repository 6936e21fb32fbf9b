"""``bipedlab reproduce --rerun`` killed for real (SIGKILL in one process, SIGINT with worker
processes) once an experiment has finished, then the same command again: it names the
experiments it resumes, computes only the others, leaves no worker behind, and its report's
rows are the uninterrupted run's. Three cheap experiments of the quick reproduction (the
seven-link free swing and low-gain PD, ATRIAS on flat ground)."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

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


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    root = tmp_path_factory.mktemp("reproduce")
    report, _ = _finish(_argv(root / "report", (SWING, PD, FLAT), jobs=2), _env(root / "cache"))
    return _rows(report)


def _check(report: dict, reference: dict, resumed: set):
    rows = _rows(report)
    assert rows and all(reference[k] == v for k, v in rows.items())
    got = {f"{k}/{e['name']}" for k, p in report["papers"].items() for e in p["experiments"] if e.get("resumed")}
    assert got == resumed


def test_a_killed_rerun_resumes_what_it_finished(reference, tmp_path):
    env, out, only = _env(tmp_path / "cache"), tmp_path / "report", (SWING, PD)
    code, err, _ = _interrupt(_argv(out, only, jobs=1), env, signal.SIGKILL, "seven-link: free-swing")
    assert code == -signal.SIGKILL
    assert json.loads((out / "progress.json").read_text())["complete"] is False
    report, err = _finish(_argv(out, only, jobs=1), env)
    assert "resuming the interrupted run" in err and f"taken as stored: {SWING}" in err
    assert "free-swing: done in" not in err and "low-gain-pd: done in" in err  # only the rest is computed
    _check(report, reference, {SWING})
    assert json.loads((out / "progress.json").read_text())["complete"] is True
    report, err = _finish(_argv(out, only, jobs=1), env)  # a finished --rerun: the next one computes everything
    assert "resuming" not in err and "free-swing: done in" in err and "low-gain-pd: done in" in err


def test_an_interrupted_run_in_workers_resumes_and_leaves_no_worker(reference, tmp_path):
    env, out, only = _env(tmp_path / "cache"), tmp_path / "report", (SWING, FLAT)
    code, err, kids = _interrupt(_argv(out, only, jobs=2), env, signal.SIGINT, "seven-link: free-swing")
    # (multiprocessing's resource tracker may add its warning about the queues' semaphores)
    assert code == 130 and "bipedlab: interrupted" in err.splitlines(), err[-2000:]
    assert kids, "the run had no worker processes"
    deadline = time.monotonic() + 20
    while not all(_gone(k) for k in kids):
        assert time.monotonic() < deadline, "a worker outlived the interrupted run"
        time.sleep(0.2)
    report, err = _finish(_argv(out, only, jobs=2), env)
    assert f"taken as stored: {SWING}" in err and "flat: done in" in err and "free-swing: done in" not in err
    _check(report, reference, {SWING})
