"""Resuming a robustness run from its chunks (the pendulum study of test_engine, which compiles
in seconds): what an interruption leaves — chunks missing, a chunk cut short, a writer's
temporary file, a full disk — is computed again or never read, and the resumed run ends with
the uninterrupted run's outcomes bit for bit; a folder of another run is refused unless
restarted; two processes resume from process 0's chunks. The command-line version (SIGKILL and
SIGINT of a real five-link run) is tests/test_robustness_resume.py."""
from __future__ import annotations

import errno
import json
import shutil

import numpy as np
import pytest

from bipedlab.outputs import dumps_json
from bipedlab.robustness import chunks, engine

from .pendulum_study import study
from .test_distributed import SCRIPT, free_port, launch

TRIALS, SEED, CHUNK = 37, 3, 3


def _run(out, **kw):
    kw.setdefault("chunk", CHUNK)
    return engine.run(study(), kw.pop("trials", TRIALS), seed=kw.pop("seed", SEED), out=str(out), progress=False,
                      **kw)


def _same_outcomes(a, b):
    a, b = np.load(a / "outcomes.npz"), np.load(b / "outcomes.npz")
    assert sorted(a.files) == sorted(b.files)
    for k in a.files:  # bit for bit: dtype, shape and bytes
        assert a[k].dtype == b[k].dtype and a[k].shape == b[k].shape and a[k].tobytes() == b[k].tobytes(), k


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    d = tmp_path_factory.mktemp("reference")
    rec = _run(d)
    return d, rec


def test_a_run_writes_one_chunk_per_call_and_a_manifest(reference):
    d, rec = reference
    names = sorted(p.name for p in (d / "chunks").iterdir())
    assert names == [chunks.chunk_name(i) for i in range(rec["chunk_files"])] + ["lock", "manifest.json"]
    assert rec["chunk_files"] == rec["padded_to"] // (rec["chunk_per_device"] * rec["devices"])
    assert (rec["computed_trials"], rec["resumed_trials"]) == (TRIALS, 0)
    m = json.loads((d / "chunks" / "manifest.json").read_text())
    assert (m["trials"], m["seed"], m["chunk_per_device"], m["devices"]) == (TRIALS, SEED, rec["chunk_per_device"],
                                                                             rec["devices"])
    assert len(m["code"]["source"]) == 64 and m["params_sha256"]


def test_lost_and_damaged_chunks_are_computed_again(reference, tmp_path):
    d, rec = reference
    shutil.copytree(d / "chunks", tmp_path / "chunks")
    last = rec["chunk_files"] - 1
    (tmp_path / "chunks" / chunks.chunk_name(1)).unlink()
    (tmp_path / "chunks" / chunks.chunk_name(last)).unlink()
    with open(tmp_path / "chunks" / chunks.chunk_name(2), "r+b") as fh:  # cut short (a copy interrupted)
        fh.truncate(200)
    tmp = tmp_path / "chunks" / f".{chunks.chunk_name(3)}.tmp-99999"  # a killed writer's half-written file
    tmp.write_bytes(b"PK\x03\x04 half")
    got = _run(tmp_path)
    assert not tmp.exists()
    n = rec["chunk_per_device"] * rec["devices"]
    assert got["computed_trials"] == 2 * n + (TRIALS - last * n) and got["resumed_trials"] == TRIALS - got["computed_trials"]
    _same_outcomes(d, tmp_path)
    for k in ("survival_rate", "survival_map", "cell_trials", "fell_at_histogram", "fell", "nonfinite"):
        assert got[k] == rec[k], k


def test_a_finished_run_reads_everything_back(reference, tmp_path):
    d, rec = reference
    shutil.copytree(d / "chunks", tmp_path / "chunks")
    got = _run(tmp_path)
    assert (got["computed_trials"], got["resumed_trials"], got["compile_s"]) == (0, TRIALS, 0.0)  # nothing compiled
    assert "no trial computed" in engine.summary(got) and f"resumed: {TRIALS} trials" in engine.summary(got)
    assert json.loads(dumps_json(got))["trials_per_s"] is None
    _same_outcomes(d, tmp_path)


