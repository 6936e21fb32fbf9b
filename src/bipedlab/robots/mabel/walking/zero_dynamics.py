"""MABEL's compliant hybrid zero dynamics (compliant-HZD paper, Section III-B/C).

On the zero-dynamics manifold the four controlled variables follow their constraints, so the
stance configuration is fixed by (theta_s, q_Bsp_st) (:func:`~bipedlab.robots.mabel.walking.constraints.
stance_coordinates`): the zero dynamics is two degrees of freedom, four states, and the
spring is one of them (the paper's eq. 35-36 in other coordinates). With
``q_s = Phi(theta, b)``, ``qdd_s = Phi_theta thetadd + e_b bdd + Phi_thetatheta thetad^2``,
and the stance dynamics ``D_s qdd_s + H_s = B_s u`` give six linear equations in
(thetadd, bdd, u): the zero dynamics and the torque u* of eq. 32 in one solve.

Integration is in theta (RK4, fixed nodes per sub-phase), with time and the cost integrands
carried along: ``w = (b, thetadot, bdot, t, int |u|^2 dt, int positive motor work,
negative work at the stance leg shape by its motor, and by its spring)``. A sub-phase ending
at a state-dependent event (the 5 deg spring trigger, touchdown) is closed by one more RK4
step whose length is found by Newton's method (the core's hybrid stage
:func:`bipedlab.sim.hybrid.step_to_guard`, with :func:`rk4`), so the map stays smooth for
forward-mode derivatives.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp

from bipedlab.robots.mabel.walking import constraints as vcm
from bipedlab.robots.mabel import tables as tb
from bipedlab.robots.mabel.walking import stance as wk
from bipedlab.sim.integrators import rk4_t_scan

GEAR_LA = tb.GEAR_LA
#: theta-dot below which the theta-domain integrand is clamped (rad/s); gaits keep thetadot > 0.1
THETA_DOT_FLOOR = 0.05


def zd_accelerations(m, vc, phase, th, b, thd, bd):
    """(thetadd, bdd, u*, q_s, qd_s) on the zero-dynamics manifold."""
    phi, phi_t, phi_tt = vcm.stance_coordinates(vc, phase, th, b)
    eb = jnp.zeros(6).at[2].set(1.0)
    qds = phi_t * thd + eb * bd
    D, H, B = wk.stance_terms(m, phi, qds)
    A = jnp.concatenate([(D @ phi_t)[:, None], D[:, 2:3], -B], 1)
    sol = jnp.linalg.solve(A, -H - D @ phi_tt * thd**2)
    return sol[0], sol[1], sol[2:], phi, qds


def motor_power(u, qds):
    """Mechanical power of each motor (W), u in (mLA_st, mLS_st, mLA_sw, mLS_sw) order."""
    rates = jnp.stack([GEAR_LA * qds[0], qds[1], GEAR_LA * qds[3], qds[4]])
    return u * rates


def _integrand(m, vc, phase, th, w):
    b, thd, bd = w[0], w[1], w[2]
    thdd, bdd, u, qs, qds = zd_accelerations(m, vc, phase, th, b, thd, bd)
    p = motor_power(u, qds)
    p_spring = wk.spring_torque(m, b, bd, 0) * bd
    inv = 1.0 / jnp.maximum(thd, THETA_DOT_FLOOR)  # keeps trial points with a stalling step finite
    dw = jnp.stack([bd, thdd, bdd, 1.0, u @ u, jnp.sum(jnp.maximum(p, 0.0)),
                    jnp.maximum(-p[1], 0.0), jnp.maximum(-p_spring, 0.0)]) * inv
    return dw, (u, qs, qds)


def rk4(f, th, w, h):
    """One RK4 step in theta of dw/dtheta = f(theta, w)[0] (:func:`bipedlab.sim.integrators.rk4_t_scan`:
    the four stages share one traced f, which keeps compile times short). Returns
    (w(th + h), f's sample at th)."""
    return rk4_t_scan(f, th, w, h)


def integrate_nodes(f, w0, thetas, steps, phases):
    """RK4 in theta over the given steps (start theta, length, sub-phase each) of
    dw/dtheta = f(phase, theta, w)[0]; returns (final w, (theta, w, sample) at step starts)."""

    def body(w, node):
        th, h, ph = node
        wn, sample = rk4(lambda t, v: f(ph, t, v), th, w, h)
        return wn, (th, w, sample)

    return jax.lax.scan(body, w0, (thetas, steps, phases))


def integrate(f, phase, w0, th0, th1, n: int):
    """RK4 in theta over [th0, th1] with n equal steps in one sub-phase."""
    h = (th1 - th0) / n
    k = jnp.arange(n)
    return integrate_nodes(f, w0, th0 + k * h, jnp.full(n, h), jnp.full(n, phase))


def zero_dynamics(m, vc):
    """The integrand f(phase, theta, w) of the zero dynamics with vc's constraints; its sample
    is (u*, q_s, qd_s)."""
    return lambda phase, th, w: _integrand(m, vc, phase, th, w)


def state(vc, phase, th, w):
    """Stance state z = (q_s, qd_s) at a zero-dynamics point."""
    phi, phi_t, _ = vcm.stance_coordinates(vc, phase, th, w[0])
    qds = phi_t * w[1] + jnp.zeros(6).at[2].set(w[2])
    return jnp.concatenate([phi, qds])


def swing_height(m, vc, phase, th, w):
    return wk.swing_toe(m, state(vc, phase, th, w))[1]


def spring_guard(th, w):
    return w[0] - vcm.SPRING_TRIGGER


def robot_mass(m=None):
    """Mass of the robot without the boom (kg), the M of c_mt (eq. 40): the published links'
    (a float), or model ``m``'s (its links' masses summed, traced)."""
    if m is not None:
        return jnp.sum(m.body.tree.mass)
    legs = sum(tb.LINKS[k][0] for k in ("csp", "csh", "thigh", "shin"))
    return float(tb.LINKS["torso"][0] + 2 * legs)
