"""Transmission identification (Section IV): the first-order fit of eq. 7 and K_T, alpha by
least squares (eqs. 10-12).

Eq. 7 in the units of the logged command u (Fig. 12: the measured transfer function is
``1 / (K_T (J s + mu))``)::

    J_exp w_dot + mu_exp w = u + c,     J_exp = K_T J_lumped,  mu_exp = K_T mu_lumped,

with c a constant command offset (what is left of the amplifier bias after compensation).
:func:`fit_first_order` fits it to one experiment without differentiating the encoder: the
model predicts the angle advanced in each sample exactly (zero-order-hold discretisation,
:func:`bipedlab.robots.mabel.sysid.rigs.motor_rig`), and that increment is compared with the difference of
two encoder readings, so quantisation enters as white reading noise, never divided by h^2.
For a given pole ``a = exp(-h mu_exp / J_exp)`` the predicted increments are linear in
``1/mu_exp``, ``c/mu_exp`` and the initial speed, so those are solved by linear least squares
and the time constant by a bounded scalar search (separable least squares).

:func:`kt_alpha` stacks eq. 10 for the pulley combinations of one motor, ``J_i^exp = K_T alpha
J^rotor,man + K_T J_i^CAD``, and solves eq. 12.
"""
from __future__ import annotations

import dataclasses

import numpy as np
from scipy import optimize, signal

from bipedlab.robots.mabel.sysid.sensors import PERIOD


@dataclasses.dataclass(frozen=True)
class FirstOrderFit:
    """Eq. 7 fitted to one experiment: J_exp (kg m^2 x K_T), mu_exp (N m s/rad x K_T),
    offset c (N m of command), initial speed (rad/s), rms residual of the per-sample angle
    increments (rad), and the number of increments."""

    J_exp: float
    mu_exp: float
    offset: float
    omega0: float
    rms: float
    n: int

    @property
    def time_constant(self) -> float:
        return self.J_exp / self.mu_exp


def _regressors(a: float, tau: float, u: np.ndarray, h: float):
    """Increments of the angle over each sample per unit of 1/mu (input u and a unit
    constant) and per unit initial speed, for the pole a and time constant tau."""
    gamma = tau * (1.0 - a)
    n = len(u)
    k = np.arange(n)
    w_u = signal.lfilter([0.0, 1.0 - a], [1.0, -a], u)       # speed x mu, from u
    w_1 = 1.0 - a**k                                          # speed x mu, from a unit constant
    r_u = gamma * w_u + (h - gamma) * u
    r_1 = gamma * w_1 + (h - gamma)
    r_w = gamma * a**k                                        # from a unit initial speed
    return np.stack([r_u, r_1, r_w], axis=1)


def _solve(tau: float, u, dtheta, h):
    a = np.exp(-h / tau)
    A = _regressors(a, tau, u, h)
    coef, *_ = np.linalg.lstsq(A, dtheta, rcond=None)
    return coef, dtheta - A @ coef


def fit_first_order(u, theta, h: float = PERIOD, tau_bounds=(1e-3, 1e3)) -> FirstOrderFit:
    """Fit eq. 7 to commands u (N,) and encoder angles theta (N,) (row k: reading at t_k,
    command over [t_k, t_k+1)). Exact on noise-free data; unbiased under reading noise."""
    u = np.asarray(u, float)
    theta = np.asarray(theta, float)
    if u.shape != theta.shape or u.ndim != 1 or len(u) < 10:
        raise ValueError("fit_first_order needs two 1-D signals of the same length (at least 10 samples)")
    dtheta = np.diff(theta)
    u = u[:-1]

    def cost(log_tau):
        return float(np.sum(_solve(np.exp(log_tau), u, dtheta, h)[1] ** 2))

    lo, hi = np.log(tau_bounds[0]), np.log(tau_bounds[1])
    grid = np.linspace(lo, hi, 41)
    costs = [cost(g) for g in grid]
    i = int(np.argmin(costs))
    a, b = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
    res = optimize.minimize_scalar(cost, bounds=(a, b), method="bounded", options=dict(xatol=1e-12, maxiter=500))
    tau = float(np.exp(res.x))
    (g, gc, w0), r = _solve(tau, u, dtheta, h)
    mu = 1.0 / g
    return FirstOrderFit(J_exp=tau * mu, mu_exp=mu, offset=gc / g, omega0=float(w0),
                         rms=float(np.sqrt(np.mean(r**2))), n=len(dtheta))


def simulate_first_order(fit: FirstOrderFit, u, theta0: float = 0.0, h: float = PERIOD) -> np.ndarray:
    """Angles (N,) the fitted eq. 7 predicts under commands u (N,), from theta0."""
    from bipedlab.robots.mabel.sysid.rigs import motor_rig

    return motor_rig(fit.J_exp, fit.mu_exp, np.asarray(u, float) + fit.offset, h, fit.omega0, theta0)


@dataclasses.dataclass(frozen=True)
class KtAlpha:
    """Eq. 12 for one motor: K_T, alpha, and the residuals of eq. 11 (kg m^2)."""

    kt: float
    alpha: float
    residuals: np.ndarray


def kt_alpha(J_exp, J_rotor_man: float, J_cad) -> KtAlpha:
    """K_T and alpha from eq. 11 ``Psi = Gamma [K_T alpha, K_T]`` by least squares (eq. 12).

    J_exp: the experiments' J_i^exp (3,); J_rotor_man: the manufacturer's rotor inertia;
    J_cad: J_i^pulley + J_i^cable of each combination (3,), from the CAD model."""
    Psi = np.asarray(J_exp, float)
    J_cad = np.asarray(J_cad, float)
    if Psi.shape != J_cad.shape or Psi.size < 2:
        raise ValueError("kt_alpha needs at least two experiments with a CAD inertia each")
    Gamma = np.stack([np.full_like(J_cad, J_rotor_man), J_cad], axis=1)
    (kt_alpha_, kt), *_ = np.linalg.lstsq(Gamma, Psi, rcond=None)
    return KtAlpha(kt=float(kt), alpha=float(kt_alpha_ / kt), residuals=Psi - Gamma @ np.array([kt_alpha_, kt]))
