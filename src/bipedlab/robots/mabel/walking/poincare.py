"""Poincaré analysis of MABEL's walking (compliant-HZD paper, Section IV, eqs. 44 and 48).

Both maps are taken on the switching surface S_si->sd (theta_s = theta_si) and integrate in
theta with fixed RK4 nodes per sub-phase; the state-dependent events (touchdown, the 5 deg
spring trigger) are closed by one RK4 step whose length Newton's method finds (:func:`to_event`,
on the core's :func:`bipedlab.sim.hybrid.step_to_guard`), so the maps are smooth and their Jacobians exact
(forward mode), checked against central differences. A step is one ``lax.scan`` over its
sub-phases (:func:`run_step`), so each map's program holds the flow once for the nodes and
once for the events, and the gait, gains and model are traced arguments of it
(:func:`restricted_at`, :func:`full_map_at`): one program per controller serves every gait.

- :func:`full_map` (eq. 44): the 12-state stance dynamics in closed loop with a controller
  (PD + feedforward, or I/O linearisation with or without corrections), through SD,
  touchdown, the transition map, MC, SC and SI.
- :func:`restricted_map` (eq. 48): the 4-state zero dynamics with the hybrid-invariance
  corrections and the stance motor leg-shape update at each impact, a map of (q_Bsp_st,
  thetadot, qdot_Bsp_st) on the section.
"""
from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.robots.mabel.walking import constraints as vcm
from bipedlab.robots.mabel.walking import controllers as ctl
from bipedlab.robots.mabel.walking import stance as wk
from bipedlab.robots.mabel.walking import zero_dynamics as zd
from bipedlab.gait.poincare import central_differences, eigenvalues, fixed_point, value_and_jacobian  # noqa: F401
from bipedlab.sim import hybrid
from bipedlab.sim.carry import joint

#: RK4 steps per sub-phase (MC, SC, SI, SD) for the closed-loop maps
NODES = (6, 28, 28, 24)


def closed_loop(m, kind, g, vc):
    """f(phase, theta, z) = (dz/dtheta, u) of the stance dynamics under a controller."""

    def f(phase, th, z):
        D, H, B = terms = wk.stance_terms(m, z[:6], z[6:])
        u = ctl.control(kind, m, vc, phase, z, g, terms)
        dz = jnp.concatenate([z[6:], jnp.linalg.solve(D, B @ u - H)])
        return dz / jnp.maximum(vcm.theta_rate(z[6:]), zd.THETA_DOT_FLOOR), u

    return f


def _toe(m):
    return lambda th, z: wk.swing_toe(m, z)[1]


def _spring(th, z):
    return z[2] - vcm.SPRING_TRIGGER


def to_event(f, th, w, guard, h0=None):
    """The RK4 step in theta (:func:`~bipedlab.robots.mabel.walking.zero_dynamics.rk4`) from
    (th, w) to where ``guard(theta, w)`` vanishes, by Newton's method from ``h0`` (default 0:
    th is the nominal end of the sub-phase), four iterations; returns (theta_event, w_event)."""
    h0 = jnp.zeros(()) if h0 is None else h0
    return hybrid.step_to_guard(f, th, w, guard, h0, iterations=4, method="newton", integrator=zd.rk4)


def _after_impact(kind, nominal, z_plus, invariant):
    if kind == "pdff":
        return nominal
    return vcm.update_at_impact(nominal, z_plus[:6], z_plus[6:], nominal, invariant=invariant)


# ----------------------------------------------------------------------------- one step as scanned sub-phases

#: the sub-phases of a step from the section theta = theta_si, in order
_ORDER = (vcm.SD, vcm.MC, vcm.SC, vcm.SI)


def _segments(nodes):
    """(sub-phase, RK4 steps, ends at an event) for the four sub-phases of a step, in order."""
    n_mc, n_sc, n_si, n_sd = nodes
    counts = {vcm.SD: n_sd, vcm.MC: n_mc, vcm.SC: n_sc, vcm.SI: n_si}
    return (jnp.asarray(_ORDER), jnp.asarray([counts[p] for p in _ORDER]),
            jnp.asarray([p in (vcm.SD, vcm.SC) for p in _ORDER]))


def _end(nominal, vc, phase):
    """Nominal end of a sub-phase in theta: touchdown's and the spring trigger's are the
    nominal gait's (the events close them), MC's and SI's the step's constraints'."""
    return jnp.select([phase == vcm.SD, phase == vcm.MC, phase == vcm.SC],
                      [nominal.theta_minus, vc.theta_mc, nominal.theta_sc], vc.theta_si)


