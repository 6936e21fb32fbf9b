"""``bipedlab robustness five-link --out DIR`` interrupted and run again: a real process killed
mid-way (SIGKILL, SIGINT) or stopped by a full disk resumes from the chunks it wrote and ends
with the outcomes of an uninterrupted run, bit for bit; a run with other options on the same
DIR is refused in one line unless --restart. Small runs (3 steps, 4 trials per device per
call), and a 10,000-trial run.

Slow tier: each test starts real processes (five for the interruptions). Their fast counterparts
run by default: the chunks' resume, a full disk, damaged and lost chunks, the refusal of another
run's folder and --restart on the engine in one process (tests/core/robustness/test_chunks.py),
and SIGINT / SIGTERM ending a study with one line and no partial output
(tests/test_cli_reliability.py)."""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.slow

TRIALS = 120
BASE = ["robustness", "five-link", "--steps", "3", "--chunk", "4", "--devices", "2", "--seed", "2"]
#: a full disk after two chunks: the third chunk's write fails half-way (ENOSPC)
FULL_DISK = """
import errno, sys
from bipedlab.robustness import chunks
real, calls = chunks.write_atomic, []
def write_atomic(path, write):
    calls.append(path)
    if len(calls) == 4:
        def half(fh):
            fh.write(b"PK some bytes")
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(path, half)
    return real(path, write)
chunks.write_atomic = write_atomic
from bipedlab.cli import main
sys.exit(main(sys.argv[1:]))
"""


def _env():
    return dict(os.environ, JAX_PLATFORMS="cpu")


def _command(out: Path, *extra, trials=TRIALS):
    return [sys.executable, "-m", "bipedlab.cli", *BASE, "--trials", str(trials), "--out", str(out), "--json", *extra]


def _finish(argv, timeout=300):
    p = subprocess.run(argv, capture_output=True, text=True, env=_env(), timeout=timeout)
    return p.returncode, p.stdout, p.stderr


def _interrupt(out: Path, sig, after_chunks=3, timeout=300):
    """Start the run, wait until ``after_chunks`` chunk files are written, send ``sig``."""
    p = subprocess.Popen(_command(out), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env())
    deadline = time.monotonic() + timeout
    try:
        while len(list((out / "chunks").glob("chunk-*.npz"))) < after_chunks:
            assert p.poll() is None, "the run ended before it could be interrupted: " + p.stderr.read()[-2000:]
            assert time.monotonic() < deadline, "no chunk written in time"
            time.sleep(0.02)
        p.send_signal(sig)
        _, err = p.communicate(timeout=120)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    return p.returncode, err


def _same_outcomes(a: Path, b: Path):
    a, b = np.load(a / "outcomes.npz"), np.load(b / "outcomes.npz")
    assert sorted(a.files) == sorted(b.files)
    for k in a.files:
        assert a[k].dtype == b[k].dtype and a[k].shape == b[k].shape and a[k].tobytes() == b[k].tobytes(), k


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("five") / "uninterrupted"
    code, stdout, err = _finish(_command(out))
    assert code == 0, err[-3000:]
    rec = json.loads(stdout)
    assert rec["computed_trials"] == TRIALS and rec["chunk_files"] == TRIALS // 8
    assert 0 < rec["survival_rate"] < 1
    return out, rec


def _resume_and_compare(out: Path, reference):
    ref, rec = reference
    code, stdout, err = _finish(_command(out))
    assert code == 0, err[-3000:]
    got = json.loads(stdout)
    assert 0 < got["resumed_trials"] < TRIALS and got["computed_trials"] == TRIALS - got["resumed_trials"]
    assert f"resuming: {got['resumed_trials']} of {TRIALS} trials" in err
    _same_outcomes(ref, out)
    for k in ("survival_rate", "survival_map", "cell_trials", "fell_at_histogram", "median_final_deviation"):
        assert got[k] == rec[k], k
    return got


def _interrupted(out: Path, rc: int, err: str, sig, at_least: int) -> int:
    """The checks on a run stopped by ``sig`` once ``at_least`` chunks were written: its exit
    code (and last line for SIGINT), no outcomes, every chunk under its final name whole;
    returns the number of chunk files."""
    if sig == signal.SIGKILL:
        assert rc == -signal.SIGKILL, err[-3000:]
    else:
        assert rc == 130, err[-3000:]
        assert err.rstrip().endswith("bipedlab: interrupted")
    assert not (out / "outcomes.npz").exists()
    written = sorted((out / "chunks").glob("chunk-*.npz"))
    assert at_least <= len(written) < TRIALS // 8  # the signal landed mid-run
    for f in written:  # every chunk under its final name is whole
        with np.load(f) as z:
            assert {z[k].shape for k in z.files if k.startswith("out_")} == {(8,)}
    return len(written)


