"""Edge cases at the command line's boundary, each ending in exit status 2 and one
``bipedlab: error:`` line (no traceback, no hang): the multi-process launch read from the
environment and options (SLURM_NTASKS, JAX_NUM_PROCESSES, JAX_PROCESS_ID, HOST:PORT, a
coordinator nobody answers), a gait file of another robot, log folders holding what is not a
regular file, a model file MuJoCo's compiler rejects, and what an identification from a few
logs could not determine."""
from __future__ import annotations

import importlib.resources
import json
import os
import socket
import subprocess
import sys
import time

import numpy as np
import pytest
from helpers import expect_usage_error

from bipedlab import cli

FIVE_LINK_GAIT = str(importlib.resources.files("bipedlab.robots.five_link") / "data" / "five_link_0.8.json")
MABEL_GAIT = str(importlib.resources.files("bipedlab.robots.mabel") / "data" / "mabel_nominal.json")
RABBIT_GAIT = str(importlib.resources.files("bipedlab.robots.imported") / "data" / "rabbit_0.8.json")
RABBIT = str(importlib.resources.files("bipedlab.robots.imported") / "data" / "rabbit.xml")
LAUNCH_ENV = ("SLURM_NTASKS", "SLURM_PROCID", "SLURM_LOCALID", "SLURM_JOB_ID", "SLURM_STEP_NODELIST",
              "JAX_COORDINATOR_ADDRESS", "JAX_NUM_PROCESSES", "JAX_PROCESS_ID", "JAX_LOCAL_DEVICE_IDS")
ROBUSTNESS = ["robustness", "five-link", "--trials", "1", "--steps", "1", "--devices", "1"]


@pytest.fixture
def clean_env(monkeypatch):
    for k in LAUNCH_ENV:
        monkeypatch.delenv(k, raising=False)
    return monkeypatch


def _one_error_line(err: str) -> str:
    lines = [ln for ln in err.splitlines() if not ln.startswith("[bipedlab]")]
    assert len(lines) == 1 and lines[0].startswith("bipedlab: error: "), err[-3000:]
    assert "Traceback" not in err, err[-3000:]
    return lines[0]


def _console(argv, timeout, env=None, cwd=None):
    t0 = time.monotonic()
    r = subprocess.run([sys.executable, "-m", "bipedlab.cli", *argv], capture_output=True, text=True, timeout=timeout,
                       env=dict(os.environ, JAX_PLATFORMS="cpu", **(env or {})), cwd=cwd)
    return r, time.monotonic() - t0


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# ----------------------------------------------------------------------------- 1. launch variables
@pytest.mark.parametrize("env,name", [
    ({"SLURM_NTASKS": "two"}, "SLURM_NTASKS"), ({"SLURM_NTASKS": "0"}, "SLURM_NTASKS"),
    ({"SLURM_NTASKS": "-3"}, "SLURM_NTASKS"), ({"SLURM_NTASKS": "1.5"}, "SLURM_NTASKS"),
    ({"SLURM_NTASKS": "\u0663"}, "SLURM_NTASKS"), ({"JAX_NUM_PROCESSES": "two"}, "JAX_NUM_PROCESSES"),
    ({"JAX_NUM_PROCESSES": "0"}, "JAX_NUM_PROCESSES"), ({"JAX_PROCESS_ID": "x"}, "JAX_PROCESS_ID"),
    ({"JAX_PROCESS_ID": "-1"}, "JAX_PROCESS_ID"), ({"SLURM_PROCID": "first"}, "SLURM_PROCID"),
    ({"JAX_COORDINATOR_ADDRESS": "notahost"}, "JAX_COORDINATOR_ADDRESS"),
    ({"JAX_NUM_PROCESSES": "2", "JAX_PROCESS_ID": "0", "JAX_COORDINATOR_ADDRESS": "h:1",
      "JAX_LOCAL_DEVICE_IDS": "a,b"}, "JAX_LOCAL_DEVICE_IDS"),
], ids=lambda v: ",".join(f"{k}={x}" for k, x in v.items()) if isinstance(v, dict) else "")
def test_a_bad_launch_variable_is_one_line_naming_it(env, name, clean_env, capsys):
    for k, v in env.items():
        clean_env.setenv(k, v)
    expect_usage_error(ROBUSTNESS, capsys, needle=f"${name}")


