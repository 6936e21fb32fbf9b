"""Bézier polynomials in a phase variable, and chains of them joined with C¹ continuity.

A Bézier polynomial of order M on s in [0, 1] with coefficients alpha_0..alpha_M is

    b(s) = sum_k alpha_k * M! / (k! (M - k)!) * s^k (1 - s)^(M - k),

so b(0) = alpha_0, b(1) = alpha_M, b'(0) = M (alpha_1 - alpha_0), b'(1) = M (alpha_M - alpha_{M-1}).
Coefficients live on the last axis, so one call evaluates many outputs at once.

Sub-phases (Appendix A of the compliant-HZD paper): a virtual constraint is a chain of Béziers,
phase p covering theta in [theta_p, theta_{p+1}] with s = (theta - theta_p) / (theta_{p+1} - theta_p).
Two neighbours join C¹ in theta when the second's first two coefficients follow from the
first's last two (:func:`c1_continuation`). A "combined phase" is simply one Bézier whose domain
spans several sub-phases.
"""
from __future__ import annotations

from math import comb

import jax.numpy as jnp
import numpy as np


def _powers(x, M: int):
    """[1, x, ..., x^M] on a new last axis, by products (so autodiff is exact at x = 0)."""
    out = [jnp.ones_like(x)]
    for _ in range(M):
        out.append(out[-1] * x)
    return jnp.stack(out, -1)


def _bernstein(M: int, s):
    binom = np.array([comb(M, i) for i in range(M + 1)], float)
    s = jnp.asarray(s, dtype=float)
    return binom * _powers(s, M) * _powers(1.0 - s, M)[..., ::-1]


def bezier(alpha, s):
    """b(s) for coefficients alpha (..., M+1); s broadcasts against alpha's leading axes."""
    alpha = jnp.asarray(alpha)
    return jnp.sum(alpha * _bernstein(alpha.shape[-1] - 1, s), -1)


def derivative_coefficients(alpha):
    """Coefficients (..., M) of db/ds, itself a Bézier of order M - 1."""
    alpha = jnp.asarray(alpha)
    M = alpha.shape[-1] - 1
    return M * (alpha[..., 1:] - alpha[..., :-1])


def bezier_d(alpha, s):
    """db/ds."""
    return bezier(derivative_coefficients(alpha), s)


def bezier_dd(alpha, s):
    """d²b/ds²."""
    return bezier(derivative_coefficients(derivative_coefficients(alpha)), s)


def c1_continuation(alpha_prev, width_prev, width_next):
    """First two coefficients of the next phase making the chain C¹ in theta.

    alpha_prev: (..., M+1) coefficients of the previous phase, of theta-width width_prev;
    the next phase has theta-width width_next. Returns (..., 2)."""
    alpha_prev = jnp.asarray(alpha_prev)
    end = alpha_prev[..., -1]
    step = (alpha_prev[..., -1] - alpha_prev[..., -2]) * (width_next / width_prev)
    return jnp.stack([end, end + step], -1)


def phase_coordinate(theta, theta_start, theta_end):
    """s = (theta - theta_start) / (theta_end - theta_start) and ds/dtheta."""
    w = theta_end - theta_start
    return (theta - theta_start) / w, 1.0 / w


def chain(theta, breaks, alphas):
    """Evaluate a chain of Béziers at theta: value, d/dtheta and d²/dtheta².

    breaks: (P+1,) increasing phase boundaries; alphas: (P, ..., M+1), one coefficient set
    per phase, all of the same order. Outside [breaks[0], breaks[-1]] the first or last
    polynomial is extrapolated."""
    breaks = jnp.asarray(breaks)
    alphas = jnp.asarray(alphas)
    P = alphas.shape[0]
    idx = jnp.clip(jnp.searchsorted(breaks, theta, side="right") - 1, 0, P - 1)
    a = alphas[idx]
    s, ds = phase_coordinate(theta, breaks[idx], breaks[idx + 1])
    return bezier(a, s), bezier_d(a, s) * ds, bezier_dd(a, s) * ds * ds


#: Public name of the Bernstein basis (M + 1 values at s), for fitting Bézier coefficients.
bernstein = _bernstein
