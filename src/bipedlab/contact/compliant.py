"""Compliant ground for point feet: a Marhefka-Orin normal force and LuGre friction.

Normal force (Marhefka & Orin 1996, nonlinear spring-damper in the penetration depth d):

    F_N = max(0, d^n (k + lam * d_dot)),   lam = lam_in while d_dot >= 0, lam_out otherwise,

zero while the point is above the terrain. The depth factor d^n on the damper makes the force
vanish continuously at first touch (no jump at impact, unlike a linear damper), and
``F_N >= 0`` keeps the ground from pulling. Compression and restitution may have different
damping coefficients (``damping_in``, ``damping_out``). A robot package states how its
published ground parameters map onto these, with the reasons.

Tangential force (LuGre, Canudas de Wit et al. 1995), written per unit normal force as in
Plestan et al. 2003, with a bristle deflection z (m) as an extra state per contact:

    z_dot = v - sigma0 |v| z / g(v),    g(v) = mu_c + (mu_s - mu_c) exp(-(v / v_s)^2),
    F_T = -F_N (sigma0 z + sigma1 z_dot + alpha v).

In steady sliding ``F_T = -F_N (g(v) sign(v) + alpha v)``: Coulomb friction ``mu_c`` with a
Stribeck peak ``mu_s`` at low speed and a viscous part ``alpha``; below the break-away force
the bristles act as a stiff spring-damper, so a standing foot does not creep. Away from the
ground the bristles relax to zero with rate ``relax`` (1/s), so each touchdown starts
unstressed.
"""
from __future__ import annotations

import dataclasses
from typing import Callable

import jax
import jax.numpy as jnp

from bipedlab.contact.penalty import flat
from bipedlab.pytree import replace as pytree_replace


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class CompliantGround:
    """Parameters (float64 leaves). stiffness k: N/m^n; exponent n; damping_in/out:
    N s/m^(n+1); bristle_stiffness sigma0: 1/m; bristle_damping sigma1: s/m; viscous alpha:
    s/m; coulomb mu_c, static mu_s (dimensionless); stribeck_velocity: m/s; relax: 1/s.
    terrain: height (m) as a function of x (static)."""

    stiffness: jax.Array
    exponent: jax.Array
    damping_in: jax.Array
    damping_out: jax.Array
    bristle_stiffness: jax.Array
    bristle_damping: jax.Array
    viscous: jax.Array
    coulomb: jax.Array
    static: jax.Array
    stribeck_velocity: jax.Array
    relax: jax.Array
    terrain: Callable = dataclasses.field(default=flat, metadata=dict(static=True))

    replace = pytree_replace


def make(**values) -> CompliantGround:
    """Build from keyword values (floats); ``terrain`` may be passed as a callable."""
    terrain = values.pop("terrain", flat)
    return CompliantGround(**{k: jnp.asarray(v, dtype=jnp.float64) for k, v in values.items()}, terrain=terrain)


def normal_force(g: CompliantGround, depth, depth_rate):
    """F_N (N) for penetration depth (m, > 0 inside) and its rate (m/s)."""
    d = jnp.maximum(depth, 0.0)
    lam = jnp.where(depth_rate >= 0.0, g.damping_in, g.damping_out)
    f = d**g.exponent * (g.stiffness + lam * depth_rate)
    return jnp.where(depth > 0.0, jnp.maximum(f, 0.0), 0.0)


def friction_curve(g: CompliantGround, v):
    """g(v): the friction coefficient of steady sliding at speed v, viscous part excluded."""
    return g.coulomb + (g.static - g.coulomb) * jnp.exp(-((v / g.stribeck_velocity) ** 2))


def tangential_force(g: CompliantGround, fn, v, z):
    """(F_T, z_dot) for normal force fn (N), tangential velocity v (m/s), bristle z (m)."""
    zdot_contact = v - g.bristle_stiffness * jnp.abs(v) * z / friction_curve(g, v)
    zdot = jnp.where(fn > 0.0, zdot_contact, -g.relax * z)
    mu = g.bristle_stiffness * z + g.bristle_damping * zdot_contact + g.viscous * v
    return jnp.where(fn > 0.0, -fn * mu, 0.0), zdot


def contact_split(g: CompliantGround, p, v, z):
    """The same force split for implicit integration: (F_N, F_T rest, c_T) with
    ``F_T = rest - c_T v_x``; c_T = F_N (sigma1 + alpha) >= 0 is the viscous part along the
    ground, which makes the tangential dynamics stiff under heavy load."""
    depth = g.terrain(p[0]) - p[1]
    fn = normal_force(g, depth, -v[1])
    zdot_rest = -g.bristle_stiffness * jnp.abs(v[0]) * z / friction_curve(g, v[0])
    rest = -fn * (g.bristle_stiffness * z + g.bristle_damping * zdot_rest)
    c_t = fn * (g.bristle_damping + g.viscous)
    return fn, jnp.where(fn > 0.0, rest, 0.0), c_t


def bristle_step(g: CompliantGround, fn, v, z, h):
    """Bristle deflection after a step h at tangential speed v, implicit in z (stable for
    any h): in contact ``z' = (z + h v) / (1 + h sigma0 |v| / g(v))``, else relaxing."""
    in_contact = (z + h * v) / (1.0 + h * g.bristle_stiffness * jnp.abs(v) / friction_curve(g, v))
    return jnp.where(fn > 0.0, in_contact, z / (1.0 + h * g.relax))


def contact(g: CompliantGround, p, v, z):
    """Ground force (Fx, Fy) on a point at p = (x, y) moving with v = (vx, vy), and the
    bristle rate, on terrain y = h(x) (forces along the world axes; h' is neglected)."""
    depth = g.terrain(p[0]) - p[1]
    depth_rate = -v[1]
    fn = normal_force(g, depth, depth_rate)
    ft, zdot = tangential_force(g, fn, v[0], z)
    return (ft, fn), zdot
