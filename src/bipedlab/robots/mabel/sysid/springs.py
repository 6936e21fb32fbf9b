"""Spring stiffness and preload from the static experiments (Section VII-A, eqs. 21-24).

The robot stands balanced on one toe on a scale, leg angle 180 deg, leg shape held by its
motor at 10-30 deg. At rest the torque the B_spring pulley carries balances the load the
differentials pass down from the toe, and the paper writes (eqs. 21-24)::

    tau_Bsp = W sin(q_LS) / 5.18043,          K_B = |W sin(q_LS) / (5.18043 q_Bsp)|,

with W the scale's reading. That treats the leg as a massless straight strut under the toe
force. :func:`spring_torque` evaluates the same balance on the CAD model: the generalised
forces on q_LS of the toe force (W up at the toe, through the measured torso and leg angles)
and of the links' weights, divided by gamma_LS->Bsp = 5.18 (the cable force cancels between
the q_LS and q_Bsp equations, eq. 23). For a vertical massless leg it is eq. 21-23 exactly;
on MABEL the thigh's and shin's own weights lower it by about 3 % (16 N of W's 610 N), which
eq. 24 would put into K_B.

:func:`fit_spring` regresses ``tau_Bsp = K_B q_Bsp + tau_0`` over the postures (Fig. 19: a
line with an intercept, the preload tau_0) and also reports the same line through the paper's
torques (eqs. 21-23), whose slope is eq. 24's stiffness; :func:`eq24` is the per-posture
formula, which a preload biases.
"""
from __future__ import annotations

import dataclasses
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.mechanics import coupled as cp
from bipedlab.robots.mabel import model as mm
from bipedlab.robots.mabel import tables as tb
from bipedlab.robots.mabel.sysid.logs import Experiment

_H = {c: i for i, c in enumerate(mm.COORDS_13)}
#: tau_gravity / tau_Bsp of eq. 23 times 2 (eq. 24's 5.18043).
EQ24_RATIO = 5.18043


def spring_torque(m: mm.Mabel, q, side: str, force) -> float:
    """tau_Bsp (N m) at rest with the toe of ``side`` pushed up by ``force`` (N), the 13-DoF
    configuration q: ``(Q_LS^gravity + Q_LS^toe) / gamma_LS->Bsp``."""
    return float(_spring_torque(m, jnp.asarray(q, dtype=jnp.float64), side, jnp.asarray(force, dtype=jnp.float64)))


@partial(jax.jit, static_argnames=("side",))
def _spring_torque(m: mm.Mabel, q, side: str, force):
    i = _H[f"ls_{side}"]
    Jt = cp.point_jacobian(m.body, q, f"toe_{side}")
    q_grav = -jax.grad(lambda q: cp.potential_energy(m.body, q))(q)[i]
    return (q_grav + force * Jt[1, i]) / tb.GEAR_BSP


def configuration(exp: Experiment, row: int) -> jnp.ndarray:
    """The 13-DoF configuration of one posture of a static log (unlogged coordinates 0)."""
    q = np.zeros(13)
    for c, v in exp.enc.items():
        if c in _H:
            q[_H[c]] = v[row]
    return jnp.asarray(q)


@dataclasses.dataclass(frozen=True)
class SpringFit:
    """K_B (N m/rad) and preload tau_0 (N m) of one leg's spring, their 1-sigma errors, the
    postures' (q_Bsp, tau_Bsp), and the paper's torque ``W sin(q_LS) / 5.18043`` (eqs. 21-23)
    per posture with the slope and intercept of its line (what Fig. 19 fits)."""

    side: str
    stiffness: float
    preload: float
    stiffness_std: float
    preload_std: float
    deflection: np.ndarray
    torque: np.ndarray
    eq23_torque: np.ndarray
    eq24_stiffness: float
    eq24_preload: float


def eq24(W, q_ls, q_bsp) -> np.ndarray:
    """K_B = |W sin(q_LS) / (5.18043 q_Bsp)| per posture (eq. 24; no preload)."""
    return np.abs(np.asarray(W) * np.sin(q_ls) / (EQ24_RATIO * np.asarray(q_bsp)))


def _line(q, tau):
    """Least-squares (slope, intercept, their 1-sigma errors) of tau = slope q + intercept."""
    A = np.stack([q, np.ones_like(q)], axis=1)
    coef, *_ = np.linalg.lstsq(A, tau, rcond=None)
    r = tau - A @ coef
    cov = np.linalg.inv(A.T @ A) * float(r @ r) / max(len(q) - 2, 1)
    return float(coef[0]), float(coef[1]), float(np.sqrt(cov[0, 0])), float(np.sqrt(cov[1, 1]))


def fit_spring(m: mm.Mabel, exp: Experiment) -> SpringFit:
    """Stiffness and preload of the spring of ``exp.meta['side']`` from a static log (the CAD
    model m evaluates tau_Bsp at each measured posture)."""
    side = exp.meta["side"]
    W = np.asarray(exp.scale, float)
    tau = np.array([spring_torque(m, configuration(exp, i), side, W[i]) for i in range(len(W))])
    q = np.asarray(exp.enc[f"bsp_{side}"], float)
    if len(q) < 2 or np.ptp(q) == 0.0:
        raise ValueError(f"{exp.name}: the spring fit needs at least two postures with different deflections")
    k, t0, k_sd, t0_sd = _line(q, tau)
    tau23 = W * np.sin(np.asarray(exp.enc[f"ls_{side}"], float)) / EQ24_RATIO
    k23, t23, _, _ = _line(q, tau23)
    return SpringFit(side, k, t0, k_sd, t0_sd, q, tau, tau23, k23, t23)
