"""The hybrid step: one mode transition as named pure functions, and the stages that integrate
it, detect the event, locate it, apply the reset and go on.

A :class:`Transition` names the pieces of a hybrid system (flow + guard + reset):

* ``flow(x, u) -> xdot``: the continuous dynamics under an input ``u`` held over the step (any
  pytree, e.g. a torque and a force), in state units per second;
* ``guard(x) -> scalar``: the event happens where it crosses zero downwards (from > 0 to <= 0),
  e.g. a foot's height above the ground in m;
* ``armed(x) -> bool``: whether the guard may fire, evaluated at the state a step reaches
  without an event (e.g. the swing foot is ahead, or the step has lasted long enough);
* ``reset(x) -> (x_plus, info)``: the state just before the event to the state just after, and
  a pytree of what the caller wants to know about it (a step length in m, an impulse in N s);
* ``integrator(f, x, u, h)``: one fixed step (default the core RK4 of
  :mod:`bipedlab.sim.integrators`; any of that module's integrators fits);
* ``input_after(u) -> u``: the input held over the rest of the step after the event (default:
  the same input; e.g. a push that ends at a touchdown).

Stages:

* :func:`substep` - one step of length ``h`` (s) of a sampled plant: integrate, detect a
  crossing, locate it inside the step by false position (Illinois, or plain regula falsi) on
  the fraction of the step (a fixed number of iterations), apply the reset and integrate the
  remainder of the step from the reset state. One compiled ``lax.while_loop`` holds one call
  of the integrator, shared by the step, the locating iterations and the remainder, and one
  call of the reset. Returns the state and
  an :class:`Event` (``event``, ``fraction`` of ``h`` before it, the reset's ``info``).
* :func:`flow_until_event` - flow from a state until the event and reset it, for step-to-step
  (Poincare) maps on the section after the reset, or reset a state at an event and flow to the
  next one, for maps on the section before it (``section="pre"``): the crossing is located
  by :func:`bipedlab.sim.events.flow_to_event` (secant iterations to a tolerance), or, with ``locate="linear"``, the state is linearly
  interpolated between the two integration steps around the crossing (first order in the step;
  kept for results recorded with it);
* :func:`flow_sample` - one sample interval of a :class:`MultiTransition`, a system with a
  discrete state (an active set of contacts, anchors, counters) and a vector of guards
  (several contacts at once): integrator steps of at most ``h``, each accepted one followed
  by the transition's projection; a step that ends with any element past its guard is
  bisected to ``tr.tol`` s, the reset applies at the bracket's far end, and the interval goes
  on from there, so any number of events happen in one sample. One compiled
  ``lax.while_loop`` holds one call of the integrator, of the projection and of the reset.
* :func:`step_to_guard` - one integrator step in an independent variable (a phase variable
  the flow is written in, or time) from a point near the event, of the length where a smooth
  guard of (variable, state) vanishes: the closing step of a flow integrated on fixed nodes
  (``method="newton"``: Newton's method on the step length, its derivative by forward mode, a
  fixed number of iterations), smooth in the initial state so its forward-mode derivative is
  the exact event's;
* :func:`first_event_time` - the first time a guard given as a function of time reaches zero,
  for motions known in closed form (a ballistic flight), where nothing is integrated and the
  guard may jump (a foot passing over a terrain step): a grid, then bisection.

Event-time sensitivity: the located fraction ``tau`` of a substep is re-expressed through the
implicit function theorem, ``tau <- stop_gradient(tau) - (g - stop_gradient(g)) /
stop_gradient(dg/dtau)``, with ``g`` the guard at the located state and ``dg/dtau`` its rate
along the flow there. The value is the located one unchanged (the correction is zero); the
forward-mode tangent (``jax.jvp``, ``jax.jacfwd``) is the exact derivative of the event time, so
derivatives of the post-event state include the event's shift. ``flow_until_event`` inherits the
same correction from ``flow_to_event``.

Everything is traced (``lax.while_loop``, ``lax.cond``, ``jnp.where``): no Python branching on
values, and a failure is a status, never an exception.
"""
from __future__ import annotations

from typing import Any, Callable

import jax
import jax.numpy as jnp

from bipedlab.pytree import pytree, static_field
from bipedlab.sim.carry import joint
from bipedlab.sim.events import (StepResult, bisection, bisection_step, first_on_grid, flow_to_event,
                                 linear_crossing, newton)
from bipedlab.sim.integrators import rk4, rk4_t_scan
from bipedlab.sim.rollout import FELL, NONFINITE, OK


