"""Section IV and Appendix A estimators: eq. 7 by separable least squares on encoder
increments, K_T and alpha by eq. 12, and the two-input ARX bias of eqs. 31-33."""
from __future__ import annotations

import numpy as np
import pytest

import bipedlab  # noqa: F401
from bipedlab.robots.mabel import sysid
from bipedlab.robots.mabel.sysid import arx, rigs
from bipedlab.robots.mabel.sysid import params as P
from bipedlab.robots.mabel.sysid.logs import motor_encoder


def _chirp():
    d = sysid.Design()
    freqs = sysid.experiments.chirp_frequencies(d.chirp_f0, d.chirp_f1, d.chirp_steps)
    return sysid.experiments.modified_chirp(freqs, 0.02 * (1 + freqs), periods=2)


def test_first_order_fit_recovers_exact_parameters():
    """Noise-free angles of J w' + mu w = u + c (exact zero-order-hold samples, a non-zero
    initial speed) give back J, mu, c and the speed to rounding."""
    u = _chirp()
    J, mu, c, w0 = 6.3e-4, 4.1e-3, 0.013, 2.5
    theta = rigs.motor_rig(J, mu, u + c, omega0=w0, theta0=0.7)
    f = sysid.fit_first_order(u, theta)
    assert f.J_exp == pytest.approx(J, rel=1e-7)
    assert f.mu_exp == pytest.approx(mu, rel=1e-7)
    assert f.offset == pytest.approx(c, abs=1e-9)
    assert f.omega0 == pytest.approx(w0, rel=1e-6)
    assert f.rms < 1e-12


def test_kt_alpha_solves_eq_11_exactly():
    J_man, cad = 4.4928e-4, np.array([7.5e-5, 2.05e-4, 2.3e-4])
    kt, alpha = 1.31, 0.77
    r = sysid.kt_alpha(kt * (alpha * J_man + cad), J_man, cad)
    assert r.kt == pytest.approx(kt, rel=1e-12) and r.alpha == pytest.approx(alpha, rel=1e-12)


def test_transmission_experiments_give_kt_alpha_exactly_without_noise_and_within_targets_with_it():
    truth = sysid.perturbed(3)
    design = sysid.quick_design()
    for sensors, tol in ((sysid.sensors.exact(), 1e-6), (sysid.Sensors(), 0.02)):
        for a in ("mLA_R", "mLS_L"):
            k = P.actuator_index(a)
            exps = sysid.transmission_experiments(truth, a, sensors, design)
            fits = [sysid.fit_first_order(e.u[a] + truth.bias[k], e.enc[motor_encoder(a)]) for e in exps]
            r = sysid.kt_alpha([f.J_exp for f in fits], P.rotor_inertia_manufacturer(a), P.combination_inertia(a))
            assert abs(r.kt / truth.kt[k] - 1) < tol
            assert abs(r.alpha / truth.alpha[k] - 1) < tol
            mu = np.array([f.mu_exp for f in fits]) / truth.kt[k]
            assert np.all(np.abs(mu / truth.trans_friction[k] - 1) < tol)


def test_arx_recovers_a_planted_bias_from_eq_32():
    """Data that follow eq. 32 exactly, y_k = a1 y_k-1 + b1 (u_k-1 + bias): b2 / b1 is the bias."""
    rng = np.random.default_rng(1)
    u = np.sin(np.arange(3000) * 0.02) + 0.3 * rng.standard_normal(3000)
    bias, a1, b1 = -0.0371, 0.97, 0.25
    y = np.zeros_like(u)
    for k in range(1, len(u)):
        y[k] = a1 * y[k - 1] + b1 * (u[k - 1] + bias)
    r = sysid.arx_bias(u, y=y, lags=1)
    assert r.bias == pytest.approx(bias, abs=1e-12)
    assert r.a1 == pytest.approx(a1, abs=1e-12) and r.b[0] == pytest.approx(b1, rel=1e-10)


def test_arx_two_lags_are_exact_for_the_sampled_rotor():
    """A rotor sampled at 1 kHz (speed = encoder difference): the two-lag ARX is its exact
    discretisation, so the planted bias and the rotor come back to rounding (under a rich
    unbiased command; a single sinusoid leaves the split between the two lags ill-conditioned)."""
    J, mu, kt, bias = 3.3e-4, 1.2e-3, 1.3, 0.0217
    t = np.arange(6000) * 1e-3
    rng = np.random.default_rng(4)
    u = 0.05 * np.sin(2 * np.pi * 2.0 * t) + 0.02 * rng.standard_normal(len(t))
    u -= u.mean()
    theta = rigs.motor_rig(J, mu, (u + bias) / kt)
    r = sysid.arx_bias(u, theta, lags=2, block=1, instrumental=0)
    assert r.bias == pytest.approx(bias, abs=1e-10)
    assert r.J_exp == pytest.approx(kt * J, rel=1e-6) and r.mu_exp == pytest.approx(kt * mu, rel=1e-6)


def test_arx_bias_under_encoder_quantisation():
    """With 14-bit encoders and one count of noise, the default (10 ms blocks, instrumental
    variables) stays within 2 mN m of every planted bias, while least squares on the raw
    1 kHz differences is off by more than 10 mN m on some motor (why the defaults exist)."""
    truth = sysid.perturbed(5)
    raw = []
    for a in P.ACTUATORS:
        k = P.actuator_index(a)
        e = sysid.bias_experiment(truth, a, sysid.Sensors(seed=2))
        u, theta = e.u[a], e.enc[motor_encoder(a)]
        assert abs(arx.arx_bias(u, theta).bias - truth.bias[k]) < 2e-3
        raw.append(abs(arx.arx_bias(u, theta, block=1, instrumental=0).bias - truth.bias[k]))
    assert max(raw) > 1e-2
