"""Defaults that walk: ``optimize model FILE --stance A --swing B`` with no design option gives,
on biped files written for these tests (independently of the shipped RABBIT files), a gait whose
full closed-loop Poincaré map is stable and that ``walk model`` walks 30 steps.

The files (``data/``), each a point-foot planar biped with its own names:

* ``heron.xml``: MJCF, hinges about +y (``0 1 0``), the torso the root body, legs declared
  right first, femur 0.42 m and tibia 0.38 m, actuators listed knees first, no torque limits;
* ``wader.xml``: MJCF, hinges about -y (``0 -1 0``), sites ``toe_l`` / ``toe_r``, a light
  pelvis as the root body with the legs declared before the trunk (the torso on its own waist
  joint), thigh 0.40 m and shank 0.43 m, knee ranges, 200 N m limits;
* ``plover.urdf``: URDF, revolute axes +y, a light hip housing as the root link with the torso
  on a revolute joint, links and joints declared out of tree order, thigh 0.36 m and shank
  0.44 m, 180 N m limits;
* ``strider.xml`` (slow), the biped of ``test_stable_by_design``, at 0.7 m/s: with no
  clearance its design grazes the ground at mid-step and does not walk.

The default swing clearance (:data:`bipedlab.robots.imported.study.CLEARANCE_FRACTION`, 3 % of
the leg) and the retry (a design whose closed loop's swing point lands early is designed once
more at twice the clearance; one whose restricted map is unstable, with the eigenvalue bound)
are checked without a design, on a stand-in for the design (the default tier); the files through
both commands are the slow tier (heron.xml alone took 97 s of a default run: the design and walk
programs of a robot no other test compiles).
The checks are physical: the full map's largest |eigenvalue| below 1, 30 steps without a fall,
the swing point above the ground at mid-step.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")

DATA = Path(__file__).parent / "data"
#: (file, stance site, swing site)
HERON = ("heron.xml", "foot_l", "foot_r")
WADER = ("wader.xml", "toe_l", "toe_r")
PLOVER = ("plover.urdf", "sole_a", "sole_b")
FILES = (HERON, WADER, PLOVER)
#: the biped of test_stable_by_design, whose design at 0.7 m/s with no clearance grazes the ground
STRIDER = ("strider.xml", "sole_port", "sole_starboard")
STEPS = 30


def _cli_json(argv, capsys):
    from bipedlab import cli

    assert cli.main(list(argv) + ["--json"]) == 0
    out = capsys.readouterr()
    return json.loads(out.out), out.err


# ----------------------------------------------------------------------------- the default clearance
@pytest.mark.parametrize("case", FILES, ids=lambda c: c[0])
def test_default_clearance_is_a_fraction_of_the_leg(case):
    """3 % of the stance hip-to-foot distance in the file's zero pose (straight legs): 0.8 m
    legs (heron 0.42 + 0.38, plover 0.36 + 0.44) get 2.4 cm, wader's 0.83 m 2.49 cm."""
    from bipedlab.robots.imported import robot, study

    name, stance, swing = case
    s = robot.load(str(DATA / name), stance, swing)
    legs = {"heron.xml": 0.80, "wader.xml": 0.83, "plover.urdf": 0.80}
    assert s.leg == pytest.approx(legs[name], abs=1e-12)
    assert study.default_clearance(s) == pytest.approx(0.03 * legs[name], abs=1e-12)


def test_cli_clearance_default_is_derived():
    """``--clearance`` left out reaches the study as None (the derived default), 0 as 0."""
    from bipedlab.registry import parse

    base = ["optimize", "model", "rabbit.xml", "--stance", "left_foot", "--swing", "right_foot"]
    assert parse(base)[1].clearance is None
    assert parse(base + ["--clearance", "0"])[1].clearance == 0.0


# ----------------------------------------------------------------------------- the retry, on a stand-in
def _fake_record(stable: bool, note: str, clearance: float, bound) -> dict:
    return dict(robot="model", cost="torque", success=True, message="", iterations=1, solver="scipy SLSQP",
                solver_tolerance=1e-10, speed_mps=0.8, step_length_m=0.4, period_s=0.5, cmt=0.2,
                torque_cost=30.0, peak_torques_nm=[1.0] * 4, periodicity_error=0.0,
                max_constraint_violation=0.0, min_inequality=0.0, optimize_warm_s=1.0, optimize_cold_s=1.0,
                controller="iolin", max_abs_eigenvalue=0.7 if stable else 1.56, poincare_eigenvalues=[0.7],
                poincare_eigenvalues_complex=[[0.7, 0.0]], restricted_eigenvalue=0.7 if stable else 1.2,
                eps=0.1, kp=1.0, kd=2.0, stable=stable,
                closed_loop_periodicity_error=1e-7 if stable or "bound" in note else 21.0,
                eps_search=[], controller_note=note, max_eigenvalue_bound=bound, clearance_m=clearance)


