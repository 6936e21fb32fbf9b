"""MABEL's walking virtual constraints with sub-phases (compliant-HZD paper, Section III-A and
Appendix A).

Controlled variables (eq. 23), in the stance coordinates q_s = (q_LA_st, q_mLS_st, q_Bsp_st,
q_LA_sw, q_mLS_sw, q_Tor)::

    H0 q_s = (q_mLS_st, q_LA_sw, q_mLS_sw, q_Tor),      theta_s = pi - q_LA_st - q_Tor  (eq. 25)

Sub-phases ``MC, SC, SI, SD`` (motor compression, stance compression, stance injection,
stance decompression). Every piece is a Bézier polynomial of order 5 in its own normalised
phase (eq. 51-52), joined C¹:

- stance motor leg shape: ``mls_mc`` on [theta+, theta_mc] from the post-impact (q, qd) to
  ``(mls_sc, 0)``; the constant ``mls_sc`` in SC; ``mls_si`` on [theta_sc, theta_si] from
  ``(mls_sc, 0)`` to ``(mls_sd, 0)``; the constant ``mls_sd`` in SD;
- torso: one Bézier ``tor`` over the combined phase MC-SC-SI, [theta+, theta_si], ending at
  rest at ``tor[5]``, held there in SD;
- swing leg angle and motor leg shape: one Bézier each over the whole step [theta+, theta-].

Outside its phase interval no piece is extrapolated for long: beyond s = 1 + ``OVERRUN`` (or
below -``OVERRUN``) its normalised phase saturates smoothly (C²) within about
``OVERRUN_WIDTH`` more, so past theta- (a touchdown later than designed, e.g. under a forward
push) the swing leg holds its touchdown pose while the hip descends onto it, and a step that
starts behind theta+ holds the first values. Extrapolated quintics swung the leg forward and
up so the toe skimmed over the ground (measured: a 30 N push, the toe missed it by 2 mm and the
robot fell), and after a late touchdown the MC piece read hundreds of radians. Near the
interval nothing changes, so the designed gaits and their Poincaré maps are untouched.

Transitions (eq. 37): MC -> SC at theta_mc, SC -> SI when the stance spring decompresses
through 5 deg, SI -> SD at theta_si, SD -> MC at swing-toe touchdown. The guarded variant
(eq. 50) also fires SC -> SI at ``theta_sc + gamma`` and ignores the spring trigger before
``theta_sc - gamma``. The SI piece starts where SC actually ended (``theta_sc`` is the
event's theta), so the join stays C¹ whatever triggered it.

Hybrid-invariance corrections (eqs. 45-47): ``corr`` holds, per swing leg angle, swing motor
leg shape and torso, the output error and its theta-slope at the start of the step. The
correction ``(c0 + c1 (theta - theta+)) (1 - sigma(s))`` with the quintic smoothstep sigma on
s = (theta - theta+) / (theta_mid - theta+) is C² and vanishes from theta_mid on, the middle of
the variable's first phase. The stance motor leg shape is corrected by the event-based update
of its MC, SC and SI pieces instead (:func:`update_at_impact`).
"""
from __future__ import annotations

import jax
import jax.numpy as jnp

from bipedlab.control import bezier as bz
from bipedlab.pytree import pytree

MC, SC, SI, SD = range(4)
PHASES = ("mc", "sc", "si", "sd")
OUTPUTS = ("mLS_st", "LA_sw", "mLS_sw", "Tor")
#: index in q_s of each controlled variable
H0_INDEX = (1, 3, 4, 5)
SPRING_TRIGGER = jnp.deg2rad(5.0)
ORDER = 5
#: pieces follow their polynomial on [-OVERRUN, 1 + OVERRUN], then saturate
OVERRUN = 0.0
OVERRUN_WIDTH = 0.02


