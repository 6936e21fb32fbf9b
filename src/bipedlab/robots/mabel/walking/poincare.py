"""Poincaré analysis of MABEL's walking (compliant-HZD paper, Section IV, eqs. 44 and 48).

Both maps are taken on the switching surface S_si->sd (theta_s = theta_si) and integrate in
theta with fixed RK4 nodes per sub-phase; the state-dependent events (touchdown, the 5 deg
spring trigger) are closed by one RK4 step whose length Newton's method finds
(:func:`~bipedlab.robots.mabel.walking.zero_dynamics.to_event`), so the maps are smooth and their Jacobians exact
(forward mode), checked against central differences.

- :func:`full_map` (eq. 44): the 12-state stance dynamics in closed loop with a controller
  (PD + feedforward, or I/O linearisation with or without corrections), through SD,
  touchdown, the transition map, MC, SC and SI.
- :func:`restricted_map` (eq. 48): the 4-state zero dynamics with the hybrid-invariance
  corrections and the stance motor leg-shape update at each impact, a map of (q_Bsp_st,
  thetadot, qdot_Bsp_st) on the section.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.robots.mabel.walking import constraints as vcm
from bipedlab.robots.mabel.walking import controllers as ctl
from bipedlab.robots.mabel.walking import stance as wk
from bipedlab.robots.mabel.walking import zero_dynamics as zd
from bipedlab.gait.poincare import central_differences, eigenvalues, fixed_point, value_and_jacobian  # noqa: F401

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


def _phase_run(f, phase, w, th0, th1, n):
    return zd.integrate(f, phase, w, th0, th1, n)[0]


def _after_impact(kind, nominal, z_plus, invariant):
    if kind == "pdff":
        return nominal
    return vcm.update_at_impact(nominal, z_plus[:6], z_plus[6:], nominal, invariant=invariant)


def full_map(m, kind, g, nominal, z, eta=1.0, invariant=True, nodes=NODES):
    """P(z) of eq. 44 for a stance state z on (or near) theta = theta_si: the state on the
    section after one step."""
    n1, n2, n3, n4 = nodes
    f_sd = closed_loop(m, kind, g, nominal)
    th0 = vcm.theta(z[:6])
    w = _phase_run(f_sd, vcm.SD, z, th0, nominal.theta_minus, n4)
    h0 = jnp.zeros(())
    _, z_minus = zd.to_event(lambda th, w: f_sd(vcm.SD, th, w), nominal.theta_minus, w, _toe(m), h0)
    zp = wk.impact(m, z_minus, eta).z_plus
    vc = _after_impact(kind, nominal, zp, invariant)
    f = closed_loop(m, kind, g, vc)
    w = _phase_run(f, vcm.MC, zp, vcm.theta(zp[:6]), vc.theta_mc, n1)
    w = _phase_run(f, vcm.SC, w, vc.theta_mc, nominal.theta_sc, n2)
    th_sc, w = zd.to_event(lambda th, v: f(vcm.SC, th, v), nominal.theta_sc, w, _spring, h0)
    vc = vc.replace(theta_sc=th_sc)
    f = closed_loop(m, kind, g, vc)
    w = _phase_run(f, vcm.SI, w, th_sc, vc.theta_si, n3)
    return w


def restricted_map(m, nominal, x, eta=1.0, nodes=NODES):
    """rho(x) of eq. 48 for x = (q_Bsp_st, thetadot, qdot_Bsp_st) at theta = theta_si: the zero
    dynamics with the corrections of eqs. 45-47 and the event-based stance motor update."""
    n1, n2, n3, n4 = nodes
    pad = jnp.zeros(5)
    w = jnp.concatenate([x, pad])
    f0 = zd.zero_dynamics(m, nominal)
    w = _phase_run(f0, vcm.SD, w, nominal.theta_si, nominal.theta_minus, n4)
    th_m, w = zd.to_event(lambda th, v: f0(vcm.SD, th, v), nominal.theta_minus, w,
                          lambda th, v: zd.swing_height(m, nominal, vcm.SD, th, v), jnp.zeros(()))
    z_minus = zd.state(nominal, vcm.SD, th_m, w)
    zp = wk.impact(m, z_minus, eta).z_plus
    vc = vcm.update_at_impact(nominal, zp[:6], zp[6:], nominal, invariant=True)
    w = jnp.concatenate([jnp.stack([zp[2], vcm.theta_rate(zp[6:]), zp[8]]), pad])
    f = zd.zero_dynamics(m, vc)
    w = _phase_run(f, vcm.MC, w, vc.theta_plus, vc.theta_mc, n1)
    w = _phase_run(f, vcm.SC, w, vc.theta_mc, nominal.theta_sc, n2)
    th_sc, w = zd.to_event(lambda th, v: f(vcm.SC, th, v), nominal.theta_sc, w,
                           zd.spring_guard, jnp.zeros(()))
    vc = vc.replace(theta_sc=th_sc)
    f = zd.zero_dynamics(m, vc)
    w = _phase_run(f, vcm.SI, w, th_sc, vc.theta_si, n3)
    return w[:3]