@pytest.fixture
def stand_in(monkeypatch):
    """The imported study with its design replaced: each call records (max_eigenvalue, clearance)
    and returns the next of the queued verdicts ('early', 'unstable zero dynamics' or 'stable')."""
    from bipedlab.gait import study as hs
    from bipedlab.robots.imported import study

    calls, verdicts = [], []
    notes = {"early": f"the closed loop from the fixed point does not return to it (...) ({hs.REMEDY_CLEARANCE})",
             "zero": f"eps 0.1: ...; the restricted map is itself unstable, which no output convergence mends "
                     f"({hs.REMEDY_BOUND})",
             "stable": "eps 0.1: within 0.05"}

    def design(s, speed, cost, controller, progress, max_eigenvalue, clearance):
        calls.append((max_eigenvalue, clearance))
        v = verdicts.pop(0)
        return _fake_record(v == "stable", notes[v], clearance, max_eigenvalue), None, None, None

    monkeypatch.setattr(study, "_design", design)
    return calls, verdicts


def _optimize(**kw):
    from bipedlab.robots.imported import study

    lines = []
    name, stance, swing = HERON
    rec = study.optimize(str(DATA / name), stance, swing, progress=lines.append, **kw)
    return rec, lines


def test_retry_with_twice_the_clearance(stand_in):
    calls, verdicts = stand_in
    verdicts[:] = ["early", "stable"]
    rec, lines = _optimize()
    assert calls == [(None, pytest.approx(0.024)), (None, pytest.approx(0.048))]
    t = rec["retried"]
    assert t["clearance"] == pytest.approx(0.048) and "not a fixed point of its closed loop" in t["because"]
    assert t["first_max_abs_eigenvalue"] == 1.56 and t["first_closed_loop_periodicity_error"] == 21.0
    assert rec["stable"] is True and rec["clearance_m"] == pytest.approx(0.048)
    retry = [ln for ln in lines if "retrying" in ln]
    assert len(retry) == 1 and "--clearance 0.048" in retry[0]
    from bipedlab.robots.imported import study

    assert "retried with clearance 0.048" in study.summary_optimize(rec)


def test_retry_with_the_eigenvalue_bound(stand_in):
    calls, verdicts = stand_in
    verdicts[:] = ["zero", "stable"]
    rec, lines = _optimize()
    assert calls == [(None, pytest.approx(0.024)), (0.8, pytest.approx(0.024))]
    assert rec["retried"]["max_eigenvalue"] == 0.8 and "unstable" in rec["retried"]["because"]
    assert len([ln for ln in lines if "retrying" in ln and "--max-eigenvalue 0.8" in ln]) == 1


def test_retry_once_only(stand_in):
    """A retried design that is still unstable is reported as it is (no second retry)."""
    calls, verdicts = stand_in
    verdicts[:] = ["early", "early"]
    rec, _ = _optimize()
    assert len(calls) == 2 and rec["stable"] is False and rec["retried"]["clearance"] == pytest.approx(0.048)


@pytest.mark.parametrize("kw, verdict", [(dict(clearance=0.0), "early"), (dict(clearance=0.03), "early"),
                                         (dict(max_eigenvalue=0.9), "zero"), (dict(retry=False), "early"),
                                         ({}, "stable")])
def test_no_retry_of_an_explicit_option_or_a_stable_gait(stand_in, kw, verdict):
    """An option the caller set is the caller's (``--clearance 0``: no bound, and no retry), and a
    stable design is reported at once: one design, ``retried`` null."""
    calls, verdicts = stand_in
    verdicts[:] = [verdict]
    rec, lines = _optimize(**kw)
    assert len(calls) == 1 and rec["retried"] is None and not any("retrying" in ln for ln in lines)
    assert calls[0][1] == pytest.approx(kw.get("clearance", 0.024))


