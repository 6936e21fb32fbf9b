"""The passive compass-gait biped of Goswami, Thuilot & Espiau, built on the core only.

Two identical rigid legs of length l = a + b (m) with their mass m (kg) at distance b from the
hip (a from the foot), a point mass m_hip (kg) at the hip, point feet, no actuation.

Model (a :class:`bipedlab.mechanics.Model`)
-------------------------------------------
Floating base ``q = [x_hip, y_hip, leg_1, leg_2]``: hip position (m, world, y up), the
absolute angle of leg 1 (rad, from the downward vertical, counter-clockwise positive, so a
positive angle puts the foot ahead of the hip in +x) and the hip angle of leg 2 relative to
leg 1 (rad). The root body is leg 1 with its frame at the hip; the hip mass is lumped into it
exactly (a point mass at the hip joint belongs equally to either leg: the combined body has
mass m + m_hip, its COM on the leg at m b / (m + m_hip) below the hip and the inertia of the
two point masses about that COM). Named points: ``hip``, ``foot_1``, ``foot_2``.

Stance (``bipedlab.mechanics.stance``)
-------------------------------------
Single support on ``foot_1`` (stance leg = leg 1, swing leg = leg 2). The stance state is
``z = [theta, psi, thetadot, psidot]``: stance-leg absolute angle and hip angle (rad), with
rates (rad/s); the swing leg's absolute angle is theta + psi.

Slope: gravity stays vertical (the core's gravity is a scalar along -y) and the slope enters
the guard: the ground is the line through the stance foot descending at ``slope`` (rad) in +x,
and the guard is the swing foot's signed distance to that line.

Leg swap: after the impact the old swing leg becomes leg 1. With a relative hip angle this is
the linear map ``theta' = theta + psi``, ``psi' = -psi`` (same for rates), which the core's
permutation-only :func:`bipedlab.mechanics.relabel` cannot express; :func:`swap_legs` does it
here (a core gap).
"""
from __future__ import annotations


import jax
import jax.numpy as jnp

from bipedlab.mechanics import (Body, Point, build_model, kinetic_energy, point_position,
                                point_velocity, potential_energy)
from bipedlab.mechanics import stance as stance_lib
from bipedlab.pytree import pytree, static_field

@pytree
class CompassGaitParams:
    """Compass-gait parameters. a: foot to leg COM (m); b: leg COM to hip (m); m: leg mass
    (kg); m_hip: hip mass (kg); gravity (m/s^2); slope: ground slope, descending in +x (rad).
    The geometry and masses are static (they build the model); ``slope`` is an array leaf, so a
    gait can be differentiated with respect to it. ``arm_distance``: the guard is armed only
    once the swing foot is this far (m, along the slope) ahead of the stance foot."""

    slope: jax.Array = 3.0 * jnp.pi / 180.0
    a: float = static_field(0.5)
    b: float = static_field(0.5)
    m: float = static_field(5.0)
    m_hip: float = static_field(10.0)
    gravity: float = static_field(9.81)
    arm_distance: float = static_field(0.05)

    @property
    def length(self) -> float:
        """Leg length l = a + b, m."""
        return self.a + self.b


def params(slope_deg: float = 3.0, **kw) -> CompassGaitParams:
    """Goswami's robot (a = b = 0.5 m, m = 5 kg, m_hip = 10 kg) on a slope given in degrees."""
    return CompassGaitParams(slope=jnp.asarray(slope_deg * jnp.pi / 180.0, dtype=jnp.float64), **kw)