def _same_input(u):
    return u


@pytree
class Transition:
    """One mode transition of a hybrid system (see the module docstring for the signatures and
    units). ``iterations``: bracket updates of the located fraction in :func:`substep` (one
    more evaluation follows them); ``method``: ``"illinois"`` (false position that halves the
    guard value kept at an end retained twice: superlinear, robust on long substeps) or
    ``"false_position"`` (plain regula falsi: linear convergence, at the rate of the guard's
    curvature over the substep); ``sensitivity``: whether the located event time carries its
    implicit-function tangent (costs one evaluation of ``flow`` at the event)."""

    flow: Callable = static_field()
    guard: Callable = static_field()
    armed: Callable = static_field()
    reset: Callable = static_field()
    integrator: Callable = static_field(rk4)
    input_after: Callable = static_field(_same_input)
    iterations: int = static_field(6)
    method: str = static_field("illinois")
    sensitivity: bool = static_field(True)


@pytree
class Event:
    """What a substep saw: ``event`` (bool) whether the guard fired, ``fraction`` of the step
    length h elapsed before it (1.0 without an event; multiply by h for seconds), and ``info``,
    the reset's pytree (zeros without an event)."""

    event: jax.Array
    fraction: jax.Array
    info: Any


def _keep(x, d):
    return x, d


@pytree
class MultiTransition:
    """Transitions of a system with a discrete state ``d`` (any pytree: an active set, contact
    anchors, records of what happened) held over the flow, and several guards at once:

    * ``flow(x, u, d) -> xdot``, the continuous dynamics in mode ``d`` under the held input u;
    * ``guard(x, d) -> (k,) bool``: the elements past their guard (e.g. an inactive contact
      point below the ground by more than a tolerance); an event is any of them;
    * ``reset(x, d, crossed) -> (x_plus, d_plus)`` at the located state, ``crossed`` the
      elements past their guard there (e.g. a plastic impact over the new active set);
    * ``project(x, d) -> (x, d)``: applied after every step accepted without an event (e.g.
      back onto the active constraints; ``d`` may record the drift); default none;
    * ``integrator(f, x, u, h)`` (default RK4), ``tol``: the width in s to which an event is
      bisected, ``max_iterations``: loop iterations per sample (steps, halvings, events)
      before the sample counts as unresolved."""

    flow: Callable = static_field()
    guard: Callable = static_field()
    reset: Callable = static_field()
    project: Callable = static_field(_keep)
    integrator: Callable = static_field(rk4)
    tol: float = static_field(1e-10)
    max_iterations: int = static_field(400)


@pytree
class Sampled:
    """What :func:`flow_sample` saw over its interval: ``events`` (int32) the resets applied,
    ``crossed`` (k,) bool the elements that crossed at any of them, ``finite`` whether every
    integrated state was finite, ``resolved`` whether the interval was completed within
    ``max_iterations``."""

    events: jax.Array
    crossed: jax.Array
    finite: jax.Array
    resolved: jax.Array


#: time left in an interval (s) below which it is complete
_INTERVAL_END = 1e-13


