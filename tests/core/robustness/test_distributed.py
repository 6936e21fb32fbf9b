"""Two CPU processes joined by jax.distributed (gloo collectives) give the one-process result
trial by trial: each process computes its addressable shard of the global mesh and process 0
gathers them. The same study as test_engine (compiles in seconds); the five-link version is
tests/test_robustness_five_link.py (slow)."""
from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np

SCRIPT = str(Path(__file__).with_name("pendulum_study.py"))


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def launch(args_per_process, timeout=240):
    env = dict(os.environ, JAX_PLATFORMS="cpu")
    env.pop("XLA_FLAGS", None)
    procs = [subprocess.Popen([sys.executable, *a], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
             for a in args_per_process]
    outs = []
    try:
        for p in procs:
            o, e = p.communicate(timeout=timeout)
            outs.append((p.returncode, o, e))
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
    for rc, o, e in outs:
        assert rc == 0, e[-3000:]
        assert o == "", o[:300]  # stdout stays the command's (native libraries print on stderr)
    return outs


def test_two_processes_equal_one_process(tmp_path):
    one, two = tmp_path / "one", tmp_path / "two"
    trials, seed = 30, 7
    port = free_port()  # the one-process run and the two processes at once
    launch([[SCRIPT, str(one), str(trials), str(seed)]]
           + [[SCRIPT, str(two), str(trials), str(seed), f"127.0.0.1:{port}", "2", str(i)] for i in (0, 1)])
    r1 = json.loads((one / "record.json").read_text())
    r2 = json.loads((two / "record.json").read_text())
    assert (r1["processes"], r1["devices"]) == (1, 2)
    assert (r2["processes"], r2["devices"], r2["local_devices"]) == (2, 2, 1)
    a, b = np.load(one / "outcomes.npz"), np.load(two / "outcomes.npz")
    assert a["status"].shape == (trials,)
    assert 0 < a["survived"].sum() < trials  # both outcomes occur
    for k in ("param_theta0", "param_omega0", "status", "completed", "fell_at", "final_theta"):
        assert np.array_equal(a[k], b[k]), k
    for k in ("trials", "survival_rate", "survival_map", "cell_trials", "fell_at_histogram"):
        assert r1[k] == r2[k], k
