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
    """10 s on flat ground (energy regulation, the CLI default). The paper's steady errors are
    1.8 cm and 0.8 cm/s (Sec. IV-A); tolerance +-2 cm and +-5 cm/s, the size of the
    spring-mass model's own polynomial-fit error (-1.1 cm, 2.3 cm/s) that sets them. The
    whole-run mean speed error includes the start transient (measured -1.9 cm/s): the steady
    figure must be the smaller (measured +0.09 cm/s)."""
    import json

    from bipedlab import cli

    assert cli.main(["run", "atrias", "--seconds", "10", "--json"]) == 0
    rec = json.loads(capsys.readouterr().out)
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


def test_model_errors_reach_the_policy_and_the_stance_model_not_the_plant():
    """A +20 % mass or stiffness error: the swing-leg policy is the deadbeat policy of the
    erroneous spring-mass model (oracle: slip.swing_policy of that model), the stance inverse
    dynamics uses the erroneous mass, the realised leg spring and the plant keep their values."""
    k0 = slip.SlipParams().k0
    rp, cp, _, _ = ra.build(ra.Settings(model_error=(("mass", 0.2),)))
    pol, _ = slip.swing_policy(slip.SlipParams(m=1.2 * rp.m), GAIT)
    np.testing.assert_allclose(np.asarray(cp.policy.coeffs), np.asarray(pol.coeffs), rtol=1e-12)
    assert float(cp.mp.m) == pytest.approx(1.2 * rp.m) and rp.m == ra.at.AtriasParams().m
    assert float(cp.smm.k0) == pytest.approx(k0)
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
