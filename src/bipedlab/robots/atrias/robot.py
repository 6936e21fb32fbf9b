"""The planar ATRIAS-like running robot of the running paper (Wu & Geyer, Fig. 3) and its
ground model (Geyer & Herr 2010).

Coordinates q = (x, y, theta, gamma1, gamma2, l1, l2): trunk COM position (m), trunk pitch
(rad, positive = leaning forward, i.e. clockwise with x forward and y up), the global angle of
each leg (rad, clockwise from straight up: pi is straight down, larger is further back) and
each leg length (m). The hip lies d below the COM along the trunk axis,
hip = (x - d sin theta, y - d cos theta); foot i = hip + l_i (sin gamma_i, cos gamma_i). These
conventions reproduce the paper's Jacobian (eq. 4) and virtual leg (eq. 7).

Bodies: the trunk (mass m, inertia I_t), a rotary hip inertia I_m on each leg angle (the leg
and the geared motors, turning with the absolute leg angle, so H = I_t th' + I_m g1' + I_m g2'
about the COM when the feet are massless), and a foot point mass m_f on each leg. Inputs:
hip torques tau_i (on gamma_i, reacting on theta), |tau_i| <= tau_max, and leg forces F_i
(on l_i). Foot forces enter through the foot Jacobians (the full model, eq. 2).

Values (reference-values.md, "The planar running robot (ATRIAS-like)"): about 60 kg
concentrated in the trunk, legs about 1 m; torso inertia 1.37 kg m^2 (ATRIAS parameter
sheet, 2011). Chosen here, because the paper gives no table: m = 59 kg (torso 44 kg plus the
motors and upper leg links), m_f = 0.2 kg per foot (about the lightest lower link of the
four-bar, 0.191 kg; the paper asks m_f / m << 1 and a heavier foot breaks the controller's
massless-leg momentum balance noticeably), d = 0.1 m, I_m = 1.0 kg m^2 (leg links about
0.3 kg m^2 plus part of the rotor inertia 2.86e-3 * 50^2 = 7.2 kg m^2, most of which the
series springs decouple), tau_max = 250 N m (a 50:1 harmonic drive behind a ~5 N m motor).

Ground (reference-values.md, "Ground model of the running paper"): vertical
GRF_y = k_gy pen (1 - y_f'/v_max), clipped >= 0, k_gy = total weight / 0.01 m,
v_max = 0.03 m/s; horizontal stiction spring-damper F_x = -k_gx dx (1 + sgn(dx) x_f'/v_max)
about the anchor point with k_gx = total weight / 0.1 m (the damping of the same form as the
vertical one, as in Geyer & Herr 2010), valid while |F_x| <= mu_stick GRF_y (0.9); otherwise
sliding friction -mu_slide GRF_y sgn(x_f') (0.8), back to stiction below 0.01 m/s.
"""
from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.contact import stick_slip as ss
from bipedlab.contact import terrain as tr  # noqa: F401  (the terrain type of the ground)
from bipedlab.mechanics import dynamics as dyn
from bipedlab.mechanics import kinematics as kin
from bipedlab.mechanics.tree import PRISMATIC, Body, Model, Point, build_model
from bipedlab.pytree import pytree

G = 9.81
NQ = 7
IX, IY, ITH, IG1, IG2, IL1, IL2 = range(7)


@pytree
class AtriasParams:
    m: float = 59.0          # trunk mass (kg)
    I_t: float = 1.37        # trunk inertia about its COM (kg m^2)
    d: float = 0.1           # COM above the hip (m)
    I_m: float = 1.0         # hip inertia per leg (kg m^2)
    m_f: float = 0.2         # foot point mass per leg (kg)
    tau_max: float = 250.0   # hip torque limit (N m)
    g: float = G
    # the ground (reference-values.md, after Geyer & Herr 2010): the total weight over each depth
    # gives the normal and the stiction stiffness (:func:`ground_params`)
    depth_y: float = 0.01    # normal stiffness k_gy = weight / depth_y (m)
    depth_x: float = 0.1     # stiction stiffness k_gx = weight / depth_x (m)
    v_max: float = 0.03      # damping velocity scale (m/s)
    mu_stick: float = 0.9    # stiction limit
    mu_slide: float = 0.8    # sliding friction

    @property
    def total_mass(self) -> float:
        return self.m + 2 * self.m_f


