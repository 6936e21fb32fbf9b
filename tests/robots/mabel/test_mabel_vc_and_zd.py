"""MABEL's sub-phase virtual constraints (compliant-HZD paper, Section III-A, Appendix A), the
hybrid-invariance corrections (eqs. 45-47), the compliant zero dynamics (Section III-B/C) and
the shipped gait designs (Section III-D/E)."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import bipedlab  # noqa: F401
from bipedlab.robots.mabel.walking import constraints as vcm
from bipedlab.robots.mabel.walking import design as md
from bipedlab.robots.mabel.walking import zero_dynamics as zd
from bipedlab.robots.mabel.walking import stance as wk
from bipedlab.robots.mabel.walking import study as wm

_dd = jax.jit(vcm.desired_derivatives)
_corr = jax.jit(vcm.correction)


@pytest.fixture(scope="module")
def nominal():
    return wm.load_gait("nominal")


@pytest.fixture(scope="module")
def vc(nominal):
    return nominal[0]


@pytest.fixture(scope="module")
def dm():
    return md.design_model()


@pytest.fixture(scope="module")
def evaluate_fn(dm):
    """evaluate(x, speed, max_step), compiled once."""
    return jax.jit(lambda x, s, mx: md.evaluate(dm, x, s, max_step=mx))


@pytest.fixture(scope="module")
def evaluated(evaluate_fn, nominal):
    """evaluate() at the shipped nominal and efficient decision vectors (one compile)."""
    f = lambda x, s: evaluate_fn(x, s, md.MAX_STEP)  # noqa: E731
    out = {}
    for name in ("nominal", "efficient"):
        rec = nominal[2] if name == "nominal" else wm.load_gait(name)[2]
        fig, eq, ineq, data = f(jnp.asarray(rec["x"], float), jnp.asarray(rec["speed"], float))
        out[name] = (rec, jax.tree_util.tree_map(np.asarray, (fig, eq, ineq, data)))
    return out


# ----------------------------------------------------------------------------- constraints

@pytest.mark.parametrize("before, after, where", [
    (vcm.MC, vcm.SC, "theta_mc"), (vcm.SC, vcm.SI, "theta_sc"), (vcm.SI, vcm.SD, "theta_si")])
def test_constraints_are_C1_across_sub_phases(vc, before, after, where):
    """h and dh/dtheta of all four outputs agree at each sub-phase boundary (Appendix A:
    Béziers joined C¹)."""
    th = getattr(vc, where)
    h0, d0, _ = (np.asarray(a) for a in _dd(vc, before, th))
    h1, d1, _ = (np.asarray(a) for a in _dd(vc, after, th))
    assert h1 == pytest.approx(h0, abs=1e-9)
    assert d1 == pytest.approx(d0, abs=1e-9)
    # the check is not vacuous: the stance leg shape moves somewhere in the step
    assert vc.theta_plus < vc.theta_mc < vc.theta_sc < vc.theta_si < vc.theta_minus


def test_swing_constraints_saturate_past_theta_minus_and_stay_C2(vc):
    """Past theta- the swing constraints follow their polynomial, then hold a pose instead of
    extrapolating (a late touchdown after a push): h, dh, d2h continuous at the joint, h
    bounded and dh -> 0 well past it; before theta- nothing changed."""
    bez = lambda th: np.asarray(vcm.bz.bezier(vc.la_sw, (th - vc.theta_plus) / (vc.theta_minus - vc.theta_plus)))  # noqa: E731
    w = float(vc.theta_minus - vc.theta_plus)
    inside = float(vc.theta_minus) - 0.3 * w
    assert float(_dd(vc, vcm.SD, inside)[0][1]) == pytest.approx(float(bez(inside)), abs=1e-12)
    th_knee = vc.theta_minus + vcm.OVERRUN * w
    eps = 1e-10
    lo, hi = (tuple(np.asarray(a)[1:3] for a in _dd(vc, vcm.SD, th_knee + d)) for d in (-eps, eps))
    for a, b in zip(lo, hi):
        assert b == pytest.approx(a, rel=1e-4, abs=1e-4)
    far = [np.asarray(a)[1:3] for a in _dd(vc, vcm.SD, vc.theta_minus + 0.5 * w)]
    assert np.all(np.abs(far[1]) < 1e-6 * np.abs(np.asarray(_dd(vc, vcm.SD, vc.theta_minus)[1])[1:3]) + 1e-9)
    # the polynomial itself would have kept swinging far away
    extrapolated = bez(vc.theta_minus + 0.5 * w)
    assert abs(float(extrapolated) - float(far[0][0])) > 0.1


def test_stance_leg_shape_changes_across_the_step(vc):
    """The sub-phase pieces are not all one constant: the stance motor leg shape at the
    start of SC and at the end of SI differ (the injection phase moves it)."""
    h_sc = float(_dd(vc, vcm.SC, vc.theta_sc)[0][0])
    h_sd = float(_dd(vc, vcm.SD, vc.theta_minus)[0][0])
    assert abs(h_sd - h_sc) > 1e-3


def test_swing_outputs_do_not_depend_on_the_sub_phase(vc):
    """LA_sw and mLS_sw are one Bézier each over [theta+, theta-]: identical in every phase;
    the torso is one Bézier over MC-SC-SI."""
    for th in np.linspace(float(vc.theta_plus), float(vc.theta_minus), 7):
        hs = [np.asarray(_dd(vc, p, jnp.asarray(th))[0]) for p in range(4)]
        ds = [np.asarray(_dd(vc, p, jnp.asarray(th))[1]) for p in range(4)]
        for p in range(1, 4):
            assert hs[p][1:3] == pytest.approx(hs[0][1:3], abs=0.0)
            assert ds[p][1:3] == pytest.approx(ds[0][1:3], abs=0.0)
            if p < 3:
                assert hs[p][3] == pytest.approx(hs[0][3], abs=0.0)


def test_constraints_meet_the_designed_pre_and_post_impact_states(vc, nominal):
    """Appendix B, step 3: the Bézier end coefficients come from z+ and z-, so y = y-dot = 0
    at z+ (phase MC) and at z- (phase SD)."""
    rec = nominal[2]
    zp, zm = np.asarray(rec["z_plus"]), np.asarray(rec["z_minus"])
    y, yd = vcm.outputs(vc, vcm.MC, jnp.asarray(zp[:6]), jnp.asarray(zp[6:]))
    assert np.asarray(y) == pytest.approx(np.zeros(4), abs=1e-9)
    assert np.asarray(yd) == pytest.approx(np.zeros(4), abs=1e-8)
    y, yd = vcm.outputs(vc, vcm.SD, jnp.asarray(zm[:6]), jnp.asarray(zm[6:]))
    assert np.asarray(y) == pytest.approx(np.zeros(4), abs=1e-9)
    assert np.asarray(yd) == pytest.approx(np.zeros(4), abs=1e-8)
    assert float(vcm.theta(jnp.asarray(zp[:6]))) == pytest.approx(float(vc.theta_plus), abs=1e-12)


# ----------------------------------------------------------------------------- corrections

CORR = np.array([[0.02, -0.15], [-0.3, 1.2], [0.01, 0.05]])


def test_correction_starts_at_c0_with_slope_c1(vc):
    """Eq. 46: h_c(theta+) = c0, dh_c/dtheta(theta+) = c1."""
    v = vc.replace(corr=jnp.asarray(CORR))
    th = v.theta_plus
    val, slope = jax.jvp(lambda t: vcm.correction(v, t), (th,), (jnp.ones_like(th),))
    assert np.asarray(val) == pytest.approx(CORR[:, 0], rel=1e-14, abs=1e-15)
    assert np.asarray(slope) == pytest.approx(CORR[:, 1], rel=1e-10, abs=1e-12)
    # and the outputs see it: desired with corrections minus without equals h_c
    h_c = np.asarray(vcm.desired(v, vcm.MC, th)) - np.asarray(vcm.desired(vc.replace(corr=jnp.zeros((3, 2))), vcm.MC, th))
    assert h_c[1:] == pytest.approx(CORR[:, 0], abs=1e-12)
    assert h_c[0] == 0.0


def test_correction_vanishes_past_the_middle_of_the_first_phase(vc):
    """Zero from theta_mid on: mid of [theta+, theta-] for the swing outputs, of
    [theta+, theta_si] for the torso; nonzero just before."""
    v = vc.replace(corr=jnp.asarray(CORR))
    mid_sw = 0.5 * (float(v.theta_plus) + float(v.theta_minus))
    mid_tor = 0.5 * (float(v.theta_plus) + float(v.theta_si))
    assert mid_tor < mid_sw
    for th in (mid_sw, mid_sw + 1e-3, float(v.theta_minus)):
        assert np.all(np.asarray(_corr(v, jnp.asarray(th))) == 0.0)
    for th in (mid_tor, mid_tor + 1e-4, 0.5 * (mid_tor + mid_sw)):
        c = np.asarray(_corr(v, jnp.asarray(th)))
        assert c[2] == 0.0
        if th < mid_sw - 1e-3:
            assert np.all(c[:2] != 0.0)
    # just before the torso's midpoint the torso correction is still (slightly) on
    assert float(_corr(v, jnp.asarray(mid_tor - 0.05 * (mid_tor - float(v.theta_plus))))[2]) != 0.0
    # C1 (indeed C2) at the midpoint: the slope from the left tends to zero
    eps = 1e-6
    slope = jax.jvp(lambda t: vcm.correction(v, t), (jnp.asarray(mid_tor - eps),), (jnp.asarray(1.0),))[1]
    assert abs(float(slope[2])) < 1e-6


def test_update_at_impact_zeroes_the_outputs_at_a_perturbed_state(vc, nominal):
    """Eq. 47 and the event-based stance leg-shape update: after an off-orbit impact the
    updated constraints give y = y-dot = 0 at the post-impact state (phase MC)."""
    zp = np.asarray(nominal[2]["z_plus"])
    offset = np.array([0.01, -0.05, 0.004, -0.02, 0.08, 0.015, -0.05, 0.3, 0.1, 0.2, -0.4, 0.05])
    z = jnp.asarray(zp + offset)
    new = jax.jit(vcm.update_at_impact)(vc, z[:6], z[6:], vc)
    y, yd = vcm.outputs(new, vcm.MC, z[:6], z[6:])
    assert np.asarray(y) == pytest.approx(np.zeros(4), abs=1e-10)
    assert np.asarray(yd) == pytest.approx(np.zeros(4), abs=1e-10)
    assert float(new.theta_plus) == pytest.approx(float(vcm.theta(z[:6])), abs=1e-14)
    # the nominal constraints do not: the perturbation is seen by the plain outputs
    y0, _ = vcm.outputs(vc, vcm.MC, z[:6], z[6:])
    assert np.max(np.abs(np.asarray(y0))) > 1e-3
    # the updated constraints stay C1 into SC and SI
    for a, b, where in ((vcm.MC, vcm.SC, "theta_mc"), (vcm.SC, vcm.SI, "theta_sc")):
        th = getattr(new, where)
        h0, d0, _ = _dd(new, a, th)
        h1, d1, _ = _dd(new, b, th)
        assert float(h1[0]) == pytest.approx(float(h0[0]), abs=1e-9)
        assert float(d1[0]) == pytest.approx(float(d0[0]), abs=1e-9)


# ----------------------------------------------------------------------------- zero dynamics

def test_zero_dynamics_torque_keeps_the_outputs_on_the_manifold(dm, vc, evaluated):
    """Eq. 32: u* applied to the full stance dynamics gives accelerations with y-dd = 0 and the
    zero dynamics' (thetadd, bdd), at points of the nominal orbit in every sub-phase."""
    _, (_, _, _, data) = evaluated["nominal"]
    thetas, ws = data["thetas"], data["w"]
    phases = np.repeat(np.arange(4), md.NODES)
    zdacc = jax.jit(lambda p, th, b, thd, bd: zd.zd_accelerations(dm, vc, p, th, b, thd, bd))
    flow = jax.jit(lambda z, u: wk.stance_flow(dm, z, u))
    dd = _dd
    idx = [1, md.NODES[0] + 5, sum(md.NODES[:2]) + 7, sum(md.NODES[:3]) + 6]
    for k in idx:
        p, th = int(phases[k]), thetas[k]
        b, thd, bd = ws[k, :3]
        thdd, bdd, u, qs, qds = zdacc(p, th, b, thd, bd)
        z = jnp.concatenate([qs, qds])
        qdd = np.asarray(flow(z, u))[6:]
        thdd_flow = float(vcm.theta_rate(jnp.asarray(qdd)))
        h, dh, ddh = (np.asarray(a) for a in dd(vc, p, jnp.asarray(th)))
        ydd = qdd[list(vcm.H0_INDEX)] - dh * thdd_flow - ddh * thd**2
        scale = np.max(np.abs(qdd))
        assert np.max(np.abs(ydd)) < 1e-8 * max(scale, 1.0), (k, ydd)
        assert thdd_flow == pytest.approx(float(thdd), rel=1e-9, abs=1e-9)
        assert qdd[2] == pytest.approx(float(bdd), rel=1e-9, abs=1e-9)
        # on the manifold: y = y-dot = 0 at the reconstructed state
        y, yd = vcm.outputs(vc, p, qs, qds)
        assert np.max(np.abs(np.asarray(y))) < 1e-12 and np.max(np.abs(np.asarray(yd))) < 1e-11
        # the orbit samples were produced by this u*
        assert np.asarray(u) == pytest.approx(data["u"][k], rel=1e-10, abs=1e-10)


