"""The seven-link studies: a short walk that does not fall (with the physics checks the
simulator reports: constraint drift, impact energy), the CLI contract of
``bipedlab walk seven-link`` and ``bipedlab experiment seven-link``, and the Fig. 6 / Fig. 7
experiments."""
from __future__ import annotations

import json

import pytest

from helpers import expect_usage_error

from bipedlab import cli
from bipedlab.robots.seven_link import study as w

pytestmark = pytest.mark.optimized  # its time is running long simulations (tests/conftest.py)

SHORT = 5


@pytest.fixture(scope="module")
def short_run():
    """The short walk's record and its simulation: (record, (run_walk's arguments, SimResult))."""
    runs = []
    real = w.run_walk

    def recording(*args, **kwargs):
        res = real(*args, **kwargs)
        runs.append(((args, kwargs), res))
        return res

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(w, "run_walk", recording)
        rec = w.walk(SHORT, "tuned")
    assert len(runs) == 1
    return rec, runs[0]


@pytest.fixture(scope="module")
def short_walk(short_run):
    return short_run[0]


def test_short_walk_does_not_fall(short_walk):
    rec = short_walk
    assert not rec["fell"] and rec["steps_completed"] == SHORT and rec["status"] == "ok"
    drift = rec["max_constraint_drift"]
    assert drift["position_after_projection_m"] < 1e-8 and drift["velocity_after_projection_mps"] < 1e-8
    assert drift["position_before_projection_m"] < 1e-8  # even before the projection of each step
    assert rec["max_impact_energy_change_j"] <= 1e-9  # impacts never add kinetic energy
    assert rec["speed_mps"] > 0.2 and 0.2 < rec["step_length_m"] < 0.9
    assert 0.05 < rec["cmt"] < 1.0 and rec["cmt_positive"] <= rec["cmt"]
    assert rec["body_angle_deg_mean"] == pytest.approx(87.5, abs=6.0)
    # the unilateral check: no contact chatter (it was about 70 events per step without)
    assert rec["unilateral_check"] and rec["events_per_step"] < 12


def test_short_walk_with_section_va_sensing():
    rec = w.walk(SHORT, "tuned", sensing=True)
    assert rec["sensing"] == "section V-A" and not rec["fell"] and rec["steps_completed"] == SHORT


def test_cli_walk_json_contract(capsys, short_run, monkeypatch, tmp_path):
    """The command's record and files; its walk is the short walk's own simulation (run_walk
    called with the same arguments: the simulation is shared, not run twice), any other walk
    is simulated."""
    short_walk, (key, result) = short_run
    real, asked = w.run_walk, []

    def shared(*args, **kwargs):
        asked.append((args, kwargs))
        return result if (args, kwargs) == key else real(*args, **kwargs)

    monkeypatch.setattr(w, "run_walk", shared)
    assert cli.main(["walk", "seven-link", "--steps", str(SHORT), "--json", "--out", str(tmp_path)]) == 0
    assert asked == [key]  # the defaults: the tuned parameters on the planar model, ideal sensing
    out = capsys.readouterr().out
    lines = out.strip().splitlines()
    assert len(lines) == 1
    rec = json.loads(lines[0])
    for key in ("fell", "steps_completed", "speed_mps", "step_length_m", "step_frequency_hz", "cmt", "params",
                "max_constraint_drift", "peak_torques_nm", "cmt_comparison"):
        assert key in rec, key
    assert rec["params"] == "tuned" and rec["steps_completed"] == short_walk["steps_completed"]
    assert rec["speed_mps"] == pytest.approx(short_walk["speed_mps"], rel=1e-9)
    for name in ("angles_torques.png", "stick_figures.png", "walk_seven_link_tuned.npz"):
        assert (tmp_path / name).stat().st_size > 1000, name


@pytest.mark.parametrize("argv,needle", [
    (["walk", "seven-link", "--lean", "5"], "--lean"),
    (["walk", "seven-link", "--controller", "pd"], "--controller"),
    (["walk", "seven-link", "--impact-scale", "2"], "--impact-scale"),
    (["walk", "seven-link", "--sensing", "ideal"], "--sensing"),
    (["experiment", "seven-link", "nominal"], "seven-link"),
    (["walk", "seven-link", "--params", "fast"], None),
])
def test_cli_rejects_options_of_other_robots(capsys, argv, needle):
    expect_usage_error(argv, capsys, needle)