#: The ground's parameters (the core's stick/slip point contact).
GroundParams = ss.StickSlipGround


def ground_params(p: AtriasParams) -> GroundParams:
    w = p.total_mass * p.g
    return GroundParams(k_y=w / p.depth_y, k_x=w / p.depth_x, v_max=p.v_max, mu_slide=p.mu_slide, mu_stick=p.mu_stick)


@pytree
class SimState:
    """q, qd (7,); anchor (2,): stiction anchor x of each foot (m); stick (2,): 1 = stiction."""

    q: jax.Array
    qd: jax.Array
    anchor: jax.Array
    stick: jax.Array


# ---------------------------------------------------------------- the tree model
# bipedlab.mechanics trees use counter-clockwise angles and joint angles relative to the
# parent; the robot's coordinates use clockwise absolute angles. The tree's coordinates are
# z = T q: (x, y, phi = -theta, r_i = theta - gamma_i (leg relative to trunk), l_i). Bodies:
# the trunk (m, I_t) at its COM, a massless leg link per hip carrying the hip inertia I_m
# (turning with the absolute leg angle), and the foot point mass m_f sliding along the leg.
_T = np.array([[1, 0, 0, 0, 0, 0, 0],
               [0, 1, 0, 0, 0, 0, 0],
               [0, 0, -1, 0, 0, 0, 0],
               [0, 0, 1, -1, 0, 0, 0],
               [0, 0, 1, 0, -1, 0, 0],
               [0, 0, 0, 0, 0, 1, 0],
               [0, 0, 0, 0, 0, 0, 1]], dtype=float)
FOOT_POINTS = ("foot_1", "foot_2")


@functools.lru_cache(maxsize=16)
def _tree(m, I_t, d, I_m, m_f, g) -> Model:
    bodies = [Body("trunk", None, m, (0.0, 0.0), I_t),
              Body("leg_1", "trunk", 0.0, (0.0, 0.0), I_m, offset=(0.0, -d)),
              Body("leg_2", "trunk", 0.0, (0.0, 0.0), I_m, offset=(0.0, -d)),
              Body("l_1", "leg_1", m_f, (0.0, 0.0), 0.0, joint=PRISMATIC, axis=(0.0, 1.0)),
              Body("l_2", "leg_2", m_f, (0.0, 0.0), 0.0, joint=PRISMATIC, axis=(0.0, 1.0))]
    points = [Point("foot_1", "l_1", (0.0, 0.0)), Point("foot_2", "l_2", (0.0, 0.0)),
              Point("hip", "trunk", (0.0, -d))]
    return build_model(bodies, points, actuated=(), gravity=g, base_names=("x", "y", "phi"))


def tree_model(p) -> Model:
    """The robot as a :class:`bipedlab.mechanics.Model`, in the tree coordinates z = T q."""
    return _tree(float(p.m), float(p.I_t), float(p.d), float(p.I_m), float(p.m_f), float(p.g))


def to_tree(q):
    """Tree coordinates z = T q (also for velocities: T is constant)."""
    return jnp.asarray(_T) @ q


def hip(p, q):
    return kin.point_position(tree_model(p), to_tree(q), "hip")


def foot(p, q, i):
    return kin.point_position(tree_model(p), to_tree(q), FOOT_POINTS[i])


def foot_jac(p, q, i):
    """2x7 Jacobian of foot i (the paper's eq. 4 with the leg coordinates of leg i)."""
    return kin.point_jacobian(tree_model(p), to_tree(q), FOOT_POINTS[i]) @ jnp.asarray(_T)


def foot_bias(p, q, qd, i):
    """Jdot qd of foot i (foot acceleration at zero generalised acceleration)."""
    return kin.point_jdot_qd(tree_model(p), to_tree(q), to_tree(qd), FOOT_POINTS[i])


def mass_matrix(p, q):
    T = jnp.asarray(_T)
    return T.T @ dyn.mass_matrix(tree_model(p), to_tree(q)) @ T


