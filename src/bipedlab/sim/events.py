"""The one event locator: where a guard crosses zero inside an integration step.

Methods, all inside compiled code (no Python control flow on values):

* :func:`flow_to_event` - flow a smooth ODE until an armed guard crosses zero downwards; the
  crossing is located by secant iterations to a tolerance and re-expressed through the
  implicit function theorem so forward-mode derivatives include the event-time sensitivity;
* :func:`regula_falsi` - a fixed number of false-position iterations on a bracketed crossing
  inside one step (sampled-data loops);
* :func:`newton` - Newton's method with the derivative by forward mode (a smooth guard along a
  smooth step, e.g. the zero dynamics integrated in the phase variable);
* :func:`bisection` - a fixed number of halvings of a bracket on a predicate (non-smooth guards,
  several contacts at once);
* :func:`first_on_grid` - the first grid point where a predicate holds, to seed a bracket;
* :func:`linear_crossing` - the fraction of a step at which a linearly interpolated guard
  vanishes.

``flow_to_event`` in detail:

Fixed-step RK4 runs until the armed guard ``g(z)`` changes sign from positive to negative;
the crossing inside the last step is then located by secant iterations on the sub-step
``tau``, using the RK4 step from the start of that step as a 4th-order accurate local
solution, until ``|g(rk4(z_k, tau))|`` is below ``tol`` (1e-13 by default). The same RK4 call
serves the stepping and the refinement, and its four stages are one ``lax.scan`` over a single
traced flow (:func:`bipedlab.sim.integrators.rk4_scan`), so the compiled loop holds the flow
once. The event time is finally re-expressed through the implicit function theorem,
``tau <- tau - g / stop_gradient(g')``, so forward-mode derivatives (``jax.jacfwd``) of the event
state include the event-time sensitivity; that correction and the step to the corrected time are
the two iterations of one more scan over the same step, so the whole program holds the flow
three times (loop, correction, guard slope) however large it is.

Everything runs inside ``lax.while_loop`` (forward-mode differentiable) and returns a status
(``OK``; ``FELL`` when the step does not end within ``max_time`` or ``fell(z)`` holds;
``NONFINITE``) instead of raising.
"""
from __future__ import annotations

from typing import Callable

import jax
import jax.numpy as jnp

from bipedlab.pytree import pytree
from bipedlab.sim.integrators import rk4_scan
from bipedlab.sim.rollout import FELL, NONFINITE, OK


@pytree
class StepResult:
    """State at the event, its time, the integrals of ``integrand`` over the step (rectangle
    rule at the RK4 steps), the number of loop iterations, the guard value at the event, and
    the status code."""

    z: jax.Array
    t: jax.Array
    integrals: jax.Array
    steps: jax.Array
    guard: jax.Array
    status: jax.Array


def flow_to_event(f: Callable, guard: Callable, armed: Callable, z0, h: float, max_time: float,
                  integrand: Callable | None = None, fell: Callable | None = None,
                  tol: float = 1e-13, max_refine: int = 30) -> StepResult:
    """Integrate zdot = f(z) from z0 until guard(z) crosses zero downwards while armed(z).

    integrand(z) -> (k,) is accumulated over time; fell(z) -> bool ends the step as FELL."""
    integrand = integrand or (lambda z: jnp.zeros(0))
    fell = fell or (lambda z: jnp.asarray(False))
    nint = jax.eval_shape(integrand, z0).shape
    max_steps = int(max_time / h) + 1
    step = lambda z, dt: rk4_scan(lambda x, _: f(x), z, None, dt)  # noqa: E731
    z0 = jnp.asarray(z0)
    zero = jnp.zeros((), z0.dtype)

    # carry: k, z (start of the current step), guard at z, t, acc, integrand at z,
    #        mode (0 stepping, 1 refining, 2 done), secant bracket (ta, ga, tb, gb), status
    def cond(c):
        k, z, gz, t, acc, iz, mode, ta, ga, tb, gb, status = c
        return (mode < 2) & (k < max_steps + max_refine)

    def body(c):
        k, z, gz, t, acc, _, mode, ta, ga, tb, gb, status = c
        iz = integrand(z)
        refining = mode == 1
        denom = jnp.where(gb != ga, gb - ga, 1.0)
        tau = jnp.where(refining, jnp.clip(tb - gb * (tb - ta) / denom, 0.0, h), h)
        zn = step(z, tau)
        g_new = guard(zn)
        bad = ~jnp.all(jnp.isfinite(zn)) | (fell(zn) & ~refining)
        # stepping: detect a crossing in [z, zn]
        hit = ~refining & armed(zn) & (g_new < 0) & (gz >= 0)
        acc = acc + jnp.where(refining | hit, 0.0, h) * iz  # the crossing step: below
        # refining: keep the secant pair (previous iterate, new iterate)
        converged = refining & (jnp.abs(g_new) <= tol)
        new_mode = jnp.where(bad, 2, jnp.where(hit, 1, jnp.where(converged, 2, mode)))
        advance = ~refining & ~hit & ~bad
        z_next = jnp.where(advance | bad, zn, z)
        gz_next = jnp.where(advance | bad, g_new, gz)
        t_next = t + jnp.where(advance | bad, h, 0.0)
        ta_n = jnp.where(hit, 0.0, jnp.where(refining, tb, ta))
        ga_n = jnp.where(hit, gz, jnp.where(refining, gb, ga))
        tb_n = jnp.where(hit, h, jnp.where(refining, tau, tb))
        gb_n = jnp.where(hit, g_new, jnp.where(refining, g_new, gb))
        status = jnp.where(bad, jnp.where(jnp.all(jnp.isfinite(zn)), FELL, NONFINITE), status)
        return k + 1, z_next, gz_next, t_next, acc, iz, new_mode, ta_n, ga_n, tb_n, gb_n, status

    init = (jnp.asarray(0), z0, guard(z0), zero, jnp.zeros(nint), jnp.zeros(nint), jnp.asarray(0), zero, zero,
            zero, zero, jnp.asarray(OK))
    k, z, _, t, acc, iz, mode, ta, ga, tb, gb, status = jax.lax.while_loop(cond, body, init)
    found = (mode == 2) & (status == OK)
    status = jnp.where(found, OK, jnp.where(status == OK, FELL, status))

    # implicit-function form of the event time: exact value, exact forward-mode derivative.
    # Iteration 0 steps to the located time (no derivative) and corrects it by one Newton step
    # on the guard with the slope held; iteration 1 steps to the corrected time.
    def settle(tau, first):
        ze = step(z, tau)
        gz = guard(ze)
        slope = jax.lax.stop_gradient(jax.jvp(guard, (ze,), (f(ze),))[1])
        corrected = tau - gz / jnp.where(found, slope, 1.0)
        return jnp.where(first, corrected, tau), (ze, gz)

    tau, (zs, gs) = jax.lax.scan(settle, jax.lax.stop_gradient(tb), jnp.asarray([True, False]))
    ze = jnp.where(found, zs[1], z)
    t = t + jnp.where(found, tau, 0.0)
    acc = acc + jnp.where(found, tau, 0.0) * iz  # the located part of the last step
    return StepResult(ze, t, acc, k, jnp.where(found, gs[1], guard(z)), status)


