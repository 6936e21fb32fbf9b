"""Gait files: round trip, and a ValueError naming the file for every kind of malformed input."""
from __future__ import annotations

import json

import numpy as np
import pytest

from bipedlab.gait import gaitfile


@pytest.fixture(scope="module")
def shipped():
    return gaitfile.shipped("bipedlab.robots.five_link", "five_link_0.8")


def test_save_load_round_trip_is_exact(shipped, tmp_path):
    vc, z, rec = shipped
    path = tmp_path / "gait.json"
    gaitfile.save(path, "five-link", vc, z, rec["design"])
    vc2, z2, rec2 = gaitfile.load(path)
    for name in ("H0", "c", "alpha", "theta_plus", "theta_minus"):
        np.testing.assert_array_equal(np.asarray(getattr(vc2, name)), np.asarray(getattr(vc, name)))
    np.testing.assert_array_equal(np.asarray(z2), np.asarray(z))
    assert rec2["design"] == rec["design"] and rec2["robot"] == "five-link"


def _valid(shipped):
    vc, z, rec = shipped
    return gaitfile.to_dict("five-link", vc, z, rec["design"])


@pytest.mark.parametrize("mutate,needle", [
    (lambda d: d.update(format="other/1"), "format: not a bipedlab gait file"),
    (lambda d: d.update(kind="some-other-robot-payload"), "kind: a 'some-other-robot-payload' gait"),
    (lambda d: d.pop("payload"), "payload: missing"),
    (lambda d: d["payload"].pop("alpha"), "payload.alpha: missing"),
    (lambda d: d["payload"].update(theta_plus="abc"), "payload.theta_plus: expected a number, got a string"),
    (lambda d: d["payload"].update(z_minus=d["payload"]["z_minus"][:-1]),
     "payload.z_minus: expected an array of 10 finite numbers, got an array of 9 numbers"),
    (lambda d: d["payload"].update(H0=[row[:-1] for row in d["payload"]["H0"]]), "payload.c: expected an array of 4"),
    (lambda d: d["payload"].update(theta_minus=d["payload"]["theta_plus"] - 0.1), "theta_minus <= theta_plus"),
    (lambda d: d["payload"]["alpha"][0].__setitem__(0, float("nan")),
     "payload.alpha[0][0]: expected a finite number, got nan"),
])
def test_malformed_records_raise_value_error_naming_the_file(shipped, tmp_path, mutate, needle):
    d = _valid(shipped)
    mutate(d)
    path = tmp_path / "bad_gait.json"
    path.write_text(json.dumps(d))
    with pytest.raises(ValueError) as exc:
        gaitfile.load(path)
    assert str(path) in str(exc.value)
    assert needle in str(exc.value)


@pytest.mark.parametrize("text", ["{not json", "", "[1, 2, 3]", "42"])
def test_not_json_or_not_an_object(tmp_path, text):
    path = tmp_path / "junk.json"
    path.write_text(text)
    with pytest.raises(ValueError) as exc:
        gaitfile.load(path)
    assert str(path) in str(exc.value)


def test_missing_file(tmp_path):
    path = tmp_path / "nope.json"
    with pytest.raises(ValueError) as exc:
        gaitfile.load(path)
    assert str(path) in str(exc.value) and "cannot read" in str(exc.value)


@pytest.mark.parametrize("field,value", [
    ("theta_minus", float("inf")),
    ("theta_plus", float("-inf")),
    ("H0", "nan"),
    ("c", "nan"),
])
def test_non_finite_fields_are_rejected(shipped, tmp_path, field, value):
    d = _valid(shipped)
    p = d["payload"]
    if value == "nan":
        p[field] = (np.asarray(p[field]) * np.nan).tolist()
    else:
        p[field] = value
    path = tmp_path / "nonfinite.json"
    path.write_text(json.dumps(d))  # writes Infinity / NaN, which json.loads accepts
    with pytest.raises(ValueError) as exc:
        gaitfile.load(path)
    assert str(path) in str(exc.value)


def test_version_1_files_still_load(shipped, tmp_path):
    """A file of the former flat format (the payload alone, format 'bipedlab-gait/1') reads
    as the same gait."""
    vc, z, rec = shipped
    flat = dict(_valid(shipped)["payload"], format=gaitfile.HZD_V1, robot="five-link")
    path = tmp_path / "v1.json"
    path.write_text(json.dumps(flat))
    vc1, z1, rec1 = gaitfile.load(path)
    np.testing.assert_array_equal(np.asarray(vc1.alpha), np.asarray(vc.alpha))
    np.testing.assert_array_equal(np.asarray(z1), np.asarray(z))
    assert rec1["design"] == rec["design"]


def test_files_carry_format_robot_and_payload_kind(shipped):
    d = _valid(shipped)
    assert d["format"] == "bipedlab-gait/2" and d["robot"] == "five-link" and d["kind"] == gaitfile.HZD
    assert set(d) == {"format", "robot", "kind", "payload"}
