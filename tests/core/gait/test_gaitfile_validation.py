"""Gait files are checked completely on reading: every damaged file gives one ValueError line
that starts with the file's name and names the field, or loads as a gait whose every number is
finite and within the documented bounds; nothing else escapes (property-based, hypothesis)."""
from __future__ import annotations

import json
import os
import string

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mutations import json_bytes

from bipedlab.gait import gaitfile, schema

SIZES = (5, 4)   # the shipped HZD gait: 5 stance coordinates, 4 outputs


@pytest.fixture(scope="module")
def valid():
    return json.loads(gaitfile.shipped_text("bipedlab.robots.five_link", "five_link_0.8")[0])


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("gaits")


def _load_or_error(path, sizes=None):
    """The loaded gait, or the ValueError's message (asserted one line naming the file)."""
    try:
        vc, z, rec = gaitfile.load(path, sizes)
    except ValueError as e:
        msg = str(e)
        assert msg.startswith(f"{path}: "), msg
        assert "\n" not in msg and "\r" not in msg, msg
        return msg
    for a in (vc.H0, vc.c, vc.alpha, z):
        assert np.all(np.isfinite(np.asarray(a)))
    assert np.all(np.abs(np.asarray(vc.alpha)) <= schema.ANGLE)
    assert np.all(np.abs(np.asarray(z)) <= schema.RATE)
    assert float(vc.theta_minus) > float(vc.theta_plus)
    if sizes is not None:
        assert np.asarray(vc.H0).shape == (sizes[1], sizes[0])
    return None


def _check(folder, raw: bytes, sizes):
    path = folder / "gait.json"
    path.write_bytes(raw)
    _load_or_error(path, sizes)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(data=st.data(), sized=st.booleans())
def test_damaged_gait_files_load_or_fail_on_one_line(valid, folder, data, sized):
    _check(folder, data.draw(json_bytes(valid)), SIZES if sized else None)


