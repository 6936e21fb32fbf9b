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


def rk4_t(f: Callable, t, x, h):
    """RK4 step of the non-autonomous ``xdot, aux = f(t, x)`` (e.g. integration in a phase
    variable). Returns (x(t + h), aux at the first stage)."""
    k1, aux = f(t, x)
    k2 = f(t + 0.5 * h, x + 0.5 * h * k1)[0]
    k3 = f(t + 0.5 * h, x + 0.5 * h * k2)[0]
    k4 = f(t + h, x + h * k3)[0]
    return x + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4), aux


_STAGE_OFFSET = (0.0, 0.5, 0.5, 1.0)


def rk4_t_scan(f: Callable, t, x, h):
    """The same RK4 step with its four stages as one ``lax.scan`` over a single traced ``f``:
    the compiled program holds f once instead of four times (much shorter compile times for
    large flows; sums the stages in sequence, so results differ from :func:`rk4_t` by
    rounding). Returns (x(t + h), aux at the first stage)."""
    import jax
    import jax.numpy as jnp

    from bipedlab.sim.carry import joint

    coeffs = jnp.stack([jnp.asarray(_STAGE_OFFSET), jnp.asarray([1.0, 2.0, 2.0, 1.0]) / 6.0], 1)

    def stage(carry, c):
        acc, k = carry
        dx, aux = f(t + c[0] * h, x + c[0] * h * k)
        return (acc + c[1] * h * dx, dx), aux

    (xn, _), auxs = jax.lax.scan(stage, joint((x, jnp.zeros_like(x)), t, h), coeffs)
    return xn, jax.tree_util.tree_map(lambda a: a[0], auxs)



def rk4_scan(f: Flow, x, u, h):
    """The classical RK4 step of :func:`rk4` with its four evaluations of ``f`` as one
    ``lax.scan`` over the stages, so a compiled program holds ``f`` once instead of four times
    (a large flow, e.g. a cable-driven 7-DoF stance model, then compiles several times
    faster). The stages are combined after the scan exactly as :func:`rk4` combines them, so
    the two give the same numbers up to the compiler's contraction of multiply-adds."""
    import jax
    import jax.numpy as jnp

    def stage(k, c):
        dx = f(x + (c * h) * k, u)
        return dx, dx

    # stage offsets 0, 1/2, 1/2, 1; the first stage's offset multiplies a zero "previous" k
    _, ks = jax.lax.scan(stage, jnp.zeros_like(x), jnp.asarray([0.0, 0.5, 0.5, 1.0]))
    k1, k2, k3, k4 = ks[0], ks[1], ks[2], ks[3]
    return x + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)