def test_slurm_without_its_job_variables_is_refused(clean_env, capsys):
    clean_env.setenv("SLURM_NTASKS", "2")
    clean_env.setenv("SLURM_JOB_ID", "7")
    line = expect_usage_error(ROBUSTNESS, capsys, needle="$SLURM_NTASKS")
    assert "SLURM_STEP_NODELIST" in line


def test_valid_launch_variables_are_read(clean_env):
    clean_env.setenv("JAX_NUM_PROCESSES", " 2 ")
    clean_env.setenv("JAX_PROCESS_ID", "1")
    clean_env.setenv("JAX_COORDINATOR_ADDRESS", "[::1]:1234")
    _, args = cli.parse(ROBUSTNESS)
    assert (args.num_processes, args.process_id, args.coordinator) == (2, 1, "[::1]:1234")


# ----------------------------------------------------------------------------- 2. HOST:PORT
@pytest.mark.parametrize("value", ["notahost", "host:", ":1234", "host:0", "host:65536", "host:12a", "a b:12",
                                   "host:+80", "[::1", "::1:80"])
def test_the_coordinator_is_host_colon_port(value, clean_env, capsys):
    line = expect_usage_error(ROBUSTNESS + ["--num-processes", "2", "--process-id", "0", f"--coordinator={value}"],
                              capsys, needle="--coordinator")
    assert "HOST:PORT" in line and "[1, 65535]" in line


# ----------------------------------------------------------------------------- 3. nobody answers
def test_init_timeout_is_documented():
    helptext = cli.command_parsers(cli.build_parser())["robustness five-link"].format_help()
    assert "--init-timeout" in helptext and "default 60" in helptext


@pytest.mark.parametrize("pid", [0, 1])
def test_a_coordinator_nobody_answers_ends_within_the_timeout(pid, tmp_path):
    """Process 0 listens and waits for the others; another process waits for the coordinator:
    either ends after --init-timeout with one line, and leaves no output behind."""
    port = _free_port()
    out = tmp_path / "res"
    r, dt = _console(ROBUSTNESS + ["--num-processes", "2", "--process-id", str(pid), "--coordinator",
                                   f"127.0.0.1:{port}", "--init-timeout", "2", "--out", str(out)], timeout=120,
                     cwd=tmp_path)
    assert r.returncode == 2 and r.stdout == "", r.stderr[-3000:]
    line = _one_error_line(r.stderr)
    assert f"127.0.0.1:{port}" in line and "2 s" in line, line
    assert dt < 60
    assert list(tmp_path.iterdir()) == []


# ----------------------------------------------------------------------------- 4. another robot's gait
@pytest.mark.parametrize("argv,robots", [
    (["robustness", "mabel", "--gait", FIVE_LINK_GAIT, "--trials", "1", "--devices", "1"], ("five-link", "mabel")),
    (["walk", "mabel", "--gait", FIVE_LINK_GAIT, "--steps", "1"], ("five-link", "mabel")),
    (["walk", "five-link", "--gait", MABEL_GAIT, "--steps", "1"], ("mabel", "five-link")),
    (["walk", "five-link", "--gait", RABBIT_GAIT, "--steps", "1"], ("model", "five-link")),
    (["walk", "model", RABBIT, "--gait", FIVE_LINK_GAIT, "--steps", "1"], ("five-link", "model")),
    (["robustness", "model", RABBIT, "--gait", MABEL_GAIT, "--trials", "1", "--devices", "1"], ("mabel", "model")),
], ids=lambda v: " ".join(v[:2]) if isinstance(v, list) else None)
def test_a_gait_of_another_robot_names_both(argv, robots, clean_env, capsys):
    line = expect_usage_error(argv, capsys, needle="robot")
    got, want = robots
    assert f"'{got}'" in line and f"'{want}'" in line, line