def flow_sample(tr: MultiTransition, x, d, u, t0, duration, h):
    """The interval [t0, t0 + duration] (s) from (x, d) under the held input u, with every event
    in it (see :class:`MultiTransition`).

    Each loop iteration is one integrator step from the current state: a step of
    ``min(h, time left)``, or while an event is being located, to the midpoint of the bracket.
    A full step with no element past its guard is accepted and projected; one with any opens
    the bracket [0, step] on the time since the current state, halved
    (:func:`bipedlab.sim.events.bisection_step`) until narrower than ``tr.tol``; then
    ``tr.reset`` applies at the state of the bracket's far end with the elements past their
    guard there, time advances by that end, and the interval goes on from the reset state.
    A non-finite state ends the interval. Returns (x, d, :class:`Sampled`)."""
    x = jnp.asarray(x)
    t_end = t0 + duration
    zero = jnp.zeros((), x.dtype)
    k = jax.eval_shape(tr.guard, x, d).shape

    def cond(c):
        return ~c[-1] & (c[7] < tr.max_iterations)

    def body(c):
        t, x, xh, d, mode, lo, hi, it, n_ev, crossed, finite_all, done = c
        tau = jnp.where(mode == 0, jnp.minimum(t_end - t, h), 0.5 * (lo + hi))
        x1 = tr.integrator(lambda z, v: tr.flow(z, v, d), x, u, tau)
        any_hit = jnp.any(tr.guard(x1, d))
        finite = jnp.all(jnp.isfinite(x1))
        accept = (mode == 0) & ~any_hit
        # bracket [lo, hi] on the time since t: no element past its guard at lo, some at hi
        # (state xh); a crossing in a full step opens [0, tau]
        b_lo, b_hi = bisection_step(any_hit, lo, hi, tau)
        lo_n = jnp.where(mode == 0, 0.0, b_lo)
        hi_n = jnp.where(mode == 0, jnp.where(any_hit, tau, hi), b_hi)
        xh = jnp.where(any_hit, x1, xh)
        located = (mode == 1) & (hi_n - lo_n < tr.tol)
        new = tr.guard(xh, d)
        # accepted and located are exclusive: one branch keeps, projects or resets
        which = jnp.where(accept & finite, 1, jnp.where(located & finite, 2, 0))
        x_n, d_n = jax.lax.switch(which, (lambda: (x, d), lambda: tr.project(x1, d), lambda: tr.reset(xh, d, new)))
        t_n = jnp.where(accept, t + tau, jnp.where(located, t + hi_n, t))
        mode_n = jnp.where(located | accept, 0, 1)
        done = (accept & (t_end - t_n <= _INTERVAL_END)) | ~finite
        return (t_n, x_n, xh, d_n, mode_n, lo_n, hi_n, it + 1, n_ev + located.astype(jnp.int32),
                crossed | (new & located), finite_all & finite, done)

    init = (jnp.asarray(t0, x.dtype), x, x, d, jnp.asarray(0), zero, zero, jnp.asarray(0), jnp.asarray(0, jnp.int32),
            jnp.zeros(k, bool), jnp.asarray(True), jnp.asarray(False))
    _, x, _, d, *_, n_ev, crossed, finite, done = jax.lax.while_loop(cond, body, init)
    return x, d, Sampled(events=n_ev, crossed=crossed, finite=finite, resolved=done)


def _where(c, a, b):
    return jax.tree_util.tree_map(lambda p, q: jnp.where(c, p, q), a, b)


def _zeros_like_shape(tree):
    return jax.tree_util.tree_map(lambda s: jnp.zeros(s.shape, s.dtype), tree)


def _event_state(tr: Transition, x_tau, g_tau, tau, u, h):
    """The located state and fraction with the implicit-function tangent of the event time.

    ``x_tau`` is the state reached at the fixed (non-differentiated) fraction ``tau``, ``g_tau``
    the guard there. Values are returned unchanged; tangents are those of the exact root."""
    tau = jax.lax.stop_gradient(tau)
    if not tr.sensitivity:
        return x_tau, tau
    rate = jax.lax.stop_gradient(h * tr.flow(x_tau, u))  # d x / d tau
    slope = jax.lax.stop_gradient(jax.jvp(tr.guard, (x_tau,), (rate,))[1])  # d g / d tau
    safe = jnp.isfinite(slope) & (slope != 0.0)
    corr = -(g_tau - jax.lax.stop_gradient(g_tau)) / jnp.where(safe, slope, 1.0)
    corr = jnp.where(safe, corr, 0.0)
    rate = jnp.where(jnp.isfinite(rate), rate, 0.0)
    return x_tau + rate * corr, tau + corr


