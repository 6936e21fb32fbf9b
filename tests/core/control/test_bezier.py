"""Bézier polynomials and C¹ chains of them, against independent polynomial oracles.

Oracles: the power-basis expansion of sum_k alpha_k C(M,k) s^k (1-s)^(M-k) built with
numpy.polynomial (whose .deriv() knows nothing of Bernstein derivative formulas), explicit
Bernstein sums with math.comb, JAX autodiff of the value and central finite differences."""
from __future__ import annotations

from math import comb

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from numpy.polynomial import Polynomial

from bipedlab.control import bezier as bz

#: the functions under test compiled, each once per shape: run op by op, every new shape of
#: alpha or s compiled each of their dozen operations on its own (300 small programs, most of
#: this module's compile time)
_bezier, _bezier_d, _bezier_dd = (jax.jit(f) for f in (bz.bezier, bz.bezier_d, bz.bezier_dd))

S_GRID = np.r_[0.0, 1e-3, 0.137, 0.25, 0.5, 0.731, 0.9, 1.0 - 1e-3, 1.0]


def _power_basis(alpha):
    """numpy Polynomial in s equal to the Bézier polynomial with coefficients alpha (M+1,)."""
    M = len(alpha) - 1
    s, one_minus_s = Polynomial([0.0, 1.0]), Polynomial([1.0, -1.0])
    p = Polynomial([0.0])
    for k, a in enumerate(alpha):
        p = p + a * comb(M, k) * s**k * one_minus_s ** (M - k)
    return p


def _bernstein_sum(alpha, s):
    M = len(alpha) - 1
    return sum(a * comb(M, k) * s**k * (1.0 - s) ** (M - k) for k, a in enumerate(alpha))


