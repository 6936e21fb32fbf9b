"""`bipedlab walk mabel`: the JSON record of a short closed-loop walk on the shipped nominal gait,
and one-line usage errors (status 2) for a malformed push and an unreadable gait file. main() is
called in-process (no interpreter start-up), with JAX's compilation cache left untouched."""
from __future__ import annotations

import contextlib
import io
import json

import pytest

from bipedlab import cli
from helpers import expect_usage_error
from bipedlab.robots.mabel.walking import catalog
from bipedlab.robots.mabel.walking import study as wm


@pytest.fixture(scope="module")
def walk_record():
    out = io.StringIO()
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(cli, "_enable_compile_cache", lambda: None)
        with contextlib.redirect_stdout(out):
            rc = cli.main(["walk", "mabel", "--steps", "3", "--json"])
    assert rc == 0
    lines = out.getvalue().strip().splitlines()
    assert len(lines) == 1, out.getvalue()  # --json: one object and nothing else on stdout
    return json.loads(lines[0])


def test_walk_json_record_has_the_documented_keys(walk_record):
    r = walk_record
    for k in ("fell", "steps_completed", "speed_mps", "cmt", "tracking_rms_deg", "max_abs_eigenvalue",
              "speed_per_step", "designed_speed_mps", "plant", "cmt_designed"):
        assert k in r, k
    assert r["robot"] == "mabel" and r["gait"] == "nominal" and r["controller"] == "pdff"
    assert r["plant"] == "stance"  # the default plant
    assert r["cmt_designed"] == pytest.approx(wm.load_gait("nominal")[2]["design"]["cmt"], rel=1e-12)
    assert set(r["tracking_rms_deg"]) == {"mLS_st", "LA_sw", "mLS_sw", "Tor"}
    assert isinstance(r["speed_per_step"], list) and len(r["speed_per_step"]) == 3
    assert r["max_abs_eigenvalue"] is None or 0.0 <= r["max_abs_eigenvalue"] < 1.0


def test_walk_on_the_nominal_gait_keeps_its_designed_speed(walk_record):
    """Three steps under PD + feedforward at 1 kHz with encoders: no fall, and the walking speed
    (overall and per step) within 5 % of the design's 0.8 m/s."""
    r = walk_record
    rec = wm.load_gait("nominal")[2]
    assert r["fell"] is False and r["steps_completed"] == 3
    v = rec["design"]["speed"]
    assert r["designed_speed_mps"] == pytest.approx(v, rel=1e-12)
    assert r["speed_mps"] == pytest.approx(v, rel=0.05)
    assert r["speed_per_step"] == pytest.approx([v] * 3, rel=0.05)
    # the steps are the designed ones: length and duration
    assert r["step_lengths_m"] == pytest.approx([rec["design"]["step_length"]] * 3, rel=0.05)
    assert r["step_durations_s"] == pytest.approx([rec["design"]["period"]] * 3, rel=0.05)
    # tracking stays small (a few degrees at the motor leg shape, well under a degree elsewhere)
    assert all(0.0 <= x < 5.0 for x in r["tracking_rms_deg"].values())
    assert r["tracking_rms_deg"]["LA_sw"] < 1.0 and r["tracking_rms_deg"]["Tor"] < 1.0
    # positive motor work per weight and distance, the order of the designed c_mt
    assert r["cmt"] > 0 and r["cmt"] == pytest.approx(rec["design"]["cmt"], rel=0.5)
    assert all(t <= c for t, c in zip(r["peak_torques_nm"], (30.0, 55.0, 30.0, 55.0)))


@pytest.fixture
def no_walk(monkeypatch):
    """Bad input must be refused before any simulation, and JAX's configuration kept."""
    def reached(*args, **kwargs):
        raise AssertionError("the walk started despite bad input")

    monkeypatch.setattr(cli, "_enable_compile_cache", lambda: None)
    monkeypatch.setattr(wm, "walk", reached)


@pytest.mark.parametrize("push", ["78", "abc@3", "78@-1", "nan@2", "78@1.5"])
def test_bad_push_is_one_error_line_and_status_2(push, capsys, no_walk):
    line = expect_usage_error(["walk", "mabel", "--steps", "3", "--push", push, "--json"], capsys)
    assert "--push" in line