def substep(tr: Transition, x, u, h):
    """One step of length ``h`` (s) from state ``x`` under the held input ``u``.

    Without an event: ``tr.integrator(tr.flow, x, u, h)``. With one - ``guard(x) > 0``,
    ``guard <= 0`` at the end of the step and ``armed`` there - the fraction of the step at the
    crossing is located by ``tr.iterations`` bracket updates on [0, 1] (``tr.method``) and one final
    evaluation (each an integrator step from ``x`` over the trial fraction), the reset is
    applied at the located state and the rest of the step is integrated from the reset state
    under ``tr.input_after(u)``. At most one event per substep. Returns (state, :class:`Event`).
    """
    x = jnp.asarray(x)
    h = jnp.asarray(h, x.dtype)
    u_after = tr.input_after(u)
    g0 = tr.guard(x)
    _, info0 = jax.eval_shape(tr.reset, x)
    info0 = _zeros_like_shape(info0)
    n = tr.iterations
    one, zero = jnp.ones((), x.dtype), jnp.zeros((), x.dtype)

    if tr.method not in ("illinois", "false_position"):
        raise ValueError(f"Transition.method: unknown {tr.method!r}; choose 'illinois' or 'false_position'")
    illinois = tr.method == "illinois"
    sg = jax.lax.stop_gradient

    # mode 0: the step; 1: locating (iteration j of n + 1); 2: the remainder; 3: done;
    # bracket (a, b, ga, gb) on the fraction, ga > 0 >= gb; side: the end replaced last (+1 a)
    def cond(c):
        return c[0] < 3

    def body(c):
        mode, j, a, b, ga, gb, side, tau, x_plus, info, x_out, event = c
        trial = sg(a - ga * (b - a) / (gb - ga))
        start = jnp.where(mode == 2, x_plus, x)
        dt = jnp.where(mode == 0, h, jnp.where(mode == 1, trial * h, (1.0 - tau) * h))
        xn = tr.integrator(tr.flow, start, _where(mode == 2, u_after, u), dt)
        gn = tr.guard(xn)
        hit = (mode == 0) & (g0 > 0.0) & (gn <= 0.0) & tr.armed(xn)
        locating = mode == 1
        left = locating & (sg(gn) > 0.0)
        right = locating & ~(sg(gn) > 0.0)
        if illinois:  # the end kept a second time counts half
            gb = jnp.where(left & (side > 0), 0.5 * gb, gb)
            ga = jnp.where(right & (side < 0), 0.5 * ga, ga)
        a = jnp.where(hit, 0.0, jnp.where(left, trial, a))
        b = jnp.where(hit, 1.0, jnp.where(right, trial, b))
        ga = jnp.where(hit, sg(g0), jnp.where(left, sg(gn), ga))
        gb = jnp.where(hit | right, sg(gn), gb)
        side = jnp.where(hit, 0, jnp.where(left, 1, jnp.where(right, -1, side)))
        last = locating & (j == n)

        def at_event(_):
            xe, te = _event_state(tr, xn, gn, trial, u, h)
            xp, inf = tr.reset(xe)
            return jnp.asarray(xp, x.dtype), inf, te

        x_plus, info, tau = jax.lax.cond(last, at_event, lambda _: (x_plus, info, tau), None)
        x_out = jnp.where((mode == 0) | (mode == 2), xn, x_out)
        mode = jnp.where(mode == 0, jnp.where(hit, 1, 3), jnp.where(locating, jnp.where(last, 2, 1), 3))
        return mode, j + locating, a, b, ga, gb, side, tau, x_plus, info, x_out, event | hit

    init = (jnp.asarray(0), jnp.asarray(0), zero, one, one, -one, jnp.asarray(0), one, x, info0, x,
            jnp.asarray(False))
    c = jax.lax.while_loop(cond, body, init)
    tau, info, x_out, event = c[7], c[9], c[10], c[11]
    return x_out, Event(event=event, fraction=jnp.where(event, tau, 1.0), info=info)


def flow_until_event(tr: Transition, x0, u, h: float, max_time: float, integrand: Callable | None = None,
                     fell: Callable | None = None, locate: str = "secant", tol: float = 1e-13,
                     max_refine: int = 30, section: str = "post"):
    """Flow ``tr.flow`` under the held input ``u`` with steps of ``h`` (s) until the armed guard
    crosses zero downwards, with ``tr.reset``: a step-to-step map.

    ``section="post"``: the map of the section just after the reset: flow from ``x0`` to the
    event, then apply the reset there. ``section="pre"``: the map of the section on the guard,
    just before the reset: apply the reset to ``x0`` (a state at an event), then flow from the
    reset state to the next event (the state there is the map's value; its reset is the next
    step's).

    ``locate="secant"``: :func:`bipedlab.sim.events.flow_to_event` (RK4, the crossing located by
    secant iterations to ``tol`` in the guard's unit, event-time tangent included; ``integrand``
    accumulated over the flow). ``locate="linear"``: ``tr.integrator`` steps until a step ends
    armed with ``guard <= 0`` (or ``fell``), and the event state is the linear interpolation
    between that step's ends at the guard's linear crossing (no ``integrand``).

    ``fell(x) -> bool`` ends the flow with status FELL; so does ``max_time`` (s) without an
    event. Returns (:class:`~bipedlab.sim.events.StepResult` at the event, the reset state,
    the reset's info). With ``section="post"`` the reset is the event's, and where the status
    is not OK the reset state is the event state and the info zeros; with ``section="pre"`` it
    is the reset of ``x0`` the flow started from."""
    if section not in ("post", "pre"):
        raise ValueError(f"flow_until_event: unknown section {section!r}; choose 'post' or 'pre'")
    if section == "pre":
        x_start, info_start = tr.reset(x0)
        x0 = jnp.asarray(x_start, jnp.asarray(x0).dtype)
    if locate == "secant":
        r = flow_to_event(lambda z: tr.flow(z, u), tr.guard, tr.armed, x0, h, max_time, integrand, fell, tol,
                          max_refine)
    elif locate == "linear":
        if integrand is not None:
            raise ValueError("flow_until_event: locate='linear' accumulates no integrand")
        r = _flow_linear(tr, x0, u, h, int(round(max_time / h)), fell)
    else:
        raise ValueError(f"flow_until_event: unknown locate {locate!r}; choose 'secant' or 'linear'")
    if section == "pre":
        return r, x0, info_start
    xp, info = tr.reset(r.z)
    ok = r.status == OK
    info0 = _zeros_like_shape(jax.eval_shape(lambda z: tr.reset(z)[1], r.z))
    return r, jnp.where(ok, xp, r.z), _where(ok, info, info0)