# ----------------------------------------------------------------------------- 5. not regular files
def test_a_fifo_among_the_logs_is_refused_without_opening_it(tmp_path):
    data = tmp_path / "logs"
    data.mkdir()
    os.mkfifo(data / "a.csv")
    r, dt = _console(["identify", "mabel", "--data", str(data)], timeout=60)
    assert r.returncode == 2 and r.stdout == ""
    line = _one_error_line(r.stderr)
    assert "a.csv" in line and "FIFO" in line, line


@pytest.mark.parametrize("kind", ["directory", "symlink loop", "/dev/null", "/dev/zero", "dangling symlink"])
def test_what_is_not_a_regular_file_among_the_logs_is_refused(kind, tmp_path, capsys):
    data = tmp_path / "logs"
    data.mkdir()
    target = data / "a.csv"
    if kind == "directory":
        target.mkdir()
    elif kind == "symlink loop":
        os.symlink(data / "b.csv", target)
        os.symlink(target, data / "b.csv")
    elif kind == "dangling symlink":
        os.symlink(data / "nowhere", target)
    else:
        os.symlink(kind, target)
    args = _parse_only(["identify", "mabel", "--data", str(data)], capsys)
    assert args is None
    line = capsys.readouterr().err.strip()
    assert line.startswith("bipedlab: error: ") and "\n" not in line and "a.csv" in line, line


def _parse_only(argv, capsys):
    try:
        return cli.parse(argv)[1]
    except SystemExit as e:
        assert e.code == 2
        return None


def _fifo(path):
    """A FIFO at path; a writer opens and closes it after 5 s, so that a reader that opens it
    anyway ends (reading nothing) instead of waiting for ever."""
    import threading

    os.mkfifo(path)

    def release():
        time.sleep(5.0)
        try:
            fd = os.open(path, os.O_WRONLY | os.O_NONBLOCK)
            os.close(fd)
        except OSError:  # nobody is reading: nothing to release
            pass

    threading.Thread(target=release, daemon=True).start()
    return path


def test_the_log_reader_refuses_a_fifo_without_opening_it(tmp_path):
    from bipedlab.robots.mabel.sysid.logs import LogError, read_log

    t0 = time.monotonic()
    with pytest.raises(LogError, match=r"a\.csv: .*FIFO"):
        read_log(_fifo(tmp_path / "a.csv"))
    assert time.monotonic() - t0 < 4.5  # the writer releases the FIFO after 5 s


def test_the_gait_reader_refuses_a_fifo_without_opening_it(tmp_path):
    from bipedlab.gait import schema

    t0 = time.monotonic()
    with pytest.raises(ValueError, match=r"g\.json: .*FIFO"):
        schema.read_json(_fifo(tmp_path / "g.json"))
    assert time.monotonic() - t0 < 4.5  # the writer releases the FIFO after 5 s


# ----------------------------------------------------------------------------- 6. MuJoCo's messages
def test_an_mjcf_the_compiler_rejects_is_one_line(tmp_path, capfd, monkeypatch):
    pytest.importorskip("mujoco")
    text = open(RABBIT).read()
    i = text.index('mass="')
    j = text.index('"', i + 6)
    bad = tmp_path / "nan.xml"
    bad.write_text(text[:i] + 'mass="nan"' + text[j + 1:])
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exc:
        cli.main(["optimize", "model", str(bad), "--stance", "left_foot", "--swing", "right_foot"])
    assert exc.value.code == 2
    cap = capfd.readouterr()
    assert cap.out == ""
    line = _one_error_line(cap.err)
    assert "nan.xml" in line and "mass" in line and "NaN" in line, line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["nan.xml"]  # no MUJOCO_LOG.TXT