def input_matrix():
    """S (7x4) mapping u = (tau1, tau2, F1, F2) to generalised forces."""
    S = jnp.zeros((NQ, 4))
    S = S.at[IG1, 0].set(1.0).at[ITH, 0].set(-1.0).at[IG2, 1].set(1.0).at[ITH, 1].set(-1.0)
    return S.at[IL1, 2].set(1.0).at[IL2, 3].set(1.0)


def bias(p, q, qd):
    """Bias h(q, qd) (Coriolis, centrifugal, gravity) in the robot's coordinates: T^T h_tree."""
    return jnp.asarray(_T).T @ dyn.bias(tree_model(p), to_tree(q), to_tree(qd))


def free_forces(p, q, qd, u):
    """Generalised forces other than the ground's: inputs minus the bias (gravity, foot
    inertial terms)."""
    return input_matrix() @ u - bias(p, q, qd)


def energy(p, q, qd):
    """Kinetic + gravitational energy (J) of the full model."""
    T = 0.5 * qd @ mass_matrix(p, q) @ qd
    V = p.m * p.g * q[IY] + sum(p.m_f * p.g * foot(p, q, i)[1] for i in range(2))
    return T + V


def angular_momentum(p, q, qd):
    """H = I_t th' + I_m (g1' + g2') (the paper's H, feet massless), clockwise positive."""
    return p.I_t * qd[ITH] + p.I_m * (qd[IG1] + qd[IG2])


def solve(A, b):
    """Solve A x = b for the symmetric positive definite 7x7 A with the core's unrolled
    L^T D L factorisation (elementwise ops: much faster than a LAPACK call per matrix when
    batched on CPU)."""
    n = A.shape[0]
    H = [[A[i, j] for j in range(i + 1)] for i in range(n)]
    return jnp.stack(dyn.ltdl_solve(H, [b[i] for i in range(n)]))


def clip_input(p, u):
    return u.at[:2].set(jnp.clip(u[:2], -p.tau_max, p.tau_max))


def _contact_terms(p, gp, terr, s: SimState, i):
    """Explicit force F0 (2,), damping C (2,) so that F = F0 - C * v_foot, and contact flag."""
    pf = foot(p, s.q, i)
    vf = foot_jac(p, s.q, i) @ s.qd
    return ss.contact_terms(gp, terr, pf, vf, s.anchor[i], s.stick[i] > 0.5)


def step(p: AtriasParams, gp: GroundParams, terr, s: SimState, u, h: float):
    """One semi-implicit Euler step of length h with the ground dampers implicit (stable for
    the stiff ground at millisecond-scale steps). Returns (new state, GRFs (2, 2) per foot)."""
    u = clip_input(p, u)
    M = mass_matrix(p, s.q)
    f = free_forces(p, s.q, s.qd, u)
    A = M
    Js, F0s, Cs, ons = [], [], [], []
    for i in range(2):
        J = foot_jac(p, s.q, i)
        F0, C, on = _contact_terms(p, gp, terr, s, i)
        A = A + h * J.T @ (C[:, None] * J)
        f = f + J.T @ F0
        Js.append(J), F0s.append(F0), Cs.append(C), ons.append(on)
    qd = solve(A, M @ s.qd + h * f)
    q = s.q + h * qd
    grf = jnp.stack([F0s[i] - Cs[i] * (Js[i] @ qd) for i in range(2)])
    grf = grf.at[:, 1].set(jnp.maximum(grf[:, 1], 0.0))
    # stick / slip switching and anchors
    anchors, sticks = [], []
    for i in range(2):
        pf = foot(p, q, i)
        vx = (foot_jac(p, q, i) @ qd)[0]
        new_stick, anchor = ss.transition(gp, ons[i], s.stick[i] > 0.5, s.anchor[i], grf[i], pf[0], vx)
        anchors.append(anchor), sticks.append(new_stick.astype(q.dtype))
    return SimState(q, qd, jnp.stack(anchors), jnp.stack(sticks)), grf


def initial_state(p: AtriasParams, x, y, vx, theta, gamma1, gamma2, l1, l2) -> SimState:
    q = jnp.array([x, y, theta, gamma1, gamma2, l1, l2], dtype=float)
    qd = jnp.zeros(NQ).at[IX].set(vx)
    anchors = jnp.stack([foot(p, q, 0)[0], foot(p, q, 1)[0]])
    return SimState(q, qd, anchors, jnp.ones(2))
