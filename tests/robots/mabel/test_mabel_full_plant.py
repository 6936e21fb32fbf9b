"""MABEL's walking controllers on the 13-DoF plant (``walk mabel --plant full``): the
design-to-robot gap of the compliant-HZD paper (Sections V-A, V-C, VI-C) in simulation.

Oracles: the stance model the gaits are designed on (the 13-DoF state built from a stance state
reads back that stance state; with rigid cables the two models share their kinematics), the
mirror symmetry of the relabelling, and the paper's Exp. 1 measurements (PD + feedforward
tracking error of the stance motor leg shape; realised c_mt about three times the designed)."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from helpers import expect_usage_error

from bipedlab.robots.mabel import dynamics as mdyn
from bipedlab.robots.mabel import model as mm
from bipedlab.robots.mabel import transmission as tr
from bipedlab.robots.mabel.walking import full_plant as fp
from bipedlab.robots.mabel.walking import study as wm

#: Exp. 1 (PD + feedforward on the robot): RMSE of the stance motor leg-shape output, deg
#: (Section V-D: "from 29.82 deg to 0.28 deg")
PAPER_MLS_ST_RMSE_DEG = 29.82


def _z_plus(gait="nominal"):
    return jnp.asarray(wm.load_gait(gait)[2]["z_plus"])


def test_initial_state_reads_back_the_stance_state():
    """The 13-DoF state built from the nominal gait's post-impact stance state: its stance
    coordinates (left leg in stance) are that state exactly, the stance toe is at the origin,
    and both cables of both legs are unstretched (rigid-cable configuration)."""
    z = _z_plus()
    p = fp.initial_plant(z)
    q, qd = fp.stance_state(p.x, p.stance)
    np.testing.assert_allclose(np.asarray(q), np.asarray(z[:6]), rtol=0, atol=1e-14)
    np.testing.assert_allclose(np.asarray(qd), np.asarray(z[6:]), rtol=0, atol=1e-12)
    m = fp.plant_model()
    toes = np.asarray(mdyn.toe_positions(m, p.x[:13]))
    np.testing.assert_allclose(toes[0], 0.0, atol=1e-12)
    named = {c: float(p.x[i]) for i, c in enumerate(mm.COORDS_13)}
    for s in ("L", "R"):
        lam = tr.cable_stretch(*(named[f"{c}_{s}"] for c in tr.LOCAL))
        np.testing.assert_allclose(np.asarray(lam, float), 0.0, atol=1e-12)


def test_relabelling_is_the_mirror():
    """A state with the legs swapped, read with the right leg in stance, gives the stance
    coordinates of the original with the left leg in stance; the torques of the right-stance
    controller go to the right leg's motors first."""
    x = np.asarray(fp.initial_plant(_z_plus()).x)
    swap = [mm.COORDS_13.index(c.replace("_L", "_X").replace("_R", "_L").replace("_X", "_R")) for c in mm.COORDS_13]
    xs = np.concatenate([x[:13][swap], x[13:26][swap], x[26:][::-1]])
    for a, b in zip(fp.stance_state(jnp.asarray(xs), 1), fp.stance_state(jnp.asarray(x), 0)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    u = jnp.asarray([1.0, 2.0, 3.0, 4.0])
    np.testing.assert_array_equal(np.asarray(fp.actuator_torques(u, 1)), [3.0, 4.0, 1.0, 2.0])
    np.testing.assert_array_equal(np.asarray(fp.actuator_torques(u, 0)), [1.0, 2.0, 3.0, 4.0])


def _walk(steps):
    return wm.walk("nominal", "pdff", steps, plant="full")


@pytest.mark.slow
def test_nominal_gait_on_the_full_plant_shows_the_papers_gap():
    """The nominal gait under PD + feedforward on encoders, 8 steps on the 13-DoF plant.

    - It walks (no fall) and the record carries ``plant`` and ``cmt_designed``.
    - The stance motor leg-shape tracking error grows from about 1 deg RMS on the stance
      model (golden record cli_walk_mabel: 1.08 deg) to the size the paper measured on the
      robot in Exp. 1, 29.82 deg: asserted within a factor 2 (measured 27.4 deg over these
      8 steps, 30.4 over 100). Cable stretch between the motor and the leg is what the output
      sees: the motor angle moves while the leg shape is held by the spring.
    - The swing spring is not held at rest (Fig. 15): it deflects by more than 1 deg.
    - The realised c_mt exceeds the designed one (paper: about 0.15 against 0.0452). Against
      the gait's own design model (motor friction and spring damping included, 0.1435) the
      ratio is 1.37 here; against the same decision vector on the HZD paper's design model (no
      friction or damping, 0.101) it is about 2 (1.95 over 8 steps, 2.03 over 100): the factor
      the paper's design-to-robot gap is measured with; asserted >= 1.8."""
    r = _walk(8)
    assert r["plant"] == "full" and r["fell"] is False and r["steps_completed"] == 8
    assert r["cmt_designed"] == pytest.approx(wm.load_gait("nominal")[2]["design"]["cmt"])
    rms = r["tracking_rms_deg"]["mLS_st"]
    assert PAPER_MLS_ST_RMSE_DEG / 2 <= rms <= 2 * PAPER_MLS_ST_RMSE_DEG
    assert r["swing_spring_peak_deg"] > 1.0
    assert r["cmt"] > r["cmt_designed"]
    assert r["cmt_designed_paper_model"] < r["cmt_designed"]
    assert r["cmt_ratio_paper_model"] >= 1.8


@pytest.mark.slow
def test_nominal_gait_walks_100_steps_on_the_full_plant():
    """100 steps as the experiments ran: no fall; realised c_mt at least twice the designed
    one on the paper's design model (measured 0.206 / 0.101 = 2.03; the paper's robot: about
    3.3); the left and right stance steps alternate in speed (period-two gait, measured
    0.53 / 1.02 m/s), the PD + feedforward loop's alternating Poincaré mode (eigenvalue
    -0.89 on the stance model) grown into an alternation on this plant."""
    r = _walk(100)
    assert r["fell"] is False and r["steps_completed"] == 100
    assert r["cmt_ratio_paper_model"] >= 2.0
    assert abs(r["speed_left_stance_mps"] - r["speed_right_stance_mps"]) > 0.1


def test_full_plant_refuses_impact_scaling(capsys):
    """The impact scaling is a stance-model option (the full plant's impact is its ground's):
    one line, exit 2."""
    expect_usage_error(["walk", "mabel", "--plant", "full", "--steps", "4", "--impact-scale", "0.97"], capsys,
                       "--plant full")


def test_the_stance_plant_refuses_a_ground_scale_and_the_scale_has_a_range(capsys):
    """--ground-scale is a 13-DoF plant option (the stance plant pins its toe), in 0.01 to 100:
    one line, exit 2, before anything compiles."""
    expect_usage_error(["walk", "mabel", "--steps", "4", "--ground-scale", "10"], capsys, "--ground-scale")
    expect_usage_error(["walk", "mabel", "--plant", "full", "--ground-scale", "0"], capsys, "--ground-scale")


def test_push_on_the_full_plant_speeds_up_and_slips_without_a_fall():
    """The paper's 78 N forward push over the second half of step 2, paper-nominal gait under
    PD + feedforward on the 13-DoF plant: the steps after it are faster than the unpushed ones
    (by more than 10 %: the paper's push gave 45 % on the robot), the run is no fall, and the
    push is in the log (78 N while it acts, 0 otherwise)."""
    r = wm.walk("paper-nominal", "pdff", 6, push=(78.0, 2), plant="full")
    assert r["fell"] is False and r["steps_completed"] == 6
    sp = r["speed_per_step"]
    assert max(sp[2:4]) > 1.10 * sp[1]
    assert r["push_force_n"] == 78.0


def test_paper_design_gap_is_at_least_twofold():
    """The paper-nominal gait (designed on the paper's design model, the default of optimize
    mabel) under PD + feedforward on encoders, 8 steps on the 13-DoF plant: it walks, and the
    realised c_mt is at least twice the designed one, as on the robot (Sec. V-C: about three
    times; measured here 2.30 over 8 and 20 steps). The realised c_mt is the robot's Exp. 1
    value, 0.15, within 25 % (measured 0.142). The swing spring is not held at rest (Fig. 15):
    it deflects by more than 1 deg (measured 2.6)."""
    r = wm.walk("paper-nominal", "pdff", 8, plant="full")
    assert r["plant"] == "full" and r["fell"] is False and r["steps_completed"] == 8
    assert r["cmt_designed"] == pytest.approx(r["cmt_designed_paper_model"], rel=1e-6)
    assert r["cmt_ratio"] >= 2.0
    assert r["cmt"] == pytest.approx(0.15, rel=0.25)
    assert r["swing_spring_peak_deg"] > 1.0


def test_the_grazing_c_mt_gait_scuffs_on_the_full_plant_and_the_clearance_gait_walks():
    """paper-efficient's swing toe grazes the ground at mid-step (designed): on the 13-DoF plant
    (cable stretch) it meets the ground as the legs cross, a first "step" of a few centimetres
    instead of the designed 0.35 m, and PD + feedforward falls within four steps (measured: step
    4, 0.78 s). Exp. 3's gait, the same design with 1 cm of clearance at mid-step, walks its
    designed steps (measured: 100 steps under each controller)."""
    grazing = wm.walk("paper-efficient", "pdff", 5, plant="full")
    assert grazing["fell"] and grazing["steps_completed"] <= 3
    assert abs(grazing["step_lengths_m"][0]) < 0.1
    clear = wm.walk("paper-efficient-clear", "pdff", 5, plant="full")
    designed = wm.load_gait("paper-efficient-clear")[2]["design"]["step_length"]
    assert not clear["fell"] and clear["steps_completed"] == 5
    assert np.allclose(clear["step_lengths_m"], designed, rtol=0.3)




def test_exact_sensing_on_the_compliant_ground_reads_predicted_rates_at_the_touchdown():
    """At the contact-switch sample the 13-DoF plant's exact rates are still pre-impact (its
    ground's impact takes milliseconds): the full plant's controller takes the model's
    post-impact prediction from its last state, as the encoders' estimate does, while the
    stance model (whose rigid impact has happened) keeps reading its exact rates. Oracle: the
    stance model's impact map applied to the previous sample's state."""
    from bipedlab.robots.mabel.walking import loop as sw
    from bipedlab.robots.mabel.walking import stance as wk

    vc, g, rec = wm.load_gait("paper-nominal")
    setup = wm.setup_for(vc, g, rec["design"]["period"], sensing="ideal")
    z = jnp.asarray(rec["z_plus"])
    c = sw.initial_ctrl(setup, z)
    pre = jnp.asarray(np.asarray(z[6:]) * 1.3)  # rates the impact has not yet changed
    r = sw.Reading(q=z[:6], qd=pre, impacted=jnp.asarray(True), step=jnp.asarray(1))
    m = wk.walking_model()
    predicted = np.asarray(wk.impact(m, jnp.concatenate([c.q_prev, c.v_est]), setup.eta).z_plus[6:])
    # compiled, not op by op (the controller run eagerly compiled 600 small programs)
    ctrl = jax.jit(sw.controller, static_argnums=1, static_argnames="predict_impact_rates")
    full = np.asarray(ctrl(m, "iolin", setup, c, r, 0.05, predict_impact_rates=True)[0].v_est)
    stance = np.asarray(ctrl(m, "iolin", setup, c, r, 0.05)[0].v_est)
    np.testing.assert_allclose(full, predicted, rtol=1e-12, atol=1e-12)  # same map, other rounding
    np.testing.assert_array_equal(stance, np.asarray(pre))
    assert np.max(np.abs(full - np.asarray(pre))) > 0.1  # the impact changes the rates


@pytest.mark.slow
def test_eq42_at_pd_stiffness_with_exact_sensing_walks_the_full_plant():
    """eq. 42 at one eps on every output (controllers.EPS, PD + FF's stiffness on the stance
    leg-shape motor), exact sensing, paper-nominal on the 13-DoF plant: 8 steps without a fall, the stance
    leg shape tracked better than PD + FF on the encoders (measured 2.12 against 6.84 deg rms).
    Before the touchdown sample read predicted rates it lifted the stance toe and fell in the
    first step."""
    from bipedlab.robots.mabel.walking import controllers as ctl

    vc, g, rec = wm.load_gait("paper-nominal")
    g = g.replace(eps=jnp.full(4, ctl.EPS))  # one eps on every output, the loop this fix was found on
    s, log, _ = wm.run_walk("paper-nominal", "iolin", 8, sensing="ideal", plant="full", loaded=(vc, g, rec))
    r = wm.metrics(s, log, g.limit)
    pd = wm.walk("paper-nominal", "pdff", 8, plant="full")
    assert r["fell"] is False and r["steps_completed"] == 8
    assert r["tracking_rms_deg"]["mLS_st"] < pd["tracking_rms_deg"]["mLS_st"] / 2
    # exact sensing: the controller's rates are the plant's, to the last bit, except at each
    # touchdown sample (the one after a touchdown), where the model's post-impact prediction
    # stands in for them
    v_err = np.asarray(log["v_err"])
    after = np.nonzero(np.asarray(log["touched"]))[0] + 1
    nonzero = np.nonzero(np.any(v_err != 0.0, axis=1))[0]
    assert len(after) == 8 and set(nonzero) <= set(after.tolist()), (nonzero, after)
    assert np.all(v_err[np.setdiff1d(np.arange(len(v_err)), after)] == 0.0)


def test_the_ground_scale_multiplies_the_contact_force_and_only_the_full_plant_takes_it():
    """``Setup.ground`` scales the compliant ground's stiffness and damping together: the normal
    force of the Marhefka-Orin model (k d^n + c d^n dd, both terms linear in the constants) on
    the toes of the post-impact state pressed 1 mm further into the ground and moving down is
    exactly ``ground`` times the identified ground's, and scale 1 is that ground. The stance
    plant pins its toe and refuses a scale (one clear error before anything compiles)."""
    p = fp.initial_plant(_z_plus("paper-nominal"))
    iy = mm.COORDS_13.index("y")
    x = p.x.at[iy].add(-1e-3).at[13 + iy].set(-0.1)
    vc, gains, rec = wm.load_gait("paper-nominal")
    m = fp.plant_model()
    base = np.asarray(mdyn.ground_forces(fp.scaled_plant(m, wm.setup_for(vc, gains, 0.5)), x))
    tenfold = np.asarray(mdyn.ground_forces(fp.scaled_plant(m, wm.setup_for(vc, gains, 0.5, ground=10.0)), x))
    np.testing.assert_array_equal(base, np.asarray(mdyn.ground_forces(m, x)))
    assert np.all(base[:, 1] > 0)
    np.testing.assert_allclose(tenfold[:, 1], 10.0 * base[:, 1], rtol=1e-12, atol=0)
    with pytest.raises(ValueError, match="only the full plant"):
        wm.walk("paper-nominal", "pdff", 1, ground=10.0)
    with pytest.raises(ValueError, match="positive"):
        wm.walk("paper-nominal", "pdff", 1, plant="full", ground=-1.0)


def test_the_cable_and_friction_scales_multiply_their_constants_and_only_the_full_plant_takes_them():
    """``Setup.cable`` scales the 13-DoF plant's cable stiffness and damping together (data of the
    compiled loop, as the ground's scale), leaves the ground and everything else of the drive as
    identified, and scale 1 is the identified plant. The stance plant's cables are rigid: it
    refuses a scale, and a scale must be positive."""
    vc, gains, rec = wm.load_gait("paper-nominal")
    m = fp.plant_model()
    one = fp.scaled_plant(m, wm.setup_for(vc, gains, 0.5))
    ten = fp.scaled_plant(m, wm.setup_for(vc, gains, 0.5, cable=10.0))
    np.testing.assert_array_equal(np.asarray(one.drive.cable_k), np.asarray(m.drive.cable_k))
    np.testing.assert_allclose(np.asarray(ten.drive.cable_k), 10.0 * np.asarray(m.drive.cable_k), rtol=1e-15)
    np.testing.assert_allclose(np.asarray(ten.drive.cable_d), 10.0 * np.asarray(m.drive.cable_d), rtol=1e-15)
    np.testing.assert_array_equal(np.asarray(ten.drive.spring_k), np.asarray(m.drive.spring_k))
    np.testing.assert_array_equal(np.asarray(ten.ground.stiffness), np.asarray(m.ground.stiffness))
    np.testing.assert_array_equal(np.asarray(ten.drive.friction), np.asarray(m.drive.friction))
    two = fp.scaled_plant(m, wm.setup_for(vc, gains, 0.5, friction=2.0))  # Table V's motor friction doubled
    np.testing.assert_allclose(np.asarray(two.drive.friction), 2.0 * np.asarray(m.drive.friction), rtol=1e-15)
    np.testing.assert_array_equal(np.asarray(two.drive.cable_k), np.asarray(m.drive.cable_k))
    with pytest.raises(ValueError, match="motor friction can be scaled"):
        wm.walk("paper-nominal", "pdff", 1, friction=2.0)
    with pytest.raises(ValueError, match="only the full plant has cables"):
        wm.walk("paper-nominal", "pdff", 1, cable=10.0)
    with pytest.raises(ValueError, match="cable scale must be a positive"):
        wm.walk("paper-nominal", "pdff", 1, plant="full", cable=0.0)


def test_the_torque_noise_is_the_rms_sample_to_sample_change_over_the_completed_steps():
    """gap_record's torque_noise_rms_nm: per motor, the rms of u[k+1] - u[k] over the samples up to
    the last completed step's end (a motor whose torque alternates +-a has noise 2a; a constant
    one, 0; samples after the last touchdown are not counted)."""
    n = 12
    touched = np.zeros(n, bool)
    touched[[3, 7]] = True
    u = np.zeros((n, 4))
    u[:, 0] = 1.5 * (-1.0) ** np.arange(n)
    u[:, 1] = 4.0
    u[8:, 2] = 100.0  # after the last completed step: not counted
    log = dict(step=np.cumsum(touched), touched=touched, stance=np.zeros(n, int), bsp_st=np.zeros(n),
               bsp_sw=np.zeros(n), toe_drift=np.zeros(n), grf=np.ones((n, 2)), stretch=np.zeros((n, 4)), u=u)
    r = fp.gap_record(log, [0.8, 0.8])
    noise = r["torque_noise_rms_nm"]
    assert noise["mLA_st"] == pytest.approx(3.0) and noise["mLS_st"] == 0.0 and noise["mLA_sw"] == 0.0
