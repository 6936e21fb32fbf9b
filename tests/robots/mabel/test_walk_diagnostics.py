"""What a MABEL walk record says about the controller's own view of the plant: the torque
saturation per actuator, the error of the rate estimate, and (13-DoF plant) the cable stretch
the rigid-cable controller does not see.

Oracles: hand-made logs with known saturated samples and known errors (closed forms), the
cable stretch's definition (a motor turned against its leg by a known angle stretches exactly
that motor's cable by that angle, on the stance or the swing side as the relabelling says), and
exact sensing, whose rate estimate is the plant's rates to the last bit."""
from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

from bipedlab.robots.mabel import model as mm
from bipedlab.robots.mabel.walking import full_plant as fp
from bipedlab.robots.mabel.walking import loop as sw
from bipedlab.robots.mabel.walking import study as wm


def test_drive_record_counts_the_saturated_samples_and_the_rate_error():
    """Ten samples, the stance leg-shape motor at +55 N m in samples 3 and 4 and at -55 N m in
    sample 7, the swing leg-angle motor at 29.999 N m (not at its limit): fractions 0.3 and 0,
    first at 3 ms; rate errors of 0.3 rad/s in one coordinate over 4 of the 8 samples taken:
    rms 0.3 * sqrt(4 / 8)."""
    u = np.zeros((10, 4))
    u[[3, 4], 1], u[7, 1], u[:, 2] = 55.0, -55.0, 29.999
    err = np.zeros((10, 6))
    err[[0, 2, 4, 6], 4] = 0.3
    err[9, :] = 100.0  # after the window: not counted
    r = sw.drive_record(dict(u=u, v_err=err), [30.0, 55.0, 30.0, 55.0], n=8)
    assert r["saturation_fraction"] == dict(mLA_st=0.0, mLS_st=3 / 8, mLA_sw=0.0, mLS_sw=0.0)
    assert r["first_saturation_s"] == dict(mLA_st=None, mLS_st=pytest.approx(3 * sw.SAMPLE), mLA_sw=None,
                                           mLS_sw=None)
    assert r["rate_estimate_error_rms"]["mLS_sw"] == pytest.approx(0.3 * np.sqrt(0.5), rel=1e-15)
    assert sum(r["rate_estimate_error_rms"].values()) == pytest.approx(0.3 * np.sqrt(0.5), rel=1e-15)
    assert list(r["rate_estimate_error_rms"]) == list(sw.RATES)


@pytest.mark.parametrize("stance", [0, 1])
def test_cable_stretch_is_the_motor_turned_against_its_leg(stance):
    """At the rigid-cable configuration of a gait's post-impact state every cable is
    unstretched; turning the left leg's leg-angle motor by 0.01 rad and the right leg's
    leg-shape motor by -0.02 rad (the joints held) stretches exactly those cables by those
    angles, reported for the stance leg first: left in stance, (0.01, 0, 0, -0.02); right in
    stance, (0, -0.02, 0.01, 0)."""
    x = np.asarray(fp.initial_plant(jnp.asarray(wm.load_gait("paper-nominal")[2]["z_plus"])).x)
    np.testing.assert_allclose(np.asarray(fp.cable_stretch(jnp.asarray(x), stance)), 0.0, atol=1e-12)
    x = x.copy()
    x[mm.COORDS_13.index("mla_L")] += 0.01
    x[mm.COORDS_13.index("mls_R")] -= 0.02
    want = [0.01, 0.0, 0.0, -0.02] if stance == 0 else [0.0, -0.02, 0.01, 0.0]
    np.testing.assert_allclose(np.asarray(fp.cable_stretch(jnp.asarray(x), stance)), want, atol=1e-12)


def test_a_walk_reports_its_saturation_and_rate_errors():
    """Two steps of the nominal gait under PD + feedforward on the stance model: on the
    encoders the rate estimate errs (the stance leg-shape motor's rate most, a motor angle
    differentiated at 1 kHz), with exact sensing not at all; at the drive's 30 / 55 N m limits no
    motor saturates (peak torques below them), at 1 N m each the motors do, from the first
    sample on."""
    enc = wm.walk("nominal", "pdff", 2)
    assert all(v > 0.0 for v in enc["rate_estimate_error_rms"].values())
    assert max(enc["rate_estimate_error_rms"], key=enc["rate_estimate_error_rms"].get) in ("mLS_st", "mLS_sw")
    assert all(v == 0.0 for v in enc["saturation_fraction"].values())
    assert all(p < lim for p, lim in zip(enc["peak_torques_nm"], (30.0, 55.0, 30.0, 55.0)))
    ideal = wm.walk("nominal", "pdff", 2, sensing="ideal")
    assert all(v == 0.0 for v in ideal["rate_estimate_error_rms"].values())
    s, log, _ = wm.run_walk("nominal", "pdff", 2, torque_limits=(1.0, 1.0, 1.0, 1.0))
    low = wm.metrics(s, log, (1.0, 1.0, 1.0, 1.0))
    assert max(low["saturation_fraction"].values()) > 0.0
    first = [t for t in low["first_saturation_s"].values() if t is not None]
    assert first and min(first) == 0.0


def test_the_torso_travel_inequality_is_appendix_bs_bound():
    """Appendix B: "range of travel of torso less than 5 deg". The design's inequality on the
    torso samples (the nodes before theta_si and the pre-impact state) is 5 deg minus a soft
    range that is never below the range and at most 2 ln(n) / sharpness above it: met by a
    torso that travels 4.5 deg, violated by one that travels 5.5 deg, whichever samples hold the
    extremes; the samples after theta_si (torso held at q_Tor-) do not enter."""
    from bipedlab.robots.mabel.walking import design as md

    rng = np.random.default_rng(3)
    starts = np.concatenate([[0], np.cumsum(md.NODES)])
    n = int(starts[3]) + 1
    for travel_deg in (4.5, 5.5):
        tor = rng.uniform(0.0, 1.0, n)
        tor = (tor - tor.min()) / np.ptp(tor) * np.radians(travel_deg) - 0.1
        qss = np.zeros((int(starts[-1]), 6))
        qss[: n - 1, 5] = tor[:-1]
        qss[n - 1:, 5] = 3.0  # after theta_si: not a torso sample of the bound
        zm = np.zeros(12)
        zm[5] = tor[-1]
        margin = float(md.torso_travel_margin(jnp.asarray(qss), starts, jnp.asarray(zm)))
        exact = md.TORSO_TRAVEL - np.ptp(tor)
        assert exact - 2 * np.log(n) / md.TORSO_SHARPNESS <= margin <= exact
        assert (margin > 0) == (travel_deg < 5.0)
