"""MABEL's walking model (compliant HZD paper, Section II-B): stance dynamics on the 9-DoF
rigid-cable model and the stance-to-stance transition map (eqs. 13-20).

Stance (Section II-B2): the stance toe is a pivot (no slip, no rebound) and the swing leg's
spring does not deflect, ``q_Bsp_sw = 0``. With the left leg in stance, the stance coordinates
are the paper's ``q_s = (q_LA_st, q_mLS_st, q_Bsp_st, q_LA_sw, q_mLS_sw, q_Tor)`` and
``q_e = Upsilon_s(q_s)`` puts the stance toe at the origin. The constrained dynamics

    D_e qdd_e + H_e = Gamma_e(u) + G^T lam,      G qdd_e + Gdot qd_e = 0,

with G the Jacobian of (stance toe position, swing spring angle), give the accelerations
and lam = (toe force Fx, Fy; torque holding the swing spring). Inputs are the motor torques
``u = (u_mLA_st, u_mLS_st, u_mLA_sw, u_mLS_sw)`` (N m at the motors); the drivetrain adds the
unilateral springs (eq. 30) and the motors' viscous friction. ``ideal=True`` (the default)
uses K_T = 1 and no amplifier bias, so u is the torque at the motor, as in gait design.

Transition (eqs. 14-20): when the swing toe reaches the ground, a rigid impact with an
impulse at the swing toe and an impulsive torque at the stance B_spring pulley (its hard
stop) gives the post-impact velocities subject to (16) zero velocity of the old stance
spring and (17) zero velocity of the new stance toe, with the impulse balance (18). The old
stance spring is then put at rest keeping its leg shape (T_mLS: the motor takes up the
deflection through eq. 1), and the legs are relabelled.
"""
from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.mechanics import coupled as cp
from bipedlab.robots.mabel import tables as tb
from bipedlab.robots.mabel import transmission as tr
from bipedlab.robots.mabel.dynamics import drivetrain_forces
from bipedlab.robots.mabel.model import COORDS_9, Mabel, rigid_model
from bipedlab.pytree import pytree

_E = {c: i for i, c in enumerate(COORDS_9)}
#: Stance coordinates with the left leg in stance, in the paper's order.
STANCE = ("la_L", "mls_L", "bsp_L", "la_R", "mls_R", "tor")
_S = np.array([_E[c] for c in STANCE])
#: Relabelling of q_e: swaps the legs (an involution).
SWAP = tuple(_E[c.replace("_L", "_X").replace("_R", "_L").replace("_X", "_R")] for c in COORDS_9)


@functools.lru_cache(maxsize=32)
def walking_model(ideal: bool = True, kernel: str = "auto", scale: tuple = ()) -> Mabel:
    """The 9-DoF rigid-cable model used for walking (ideal actuators by default). One object
    per process and arguments (the model is a frozen pytree): the walking loop is compiled once
    per (model, controller) (:func:`bipedlab.robots.mabel.walking.loop.closed_loop`), so every
    walk reuses its program. ``kernel``: the mechanics' form
    (:class:`bipedlab.mechanics.coupled.Coupled`); ``"scalar"`` for trials batched with vmap.
    ``scale``: pairs (name, factor) of published values built scaled
    (:data:`bipedlab.robots.mabel.model.SCALABLE`)."""
    m = rigid_model(scale=scale)
    if ideal:
        d = m.drive
        m = m.replace(drive=d.replace(kt=jnp.ones_like(d.kt), bias=jnp.zeros_like(d.bias)))
    if kernel != "auto":
        m = m.replace(body=m.body.replace(kernel=kernel))
    return m


def embed(m: Mabel, z):
    """(q_e, qd_e) of the stance state z = (q_s, qd_s): stance toe at the origin and at rest,
    swing spring at rest."""
    qs, qds = z[:6], z[6:]
    q0 = jnp.zeros(9).at[_S].set(qs)
    toe = cp.point_position(m.body, q0, "toe_L")
    q = q0.at[0].set(-toe[0]).at[1].set(-toe[1])
    J = cp.point_jacobian(m.body, q, "toe_L")
    qd0 = jnp.zeros(9).at[_S].set(qds)
    v = J @ qd0  # toe velocity with the hip still; the hip moves to cancel it
    qd = qd0.at[0].set(-v[0]).at[1].set(-v[1])
    return q, qd


