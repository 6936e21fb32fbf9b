"""Friction and bias of the leg experiments by simulation error (Section V-C, eqs. 19-20).

With the links from CAD, K_T and alpha from Section IV and the biases from Appendix A, the
leg rig (:class:`bipedlab.robots.mabel.sysid.rigs.LegRig`, eq. 18) is simulated under the logged commands
and compared with the encoders::

    J(mu_Q) = sqrt(sum (y_exp - y_sim(mu_Q))^2)          (19)
    J(b_Q)  = sqrt(sum (y_exp - y_sim(b_Q))^2)           (20)

:func:`fit_leg` minimises the same sum of squares over any of the viscous frictions and
biases of the actuated motors, by Levenberg-Marquardt with the exact Jacobian of the simulated
response, obtained by forward-mode differentiation through the RK4 integration
(``jax.jacfwd``). The outputs are the actuated motors' encoders expressed at the joints
(q_LA, q_LS in rad, as the paper plots them), so both channels of a MIMO experiment weigh
alike. Frictions are fitted in log scale (they stay positive); biases in N m. The simulation
starts at rest at the first encoder readings.
"""
from __future__ import annotations

import dataclasses
import jax
import jax.numpy as jnp
import numpy as np
from scipy import optimize

from bipedlab.robots.mabel import tables as tb
from bipedlab.robots.mabel.sysid import rigs
from bipedlab.robots.mabel.sysid.logs import Experiment, motor_encoder

_GEARS = np.array([abs(tb.GEAR_LA), tb.GEAR_LS])
#: Names of the fit variables of one leg, in the order of the parameter vector.
VARIABLES = ("friction_mLA", "friction_mLS", "bias_mLA", "bias_mLS")


@dataclasses.dataclass(frozen=True)
class LegFit:
    """Result of :func:`fit_leg`: the rig with the fitted values, the fitted variables and
    their values, 1-sigma standard errors from the Jacobian (same units), the rms of the
    joint-side residuals (deg) per experiment, and the number of function evaluations."""

    rig: rigs.LegRig
    variables: tuple
    values: np.ndarray
    std: np.ndarray
    rms_deg: dict
    nfev: int


def experiment_arrays(exp: Experiment, side: str):
    """(active mask, x0, U (N, 2), Y (N, 2) motor encoders) of a leg experiment."""
    acts = rigs.LEG_ACTUATORS[side]
    active = tuple(a in exp.u for a in acts)
    n = len(exp.t)
    U = np.stack([exp.u[a] if a in exp.u else np.zeros(n) for a in acts], axis=1)
    Y = np.stack([exp.enc[motor_encoder(a)] for a in acts], axis=1)
    x0 = np.concatenate([Y[0], np.zeros(2)])
    return active, x0, U, Y


def _with(rig: rigs.LegRig, theta):
    """The rig with (log friction (2), bias (2)) = theta."""
    return rig.replace(friction=jnp.exp(theta[:2]), bias=theta[2:])


def _residual_fn(theta, rig, x0, U, Y, active, substeps):
    """Joint-side residuals (N-1, 2) of both motors; a locked motor's are multiplied by 0."""
    Ysim = rigs.simulate_leg(_with(rig, theta), x0, U, active, substeps)
    return ((Ysim[1:] - Y[1:]) / _GEARS * active).ravel()


def _both(z, theta0, B, rig, x0, U, Y, active, substeps):
    r = _residual_fn(theta0 + B @ z, rig, x0, U, Y, active, substeps)
    return r, r


#: (Jacobian in the free directions B (4, k), residual) in one compiled forward-mode pass.
_jacobian_and_residual = jax.jit(jax.jacfwd(_both, has_aux=True), static_argnames=("substeps",))


def simulate(rig: rigs.LegRig, exp: Experiment, substeps: int = 1) -> np.ndarray:
    """Motor angles (N, 2) the rig predicts for a leg experiment (from its first readings)."""
    active, x0, U, _ = experiment_arrays(exp, exp.meta["side"])
    return np.asarray(_simulate(rig, jnp.asarray(x0), jnp.asarray(U), jnp.asarray(active, dtype=float), substeps))


_simulate = jax.jit(rigs.simulate_leg, static_argnames=("substeps", "h"))


def fit_leg(rig: rigs.LegRig, experiments, variables=("friction_mLA", "friction_mLS"), substeps: int = 1,
            max_nfev: int = 50) -> LegFit:
    """Minimise eqs. 19-20 over ``variables`` (a subset of :data:`VARIABLES`) on one or more
    experiments of the rig's leg (their metadata name the side); the other values stay as in
    ``rig``."""
    experiments = [experiments] if isinstance(experiments, Experiment) else list(experiments)
    free = [VARIABLES.index(v) for v in variables]
    theta0 = np.concatenate([np.log(np.asarray(rig.friction)), np.asarray(rig.bias)])
    data = []
    for e in experiments:
        active, x0, U, Y = experiment_arrays(e, e.meta["side"])
        data.append((jnp.asarray(active, dtype=float), jnp.asarray(x0), jnp.asarray(U), jnp.asarray(Y)))
    scale = np.array([1.0, 1.0, 0.01, 0.01])[free]   # log-friction and N m of bias

    def full(z):
        th = theta0.copy()
        th[free] = np.asarray(z) * scale
        return jnp.asarray(th)

    cache = {}
    B = np.zeros((4, len(free)))
    B[free, np.arange(len(free))] = scale
    B = jnp.asarray(B)

    def evaluate(z):
        key = np.asarray(z).tobytes()
        if key not in cache:
            th0 = jnp.asarray(full(z))
            zero = jnp.zeros(len(free))
            out = [_jacobian_and_residual(zero, th0, B, rig, x0, U, Y, active, substeps) for active, x0, U, Y in data]
            cache.clear()
            cache[key] = (np.concatenate([np.asarray(r) for _, r in out]),
                          np.concatenate([np.asarray(J) for J, _ in out]))
        return cache[key]

    sol = optimize.least_squares(lambda z: evaluate(z)[0], theta0[free] / scale, jac=lambda z: evaluate(z)[1], method="lm", max_nfev=max_nfev,
                                 xtol=1e-10, ftol=1e-10, gtol=1e-10)
    th = np.asarray(full(sol.x))
    fitted = _with(rig, jnp.asarray(th))
    values = np.concatenate([np.exp(th[:2]), th[2:]])[free]
    std = _std(sol) * scale
    std[[i for i, f in enumerate(free) if f < 2]] *= values[[i for i, f in enumerate(free) if f < 2]]
    rms = {}
    offset = 0
    for e, (active, *_rest) in zip(experiments, data):
        k = (len(e.t) - 1) * 2
        moving = float(np.sum(np.asarray(active)))
        rms[e.name] = float(np.rad2deg(np.sqrt(np.sum(sol.fun[offset:offset + k] ** 2) / ((len(e.t) - 1) * moving))))
        offset += k
    return LegFit(fitted, tuple(variables), values, std, rms, int(sol.nfev))


def _std(sol) -> np.ndarray:
    """1-sigma standard errors of least-squares variables: sqrt(diag((J^T J)^-1) s^2)."""
    J = sol.jac
    dof = max(len(sol.fun) - J.shape[1], 1)
    s2 = float(np.sum(sol.fun**2) / dof)
    cov = np.linalg.pinv(J.T @ J) * s2
    return np.sqrt(np.clip(np.diag(cov), 0.0, None))
