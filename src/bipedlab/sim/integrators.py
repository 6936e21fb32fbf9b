"""The fixed-step integrators (one of each, used by every robot) for ``xdot = f(x, u)`` with u held over the step.

All take ``(f, x, u, h)`` and return the next state. ``rk4`` is 4th order (4 evaluations);
``heun`` is 2nd order (2 evaluations); ``semi_implicit_euler`` is 1st order and symplectic
(1 evaluation) for states split as ``x = [q, qd]``.
"""
from __future__ import annotations

from typing import Callable

Flow = Callable  # f(x, u) -> xdot


def rk4(f: Flow, x, u, h, k1=None):
    """Classical 4th-order Runge-Kutta step. ``k1`` = f(x, u) may be passed when the caller
    already evaluated it (see :func:`rk4_with_stage`)."""
    k1 = f(x, u) if k1 is None else k1
    k2 = f(x + (0.5 * h) * k1, u)
    k3 = f(x + (0.5 * h) * k2, u)
    k4 = f(x + h * k3, u)
    return x + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)


def rk4_with_stage(f: Flow, x, u, h):
    """An RK4 step that also hands back its first stage f(x, u) (the derivative at the
    start), e.g. for a loop that logs accelerations or reuses them for event location."""
    k1 = f(x, u)
    return rk4(f, x, u, h, k1), k1


def heun(f: Flow, x, u, h):
    k1 = f(x, u)
    k2 = f(x + h * k1, u)
    return x + (0.5 * h) * (k1 + k2)


def semi_implicit_euler(f: Flow, x, u, h):
    n = x.shape[-1] // 2
    qdd = f(x, u)[..., n:]
    qd = x[..., n:] + h * qdd
    q = x[..., :n] + h * qd
    return x.at[..., :n].set(q).at[..., n:].set(qd)


INTEGRATORS = {"rk4": rk4, "heun": heun, "semi_implicit_euler": semi_implicit_euler}
#: Dynamics evaluations per step, for throughput accounting.
EVALUATIONS = {"rk4": 4, "heun": 2, "semi_implicit_euler": 1}


def get(name: str):
    try:
        return INTEGRATORS[name]
    except KeyError:
        raise ValueError(f"unknown integrator {name!r}; choose from {', '.join(INTEGRATORS)}") from None