def reduce(q, qd):
    """Stance state from q_e, qd_e (Pi_s)."""
    return jnp.concatenate([q[_S], qd[_S]])


def _constraint_jacobian(m: Mabel, q):
    J = cp.point_jacobian(m.body, q, "toe_L")
    return jnp.concatenate([J, jnp.zeros((1, 9)).at[0, _E["bsp_R"]].set(1.0)])


def spring_torque(m: Mabel, b, bd, leg: int):
    """Torque of the unilateral spring on B_spring in walking (eq. 30), N m: the spring and
    its damping while compressed; the hard stop's damper acts only while the pulley presses
    into the stop (b <= 0 and closing), so a spring released at rest on the stop, or leaving
    it, sees the spring law alone."""
    return tr.spring_elastic(m.drive.spring_k[leg], m.drive.kd1, b) + spring_damping(m, b, bd)


def spring_damping(m: Mabel, b, bd):
    """The dissipative part of :func:`spring_torque` (N m)."""
    d = m.drive
    at_stop = (b <= 0.0) & (bd < 0.0)
    return jnp.where(at_stop, tr.spring_damping_torque(d.spring_d, d.kvd1, d.kvd2, b, bd), -d.spring_d * bd)


def _generalized_forces(m: Mabel, q, qd, u, f_hip=None):
    """Generalised forces on q_e: motors (u = (mLA_L, mLS_L, mLA_R, mLS_R), i.e. stance then
    swing), motor friction, the springs, and an optional horizontal/vertical force on the hip
    (N), the push of the experiments."""
    Em = jnp.asarray(np.asarray(m.E))
    out = drivetrain_forces(m, Em @ q, Em @ qd, u, implicit_spring_damping=True)
    gen = jnp.stack(cp.pull_back(m.E, out))
    for c in ("bsp_L", "bsp_R"):  # drivetrain_forces gave the elastic part; add the walking damping
        i = _E[c]
        gen = gen.at[i].add(spring_damping(m, q[i], qd[i]))
    if f_hip is not None:
        gen = gen + cp.point_jacobian(m.body, q, "hip").T @ f_hip
    return gen


def without_stop(m: Mabel) -> Mabel:
    """The model with the spring's hard stop (stiffening and damping of eq. 30) left out: the
    model that gait design and the walking controllers use, the spring being meant to stay off
    its stop; the plant keeps the stop."""
    z = jnp.zeros(())
    return m.replace(drive=m.drive.replace(kd1=z, kvd1=z, kvd2=z))


def without_losses(m: Mabel) -> Mabel:
    """The model with the drivetrain's dissipation left out: no viscous motor friction (Table V
    of the identification paper) and no spring damping (Kd_B), the stance dynamics then
    conservative apart from the motors' work. With the hard stop also out
    (:func:`without_stop`) this is the HZD paper's design model (``optimize mabel
    --design-model paper``)."""
    d = m.drive
    return m.replace(drive=d.replace(friction=jnp.zeros_like(d.friction), spring_d=jnp.zeros_like(d.spring_d)))


def constrained(m: Mabel, q, qd, u, f_hip=None):
    """(qdd_e, lam) of the stance dynamics at (q_e, qd_e) under motor torques u."""
    D = cp.mass_matrix(m.body, q)
    H = cp.bias(m.body, q, qd)
    G = _constraint_jacobian(m, q)
    gdot = jax.jvp(lambda q: _constraint_jacobian(m, q) @ qd, (q,), (qd,))[1]
    K = jnp.block([[D, -G.T], [G, jnp.zeros((3, 3))]])
    rhs = jnp.concatenate([_generalized_forces(m, q, qd, u, f_hip) - H, -gdot])
    sol = jnp.linalg.solve(K, rhs)
    return sol[:9], sol[9:]