def _flow_linear(tr: Transition, x0, u, h, max_steps: int, fell: Callable | None) -> StepResult:
    """Integrator steps until one ends armed on the far side of the guard, or fell; the event
    state linearly interpolated inside that step. Time = (steps - 1 + fraction) h."""
    fell = fell or (lambda z: jnp.asarray(False))
    x0 = jnp.asarray(x0)

    def cond(c):
        _, _, k, done = c
        return (~done) & (k < max_steps)

    def body(c):
        x, _, k, _ = c
        xn = tr.integrator(tr.flow, x, u, h)
        out = (tr.armed(xn) & (tr.guard(xn) <= 0.0)) | fell(xn)
        return xn, x, k + 1, out

    x, xp, k, done = jax.lax.while_loop(cond, body, (x0, x0, 0, False))
    frac = linear_crossing(tr.guard(xp), tr.guard(x), 0.0)
    xe = xp + frac * (x - xp)
    finite = jnp.all(jnp.isfinite(x))
    status = jnp.where(~finite, NONFINITE, jnp.where(done & ~fell(x), OK, FELL))
    return StepResult(z=xe, t=(k - 1 + frac) * h, integrals=jnp.zeros(0), steps=k, guard=tr.guard(xe),
                      status=status)


def step_to_guard(flow: Callable, s, w, guard: Callable, h0, iterations: int = 4, method: str = "newton",
                  integrator: Callable = rk4_t_scan):
    """One step of ``integrator`` from ``(s, w)`` in the independent variable ``s`` of
    ``dw/ds, aux = flow(s, w)``, of the length h where ``guard(s + h, w(s + h))`` vanishes.

    ``integrator(flow, s, w, h) -> (w(s + h), aux)`` (default
    :func:`bipedlab.sim.integrators.rk4_t_scan`); ``method="newton"``: ``iterations`` Newton
    steps on h from ``h0`` (``s`` units, e.g. 0 when ``s`` is the nominal end of the flow), the
    guard's slope by forward mode through the step. The step is a smooth function of ``w`` and
    of everything the flow is traced with, so forward-mode derivatives of the result are those
    of the exact event. Returns (s at the event, w there)."""
    if method != "newton":
        raise ValueError(f"step_to_guard: unknown method {method!r}; choose 'newton'")

    def g(h):
        return guard(s + h, integrator(flow, s, w, h)[0])

    h = newton(g, joint(h0, s, w), iterations)
    return s + h, integrator(flow, s, w, h)[0]


def first_event_time(guard_at: Callable, t_max: float, n: int, t_min: float = 0.0, iterations: int = 40):
    """The first time in (t_min, t_max] (s) at which ``guard_at(t) <= 0``, for a motion known in
    closed form as a function of time: the first of ``n`` grid points from 0 to ``t_max`` past
    ``t_min`` where the guard is non-positive, then ``iterations`` halvings of the bracket
    before it (a predicate, so a guard that jumps is located too, to (t_max / n) 2^-iterations
    s). Returns (time, found): the bracket's far end, and whether any grid point is past the
    guard (without one the time is meaningless)."""
    ts = jnp.linspace(0.0, t_max, n)
    below = (jax.vmap(guard_at)(ts) <= 0.0) & (ts > t_min)
    _, lo, hi, found = first_on_grid(below, ts)
    lo, hi = bisection(lambda t: guard_at(t) <= 0, lo, hi, iterations)
    return hi, found


__all__ = ["Event", "MultiTransition", "Sampled", "Transition", "first_event_time", "flow_sample",
           "flow_until_event", "step_to_guard", "substep"]