# ----------------------------------------------------------------------------- 7. what was not identified
def _rotor(u, J=3e-4, mu=2e-3, bias=0.01, h=1e-3):
    w, th, out = 0.0, 0.0, []
    for v in u:
        out.append(th)
        th += h * w
        w += h * (v + bias - mu * w) / J
    return np.array(out)


def _bias_log():
    from bipedlab.robots.mabel.sysid.logs import Experiment

    t = np.arange(400) * 1e-3
    u = 0.02 * np.sin(2 * np.pi * 3 * t) + 0.01 * np.sin(2 * np.pi * 11 * t)
    return Experiment("bias_mLA_L", "bias", t, {"mLA_L": u}, {"mla_L": _rotor(u)}, meta=dict(actuator="mLA_L"))


def test_one_bias_log_says_what_it_did_not_identify(tmp_path, capsys):
    from bipedlab.robots.mabel.sysid.logs import write_log

    write_log(_bias_log(), tmp_path / "bias.csv")
    assert cli.main(["identify", "mabel", "--data", str(tmp_path), "--json"]) == 0
    cap = capsys.readouterr()
    rec = json.loads(cap.out)
    missing = {row["group"]: row for row in rec["not_identified"]}
    assert {"motor_constant", "rotor_inertia_scale", "friction", "spring_stiffness", "cable_stretch", "hard_stop",
            "ground", "bias"} <= set(missing)
    assert "transmission" in missing["motor_constant"]["why"] and "hopping" in missing["ground"]["why"]
    assert "bias_mLA_L" not in missing["bias"]["parameters"] and "bias_mLS_L" in missing["bias"]["parameters"]
    assert all(row["parameters"] and row["why"] for row in rec["not_identified"])
    rows = {p["name"]: p for p in rec["parameters"]}
    assert rows["bias_mLA_L"]["identified"] is True and rows["kt_mLA_L"]["identified"] is False
    said = [ln for ln in cap.err.splitlines() if "not identified" in ln]
    assert len(said) == 1 and "motor_constant" in said[0], cap.err


def test_logs_that_identify_nothing_are_refused(tmp_path, capsys):
    from bipedlab.robots.mabel.sysid.logs import Experiment, write_log

    t = np.arange(200) * 1e-3
    u = 0.02 * np.sin(2 * np.pi * 3 * t) + 0.01 * np.sin(2 * np.pi * 11 * t)
    write_log(Experiment("transmission_mLS_R_2", "transmission", t, {"mLS_R": u}, {"mls_R": _rotor(u, J=6e-4)},
                         meta=dict(actuator="mLS_R", combination=2, cad_inertia=2.4e-4)), tmp_path / "t.csv")
    line = expect_usage_error(["identify", "mabel", "--data", str(tmp_path)], capsys, needle="no parameter")
    assert "two or more transmission logs" in line, line


def test_a_nan_in_a_model_is_one_line_naming_the_attribute(tmp_path, capsys):
    """A NaN is found before MuJoCo compiles the file (which warned on a second line and then
    blamed the body's mass and inertia)."""
    bad = tmp_path / "bad.xml"
    bad.write_text('<mujoco><worldbody><body name="torso" pos="0 0 1"><joint name="rootx" type="slide" axis="1 0 0"/>'
                   '<geom type="capsule" size="0.05" fromto="0 0 0 0 0 0.5" mass="nan"/></body></worldbody></mujoco>')
    line = expect_usage_error(["optimize", "model", str(bad), "--stance", "a", "--swing", "b"], capsys, needle="bad.xml")
    assert "mass='nan'" in line and "NaN" in line, line


def test_a_warning_is_one_line():
    assert cli._warning_line("first\nsecond", RuntimeWarning, "f.py", 1).count("\n") == 1