@pytest.mark.slow
@settings(max_examples=3000, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(data=st.data(), sized=st.booleans())
def test_damaged_gait_files_load_or_fail_on_one_line_many(valid, folder, data, sized):
    _check(folder, data.draw(json_bytes(valid)), SIZES if sized else None)


@settings(max_examples=100, deadline=None)
@given(raw=st.binary(max_size=200))
def test_arbitrary_bytes_load_or_fail_on_one_line(folder, raw):
    _check(folder, raw, None)


@pytest.mark.slow
@settings(max_examples=1000, deadline=None)
@given(raw=st.binary(max_size=200))
def test_arbitrary_bytes_load_or_fail_on_one_line_many(folder, raw):
    _check(folder, raw, None)


def test_the_shipped_gait_loads_bit_identical(valid):
    vc, z, rec = gaitfile.shipped("bipedlab.robots.five_link", "five_link_0.8", SIZES)
    p = valid["payload"]
    for name in ("H0", "c", "alpha"):
        np.testing.assert_array_equal(np.asarray(getattr(vc, name)), np.asarray(p[name], float))
    assert float(vc.theta_plus) == p["theta_plus"] and float(vc.theta_minus) == p["theta_minus"]
    np.testing.assert_array_equal(np.asarray(z), np.asarray(p["z_minus"], float))
    assert rec["design"] == p["design"]


def _mutated(valid, edit):
    d = json.loads(json.dumps(valid))
    edit(d["payload"])
    return d


CASES = {
    "missing section": (lambda p: p.pop("z_minus"), "payload.z_minus: missing"),
    "wrong type": (lambda p: p.update(theta_plus="0.1"), "payload.theta_plus: expected a number, got a string"),
    "bool for a number": (lambda p: p["c"].__setitem__(2, True), "payload.c[2]: expected a number, got true/false"),
    "empty array": (lambda p: p.update(alpha=[]), "payload.alpha: expected a 4 x N array of finite numbers, got an "
                                                  "empty array"),
    "empty rows": (lambda p: p.update(alpha=[[]] * 4), "payload.alpha: expected a 4 x N array of finite numbers"),
    "ragged": (lambda p: p["alpha"][1].pop(), "payload.alpha[1]: has 5 entries where [0] has 6 (ragged)"),
    "wrong shape": (lambda p: p.update(H0=p["H0"][:3]), "payload.H0: expected a 4 x 5 array of finite numbers, got "
                                                        "a 3 x 5 array"),
    "NaN": (lambda p: p["alpha"][2].__setitem__(3, float("nan")), "payload.alpha[2][3]: expected a finite number"),
    "infinity": (lambda p: p.update(theta_minus=float("inf")), "payload.theta_minus: expected a finite number"),
    "huge angle": (lambda p: p["z_minus"].__setitem__(1, 1e6), "payload.z_minus[1]: 1e+06 is outside +-100 rad"),
    "huge rate": (lambda p: p["z_minus"].__setitem__(7, -2e3), "payload.z_minus[7]: -2000 is outside +-1000 rad/s"),
    "huge coefficient": (lambda p: p["alpha"][0].__setitem__(0, 1e300), "payload.alpha[0][0]: 1e+300 is outside "
                                                                        "+-100 rad"),
    "integer beyond float": (lambda p: p["c"].__setitem__(0, 10**400), "payload.c: expected an array of 5 finite "
                                                                       "numbers, got an integer too large"),
    "one coefficient": (lambda p: p.update(alpha=[[0.1]] * 4), "payload.alpha: expected 4 rows of 2 to 21 Bézier"),
    "design not an object": (lambda p: p.update(design=[1, 2]), "payload.design: expected an object"),
    "design speed a string": (lambda p: p["design"].update(speed_mps="fast"), "payload.design.speed_mps: expected a "
                                                                              "number"),
    "phase does not grow": (lambda p: p.update(theta_minus=p["theta_plus"]), "payload.theta_minus: theta_minus <= "
                                                                             "theta_plus"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_each_kind_of_bad_field_is_named(valid, tmp_path, case):
    edit, needle = CASES[case]
    path = tmp_path / "gait.json"
    path.write_text(json.dumps(_mutated(valid, edit)))
    msg = _load_or_error(path, SIZES)
    assert msg is not None and needle in msg, msg


@pytest.mark.parametrize("raw,needle", [
    (b"[" * 100_000 + b"]" * 100_000, "nested 100000 levels deep"),
    (b'{"a":' * 40 + b"1" + b"}" * 40, "nested 40 levels deep"),
    (b'{"format": "bipedlab-gait/2", "robot": "r\xe9", "kind": "hzd"}', "not UTF-8 text (byte 0xe9"),
    (b"\x00\x01\x02", "holds a NUL byte: not a text file"),
    (b"", "empty (0 bytes)"),
    ('{"format": "bipedlab-gait/2", "robot": "r", "kind": "hzd"}'.encode("utf-16"), "payload: missing"),  # BOM
    (b"[1, 2]", "not a bipedlab gait file (the top level is an array of 2 numbers, not an object)"),
    (b'{"format": "bipedlab-gait/2", "robot": "r", "kind": "hzd", "payload": [1]}',
     "payload: expected an object, got an array of 1 numbers"),
    (b'{"format": "bipedlab-gait/2", "robot": 3, "kind": "hzd", "payload": {}}', "robot: expected a string"),
    (b'{"format": "bipedlab-gait/2", "robot": "r", "kind": "other", "payload": {}}', "kind: a 'other' gait"),
    (b'{"robot": "r"}', "format: not a bipedlab gait file (expected 'bipedlab-gait/2', got nothing)"),
    (b"[" + b"1" * 5000 + b"]", "not valid JSON"),
])
def test_unreadable_text_is_named(tmp_path, raw, needle):
    path = tmp_path / "gait.json"
    path.write_bytes(raw)
    msg = _load_or_error(path)
    assert msg is not None and needle in msg, msg


def test_directories_missing_and_unreadable_files_are_named(tmp_path):
    d = tmp_path / "a_folder.json"
    d.mkdir()
    assert "a directory, not a file" in _load_or_error(d)
    assert "cannot read (No such file or directory)" in _load_or_error(tmp_path / "absent.json")
    locked = tmp_path / "locked.json"
    locked.write_text("{}")
    locked.chmod(0)
    try:
        if not os.access(locked, os.R_OK):   # root reads anything
            assert "cannot read (Permission denied)" in _load_or_error(locked)
    finally:
        locked.chmod(0o644)


def test_oversized_file_is_refused_without_being_parsed(tmp_path, monkeypatch):
    monkeypatch.setattr(schema, "MAX_BYTES", 100)
    path = tmp_path / "big.json"
    path.write_text(json.dumps({"x": string.ascii_letters * 4}))
    assert "bytes; a gait file has at most 100" in _load_or_error(path)


def test_nesting_depth_ignores_brackets_inside_strings():
    assert schema.nesting_depth('{"a": "[[[[{{{{", "b": [[1]]}') == 3
    assert schema.nesting_depth('"\\"[[["') == 0