@pytest.mark.parametrize("change, words", [
    (dict(seed=SEED + 1), "seed: 3 in the stored run, 4 now"),
    (dict(trials=TRIALS + 1), "trials: 37 in the stored run, 38 now"),
    (dict(chunk=CHUNK + 1), "chunk_per_device"),
    (dict(key=dict(gait="other")), "arguments.gait"),
])
def test_another_run_is_refused_and_restart_starts_over(reference, tmp_path, change, words):
    d, _ = reference
    shutil.copytree(d / "chunks", tmp_path / "chunks")
    before = sorted((p.name, p.read_bytes()) for p in (tmp_path / "chunks").iterdir())
    with pytest.raises(chunks.ResumeError) as e:
        _run(tmp_path, **change)
    assert words in str(e.value) and "another run" in str(e.value) and "\n" not in str(e.value)
    assert sorted((p.name, p.read_bytes()) for p in (tmp_path / "chunks").iterdir()) == before  # nothing touched
    got = _run(tmp_path, restart=True, **change)
    assert got["resumed_trials"] == 0


def test_one_run_at_a_time_holds_a_folder(tmp_path):
    m = dict(format=chunks.FORMAT, trials=1)
    held = chunks.Store(tmp_path / "c", m)
    try:
        with pytest.raises(chunks.ResumeError, match="in use by another run"):
            chunks.Store(tmp_path / "c", m)
    finally:
        held.close()
    chunks.Store(tmp_path / "c", m).close()  # released


def test_a_full_disk_keeps_the_chunks_written_and_leaves_no_half_file(reference, tmp_path, monkeypatch):
    d, rec = reference
    real = chunks.write_atomic
    calls = []

    def full_disk(path, write):
        calls.append(path)
        if len(calls) == 4:  # the manifest, chunks 0 and 1, then the disk is full mid-write of chunk 2

            def half(fh):
                fh.write(b"PK\x03\x04 some bytes")
                raise OSError(errno.ENOSPC, "No space left on device")

            return real(path, half)
        return real(path, write)

    monkeypatch.setattr(chunks, "write_atomic", full_disk)
    with pytest.raises(OSError) as e:
        _run(tmp_path)
    assert e.value.errno == errno.ENOSPC and str(e.value.filename).endswith(chunks.chunk_name(2))
    monkeypatch.undo()
    left = sorted(p.name for p in (tmp_path / "chunks").iterdir())
    assert left == [chunks.chunk_name(0), chunks.chunk_name(1), "lock", "manifest.json"]
    assert not (tmp_path / "outcomes.npz").exists()
    got = _run(tmp_path)
    n = rec["chunk_per_device"] * rec["devices"]
    assert got["resumed_trials"] == 2 * n
    _same_outcomes(d, tmp_path)


def test_two_processes_resume_from_process_0s_chunks(tmp_path):
    """Two processes, one device each: a run, one chunk lost, the run again: every process
    reads back what process 0 held (broadcast), the outcomes are the one-process run's."""
    one, two = tmp_path / "one", tmp_path / "two"
    trials, seed = 30, 7
    port = free_port()
    launch([[SCRIPT, str(one), str(trials), str(seed)]]
           + [[SCRIPT, str(two), str(trials), str(seed), f"127.0.0.1:{port}", "2", str(i)] for i in (0, 1)])
    files = sorted((two / "chunks").glob("chunk-*.npz"))
    assert len(files) >= 2
    files[0].unlink()
    (two / "outcomes.npz").unlink()
    port = free_port()
    launch([[SCRIPT, str(two), str(trials), str(seed), f"127.0.0.1:{port}", "2", str(i)] for i in (0, 1)])
    r = json.loads((two / "record.json").read_text())
    assert r["processes"] == 2 and 0 < r["resumed_trials"] < trials
    _same_outcomes(one, two)