def test_remedy_is_read_from_the_figures_not_the_note():
    """The remedy follows from the record's figures (closed-loop periodicity error, controller,
    restricted eigenvalue), whatever its note says; a step that reaches no touchdown (error not
    finite, or null as a gait file stores it) names none, and neither does a stable design."""
    from bipedlab.gait import study as hs

    base = dict(stable=False, controller="iolin", closed_loop_periodicity_error=1e-7, restricted_eigenvalue=0.7,
                controller_note=f"x ({hs.REMEDY_BOUND})")
    assert hs.remedy(dict(base, closed_loop_periodicity_error=21.0)) == "clearance"
    assert hs.remedy(dict(base, controller="pd", closed_loop_periodicity_error=21.0)) == "clearance"
    assert hs.remedy(dict(base, restricted_eigenvalue=-1.2, controller_note="")) == "max_eigenvalue"
    assert hs.remedy(dict(base, restricted_eigenvalue=1.2, controller="pd")) is None
    assert hs.remedy(base) is None  # the note names a bound the figures do not call for
    assert hs.remedy(dict(base, closed_loop_periodicity_error=None, restricted_eigenvalue=1.2)) is None
    assert hs.remedy(dict(base, closed_loop_periodicity_error=float("inf"))) is None
    assert hs.remedy(dict(base, stable=True, closed_loop_periodicity_error=21.0)) is None


def test_the_note_names_the_remedy_the_figures_give():
    """The controller note's remedy text and :func:`remedy_of` are one decision: for each case
    the note of :func:`choose_controller`'s helpers names exactly the remedy remedy_of returns."""
    from bipedlab.gait import study as hs

    early = dict(status="ok", duration=0.3, residual=21.0)
    assert hs.REMEDY_CLEARANCE in hs._not_periodic(early) and hs.remedy_of("iolin", 21.0, 0.7) == "clearance"
    stuck = dict(status="no touchdown", duration=1.0, residual=float("inf"))
    assert hs.REMEDY_CLEARANCE not in hs._not_periodic(stuck) and hs.remedy_of("iolin", float("inf"), 0.7) is None


# ----------------------------------------------------------------------------- designs and walks
def _mid_step_clearance(path, gait) -> float:
    """The swing point's height at mid-step (the phase half-way) on the gait's zero dynamics."""
    from bipedlab.control import hzd
    from bipedlab.mechanics import stance as stm
    from bipedlab.robots.imported import study

    s, vc, z, _ = study.load_gait(path, gait)
    st = s.study.stance
    theta = 0.5 * (float(vc.theta_plus) + float(vc.theta_minus))
    q, qd = hzd.lift(vc, theta, 1.0)
    return float(stm.swing_height(st, np.concatenate([np.asarray(q), np.asarray(qd)])))


def _design_and_walk(case, capsys, tmp_path, speed=0.8):
    name, stance, swing = case
    path = str(DATA / name)
    gait = str(tmp_path / "gait.json")
    extra = [] if speed == 0.8 else ["--speed", str(speed)]
    rec, _ = _cli_json(["optimize", "model", path, "--stance", stance, "--swing", swing, *extra, "--save", gait],
                       capsys)
    assert rec["success"] and rec["periodicity_error"] < 1e-9
    assert rec["stable"] is True and rec["max_abs_eigenvalue"] < 1.0
    assert rec["closed_loop_periodicity_error"] < 1e-3
    assert rec["clearance_m"] > 0.0
    assert _mid_step_clearance(path, gait) >= rec["clearance_m"] - 1e-9
    walk, err = _cli_json(["walk", "model", path, "--gait", gait, "--steps", str(STEPS), "--perturb", "0.01"],
                          capsys)
    assert "warning" not in err
    assert walk["fell"] is False and walk["steps_completed"] == STEPS
    # back to the fixed point, so to the design's speed (measured 2.8e-3 of the start on wader, 7.5e-4
    # on plover); the record's mean speed includes the first steps, still off the gait (0.78 m/s
    # on wader and plover, 0.66 m/s on strider designed at 0.7)
    dev = np.asarray(walk["deviation_per_step"])
    assert dev[-1] < 1e-2 * dev[0]
    assert walk["speed_mps"] == pytest.approx(speed, rel=0.1)
    return rec, walk


@pytest.mark.slow
@pytest.mark.parametrize("case", FILES, ids=lambda c: c[0])
def test_designs_and_walks_with_the_defaults(case, capsys, tmp_path):
    _design_and_walk(case, capsys, tmp_path)


@pytest.mark.slow
def test_grazing_design_walks_with_the_defaults(capsys, tmp_path):
    """strider.xml at 0.7 m/s: with no clearance its design grazes the ground at mid-step (full
    map 1.85, not a fixed point of the closed loop; test_stable_by_design); with the default
    clearance (2.46 cm for its 0.82 m leg) it is stable at once (measured 0.768) and walks."""
    rec, _ = _design_and_walk(STRIDER, capsys, tmp_path, speed=0.7)
    assert rec["clearance_m"] == pytest.approx(0.03 * 0.82)
