"""The CSV log format of `bipedlab identify mabel --data`: round trip, and one clear error that
names the file and the problem for each kind of malformed log."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers import expect_usage_error

import bipedlab  # noqa: F401
from bipedlab.robots.mabel import sysid
from bipedlab.robots.mabel.sysid.logs import LogError, read_log


@pytest.fixture(scope="module")
def logs():
    truth = sysid.perturbed(1)
    d = sysid.quick_design()
    return (sysid.transmission_experiments(truth, "mLA_L", sysid.Sensors(), d)[:1]
            + [sysid.spring_experiment(truth, "L", sysid.Sensors(), d)])


def test_round_trip(tmp_path, logs):
    paths = sysid.write_logs(logs, tmp_path)
    back = sysid.read_logs(tmp_path)
    assert sorted(e.name for e in back) == sorted(e.name for e in logs) and len(paths) == 2
    for e in logs:
        b = next(x for x in back if x.name == e.name)
        assert b.kind == e.kind
        np.testing.assert_allclose(b.t, e.t, rtol=1e-12, atol=1e-15)
        for k in e.enc:
            np.testing.assert_allclose(b.enc[k], e.enc[k], rtol=1e-11, atol=1e-14)
        for k in e.u:
            np.testing.assert_allclose(b.u[k], e.u[k], rtol=1e-11, atol=1e-14)
        if e.scale is not None:
            np.testing.assert_allclose(b.scale, e.scale, rtol=1e-11)
        assert {k: str(v) for k, v in e.meta.items()} == b.meta


def _write(tmp_path, logs, edit) -> Path:
    path = sysid.write_log(logs[0], tmp_path / "transmission_mLA_L_1.csv")
    lines = path.read_text().splitlines()
    path.write_text("\n".join(edit(lines)) + "\n")
    return path


def _header_index(lines):
    return next(i for i, line in enumerate(lines) if not line.startswith("#"))


def _drop_column(lines, name):
    h = _header_index(lines)
    cols = lines[h].split(",")
    j = cols.index(name)
    return lines[:h] + [",".join(c for i, c in enumerate(row.split(",")) if i != j) for row in lines[h:]]


def _set_cell(lines, row, col, value):
    h = _header_index(lines)
    j = lines[h].split(",").index(col)
    cells = lines[h + row].split(",")
    cells[j] = value
    return lines[: h + row] + [",".join(cells)] + lines[h + row + 1:]


CASES = {
    "missing column 'enc_mla_L'": lambda ls: _drop_column(ls, "enc_mla_L"),
    "time_s is not strictly increasing": lambda ls: _set_cell(ls, 40, "time_s", "0.030"),
    "non-finite value (nan) at row 17": lambda ls: _set_cell(ls, 17, "enc_mla_L", "nan"),
    "units metadata says angle=deg; expected angle=rad":
        lambda ls: [line.replace("angle=rad", "angle=deg") for line in ls],
    "metadata 'units' is missing": lambda ls: [line for line in ls if not line.startswith("# units")],
    "unknown experiment 'chirp'": lambda ls: [line.replace("experiment: transmission", "experiment: chirp") for line in ls],
    "time_s must advance by 1 ms per row": lambda ls: _set_cell(ls, 5, "time_s", "0.0045"),
    "row 3, column 'u_mLA_L': 'abc' is not a number": lambda ls: _set_cell(ls, 3, "u_mLA_L", "abc"),
}


@pytest.mark.parametrize("problem", list(CASES))
def test_malformed_log_fails_with_one_clear_message(tmp_path, logs, problem):
    path = _write(tmp_path, logs, CASES[problem])
    with pytest.raises(LogError) as err:
        read_log(path)
    msg = str(err.value)
    assert msg.startswith(f"{path}: ") and problem in msg
    assert "\n" not in msg


def test_cli_reports_a_malformed_log_on_one_line(tmp_path, logs, capsys):
    path = _write(tmp_path, logs, CASES["missing column 'enc_mla_L'"])
    line = expect_usage_error(["identify", "mabel", "--data", str(tmp_path)], capsys, needle="missing column 'enc_mla_L'")
    assert str(path) in line


def test_cli_identify_usage_errors(tmp_path, capsys):
    expect_usage_error(["identify", "mabel"], capsys, needle="--synthetic")
    expect_usage_error(["identify", "mabel", "--data", str(tmp_path), "--noise", "2"], capsys, needle="--synthetic only")
    expect_usage_error(["identify", "mabel", "--data", str(tmp_path)], capsys, needle="no .csv logs")
    expect_usage_error(["identify", "mabel", "--synthetic", "--noise", "-1"], capsys, needle="--noise: expected a number in [0,")