@pytree
class Constraints:
    """Virtual constraints of one step (all float64; angles in rad, motor angles motor-side).

    theta_plus, theta_minus: start and end of the step; theta_mc, theta_sc, theta_si: ends of
    MC, SC and SI (theta_sc is the nominal one until the event sets it); mls_mc, mls_si (6,);
    mls_sc, mls_sd: constants; tor (6,) on [theta+, theta_si]; la_sw, mls_sw (6,) on
    [theta+, theta-]; corr (3, 2): corrections (value, theta-slope at theta+) of LA_sw,
    mLS_sw, Tor."""

    theta_plus: jax.Array
    theta_minus: jax.Array
    theta_mc: jax.Array
    theta_sc: jax.Array
    theta_si: jax.Array
    mls_mc: jax.Array
    mls_sc: jax.Array
    mls_si: jax.Array
    mls_sd: jax.Array
    tor: jax.Array
    la_sw: jax.Array
    mls_sw: jax.Array
    corr: jax.Array


def theta(qs):
    """theta_s of eq. 25."""
    return jnp.pi - qs[0] - qs[5]


def theta_rate(qds):
    return -qds[0] - qds[5]


def controlled(qs):
    """H0 q_s (eq. 23)."""
    return qs[jnp.asarray(H0_INDEX)]


def saturated_phase(th, a, b):
    """s = (theta - a) / (b - a) on [-OVERRUN, 1 + OVERRUN], saturating smoothly outside at
    about OVERRUN_WIDTH further (tanh: value, slope and curvature continuous at the joints)."""
    s = (th - a) / (b - a)
    hi, lo = 1.0 + OVERRUN, -OVERRUN
    sat = lambda x: OVERRUN_WIDTH * jnp.tanh(x / OVERRUN_WIDTH)  # noqa: E731
    return jnp.where(s > hi, hi + sat(s - hi), jnp.where(s < lo, lo + sat(s - lo), s))


def _bez(alpha, th, a, b):
    return bz.bezier(alpha, saturated_phase(th, a, b))


def _smoothstep(s):
    s = jnp.clip(s, 0.0, 1.0)
    return s * s * s * (10.0 + s * (-15.0 + 6.0 * s))


def correction(vc: Constraints, th):
    """h_c of eq. 46 for (LA_sw, mLS_sw, Tor) at theta."""
    mids = jnp.stack([0.5 * (vc.theta_plus + vc.theta_minus)] * 2 + [0.5 * (vc.theta_plus + vc.theta_si)])
    s = (th - vc.theta_plus) / (mids - vc.theta_plus)
    return (vc.corr[:, 0] + vc.corr[:, 1] * (th - vc.theta_plus)) * (1.0 - _smoothstep(s))


def desired(vc: Constraints, phase, th):
    """h_d + h_c (4,) in phase (MC..SD) at theta."""
    mls = jnp.select(
        [phase == MC, phase == SC, phase == SI],
        [_bez(vc.mls_mc, th, vc.theta_plus, vc.theta_mc), vc.mls_sc + 0.0 * th,
         _bez(vc.mls_si, th, vc.theta_sc, vc.theta_si)],
        vc.mls_sd + 0.0 * th)
    tor = jnp.where(phase == SD, vc.tor[-1] + 0.0 * th, _bez(vc.tor, th, vc.theta_plus, vc.theta_si))
    la = _bez(vc.la_sw, th, vc.theta_plus, vc.theta_minus)
    ms = _bez(vc.mls_sw, th, vc.theta_plus, vc.theta_minus)
    c = correction(vc, th)
    return jnp.stack([mls, la + c[0], ms + c[1], tor + c[2]])


def desired_derivatives(vc: Constraints, phase, th):
    """(h, dh/dtheta, d2h/dtheta2), each (4,)."""
    f = lambda t: desired(vc, phase, t)  # noqa: E731
    d1 = lambda t: jax.jvp(f, (t,), (jnp.ones_like(t),))  # noqa: E731
    (h, dh), (_, ddh) = jax.jvp(d1, (th,), (jnp.ones_like(th),))
    return h, dh, ddh


def outputs(vc: Constraints, phase, qs, qds):
    """(y, y-dot) of eqs. 22/45 at the stance state."""
    th, thd = theta(qs), theta_rate(qds)
    h, dh, _ = desired_derivatives(vc, phase, th)
    return controlled(qs) - h, controlled(qds) - dh * thd


