"""MABEL's gait files (payload kind mabel-compliant-hzd) are checked completely before a walk:
every damaged file gives one ValueError line naming the file and the field, or loads as a gait
whose numbers are all finite and within bounds (property-based); `walk mabel --gait BAD` exits
2 with one line, before the walk and before any compilation."""
from __future__ import annotations

import json
import time

import jax
import numpy as np
import pytest
from helpers import expect_usage_error
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from mutations import json_bytes

from bipedlab import cli
from bipedlab.gait import gaitfile, schema
from bipedlab.robots.mabel.walking import gait_schema
from bipedlab.robots.mabel.walking import study as wm

SETTINGS = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


VALID = json.loads(gaitfile.shipped_text("bipedlab.robots.mabel", "mabel_nominal")[0])


def _damaged(edit) -> bytes:
    d = json.loads(json.dumps(VALID))
    edit(d["payload"])
    return json.dumps(d).encode()


#: examples the property tests once failed on, replayed on every run
PINNED = [
    # rows of equal length that are not numbers (an array of two empty arrays): _first_bad's
    # search for a ragged row found none and escaped as StopIteration
    _damaged(lambda p: p["feedforward"]["bounds"].__setitem__(0, [[], []])),
]


@pytest.fixture(scope="module")
def valid():
    return VALID


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("mabel_gaits")


def _load_or_error(path):
    try:
        vc, gains, rec = wm.load_gait(str(path))
    except ValueError as e:
        msg = str(e)
        assert msg.startswith(f"{path}: "), msg
        assert "\n" not in msg and "\r" not in msg, msg
        return msg
    for leaf in jax.tree_util.tree_leaves((vc, gains)):
        assert np.all(np.isfinite(np.asarray(leaf)))
    for k in ("z_minus", "z_plus"):
        z = np.asarray(rec[k], float)
        assert z.shape == (12,) and np.all(np.abs(z[:6]) <= schema.ANGLE) and np.all(np.abs(z) <= schema.RATE)
    assert gait_schema.MIN_PERIOD <= rec["design"]["period"] <= gait_schema.MAX_PERIOD
    assert np.all(np.abs(np.asarray(gains.beta)) <= schema.TORQUE)
    return None


def _check(folder, raw: bytes):
    path = folder / "gait.json"
    path.write_bytes(raw)
    _load_or_error(path)


def _pinned(test):
    for raw in PINNED:
        test = example(raw=raw)(test)
    return test


@_pinned
@settings(max_examples=300, **SETTINGS)
@given(raw=json_bytes(VALID))
def test_damaged_gait_files_load_or_fail_on_one_line(folder, raw):
    _check(folder, raw)


@pytest.mark.slow
@_pinned
@settings(max_examples=3000, **SETTINGS)
@given(raw=json_bytes(VALID))
def test_damaged_gait_files_load_or_fail_on_one_line_many(folder, raw):
    _check(folder, raw)


def test_the_pinned_damage_fails_on_one_line_naming_the_entry(folder):
    path = folder / "pinned.json"
    path.write_bytes(PINNED[0])
    msg = _load_or_error(path)
    assert msg is not None and "payload.feedforward.bounds[0]: is a 2 x 0 array where " \
        "[1] is an array of 2 numbers (ragged)" in msg, msg


@pytest.mark.parametrize("name", wm.GAITS)
def test_shipped_gaits_load_bit_identical(name):
    d = json.loads(gaitfile.shipped_text("bipedlab.robots.mabel", f"mabel_{name}")[0])["payload"]
    vc, gains, rec = wm.load_gait(name)
    for k, v in d["constraints"].items():
        np.testing.assert_array_equal(np.asarray(getattr(vc, k)), np.asarray(v, float))
    np.testing.assert_array_equal(np.asarray(gains.beta), np.asarray(d["feedforward"]["beta"], float))
    assert rec["z_plus"] == d["z_plus"] and rec["design"] == d["design"] and rec["poincare"] == d["poincare"]


def _edit(valid, fn):
    d = json.loads(json.dumps(valid))
    fn(d["payload"])
    return d