def test_a_full_disk_a_kill_and_an_interrupt_each_resume_to_the_uninterrupted_outcomes(reference, tmp_path):
    """One folder, four processes of the same command: stopped by a full disk at the third
    chunk (one line, status 1, two whole chunks kept); run again, it resumes those 16 trials and
    is killed (SIGKILL) once 4 chunks are written; run again, it resumes and is interrupted
    (SIGINT) once 8 are written; run again, it ends with the uninterrupted run's outcomes, bit
    for bit. Each stop leaves chunks the next run reads back, so a bad chunk from any of them
    changes the final outcomes."""
    out = tmp_path / "atlas"
    # a full disk after two chunks
    argv = [sys.executable, "-c", FULL_DISK, *_command(out)[3:]]
    code, stdout, err = _finish(argv)
    assert code == 1 and stdout == ""
    last = err.strip().splitlines()[-1]
    assert last.startswith("bipedlab: error: robustness five-link: could not write the outputs: No space left")
    assert "run the same command again to resume" in last
    assert sorted(p.name for p in (out / "chunks").iterdir()) == ["chunk-000000.npz", "chunk-000001.npz", "lock",
                                                                  "manifest.json"]
    assert sorted(p.name for p in out.iterdir()) == ["chunks"]
    assert not [p for p in out.parent.iterdir() if p.name.startswith(".bipedlab-tmp-")]  # staged outputs removed
    # run again: it resumes the two whole chunks (16 trials, not the half-written third) and is killed
    rc, err = _interrupt(out, signal.SIGKILL, after_chunks=4)
    assert f"resuming: 16 of {TRIALS} trials" in err, err[-3000:]
    killed_at = _interrupted(out, rc, err, signal.SIGKILL, 4)
    # run again: it resumes what the killed run wrote and is interrupted
    rc, err = _interrupt(out, signal.SIGINT, after_chunks=8)
    assert f"resuming: {8 * killed_at} of {TRIALS} trials" in err, err[-3000:]
    interrupted_at = _interrupted(out, rc, err, signal.SIGINT, 8)
    # run again: the rest, and the uninterrupted run's outcomes
    assert _resume_and_compare(out, reference)["resumed_trials"] == 8 * interrupted_at


def test_other_options_on_the_same_out_are_refused_then_restart(reference, tmp_path, capsys):
    """The refusal is checked in this process (bipedlab.cli.main; nothing is computed before
    it), on a copy of the uninterrupted run's folder; the --restart run is a real process."""
    import jax

    from bipedlab.cli import main

    jax.devices()  # this process's devices are up: the command's --devices 2 leaves them as they are
    ref, _ = reference
    out = tmp_path / "atlas"
    shutil.copytree(ref, out)
    argv = _command(out, trials=24)[3:]
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    captured = capsys.readouterr()
    stdout, err = captured.out, captured.err
    assert stdout == "", err
    errors = [line for line in err.splitlines() if line.startswith("bipedlab: error:")]
    assert len(errors) == 1 and errors[0] == err.strip().splitlines()[-1]
    assert errors[0].startswith("bipedlab: error: robustness five-link: --out: ")
    assert f"trials: {TRIALS} in the stored run, 24 now" in errors[0] and "--restart" in errors[0]
    assert not [p for p in out.parent.iterdir() if p.name.startswith(".bipedlab-tmp-")]  # staged outputs removed
    code, stdout, err = _finish(_command(out, "--restart", trials=24))
    assert code == 0, err[-3000:]
    assert json.loads(stdout)["resumed_trials"] == 0 and "discarded the chunks" in err


@pytest.mark.slow
def test_an_interrupted_ten_thousand_trial_study_resumes(tmp_path):
    """10,000 trials of two steps, 16 per device per call on two CPU devices (313 chunks):
    uninterrupted; then killed (SIGKILL) at a third, resumed and interrupted (SIGINT) at two
    thirds, resumed to the end: the same outcomes, bit for bit."""
    n = 10_000
    base = ["robustness", "five-link", "--steps", "2", "--chunk", "16", "--devices", "2", "--trials", str(n), "--json"]
    cmd = lambda out: [sys.executable, "-m", "bipedlab.cli", *base, "--out", str(out)]  # noqa: E731
    t0 = time.perf_counter()
    code, stdout, err = _finish(cmd(tmp_path / "whole"), timeout=3600)
    assert code == 0, err[-3000:]
    whole_s = time.perf_counter() - t0
    out = tmp_path / "resumed"
    t0 = time.perf_counter()
    for sig, at in ((signal.SIGKILL, 104), (signal.SIGINT, 209)):
        p = subprocess.Popen(cmd(out), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env())
        while len(list((out / "chunks").glob("chunk-*.npz"))) < at:
            assert p.poll() is None, p.stderr.read()[-2000:]
            time.sleep(0.05)
        p.send_signal(sig)
        p.communicate(timeout=120)
    code, stdout, err = _finish(cmd(out), timeout=3600)
    assert code == 0, err[-3000:]
    resumed_s = time.perf_counter() - t0
    got = json.loads(stdout)
    assert got["resumed_trials"] >= 209 * 32 and got["computed_trials"] == n - got["resumed_trials"]
    _same_outcomes(tmp_path / "whole", out)
    print(f"\n10,000 trials: uninterrupted {whole_s:.0f} s; killed, interrupted and resumed {resumed_s:.0f} s in all "
          f"(the last run computed {got['computed_trials']} trials); outcomes equal bit for bit")
