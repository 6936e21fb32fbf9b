"""The running study's sensitivity (``bipedlab experiment atrias sensitivity``): the robot's values
scaled where they act, the pooled statistics and their jackknife against closed forms, and a
short run whose elasticities obey the physics (the pure spring-mass model knows nothing of the
robot's torque limit) and which the report attaches to the rows it measured."""
from __future__ import annotations

import numpy as np
import pytest

from helpers import expect_usage_error

from bipedlab.control import slip
from bipedlab.robots.atrias import catalog
from bipedlab.robots.atrias import reproduce as rr
from bipedlab.robots.atrias import robot as at
from bipedlab.robots.atrias import sensitivity as sens
from bipedlab.robots.atrias import study


def test_scaled_values_reach_the_plant_the_ground_and_the_spring_mass_model():
    rp0, smm0 = study.robot()
    rp, smm = study.robot((("depth_y", 0.5), ("mu_slide", 0.9), ("l0", 0.95), ("m", 1.1), ("k0", 1.2)))
    g0, g = at.ground_params(rp0), at.ground_params(rp)
    # half the depth under a 10 % heavier robot: the normal stiffness weight / depth doubles and grows 10 %
    assert float(g.k_y) == pytest.approx(2.0 * float(g0.k_y) * float(rp.total_mass / rp0.total_mass))
    assert float(g.mu_slide) == pytest.approx(0.72) and float(g.mu_stick) == float(g0.mu_stick)
    assert float(smm.l0) == pytest.approx(0.95) and float(smm.k0) == pytest.approx(1.2 * float(smm0.k0))
    assert float(smm.m) == float(rp.m) == pytest.approx(1.1 * float(rp0.m))
    # the unscaled ground is the one reference-values.md gives
    assert float(g0.k_y) == pytest.approx(rp0.total_mass * rp0.g / 0.01)
    assert (float(g0.v_max), float(g0.mu_stick), float(g0.mu_slide)) == (0.03, 0.9, 0.8)
    # the controller is made for the scaled robot: its model's friction and spring-mass model follow
    _, cp, _, _ = study._build((), "regulation", (("mu_slide", 0.9), ("l0", 0.95)))
    assert float(cp.mp.mu) == pytest.approx(0.72) and float(cp.smm.l0) == pytest.approx(0.95)
    with pytest.raises(ValueError, match="scale: unknown value 'leg'"):
        study.robot((("leg", 1.1),))


def _per_trial(rng, n):
    arrays = [(1.05 + 0.05 * rng.standard_normal(k), 5.0 + 0.1 * rng.standard_normal(k))
              for k in rng.integers(3, 30, n)]
    return arrays, study.per_trial(arrays, np.ones(n, bool), slip.Gait(1.05, 5.0))


def test_pooled_statistics_are_those_of_all_the_apexes():
    rng = np.random.default_rng(3)
    arrays, pt = _per_trial(rng, 7)
    keep = [0, 2, 3, 6]
    b = np.concatenate([arrays[i][0] for i in keep])
    v = np.concatenate([arrays[i][1] for i in keep])
    assert sens.pooled(pt, "sd", keep) == pytest.approx(np.std(b), rel=1e-12)
    assert sens.pooled(pt, "height", keep) == pytest.approx(np.mean(b) - 1.05, abs=1e-14)
    assert sens.pooled(pt, "speed", keep) == pytest.approx(np.mean(v) - 5.0, abs=1e-14)
    # a fallen trial (no apexes) is left out
    pt["apexes"][2] = None
    assert sens.pooled(pt, "sd", keep) == pytest.approx(np.std(np.concatenate([arrays[i][0] for i in (0, 3, 6)])))


