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

from typing import NamedTuple

import jax
import jax.numpy as jnp

from bipedlab.contact import terrain as tr

G = 9.81
NQ = 7
IX, IY, ITH, IG1, IG2, IL1, IL2 = range(7)


class AtriasParams(NamedTuple):
    m: float = 59.0          # trunk mass (kg)
    I_t: float = 1.37        # trunk inertia about its COM (kg m^2)
    d: float = 0.1           # COM above the hip (m)
    I_m: float = 1.0         # hip inertia per leg (kg m^2)
    m_f: float = 0.2         # foot point mass per leg (kg)
    tau_max: float = 250.0   # hip torque limit (N m)
    g: float = G

    @property
    def total_mass(self) -> float:
        return self.m + 2 * self.m_f


class GroundParams(NamedTuple):
    k_y: float       # vertical stiffness (N/m)
    k_x: float       # horizontal stiction stiffness (N/m)
    v_max: float = 0.03
    mu_slide: float = 0.8
    mu_stick: float = 0.9
    v_stick: float = 0.01


def ground_params(p: AtriasParams) -> GroundParams:
    w = p.total_mass * p.g
    return GroundParams(k_y=w / 0.01, k_x=w / 0.1)


class SimState(NamedTuple):
    """q, qd (7,); anchor (2,): stiction anchor x of each foot (m); stick (2,): 1 = stiction."""

    q: jax.Array
    qd: jax.Array
    anchor: jax.Array
    stick: jax.Array


def hip(p, q):
    return jnp.stack([q[IX] - p.d * jnp.sin(q[ITH]), q[IY] - p.d * jnp.cos(q[ITH])])


def foot(p, q, i):
    g, l = q[IG1 + i], q[IL1 + i]
    return hip(p, q) + l * jnp.stack([jnp.sin(g), jnp.cos(g)])


def foot_jac(p, q, i):
    """2x7 Jacobian of foot i (the paper's eq. 4 with the leg coordinates of leg i)."""
    th, g, l = q[ITH], q[IG1 + i], q[IL1 + i]
    J = jnp.zeros((2, NQ))
    J = J.at[0, IX].set(1.0).at[1, IY].set(1.0)
    J = J.at[0, ITH].set(-p.d * jnp.cos(th)).at[1, ITH].set(p.d * jnp.sin(th))
    J = J.at[0, IG1 + i].set(l * jnp.cos(g)).at[1, IG1 + i].set(-l * jnp.sin(g))
    J = J.at[0, IL1 + i].set(jnp.sin(g)).at[1, IL1 + i].set(jnp.cos(g))
    return J


def foot_bias(p, q, qd, i):
    """Jdot qd of foot i (foot acceleration at zero generalised acceleration)."""
    th, g, l = q[ITH], q[IG1 + i], q[IL1 + i]
    thd, gd, ld = qd[ITH], qd[IG1 + i], qd[IL1 + i]
    ax = p.d * jnp.sin(th) * thd ** 2 + 2 * ld * jnp.cos(g) * gd - l * jnp.sin(g) * gd ** 2
    ay = p.d * jnp.cos(th) * thd ** 2 - 2 * ld * jnp.sin(g) * gd - l * jnp.cos(g) * gd ** 2
    return jnp.stack([ax, ay])


def mass_matrix(p, q):
    M = jnp.diag(jnp.array([p.m, p.m, p.I_t, p.I_m, p.I_m, 0.0, 0.0]))
    for i in range(2):
        J = foot_jac(p, q, i)
        M = M + p.m_f * J.T @ J
    return M


def input_matrix():
    """S (7x4) mapping u = (tau1, tau2, F1, F2) to generalised forces."""
    S = jnp.zeros((NQ, 4))
    S = S.at[IG1, 0].set(1.0).at[ITH, 0].set(-1.0).at[IG2, 1].set(1.0).at[ITH, 1].set(-1.0)
    return S.at[IL1, 2].set(1.0).at[IL2, 3].set(1.0)


def free_forces(p, q, qd, u):
    """Generalised forces other than the ground's: inputs, gravity, foot inertial bias."""
    f = input_matrix() @ u
    f = f.at[IY].add(-p.m * p.g)
    for i in range(2):
        J = foot_jac(p, q, i)
        f = f - p.m_f * J.T @ (foot_bias(p, q, qd, i) + jnp.array([0.0, p.g]))
    return f


