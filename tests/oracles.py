"""Independent reference implementations used as test oracles.

Nothing here imports bipedlab's mechanics: the kinematics are written out by hand from the
published geometry, and the dynamics come from the Lagrangian by automatic differentiation:

    M(q)    = sum_b m_b Jc_b^T Jc_b + I_b Jw_b^T Jw_b      (Jc, Jw: jacfwd of COM and angle)
    bias    = Mdot(q, qd) qd - dT/dq + dV/dq                  (jvp for Mdot, grad for T, V)
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

G = 9.81

# ----- five-link biped: q = [x_hip, y_hip, torso, hip_1, knee_1, hip_2, knee_2] ----------
TORSO_M, TORSO_I, TORSO_C = 12.0, 1.33, 0.24
THIGH_M, THIGH_I, THIGH_L, THIGH_C = 6.8, 0.47, 0.4, 0.11
SHIN_M, SHIN_I, SHIN_L, SHIN_C = 3.2, 0.2, 0.4, 0.24
FIVE_MASSES = np.array([TORSO_M, THIGH_M, SHIN_M, THIGH_M, SHIN_M])
FIVE_INERTIAS = np.array([TORSO_I, THIGH_I, SHIN_I, THIGH_I, SHIN_I])
FIVE_TOTAL_MASS = float(FIVE_MASSES.sum())


def _down(a):
    """Unit vector along a link hanging down at absolute angle a (CCW positive)."""
    return jnp.stack([jnp.sin(a), -jnp.cos(a)])


def five_link_geometry(q):
    """(COMs (5, 2), absolute angles (5,), feet (2, 2)); bodies: torso, thigh1, shin1, thigh2, shin2."""
    hip = q[:2]
    th = q[2]
    coms = [hip + TORSO_C * jnp.stack([-jnp.sin(th), jnp.cos(th)])]
    angles = [th]
    feet = []
    for hj, kj in ((3, 4), (5, 6)):
        a = th + q[hj]
        b = a + q[kj]
        knee = hip + THIGH_L * _down(a)
        coms += [hip + THIGH_C * _down(a), knee + SHIN_C * _down(b)]
        angles += [a, b]
        feet.append(knee + SHIN_L * _down(b))
    return jnp.stack(coms), jnp.stack(angles), jnp.stack(feet)


def five_link_foot(q, leg):
    return five_link_geometry(q)[2][leg]


def five_link_coms(q):
    return five_link_geometry(q)[0]


def five_link_angles(q):
    return five_link_geometry(q)[1]


class Lagrangian:
    """Mass matrix, bias, energies and momenta of a planar system from its body COMs and
    absolute angles as functions of q (arrays (nb, 2) and (nb,))."""

    def __init__(self, coms, angles, masses, inertias, gravity=G, rotors=()):
        self.coms = coms
        self.angles = angles
        self.masses = jnp.asarray(masses, dtype=jnp.float64)
        self.inertias = jnp.asarray(inertias, dtype=jnp.float64)
        self.g = gravity
        self.rotors = [(float(i), jnp.asarray(r, dtype=jnp.float64)) for i, r in rotors]

    def mass_matrix(self, q):
        Jc = jax.jacfwd(self.coms)(q)  # (nb, 2, nq)
        Jw = jax.jacfwd(self.angles)(q)  # (nb, nq)
        M = jnp.einsum("b,bin,bim->nm", self.masses, Jc, Jc) + jnp.einsum("b,bn,bm->nm", self.inertias, Jw, Jw)
        for inertia, r in self.rotors:
            M = M + inertia * jnp.outer(r, r)
        return M

    def kinetic(self, q, qd):
        return 0.5 * qd @ self.mass_matrix(q) @ qd

    def potential(self, q):
        return self.g * jnp.sum(self.masses * self.coms(q)[:, 1])

    def bias(self, q, qd):
        _, Mdot = jax.jvp(self.mass_matrix, (q,), (qd,))
        dTdq = jax.grad(self.kinetic, argnums=0)(q, qd)
        dVdq = jax.grad(self.potential)(q)
        return Mdot @ qd - dTdq + dVdq

    def accel(self, q, qd, tau):
        return jnp.linalg.solve(self.mass_matrix(q), tau - self.bias(q, qd))

    def com(self, q):
        return self.masses @ self.coms(q) / jnp.sum(self.masses)

    def angular_momentum(self, q, qd, point):
        """About a fixed world point: sum m (c - P) x v + I w (+ rotors)."""
        c = self.coms(q)
        v = jax.jacfwd(self.coms)(q) @ qd
        w = jax.jacfwd(self.angles)(q) @ qd
        r = c - point
        L = jnp.sum(self.masses * (r[:, 0] * v[:, 1] - r[:, 1] * v[:, 0])) + jnp.sum(self.inertias * w)
        for inertia, ratios in self.rotors:
            L = L + inertia * ratios @ qd
        return L


FIVE_LINK = Lagrangian(five_link_coms, five_link_angles, FIVE_MASSES, FIVE_INERTIAS)


# ----- a branched tree with a prismatic joint (see trees.py)   -------
def _rot(a, v):
    c, s = jnp.cos(a), jnp.sin(a)
    return jnp.stack([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def branched_geometry(q, spec):
    """spec: dict name -> (mass, com, inertia, offset, axis). Coordinates:
    q = [x, y, theta_base, arm (revolute, on base), slide (prismatic, on arm),
         leg (revolute, on base), tip (revolute, on slide)]."""
    base, arm, slide, leg, tip = (spec[k] for k in ("base", "arm", "slide", "leg", "tip"))
    a_base = q[2]
    a_arm = a_base + q[3]
    a_slide = a_arm  # prismatic: no rotation
    a_leg = a_base + q[5]
    a_tip = a_slide + q[6]
    o_base = q[:2]
    o_arm = o_base + _rot(a_base, arm["offset"])
    ax = np.asarray(slide["axis"], float)
    ax = ax / np.linalg.norm(ax)
    o_slide = o_arm + _rot(a_arm, jnp.asarray(slide["offset"]) + q[4] * ax)
    o_leg = o_base + _rot(a_base, leg["offset"])
    o_tip = o_slide + _rot(a_slide, tip["offset"])
    origins = [o_base, o_arm, o_slide, o_leg, o_tip]
    angles = [a_base, a_arm, a_slide, a_leg, a_tip]
    coms = [o + _rot(a, jnp.asarray(b["com"])) for o, a, b in zip(origins, angles, (base, arm, slide, leg, tip))]
    return jnp.stack(coms), jnp.stack(angles), jnp.stack(origins)