def regula_falsi(g: Callable, a, b, ga, gb, iterations: int):
    """False position on the bracket [a, b] with g(a) = ga > 0 >= gb = g(b): ``iterations``
    updates keeping the sign change, then the final false-position point. Returns x."""
    def body(c, _):
        a, b, ga, gb = c
        x = a - ga * (b - a) / (gb - ga)
        gx = g(x)
        left = gx > 0.0
        return (jnp.where(left, x, a), jnp.where(left, b, x), jnp.where(left, gx, ga), jnp.where(left, gb, gx)), None

    a, b, ga, gb = jax.lax.scan(body, (a, b, ga, gb), None, length=iterations)[0]
    return a - ga * (b - a) / (gb - ga)


def regula_falsi_with(g: Callable, a, b, ga, gb, iterations: int):
    """:func:`regula_falsi` for a ``g`` that returns ``(value, aux)`` (e.g. the event function
    and the state it was computed from): the same ``iterations`` updates, then one more
    evaluation at the final false-position point, all in one ``lax.scan`` over a single traced
    ``g``. Returns (x, aux at x): the same x as :func:`regula_falsi`, and aux without a second
    copy of ``g`` in the program."""
    aux0 = jax.eval_shape(lambda: g(a)[1])
    aux0 = jax.tree_util.tree_map(lambda s: jnp.zeros(s.shape, s.dtype), aux0)

    def body(c, _):
        a, b, ga, gb, x_prev, aux_prev = c
        x = a - ga * (b - a) / (gb - ga)
        gx, aux = g(x)
        left = gx > 0.0
        return (jnp.where(left, x, a), jnp.where(left, b, x), jnp.where(left, gx, ga), jnp.where(left, gb, gx),
                x, aux), None

    c = jax.lax.scan(body, (a, b, ga, gb, jnp.zeros_like(jnp.asarray(a, float)), aux0), None,
                     length=iterations + 1)[0]
    return c[4], c[5]


def newton(g: Callable, x0, iterations: int):
    """``iterations`` Newton steps on g(x) = 0 from x0, g' by forward mode. Returns x."""
    def body(x, _):
        val, slope = jax.jvp(g, (x,), (jnp.ones_like(x),))
        return x - val / slope, None

    return jax.lax.scan(body, x0, None, length=iterations)[0]


def bisection(crossed: Callable, lo, hi, iterations: int):
    """``iterations`` halvings of [lo, hi], where ``crossed(hi)`` holds and ``crossed(lo)``
    does not. Returns the final (lo, hi)."""
    def body(_, c):
        lo, hi = c
        mid = 0.5 * (lo + hi)
        m = crossed(mid)
        return jnp.where(m, lo, mid), jnp.where(m, mid, hi)

    return jax.lax.fori_loop(0, iterations, body, (lo, hi))


def first_on_grid(values_hold, ts):
    """Index of the first grid point where ``values_hold`` (bool array over ``ts``) is true,
    the bracket (ts[k - 1], ts[k]) around it, and whether there is one."""
    k = jnp.argmax(values_hold)
    return k, ts[jnp.maximum(k - 1, 0)], ts[k], jnp.any(values_hold)


def linear_crossing(g0, g1, target=0.0):
    """Fraction in [0, 1] of a step at which g, linear from g0 to g1, reaches ``target``."""
    return jnp.clip((target - g0) / jnp.where(g1 - g0 == 0, 1.0, g1 - g0), 0.0, 1.0)


def bisection_step(crossed, lo, hi, mid):
    """One halving of the bracket [lo, hi] given ``crossed`` at its midpoint ``mid``: the
    update of :func:`bisection`, for loops that interleave the halvings with their own work
    (e.g. one integration step per iteration shared by stepping and locating). Returns the
    new (lo, hi)."""
    return jnp.where(crossed, lo, mid), jnp.where(crossed, mid, hi)