# ----------------------------------------------------------------------------- designs

def _torso_bound_violated(ineq, travel_deg):
    """The design's last inequality is Appendix B's torso bound, 5 (5 deg - soft range): for a
    gait designed before the bound, travelling ``travel_deg`` > 5 deg, it is negative by the
    excess (the soft range within 2 ln(n) / sharpness of the range)."""
    want = 5 * (md.TORSO_TRAVEL - np.radians(travel_deg))
    return want - 5 * 2 * np.log(40) / md.TORSO_SHARPNESS <= float(ineq[-1]) <= want + 5 * np.radians(0.01) < 0


def test_shipped_nominal_design_is_a_feasible_fixed_point(evaluated):
    """Periodicity, the 5 deg spring trigger, touchdown and speed hold to 1e-7; every
    inequality (friction cone, torque limits, ...) is satisfied but Appendix B's torso bound:
    the shipped nominal gait was designed before the design had it, and travels 8.4 deg."""
    rec, (fig, eq, ineq, _) = evaluated["nominal"]
    assert np.max(np.abs(eq)) < 1e-7, eq
    assert np.min(ineq[:-1]) >= -1e-8
    assert _torso_bound_violated(ineq, np.degrees(md.torso_travel(md.design_model(), wm.design_from_record(rec))))
    assert float(fig["speed"]) == pytest.approx(rec["speed"], rel=1e-7)
    # the record's figures are those of the design
    for k in ("cmt", "step_length", "period"):
        assert float(fig[k]) == pytest.approx(rec["design"][k], rel=1e-8)
    assert np.asarray(fig["peak_torques"]) == pytest.approx(rec["design"]["peak_torques"], rel=1e-8)


