"""`bipedlab identify mabel --synthetic --json` on the reduced design: the contract keys, the
targets, honest identifiability flags, figures and logs that read back. The whole command
(hopping included) is slow; its fast counterpart runs the same command without the leg and hop
experiments (the legs' and the hop's fits have module tests of their own: test_sysid_legs,
test_sysid_hopping), so the contract, the estimates of the groups the other experiments
identify, the flags of what only the legs or the hop identify, the figures and the logs are
checked on every run."""
from __future__ import annotations

import json

import pytest

import bipedlab  # noqa: F401
from bipedlab.cli import main
from bipedlab.robots.mabel import sysid
from bipedlab.robots.mabel.sysid import experiments, study

GROUPS = ("motor_constant", "rotor_inertia_scale", "friction", "spring_stiffness", "cable_stretch", "hard_stop", "ground")
#: the groups only the hopping experiment identifies (Section VIII)
HOP_ONLY = ("hard_stop", "ground")


def _identify(capsys, tmp_path) -> dict:
    assert main(["identify", "mabel", "--synthetic", "--quick", "--seed", "0", "--json", "--out", str(tmp_path)]) == 0
    rec = json.loads(capsys.readouterr().out)
    for key in ("max_rel_error", "max_abs_bias_error_nm", "validation_rms_deg", "parameters"):
        assert key in rec
    assert set(GROUPS) <= set(rec["max_rel_error"])
    for row in rec["parameters"]:
        assert {"name", "true", "estimate", "rel_error"} <= set(row)
        if row["estimate"] is not None:
            assert abs(row["estimate"] - row["true"]) / abs(row["true"]) == pytest.approx(row["rel_error"])
    err = rec["max_rel_error"]
    assert err["motor_constant"] < 0.02 and err["rotor_inertia_scale"] < 0.02
    assert err["friction"] < 0.10 and err["spring_stiffness"] < 0.02
    assert rec["max_abs_bias_error_nm"] < 0.005
    return rec


@pytest.mark.slow
def test_cli_identify_synthetic_json(capsys, tmp_path):
    rec = _identify(capsys, tmp_path)
    assert rec["max_rel_error"]["cable_stretch"] < 0.10
    assert all(rec["targets_met"].values())
    assert 0.0 < rec["validation_rms_deg"] < 1.0
    # the cubic hard-stop term never acts at the penetrations of a hop: it must not be claimed
    assert rec["identifiability"]["kd1"]["identified"] is False
    assert rec["identifiability"]["spring_d"]["identified"] is True
    assert len(rec["figures"]) == 7
    logs = sysid.read_logs(tmp_path / "logs")
    assert len(logs) == rec["logs_written"] == 27
    assert {e.kind for e in logs} == set(sysid.logs.KINDS)


def test_cli_identify_synthetic_json_without_the_legs_and_the_hop(capsys, tmp_path, monkeypatch):
    real = experiments.generate
    kinds = tuple(k for k in sysid.logs.KINDS if k not in ("hopping", "leg"))
    monkeypatch.setattr(sysid, "generate", lambda *a, **kw: real(*a, **{**kw, "kinds": kinds}))
    rec = _identify(capsys, tmp_path)
    # judged over what the logs fit: the groups the transmission, bias and static experiments
    # identify within their targets (friction over the transmissions' friction alone); a
    # parameter only the legs or the hop fit keeps its published value, is listed as not
    # identified with the log it needs, and a group with none identified has no verdict
    met, ident = rec["targets_met"], rec["max_rel_error_identified"]
    assert all(met[g] for g in ("motor_constant", "rotor_inertia_scale", "friction", "spring_stiffness", "bias"))
    assert met["cable_stretch"] is None and ident["cable_stretch"] is None and ident["ground"] is None
    assert ident["friction"] < rec["max_rel_error"]["friction"]  # the legs' joint friction, unfitted, left out
    why = {r["group"]: r["why"] for r in rec["not_identified"]}
    assert set(why) == {"friction", "cable_stretch", "cable_damping", *HOP_ONLY}
    assert "SISO leg log" in why["friction"] and all("hopping" in why[g] for g in HOP_ONLY)
    unfitted = {n for r in rec["not_identified"] for n in r["parameters"]}
    for row in rec["parameters"]:
        assert row["identified"] is (row["name"] not in unfitted), row["name"]
    assert rec["identifiability"] == {}  # no hopping fit, no 1-sigma errors of one
    # the figures of the experiments run (the others announced missing); the logs read back
    assert [f.rsplit("/", 1)[1] for f in rec["figures"]] == ["identify_transmission.png", "identify_springs.png",
                                                             "identify_com.png"]
    logs = sysid.read_logs(tmp_path / "logs")
    assert len(logs) == rec["logs_written"] == 20
    assert {e.kind for e in logs} == set(kinds)
    # the summary's verdict of a group with nothing identified
    assert "cable_stretch" in study.summary(rec) and "not identified)" in study.summary(rec)