def test_free_swing_fig6(capsys):
    assert cli.main(["experiment", "seven-link", "free-swing", "--json"]) == 0
    rec = json.loads(capsys.readouterr().out)
    hip, knee = rec["joints"]["hip"], rec["joints"]["knee"]
    lo_h, hi_h = hip["21:1 (Table I)"], hip["105:1"]
    lo_k, hi_k = knee["12:1 (Table I)"], knee["60:1"]
    # backdrivable: several lightly damped swings; the highly geared joints barely swing
    assert lo_h["half_cycles"] >= 6 and lo_k["half_cycles"] >= 6
    assert hi_h["settling_time_s"] < lo_h["settling_time_s"] and hi_k["settling_time_s"] < lo_k["settling_time_s"]
    assert hi_h["half_cycles"] < lo_h["half_cycles"] and hi_k["half_cycles"] <= 2
    # the rotor inertia lengthens the period: n^2 J_m added to the pendulum's inertia
    assert hi_h["period_s"] > lo_h["period_s"] > 0.5
    assert hi_h["reflected_inertia_kgm2"] == pytest.approx(25 * 0.0067, rel=3e-3)


def test_low_gain_pd_fig7():
    """The experiment as `bipedlab experiment seven-link low-gain-pd` and the reproduction run
    it (8 s, the last 4 analysed): the reproduction tests compile the same program."""
    rec = w.low_gain_pd()
    assert rec["duration_s"] == 8.0
    for joint in ("hip", "knee", "ankle"):
        m = rec["joints"][joint]
        # low gains: the response follows the reference's frequency with a reduced amplitude
        # and a lag, shaped by the leg's own dynamics rather than dictated by the controller
        assert 0.1 < m["amplitude_ratio"] < 1.2, (joint, m)
        assert 0.0 < m["phase_lag_deg"] < 180.0
    assert rec["gains"]["K"] == (2.0, 1.5, 1.0) and not rec["knee_stop_reached"]


@pytest.mark.slow
def test_thirty_steps_tuned_and_paper():
    # Table II on the planar model, with the unilateral check (no contact chatter), falls: it
    # walked (1.06 m/s) only through the chatter's losses; it walks on the boom setup
    # (test_seven_link_contact_sequence)
    paper = w.walk(30, "paper")
    assert paper["fell"] and paper["steps_completed"] < 30 and paper["unilateral_check"]
    assert paper["max_constraint_drift"]["position_after_projection_m"] < 1e-8
    tuned = w.walk(30, "tuned")
    assert not tuned["fell"] and tuned["steps_completed"] == 30 and tuned["unilateral_check"]
    drift = tuned["max_constraint_drift"]
    assert drift["position_after_projection_m"] < 1e-8 and drift["position_before_projection_m"] < 1e-8
    assert tuned["max_impact_energy_change_j"] <= 1e-9
    # the targets: about 0.5 m/s, 0.5 m steps, 1 Hz, and c_mt <= 0.31 (with margin)
    assert tuned["speed_mps"] == pytest.approx(0.5, abs=0.06) and tuned["step_length_m"] == pytest.approx(0.5, abs=0.05)
    assert tuned["step_frequency_hz"] == pytest.approx(1.0, abs=0.12) and tuned["cmt"] <= 0.295
    # no contact chatter: a handful of make/release events per step (toe, heel, knee stops)
    assert tuned["events_per_step"] < 10 and tuned["releases"] < 3 * 30
    assert tuned["max_friction_ratio"] < 1.5


@pytest.mark.slow
@pytest.mark.parametrize("speed", [0.40, 0.45, 0.55])
def test_tuned_walks_from_other_start_speeds(speed):
    res = w.run_walk(30, "tuned", speed=speed)
    assert int(res.status) == 0 and int(res.n_touchdowns) == 30
