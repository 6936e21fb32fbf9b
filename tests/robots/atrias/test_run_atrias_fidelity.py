"""`bipedlab run atrias`: the paper's steady-state figures (Sec. IV-A), its delay experiment
(Sec. IV-C) and its model errors (Sec. IV-C), each against the paper's number with the
tolerance stated in the test, or, where this model departs, against its own measured value with
the departure and its cause in the docstring."""
import numpy as np
import pytest

from bipedlab.control import slip
from bipedlab.robots.atrias import study as ra

GAIT = slip.Gait(1.05, 5.0)


def _synthetic(bounce, speed):
    n = len(bounce)
    pad = np.zeros(96 - n)
    return dict(bounce=np.concatenate([bounce, pad])[None], speed=np.concatenate([speed, pad])[None],
                n_apex=np.array([n]))


def test_steady_errors_are_the_mean_of_the_last_ten_apexes():
    """Oracle: the hand-computed means. 15 apexes, the first five a transient far from the
    target: the steady figures see only the last ten, the whole-run means all past SKIP_APEX."""
    bounce = np.array([0.8, 0.9, 0.95, 1.0, 1.02] + [1.06] * 5 + [1.04] * 5)
    speed = np.array([4.0, 4.5, 4.8, 4.9, 4.95] + [5.01] * 5 + [4.99] * 5)
    out = _synthetic(bounce, speed)
    s = ra.steady_errors(out, [0], GAIT)
    assert s["apex_height_error_steady_m"] == pytest.approx(np.mean(bounce[5:]) - 1.05, abs=1e-12)
    assert s["speed_error_steady_mps"] == pytest.approx(np.mean(speed[5:]) - 5.0, abs=1e-12)
    assert s["apex_height_error_steady_m"] == pytest.approx(0.0, abs=1e-12)
    # a run of 6 apexes: the steady window stops at the transient (apexes 2..5)
    short = _synthetic(bounce[:6], speed[:6])
    s6 = ra.steady_errors(short, [0], GAIT)
    assert s6["speed_error_steady_mps"] == pytest.approx(np.mean(speed[2:6]) - 5.0, abs=1e-12)
    # no apex past the transient: no steady state
    assert np.isnan(ra.steady_errors(_synthetic(bounce[:2], speed[:2]), [0], GAIT)["speed_error_steady_mps"])


@pytest.mark.slow
def test_flat_run_reports_the_steady_state_beside_the_whole_run_mean(capsys):
    """10 s on flat ground (energy regulation, the CLI default) under bipedlab's controller, the
    labelled variant whose energy integral and landing-angle trim remove the
    paper's controller's steady bias (+3.2 cm, -7.0 cm/s here; its measured cause, the landing
    foot's slide, is in the running rows). The paper's steady errors are 1.8 cm and 0.8 cm/s
    (Sec. IV-A); tolerance +-2 cm and +-5 cm/s, the size of the spring-mass model's own
    polynomial-fit error (-1.1 cm, 2.3 cm/s) that sets them. The whole-run mean speed error
    includes the start transient (measured -0.20 cm/s): the steady figure must be the smaller
    (measured -0.02 cm/s, apex -0.07 cm)."""
    import json

    from bipedlab import cli

    assert cli.main(["run", "atrias", "--seconds", "10", "--controller", "bipedlab", "--json"]) == 0
    rec = json.loads(capsys.readouterr().out)
    assert rec["controller"] == "bipedlab"
    assert abs(rec["apex_height_error_steady_m"]) <= 0.018 + 0.02
    assert abs(rec["speed_error_steady_mps"]) <= 0.008 + 0.05
    assert abs(rec["speed_error_steady_mps"]) < abs(rec["speed_error_mean_mps"])
    assert rec["last10"]["speed_error_mean_mps"] == rec["speed_error_steady_mps"]


def test_delay_is_unknown_to_the_controller_unless_compensation_is_asked():
    """The paper's experiment: every measurement 10 samples (10 ms) late, the controller told
    nothing (its predictor and delayed-spring terms off); --delay-compensation tells it."""
    _, cp, _, _ = ra.build(ra.Settings())
    cfg, cpd = ra.loop_config(ra.Settings(delay_ms=10.0), cp)
    assert cfg.delay == 10 and float(cpd.delay) == 0.0
    cfg, cpc = ra.loop_config(ra.Settings(delay_ms=10.0, delay_compensation=True), cp)
    assert cfg.delay == 10 and float(cpc.delay) == pytest.approx(0.010)