def test_jackknife_of_a_paired_mean_difference_is_the_classical_standard_error():
    """Equal apex counts: the pooled mean is the mean of the trials' means, and the jackknife
    standard error of the paired difference is sd(d_i) / sqrt(n)."""
    rng = np.random.default_rng(5)
    n = 9
    base = dict(apexes=[10] * n, apex_height_error_mean_m=list(rng.standard_normal(n)),
                speed_error_mean_mps=[0.0] * n, apex_height_sd_m=[0.1] * n)
    d = 0.3 + 0.05 * rng.standard_normal(n)
    scaled = dict(base, apex_height_error_mean_m=list(np.asarray(base["apex_height_error_mean_m"]) + d))
    assert sens.jackknife_se(base, scaled, "height") == pytest.approx(np.std(d, ddof=1) / np.sqrt(n), rel=1e-10)
    assert sens.jackknife_se(base, base, "height") == 0.0


def test_elasticities_pair_each_scaled_run_with_the_unscaled_one_on_the_same_draws(monkeypatch):
    """The orchestration on a stand-in study whose trials' apexes move in known ways with the
    scaled value: the mean bounce-height error grows as mass^2 (elasticity 2 exactly, every draw
    shifted alike: no jackknife error), the speed error is noise that the scaling re-draws (a
    standard error as large as the change)."""
    calls = []

    def fake_study(st, out_dir=None, progress=None):
        calls.append(st)
        f = dict(st.scale).get("m", 1.0)
        rng = np.random.default_rng(st.seed + (0 if f == 1.0 else 1))
        arrays = [(1.05 + 0.04 * f ** 2 + 0.01 * np.sin(np.arange(5) + i), 5.0 + 0.1 * rng.standard_normal(5))
                  for i in range(st.trials)]
        pt = study.per_trial(arrays, np.ones(st.trials, bool), slip.Gait(1.05, 5.0))
        b, v = np.concatenate([a for a, _ in arrays]), np.concatenate([w for _, w in arrays])
        return dict(apex_height_sd_m=float(np.std(b)), apex_height_error_mean_m=float(np.mean(b) - 1.05),
                    speed_error_mean_mps=float(np.mean(v) - 5.0), per_trial=pt)

    monkeypatch.setattr(study, "study", fake_study)
    rec = sens.sensitivity(step=-0.1, trials=6, parameters=("m", "I_t"), experiments=("mass-20pct",))
    assert rec["method"].startswith("each value 10% smaller in plant and controller alike")
    assert len(calls) == 3 and all(c.trials == 6 and c.model_error == (("mass", -0.2),) for c in calls)
    assert [c.scale for c in calls] == [(), (("m", 0.9),), (("I_t", 0.9),)]
    assert rec["runs"] == 3 and set(rec["base"]) == {f"mass-20pct_{q}" for q in ("apex_sd_m", "apex_error_m", "speed_error_mps")}
    m = rec["parameters"]["m"]
    h0 = rec["base"]["mass-20pct_apex_error_m"]
    h1 = h0 - 0.04 * (1 - 0.81)
    assert m["scaled"]["mass-20pct_apex_error_m"] == pytest.approx(h1, abs=1e-12)
    assert m["elasticity"]["mass-20pct_apex_error_m"] == pytest.approx((h1 - h0) / (-0.1 * h0), rel=1e-9)
    assert m["standard_error"]["mass-20pct_apex_error_m"] == pytest.approx(0.0, abs=1e-9)
    assert m["standard_error"]["mass-20pct_speed_error_mps"] > 0.0
    # I_t moves nothing in the stand-in: zero elasticities, the unscaled draws
    assert all(e == 0.0 for e in rec["parameters"]["I_t"]["elasticity"].values())
    assert rec["parameters"]["m"]["precision"] is None and rec["parameters"]["I_t"]["precision"] > 0
    with pytest.raises(ValueError, match="unknown value 'leg'"):
        sens.sensitivity(parameters=("leg",))


@pytest.fixture(scope="module")
def short():
    return sens.sensitivity(trials=2, distance=8.0, parameters=("tau_max",), experiments=("flat", "mass-20pct"))


