"""MABEL's two-legged hopping controller (identification paper, Section VIII-B, Appendix C).

Five phases (Fig. 20): I flight, II touchdown, III kick-off, IV_a / IV_b one leg lifted,
V retract (50 ms), with the transitions (38)-(43). In every phase a PD law (34) drives
``h = [q_LA_L, q_mLS_L, q_LA_R, q_mLS_R]`` to the phase's reference; the references are
built from the parameters (46) through x^d (37). An event-based update (44) re-centres the
desired torso angle at each touchdown from the distance travelled during the last hop.

Sensing, as on the robot: the controller runs every 1 ms on quantised encoder readings
(``encoder_counts`` per revolution on q_LA, q_mLS and the torso angle; 2^14 by default,
the resolution of a 14-bit absolute magnetic encoder), and estimates h-dot by a backward
difference smoothed by a first-order filter (``velocity_filter`` is the weight of the
previous estimate). Touchdown and lift-off are read from the toe heights and the vertical
boom rate from the state, standing in for the robot's contact and boom sensors.

Conventions: angles in rad; the leg-angle motors turn against q_LA (q_mLA = -23.53 q_LA), so
their PD output is negated to push q_LA the intended way. Transition (39) fires when the
vertical boom rate rises above -0.01 rad/s (the bottom of the landing, the sampled form of
|phi_v-dot| < 0.01).
"""
from __future__ import annotations


import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.pytree import pytree
FLIGHT, TOUCHDOWN, KICKOFF, LEFT_UP, RIGHT_UP, RETRACT = range(6)
PHASE_NAMES = ("I flight", "II touchdown", "III kick-off", "IV_a left lift-off", "IV_b right lift-off", "V retract")


@pytree
class HopParams:
    """Controller parameters (float64 leaves; angles in rad).

    The set (45)-(46): delta_la, h_ls (L, R), delta_minus (L, R), delta_plus (L, R), h_tor0,
    dphi_d (desired boom travel per hop). Gains: kp, kd (4,) in motor N m per rad (per rad/s)
    of h; k_tor: torso-update gain; torso_update: 1.0 on, 0.0 off (the nominal controller).
    gear_ls: LS-to-mLS ratio used in x^d; boom_radius (m); retract_time (s);
    encoder_counts per revolution (0 disables quantisation); velocity_filter in [0, 1);
    period: control sampling period (s); torque_limit: saturation of the commands (4,), N m."""

    delta_la: jax.Array
    h_ls: jax.Array
    delta_minus: jax.Array
    delta_plus: jax.Array
    h_tor0: jax.Array
    dphi_d: jax.Array
    kp: jax.Array
    kd: jax.Array
    k_tor: jax.Array
    torso_update: jax.Array
    gear_ls: jax.Array
    boom_radius: jax.Array
    retract_time: jax.Array
    encoder_counts: jax.Array
    velocity_filter: jax.Array
    period: jax.Array
    torque_limit: jax.Array



def paper_params(**overrides) -> HopParams:
    """Eq. (46) with this package's tuned gains.

    The paper gives neither the PD gains nor K_Tor nor the torque limits. These were found by
    batched random search on the 13-DoF model (about 1800 sets of K_p, K_d for the leg-angle
    and leg-shape channels, K_Tor, the velocity filter and the limits; whole batches simulated
    in one vectorised call), keeping a set that hops 150 times and whose neighbours within
    +-20 % also mostly hop (a third of them for 150 hops): K_p = 45 N m/rad on q_LA (motor
    torque per joint radian) and 3.5 N m/rad on q_mLS, K_d = 1.2 and 0.05 N m s/rad,
    K_Tor = 2, limits 27 / 13 N m (within the motors' 30 / 55 N m capacities)."""
    d = np.deg2rad
    v = dict(
        delta_la=d(30.0), h_ls=d([12.0, 12.0]), delta_minus=d([5.0, 13.0]), delta_plus=d([5.0, 5.0]),
        h_tor0=d(8.0), dphi_d=d(-6.9), kp=[45.0, 3.5, 45.0, 3.5], kd=[1.2, 0.05, 1.2, 0.05], k_tor=2.0,
        torso_update=1.0, gear_ls=31.42, boom_radius=2.25, retract_time=0.05, encoder_counts=2.0**14,
        velocity_filter=0.45, period=1e-3, torque_limit=[27.0, 13.0, 27.0, 13.0],
    )
    v.update(overrides)
    return HopParams(**{k: jnp.asarray(val, dtype=jnp.float64) for k, val in v.items()})


@pytree
class HopState:
    """Controller memory: phase, time (s), time entering V, LA references frozen at III->IV,
    previous quantised h, filtered h-dot, current desired torso angle, boom angle at the last
    touchdown, whether one was seen, and the touchdown count."""

    phase: jax.Array
    t: jax.Array
    t_retract: jax.Array
    la_frozen: jax.Array
    h_prev: jax.Array
    hdot: jax.Array
    h_tor: jax.Array
    phi_last: jax.Array
    seen: jax.Array
    touchdowns: jax.Array