def stance_flow(m: Mabel, z, u, f_hip=None):
    """z-dot of the stance dynamics (eq. 12) under motor torques u (4,)."""
    q, qd = embed(m, z)
    qdd, _ = constrained(m, q, qd, u, f_hip)
    return jnp.concatenate([z[6:], qdd[_S]])


def ground_reaction(m: Mabel, z, u, f_hip=None):
    """Force of the ground on the stance toe (Fx, Fy), N."""
    q, qd = embed(m, z)
    return constrained(m, q, qd, u, f_hip)[1][:2]


def _upsilon(m: Mabel, qs):
    return embed(m, jnp.concatenate([qs, jnp.zeros_like(qs)]))[0]


def stance_terms(m: Mabel, qs, qds, f_hip=None):
    """(D_s, H_s, B_s) of eqs. (11)-(12), ``D_s qdd_s + H_s = B_s u``, by reducing the 9-DoF
    equations through q_e = Upsilon_s(q_s): D_s = J^T D_e J, H_s = J^T (D_e Jdot qd_s + H_e -
    Gamma_e(0)), B_s = J^T dGamma_e/du, with J = dUpsilon_s/dq_s. The constraint forces drop
    out because J spans the motions that keep the toe pinned and the swing spring at rest."""
    ups = lambda s: _upsilon(m, s)  # noqa: E731
    q, J = ups(qs), jax.jacfwd(ups)(qs)
    qd = J @ qds
    jdqd = jax.jvp(lambda s: jax.jvp(ups, (s,), (qds,))[1], (qs,), (qds,))[1]
    D = cp.mass_matrix(m.body, q)
    gam = lambda u: _generalized_forces(m, q, qd, u, f_hip)  # noqa: E731
    u0 = jnp.zeros(4)
    B = jax.jacfwd(gam)(u0)
    H = D @ jdqd + cp.bias(m.body, q, qd) - gam(u0)
    return J.T @ D @ J, J.T @ H, J.T @ B


def swing_toe(m: Mabel, z):
    """Swing toe position (m); its height is the guard of S_s->s (eq. 13)."""
    q, _ = embed(m, z)
    return cp.point_position(m.body, q, "toe_R")


@pytree
class Transition:
    """Result of the stance-to-stance map: the new stance state, the toe impulse (N s), the
    hard-stop impulse on the old stance spring (N m s), the step vector (m) and the velocity
    of the lifting toe just after impact (m/s)."""

    z_plus: jax.Array
    toe_impulse: jax.Array
    spring_impulse: jax.Array
    step: jax.Array
    lift_velocity: jax.Array


def impact(m: Mabel, z_minus, eta=1.0) -> Transition:
    """Delta_s->s of eqs. (14)-(20) for the pre-impact stance state z_minus.

    eta: the impact scaling of Section VI-B, qd_e+ replaced by eta qd_e+ in (16)-(18): the
    constraints are homogeneous, so the post-impact velocity is the rigid one divided by eta."""
    q, qd = embed(m, z_minus)
    D = cp.mass_matrix(m.body, q)
    Jt = cp.point_jacobian(m.body, q, "toe_R")
    Js = jnp.zeros((1, 9)).at[0, _E["bsp_L"]].set(1.0)
    A = jnp.concatenate([Jt, Js])  # (17) new stance toe at rest, (16) old stance spring at rest
    K = jnp.block([[D, -A.T], [A, jnp.zeros((3, 3))]])
    sol = jnp.linalg.solve(K, jnp.concatenate([D @ qd, jnp.zeros(3)]))  # (18)
    qd_plus, imp = sol[:9] / eta, sol[9:]
    step = cp.point_position(m.body, q, "toe_R")
    lift = cp.point_jacobian(m.body, q, "toe_L") @ qd_plus
    # T_mLS: the old stance spring returns to its stop, the motor keeps q_LS (eq. 1)
    q_t = q.at[_E["mls_L"]].add((tb.GEAR_LS / tb.GEAR_BSP) * q[_E["bsp_L"]]).at[_E["bsp_L"]].set(0.0)
    swap = np.asarray(SWAP)
    z_plus = reduce(q_t[swap], qd_plus[swap])
    return Transition(z_plus, imp[:2], imp[2], step, lift)
