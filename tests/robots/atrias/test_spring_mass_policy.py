"""The pure spring-mass model as the paper ran it (Sec. IV-A): with the polynomial a*(t) of the
robot's controller, beside the exact policy (the solved landing pairs themselves)."""
import numpy as np
import pytest

from bipedlab.control import slip
from bipedlab.robots.atrias import study


def test_the_flat_spring_mass_model_runs_the_controllers_polynomial_and_its_fit_error_is_its_bias():
    """Oracle: on flat ground from the target apex, the exact policy lands on the periodic
    gait's own solved pair, so its first apex is the target (to the solver's tolerance); the
    polynomial's fit error eps at that landing time shifts the landing angle by
    eps g t* / (g t* + cos(a0) a*'(t*)) (the leg keeps moving while the foot falls to the
    ground, t* the landing time, a0 the landing angle) and the apex by that times the return
    map's slope df/da, the speed by -g / v* times the height at the same energy. Measured: fit
    error 8.2e-6 rad at most, 2.0e-6 rad rms, 1.9e-6 rad at the gait (df/da = -1.83 m/rad,
    a*'(t*) = 0.77 rad/s); first apex -3.006e-6 m (the prediction to 1e-5), +5.90e-6 m/s from
    the exact policy's; whole 20 m run -2.5e-6 m, -3.3e-6 m/s (the exact policy +0.5e-6 m,
    -9.3e-6 m/s: the stance integration's drift)."""
    st = study.Settings(terrain="flat", distance=20.0)
    _, cp, gait, samples = study.build(st)
    terr = study.make_terrains(st, 1, 32.0)
    fit = slip.fit_error(cp.smm, gait, cp.policy, samples)
    assert 0.0 < fit["rms_rad"] <= fit["max_rad"] < 1e-4 and fit["points"] > len(samples)
    assert fit["t_min_s"] < 0.02 and fit["t_max_s"] > 0.25

    poly, rp = study.slip_model(st, terr, 1, gait)
    exact, re = study.slip_model(st, terr, 1, gait, policy="table")
    assert poly["success_rate"] == exact["success_rate"] == 1.0
    assert abs(float(re.bounce[0, 0]) - gait.y_apex) < 1e-9

    a0 = slip.periodic_angle(cp.smm, gait)
    t_star = np.sqrt(2.0 * (gait.y_apex - cp.smm.l0 * np.sin(a0)) / cp.smm.g)
    e = slip.gait_energy(cp.smm, gait)
    h = 1e-5
    dfda = (float(slip.apex_map(cp.smm, e, gait.y_apex, a0 + h)) - float(slip.apex_map(cp.smm, e, gait.y_apex, a0 - h))) / (2 * h)
    rate = float(slip.policy_rate(cp.policy, t_star))
    g = cp.smm.g
    d_angle = fit["gait_rad"] * g * t_star / (g * t_star + np.cos(a0) * rate)
    dy = float(rp.bounce[0, 0] - re.bounce[0, 0])
    assert dy == pytest.approx(dfda * d_angle, rel=1e-3)
    assert float(rp.speed[0, 0] - re.speed[0, 0]) == pytest.approx(-g * dy / gait.speed, rel=1e-2)
    # the whole-run means of the report's rows: finite, small, and apart by the fit's shift
    for rec in (poly, exact):
        assert abs(rec["apex_height_error_mean_m"]) < 1e-5 and abs(rec["speed_error_mean_mps"]) < 1e-4
    assert poly["apex_height_error_mean_m"] - exact["apex_height_error_mean_m"] == pytest.approx(dy, rel=0.05)


def test_the_spring_mass_foot_lands_only_after_the_flights_apex():
    """Eq. (1) gives landing angles for landings after the apex. From a lift-off state (COM
    0.96 m up, rising at 0.9 m/s: apex after 0.092 s) with a step up starting 0.2 m ahead, the
    foot at the policy's first angle (held before the apex) starts inside the step (0.046 m
    high at 20 ms). A 0.05 m step: the foot rises out of it before the apex and lands on its
    top after the apex (not at 20 ms, 4 mm inside). A 0.2 m step, which the foot never clears:
    the landing is right after the apex (the stance then starts from the foot's own point)."""
    import jax
    import jax.numpy as jnp

    jax.config.update("jax_enable_x64", True)
    from bipedlab.contact import terrain as tr
    from bipedlab.robots.atrias import slip_run

    gait = slip.Gait(1.05, 5.0)
    p = slip.SlipParams(m=60.0)
    _, pol, _ = study._policy(p.m, p.k0, gait)
    s = jnp.array([0.0, 0.96, 5.0, 0.9])
    t_apex = 0.9 / p.g

    def landing(step):
        terr = tr.Terrain(jnp.array([0.0, 0.0, step, step, step]), 3.0, -2.8, 0.0)  # the step at x = 0.2 m
        t, found = slip_run._touchdown_time(p, pol, terr, s)
        t = float(t)
        a = float(slip.policy_angle(pol, t - t_apex))
        return bool(found), t, 5.0 * t + p.l0 * np.cos(a), 0.96 + 0.9 * t - 0.5 * p.g * t * t - p.l0 * np.sin(a)

    found, t, fx, fy = landing(0.05)
    assert found and t > t_apex and fx > 0.2 and fy == pytest.approx(0.05, abs=1e-6)
    found, t, fx, fy = landing(0.2)
    assert found and t_apex < t < t_apex + 0.003 and fy < 0.2
