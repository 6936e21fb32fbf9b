"""The `bipedlab` command: help, one-line errors with status 2, and the bench JSON record."""
from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys

import pytest

from bipedlab.cli import main

BENCH_KEYS = ("bipedlab_substeps_per_s", "mujoco_substeps_per_s", "ratio_vs_mujoco",
              "batched_ratio_vs_mujoco", "compile_s", "device", "dtype", "batched")


def _console_script():
    exe = os.path.join(os.path.dirname(sys.executable), "bipedlab")
    return [exe] if os.path.exists(exe) else [shutil.which("bipedlab") or "bipedlab"]


def _run(args, env=None, timeout=300):
    return subprocess.run(_console_script() + list(args), capture_output=True, text=True, env=env, timeout=timeout)


def test_no_arguments_prints_help_listing_studies():
    r = _run([])
    assert r.returncode == 0, r.stderr
    assert "usage: bipedlab" in r.stdout
    studies = r.stdout.split("studies:", 1)[1]
    assert "bench" in studies


def test_main_without_arguments_returns_zero(capsys):
    assert main([]) == 0
    out = capsys.readouterr().out
    assert "bench" in out and "studies:" in out


@pytest.mark.parametrize("argv", [
    ["bench", "--batch", "0"],
    ["bench", "--batch", "-3"],
    ["bench", "--seconds", "0"],
    ["bench", "--seconds", "nan"],
    ["bench", "--seconds", "abc"],
    ["no-such-study"],
    ["bench", "--no-such-option"],
])
def test_bad_input_is_one_error_line_and_status_2(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("bipedlab: error: "), captured.err


def test_bad_input_exit_status_from_the_console_script():
    for argv in (["bench", "--batch", "0"], ["frobnicate"]):
        r = _run(argv)
        assert r.returncode == 2
        assert r.stdout == ""
        lines = r.stderr.splitlines()
        assert len(lines) == 1 and lines[0].startswith("bipedlab: error: "), r.stderr
    assert "frobnicate" in r.stderr


@pytest.fixture(scope="module")
def bench_records(tmp_path_factory):
    """`bench --json` without and with MuJoCo. The two runs compile the same programs, so a
    shared JAX compilation cache spares the second run its compile time."""
    env = dict(os.environ, JAX_COMPILATION_CACHE_DIR=str(tmp_path_factory.mktemp("jax_cache")))
    out = {}
    for label, extra in (("no_mujoco", ["--no-mujoco"]), ("mujoco", [])):
        r = _run(["bench", "--json", "--seconds", "0.02", "--batch", "2", *extra], env=env)
        assert r.returncode == 0, r.stderr
        lines = r.stdout.strip().splitlines()
        assert len(lines) == 1, r.stdout  # one JSON object and nothing else on stdout
        out[label] = json.loads(lines[0])
    return out


def _positive_number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0


def _check_common(rec):
    for k in BENCH_KEYS:
        assert k in rec, k
    assert _positive_number(rec["bipedlab_substeps_per_s"])
    assert isinstance(rec["compile_s"], float) and math.isfinite(rec["compile_s"])
    assert rec["dtype"] == "float64"
    assert isinstance(rec["device"], str) and rec["device"]
    assert rec["substeps_per_rollout"] == 80  # 0.02 s at 0.25 ms
    batches = [b["batch"] for b in rec["batched"]]
    assert batches == [2, 64]  # the requested size and MuJoCo's batch of 64
    for b in rec["batched"]:
        assert _positive_number(b["substeps_per_s"])
        assert b["all_finite"] is True


def test_bench_json_without_mujoco(bench_records):
    rec = bench_records["no_mujoco"]
    _check_common(rec)
    for k in ("mujoco_substeps_per_s", "ratio_vs_mujoco", "batched_ratio_vs_mujoco",
              "ratio_vs_mujoco_point_feet", "batched_ratio_vs_mujoco_point_feet"):
        assert rec.get(k) is None, k


def test_bench_json_with_mujoco(bench_records):
    pytest.importorskip("mujoco")
    rec = bench_records["mujoco"]
    _check_common(rec)
    for k in ("mujoco_substeps_per_s", "ratio_vs_mujoco", "batched_ratio_vs_mujoco"):
        assert _positive_number(rec[k]), (k, rec[k])
    assert rec["ratio_vs_mujoco"] == pytest.approx(rec["bipedlab_substeps_per_s"] / rec["mujoco_substeps_per_s"])
    b64 = next(b for b in rec["batched"] if b["batch"] == 64)
    assert rec["batched_ratio_vs_mujoco"] == pytest.approx(
        b64["substeps_per_s"] / rec["mujoco_batched_substeps_per_s"])
    assert isinstance(rec["mujoco"]["version"], str)
    # the same figures against the point-feet MuJoCo model
    pf = rec["mujoco_point_feet"]
    for k in ("ratio_vs_mujoco_point_feet", "batched_ratio_vs_mujoco_point_feet"):
        assert _positive_number(rec[k]), (k, rec[k])
    assert rec["ratio_vs_mujoco_point_feet"] == pytest.approx(
        rec["bipedlab_substeps_per_s"] / pf["single_substeps_per_s"])
    assert rec["batched_ratio_vs_mujoco_point_feet"] == pytest.approx(
        b64["substeps_per_s"] / pf["batched_substeps_per_s"])


def test_bench_simulates_the_scenario(bench_records):
    # 20 ms from rest with the joints at their references: no joint torque, feet still
    # 1.6 cm above the ground, so the hip is in free fall: y = 0.78 - g t^2 / 2
    for rec in bench_records.values():
        assert rec["final_hip_height_m"] == pytest.approx(0.78 - 0.5 * 9.81 * 0.02**2, abs=1e-9)