def energy(p, q, qd):
    """Kinetic + gravitational energy (J) of the full model."""
    T = 0.5 * qd @ mass_matrix(p, q) @ qd
    V = p.m * p.g * q[IY] + sum(p.m_f * p.g * foot(p, q, i)[1] for i in range(2))
    return T + V


def angular_momentum(p, q, qd):
    """H = I_t th' + I_m (g1' + g2') (the paper's H, feet massless), clockwise positive."""
    return p.I_t * qd[ITH] + p.I_m * (qd[IG1] + qd[IG2])


def spd_solve(A, b):
    """Solve A x = b for a small symmetric positive definite A by an unrolled Cholesky
    factorisation (elementwise ops only: much faster than a LAPACK call per matrix when
    batched on CPU)."""
    n = A.shape[0]
    L = [[None] * n for _ in range(n)]
    for j in range(n):
        s = A[j, j] - sum(L[j][k] * L[j][k] for k in range(j))
        L[j][j] = jnp.sqrt(s)
        for i in range(j + 1, n):
            L[i][j] = (A[i, j] - sum(L[i][k] * L[j][k] for k in range(j))) / L[j][j]
    y = []
    for i in range(n):
        y.append((b[i] - sum(L[i][k] * y[k] for k in range(i))) / L[i][i])
    x = [None] * n
    for i in reversed(range(n)):
        x[i] = (y[i] - sum(L[k][i] * x[k] for k in range(i + 1, n))) / L[i][i]
    return jnp.stack(x)


def clip_input(p, u):
    return u.at[:2].set(jnp.clip(u[:2], -p.tau_max, p.tau_max))


def _contact_terms(p, gp, terr, s: SimState, i):
    """Explicit force F0 (2,), damping C (2,) so that F = F0 - C * v_foot, and contact flag."""
    pf = foot(p, s.q, i)
    vf = foot_jac(p, s.q, i) @ s.qd
    pen = tr.ground(terr, pf[0]) - pf[1]
    fy_expl = gp.k_y * pen * (1.0 - vf[1] / gp.v_max)
    on = (pen > 0) & (fy_expl > 0)
    fy0 = jnp.where(on, gp.k_y * pen, 0.0)
    cy = jnp.where(on, gp.k_y * pen / gp.v_max, 0.0)
    dx = pf[0] - s.anchor[i]
    stick = s.stick[i] > 0.5
    fx0_st = -gp.k_x * dx
    cx_st = gp.k_x * jnp.abs(dx) / gp.v_max
    fx_sl = -gp.mu_slide * jnp.maximum(fy_expl, 0.0) * jnp.sign(vf[0])
    fx0 = jnp.where(on, jnp.where(stick, fx0_st, fx_sl), 0.0)
    cx = jnp.where(on & stick, cx_st, 0.0)
    return jnp.stack([fx0, fy0]), jnp.stack([cx, cy]), on


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
    qd = spd_solve(A, M @ s.qd + h * f)
    q = s.q + h * qd
    grf = jnp.stack([F0s[i] - Cs[i] * (Js[i] @ qd) for i in range(2)])
    grf = grf.at[:, 1].set(jnp.maximum(grf[:, 1], 0.0))
    # stick / slip switching and anchors
    anchors, sticks = [], []
    for i in range(2):
        pf = foot(p, q, i)
        vx = (foot_jac(p, q, i) @ qd)[0]
        on = ons[i]
        stick = s.stick[i] > 0.5
        slip_now = stick & on & (jnp.abs(grf[i, 0]) > gp.mu_stick * grf[i, 1])
        stick_now = ~stick & (jnp.abs(vx) < gp.v_stick)
        new_stick = jnp.where(on, jnp.where(stick, ~slip_now, stick_now), True)
        anchor = jnp.where(on & stick & ~slip_now, s.anchor[i], pf[0])
        anchors.append(anchor), sticks.append(new_stick.astype(q.dtype))
    return SimState(q, qd, jnp.stack(anchors), jnp.stack(sticks)), grf


def initial_state(p: AtriasParams, x, y, vx, theta, gamma1, gamma2, l1, l2) -> SimState:
    q = jnp.array([x, y, theta, gamma1, gamma2, l1, l2], dtype=float)
    qd = jnp.zeros(NQ).at[IX].set(vx)
    anchors = jnp.stack([foot(p, q, 0)[0], foot(p, q, 1)[0]])
    return SimState(q, qd, anchors, jnp.ones(2))