@pytest.mark.slow
def test_short_sensitivity_obeys_the_physics(short):
    """(slow: 30 s, four runs compiling two robots' programs; the orchestration's fast
    counterpart is the stand-in study above)"""
    e = short["parameters"]["tau_max"]["elasticity"]
    se = short["parameters"]["tau_max"]["standard_error"]
    # the pure spring-mass model runs beside the robot and has no torque limit: exactly zero
    for row in ("flat_slip_apex_error_m", "flat_slip_speed_error_mps"):
        assert e[row] == 0.0 and se[row] is None  # a single flat run: deterministic, no standard error
    # the robot's hip torque saturates on flat ground (the touchdown's swing), so its limit moves it
    assert e["flat_apex_error_m"] != 0.0 and np.isfinite(e["flat_apex_error_m"])
    # the batched rows are the pooled statistics, each with its jackknife error over the 2 draws
    for row in ("mass-20pct_apex_error_m", "mass-20pct_speed_error_mps"):
        assert np.isfinite(e[row]) and se[row] is not None and se[row] >= 0.0
    assert set(short["base"]) >= {"flat_speed_error_mps", "mass-20pct_apex_error_m"}
    assert not any(k.endswith("_success") for k in short["base"])
    assert short["runs"] == 4
    assert "tau_max" in sens.summary(short)


def test_the_report_attaches_the_sensitivity_to_the_rows_it_measured():
    base = {"flat_speed_error_mps": 0.07, "mass-20pct_apex_error_m": -0.05}
    short = dict(base=base, method="m", precision_source="s", parameters=dict(
        tau_max=dict(what="hip torque limit (250 N m)", precision=None, elasticity={"flat_speed_error_mps": -0.5, "mass-20pct_apex_error_m": 0.3},
                     standard_error={"flat_speed_error_mps": None, "mass-20pct_apex_error_m": 0.1}),
        mu_slide=dict(what="ground sliding friction (0.8)", precision=0.0625, elasticity={"flat_speed_error_mps": None, "mass-20pct_apex_error_m": 1.0},
                      standard_error={"flat_speed_error_mps": None, "mass-20pct_apex_error_m": 0.2})))
    out = rr._with_sensitivity({"flat_speed_error_mps": base["flat_speed_error_mps"],
                                "mass-20pct_apex_error_m": base["mass-20pct_apex_error_m"] + 1e-3}, short)
    # the same run's value gets its sensitivity; another run's value (here shifted) does not
    assert set(out) == {"flat_speed_error_mps"}
    s = out["flat_speed_error_mps"].sensitivity
    # named by what they are; a parameter with no elasticity for the row is left out; a
    # deterministic row has no standard errors
    assert s.elasticity == {"hip torque limit": -0.5} and s.precision == {"hip torque limit": None}
    assert s.standard_error == {} and s.method.startswith("experiment sensitivity: ")
    both = rr._with_sensitivity({"mass-20pct_apex_error_m": rr.Measured(-0.05, dict(reference=0.02))}, short)
    s = both["mass-20pct_apex_error_m"]
    assert s.facts == dict(reference=0.02)
    assert s.sensitivity.standard_error == {"hip torque limit": 0.1, "ground sliding friction": 0.2}
    assert s.sensitivity.precision == {"hip torque limit": None, "ground sliding friction": 0.0625}


def test_stated_precisions_are_printed_digits():
    assert catalog.SCALABLE["I_t"][1] == pytest.approx(0.005 / 1.37)
    assert catalog.SCALABLE["mu_slide"][1] == pytest.approx(0.0625)
    assert all(v[1] is None for k, v in catalog.SCALABLE.items() if k in ("m", "d", "I_m", "m_f", "tau_max", "l0"))
    # the report names each value by what it is: one name each
    labels = [v[0].split(" (")[0] for v in catalog.SCALABLE.values()]
    assert len(set(labels)) == len(labels)


@pytest.mark.parametrize("argv,needle", [
    (["--parameters", "leg"], "invalid choice"),
    (["--trials", "1"], "--trials"),
    (["--distance", "2"], "--distance"),
])
def test_bad_options_are_refused_in_one_line(argv, needle, capsys):
    expect_usage_error(["experiment", "atrias", "sensitivity", *argv], capsys, needle)