def test_mass_error_reaches_the_policy_and_the_stance_model_not_the_plant():
    """A +20 % mass error: the swing-leg policy is the deadbeat policy of the erroneous
    spring-mass model (oracle: slip.swing_policy of that model), the stance inverse dynamics
    uses the erroneous mass, the realised leg spring and the plant keep their values."""
    k0 = slip.SlipParams().k0
    rp, cp, _, _ = ra.build(ra.Settings(model_error=(("mass", 0.2),)))
    pol, _ = slip.swing_policy(slip.SlipParams(m=1.2 * rp.m), GAIT)
    np.testing.assert_allclose(np.asarray(cp.policy.coeffs), np.asarray(pol.coeffs), rtol=1e-12)
    assert float(cp.mp.m) == pytest.approx(1.2 * rp.m) and rp.m == ra.at.AtriasParams().m
    assert float(cp.smm.k0) == pytest.approx(k0)


@pytest.mark.slow
def test_stiffness_error_reaches_the_policy_not_the_realised_spring():
    """A +20 % stiffness error: the swing-leg policy is that of the erroneous spring-mass model
    (oracle: slip.swing_policy of that model); the leg spring the stance realises keeps k0."""
    k0 = slip.SlipParams().k0
    rp = ra.at.AtriasParams()
    _, cpk, _, _ = ra.build(ra.Settings(model_error=(("stiffness", 0.2),)))
    pol, _ = slip.swing_policy(slip.SlipParams(m=rp.m, k0=1.2 * k0), GAIT)
    np.testing.assert_allclose(np.asarray(cpk.policy.coeffs), np.asarray(pol.coeffs), rtol=1e-12)
    assert float(cpk.smm.k0) == pytest.approx(k0, rel=1e-12) and float(cpk.mp.m) == pytest.approx(rp.m)


def test_foot_placement_errors_of_the_spring_mass_model_have_the_papers_signs():
    """The paper traces its mass and stiffness errors to the foot-placement policy. Oracle: the
    pure spring-mass model (true mass and stiffness) on flat ground run with the policy of a
    +-20 % erroneous model; its steady errors have the signs of the paper's four pairs
    [+-14 cm, -+17 cm/s] (mass) and [-+6 cm, +-5 cm/s] (stiffness). Measured: mass +20 %
    +5.8 cm / -11.6 cm/s, -20 % -4.2 / +8.2; stiffness +20 % -3.6 / +7.1, -20 % +7.5 / -14.9."""
    import jax

    from bipedlab.contact import terrain as tr
    from bipedlab.robots.atrias import slip_run

    true = slip.SlipParams(m=ra.at.AtriasParams().m)
    run = jax.jit(lambda pol: slip_run.run(true, GAIT, pol, tr.flat(60.0), 16))
    paper = {("m", 0.2): (1, -1), ("m", -0.2): (-1, 1), ("k0", 0.2): (-1, 1), ("k0", -0.2): (1, -1)}
    for (name, rel), signs in paper.items():
        model = true.replace(**{name: getattr(true, name) * (1 + rel)})
        pol, _ = slip.swing_policy(model, GAIT)
        r = run(pol)
        assert not bool(r.fell)
        k = int(r.steps_done)
        dh = float(np.mean(np.asarray(r.bounce)[2:k]) - GAIT.y_apex)
        dv = float(np.mean(np.asarray(r.speed)[2:k]) - GAIT.speed)
        assert (np.sign(dh), np.sign(dv)) == signs, (name, rel, dh, dv)
        assert abs(dh) > 0.02 and abs(dv) > 0.05


def _rough(n=8, distance=30.0, **kw):
    rec = ra.study(ra.Settings(terrain="rough", energy="conservation", trials=n, distance=distance, seed=0, **kw))
    return rec


@pytest.mark.slow
def test_ten_ms_delay_runs_lower_and_faster_as_in_the_paper():
    """Sec. IV-C: with a 10 ms delay (energy conservation, rough terrain) the robot "runs
    significantly lower and faster (average errors of -7.2cm and +71.9cm/s)", the controller
    not knowing the delay. The late spring force injects energy in every stance, which eq. 7's
    unlimited stiffness modulation takes out again. Measured on 8 terrains of 30 m, seed 0:
    8 of 8 run through, apex -3.8 cm, speed +75.0 cm/s (with the modulation limited to 150 J and
    50 % of k0, as bipedlab's controller once did, +2.13 m/s and 7 of 8: the speed ran away).
    Asserted: survival of at least 7 of 8 (the paper: "tolerates"), the speed error within a
    factor of two of the paper's +71.9 cm/s, the apex lower, between -8 and -1 cm (the paper's
    -7.2 cm inside; its size moves with the modulation's gain, which the paper does not give:
    the running rows' energy_gain_sweep)."""
    rec = _rough(delay_ms=10.0)
    assert rec["delay_compensation"] is False
    assert rec["success_rate"] >= 7 / 8
    assert 0.719 / 2 <= rec["speed_error_mean_mps"] <= 0.719 * 2
    assert -0.08 < rec["apex_height_error_mean_m"] < -0.01