@pytest.mark.parametrize("M", [1, 2, 3, 5, 6])
def test_values_and_derivatives_match_power_basis(M):
    rng = np.random.default_rng(M)
    alpha = rng.normal(size=(3, M + 1))
    s = jnp.asarray(S_GRID)
    for row in range(3):
        p = _power_basis(alpha[row])
        b = np.asarray(_bezier(alpha[row], s))
        np.testing.assert_allclose(b, p(S_GRID), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(b, [_bernstein_sum(alpha[row], v) for v in S_GRID], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(np.asarray(_bezier_d(alpha[row], s)), p.deriv(1)(S_GRID), rtol=1e-11, atol=1e-11)
        np.testing.assert_allclose(np.asarray(_bezier_dd(alpha[row], s)), p.deriv(2)(S_GRID), rtol=1e-10, atol=1e-10)
    # several outputs in one call: alpha (m, M+1) with a scalar s -> one value per row
    for v in (0.0, 0.3, 1.0):
        np.testing.assert_allclose(np.asarray(_bezier(alpha, v)), [_power_basis(a)(v) for a in alpha], atol=1e-12)
        np.testing.assert_allclose(np.asarray(_bezier_d(alpha, v)), [_power_basis(a).deriv()(v) for a in alpha],
                                   atol=1e-11)


def test_derivatives_match_autodiff_and_finite_differences():
    rng = np.random.default_rng(7)
    alpha = jnp.asarray(rng.normal(size=6))
    b = lambda s: _bezier(alpha, s)  # noqa: E731
    db = jax.vmap(jax.grad(b))
    ddb = jax.vmap(jax.grad(jax.grad(b)))
    s = jnp.asarray(S_GRID)
    np.testing.assert_allclose(np.asarray(_bezier_d(alpha, s)), np.asarray(db(s)), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(np.asarray(_bezier_dd(alpha, s)), np.asarray(ddb(s)), rtol=1e-11, atol=1e-11)
    h = 1e-5
    fd = (np.asarray(b(s + h)) - np.asarray(b(s - h))) / (2 * h)
    np.testing.assert_allclose(np.asarray(_bezier_d(alpha, s)), fd, rtol=1e-8, atol=1e-8)
    h = 1e-4
    fd2 = (np.asarray(b(s + h)) - 2 * np.asarray(b(s)) + np.asarray(b(s - h))) / h**2
    np.testing.assert_allclose(np.asarray(_bezier_dd(alpha, s)), fd2, rtol=1e-5, atol=1e-5)


def test_endpoint_properties():
    rng = np.random.default_rng(3)
    for M in (2, 4, 5, 7):
        a = rng.normal(size=(4, M + 1))
        np.testing.assert_allclose(np.asarray(_bezier(a, 0.0)), a[:, 0], atol=1e-14)
        np.testing.assert_allclose(np.asarray(_bezier(a, 1.0)), a[:, M], atol=1e-14)
        np.testing.assert_allclose(np.asarray(_bezier_d(a, 0.0)), M * (a[:, 1] - a[:, 0]), atol=1e-12)
        np.testing.assert_allclose(np.asarray(_bezier_d(a, 1.0)), M * (a[:, M] - a[:, M - 1]), atol=1e-12)
        np.testing.assert_allclose(np.asarray(_bezier_dd(a, 0.0)), M * (M - 1) * (a[:, 2] - 2 * a[:, 1] + a[:, 0]),
                                   atol=1e-11)
        np.testing.assert_allclose(np.asarray(bz.derivative_coefficients(a)), M * np.diff(a, axis=-1), atol=1e-14)


def test_autodiff_of_the_value_is_exact_at_the_ends():
    """The powers are built by products, so the derivative at s = 0 and 1 is finite and right."""
    alpha = jnp.asarray([0.3, -1.0, 2.0, 0.5])
    g0 = float(jax.grad(lambda s: _bezier(alpha, s))(0.0))
    g1 = float(jax.grad(lambda s: _bezier(alpha, s))(1.0))
    assert g0 == pytest.approx(3 * (-1.0 - 0.3), abs=1e-13)
    assert g1 == pytest.approx(3 * (0.5 - 2.0), abs=1e-13)


def test_constant_and_linear_coefficients_reproduce_constant_and_linear_functions():
    """Bernstein polynomials are a partition of unity and reproduce s (linear precision)."""
    s = jnp.asarray(S_GRID)
    for M in (1, 3, 6):
        np.testing.assert_allclose(np.asarray(_bezier(np.full(M + 1, 2.5), s)), 2.5, atol=1e-13)
        np.testing.assert_allclose(np.asarray(_bezier(np.arange(M + 1) / M, s)), S_GRID, atol=1e-13)
        np.testing.assert_allclose(np.asarray(_bezier_d(np.arange(M + 1) / M, s)), 1.0, atol=1e-12)


# ---- chains ----------------------------------------------------------------------------

BREAKS = np.array([-0.2, 0.1, 0.6, 0.75, 1.3])  # four phases of unequal widths


def _c1_chain(rng, m=3, M=5):
    """(P, m, M+1) coefficients; phase p > 0 starts with c1_continuation of phase p-1."""
    widths = np.diff(BREAKS)
    alphas = [rng.normal(size=(m, M + 1))]
    for p in range(1, len(widths)):
        a = rng.normal(size=(m, M + 1))
        a[:, :2] = np.asarray(bz.c1_continuation(alphas[-1], widths[p - 1], widths[p]))
        alphas.append(a)
    return np.stack(alphas)


def _one_sided(alphas, p, at_end):
    """Value and d/dtheta of phase p at its end (at_end) or start, from the power basis."""
    w = BREAKS[p + 1] - BREAKS[p]
    s = 1.0 if at_end else 0.0
    val = np.array([_power_basis(a)(s) for a in alphas[p]])
    der = np.array([_power_basis(a).deriv()(s) / w for a in alphas[p]])
    dd = np.array([_power_basis(a).deriv(2)(s) / w**2 for a in alphas[p]])
    return val, der, dd


def test_c1_continuation_joins_value_and_slope():
    alphas = _c1_chain(np.random.default_rng(11))
    for p in range(1, len(BREAKS) - 1):
        v_left, d_left, dd_left = _one_sided(alphas, p - 1, True)
        v_right, d_right, dd_right = _one_sided(alphas, p, False)
        np.testing.assert_allclose(v_right, v_left, atol=1e-12)
        np.testing.assert_allclose(d_right, d_left, rtol=1e-12, atol=1e-12)
        # only C¹: the curvature jumps for random interior coefficients
        assert np.abs(dd_right - dd_left).max() > 1e-2


def test_chain_is_c1_at_the_joins_from_both_sides():
    alphas = _c1_chain(np.random.default_rng(5))
    f = jax.jit(lambda th: bz.chain(th, BREAKS, alphas))
    eps = 1e-9
    for brk in BREAKS[1:-1]:
        vl, dl, _ = (np.asarray(v) for v in f(brk - eps))
        vr, dr, _ = (np.asarray(v) for v in f(brk + eps))
        v0, d0, _ = (np.asarray(v) for v in f(brk))
        scale = 1.0 + np.abs(dl).max()
        assert np.abs(vr - vl).max() < 1e-7 * scale
        assert np.abs(v0 - vl).max() < 1e-7 * scale
        assert np.abs(dr - dl).max() < 1e-6 * scale


def test_arbitrary_chain_is_not_c1():
    """The same check fails on a chain without c1_continuation, so it can detect a bad join."""
    rng = np.random.default_rng(5)
    alphas = rng.normal(size=(len(BREAKS) - 1, 3, 6))
    f = jax.jit(lambda th: bz.chain(th, BREAKS, alphas))
    eps = 1e-9
    for brk in BREAKS[1:-1]:
        vl, dl, _ = (np.asarray(v) for v in f(brk - eps))
        vr, dr, _ = (np.asarray(v) for v in f(brk + eps))
        assert np.abs(vr - vl).max() > 1e-3
        assert np.abs(dr - dl).max() > 1e-3
    # continuity of the value only (first coefficient matched) still leaves a kink
    a = alphas.copy()
    for p in range(1, len(BREAKS) - 1):
        a[p, :, 0] = a[p - 1, :, -1]
    f = jax.jit(lambda th: bz.chain(th, BREAKS, a))
    for brk in BREAKS[1:-1]:
        vl, dl, _ = (np.asarray(v) for v in f(brk - eps))
        vr, dr, _ = (np.asarray(v) for v in f(brk + eps))
        assert np.abs(vr - vl).max() < 1e-6
        assert np.abs(dr - dl).max() > 1e-3


def test_chain_values_and_theta_derivatives():
    """Inside every phase (and extrapolated outside the breaks) the chain is the phase's
    polynomial in s = (theta - theta_p) / width, with the chain rule applied to d/dtheta."""
    alphas = _c1_chain(np.random.default_rng(2), m=2)
    f = jax.jit(jax.vmap(lambda th: bz.chain(th, BREAKS, alphas)))
    thetas = np.r_[BREAKS[0] - 0.05, np.linspace(BREAKS[0] + 0.01, BREAKS[-1] - 0.01, 23), BREAKS[-1] + 0.05]
    val, der, dd = (np.asarray(v) for v in f(jnp.asarray(thetas)))
    for i, th in enumerate(thetas):
        p = int(np.clip(np.searchsorted(BREAKS, th, side="right") - 1, 0, len(BREAKS) - 2))
        w = BREAKS[p + 1] - BREAKS[p]
        s = (th - BREAKS[p]) / w
        polys = [_power_basis(a) for a in alphas[p]]
        np.testing.assert_allclose(val[i], [P(s) for P in polys], atol=1e-11)
        np.testing.assert_allclose(der[i], [P.deriv()(s) / w for P in polys], rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(dd[i], [P.deriv(2)(s) / w**2 for P in polys], rtol=1e-9, atol=1e-9)
    # d/dtheta from autodiff of the chain's value, away from the joins
    g = jax.jit(jax.vmap(jax.jacfwd(lambda th: bz.chain(th, BREAKS, alphas)[0])))(jnp.asarray(thetas))
    np.testing.assert_allclose(np.asarray(g), der, rtol=1e-11, atol=1e-11)