def model(p: CompassGaitParams):
    """The compass gait as a floating-base planar :class:`~bipedlab.mechanics.Model`."""
    l, mt = p.length, p.m + p.m_hip
    c = p.m * p.b / mt  # combined COM of leg 1 + hip mass, below the hip, m
    inertia = p.m * p.m_hip * p.b**2 / mt  # the two point masses about that COM, kg m^2
    bodies = [
        Body("leg_1", None, mt, (0.0, -c), inertia),
        Body("leg_2", "leg_1", p.m, (0.0, -p.b), 0.0),
    ]
    points = [
        Point("hip", "leg_1", (0.0, 0.0)),
        Point("foot_1", "leg_1", (0.0, -l)),
        Point("foot_2", "leg_2", (0.0, -l)),
    ]
    return build_model(bodies, points, actuated=(), gravity=p.gravity,
                       base_names=("x_hip", "y_hip", "leg_1"))


#: Stance relabelling handed to the core's Stance: the identity (the swap is :func:`swap_legs`).
IDENTITY = (0, 1, 2, 3)


def stance(p: CompassGaitParams) -> stance_lib.Stance:
    """Single support on foot_1, swing foot foot_2 (the core's stance model)."""
    return stance_lib.stance_from_names(model(p), "foot_1", "foot_2", IDENTITY)


def swap_legs(z):
    """Relabel a stance state so that the swing leg becomes the stance leg (an involution)."""
    th, psi, thd, psid = z[0], z[1], z[2], z[3]
    return jnp.stack([th + psi, -psi, thd + psid, -psid])


def absolute_angles(z):
    """(stance-leg angle, swing-leg angle, their rates), rad and rad/s, from the vertical."""
    return jnp.stack([z[0], z[0] + z[1], z[2], z[2] + z[3]])


def from_absolute(x):
    """Inverse of :func:`absolute_angles`."""
    return jnp.stack([x[0], x[1] - x[0], x[2], x[3] - x[2]])


def _normal(p: CompassGaitParams):
    """Unit normal of the slope (pointing up) and unit tangent (pointing downhill, +x)."""
    c, s = jnp.cos(p.slope), jnp.sin(p.slope)
    return jnp.stack([s, c]), jnp.stack([c, -s])


def flow(p: CompassGaitParams, z):
    """zdot of the passive stance dynamics (no input), pinned at foot_1."""
    return stance_lib.stance_flow(stance(p), z, jnp.zeros(0))


def guard(p: CompassGaitParams, z):
    """Height of the swing foot above the slope through the stance foot, m."""
    n, _ = _normal(p)
    return stance_lib.swing_position(stance(p), z) @ n


def armed(p: CompassGaitParams, z):
    """True once the swing foot is ``arm_distance`` ahead of the stance foot along the slope
    and moving towards the slope (foot scuffing at mid-stance is ignored)."""
    st = stance(p)
    q, qd = stance_lib.embed(st, z)
    n, t = _normal(p)
    r = point_position(st.model, q, st.swing)
    v = point_velocity(st.model, q, qd, st.swing)
    return (r @ t > p.arm_distance) & (v @ n < 0.0)


def fell(p: CompassGaitParams, z):
    """The hip has dropped below half a leg above the slope (the walker is down)."""
    st = stance(p)
    q, _ = stance_lib.embed(st, z)
    n, _ = _normal(p)
    return point_position(st.model, q, "hip") @ n < 0.5 * p.length


def reset(p: CompassGaitParams, z_minus):
    """Plastic impact of the swing foot, then the leg swap: (z_plus, impulse (2,) N s, step
    vector from the old to the new stance foot (2,) m, velocity of the lifting foot (2,) m/s)."""
    zc, impulse, step, lift = stance_lib.impact(stance(p), z_minus)
    return swap_legs(zc), impulse, step, lift


def energy(p: CompassGaitParams, z):
    """(kinetic, potential) energy, J; potential from the stance foot's height."""
    st = stance(p)
    q, qd = stance_lib.embed(st, z)
    return kinetic_energy(st.model, q, qd), potential_energy(st.model, q)


def points(p: CompassGaitParams, z):
    """World positions (m) of stance foot, hip and swing foot, stance foot at the origin, (3, 2)."""
    st = stance(p)
    q, _ = stance_lib.embed(st, z)
    return jnp.stack([point_position(st.model, q, k) for k in ("foot_1", "hip", "foot_2")])
