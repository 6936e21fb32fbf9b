"""The `bipedlab optimize` and `bipedlab walk` commands (five-link HZD studies).

The two walks (from the fixed point and perturbed, the same number of steps) run in this
process (``cli.main``, stdout and stderr captured: the record is the one line on stdout), so
the second reuses the first one's compiled Poincaré analysis and walk; the console script
itself runs as a subprocess for the exit status of bad input. The full optimisation (about a
minute) is marked slow; tests/robots/five_link/test_five_link_gait.py checks a few solver
iterations by default."""
from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

from bipedlab import cli
from helpers import expect_usage_error
from bipedlab.gait import gaitfile

WALK_KEYS = {
    "fell": bool, "steps_completed": int, "speed_mps": float, "step_length_m": float, "cmt": float,
    "max_abs_eigenvalue": float, "tracking_rms_rad": float, "initial_deviation": float,
    "final_deviation": float, "deviation_per_step": list, "poincare_eigenvalues": list,
    "restricted_eigenvalue": float, "status": str,
}
OPTIMIZE_KEYS = {
    "speed_mps": float, "step_length_m": float, "cmt": float, "max_abs_eigenvalue": float,
    "poincare_eigenvalues": list, "peak_torques_nm": list, "optimize_warm_s": float,
    "optimize_cold_s": float, "success": bool, "periodicity_error": float,
}


def _console_script():
    exe = os.path.join(os.path.dirname(sys.executable), "bipedlab")
    return [exe] if os.path.exists(exe) else [shutil.which("bipedlab") or "bipedlab"]


@pytest.fixture(scope="module")
def env(tmp_path_factory):
    # the run's shared cache (tests/conftest.py), so programs the in-process tests compiled are reused
    shared = os.environ.get("BIPEDLAB_TEST_XLA_CACHE") or str(tmp_path_factory.mktemp("bipedlab_cache"))
    return dict(os.environ, BIPEDLAB_CACHE_DIR=shared)


def _run(args, env, timeout=400):
    return subprocess.run(_console_script() + list(args), capture_output=True, text=True, env=env, timeout=timeout)


def _json_record(r):
    assert r.returncode == 0, r.stderr
    lines = r.stdout.strip().splitlines()
    assert len(lines) == 1, r.stdout  # --json: one object and nothing else on stdout
    return json.loads(lines[0])


def _check_types(rec, keys):
    for k, t in keys.items():
        assert k in rec, k
        v = rec[k]
        if t is float:
            assert isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v), (k, v)
        else:
            assert isinstance(v, t), (k, v)


def _main_json(args):
    """``bipedlab ARGS`` run in this process: its record, the one line it prints on stdout."""
    import contextlib
    import io

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = cli.main(list(args))
    assert status == 0, err.getvalue()
    lines = out.getvalue().strip().splitlines()
    assert len(lines) == 1, out.getvalue()  # --json: one object and nothing else on stdout
    return json.loads(lines[0])


#: steps of both walks: the step count is a static argument of the compiled walk, so one count
#: is one program (a second count compiled the whole walk again)
STEPS = 50


@pytest.fixture(scope="module")
def perturbed_walk():
    return _main_json(["walk", "five-link", "--perturb", "0.05", "--steps", str(STEPS), "--json"])


@pytest.fixture(scope="module")
def unperturbed_walk(perturbed_walk):  # after the perturbed run: its compiled programs are reused
    return _main_json(["walk", "five-link", "--steps", str(STEPS), "--json"])


def test_walk_from_the_fixed_point_json(unperturbed_walk):
    """From the fixed point the walk stays on the orbit: 50 steps end 1.0e-6 from it (the
    closed loop's own fixed point, which the design's RK4 in the phase puts there; 7e-7 after
    3 steps)."""
    r = unperturbed_walk
    _check_types(r, WALK_KEYS)
    assert r["fell"] is False and r["status"] == "ok"
    assert r["steps_completed"] == STEPS
    assert r["speed_mps"] == pytest.approx(0.8, rel=0.05)
    assert 0.0 < r["max_abs_eigenvalue"] < 1.0
    assert r["max_abs_eigenvalue"] == pytest.approx(max(r["poincare_eigenvalues"]), rel=1e-12)
    assert r["max_abs_eigenvalue"] == pytest.approx(r["restricted_eigenvalue"], abs=1e-3)
    # from the fixed point: on the orbit, on Z, at the designed figures
    gait = gaitfile.shipped("bipedlab.robots.five_link", "five_link_0.8")[2]["design"]
    assert r["initial_deviation"] == 0.0
    assert r["final_deviation"] < 1e-5
    assert r["tracking_rms_rad"] < 1e-6
    assert r["step_length_m"] == pytest.approx(gait["step_length_m"], abs=1e-5)
    assert r["cmt"] == pytest.approx(gait["cmt"], rel=1e-2)
    assert r["gait_speed_mps"] == pytest.approx(0.8, abs=1e-9)


def test_walk_from_a_perturbed_state_converges(perturbed_walk, unperturbed_walk):
    r = perturbed_walk
    _check_types(r, WALK_KEYS)
    assert r["fell"] is False and r["steps_completed"] == STEPS
    assert r["initial_deviation"] > 0.1
    assert r["final_deviation"] < 1e-4 * r["initial_deviation"]
    dev = np.asarray(r["deviation_per_step"])
    assert dev.size == STEPS
    # early on the distance shrinks about like the dominant Poincaré eigenvalue per step
    ratios = dev[6:16] / dev[5:15]
    assert np.all(ratios < 1.0)
    assert np.median(ratios) == pytest.approx(r["max_abs_eigenvalue"], abs=0.05)
    # the converged walk is the unperturbed one
    assert r["speed_mps"] == pytest.approx(0.8, rel=0.05)
    assert r["max_abs_eigenvalue"] == unperturbed_walk["max_abs_eigenvalue"]


