"""The HZD paper's design rows as functions of MABEL's published values (``bipedlab experiment
mabel sensitivity``): each value scaled where the model uses it and nowhere else, the printed
precisions against the tables, the forward differences on a stand-in with known elasticities,
the report attaching them only to the optimum it found again, and (slow) a real re-design whose
elasticities obey the paper's design model (it has no spring damping)."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from helpers import expect_usage_error, new_programs

from bipedlab.mechanics import coupled as cp
from bipedlab.report.spec import Measured, Skip, printed_precision, with_sensitivity
from bipedlab.robots.mabel import model as mm
from bipedlab.robots.mabel import reproduce as mr
from bipedlab.robots.mabel import tables as tb
from bipedlab.robots.mabel.walking import sensitivity as ws
from bipedlab.robots.mabel.walking import stance as wk
from bipedlab.robots.mabel.walking import zero_dynamics as zd

STEP = 1.01


def _toe_reach(m):
    """Hip-to-toe distance of the straight left leg (all angles 0: the leg points up)."""
    q = jnp.zeros(m.n)
    return float(np.linalg.norm(np.asarray(cp.point_position(m.body, q, "toe_L") - cp.point_position(m.body, q, "hip"))))


#: per scaled value: what it must multiply by STEP in the 9-DoF walking model
_EFFECTS = {
    "torso mass": lambda m: float(m.body.tree.mass[0]),
    "torso COM height": lambda m: float(m.body.tree.com[0, 1]),
    "thigh mass": lambda m: float(m.body.tree.mass[m.body.tree.body_names.index("thigh_L")]),
    "shin mass": lambda m: float(m.body.tree.mass[m.body.tree.body_names.index("shin_R")]),
    "spring stiffness": lambda m: np.asarray(m.drive.spring_k),
    "spring damping": lambda m: float(m.drive.spring_d),
    "motor friction": lambda m: np.asarray(m.drive.friction),
    "torque capacity": lambda m: np.asarray(m.drive.torque_limit),
    "boom mass": lambda m: float(np.asarray(m.body.weight)[1]),
    "boom inertia": lambda m: float(np.asarray(m.body.rotor_inertia)[m.body.rotor_names.index("boom_yaw")]),
    "leg-shape rotor inertia": lambda m: float(np.asarray(m.body.rotor_inertia)[m.body.rotor_names.index("mLS_L")]),
    "leg-angle rotor inertia": lambda m: float(np.asarray(m.body.rotor_inertia)[m.body.rotor_names.index("mLA_R")]),
}


def _leaves(m):
    return [np.asarray(x) for x in jax.tree_util.tree_leaves(m)]


@pytest.mark.parametrize("name", list(mm.SCALABLE))
def test_a_scaled_value_changes_its_own_leaves_and_keeps_the_program(name):
    m0, m = wk.walking_model(), wk.walking_model(scale=((name, STEP),))
    assert jax.tree_util.tree_structure(m) == jax.tree_util.tree_structure(m0)  # one compiled program serves both
    changed = [i for i, (a, b) in enumerate(zip(_leaves(m0), _leaves(m))) if not np.array_equal(a, b)]
    assert 1 <= len(changed) <= 2
    if name in _EFFECTS:
        f = _EFFECTS[name]
        assert np.asarray(f(m)) == pytest.approx(STEP * np.asarray(f(m0)), rel=1e-12)


def test_inertias_about_the_joint_lengths_and_mass_follow_the_table():
    m0 = wk.walking_model()
    # Table VII's inertia is about the joint: scaling it moves the COM inertia by the whole change
    i0 = float(m0.body.tree.inertia[0])
    m = wk.walking_model(scale=(("torso inertia", STEP),))
    assert float(m.body.tree.inertia[0]) - i0 == pytest.approx(0.01 * tb.LINKS["torso"][2], rel=1e-10)
    # a heavier torso with the table's joint inertia: the COM inertia loses m r^2 of the extra mass
    m = wk.walking_model(scale=(("torso mass", STEP),))
    r2 = sum(c * c for c in tb.LINKS["torso"][1])
    assert float(m.body.tree.inertia[0]) - i0 == pytest.approx(-0.01 * tb.LINKS["torso"][0] * r2, rel=1e-10)
    # c_mt's M is the model's: the torso's extra 1 % of 40.8953 kg
    assert float(zd.robot_mass(m)) - zd.robot_mass() == pytest.approx(0.01 * 40.8953, rel=1e-10)
    assert float(zd.robot_mass(m0)) == pytest.approx(zd.robot_mass(), rel=1e-15)
    # the straight leg reaches thigh + shin = 1 m from the hip; 1 % more thigh adds 5 mm
    assert _toe_reach(m0) == pytest.approx(1.0, rel=1e-12)
    assert _toe_reach(wk.walking_model(scale=(("thigh length", STEP),))) == pytest.approx(1.005, rel=1e-12)
    assert _toe_reach(wk.walking_model(scale=(("shin length", STEP),))) == pytest.approx(1.005, rel=1e-12)
    # the unscaled model is the published one, leaf for leaf
    assert all(np.array_equal(a, b) for a, b in zip(_leaves(m0), _leaves(wk.walking_model(scale=()))))
    with pytest.raises(ValueError, match="unknown MABEL parameter.*'?leg'?"):
        mm.hopping_model(scale=(("leg", 1.1),))


#: each printed form and the table value it must equal
_TABLE = {
    "torso mass": [tb.LINKS["torso"][0]], "torso COM height": [tb.LINKS["torso"][1][1]],
    "torso inertia": [tb.LINKS["torso"][2]], "thigh mass": [tb.LINKS["thigh"][0]], "thigh inertia": [tb.LINKS["thigh"][2]],
    "shin mass": [tb.LINKS["shin"][0]], "shin inertia": [tb.LINKS["shin"][2]], "boom mass": [tb.BOOM["mass"]],
    "boom inertia": [tb.BOOM["inertia"]], "leg-shape rotor inertia": [tb.ROTOR_INERTIA["mLS"]],
    "leg-angle rotor inertia": [tb.ROTOR_INERTIA["mLA"]], "spring stiffness": [tb.SPRING_K["L"], tb.SPRING_K["R"]],
    "spring damping": [tb.SPRING_DAMPING], "motor friction": [tb.FRICTION[a] for a in ("mLS_L", "mLA_L", "mLS_R", "mLA_R")],
    "torque capacity": [tb.TORQUE_CAPACITY["mLA"], tb.TORQUE_CAPACITY["mLS"]],
}


def test_printed_forms_are_the_tables_values_and_give_their_precision():
    assert set(ws.PRINTED) == set(mm.SCALABLE)
    for name, forms in ws.PRINTED.items():
        if forms is None:
            assert name in ("thigh length", "shin length") and ws.precision(name) is None
            continue
        assert [float(t) for t in forms] == _TABLE[name], name
        assert ws.precision(name) == max(printed_precision(t) for t in forms)
    # half a unit of the last printed digit over the value
    assert printed_precision("40.8953") == pytest.approx(0.00005 / 40.8953, rel=1e-12)
    assert printed_precision("9.0144e-4") == pytest.approx(0.00005e-4 / 9.0144e-4, rel=1e-12)
    assert printed_precision("30") == pytest.approx(0.5 / 30, rel=1e-12)
    assert printed_precision("3.0e6") == pytest.approx(0.05e6 / 3.0e6, rel=1e-12)
    assert ws.precision("torque capacity") == pytest.approx(0.5 / 30)  # the coarser of 30 and 55
    for bad in ("", "abc", "0", "nan"):
        with pytest.raises(ValueError):
            printed_precision(bad)


def _stand_in(scale, start=None):
    """Rows with known elasticities: a = p_torso_mass^2 (2), b = 1 / p_boom_mass (-1), c = 3
    (0); the spring damping's 're-design' fails. The unscaled run (no start) gives its optimum
    as the start of every scaled one."""
    f = dict(scale)
    assert (start is None) == (not f) and (start is None or start == dict(nominal=1.0))
    rows = dict(a=f.get("torso mass", 1.0) ** 2, b=1.0 / f.get("boom mass", 1.0), c=3.0, d=None)
    return rows, "spring damping" not in f, dict(nominal=1.0)


def test_forward_differences_give_the_known_elasticities():
    names = ["torso mass", "boom mass", "spring damping", "thigh length"]
    rec = ws.sensitivity(step=0.01, parameters=names, redesign_fn=_stand_in)
    p = rec["parameters"]
    assert p["torso mass"]["elasticity"]["a"] == pytest.approx(2.01, rel=1e-12)  # ((1.01)^2 - 1) / 0.01
    assert p["boom mass"]["elasticity"]["b"] == pytest.approx((1 / 1.01 - 1) / 0.01, rel=1e-12)
    assert p["thigh length"]["elasticity"] == dict(a=0.0, b=0.0, c=0.0, d=None)
    assert rec["failed"] == ["spring damping"] and set(p["spring damping"]["elasticity"].values()) == {None}
    assert rec["designs"] == 10 and rec["base"] == dict(a=1.0, b=1.0, c=3.0, d=None)
    # reach: the stated precisions times |elasticity| (the lengths have none)
    assert ws.reach(rec, "a") == pytest.approx(2.01 * ws.precision("torso mass"), rel=1e-12)
    assert "spring damping" in ws.summary(rec)
    with pytest.raises(ValueError, match="unknown MABEL parameter"):
        ws.sensitivity(parameters=["leg"], redesign_fn=_stand_in)


def test_the_report_attaches_the_elasticities_only_to_the_optimum_found_again():
    rec = ws.sensitivity(step=0.01, parameters=["torso mass", "spring damping"], redesign_fn=_stand_in)
    rows = {"a": 1.00005, "b": Measured(1.5, dict(x=1)), "c": Skip("not run"), "e": 2.0}
    out = with_sensitivity(rows, rec, rel=1e-4)
    assert set(out) == {"a"}  # b is another optimum (1.5 vs 1.0); c was not measured; e is not in the record
    s = out["a"].sensitivity
    assert s.elasticity == {"torso mass": pytest.approx(2.01)} and s.precision == {"torso mass": ws.precision("torso mass")}
    assert out["a"].value == 1.00005 and with_sensitivity(rows, rec, rel=1e-6) == {}
    # the HZD paper's measure attaches the experiment's record to the design rows it reproduces
    assert mr.SAME_OPTIMUM == 1e-4


def test_experiment_sensitivity_takes_no_steps(capsys):
    expect_usage_error(["experiment", "mabel", "sensitivity", "--steps", "3"], capsys, "--steps does not apply")


@pytest.mark.slow
def test_a_real_redesign_moves_with_the_spring_damping_only_through_the_closed_loop():
    """The paper's design model has no spring damping (eq. 36): scaling Kd_B leaves both designs
    and their restricted maps where they were (the same optimum, the same program), while the full
    map under PD + feedforward, which runs on the walking model, moves."""
    rec = ws.sensitivity(step=0.01, parameters=["spring damping"])
    e = rec["parameters"]["spring damping"]["elasticity"]
    for row in ("nominal_step_length_m", "nominal_cmt", "efficient_cmt", "nominal_eig_hzd", "efficient_eig_hzd"):
        assert abs(e[row]) < 1e-6, row
    assert abs(e["nominal_eig_pdff"]) > 1e-3 and abs(e["efficient_eig_pdff"]) > 1e-3
    assert rec["base"]["nominal_step_length_m"] == pytest.approx(0.45679, abs=2e-5)  # the shipped gait's optimum


def _plant_stand_in(scale):
    """Rows of a 'plant': a = 2 p^2 in the torso mass (elasticity 2.1 at +10 %); b = 5 plus a
    rounding jitter of 0.01 / 0.02 for the two replicas (noise s.d. 0.01), no physical dependence."""
    f = dict(scale)
    jitter = 1e10 * (f.get("torso mass", 1.0) - 1.0) + 2e10 * (f.get("boom inertia", 1.0) - 1.0)
    return dict(a=2.0 * f.get("torso mass", 1.0) ** 2, b=5.0 + (jitter if abs(jitter) < 1 else 0.0))


def test_the_plant_tier_measures_the_rows_noise_from_rounding_replicas():
    rec = ws.plant_sensitivity(step=0.1, parameters=["torso mass", "spring stiffness"], rows_fn=_plant_stand_in)
    assert rec["noise"]["b"] == pytest.approx(0.01, rel=1e-3)  # 1 + 1e-12 is not exact in binary
    e, se = rec["parameters"]["torso mass"]["elasticity"], rec["parameters"]["torso mass"]["standard_error"]
    assert e["a"] == pytest.approx(2.1) and e["b"] == 0.0
    assert se["b"] == pytest.approx(np.sqrt(2) * rec["noise"]["b"] / (0.1 * 5.0), rel=1e-9)
    # a row computed apart (constant model) is attached within three noise s.d.s of the base, not beyond
    near, far = dict(b=5.0 + 2.5 * rec["noise"]["b"]), dict(b=5.0 + 3.5 * rec["noise"]["b"])
    assert set(with_sensitivity(near, rec)) == {"b"} and with_sensitivity(far, rec) == {}
    # the elasticity of b is zero within its noise: the report's closing counts it nowhere
    from bipedlab.report import values

    s = with_sensitivity(near, rec)["b"].sensitivity
    assert values.closing(5.0, 7.0, s)["within_noise"] == ["spring stiffness", "torso mass"]
    # the summary prints the plant tier beside the design tier, each elasticity with its standard error
    design = ws.sensitivity(step=0.01, parameters=["torso mass"], redesign_fn=_stand_in)
    text = ws.summary(dict(design, plant=rec))
    assert "to the plant" in text and f"a +2.1 +- {se['a']:.2g}" in text


def test_a_plant_built_with_other_values_is_data_of_one_walking_program():
    from bipedlab.robots.mabel.walking import study as wm

    const = wm.walk("paper-575", "pdff", 3)
    base = wm.walk("paper-575", "pdff", 3, plant_scale=())
    heavy, programs = new_programs(wm.walk, "paper-575", "pdff", 3, plant_scale=(("torso mass", 1.1),))
    assert programs == 0  # the scaled plant runs on the program of the unscaled one
    # the published values as data give the constant model's walk up to rounding (measured 1e-8)
    assert base["speed_mps"] == pytest.approx(const["speed_mps"], rel=1e-6)
    assert base["cmt"] == pytest.approx(const["cmt"], rel=1e-6)
    # a heavier torso in the plant alone changes the walk, and its c_mt is over the heavier robot's mass
    mass = wm.plant_mass((("torso mass", 1.1),))
    assert mass == pytest.approx(wm.robot_mass() + 0.1 * tb.LINKS["torso"][0], rel=1e-12)
    assert abs(heavy["speed_mps"] / const["speed_mps"] - 1.0) > 1e-3
    assert heavy["plant_scale"] == [["torso mass", 1.1]] and "plant_scale" not in const


def test_the_restricted_maps_eigenvalues_are_named_by_modulus():
    from bipedlab.robots.mabel.walking import catalog

    assert catalog.by_magnitude([[0.1, 0.2], [0.8, 0.0], [-0.3, 0.0]]) == [0.8, -0.3, 0.1 + 0.2j]
    assert catalog.by_magnitude(None) == []
    # the design rows and the report's name the same ones: eq. 49's second is the real part of the second largest
    rows = ws.design_quantities(type("D", (), dict(figures=dict(cmt=0.1, negative_work_fraction_spring=0.5,
                                                                step_length=0.45)))(),
                                dict(hzd=dict(max_abs_eigenvalue=0.8,
                                              poincare_eigenvalues_complex=[[0.1, 0.2], [0.8, 0.0], [-0.3, 0.0]])),
                                "nominal")
    assert rows["nominal_eig_hzd_minor_1"] == -0.3 and rows["nominal_eig_hzd_minor_2"] == 0.1
    assert mr._minor_eigenvalue(dict(eigenvalues_hzd=[[0.1, 0.2], [0.8, 0.0], [-0.3, 0.0]]), 2).value == 0.1


def _linear_push(gait, controller, force, ref, steps, push_step=None, progress=None, plant="stance", plant_scale=None,
                 direction=None):
    """A 'walk' whose peak change is linear in the force, c = 0.003 p F (p: the torso mass factor),
    back within 2 % after 4 steps forward and 2 backward."""
    p = dict(plant_scale or ()).get("torso mass", 1.0)
    return dict(speed_change=0.003 * p * force / ref, steps_to_recover=4 if force > 0 else 2, fell=False)


def test_the_searched_forces_move_to_first_order_in_the_change_they_make(monkeypatch):
    from bipedlab.robots.mabel.walking import experiments as wx

    def search(controller, target, f0, ref, steps, progress=None, plant="stance", plant_scale=None):
        f = target / 0.003  # the root of the linear change
        return dict(force_n=f, speed_change=0.003 * f, converged=True, fell=False, steps_to_recover=4 if f > 0 else 2)

    monkeypatch.setattr(wx, "push_at", _linear_push)
    monkeypatch.setattr(wx, "search_push", search)
    monkeypatch.setattr(ws, "_reference", lambda plant, scale, progress=None: 1.0)
    base = ws.force_base()
    assert set(base) == set(ws.FORCE_ROWS)
    assert base["push_force_plus_45pct_n"]["slope"] == pytest.approx(0.003, rel=1e-9)
    rows = ws.force_rows((), base)
    for row, b in base.items():  # the published plant gives the searched force itself
        assert rows[row] == b["force_n"] == pytest.approx(np.sign(wx.TARGET_CHANGES[ws.FORCE_ROWS[row][1]]) * 150.0)
    assert [rows[k] for k in ws.FULL_RECOVERY_ROWS] == [4.0, 2.0, 2.0]
    # a 10 % stronger response: the root moves to 136.4 N; first order from 150 N: 150 - 0.045 / 0.003 = 135 N
    scaled = ws.force_rows((("torso mass", 1.1),), base)
    assert scaled["push_force_plus_45pct_n"] == pytest.approx(135.0, rel=1e-12)
    assert scaled["fullplant_push_force_minus_45pct_n"] == pytest.approx(-135.0, rel=1e-12)


def test_the_plant_tier_runs_the_force_searches_once_and_every_plants_force_rows(monkeypatch):
    calls = []
    monkeypatch.setattr(ws, "plant_rows", lambda scale, progress=None: dict(a=2.0 * dict(scale).get("torso mass", 1.0)))
    monkeypatch.setattr(ws, "force_base", lambda progress=None: calls.append("base") or dict(f=dict(force_n=100.0)))
    monkeypatch.setattr(ws, "force_rows", lambda scale, base, progress=None: dict(
        f=base["f"]["force_n"] * dict(scale).get("torso mass", 1.0) ** 3))
    rec = ws.plant_sensitivity(step=0.1, parameters=["torso mass", "spring stiffness"])
    assert calls == ["base"] and rec["searches"] == dict(f=dict(force_n=100.0))
    e = rec["parameters"]["torso mass"]["elasticity"]
    assert e["a"] == pytest.approx(1.0) and e["f"] == pytest.approx((1.1 ** 3 - 1) / 0.1)
    assert rec["parameters"]["spring stiffness"]["elasticity"] == dict(a=0.0, f=0.0)
