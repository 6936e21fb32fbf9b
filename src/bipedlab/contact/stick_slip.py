"""Point contact with a stick/slip switch against a :class:`~bipedlab.contact.terrain.Terrain`
(the ground model of Geyer & Herr 2010), for implicit-damper integration.

Normal force: ``F_y = k_y pen (1 - v_y / v_max)`` with ``pen`` the depth below the terrain,
clipped at zero (unilateral). Tangential force while sticking: a spring-damper about the
anchor point x_a, ``F_x = -k_x dx (1 + sgn(dx) v_x / v_max)``, ``dx = x - x_a``, as long as
``|F_x| <= mu_stick F_y``; otherwise sliding friction ``-mu_slide F_y sgn(v_x)``, back to
stiction below ``v_stick``.

The forces are returned in the form ``F = F0 - C * v`` (elementwise over x, y) so that a
semi-implicit integrator can treat the dampers implicitly; the stick/slip switch and the
anchor update are applied after the step (:func:`transition`). Named stages:

* :func:`normal_terms` - (F0_y, C_y, contact flag, explicit F_y);
* :func:`tangential_terms` - (F0_x, C_x) for the sticking or sliding state;
* :func:`contact_terms` - both, as (F0 (2,), C (2,), contact flag);
* :func:`normal_force` - the explicit normal force (>= 0), e.g. for contact switches;
* :func:`transition` - the stick/slip switch and the new anchor after a step.
"""
from __future__ import annotations

import jax.numpy as jnp

from bipedlab.contact import terrain as tr
from bipedlab.pytree import pytree


@pytree
class StickSlipGround:
    """k_y: normal stiffness (N/m); k_x: stiction stiffness (N/m); v_max: damping velocity
    scale (m/s); mu_slide, mu_stick: sliding and stiction friction coefficients; v_stick:
    speed (m/s) below which a sliding point sticks again."""

    k_y: float
    k_x: float
    v_max: float = 0.03
    mu_slide: float = 0.8
    mu_stick: float = 0.9
    v_stick: float = 0.01


def normal_terms(g: StickSlipGround, terr: tr.Terrain, pos, vel):
    """Normal force terms of a point at ``pos`` (2,) moving at ``vel`` (2,): (F0_y, C_y, on,
    explicit F_y). ``on``: below the terrain with a positive explicit force."""
    pen = tr.ground(terr, pos[0]) - pos[1]
    fy_expl = g.k_y * pen * (1.0 - vel[1] / g.v_max)
    on = (pen > 0) & (fy_expl > 0)
    fy0 = jnp.where(on, g.k_y * pen, 0.0)
    cy = jnp.where(on, g.k_y * pen / g.v_max, 0.0)
    return fy0, cy, on, fy_expl


def tangential_terms(g: StickSlipGround, pos, vel, anchor, stick, on, fy_expl):
    """Tangential force terms (F0_x, C_x): the stiction spring-damper about ``anchor`` when
    ``stick`` (bool), sliding friction otherwise; zero without contact."""
    dx = pos[0] - anchor
    fx0_st = -g.k_x * dx
    cx_st = g.k_x * jnp.abs(dx) / g.v_max
    fx_sl = -g.mu_slide * jnp.maximum(fy_expl, 0.0) * jnp.sign(vel[0])
    fx0 = jnp.where(on, jnp.where(stick, fx0_st, fx_sl), 0.0)
    cx = jnp.where(on & stick, cx_st, 0.0)
    return fx0, cx


def contact_terms(g: StickSlipGround, terr: tr.Terrain, pos, vel, anchor, stick):
    """(F0 (2,), C (2,), on): the contact force is F0 - C * v (elementwise)."""
    fy0, cy, on, fy_expl = normal_terms(g, terr, pos, vel)
    fx0, cx = tangential_terms(g, pos, vel, anchor, stick, on, fy_expl)
    return jnp.stack([fx0, fy0]), jnp.stack([cx, cy]), on


def normal_force(g: StickSlipGround, terr: tr.Terrain, pos, vel):
    """Explicit normal force (N, >= 0) of a point at pos moving at vel."""
    pen = tr.ground(terr, pos[0]) - pos[1]
    fy = jnp.where(pen > 0, g.k_y * pen * (1 - vel[1] / g.v_max), 0.0)
    return jnp.maximum(fy, 0.0)


def transition(g: StickSlipGround, on, stick, anchor, force, x_new, vx_new):
    """After a step: a sticking point slips when |F_x| > mu_stick F_y (``force`` = (F_x, F_y)
    of the step), a sliding one sticks below v_stick, a point off the ground is reset to
    sticking; the anchor follows the point unless it keeps sticking. Returns (stick (bool),
    anchor)."""
    slip_now = stick & on & (jnp.abs(force[0]) > g.mu_stick * force[1])
    stick_now = ~stick & (jnp.abs(vx_new) < g.v_stick)
    new_stick = jnp.where(on, jnp.where(stick, ~slip_now, stick_now), True)
    new_anchor = jnp.where(on & stick & ~slip_now, anchor, x_new)
    return new_stick, new_anchor
