"""`bipedlab run atrias`: the CLI contract."""
import json
import os

import pytest
from helpers import expect_usage_error

from bipedlab import cli


def test_cli_json_trials_and_outputs(tmp_path, capsys):
    out = tmp_path / "o"
    assert cli.main(["run", "atrias", "--terrain", "rough", "--seconds", "1.5", "--trials", "2", "--json",
                     "--out", str(out)]) == 0
    captured = capsys.readouterr()
    lines = captured.out.strip().splitlines()
    assert len(lines) == 1
    rec = json.loads(lines[0])
    for key in ("fell", "distance_m", "apex_height_error_mean_m", "apex_height_sd_m", "speed_error_mean_mps",
                "speed_sd_mps", "trunk_pitch_rms_deg", "success_rate", "trials", "wall_s", "slip_model",
                "apex_height_error_steady_m", "speed_error_steady_mps", "delay_compensation"):
        assert key in rec, key
    assert rec["trials"] == 2 and rec["success_rate"] == 1.0 and rec["fell"] == 0
    assert rec["delay_compensation"] is False
    assert 5.0 < rec["distance_m"] < 10.0
    assert "success_rate" in rec["slip_model"]
    assert os.path.exists(out / "apex.png") and os.path.exists(out / "run_atrias.npz")


@pytest.mark.parametrize("bad", [["mass"], ["mass=abc"], ["weight=0.2"], ["mass=-1.5"]])
def test_cli_bad_model_error_exits_2(capsys, bad):
    expect_usage_error(["run", "atrias", "--model-error", *bad], capsys, needle="--model-error")


def test_cli_delay_compensation_needs_a_delay(capsys):
    expect_usage_error(["run", "atrias", "--delay-compensation"], capsys, needle="--delay-compensation")


@pytest.mark.slow
def test_cli_single_run_human_summary_and_figures(tmp_path, capsys):
    assert cli.main(["run", "atrias", "--seconds", "3", "--out", str(tmp_path)]) == 0
    text = capsys.readouterr().out
    assert "apex height error" in text and "spring-mass model" in text
    for f in ("apex.png", "gait_time_series.png", "grf_first_stance.png", "run_atrias.npz"):
        assert os.path.exists(tmp_path / f)
