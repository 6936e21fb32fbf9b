"""``bipedlab robustness five-link``: its trials are the walks of ``walk five-link`` (same closed
loop, same perturbed state, one trial at a time), the gait's fixed point survives and stays on
itself, and two jax.distributed CPU processes give the one-process result trial by trial.
The five-link walk compiles for about a minute, so the study checks are slow; the option checks
and the short distributed check (tests/core/robustness) run by default."""
from __future__ import annotations

import dataclasses
import os
import subprocess
import sys

import numpy as np
import pytest

from bipedlab import cli

STEPS = 4
POINTS = dict(rate_scale=np.array([0.0, 0.12, -0.3, 0.45, 0.2, -0.1]),
              torso_rate=np.array([0.0, -1.0, 0.5, 1.8, 1.6, -1.9]))


def _parse_error(argv, capsys):
    with pytest.raises(SystemExit) as e:
        cli.parse(argv)
    assert e.value.code == 2
    return capsys.readouterr().err.strip()


@pytest.mark.parametrize("argv, words", [
    (["--num-processes", "2", "--process-id", "0"], "--coordinator"),
    (["--num-processes", "2", "--coordinator", "localhost:1234"], "--process-id"),
    (["--num-processes", "2", "--coordinator", "localhost:1234", "--process-id", "2"], "not below"),
    (["--process-id", "1"], "--num-processes"),
    (["--trials", "0"], "--trials"),
])
def test_launch_options_are_checked(argv, words, capsys, monkeypatch):
    for k in ("JAX_COORDINATOR_ADDRESS", "JAX_NUM_PROCESSES", "JAX_PROCESS_ID"):
        monkeypatch.delenv(k, raising=False)
    err = _parse_error(["robustness", "five-link", *argv], capsys)
    assert err.startswith("bipedlab: error:") and words in err and "\n" not in err


def test_a_process_other_than_0_writes_no_output(monkeypatch, tmp_path):
    monkeypatch.setenv("JAX_COORDINATOR_ADDRESS", "localhost:1234")
    monkeypatch.setenv("JAX_NUM_PROCESSES", "2")
    monkeypatch.setenv("JAX_PROCESS_ID", "1")
    _, args = cli.parse(["robustness", "five-link", "--out", str(tmp_path / "x")])
    assert (args.num_processes, args.process_id, args.coordinator, args.out) == (2, 1, "localhost:1234", None)


@pytest.fixture(scope="module")
def trials(tmp_path_factory):
    from bipedlab.robots.five_link import robustness as fr
    from bipedlab.robustness import engine

    s = fr.study(steps=STEPS)
    s = dataclasses.replace(s, sample=lambda rng, n: {k: v[:n] for k, v in POINTS.items()})
    d = tmp_path_factory.mktemp("five")
    rec = engine.run(s, len(POINTS["rate_scale"]), out=str(d), progress=False)
    return rec, dict(np.load(d / "outcomes.npz"))


@pytest.mark.slow
def test_trials_are_single_walks(trials):
    import jax
    import jax.numpy as jnp

    from bipedlab.gait import walking as gw
    from bipedlab.robots.five_link import robot, study as hz
    from bipedlab.robots.five_link.robustness import initial_state

    _, o = trials
    vc, z_star, _ = hz.load_gait()
    st = robot.stance()
    one = jax.jit(lambda z: gw.walk(vc, st, hz.CONTROLLERS["iolin"], z, STEPS))
    assert o["survived"].any() and not o["survived"].all()  # both outcomes in the set
    for i in range(len(o["status"])):
        z0 = initial_state(z_star, st.n, o["param_rate_scale"][i], o["param_torso_rate"][i])
        w = jax.tree_util.tree_map(np.asarray, one(jnp.asarray(z0)))
        assert int(w.status[-1]) == o["status"][i]
        assert int(np.sum(w.status == 0)) == o["completed"][i]
        assert np.sum(np.where(w.status == 0, w.step_length, 0.0)) == pytest.approx(o["distance_m"][i], abs=1e-9)


@pytest.mark.slow
def test_the_fixed_point_survives_on_itself(trials):
    _, o = trials
    assert o["param_rate_scale"][0] == 0.0 and o["param_torso_rate"][0] == 0.0
    assert o["survived"][0] and o["completed"][0] == STEPS
    assert o["final_deviation"][0] < 1e-4  # the gait file's fixed point, to its solver tolerance


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _bipedlab(argvs, timeout=1200):
    env = dict(os.environ, JAX_PLATFORMS="cpu")
    procs = [subprocess.Popen([sys.executable, "-m", "bipedlab.cli", *a], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True, env=env) for a in argvs]
    try:
        res = [p.communicate(timeout=timeout) for p in procs]
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
    for p, (_, err) in zip(procs, res):
        assert p.returncode == 0, err[-3000:]
    return [o for o, _ in res]


@pytest.mark.slow
def test_two_processes_equal_one_process(tmp_path):
    """The command itself, 12 trials of 3 steps: one process with two CPU devices, then two
    processes with one each (gloo collectives), the same trials out of process 0."""
    import json

    base = ["robustness", "five-link", "--trials", "12", "--steps", "3", "--seed", "5", "--chunk", "3", "--json"]
    out1 = _bipedlab([base + ["--devices", "2", "--out", str(tmp_path / "one")]])
    port = _free_port()
    out2 = _bipedlab([base + ["--devices", "1", "--out", str(tmp_path / "two"), "--coordinator", f"127.0.0.1:{port}",
                              "--num-processes", "2", "--process-id", str(i)] for i in (0, 1)])
    r1, r2 = json.loads(out1[0]), json.loads(out2[0])
    assert (r1["processes"], r1["devices"]) == (1, 2) and (r2["processes"], r2["devices"]) == (2, 2)
    assert json.loads(out2[1])["survival_rate"] == r2["survival_rate"]  # every process has the gathered result
    a, b = np.load(tmp_path / "one" / "outcomes.npz"), np.load(tmp_path / "two" / "outcomes.npz")
    for k in ("param_rate_scale", "param_torso_rate", "status", "completed", "final_deviation", "distance_m"):
        assert np.array_equal(a[k], b[k], equal_nan=True), k
    assert r1["survival_map"] == r2["survival_map"]
