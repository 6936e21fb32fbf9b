"""Amplifier bias by a first-order ARX model with two inputs (Appendix A, eqs. 31-33).

The rotor, disconnected from the transmission, is driven by an unbiased command tau; the bias
makes it drift (Fig. 24). Its speed y (the encoder differenced once, Fig. 25) follows a first
order system, identified by an ARX model whose second input is a sequence of ones (eq. 31,
Fig. 26)::

    y_k = a_1 y_k-1 + b_1 u_1,k-1 + b_2 u_2,k-1,      u_1 = tau, u_2 = 1      (32)
        = a_1 y_k-1 + b_1 (u_1,k-1 + b_2 / b_1),                             (33)

so the bias is b_2 / b_1. Three practical points, each an option of :func:`arx_bias`:

* ``lags = 2`` lets the command enter with two lags, ``b_1 u_k-1 + b_1' u_k-2``: the exact
  sampled form of a first-order rotor whose speed y_k is the mean over the sample [t_k-1, t_k]
  (a first difference of the angle), u_k-1 being the command held over that same sample; the
  bias is then ``b_2 / (b_1 + b_1')``. ``lags = 1`` is eq. 32 as printed.
* ``block`` samples are averaged into one (speed = angle advanced over the block / its
  duration, command = its mean). At 1 kHz a 14-bit encoder's quantisation changes the
  differenced speed by more than the rotor's speed changes in one sample, and the
  least-squares ARX then mistakes noise for dynamics: the pole a_1, whose distance from 1
  sets the bias, is grossly biased. Blocks of 10 ms (the default) make the per-step change
  a hundred times the noise; they are exact for commands constant over a block and close
  otherwise (0.1 mN m on the study's 2 Hz sinusoid).
* ``instrumental`` iterations replace the regressor y_k-1 by the noise-free output of the
  previous model (the instrumental-variable ARX of Ljung, Ch. 7.6), which removes the
  remaining equation-error bias of least squares; the first model is the least-squares ARX.
"""
from __future__ import annotations

import dataclasses

import numpy as np
from scipy import signal

from bipedlab.robots.mabel.sysid.sensors import PERIOD


@dataclasses.dataclass(frozen=True)
class ArxBias:
    """Fitted ARX: a1, the command coefficients b (lags,), the constant's coefficient b2,
    the bias b2 / sum(b) (N m of command), and the rotor it implies in command units (eq. 7):
    J_exp = K_T J and mu_exp = K_T mu, from the pole and the steady gain."""

    a1: float
    b: np.ndarray
    b2: float
    bias: float
    J_exp: float
    mu_exp: float


def _regressors(y, u, lags: int, delay: int):
    """Rows k = lags + delay - 1 .. n-1 (at least 1) of [y_k-1, u_k-delay .. u_k-delay-lags+1, 1]."""
    n = len(y)
    k0 = max(lags + delay - 1, 1)
    cols = [y[k0 - 1:n - 1]] + [u[k0 - delay - l:n - delay - l] for l in range(lags)] + [np.ones(n - k0)]
    return np.stack(cols, axis=1), k0


def _simulate(a1, b, b2, u, y0, delay: int):
    """Noise-free output x of the ARX, x_0 = y0, under u (taken zero before the start)."""
    k = np.arange(len(u))
    num = np.concatenate([np.zeros(delay), b])
    forced = signal.lfilter(num, [1.0, -a1], u)
    const = b2 * (1.0 - a1**k) / (1.0 - a1) if abs(1.0 - a1) > 1e-12 else b2 * k
    return forced - forced[0] * a1**k + const + y0 * a1**k


def arx(y, u, lags: int = 1, delay: int = 1, instrumental: int = 0):
    """ARX ``y_k = a1 y_k-1 + sum_l b_l u_k-delay-l + b2`` (l = 0..lags-1) by least squares,
    then ``instrumental`` instrumental-variable iterations. Returns (a1, b (lags,), b2)."""
    y = np.asarray(y, float)
    u = np.asarray(u, float)
    Phi, k0 = _regressors(y, u, lags, delay)
    target = y[k0:]
    coef, *_ = np.linalg.lstsq(Phi, target, rcond=None)
    for _ in range(instrumental):
        a1 = min(float(coef[0]), 1.0 - 1e-9)
        x = _simulate(a1, coef[1:1 + lags], float(coef[-1]), u, y[0], delay)
        Z, _ = _regressors(x, u, lags, delay)
        try:
            coef = np.linalg.solve(Z.T @ Phi, Z.T @ target)
        except np.linalg.LinAlgError:  # the simulated output gives no instruments: keep the last model
            break
    return float(coef[0]), np.asarray(coef[1:1 + lags]), float(coef[-1])


def block_average(u, theta, block: int, h: float = PERIOD):
    """(y, u) on blocks of ``block`` samples: mean speed over each block (angle advanced /
    duration) and mean command. Row k of the inputs: reading at t_k, command over [t_k, t_k+1)."""
    u = np.asarray(u, float)
    theta = np.asarray(theta, float)
    n = (len(theta) - 1) // block
    y = (theta[block:(n + 1) * block:block] - theta[0:n * block:block]) / (block * h)
    return y, u[: n * block].reshape(n, block).mean(axis=1)


def bias_regressors(u, theta, lags: int = 2, block: int = 10, h: float = PERIOD) -> np.ndarray:
    """The regressor matrix [y_k-1, u_k .. u_k-lags+1, 1] that :func:`arx_bias` fits on the
    blocks of a command u (N,) and encoder angles theta (N,) (for checking its rank first)."""
    y, ub = block_average(u, theta, block, h)
    return _regressors(y, ub, lags, 0)[0]


def arx_bias(u, theta=None, lags: int = 2, block: int = 10, instrumental: int = 3, h: float = PERIOD,
             y=None) -> ArxBias:
    """Amplifier bias from an unbiased command u (N,) and the rotor's encoder angles theta
    (N,), by eqs. 31-33 (see the module docstring for lags, block and instrumental). Pass y
    instead of theta for a speed already indexed as in eq. 32 (y_k follows u_k-1); block is
    then ignored."""
    if y is None:
        # the mean speed over a block and the mean command over the same block: the command of
        # eq. 32's u_k-1 is the one held while y_k's angle was advanced, delay 0 here
        y, u = block_average(u, theta, block, h)
        dt, delay = block * h, 0
    else:
        y, u = np.asarray(y, float), np.asarray(u, float)
        dt, delay = h, 1
    if len(y) < 4 * (lags + 2):
        raise ValueError("arx_bias: too few samples for the ARX fit")
    a1, b, b2 = arx(y, u, lags, delay, instrumental)
    gain = float(np.sum(b))
    if not (np.isfinite(gain) and gain != 0.0):
        raise ValueError("arx_bias: the command has no effect on the speed (sum of the b coefficients is 0)")
    mu_exp = (1.0 - a1) / gain if gain else np.nan          # steady gain of the speed is 1/mu_exp
    J_exp = -dt * mu_exp / np.log(a1) if 0.0 < a1 < 1.0 else np.nan
    return ArxBias(a1=a1, b=b, b2=b2, bias=b2 / gain, J_exp=float(J_exp), mu_exp=float(mu_exp))
