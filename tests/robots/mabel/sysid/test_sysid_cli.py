"""`bipedlab identify mabel --synthetic --json` on the reduced design: the contract keys, the
targets, honest identifiability flags, figures and logs that read back."""
from __future__ import annotations

import json

import bipedlab  # noqa: F401
from bipedlab.robots.mabel import sysid
from bipedlab.cli import main

GROUPS = ("motor_constant", "rotor_inertia_scale", "friction", "spring_stiffness", "cable_stretch", "hard_stop", "ground")


def test_cli_identify_synthetic_json(capsys, tmp_path):
    assert main(["identify", "mabel", "--synthetic", "--quick", "--seed", "0", "--json", "--out", str(tmp_path)]) == 0
    rec = json.loads(capsys.readouterr().out)
    for key in ("max_rel_error", "max_abs_bias_error_nm", "validation_rms_deg", "parameters"):
        assert key in rec
    assert set(GROUPS) <= set(rec["max_rel_error"])
    for row in rec["parameters"]:
        assert {"name", "true", "estimate", "rel_error"} <= set(row)
        assert abs(row["estimate"] - row["true"]) / abs(row["true"]) == __import__("pytest").approx(row["rel_error"])
    err = rec["max_rel_error"]
    assert err["motor_constant"] < 0.02 and err["rotor_inertia_scale"] < 0.02
    assert err["friction"] < 0.10 and err["spring_stiffness"] < 0.02 and err["cable_stretch"] < 0.10
    assert rec["max_abs_bias_error_nm"] < 0.005
    assert all(rec["targets_met"].values())
    assert 0.0 < rec["validation_rms_deg"] < 1.0
    # the cubic hard-stop term never acts at the penetrations of a hop: it must not be claimed
    assert rec["identifiability"]["kd1"]["identified"] is False
    assert rec["identifiability"]["spring_d"]["identified"] is True
    assert len(rec["figures"]) == 7
    logs = sysid.read_logs(tmp_path / "logs")
    assert len(logs) == rec["logs_written"] == 27
    assert {e.kind for e in logs} == set(sysid.logs.KINDS)