def run_step(flow, guard, reset, nominal, w, th, nodes=NODES):
    """One step through SD, touchdown, MC, SC, the spring trigger and SI as one ``lax.scan``
    over the four sub-phases, so that a compiled map holds the flow once for the RK4 nodes
    and once for the events (instead of once per sub-phase and event).

    Per sub-phase: ``n`` RK4 steps in theta of ``flow(vc, phase, theta, w) -> (dw, aux)`` from
    ``th`` to the sub-phase's nominal end (:func:`_end`, the shorter sub-phases skip the
    remaining of ``max(nodes)`` slots), then, where the sub-phase ends at an event, the RK4
    step whose length Newton's method finds (:func:`to_event`) to where ``guard(vc, phase,
    theta, w)`` vanishes, then ``reset(vc, phase, theta, w) -> (theta, w, vc)`` (the impact
    after SD, the spring trigger's theta_sc after SC). Returns w on the section after the step."""
    phases, counts, evented = _segments(nodes)
    slots = jnp.arange(max(nodes))

    def segment(carry, seg):
        w, vc, th = carry
        phase, n, has_event = seg
        th1 = _end(nominal, vc, phase)
        h = (th1 - th) / n
        f = lambda t, v: flow(vc, phase, t, v)  # noqa: E731

        def node(v, k):
            step = lambda v: zd.rk4(f, th + k * h, v, h)[0]  # noqa: E731
            return jax.lax.cond(k < n, step, lambda v: v, v), None

        w, _ = jax.lax.scan(node, w, slots)
        th_e, w = jax.lax.cond(has_event, lambda v: to_event(f, th1, v, lambda t, u: guard(vc, phase, t, u)),
                               lambda v: (th1, v), w)
        th, w, vc = reset(vc, phase, th_e, w)
        return (w, vc, th), None

    (w, _, _), _ = jax.lax.scan(segment, joint((w, nominal, th)), (phases, counts, evented))
    return w


def _spring_reset(vc, th, w):
    return th, w, vc.replace(theta_sc=th)


def _resets(at_touchdown):
    """reset(vc, phase, theta, w): ``at_touchdown`` after SD, theta_sc after SC, else none."""
    def reset(vc, phase, th, w):
        branches = [lambda a: (a[1], a[2], a[0])] * 4
        branches[vcm.SD] = lambda a: at_touchdown(*a)
        branches[vcm.SC] = lambda a: _spring_reset(*a)
        return jax.lax.switch(phase, branches, (vc, th, w))
    return reset


def full_map(m, kind, g, nominal, z, eta=1.0, invariant=True, nodes=NODES):
    """P(z) of eq. 44 for a stance state z on (or near) theta = theta_si: the state on the
    section after one step (:func:`run_step` of the closed-loop stance dynamics)."""

    def flow(vc, phase, th, w):
        return closed_loop(m, kind, g, vc)(phase, th, w)

    def guard(vc, phase, th, w):
        return jnp.where(phase == vcm.SD, wk.swing_toe(m, w)[1], _spring(th, w))

    def touchdown(vc, th, w):
        zp = wk.impact(m, w, eta).z_plus
        return vcm.theta(zp[:6]), zp, _after_impact(kind, nominal, zp, invariant)

    return run_step(flow, guard, _resets(touchdown), nominal, z, vcm.theta(z[:6]), nodes)


def restricted_map(m, nominal, x, eta=1.0, nodes=NODES):
    """rho(x) of eq. 48 for x = (q_Bsp_st, thetadot, qdot_Bsp_st) at theta = theta_si: the zero
    dynamics with the corrections of eqs. 45-47 and the event-based stance motor update."""
    pad = jnp.zeros(5)

    def flow(vc, phase, th, w):
        return zd.zero_dynamics(m, vc)(phase, th, w)

    def guard(vc, phase, th, w):
        return jnp.where(phase == vcm.SD, zd.swing_height(m, vc, phase, th, w), zd.spring_guard(th, w))

    def touchdown(vc, th, w):
        zp = wk.impact(m, zd.state(vc, vcm.SD, th, w), eta).z_plus
        vc = vcm.update_at_impact(nominal, zp[:6], zp[6:], nominal, invariant=True)
        return vc.theta_plus, jnp.concatenate([jnp.stack([zp[2], vcm.theta_rate(zp[6:]), zp[8]]), pad]), vc

    return run_step(flow, guard, _resets(touchdown), nominal, jnp.concatenate([x, pad]), nominal.theta_si, nodes)[:3]


def restricted_at(x, m, nominal):
    """:func:`restricted_map` with the section point first and the model and gait as traced
    arguments (:func:`~bipedlab.gait.poincare.fixed_point`'s ``args``): one compiled program
    serves every gait."""
    return restricted_map(m, nominal, x)