# ---- bad input: status 2, one line on stderr ----------------------------------------------

@pytest.mark.parametrize("argv", [
    ["walk", "five-link", "--steps", "0"],
    ["walk", "five-link", "--steps", "-2"],
    ["walk", "five-link", "--steps", "two"],
    ["walk", "five-link", "--perturb", "-0.1"],
    ["walk", "five-link", "--perturb", "nan"],
    ["walk", "five-link", "--controller", "lqr"],
    ["walk", "six-link"],
    ["walk"],
    ["optimize", "six-link"],
    ["optimize", "five-link", "--speed", "0"],
    ["optimize", "five-link", "--speed", "inf"],
    ["optimize", "five-link", "--cost", "energy"],
])
def test_bad_arguments_exit_2_with_one_line(argv, capsys):
    expect_usage_error(argv, capsys)


@pytest.fixture
def no_compile_cache(monkeypatch):
    """main() points JAX's compilation cache at a directory before loading the gait: keep the
    test process's JAX configuration untouched."""
    monkeypatch.setattr(cli, "_enable_compile_cache", lambda: None)


def _bad_gait_files(tmp_path):
    vc, z, rec = gaitfile.shipped("bipedlab.robots.five_link", "five_link_0.8")
    d = gaitfile.to_dict("five-link", vc, z, rec["design"])
    files = {}
    files["not_json.json"] = "{this is not json"
    files["wrong_format.json"] = json.dumps(dict(d, format="something-else/2"))
    files["missing_field.json"] = json.dumps(dict(d, payload={k: v for k, v in d["payload"].items() if k != "z_minus"}))
    files["bad_sizes.json"] = json.dumps(dict(d, payload=dict(d["payload"], c=d["payload"]["c"][:3])))
    out = {}
    for name, text in files.items():
        p = tmp_path / name
        p.write_text(text)
        out[name] = p
    out["missing.json"] = tmp_path / "missing.json"
    return out


def test_bad_gait_files_exit_2_naming_the_file(tmp_path, capsys, no_compile_cache):
    for name, path in _bad_gait_files(tmp_path).items():
        expect_usage_error(["walk", "five-link", "--gait", str(path), "--json"], capsys, needle=str(path))


@pytest.mark.parametrize("case", ["theta_minus_inf", "c_nan", "four_link_sizes"])
def test_gait_files_unusable_for_the_robot_exit_2(case, tmp_path, capsys, monkeypatch, no_compile_cache):
    from bipedlab.robots.five_link import study as hz

    def reached(*args, **kwargs):
        raise AssertionError("the walk started with an unusable gait file")

    monkeypatch.setattr(hz, "walk", reached)
    vc, z, rec = gaitfile.shipped("bipedlab.robots.five_link", "five_link_0.8")
    d = gaitfile.to_dict("five-link", vc, z, rec["design"])["payload"]
    d.update(format=gaitfile.HZD_V1, robot="five-link")  # a version-1 file: the payload alone
    if case == "theta_minus_inf":
        d["theta_minus"] = float("inf")
    elif case == "c_nan":
        d["c"] = [float("nan")] * 5
    else:  # consistent sizes, but for a robot with four stance coordinates
        d["H0"] = [row[:4] for row in d["H0"][:3]]
        d["c"] = d["c"][:4]
        d["alpha"] = d["alpha"][:3]
        d["z_minus"] = d["z_minus"][:4] + d["z_minus"][5:9]
    path = tmp_path / f"{case}.json"
    path.write_text(json.dumps(d))
    expect_usage_error(["walk", "five-link", "--gait", str(path), "--json"], capsys, needle=str(path))


def test_bad_gait_file_from_the_console_script(tmp_path, env):
    path = _bad_gait_files(tmp_path)["not_json.json"]
    r = _run(["walk", "five-link", "--gait", str(path), "--steps", "3", "--json"], env, timeout=120)
    assert r.returncode == 2
    assert r.stdout == ""
    lines = r.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("bipedlab: error: "), r.stderr
    assert str(path) in lines[0]


# ---- the full optimisation (slow) -----------------------------------------------------------

@pytest.mark.slow
def test_optimize_finds_a_stable_gait_at_the_requested_speed(tmp_path, env):
    save = tmp_path / "gait.json"
    rec = _json_record(_run(["optimize", "five-link", "--speed", "0.8", "--json", "--save", str(save)], env,
                            timeout=600))
    _check_types(rec, OPTIMIZE_KEYS)
    assert rec["success"] is True
    assert rec["speed_mps"] == pytest.approx(0.8, abs=1e-6)
    assert 0.0 < rec["max_abs_eigenvalue"] < 1.0
    assert rec["periodicity_error"] < 1e-8
    assert len(rec["peak_torques_nm"]) == 4 and all(0 < v < 200 for v in rec["peak_torques_nm"])
    # the saved gait is a valid gait file whose fixed point lies on its own constraints
    vc, z, saved = gaitfile.load(save)
    assert saved["design"]["speed_mps"] == pytest.approx(rec["speed_mps"], abs=1e-12)
    shipped_vc, shipped_z, _ = gaitfile.shipped("bipedlab.robots.five_link", "five_link_0.8")
    # same problem, same start, same solver: the shipped gait is this design
    np.testing.assert_allclose(np.asarray(z), np.asarray(shipped_z), atol=1e-4)
    np.testing.assert_allclose(np.asarray(vc.alpha), np.asarray(shipped_vc.alpha), atol=1e-4)