def test_step_length_window_is_an_inequality_of_the_design(evaluate_fn, nominal):
    """optimize(min_step, max_step) bounds the step: the two inequalities before the torso
    bound read 5 (L - min) and 5 (max - L); a window below the nominal step is violated, one
    above holds."""
    rec = nominal[2]
    x, v = jnp.asarray(rec["x"], float), jnp.asarray(rec["speed"], float)
    L = float(rec["design"]["step_length"])
    for mx, violated in ((L - 0.08, True), (L + 0.08, False)):
        fig, _, ineq, _ = evaluate_fn(x, v, mx)
        assert float(fig["step_length"]) == pytest.approx(L, rel=1e-9)
        assert float(ineq[-2]) == pytest.approx(5 * (mx - L), rel=1e-9)
        assert (float(ineq[-2]) < 0) == violated


def test_efficient_gait_saves_motor_work(evaluated):
    """The c_mt-optimised gait's designed cost of transport is at least 10 % below the
    torque-optimised nominal gait's at the same speed; it is a feasible fixed point too, but
    for Appendix B's torso bound (designed before it, it travels 7.3 deg)."""
    nom, (fig_n, _, _, _) = evaluated["nominal"]
    eff, (fig_e, eq_e, ineq_e, _) = evaluated["efficient"]
    assert eff["cost"] == "cmt" and nom["cost"] == "torque"
    assert eff["speed"] == pytest.approx(nom["speed"])
    assert np.max(np.abs(eq_e)) < 1e-7 and np.min(ineq_e[:-1]) >= -1e-8
    assert _torso_bound_violated(ineq_e, np.degrees(md.torso_travel(md.design_model(), wm.design_from_record(eff))))
    assert float(fig_e["cmt"]) <= 0.9 * float(fig_n["cmt"])
    assert eff["design"]["cmt"] <= 0.9 * nom["design"]["cmt"]


