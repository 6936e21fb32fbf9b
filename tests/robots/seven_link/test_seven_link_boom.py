"""The seven-link biped's experimental setup (``--setup boom``): the Coulomb drive friction
identified from the Fig. 6 decay against the closed-form decay of an oscillator with Coulomb
friction, the boom's terms (every loss off leaves the planar model plus the added inertia; the
energy balance with the foot-turning loss), and a short boom walk."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from helpers import expect_usage_error

from bipedlab.contact import rigid as aset
from bipedlab.robots.seven_link import contact as sc
from bipedlab.robots.seven_link import robot as sl
from bipedlab.robots.seven_link import setup as su
from bipedlab.robots.seven_link import study as w

pytestmark = pytest.mark.optimized  # its time is running long simulations (tests/conftest.py)


# ----------------------------------------------------------------------------- Fig. 6
def test_coulomb_from_decay_is_the_closed_form():
    # an oscillator with Coulomb torque F_c loses 4 F_c / k of amplitude per cycle
    assert su.coulomb_from_decay(0.1, 8.0) == pytest.approx(0.2, rel=1e-15)
    fc = su.identify_drive_friction()
    for joint in ("hip", "knee"):
        k = su.swing_stiffness(joint)
        assert fc[joint] == pytest.approx(np.deg2rad(su.FIG6_DECAY_DEG[joint]) * k / 4, rel=1e-12)
    assert fc["ankle"] == fc["hip"]
    # the hanging leg's gravitational stiffness is about m g l_c of the leg (3.3 kg, ~0.4 m)
    assert 8.0 < su.swing_stiffness("hip") < 16.0 and 2.0 < su.swing_stiffness("knee") < 6.0


@pytest.mark.parametrize("joint,release_deg", [("hip", 20.0), ("knee", 25.0)])
def test_free_swing_with_identified_friction_reproduces_the_decay(joint, release_deg):
    """Simulate the Fig. 6 swing with the identified Coulomb friction alone (viscous off, the
    closed-form oracle holds for Coulomb friction only): the amplitude falls linearly by the
    read decay each cycle."""
    r = sl.model(damping=(0.0, 0.0, 0.0)).replace(setup=su.boom(boom_inertia=False, foot_turning=False))
    q0, e = su.swing_case(joint)
    t, s = w._rk4_1dof(r, q0, e, np.deg2rad(release_deg), 8.0)
    loss = np.deg2rad(su.FIG6_DECAY_DEG[joint])
    measured = su.decay_per_cycle(t, s, min_peak=loss)
    assert measured == pytest.approx(loss, rel=0.03)
    # linear, not geometric: the first and the last cycles lose the same amplitude
    d = np.diff(s)
    turn = np.flatnonzero(np.sign(d[1:]) != np.sign(d[:-1])) + 1
    peaks = np.concatenate([[abs(s[0])], np.abs(s[turn])])
    peaks = peaks[peaks > loss]
    assert len(peaks) >= 5
    assert peaks[0] - peaks[2] == pytest.approx(peaks[-3] - peaks[-1], rel=0.06)


# ----------------------------------------------------------------------------- boom terms
def _state(r):
    x0, active = w.initial_condition()
    anchors = jnp.stack([sl.point_position(r, x0[:9], n) for n in sl.CONTACTS])[:, 0]
    x, _ = sc.project(r, x0, active, anchors)
    return x, active


def test_every_loss_off_is_planar_plus_the_boom_inertia():
    planar = sl.model()
    x, active = _state(planar)
    u = jnp.asarray([1.0, -0.5, 2.0, -1.0, 0.3, 0.7])
    # no inertia, no losses: exactly the planar model
    none = su.plant(su.boom(boom_inertia=False, foot_turning=False, drive_friction=False))
    for a, b in zip(sc.solve(planar, x, u, active), sc.solve(none, x, u, active)):
        np.testing.assert_allclose(np.asarray(b), np.asarray(a), rtol=1e-10, atol=1e-10)
    # the inertia only: the planar dynamics with M + diag(m/3, m/3) and the arm's half weight
    inert = su.plant(su.boom(foot_turning=False, drive_friction=False))
    m = su.BOOM_ARM_MASS
    q, qd = x[:9], x[9:]
    M = sl.mass_matrix(planar, q).at[0, 0].add(m / 3).at[1, 1].add(m / 3)
    np.testing.assert_allclose(sl.mass_matrix(inert, q), M, rtol=1e-14)
    _, h, P, V, J, Jd = sl.dynamics_terms(planar, q, qd)
    A, ab = sc.constraint_jacobian(J, Jd)
    f = sc.applied_forces(planar, q, qd, u, h).at[1].add(-m * sl.GRAVITY / 2)
    qdd_ref, lam_ref = aset.accelerations(M, f, A, ab, sc.row_mask(active))
    qdd, lam = sc.solve(inert, x, u, active)
    np.testing.assert_allclose(qdd, qdd_ref, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(lam, lam_ref, rtol=1e-9, atol=1e-9)
    # the arm's weight rests on the feet: the normal forces carry it
    assert float(jnp.sum(lam[:4]) - jnp.sum(sc.solve(planar, x, u, active)[1][:4])) > 0.0
    assert float(sl.kinetic_energy(inert, q, qd) - sl.kinetic_energy(planar, q, qd)) == pytest.approx(
        0.5 * m / 3 * float(qd[0] ** 2 + qd[1] ** 2), rel=1e-12)


def test_energy_balance_with_the_boom_losses():
    """d(T + V)/dt of the constrained motion equals the power of the actuators, the viscous
    and Coulomb drive friction and the foot-turning loss (the no-slip contacts do no work),
    and the turning loss dissipates turn_drag |x_dot| times the total normal force."""
    r = su.plant()
    x, active = _state(r)
    x = x.at[9:].multiply(1.7)  # a faster state (still on the constraints: they are linear in qd)
    u = jnp.asarray([1.0, -0.5, 2.0, -1.0, 0.3, 0.7])
    q, qd = x[:9], x[9:]
    qdd, lam = sc.solve(r, x, u, active)
    E = lambda q, qd: sl.energy(r, q, qd)  # noqa: E731
    _, dE = jax.jvp(E, (q, qd), (qd, qdd))
    phid = sl.joint_rates(qd)
    fn = float(jnp.sum(lam[:4]))
    p_drag = float(sc.turn_drag_direction(r, qd) @ qd) * fn
    p_drive = float(u @ phid + sl.damping_force(r, qd) @ qd)
    assert float(dE) == pytest.approx(p_drive + p_drag, rel=1e-9, abs=1e-9)
    assert p_drag < 0.0 and fn > 100.0
    assert p_drag == pytest.approx(-float(r.setup.turn_drag) * abs(float(qd[0])) * fn, rel=1e-6)
    # the Coulomb friction only ever takes energy out
    assert float(sl.drive_friction(r, qd) @ phid) < 0.0


# ----------------------------------------------------------------------------- walking
#: as many steps as test_walk_seven_link's and test_seven_link_contact_sequence's short walks, so all
#: three run the one compiled walk program (the step count fixes the program)
BOOM_STEPS = 5


@pytest.mark.slow
def test_short_boom_walk_record():
    """Table II as published on the boom setup: the record's keys, and what the setup does to
    the same controller: the boom setup walks the steps, with the contacts consistent (the
    planar model, no boom losses and no knee lock, falls within 30 steps:
    test_walk_seven_link.test_thirty_steps_tuned_and_paper). The planar walk runs as the boom setup with every part off (one compiled
    program)."""
    boom = w.walk(BOOM_STEPS, "paper", setup="boom")
    planar = w.walk(BOOM_STEPS, "paper", setup="boom", without=su.PARTS)
    for key in ("setup", "speed_mps", "step_length_m", "step_frequency_hz", "cmt", "contact_events_per_step",
                "friction_coefficient", "drive_friction_nm", "versus_paper", "setup_details", "max_friction_ratio",
                "setup_parts", "friction_cone_exceeded"):
        assert key in boom, key
    assert not any(planar["setup_parts"].values())
    assert boom["setup"] == "boom" and all(boom["setup_parts"].values())
    assert boom["friction_coefficient"] == su.FRICTION_COEFFICIENT
    assert boom["drive_friction_nm"] == pytest.approx(su.identify_drive_friction())
    assert boom["versus_paper"]["speed_mps"]["paper"] == 0.5 and boom["versus_paper"]["cmt"]["paper"] == 0.31
    assert boom["setup_details"]["added_mass_horizontal_kg"] == pytest.approx(su.BOOM_ARM_MASS / 3)
    assert boom["contact_events_per_step"] == boom["events_per_step"]
    assert not boom["fell"] and boom["steps_completed"] == BOOM_STEPS
    assert boom["friction_cone_exceeded"] == (boom["max_friction_ratio"] > su.FRICTION_COEFFICIENT)
    assert boom["max_impact_energy_change_j"] <= 1e-9
    assert boom["max_constraint_drift"]["position_after_projection_m"] < 1e-8


def test_cli_rejects_an_unknown_setup(capsys):
    expect_usage_error(["walk", "seven-link", "--setup", "treadmill"], capsys, "--setup")


def test_the_planar_walk_is_the_boom_program_with_every_part_off():
    """The planar model runs as the boom setup with all its additions zero: after a planar
    walk, a boom walk of the same length compiles no program (JAX's compile events), and the
    planar walk equals the every-part-off boom walk bit for bit while the full boom differs."""
    compiles = []

    def listen(name, duration, **_):
        if name == "/jax/core/compile/backend_compile_duration":
            compiles.append(duration)

    planar = w.run_walk(BOOM_STEPS, "paper")
    jax.monitoring.register_event_duration_secs_listener(listen)
    try:
        off = w.run_walk(BOOM_STEPS, "paper", setup="boom", without=su.PARTS)
        boom = w.run_walk(BOOM_STEPS, "paper", setup="boom")
    finally:
        jax.monitoring.unregister_event_duration_listener(listen)
    assert compiles == []
    for a, b in zip(jax.tree_util.tree_leaves(planar), jax.tree_util.tree_leaves(off)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    assert not np.array_equal(np.asarray(boom.td_time), np.asarray(planar.td_time))


def test_table_i_scaled_in_the_plant_is_data_and_reaches_only_what_it_should():
    """The sensitivity's premise: a scaled Table I value is data of the walk's compiled program
    (no new program), scaled in the plant only. The body's length places only the head (a
    drawing point): the walk is the same bit for bit. The body's mass, +1 %: the plant weighs
    61.2 g more while the controller keeps Table I, and the walk changes."""
    from helpers import new_programs

    from bipedlab.robots.seven_link import robot as sl

    base = w.run_walk(BOOM_STEPS, "paper", setup="boom")
    head, built = new_programs(w.run_walk, BOOM_STEPS, "paper", setup="boom", scale={("body", "length"): 1.3})
    assert built == 0
    for a, b in zip(jax.tree_util.tree_leaves(base), jax.tree_util.tree_leaves(head)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    heavy, built = new_programs(w.run_walk, BOOM_STEPS, "paper", setup="boom", scale={("body", "mass"): 1.01})
    assert built == 0
    assert not np.array_equal(np.asarray(heavy.td_time), np.asarray(base.td_time))
    assert float(sl.total_mass(sl.model(scale={("body", "mass"): 1.01}))) == pytest.approx(
        float(sl.total_mass(sl.model())) + 0.0612, abs=1e-12)
    with pytest.raises(ValueError, match="no Table I value"):
        sl.model(scale={("body", "colour"): 1.1})


def test_printed_precision_is_half_a_unit_of_the_last_printed_digit():
    from bipedlab.robots.seven_link import robot as sl

    assert sl.printed_precision("body", "mass") == pytest.approx(0.005 / 6.12)
    assert sl.printed_precision("body", "length") == pytest.approx(0.0005 / 0.390)  # "0.390": three decimals
    assert sl.printed_precision("thigh", "inertia") == pytest.approx(0.00005 / 0.0096)
    assert sl.BODY["length"] == 0.39 and sl.ACTUATORS["knee"]["J"] == 0.0022


def test_the_sensitivity_of_a_short_boom_walk(monkeypatch):
    """Three parameters over the short walk: the unscaled walk is the one-walk study's, the
    body's length (the head only) has elasticity 0 exactly, each elasticity is the forward
    difference of the scaled walk's figures, and the reach counts Table I's parameters only (the
    boom's mass is assumed)."""
    from bipedlab.robots.seven_link import sensitivity as sv

    monkeypatch.setattr(sv, "table_parameters", lambda: [("thigh", "mass"), ("body", "length")])
    monkeypatch.setattr(sv, "SETUP", {"boom arm mass": sv.SETUP["boom arm mass"]})
    rec = sv.sensitivity(BOOM_STEPS, "paper", step=0.01)
    assert rec["walks"] == 4 and rec["fell"] == []
    one = w.walk(BOOM_STEPS, "paper", setup="boom")
    base = rec["base"]
    for q in sv.QUANTITIES:
        assert base[q] == one[q]
        assert rec["parameters"]["body.length"]["elasticity"][q] == 0.0
    for r in rec["parameters"].values():
        for q in sv.QUANTITIES:
            assert r["elasticity"][q] == pytest.approx((r["scaled"][q] - base[q]) / (0.01 * base[q]), rel=1e-12)
    thigh = rec["parameters"]["thigh.mass"]
    assert thigh["elasticity"]["speed_mps"] != 0.0 and thigh["precision"] == pytest.approx(0.005 / 0.67)
    assert rec["parameters"]["boom arm mass"]["precision"] is None
    assert sv.reach(rec, "speed_mps") == pytest.approx(abs(thigh["elasticity"]["speed_mps"]) * thigh["precision"])


def test_elasticities_reach_and_summary_of_a_sensitivity_record():
    """The arithmetic of the sensitivity on made-up walks: forward differences relative to the
    unscaled walk, none where the scaled walk fell, the reach over the stated parameters only."""
    from bipedlab.robots.seven_link import sensitivity as sv

    base = dict(speed_mps=0.8, step_length_m=0.7, step_frequency_hz=1.2, cmt=0.4, fell=False)
    scaled = dict(speed_mps=0.81, step_length_m=0.7, step_frequency_hz=1.2 * 0.81 / 0.8, cmt=0.39, fell=False)
    e = sv._elasticity(scaled, base, 0.01)
    assert e["speed_mps"] == pytest.approx(0.01 / (0.01 * 0.8)) and e["step_length_m"] == 0.0
    assert e["cmt"] == pytest.approx(-0.01 / (0.01 * 0.4))
    assert sv._elasticity(dict(scaled, fell=True), base, 0.01) == dict.fromkeys(sv.QUANTITIES)
    rec = dict(base=base, parameters={
        "thigh.mass": dict(precision=0.005, elasticity=e),
        "boom arm mass": dict(precision=None, elasticity=dict(e, speed_mps=9.0))},
        fell=[], method="m", precision_source="Table I", walks=3, wall_time_s=1.0)
    assert sv.reach(rec, "speed_mps") == pytest.approx(0.005 * 1.25)
    text = sv.summary(rec)
    assert "thigh.mass" in text and "assumed" in text and "speed_mps 0.63%" in text