@functools.lru_cache(maxsize=None)
def full_map_at(kind: str):
    """P(z, m, gains, nominal) = :func:`full_map` under controller ``kind``, the model, gains
    and gait traced arguments: one function (so one compiled program) per controller."""
    def P(z, m, g, nominal):
        return full_map(m, kind, g, nominal, z)

    return P


# ----------------------------------------------------------------------------- PD gain scans

#: rows per call of the batched PD + feedforward map: a fixed batch, so that one compiled
#: program serves every gait, gain and grid size (rows are padded up to a multiple of it)
PD_BATCH = 100
#: central-difference step of the batched Jacobian (times max(1, |z_i|))
PD_FD_STEP = 1e-6


_PD_MAPS: dict = {}


def _pd_map_batch(m):
    """(gains, constraints, z), each batched on a leading axis of PD_BATCH rows -> P(z) of
    eq. 44 under PD + feedforward, row by row: the gains and the gait are data, so one
    compilation (per process, per model) serves all."""
    f = _PD_MAPS.get(id(m))
    if f is None:
        f = _PD_MAPS[id(m)] = jax.jit(jax.vmap(lambda g, vc, z: full_map(m, "pdff", g, vc, z)))
    return f


def _stack(trees):
    return jax.tree_util.tree_map(lambda *a: jnp.stack([jnp.asarray(x) for x in a]), *trees)


def _pd_eval(m, gains: list, vcs: list, zs: np.ndarray) -> np.ndarray:
    """P(z_i) under (gains[i], vcs[i]) for every row i, in fixed batches of PD_BATCH."""
    f = _pd_map_batch(m)
    n = len(zs)
    out = []
    for a in range(0, n, PD_BATCH):
        idx = list(range(a, min(a + PD_BATCH, n)))
        idx += [idx[-1]] * (PD_BATCH - len(idx))  # pad with the last row
        y = f(_stack([gains[i] for i in idx]), _stack([vcs[i] for i in idx]), jnp.asarray(zs[idx]))
        out.append(np.asarray(y)[: min(PD_BATCH, n - a)])
    return np.concatenate(out)


def pd_fixed_points(m, gains: list, vcs: list, z0s, iterations: int = 10, tol: float = 1e-10):
    """Fixed points of the full-order PD + feedforward map (eq. 44) and its Jacobians there, for
    many (gains, gait) pairs at once: Newton's method on z = P(z) with the Jacobian by central
    differences (step PD_FD_STEP * max(1, |z_i|)), every map evaluation of all pairs in the
    batches of :func:`_pd_eval` (the map compiles once, for any gains and gait; a grid of gains
    needs many fixed points at once, which the batch gives and the exact Jacobian of
    :func:`~bipedlab.robots.mabel.walking.study.poincare`, one point at a time, does not). A pair whose map is not finite keeps NaN. Returns (z (N, 12),
    J (N, 12, 12), residual (N,), passes over the map: Newton steps taken plus one)."""
    z = np.array(z0s, float)
    n, k = z.shape
    done = np.zeros(n, bool)
    J = np.full((n, k, k), np.nan)
    res = np.full(n, np.nan)
    passes = 0
    for it in range(iterations + 1):
        todo = np.nonzero(~done)[0]
        if todo.size == 0:
            break
        passes += 1
        h = PD_FD_STEP * np.maximum(1.0, np.abs(z[todo]))  # (T, k)
        rows = [z[todo]]
        for sign in (1.0, -1.0):
            for c in range(k):
                e = np.zeros_like(z[todo])
                e[:, c] = sign * h[:, c]
                rows.append(z[todo] + e)
        Z = np.stack(rows, 1).reshape(-1, k)  # (T * (2k + 1), k), pair-major
        rep = np.repeat(todo, 2 * k + 1)
        Y = _pd_eval(m, [gains[i] for i in rep], [vcs[i] for i in rep], Z).reshape(todo.size, 2 * k + 1, k)
        fx = Y[:, 0]
        # Y[:, 1 + c]: P at z + h_c e_c (axis 1 the perturbed column c); J[i, row, col]
        Jt = np.transpose((Y[:, 1:k + 1] - Y[:, k + 1:]) / (2 * h[:, :, None]), (0, 2, 1))
        J[todo] = Jt
        r = fx - z[todo]
        res[todo] = np.max(np.abs(r), 1)
        bad = ~np.all(np.isfinite(Y.reshape(todo.size, -1)), 1)
        conv = (res[todo] < tol) | bad | (it == iterations)
        done[todo[conv]] = True
        for j, i in enumerate(todo):
            if not conv[j]:
                z[i] = z[i] + np.linalg.lstsq(Jt[j] - np.eye(k), -r[j], rcond=None)[0]
    return z, J, res, passes