def test_unknown_gait_file_is_one_error_line_and_status_2(tmp_path, capsys, no_walk):
    path = tmp_path / "no_such_gait.json"
    expect_usage_error(["walk", "mabel", "--gait", str(path), "--steps", "3", "--json"], capsys, needle=str(path))


def test_gait_file_of_another_format_is_refused(tmp_path, capsys, no_walk):
    path = tmp_path / "other.json"
    path.write_text(json.dumps({"format": "something-else/2"}))
    expect_usage_error(["walk", "mabel", "--gait", str(path), "--json"], capsys, needle=str(path))


def test_push_is_parsed_once_and_the_gait_loaded_once(tmp_path, monkeypatch, capsys):
    """``walk mabel --push=-71@2 --gait FILE``: the option reaches the study as the typed pair
    (-71.0, 2) argparse read, and the gait file is read once (by the command, which hands the
    loaded gait to the walk); the walk itself reads no gait and parses no push."""
    path = tmp_path / "g.json"
    path.write_text(wm.gaitfile.shipped_text("bipedlab.robots.mabel", "mabel_nominal")[0])
    loads, parses, seen = [], [], {}
    real_load = wm.load_gait
    monkeypatch.setattr(wm, "load_gait", lambda g: loads.append(g) or real_load(g))
    monkeypatch.setattr(wm, "parse_push", lambda t: parses.append(t))

    def run_walk(gait, controller, steps, push, *args, loaded=None, **kw):
        seen.update(gait=gait, push=push, loaded=loaded)
        raise KeyboardInterrupt  # stop before simulating: 130, one line

    monkeypatch.setattr(cli, "_enable_compile_cache", lambda: None)
    monkeypatch.setattr(wm, "run_walk", run_walk)
    assert cli.main(["walk", "mabel", "--steps", "3", "--push=-71@2", "--gait", str(path)]) == 130
    assert loads == [str(path)] and parses == []
    assert seen["gait"] == str(path) and seen["push"] == (-71.0, 2)
    assert seen["loaded"][2]["design"] == real_load(str(path))[2]["design"]


def test_parse_push():
    assert wm.parse_push(None) == (0.0, -1)
    assert wm.parse_push("78@10") == (78.0, 10)
    assert wm.parse_push("-71@30") == (-71.0, 30)
    with pytest.raises(ValueError, match="FORCE@STEP"):
        wm.parse_push("78")


def test_cli_offers_every_experiment():
    """``experiment mabel NAME`` accepts exactly the experiments the package runs."""
    from bipedlab.robots.mabel import cli as mcli
    from bipedlab.robots.mabel.walking import experiments as wx

    assert sorted(mcli.EXPERIMENTS) == sorted(wx.NAMES)


def test_pd_gains_refuses_steps(capsys):
    """The gain sweep walks nothing: --steps is refused with one line."""
    expect_usage_error(["experiment", "mabel", "pd-gains", "--steps", "5"], capsys, "pd-gains")


def test_falling_pairing_is_refused(capsys):
    """A shipped gait under a controller/sensing pairing that falls within 100 steps (measured,
    catalog.GAIT_FALLS) is refused with one line naming the fall."""
    expect_usage_error(["walk", "mabel", "--gait", "efficient", "--controller", "decentralized", "--sensing",
                        "ideal"], capsys, "falls under decentralized")


@pytest.mark.slow
def test_refused_pairing_does_fall():
    """The refusal is a measurement: efficient under the decentralised controller with exact
    sensing falls in step 2 of 100 (0.21 s in; a quantised walk moves with the CPU's rounding, so
    a fall after step 20 would be accepted for a fall measured later). Every refused pairing of
    the catalogue falls within the 100 steps asked."""
    for (gait, controller, sensing), (steps, _) in catalog.GAIT_FALLS.items():
        r = wm.walk(gait, controller, 100, sensing=sensing)
        assert r["fell"] and min(20, steps) <= r["steps_completed"] < 100, (gait, controller, sensing)


def test_efficient_gait_strikes_behind_and_is_refused(capsys):
    """The full-model c_mt gait's swing toe strikes the ground behind the stance toe in the first
    step (a negative step length, measured -0.21 m), so walk refuses it on the stance plant and
    names the gait that walks instead."""
    r = wm.walk("efficient", "pdff", 2)
    assert r["step_lengths_m"][0] < 0.0
    expect_usage_error(["walk", "mabel", "--gait", "efficient"], capsys, "paper-efficient")
