"""`walk five-link --gait BAD` exits 2 with one line naming the file and the field, before the
walk and before any compilation."""
from __future__ import annotations

import json
import time

import jax
import pytest
from helpers import expect_usage_error

from bipedlab import cli
from bipedlab.gait import gaitfile
from bipedlab.robots.five_link import study as hz


@pytest.fixture
def no_walk(monkeypatch):
    def reached(*args, **kwargs):
        raise AssertionError("the walk started despite a bad gait file")

    monkeypatch.setattr(cli, "_enable_compile_cache", lambda: None, raising=False)
    monkeypatch.setattr(hz, "walk", reached)
    compiled = []
    listener = lambda event, duration, **kw: compiled.append(event) if "backend_compile" in event else None  # noqa: E731
    jax.monitoring.register_event_duration_secs_listener(listener)
    yield compiled
    jax.monitoring.unregister_event_duration_listener(listener)


def _payload():
    return json.loads(gaitfile.shipped_text("bipedlab.robots.five_link", "five_link_0.8")[0])


CASES = {
    "design not an object": (lambda p: p.update(design=[1]), "payload.design: expected an object"),
    "huge state": (lambda p: p["z_minus"].__setitem__(0, 1e250), "payload.z_minus[0]: 1e+250 is outside +-100 rad"),
    "four outputs expected": (lambda p: p.update(H0=p["H0"][:3], alpha=p["alpha"][:3]),
                              "payload.H0: expected a 4 x 5 array of finite numbers, got a 3 x 5 array"),
    "coefficient a string": (lambda p: p["alpha"][1].__setitem__(2, "0.3"),
                             "payload.alpha[1][2]: expected a number, got a string"),
}


@pytest.mark.parametrize("case", list(CASES) + ["MABEL gait", "not utf-8", "a directory"])
def test_cli_refuses_a_bad_gait_before_compiling(tmp_path, capsys, no_walk, case):
    path = tmp_path / "bad.json"
    needle = ""
    if case in CASES:
        d = _payload()
        CASES[case][0](d["payload"])
        path.write_text(json.dumps(d))
        needle = CASES[case][1]
    elif case == "MABEL gait":
        path.write_text(gaitfile.shipped_text("bipedlab.robots.mabel", "mabel_nominal")[0])
        needle = "robot: a gait of the robot 'mabel', not of 'five-link'"
    elif case == "not utf-8":
        path.write_bytes(b'{"format": "bipedlab-gait/2", "robot": "five-link\xff"}')
        needle = "not UTF-8 text (byte 0xff"
    else:  # refused by the loader ("a directory, not a file") or already by the option's check
        path.mkdir()
        needle = str(path)
    t0 = time.perf_counter()
    line = expect_usage_error(["walk", "five-link", "--gait", str(path), "--steps", "2"], capsys, needle=needle)
    assert time.perf_counter() - t0 < 5.0
    assert str(path) in line
    assert not no_walk, no_walk
