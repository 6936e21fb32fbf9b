"""Stable by design, on a biped written for these tests (``data/strider.xml``: a light pelvis as
the floating base, the trunk on its own actuated waist joint, thighs of 0.45 m and shanks of
0.37 m, hinges about -y), not on the shipped RABBIT files.

Gaits of ``optimize model data/strider.xml --stance sole_port --swing sole_starboard --speed
0.7`` (the commands are in the README's "Bring your own robot"):

* ``strider_0.7.json``, no bound: the restricted map's eigenvalue is 0.92, and the swing sole
  grazes the ground at mid-step (0 m of clearance at the middle node), so the closed loop from
  the design's fixed point touches down there, after 0.41 s of the 0.70 s step: it is not a
  fixed point of the closed loop under any gain, ``walk`` refuses it in one line, and walked
  anyway from a 1 % offset it falls in its first step;
* ``strider_0.7_r0.6.json``, ``--max-eigenvalue 0.6``: the bound is active, the swing sole
  clears the ground, and under the chosen eps the full map's dominant eigenvalue is the
  restricted map's 0.6; it walks back to its fixed point.

By default: the eps search (from a controller too gentle to converge, 0.4, the first eps
within 0.05 of the restricted map), the bounded design's slope against the restricted map and
its derivative against finite differences, the clearance constraint, the refusal, the walk
anyway, a short walk of the stable gait. Slow: both designs from the default guess through the
command line, and 30 steps.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from helpers import expect_usage_error

pytest.importorskip("mujoco")

DATA = Path(__file__).parent / "data"
MODEL = str(DATA / "strider.xml")
FREE = str(DATA / "strider_0.7.json")
BOUNDED = str(DATA / "strider_0.7_r0.6.json")
SITES = ["--stance", "sole_port", "--swing", "sole_starboard"]
#: steps of the default walks (one compiled walk program for both)
STEPS = 6


def _gait(path):
    from bipedlab.robots.imported import study as imported_study

    return imported_study.load_gait(MODEL, path)


def _cli_json(argv, capsys):
    from bipedlab import cli

    assert cli.main(list(argv) + ["--json"]) == 0
    out = capsys.readouterr()
    return json.loads(out.out), out.err


# ----------------------------------------------------------------------------- the controller
def test_eps_search_makes_the_full_map_converge_to_the_restricted_map():
    """From a gentle eps (0.4: the outputs' errors decay over most of the step, and the full
    map is unstable, |eig| 1.75, while the restricted map's is 0.6), the search goes down its
    grid (0.3: 1.03) to the first eps whose full map's dominant |eigenvalue| is within 0.05 of
    the restricted map's (0.2: 0.600), which makes it stable; every eps on one compiled program."""
    import dataclasses

    from bipedlab.gait import study as hs
    from bipedlab.gait import walking as gw
    from helpers import new_programs

    s, vc, z, _ = _gait(BOUNDED)
    rho = gw.restricted_eigenvalue(vc, s.study.stance, float(vc.c @ z[s.study.stance.n:]), nodes=s.study.nodes)
    assert rho == pytest.approx(0.6, abs=1e-8)
    # the default controller (eps 0.1) is within at once: the search stops at its first eps
    # (this choice compiles the analysis and the restricted map)
    ctrl0, full0, tried0, _ = hs.choose_controller(s.study, vc, z)
    assert ctrl0.eps == 0.1 and len(tried0) == 1
    assert abs(full0["ev"][0]) == pytest.approx(rho, abs=1e-4)
    gentle = gw.Controller("iolin", eps=0.4, kp=1.0, kd=2.0)
    study = dataclasses.replace(s.study, controllers=dict(s.study.controllers, iolin=gentle))
    (ctrl, full, tried, note), programs = new_programs(hs.choose_controller, study, vc, z)
    assert programs == 0  # every eps ran on the default's program: the gains are traced
    lam = [m for _, m in tried]
    assert [e for e, _ in tried][0] == 0.4 and lam[0] > 1.0  # the gentle controller: unstable
    assert all(abs(m - rho) > hs.MATCH for m in lam[:-1])     # the gentler ones are not within
    assert ctrl.eps == tried[-1][0] < 0.4 and (ctrl.kp, ctrl.kd) == (1.0, 2.0)
    assert abs(abs(full["ev"][0]) - rho) <= hs.MATCH and abs(full["ev"][0]) < 1.0
    assert full["residual"] < hs.PERIODIC_TOL and "within 0.05" in note


def test_grazing_gait_is_no_fixed_point_of_any_gain():
    """The unbounded design's swing sole touches the ground at mid-step: the closed loop from
    the fixed point touches down early, whatever eps (on Z the gains do not act), and the
    choice says so instead of searching."""
    from bipedlab.gait import study as hs
    from bipedlab.mechanics import stance as stm

    s, vc, z, rec = _gait(FREE)
    d = rec["design"]
    assert d["success"] and d["periodicity_error"] < 1e-9 and d["stable"] is False
    assert d["closed_loop_periodicity_error"] > 1.0
    ctrl, full, tried, note = hs.choose_controller(s.study, vc, z)
    assert len(tried) == 1 and full["residual"] > 1.0
    assert full["duration"] < 0.7 * d["period_s"]
    assert "does not return to it" in note and "clearance" in note
    # the early touchdown: where the closed loop stopped the sole is on the ground
    from bipedlab.gait import walking as gw

    first = gw.poincare_step_program(vc, s.study.stance, ctrl, z)[0]
    assert abs(float(stm.swing_height(s.study.stance, first.z_minus))) < 1e-9


# ----------------------------------------------------------------------------- the design
@pytest.fixture(scope="module")
def bounded_problem():
    """(setup, the bounded problem, the bounded gait's decision vector, its gait file record):
    the restricted map's slope at most 0.6 (the bounded gait's bound) and a clearance of 0.03 m
    (neither shipped gait was designed with one; only the clearance test reads its rows, which
    come before the slope's two, the last, and touch no other row). One problem, so the three
    tests below run on its one compiled evaluation (they compiled three: the problems with the
    bound alone, with the clearance alone and with neither)."""
    from bipedlab.gait import optimize as go
    from bipedlab.gait import study as hs

    s, vc, z, rec = _gait(BOUNDED)
    prob = hs.problem(s.study, 0.7, "torque", max_eigenvalue=0.6, clearance=0.03)
    return s, prob, go.pack(z, np.asarray(vc.alpha)[:, 2:prob.order - 1]), rec


def test_bounded_design_slope_is_the_restricted_maps(bounded_problem):
    """The design's eigenvalue constraint is the restricted map's slope: equal to
    walking.restricted_eigenvalue at the bounded gait (0.6, the bound, active) and off it."""
    import jax.numpy as jnp

    from bipedlab.gait import optimize as go
    from bipedlab.gait import walking as gw

    s, prob, x, rec = bounded_problem
    st, n = s.study.stance, s.study.stance.n
    ev = go.evaluator(prob)
    _, eq, ineq, met = ev(jnp.asarray(x))
    vc, z = met["vc"], met["z_minus"]
    rho = gw.restricted_eigenvalue(vc, st, float(vc.c @ z[n:]), nodes=s.study.nodes)
    assert float(met["restricted_slope"]) == pytest.approx(rho, abs=1e-10)
    assert rho == pytest.approx(rec["design"]["restricted_eigenvalue"], abs=1e-12)
    assert float(ineq[-2]) == pytest.approx(0.0, abs=1e-9)  # R - slope: the bound is active
    v = np.random.default_rng(3).standard_normal(x.size)
    m2 = ev(jnp.asarray(x + 1e-3 * v))[3]  # off the fixed point (not periodic): still the map's slope
    vc2, z2 = m2["vc"], m2["z_minus"]
    assert float(m2["restricted_slope"]) == pytest.approx(
        gw.restricted_eigenvalue(vc2, st, float(vc2.c @ z2[n:]), nodes=s.study.nodes), abs=1e-10)
    assert abs(float(m2["restricted_slope"]) - rho) > 1e-4  # it moved


def test_bounded_design_slope_differentiates(bounded_problem):
    """Forward mode through the jvp that gives the slope (what the solver's Jacobian holds)
    against central differences of the slope, along a random direction."""
    import jax
    import jax.numpy as jnp

    from bipedlab.gait import optimize as go

    s, prob, x, _ = bounded_problem
    ev = go.evaluator(prob)
    v = np.random.default_rng(3).standard_normal(x.size)
    dslope = jax.jit(jax.jvp, static_argnums=0)(lambda y: go.evaluate(prob, y)[3]["restricted_slope"],
                                                (jnp.asarray(x),), (jnp.asarray(v),))[1]
    h = 1e-6
    fd = (float(ev(jnp.asarray(x + h * v))[3]["restricted_slope"])
          - float(ev(jnp.asarray(x - h * v))[3]["restricted_slope"])) / (2 * h)
    assert abs(float(dslope)) > 0.1
    assert float(dslope) == pytest.approx(fd, rel=1e-6)


def test_clearance_constraint_rejects_the_grazing_gait(bounded_problem):
    """With a clearance of 0.03 m the grazing gait (0 m at node 23 of 40) violates the design's
    clearance rows by 10 (0 - 0.03 * 4 s (1 - s)) there; without one it is feasible: the rows of
    the problem without a clearance (their count from its evaluation's shape, traced, not
    compiled) come first and all hold."""
    import jax
    import jax.numpy as jnp

    from bipedlab.gait import optimize as go
    from bipedlab.gait import study as hs

    _, prob, _, rec_bounded = bounded_problem
    s, vc, z, rec = _gait(FREE)
    # the same robot and sites: the bounded gait's problem is the grazing gait's too
    assert (rec["design"]["stance"], rec["design"]["swing"]) == (rec_bounded["design"]["stance"],
                                                                 rec_bounded["design"]["swing"])
    plain = hs.problem(s.study, 0.7, "torque")
    x = jnp.asarray(go.pack(z, np.asarray(vc.alpha)[:, 2:plain.order - 1]))
    n_plain = jax.eval_shape(lambda y: go.evaluate(plain, y), x)[2].shape[0]
    ineq = np.asarray(go.evaluator(prob)(x)[2])
    ineq0 = ineq[:n_plain]
    assert ineq0.min() > -1e-9
    N = prob.nodes
    rows = ineq[ineq0.size:-2]  # the last two: the slope bound's
    assert rows.size == N - 1
    k = int(np.argmin(rows)) + 1
    assert k == 23 and rows[k - 1] == pytest.approx(-10 * 0.03 * 4 * (k / N) * (1 - k / N), abs=1e-9)


def test_gait_file_gains_are_checked(tmp_path):
    g = json.loads(Path(BOUNDED).read_text())
    g["payload"]["design"]["eps"] = -0.1
    p = tmp_path / "bad.json"
    p.write_text(json.dumps(g))
    from bipedlab.robots.imported import study as imported_study

    with pytest.raises(ValueError, match=r"bad\.json: payload\.design\.eps: -0\.1 is outside"):
        imported_study.load_gait(MODEL, str(p))


def test_gait_gains_drive_the_walk():
    from bipedlab.gait import study as hs

    s, vc, z, rec = _gait(BOUNDED)
    d = dict(rec["design"], eps=0.02, kp=1.5, kd=2.5)
    ctrl = hs.controller_of(s.study, dict(rec, design=d), "iolin")
    assert (ctrl.kind, ctrl.eps, ctrl.kp, ctrl.kd) == ("iolin", 0.02, 1.5, 2.5)
    assert hs.controller_of(s.study, dict(rec, design=d), "pd") == s.study.controllers["pd"]


# ----------------------------------------------------------------------------- walking
def test_walk_refuses_an_unstable_gait_in_one_line(capsys):
    line = expect_usage_error(["walk", "model", MODEL, "--gait", FREE, "--steps", str(STEPS)], capsys,
                              "not a fixed point of its closed loop")
    assert FREE in line and "--walk-anyway" in line and "eps 0.1" in line


def test_walk_anyway_warns_in_one_line_and_falls(capsys):
    """Walked anyway from the fixed point it shuffles on in short early steps (0.35 s of the
    designed 0.70 s, 40 away from the gait); disturbed by 1 % it falls in the first step."""
    rec, err = _cli_json(["walk", "model", MODEL, "--gait", FREE, "--steps", str(STEPS), "--walk-anyway",
                          "--perturb", "0.01"], capsys)
    warnings = [ln for ln in err.splitlines() if "warning" in ln]
    assert len(warnings) == 1 and "walking it anyway" in warnings[0]
    assert rec["stable"] is False and rec["fell"] is True and rec["steps_completed"] < STEPS


def _walk_back(rec, steps, rho):
    """Every step walked, and the distance to the fixed point at each touchdown shrinking by
    the dominant eigenvalue per step (measured 0.596 over the first six, 0.599 over ten): the
    1 % offset of the start, off the section, puts the first touchdown 2.5 away."""
    assert rec["stable"] is True and rec["fell"] is False and rec["steps_completed"] == steps
    assert rec["eps"] == 0.1 and rec["max_abs_eigenvalue"] == pytest.approx(rho, abs=0.05)
    dev = np.asarray(rec["deviation_per_step"])
    k = min(steps, 10) - 1
    assert (dev[k] / dev[0]) ** (1.0 / k) == pytest.approx(rho, abs=0.02)
    return dev


def test_stable_gait_walks(capsys):
    rec, err = _cli_json(["walk", "model", MODEL, "--gait", BOUNDED, "--steps", str(STEPS), "--perturb", "0.01"],
                         capsys)
    assert "warning" not in err
    _walk_back(rec, STEPS, 0.6)


@pytest.mark.slow
def test_stable_gait_walks_30_steps(capsys):
    """30 steps: back to within 5e-4 of the design's fixed point (the closed loop's own fixed
    point is 4e-4 from it: the design integrates the zero dynamics in 40 RK4 steps)."""
    rec, _ = _cli_json(["walk", "model", MODEL, "--gait", BOUNDED, "--steps", "30", "--perturb", "0.01"], capsys)
    dev = _walk_back(rec, 30, 0.6)
    assert dev[-1] < 5e-4 and dev[-1] < 2e-4 * dev[0]


# ----------------------------------------------------------------------------- the designs
@pytest.mark.slow
def test_designs_with_and_without_the_bound(capsys, tmp_path):
    """Both designs from the default guess through the command line, with no clearance bound
    (``--clearance 0``, as the shipped gaits were designed; an explicit option is not retried):
    the bound holds and is active, the records and the gait files carry the eigenvalues, the
    gains and the verdict; the unbounded design is the shipped grazing gait (restricted 0.92,
    not stable)."""
    from bipedlab.gait import gaitfile

    keys = ("restricted_eigenvalue", "max_abs_eigenvalue", "eps", "kp", "kd", "stable", "max_eigenvalue_bound")
    free, _ = _cli_json(["optimize", "model", MODEL, *SITES, "--speed", "0.7", "--clearance", "0",
                         "--save", str(tmp_path / "f.json")], capsys)
    assert free["success"] and free["periodicity_error"] < 1e-9
    assert free["restricted_eigenvalue"] == pytest.approx(0.9205, abs=1e-3)
    assert free["stable"] is False and free["max_eigenvalue_bound"] is None and free["retried"] is None
    bounded, _ = _cli_json(["optimize", "model", MODEL, *SITES, "--speed", "0.7", "--max-eigenvalue", "0.6",
                            "--clearance", "0", "--save", str(tmp_path / "b.json")], capsys)
    assert bounded["success"] and bounded["periodicity_error"] < 1e-9
    assert bounded["restricted_eigenvalue"] == pytest.approx(0.6, abs=1e-8)
    assert bounded["max_eigenvalue_bound"] == 0.6 and bounded["stable"] is True
    assert abs(bounded["max_abs_eigenvalue"] - bounded["restricted_eigenvalue"]) <= 0.05
    assert bounded["torque_cost"] > free["torque_cost"]  # stability costs torque
    for rec, name in ((free, "f.json"), (bounded, "b.json")):
        design = gaitfile.load(tmp_path / name)[2]["design"]
        for k in keys:
            assert design[k] == rec[k], k
    shipped = gaitfile.load(BOUNDED)[2]["design"]
    assert bounded["torque_cost"] == pytest.approx(shipped["torque_cost"], rel=1e-6)