@pytest.mark.slow
def test_mass_and_stiffness_errors_move_the_gait_with_the_papers_signs():
    """Sec. IV-C: +-20 % mass errors give about [+-14 cm, -+17 cm/s], +-20 % stiffness errors
    [-+6 cm, +-5 cm/s]. Measured here with the paper's controller (8 terrains of 30 m, energy
    conservation, change from the run without error, nominal +2.1 cm / -8.8 cm/s): mass +20 %
    +8.2 cm / -17.5 cm/s, -20 % -7.3 / +12.1; stiffness +20 % -5.1 / +8.6, -20 % +9.7 / -20.6;
    8 of 8 terrains each. Asserted: the paper's eight signs, survival of at least 7 of 8, and
    sizes above 0.5 cm / 1 cm/s and below 14 cm / 25 cm/s (the mass errors' speed changes
    about the paper's 17 cm/s, the stiffness errors' up to four times the paper's 5 cm/s).
    Whether a run on the edge falls turns on rounding: the loop amplifies a last-bit change by
    about 18 per stride."""
    base = _rough()
    paper = {("mass", 0.2): (1, -1), ("mass", -0.2): (-1, 1), ("stiffness", 0.2): (-1, 1),
             ("stiffness", -0.2): (1, -1)}
    for (name, rel), (sh, sv) in paper.items():
        rec = _rough(model_error=((name, rel),))
        assert rec["success_rate"] >= 7 / 8
        dh = rec["apex_height_error_mean_m"] - base["apex_height_error_mean_m"]
        dv = rec["speed_error_mean_mps"] - base["speed_error_mean_mps"]
        assert np.sign(dh) == sh and np.sign(dv) == sv, (name, rel, dh, dv)
        assert 0.005 < abs(dh) < 0.14 and 0.01 < abs(dv) < 0.25


@pytest.mark.slow
def test_inertia_and_friction_errors_have_little_effect():
    """Sec. IV-C: inverse dynamics with +-50 % inertia or friction-coefficient errors has "very
    little effect" on gait tracking over rough terrain. Tolerance: the apex s.d. within 8 cm
    (the paper's 5.3 cm without error plus the 50 % allowed a one-run s.d.) and the mean errors
    within 2 cm and 5 cm/s of the run without error (the spread of the mean over 8 terrains of
    30 m: s.d. 4 cm / 18 cm/s over some 100 apexes, standard error 0.4 cm / 2 cm/s). Measured
    on 16 terrains of 60 m: inertia +50 % -1.0 cm / -2.4 cm/s (s.d. 5.0 cm), friction +50 %
    -0.6 cm / -3.3 cm/s (s.d. 4.2 cm), without error -0.5 cm / -3.2 cm/s (s.d. 3.8 cm)."""
    base = _rough()
    for name in ("inertia", "friction"):
        rec = _rough(model_error=((name, 0.5),))
        assert rec["success_rate"] == 1.0
        assert rec["apex_height_sd_m"] <= 0.08
        assert abs(rec["apex_height_error_mean_m"] - base["apex_height_error_mean_m"]) < 0.02
        assert abs(rec["speed_error_mean_mps"] - base["speed_error_mean_mps"]) < 0.05


def test_settle_steps_counts_the_touchdowns_until_the_pitch_error_stays_in_the_band():
    """A 10 deg pitch error decaying with a 0.5 s time constant falls below 2 deg for good at
    0.5 ln 5 = 0.80 s; with a touchdown every 0.4 s (0.2, 0.6, 1.0, ...) two touchdowns came
    before it. A log that ends outside the band cannot tell."""
    from bipedlab.robots.atrias import controller as rc

    t = np.arange(0.0, 3.0, 1e-3)
    star = np.deg2rad(10.0)
    theta = star + np.deg2rad(10.0) * np.exp(-t / 0.5)
    mode = np.where((t % 0.4) >= 0.2, rc.STANCE, rc.FLIGHT)
    assert ra.settle_steps(t, theta, mode, star) == 2
    assert ra.settle_steps(t, theta, mode, star, band_deg=0.5) == 4      # 0.5 ln 20 = 1.50 s
    assert ra.settle_steps(t, np.full_like(t, star), mode, star) == 0
    assert ra.settle_steps(t[:700], theta[:700], mode[:700], star) is None


def test_a_perturbed_single_run_reports_its_settling_and_no_trial_statistics():
    """A single run with a trunk offset is still a single run: its record has the settling
    steps and the run's status, not the batched runs' success rate and trial count (which the
    report reads to tell a batch from a single run)."""
    rec = ra.study(ra.Settings(terrain="flat", seconds=1.5, theta0_offset_deg=10.0))
    assert "trials" not in rec and "success_rate" not in rec and rec["status"] == "ok"
    assert "trunk_settle_steps" in rec and rec["theta0_offset_deg"] == 10.0
