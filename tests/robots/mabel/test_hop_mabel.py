"""MABEL hopping on the 13-DoF model: the closed loop hops with the torso update (44) and
falls without it, as the identification paper reports (Section VIII-D)."""
from __future__ import annotations

import json

import numpy as np
import pytest

import bipedlab  # noqa: F401
from bipedlab.cli import main
from bipedlab.robots.mabel import tables as tb
from bipedlab.robots.mabel.hopping import study as hm


#: hops of the default runs, with and without the torso update: one compiled program for both
#: (the update is a traced parameter; the step count is static)
HOPS = 12


@pytest.fixture(scope="module")
def updated():
    return hm.run_hops(HOPS, torso_update=True)


def test_hops_with_the_torso_update(updated):
    """12 hops without a fall; periods in the range of the paper's figures (0.4-0.8 s);
    the robot leaves the ground (the hip rises well above its landing height)."""
    s = hm.summarize(updated)
    assert not s["fell"] and s["hops_completed"] == HOPS
    assert 0.4 < s["mean_hop_period_s"] < 0.8
    assert s["hop_period_sd_s"] < 0.1
    y = updated.x[:, hm.INDEX["y"]]
    assert y.max() - y.min() > 0.05


def test_commands_respect_limits_and_cables_stretch(updated):
    """Commanded torques stay within the controller's limits; the cables stretch (the
    paper's Fig. 23 shows tens of motor degrees) but stay within a few joint degrees."""
    limits = np.asarray(hm.hop.paper_params().torque_limit)
    assert np.all(np.abs(updated.u) <= limits + 1e-12)
    stretch = np.abs(hm.cable_stretch(updated.x)).max(axis=0)
    assert np.all(stretch > np.deg2rad(5.0))
    gears = np.array([abs(tb.GEAR_LA), tb.GEAR_LS, abs(tb.GEAR_LA), tb.GEAR_LS])
    assert np.all(stretch / gears < np.deg2rad(10.0))


def test_springs_compress_in_stance_and_rest_at_the_stop_in_flight(updated):
    """Unilateral springs: compressed while loaded (q_Bsp > 0), back at the hard stop
    (q_Bsp ~ 0) in the air, and never driven deep into the stop."""
    ph = updated.phase
    for s in tb.SIDES:
        bsp = updated.x[:, hm.INDEX[f"bsp_{s}"]]
        assert bsp[ph == hm.hop.TOUCHDOWN].max() > 0.1
        assert np.abs(bsp[ph == hm.hop.FLIGHT]).min() < 1e-2
        assert bsp.min() > -0.02


def test_nominal_controller_falls(updated):  # after the updated run: its compiled program serves this one
    """Without the event-based torso update the same controller does not sustain hopping: it
    falls within the 12 hops the updated controller completes (measured: after 4)."""
    run = hm.run_hops(HOPS, torso_update=False)
    s = hm.summarize(run)
    assert s["fell"] and s["hops_completed"] < HOPS


@pytest.mark.slow
def test_hundred_hops_faster_than_a_fifth_of_real_time():
    run = hm.run_hops(100)
    s = hm.summarize(run)
    assert not s["fell"] and s["hops_completed"] == 100


@pytest.mark.slow
def test_poincare_update_stabilises():
    from bipedlab.robots.mabel.hopping import poincare as hp

    r = hp.analyse()
    assert r["converged"]
    assert r["with_torso_update"]["max_abs_eigenvalue"] < 1.0
    assert r["without_torso_update"]["max_abs_eigenvalue"] > r["with_torso_update"]["max_abs_eigenvalue"]


def test_cli_hop_json_keys(capsys, tmp_path, updated):
    """`bipedlab hop mabel --json` prints one JSON object with the study's contract keys (12
    hops, after the updated run: its compiled program serves the command)."""
    assert main(["hop", "mabel", "--hops", str(HOPS), "--no-poincare", "--json", "--out", str(tmp_path)]) == 0
    rec = json.loads(capsys.readouterr().out)
    for key in ("fell", "hops_completed", "mean_hop_period_s", "hop_period_sd_s", "max_cable_stretch_deg",
                "peak_motor_torque_nm", "poincare_max_abs_eigenvalue"):
        assert key in rec
    assert rec["hops_completed"] == HOPS and rec["fell"] is False
    assert set(rec["max_cable_stretch_deg"]) == set(tb.ACTUATORS)
    assert rec["poincare_max_abs_eigenvalue"] is None
    for name in ("hop_joints.png", "hop_torques.png", "hop_cable_stretch.png"):
        assert (tmp_path / name).stat().st_size > 1000
    data = np.load(tmp_path / "hop_mabel.npz")
    assert data["x"].shape[1] == 28


def test_cli_hop_rejects_bad_input(capsys):
    with pytest.raises(SystemExit) as e:
        main(["hop", "mabel", "--hops", "0"])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("bipedlab: error:")
    with pytest.raises(SystemExit) as e:
        main(["hop", "atrias"])
    assert e.value.code == 2


def test_perturbed_drops_need_the_torso_update():
    """Nonlinear counterpart of the Poincaré result: from perturbed drops the updated
    controller keeps hopping more often, and longer, than the nominal one."""
    r = hm.robustness(samples=6, hops=12, seed=1)
    upd, nom = r["with_torso_update"], r["without_torso_update"]
    assert upd["completed_fraction"] > nom["completed_fraction"]
    assert upd["median_hops"] > nom["median_hops"]
    assert nom["median_hops"] < 12