CASES = {
    "missing design": (lambda p: p.pop("design"), "payload.design: missing"),
    "missing design speed": (lambda p: p["design"].pop("speed"), "payload.design.speed: missing"),
    "missing feedforward": (lambda p: p.pop("feedforward"), "payload.feedforward: missing"),
    "period a string": (lambda p: p["design"].update(period="0.8"), "payload.design.period: expected a number"),
    "period zero": (lambda p: p["design"].update(period=0.0), "payload.design.period: 0 is outside [0.001, inf] s"),
    "poincare a list": (lambda p: p.update(poincare=[1]), "payload.poincare: expected an object"),
    "poincare entry null": (lambda p: p["poincare"].update(hzd=None), "payload.poincare.hzd: expected an object"),
    "eigenvalue a string": (lambda p: p["poincare"]["pdff"].update(max_abs_eigenvalue="x"),
                            "payload.poincare.pdff.max_abs_eigenvalue: expected a number"),
    "empty constraint array": (lambda p: p["constraints"].update(tor=[]),
                               "payload.constraints.tor: expected an array of 6 finite numbers, got an empty array"),
    "constraint NaN": (lambda p: p["constraints"].update(mls_sc=float("nan")),
                       "payload.constraints.mls_sc: expected a finite number, got nan"),
    "phases out of order": (lambda p: p["constraints"].update(theta_si=p["constraints"]["theta_minus"]),
                            "payload.constraints.theta_minus"),
    "huge state": (lambda p: p["z_plus"].__setitem__(3, 1e200), "payload.z_plus[3]: 1e+200 is outside +-100 rad"),
    "huge rate": (lambda p: p["z_minus"].__setitem__(9, 5e3), "payload.z_minus[9]: 5000 is outside +-1000 rad/s"),
    "NaN feedforward": (lambda p: p["feedforward"]["beta"][1][2].__setitem__(3, float("nan")),
                        "payload.feedforward.beta[1][2][3]: expected a finite number"),
    "huge feedforward": (lambda p: p["feedforward"]["beta"][0][0].__setitem__(0, 1e9),
                         "payload.feedforward.beta[0][0][0]: 1e+09 is outside +-1000 N m"),
    "sign not unit": (lambda p: p["feedforward"]["signs"].__setitem__(1, 0.5),
                      "payload.feedforward.signs[1]: 0.5; expected +1 or -1"),
    "sign a bool": (lambda p: p["feedforward"]["signs"].__setitem__(0, True),
                    "payload.feedforward.signs[0]: expected a number, got true/false"),
    "empty interval": (lambda p: p["feedforward"]["bounds"].__setitem__(2, [0.1, 0.1]),
                       "payload.feedforward.bounds[2]: [0.1, 0.1] is not an interval"),
    "beta wrong shape": (lambda p: p["feedforward"].update(beta=p["feedforward"]["beta"][:3]),
                         "payload.feedforward.beta: expected a 4 x 4 x 6 array of finite numbers, got a 3 x 4 x 6"),
    "name a number": (lambda p: p.update(name=3), "payload.name: expected a string"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_each_kind_of_bad_field_is_named(valid, tmp_path, case):
    edit, needle = CASES[case]
    path = tmp_path / "gait.json"
    path.write_text(json.dumps(_edit(valid, edit)))
    msg = _load_or_error(path)
    assert msg is not None and needle in msg, msg


@pytest.fixture
def no_walk(monkeypatch):
    """The walk must not start, and nothing may compile, while bad input is refused."""
    def reached(*args, **kwargs):
        raise AssertionError("the walk started despite a bad gait file")

    monkeypatch.setattr(cli, "_enable_compile_cache", lambda: None, raising=False)
    monkeypatch.setattr(wm, "walk", reached)
    compiled = []
    listener = lambda event, duration, **kw: compiled.append(event) if "backend_compile" in event else None  # noqa: E731
    jax.monitoring.register_event_duration_secs_listener(listener)
    yield compiled
    jax.monitoring.unregister_event_duration_listener(listener)


@pytest.mark.parametrize("case", ["missing design", "huge feedforward", "poincare a list", "not utf-8", "deep"])
def test_cli_refuses_a_bad_gait_before_compiling(valid, tmp_path, capsys, no_walk, case):
    path = tmp_path / "bad.json"
    if case == "not utf-8":
        path.write_bytes(json.dumps(valid).replace('"nominal"', '"nomin\\u00e9"').encode().replace(b"\\u00e9", b"\xe9"))
    elif case == "deep":
        path.write_text("[" * 50_000 + "]" * 50_000)
    else:
        path.write_text(json.dumps(_edit(valid, CASES[case][0])))
    t0 = time.perf_counter()
    line = expect_usage_error(["walk", "mabel", "--gait", str(path), "--steps", "2"], capsys, needle=str(path))
    assert time.perf_counter() - t0 < 5.0
    assert not no_walk, no_walk
    assert line.startswith(f"bipedlab: error: {path}: ")