def initial_state(p: HopParams, h0) -> HopState:
    f = lambda v: jnp.asarray(v, dtype=jnp.float64)  # noqa: E731
    return HopState(jnp.asarray(FLIGHT), f(0.0), f(0.0), f([0.0, 0.0]), quantise(p, jnp.asarray(h0)),
                    jnp.zeros(4), p.h_tor0 + 0.0, f(0.0), jnp.asarray(False), jnp.asarray(0))


def quantise(p: HopParams, v):
    step = 2.0 * jnp.pi / jnp.where(p.encoder_counts > 0, p.encoder_counts, 1.0)
    return jnp.where(p.encoder_counts > 0, step * jnp.round(v / step), v)


def nominal_targets(p: HopParams, h_tor):
    """x^d of eq. (37)."""
    return jnp.stack([jnp.pi - 0.5 * p.delta_la - h_tor, p.gear_ls * p.h_ls[0],
                      jnp.pi + 0.5 * p.delta_la - h_tor, p.gear_ls * p.h_ls[1]])


def _stance_la(p: HopParams, h_tor, tor, la_r):
    """LA references of phases II and III: torso angle and leg splay (eqs. 39-40)."""
    return jnp.stack([tor + la_r - h_tor - p.delta_la, tor + la_r - h_tor])


def reference(p: HopParams, c: HopState, phase, tor, h):
    """h_X^ref for the given phase (eqs. 38-43)."""
    xd = nominal_targets(p, c.h_tor)
    g = p.gear_ls
    stance = _stance_la(p, c.h_tor, tor, h[2])
    ls_minus = xd[jnp.array([1, 3])] - g * p.delta_minus
    ls_plus = xd[jnp.array([1, 3])] + g * p.delta_plus
    refs = jnp.stack([
        xd,
        jnp.stack([stance[0], xd[1], stance[1], xd[3]]),
        jnp.stack([stance[0], ls_minus[0], stance[1], ls_minus[1]]),
        jnp.stack([c.la_frozen[0], ls_plus[0], c.la_frozen[1], ls_minus[1]]),
        jnp.stack([c.la_frozen[0], ls_minus[0], c.la_frozen[1], ls_plus[1]]),
        jnp.stack([c.la_frozen[0], ls_plus[0], c.la_frozen[1], ls_plus[1]]),
    ])
    return refs[phase]


#: Direction of each motor relative to its h coordinate (leg-angle motors turn against q_LA).
MOTOR_SIGN = np.array([-1.0, 1.0, -1.0, 1.0])


def update(p: HopParams, c: HopState, h_true, tor_true, toe_heights, phi_h, phi_v_rate):
    """One control sample: (new controller state, commanded torques u (4,)).

    h_true: [q_LA_L, q_mLS_L, q_LA_R, q_mLS_R]; tor_true: torso angle; toe_heights (2,);
    phi_h: horizontal boom angle (rad); phi_v_rate: vertical boom rate (rad/s)."""
    h = quantise(p, h_true)
    tor = quantise(p, tor_true)
    raw = (h - c.h_prev) / p.period
    hdot = p.velocity_filter * c.hdot + (1.0 - p.velocity_filter) * raw
    down = toe_heights <= 0.0
    up = ~down
    ph = c.phase
    t = c.t + p.period
    # transitions (one per sample)
    land = (ph == FLIGHT) & down[0] & down[1]
    bottom = (ph == TOUCHDOWN) & (phi_v_rate > -0.01)
    lift_a = (ph == KICKOFF) & up[0] & down[1]
    lift_b = (ph == KICKOFF) & down[0] & up[1]
    lift_both = (ph == KICKOFF) & up[0] & up[1]
    a_to_v = (ph == LEFT_UP) & up[1]
    b_to_v = (ph == RIGHT_UP) & up[0]
    to_flight = (ph == RETRACT) & (t >= c.t_retract + p.retract_time - 1e-9)
    new = jnp.select(
        [land, bottom, lift_a, lift_b, lift_both, a_to_v | b_to_v, to_flight],
        [TOUCHDOWN, KICKOFF, LEFT_UP, RIGHT_UP, RETRACT, RETRACT, FLIGHT], ph)
    # event-based torso update (44) at touchdown
    dphi = phi_h - c.phi_last
    h_tor_new = p.h_tor0 + p.torso_update * p.k_tor * (dphi - p.dphi_d)
    h_tor = jnp.where(land & c.seen, h_tor_new, c.h_tor)
    phi_last = jnp.where(land, phi_h, c.phi_last)
    seen = c.seen | land
    leaving = lift_a | lift_b | lift_both
    la_frozen = jnp.where(leaving, _stance_la(p, c.h_tor, tor, h[2]), c.la_frozen)
    t_retract = jnp.where(lift_both | a_to_v | b_to_v, t, c.t_retract)
    c = HopState(new, t, t_retract, la_frozen, h, hdot, h_tor, phi_last, seen, c.touchdowns + land.astype(int))
    ref = reference(p, c, new, tor, h)
    u = MOTOR_SIGN * (p.kp * (ref - h) - p.kd * hdot)
    return c, jnp.clip(u, -p.torque_limit, p.torque_limit)