def stance_coordinates(vc: Constraints, phase, th, b):
    """q_s on the zero-dynamics manifold at (theta, q_Bsp_st), and its theta- and b-derivatives
    (Phi, Phi_theta, Phi_thetatheta); Phi_b is the unit vector on q_Bsp_st."""
    h, dh, ddh = desired_derivatives(vc, phase, th)

    def assemble(hv, lead, spring):
        return jnp.stack([lead - hv[3], hv[0], spring, hv[1], hv[2], hv[3]])

    phi = assemble(h, jnp.pi - th, b)
    phi_t = assemble(dh, -1.0 + 0.0 * th, 0.0 * th)
    phi_tt = assemble(ddh, 0.0 * th, 0.0 * th)
    return phi, phi_t, phi_tt


def mc_piece(q_plus, qd_plus, thd_plus, theta_plus, theta_mc):
    """Stance motor leg shape in MC: from the post-impact (q, qd) to rest at
    ``q + qd (theta_mc - theta+) / (5 thetadot+)``, the Bézier whose last five coefficients
    are equal (it decelerates the motor monotonically). Returns (alpha (6,), resting angle).
    This stands in for the paper's ``sgn(qd+) max(20 deg, |qd+|)`` offset, which adds an angle
    and a rate."""
    rest = q_plus + qd_plus * (theta_mc - theta_plus) / (ORDER * thd_plus)
    return jnp.concatenate([q_plus[None], jnp.full(ORDER, rest)]), rest


def lean(vc: Constraints, delta):
    """The constraints with the torso leaned forward by ``delta`` rad (the torso reference
    lowered by delta, the swing leg-angle reference raised by delta so the swing leg's absolute
    angle, and thus the step, is unchanged): the knob turned by hand in Exp. 5 to walk faster."""
    return vc.replace(tor=vc.tor - delta, la_sw=vc.la_sw + delta)


def update_at_impact(vc: Constraints, qs_plus, qds_plus, nominal: Constraints, invariant: bool = True):
    """Start-of-step update: theta+ from the state, the stance motor leg shape's MC/SC/SI pieces
    rebuilt from its post-impact (q, qd) (it only stops the motor in MC, holds it in SC and
    rejoins the nominal SI piece), and, with ``invariant``, the corrections of eq. 47 so that
    y = y-dot = 0 at theta+."""
    th, thd = theta(qs_plus), theta_rate(qds_plus)
    vc = nominal.replace(theta_plus=th)
    alpha_mc, rest = mc_piece(qs_plus[1], qds_plus[1], thd, th, vc.theta_mc)
    vc = vc.replace(mls_mc=alpha_mc, mls_sc=rest, mls_si=nominal.mls_si.at[:2].set(rest))
    if not invariant:
        return vc
    y, yd = outputs(vc.replace(corr=jnp.zeros((3, 2))), MC, qs_plus, qds_plus)
    return vc.replace(corr=jnp.stack([y[1:], yd[1:] / thd], 1))


def next_phase(vc: Constraints, phase, qs, qds, gamma=None):
    """Phase after the sub-phase guards of eq. 37 (or eq. 50 with gamma) at this state; the
    SD -> MC touchdown is the impact, handled by the caller. Returns (phase, theta_sc) where
    theta_sc is updated when SC ends."""
    th, b, bd = theta(qs), qs[2], qds[2]
    spring = (b <= SPRING_TRIGGER) & (bd < 0.0)
    if gamma is not None:
        spring = (spring & (th > vc.theta_sc - gamma)) | (th >= vc.theta_sc + gamma)
    to_sc = (phase == MC) & (th >= vc.theta_mc)
    to_si = (phase == SC) & spring
    to_sd = (phase == SI) & (th >= vc.theta_si)
    new = jnp.where(to_sc, SC, jnp.where(to_si, SI, jnp.where(to_sd, SD, phase)))
    return new, jnp.where(to_si, th, vc.theta_sc)