@pytest.mark.parametrize("name", wm.GAITS)
def test_shipped_gaits_respect_the_torque_capacity(name):
    """Peak u* within the drivetrain's 30 N m (leg angle) / 55 N m (leg shape) motors."""
    rec = wm.load_gait(name)[2]
    peak = np.asarray(rec["design"]["peak_torques"])
    assert peak.shape == (4,)
    assert np.all(peak <= np.array([30.0, 55.0, 30.0, 55.0]))
    # the design's bound (design.evaluate) is the model's, in the inputs' order (leg angle, leg shape) per leg
    assert np.asarray(wk.walking_model().drive.torque_limit) == pytest.approx([30.0, 55.0, 30.0, 55.0])


def test_spring_does_most_of_the_negative_work_at_the_stance_leg_shape(nominal):
    """Section III: the compliance absorbs the impact; the stance spring does more than half of
    the negative work at the stance leg shape on the nominal gait."""
    fig = nominal[2]["design"]
    assert fig["negative_work_fraction_spring"] > 0.5
    assert fig["negative_work_fraction_spring"] == pytest.approx(
        fig["neg_work_spring"] / (fig["neg_work_spring"] + fig["neg_work_motor"]), rel=1e-12)


def test_lean_tilts_the_torso_and_keeps_the_swing_leg_absolute_angle(vc):
    """Exp. 5's lean: the torso reference drops by delta in every sub-phase while the swing leg's
    absolute angle (torso + leg angle) and the leg-shape references are unchanged."""
    delta = 0.3
    leaned = vcm.lean(vc, delta)
    for phase in (vcm.MC, vcm.SC, vcm.SI, vcm.SD):
        for th in np.linspace(float(vc.theta_plus), float(vc.theta_minus), 7):
            h0 = np.asarray(vcm.desired(vc, phase, th))
            h1 = np.asarray(vcm.desired(leaned, phase, th))
            assert h1[3] == pytest.approx(h0[3] - delta, abs=1e-12)
            assert h1[1] + h1[3] == pytest.approx(h0[1] + h0[3], abs=1e-12)
            assert h1[[0, 2]] == pytest.approx(h0[[0, 2]], abs=1e-12)
