"""Controller embedding the spring-mass model in the articulated running robot (running paper,
Section III): flight LQR with the momentum-compensated reference (III-C), stance energy
regulation by stiffness modulation (eq. 7) and inverse dynamics (eq. 8) with pitch and
mean-hip-angle feedback (III-D), the sliding transition (III-E), swing-leg length control
(III-F) and mode switching (III-G).

``control(cp, cs, meas) -> (cs, u)`` is a pure function of the controller parameters, its
memory and one measurement; u = (tau1, tau2, F1, F2) in robot leg order.

Choices where the paper is silent or ambiguous (documented, see the study's report):
- the landing hip angle is the geometry solved explicitly, g_a* = atan2(l0 cos a + d sin th,
  -l0 sin a + d cos th), where the paper's gamma_1* = pi/2 + a*(t) - asin(d sin(gamma_1 - th) / l_v)
  (Sec. III-C) states the same triangle implicitly, with the current leg angle gamma_1 and
  virtual leg length l_v on its right-hand side;
- the compensated reference (whose algebra the paper omits) keeps g_a* and moves only the
  trunk reference, to the minimiser of w_theta (th - th*)^2 + w_phi (phi - pi)^2 on the
  reachable set of the conserved momentum (:func:`running_model.compensated_reference`);
- the flight law's feedforward u-dagger (u = u-dagger - K (x_r - x_r-dagger), algebra omitted by
  the paper) is the input giving the reduced system the reference's own acceleration
  (:func:`flight_feedforward`); without it the leg landed 0.39 deg behind g_a*;
- eq. (7)'s virtual leg l_v points to the COM from the spring-mass model's foot point, fixed
  for the stance (the foot's height at touchdown, its x where it stopped sliding;
  :func:`stance_leg`), not from the real foot: the paper derives the stance control for a
  stationary foot (III-A), and a spring measured from a foot that sinks into the damped ground
  is no longer conservative (flat ground, paper's controller: apex energy -53 -> -2 J, steady
  speed error -22 -> -8 cm/s, apex height +1.8 -> +3.8 cm);
- stiffness modulation f = k0 (l0 - l_v) - c dE (l0 - l_v) l_v' (the paper's k = k0 + c dE l_v
  read with the leg-length rate so the extra work -c dE int (l0 - l_v) l_v'^2 dt opposes dE);
  c is set so that the nominal stance would remove ``energy_gain`` of dE (:data:`ENERGY_GAIN`);
  neither dE nor the stiffness change is limited, as in the paper (limits of 150 J and 50 % of
  k0, once bipedlab's, capped what a stance could take out below the 90 J a 10 ms delay
  injects: the speed ran away by 0.3 m/s a step and 27 of 32 rough-terrain draws fell; without
  them all 32 run through at +76 cm/s against the paper's +71.9, and no other figure improved
  with them);
  bipedlab's controller adds ``ki_energy`` times the sum of past lift-off errors to dE (integral
  action, clipped), which removes the steady error that the per-step losses (foot sliding,
  ground damping) leave otherwise;
- stance feedback (:func:`_stance_feedback`): tau_a = tau_a,ff - l/(l+d) (tau_b,fb +
  I_t (Kp (th* - th) - Kd th')), tau_b = tau_b,ff + tau_b,fb: with a stationary foot a hip
  torque turns the GRF, so in these coordinates (those of the paper's eqs. 3, 4) the printed
  +Kp (th* - th) in tau_1 would destabilise the pitch;
- sliding -> stance: |x_r' - x_a| < 10 % x_a and the stance command itself within the
  friction cone (|F_x*| <= mu F_y*), standing in for "the slipping dynamics reduce the speed
  difference";
- swing-leg length: the trailing foot is held at 50 % of the COM height above the last
  stance foot, the landing leg blends to the landing length as the landing-angle error falls
  below 0.4 rad (full landing length below 0.1 rad), after the flight apex (t_extend = 0; an
  earlier extension made early landings on step-ups worse in our tests);
- lift-off: the first sample the virtual leg is longer than its rest length and extending,
  as in the paper (a debounce of 2 cm of compression or 40 ms of stance, once bipedlab's,
  changed no figure with the stiffness modulation unlimited: flat ground, rough terrain,
  noise, delay and model errors alike);
- lift-off energy (:func:`_energy`) is that of the whole robot's COM (trunk and feet, m_f in
  the controller's model), the one quantity conserved exactly in flight, with the target
  (m + 2 m_f)(g y* + v*^2/2); in regulation the height is measured above the sensed foot
  height at touchdown. Measured energy budget on flat ground (conservation, before): the
  COM energy sat 14 J below the target through the whole step (flight, touchdown, stance and
  lift-off each within 2 J, i.e. no loss between lift-off and apex); the integral action had
  zeroed the controller's *estimate*, which was biased by the 0.4 kg of feet (9 J of target,
  the trunk COM instead of the system COM) and in regulation by the foot sunk 1.3 cm into the
  ground at lift-off (m g 1.3 cm = 7.5 J). This fix alone: -6.7 -> -1.5 cm/s;
- landing-angle trim: the swing policy's apex height keeps a +0.7 cm bias on the robot (not
  a point mass on a massless leg), worth -1.4 cm/s at fixed energy; at each lift-off
  a_trim += ki_angle (h_apex - y*) with h_apex the exact ballistic COM apex above the
  touchdown ground estimate (dh/da = -1.8 m/rad on the SMM map, so ki_angle = 0.25 rad/m is
  about half the deadbeat gain), clipped to +-a_trim_max; a* = a*(t) + a_trim;
- sensing delay (``delay``, s, known to the controller): in flight the delayed state is
  predicted ballistically (:func:`predict_flight`) before the flight command; the stance
  spring acts on the constant-rate predicted length l_v + tau l_v' (a spring lagging by tau
  injects k0 tau int l_v'^2 dt, about 90 J per stance at 10 ms, for the energy modulation to
  take out again); the
  leg-length PD bandwidth is capped at 0.5 / tau (:func:`_leg_pd`: at 10 ms the nominal
  gains made the swing legs limit-cycle by +-10 cm, the real cause of the early, random
  touchdowns; the cap is always designed for at least 10 ms, see :func:`_leg_pd`). A
  constant-rate prediction of the lift-off test lost every trial; the prediction and the spring
  on the predicted length are off unless the controller is told its delay
  (``--delay-compensation``); without it the controller runs the paper's experiment, measurements
  and so forces late by the delay, with no knowledge of it;
- a landing with a short virtual leg (early, on a step-up) sets that stance's rest length to
  the touchdown length (at least 0.8 l0) instead of starting with a pre-compressed spring.

Measured: the flat-ground bias of the paper's controller (steady +3.2 cm, -7.0 cm/s; the step
budget of :mod:`bipedlab.robots.atrias.budget`). The energy is right, its split between height
and speed is not: the apex sits 1.9 J below the target (-0.65 cm/s of the speed error) and the
lift-off state holds the next apex's energy to 0.1 J. The stance realises the spring-mass model
about the point where the landing foot stopped sliding (its replay from the end of the slide:
1.084 m, 4.94 m/s; the robot 1.082 m, 4.93 m/s); the flight lands 0.18 deg flatter than
commanded (replay from touchdown: 1.055 m, 4.99 m/s). The landing foot meets the ground at
4.0 m/s forward (the policy retracts the leg at 0.8 rad/s against the 4.9 m/s of the COM) and
slides 2.3 cm in the 12 ms the saturated hip torque of the transition (III-E) takes to stop it;
the spring-mass replay from touchdown about the point moved forward by that slide alone reaches
the robot's apex height (1.081 m). The slide scales with I_m / tau_max, values the paper does
not give: I_m = 0.3 / 0.5 / 1.0 / 2.0 kg m^2 (plant and controller) slid
0.9 / 1.4 / 2.3 / 3.7 cm and ran +0.7 / +1.5 / +3.2 / +6.0 cm, -5.0 / -5.8 / -7.0 / -8.2 cm/s
(apex energy -10 / -8 / -2 / +11 J under the proportional energy feedback); tau_max = 500 N m:
slide 1.3 cm, +2.2 cm, -7.1 cm/s. The foot mass m_f (also not given) moves it less and scatters
the apexes when light: 0.02 / 0.1 kg gave +2.5 / +3.1 cm, -3.3 / -5.5 cm/s (apex s.d.
0.35 / 0.08 cm), 0.4 kg an irregular gait. Changed alone, none of the controller's readings
moved the bias toward the paper: the paper's own sliding-to-stance test (the stance command
under the slipping dynamics reduces |x_r'-x_a'|) switches at the same samples as the
friction-cone test (flat ground; on 4 rough terrains of 12 s the same for the paper's
controller, bounce heights within 3 mm for bipedlab's); the spring about the touchdown point
gave +3.4 cm, -19.7 cm/s, about the real foot's x +3.3 cm, -7.4 cm/s; the paper's literal
E_trans (trunk COM, trunk mass) over-estimates the lift-off energy by 6 J (+3.4 cm, -9.4 cm/s);
a degree-9 fit of a*(t) +3.2 cm, -7.0 cm/s; a flight LQR with ten times the angle weights and
three times the rate weights lands 0.02 deg flat (+2.5 cm, -5.5 cm/s). Nor did the ground: twice
the friction +2.8 cm, -6.4 cm/s (slide 2.0 cm), four times the vertical stiffness +3.3 cm,
-7.1 cm/s, a landing foot that starts sliding instead of sticking for its first step +3.1 cm,
-6.9 cm/s.
"""
from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.robots.atrias import controller_model as rm
from bipedlab.control import slip
from bipedlab.pytree import pytree

FLIGHT, SLIDING, STANCE = 0, 1, 2
#: the share of the lift-off energy error the nominal stance's stiffness modulation removes, which
#: sets eq. (7)'s gain c (the paper gives no value)
ENERGY_GAIN = 0.5
#: the gait the controller regulates and the runs start at: apex height (m) and speed (m/s)
APEX_HEIGHT, SPEED = 1.05, 5.0


@pytree
class CtrlParams:
    mp: rm.ModelParams
    smm: slip.SlipParams          # k0 here is the stiffness the stance control realises
    policy: slip.SwingPolicy
    y_apex: float
    speed: float
    theta_star: float
    K: jax.Array                  # flight LQR gain (2x4)
    tau_max: float
    regulation: bool              # energy regulation (True) or conservation (False); traced in the loop
    c_energy: float
    kp_theta: float = 300.0
    kd_theta: float = 40.0
    kp_phi: float = 100.0
    kd_phi: float = 60.0
    w_theta: float = 4.0
    w_phi: float = 1.0
    kp_leg: float = 3000.0
    kd_leg: float = 70.0
    l_min: float = 0.4
    f_swing_max: float = 250.0
    t_extend: float = 0.0
    l_rest_min: float = 0.8
    ki_energy: float = 0.3
    e_int_max: float = 600.0
    ki_angle: float = 0.25
    a_trim_max: float = 0.03
    delay: float = 0.0            # known sensing delay (s) that the flight predictor bridges (--delay-compensation)
    leg_delay_margin: float = 0.5  # leg-length loop bandwidth times the delay (rad), see _leg_pd
    leg_design_delay: float = 0.010  # loop delay (s) the swing-leg length loop is designed to tolerate, see _leg_pd
    leg_zeta: float = 0.7


@pytree
class CtrlState:
    mode: jax.Array       # FLIGHT / SLIDING / STANCE
    leg: jax.Array        # index of the stance (or landing) leg
    dE: jax.Array         # energy error measured at the last lift-off (J)
    xa: jax.Array         # estimated apex speed (m/s)
    y_ground: jax.Array   # height of the last stance foot (m, sensed)
    e_int: jax.Array      # sum of the lift-off energy errors (J), the integral action
    l_rest: jax.Array     # virtual rest length of this stance (m)
    y_td: jax.Array       # sensed foot height at the last touchdown (the ground estimate)
    a_trim: jax.Array     # integral landing-angle trim (rad), see :func:`control`
    x_st: jax.Array       # sensed x of the stance foot: followed while it slides, held in stance


@pytree
class Meas:
    q: jax.Array          # (7,) sensed coordinates
    qd: jax.Array         # (7,)
    contact: jax.Array    # (2,) foot contact switches
    foot_y_true: jax.Array  # (2,) true foot heights (unused: conservation takes the global COM height)


def init_state(cp: CtrlParams, leg: int = 0) -> CtrlState:
    i32 = lambda v: jnp.asarray(v, jnp.int32)
    f64 = lambda v: jnp.asarray(v, jnp.float64)
    return CtrlState(i32(FLIGHT), i32(leg), f64(0.0), f64(cp.speed), f64(0.0), f64(0.0), f64(cp.smm.l0),
                     f64(0.0), f64(0.0), f64(0.0))


def make_params(mp: rm.ModelParams, smm: slip.SlipParams, policy: slip.SwingPolicy, *, y_apex=APEX_HEIGHT,
                speed=SPEED, theta_star=np.deg2rad(10.0), tau_max=250.0, regulation=True, energy_gain=ENERGY_GAIN,
                Q=(4e5, 4e5, 100.0, 100.0), R=(1.0, 1.0), stiffness_scale=1.0) -> CtrlParams:
    """Controller parameters; the flight LQR gain from the reduced system (A_r, B_r)."""
    A, B = rm.flight_reduced_system(mp.I_t, mp.I_m)
    K = rm.lqr_gain(A, B, np.diag(Q), np.diag(R))
    c = energy_gain / _nominal_work_integral(smm, y_apex, speed)
    smm_applied = smm.replace(k0=smm.k0 * stiffness_scale)
    return CtrlParams(mp, smm_applied, policy, y_apex, speed, float(theta_star), jnp.asarray(K), tau_max,
                      bool(regulation), float(c))


def paper_controller(cp: CtrlParams) -> CtrlParams:
    """The paper's controller as published: ``cp`` without bipedlab's two additions
    (:data:`bipedlab.robots.atrias.catalog.ADDITIONS`): no integral action on the lift-off
    energy error (``ki_energy`` 0) and no landing-angle trim (``ki_angle`` 0). The parameters
    stay traced values of the same structure, so both controllers run on one compiled program.

    What stays is this model's reading of the paper where it is silent or, in these
    coordinates, printed with the other sign (the module's list above): the exact landing
    geometry, the compensated reference and its feedforward, the virtual leg from the stance's
    fixed foot point, the stiffness modulation read with the leg-length rate, the pitch
    feedback's sign, the sliding test, the swing-leg length and the lift-off energy of the
    whole robot's COM."""
    return cp.replace(ki_energy=0.0, ki_angle=0.0)


_stance_flow = jax.jit(slip.stance_flow)


def _nominal_work_integral(smm, y_apex, speed, dt=1e-4):
    """int (l0 - l) l'^2 dt over the periodic SMM stance (so c dE times it is the energy
    removed per stance); cached per model and gait."""
    return _work_integral(float(smm.m), float(smm.k0), float(smm.l0), float(smm.g), float(y_apex), float(speed),
                          float(dt))


@functools.lru_cache(maxsize=16)
def _work_integral(m, k0, l0, g, y_apex, speed, dt):
    smm = slip.SlipParams(m, k0, l0, g)
    gait = slip.Gait(y_apex, speed)
    a = slip.periodic_angle(smm, gait)
    s, _ = slip.touchdown_state(smm, y_apex, speed, a)
    s = np.asarray(s)
    f = lambda s: np.asarray(_stance_flow(smm, jnp.asarray(s)))  # compiled: the same values as op by op
    total = 0.0
    for _ in range(20000):
        l = np.linalg.norm(s[:2])
        ld = s[:2] @ s[2:] / l
        total += (smm.l0 - l) * ld * ld * dt
        s = s + dt * f(s)
        if np.linalg.norm(s[:2]) >= smm.l0 and s[:2] @ s[2:] > 0:
            break
    return total


def _local(v, leg):
    """Robot order (x, y, th, g1, g2, l1, l2) -> local (x, y, th, g_a, g_b, l_a, l_b)."""
    sw = jnp.array([0, 1, 2, 4, 3, 6, 5])
    return jnp.where(leg == 0, v, v[sw])


def landing_hip_angle(cp, theta, alpha):
    l0, d = cp.smm.l0, cp.mp.d
    return jnp.arctan2(l0 * jnp.cos(alpha) + d * jnp.sin(theta), -l0 * jnp.sin(alpha) + d * jnp.cos(theta))


def landing_length(cp, theta, gamma):
    """Physical leg length that puts the foot at l0 from the COM."""
    d, l0 = cp.mp.d, cp.smm.l0
    c = jnp.cos(gamma - theta)
    return d * c + jnp.sqrt(jnp.maximum(l0 ** 2 - d ** 2 * (1 - c ** 2), 0.0))


def _leg_pd(cp, l_target, l, ld):
    """Swing-leg length PD, saturated at f_swing_max: an unsaturated retraction right after
    lift-off, while the foot still touches the ground, pulls the trunk down.

    Under a sensing delay tau the loop around the foot mass m_f (the leg-length coordinate's
    inertia in flight) becomes unstable: at 10 ms the nominal kp = 3000 N/m (w = 122 rad/s,
    70 deg of delay phase) put the swing legs into a +-10 cm, 50 ms bang-bang limit cycle so
    the landing foot met the ground at a random phase of it. The natural frequency is
    therefore capped at w_tau = leg_delay_margin / tau (kp <= m_f w_tau^2) with damping ratio
    leg_zeta (kd <= 2 zeta sqrt(kp m_f)).

    The controller does not know the delay it runs with (the paper's experiment): the cap is
    designed for ``leg_design_delay`` = 10 ms whatever the delay (kp = 500 N/m, kd = 14 N s/m on
    the 0.2 kg foot: w = 50 rad/s, a leg-length loop at 8 Hz), or for the known delay if larger
    (--delay-compensation). Measured without delay on 8 terrains of 30 m (energy conservation):
    success 100 % with either gains. The gains are functions of the (possibly traced)
    parameters: the same values for every delay and model error."""
    kp, kd = _leg_gains(cp)
    return jnp.clip(kp * (l_target - l) - kd * ld, -cp.f_swing_max, cp.f_swing_max)


def _leg_gains(cp):
    """(kp, kd) of :func:`_leg_pd`: the nominal gains, capped for the design delay."""
    tau = jnp.maximum(cp.delay, cp.leg_design_delay)
    capped = (tau > 0) & (cp.mp.m_f > 0)
    w = cp.leg_delay_margin / jnp.where(capped, tau, 1.0)
    kp = jnp.where(capped, jnp.minimum(cp.kp_leg, cp.mp.m_f * w * w), cp.kp_leg)
    kd = jnp.where(capped, jnp.minimum(cp.kd_leg, 2 * cp.leg_zeta * jnp.sqrt(kp * cp.mp.m_f)), cp.kd_leg)
    return kp, kd


def _tuck_length(cp, q, y_ground, gamma):
    """Trailing-leg length putting the foot at 50 % of the COM height above the ground."""
    hip_y = q[1] - cp.mp.d * jnp.cos(q[2])
    foot_h = 0.5 * (q[1] - y_ground)
    l = (hip_y - (y_ground + foot_h)) / jnp.maximum(-jnp.cos(gamma), 0.3)
    return jnp.clip(l, cp.l_min, 1.0)


def flight_feedforward(cp, theta, t, a_trim):
    """The feedforward u-dagger of the flight law u = u-dagger - K (x_r - x_r-dagger) (III-C;
    the paper omits its algebra): the input under which the reduced system (A_r, B_r) follows
    its reference exactly, B_r u-dagger = (theta-dagger'', g_a*''). theta-dagger' is constant
    in flight (the momentum is), so tau_b = -tau_a and tau_a = I_m g_a*'' with g_a*'' the second
    time derivative of the landing hip angle along the policy a*(t) (t the time since apex) at
    the current pitch. Without it the LQR tracked the accelerating reference with a lag: the
    leg landed 0.39 deg behind g_a* (0.23 deg with it), a flatter landing angle that raises the
    coming apex (flat ground, paper's controller: apex +3.8 -> +3.2 cm, speed -8.1 -> -7.0 cm/s
    over 6 s)."""
    h = lambda tt: landing_hip_angle(cp, theta, slip.policy_angle(cp.policy, tt) + a_trim)
    tau_a = cp.mp.I_m * jax.grad(jax.grad(h))(t)
    return jnp.stack([tau_a, -tau_a])


def flight_command(cp, cs, q, qd):
    """Flight (III-C, III-F) in local coordinates: (tau_a, tau_b, F_a, F_b) and the target
    landing angle/hip angle for logging."""
    mp = cp.mp
    t = -qd[1] / mp.g                                  # time since the flight apex
    alpha = slip.policy_angle(cp.policy, t) + cs.a_trim
    alpha_d = slip.policy_rate(cp.policy, t)
    ga_star, dga = jax.jvp(lambda a: landing_hip_angle(cp, q[2], a), (alpha,), (alpha_d,))
    H = mp.I_t * qd[2] + mp.I_m * (qd[3] + qd[4])
    C = mp.I_t * q[2] + mp.I_m * (q[3] + q[4])
    th_dag, thd_dag = rm.compensated_reference(mp, cp.theta_star, C, H, cp.w_theta, cp.w_phi)
    xr = jnp.array([q[2], q[3], qd[2], qd[3]])
    xr_dag = jnp.array([th_dag, ga_star, thd_dag, dga])
    tau = flight_feedforward(cp, q[2], t, cs.a_trim) - cp.K @ (xr - xr_dag)
    # leg lengths: the landing leg blends from tucked to landing length after apex
    l_land = landing_length(cp, q[2], ga_star)
    err = jnp.abs(ga_star - q[3])
    w = jnp.where(t > -cp.t_extend, jnp.clip((0.4 - err) / 0.3, 0.0, 1.0), 0.0)
    la_t = w * l_land + (1 - w) * _tuck_length(cp, q, cs.y_ground, q[3])
    lb_t = _tuck_length(cp, q, cs.y_ground, q[4])
    F = jnp.array([_leg_pd(cp, la_t, q[5], qd[5]), _leg_pd(cp, lb_t, q[6], qd[6])])
    return jnp.concatenate([tau, F]), alpha


def stance_leg(cp, cs, q6, qd6):
    """Eq. (7)'s virtual leg: from the spring-mass model's foot point (x_st, y_td) to the COM,
    with its length and rate (r (2,), l_v, l_v').

    The spring-mass model's foot is a fixed point (III-A: the stationary foot), and the virtual
    spring is conservative about it: the COM's translational energy plus k0 (l_rest - l_v)^2 / 2
    is constant whatever the real foot does. The point is the sensed foot height at touchdown
    and the foot's x where it stopped sliding (while it still slides, mode not STANCE, the
    foot's x and x-rate). Measured from the real foot instead, the spring follows the foot as
    it sinks into the damped ground (1.4 cm over a stance on flat ground, at up to 0.17 m/s
    under 3.4 kN) and creeps on the stiction spring: the work the ground absorbs there (about
    40 J a stance) left the COM unreplaced, the lift-off energy sat 53 J below the target under
    the proportional energy feedback and the steady speed 22 cm/s below it."""
    vfoot = rm.jac6(cp.mp, q6) @ qd6
    r = q6[:2] - jnp.array([cs.x_st, cs.y_td])
    lv = jnp.linalg.norm(r)
    v_pt = jnp.array([jnp.where(cs.mode == STANCE, 0.0, vfoot[0]), 0.0])
    return r, lv, jnp.dot(r, qd6[:2] - v_pt) / lv


def _spring_force(cp, cs, q6, qd6):
    """Eq. (7) with the stiffness modulation: target GRF (2,) and l_v."""
    r, lv, lvd = stance_leg(cp, cs, q6, qd6)
    # told its delay tau, the spring acts on the predicted length: a spring lagging by tau does
    # the extra work k0 tau int l_v'^2 dt (about 90 J per stance at 10 ms)
    dl = cs.l_rest - (lv + cp.delay * lvd)
    f = (cp.smm.k0 - cp.c_energy * cs.dE * lvd) * dl
    return jnp.maximum(f, 0.0) * r / lv, lv, lvd


def _phi_feedback(cp, q6, qd6):
    return cp.kp_phi * (2 * jnp.pi - q6[3] - q6[4]) - cp.kd_phi * (qd6[3] + qd6[4])


def _stance_feedback(cp, q6, qd6, tau_a_ff, tau_b_ff):
    """Feedback of III-D. tau_b_fb drives the mean hip angle to pi; tau_a cancels its trunk
    reaction and adds the pitch PD. With the foot fixed a change of tau_a turns the GRF and
    changes the pitch acceleration by -(l + d) / (l I_t) per N m, hence the factor
    l / (l + d) and the sign (opposite to the paper's printed sign in these coordinates)."""
    tb = _phi_feedback(cp, q6, qd6)
    thdd = cp.kp_theta * (cp.theta_star - q6[2]) - cp.kd_theta * qd6[2]
    r = q6[5] / (q6[5] + cp.mp.d)
    ta = -r * (tb + cp.mp.I_t * thdd)
    return tau_a_ff + ta, tau_b_ff + tb


def stance_command(cp, cs, q, qd):
    """Stance (III-D): eq. (7) target GRF, eq. (8) inverse dynamics with pitch feedback as the
    commanded pitch acceleration, mean-hip-angle feedback on tau_b. Returns (u_local (4,),
    F* (2,), l_v, l_v', l'' nominal)."""
    q6, qd6 = q[:6], qd[:6]
    F, lv, lvd = _spring_force(cp, cs, q6, qd6)
    z = rm.inverse_dynamics(cp.mp, q6, qd6, F, 0.0)
    tau_a, tau_b = _stance_feedback(cp, q6, qd6, z[0], z[1])
    lb_t = _tuck_length(cp, q, cs.y_ground, q[4])
    u = jnp.array([tau_a, tau_b, z[2], _leg_pd(cp, lb_t, q[6], qd[6])])
    return u, F, lv, lvd, z[7]


def sliding_command(cp, cs, q, qd, stance=None):
    """Sliding transition (III-E): maximum tau_a against the foot's sliding, scaled vertical
    load, the nominal leg acceleration."""
    q6, qd6 = q[:6], qd[:6]
    _, F, _, _, ldd = stance if stance is not None else stance_command(cp, cs, q, qd)
    J = rm.jac6(cp.mp, q6)
    vfoot = J @ qd6
    slide_dir = jnp.where(vfoot[0] >= 0, 1.0, -1.0)
    tau_a = -cp.tau_max * jnp.sign(vfoot[0] * J[0, 3])
    xr = qd6[0] - vfoot[0]
    Fy = jnp.square(jnp.maximum(0.0, xr / jnp.maximum(cs.xa, 0.5))) * F[1]
    Fy = jnp.minimum(Fy, F[1])
    w = rm.sliding_dynamics(cp.mp, q6, qd6, tau_a, Fy, ldd, slide_dir)
    lb_t = _tuck_length(cp, q, cs.y_ground, q[4])
    tau_b = w[0] + _phi_feedback(cp, q6, qd6)
    return jnp.array([tau_a, tau_b, w[1], _leg_pd(cp, lb_t, q[6], qd[6])]), xr


def _energy(cp, q, qd, y_ground):
    """Translational energy of the whole robot's COM (trunk and feet, the foot masses m_f of
    the controller's model) at lift-off, and the COM apex height it will reach above
    ``y_ground``. In flight this COM is ballistic, so both are exactly the coming apex's.
    Regulation measures heights above the ground under the stance foot, estimated as the
    sensed foot height at touchdown (the foot sinks about 1.3 cm into the ground by lift-off:
    taking the lift-off foot height over-estimated the energy by m g 1.3 cm = 7.5 J);
    conservation takes the global height (truth, so only the dissipated energy is replaced).
    Returns (energy, energy target, apex height above y_ground)."""
    mp = cp.mp
    M, g = mp.m + 2 * mp.m_f, mp.g
    com, vcom = rm.system_com(mp, q, qd)
    y_ref = jnp.where(cp.regulation, y_ground, 0.0)
    e = 0.5 * M * (vcom[0] ** 2 + vcom[1] ** 2) + M * g * (com[1] - y_ref)
    e_star = M * g * cp.y_apex + 0.5 * M * cp.speed ** 2
    h_apex = com[1] - y_ground + jnp.square(jnp.maximum(vcom[1], 0.0)) / (2 * g)
    return e, e_star, h_apex


def predict_flight(cp, q, qd):
    """Delay compensation in flight: the trunk moves ballistically over the known sensing delay
    (exact for the robot's COM, whose difference from the trunk COM is the foot masses' 0.7 %),
    the joint coordinates at constant rate. Identity when cp.delay = 0."""
    tau = cp.delay
    q = q + tau * qd
    q = q.at[1].add(-0.5 * cp.mp.g * tau * tau)
    qd = qd.at[1].add(-cp.mp.g * tau)
    return q, qd


def control(cp: CtrlParams, cs: CtrlState, meas: Meas):
    """One controller sample: switch modes (III-G), then command. Returns (cs, u, info)."""
    leg = cs.leg
    q, qd = _local(meas.q, leg), _local(meas.qd, leg)
    contact_a = jnp.where(leg == 0, meas.contact[0], meas.contact[1]) > 0.5
    foot_ya = q[1] - cp.mp.d * jnp.cos(q[2]) + q[5] * jnp.cos(q[3])

    # --- mode switching (III-G); a touchdown fixes this stance's rest length first
    mode = cs.mode
    to_slide = (mode == FLIGHT) & contact_a
    lv_td = jnp.linalg.norm(rm.virtual_leg(cp.mp, q[:6]))
    l_rest = jnp.where(to_slide, jnp.clip(lv_td, cp.l_rest_min * cp.smm.l0, cp.smm.l0), cs.l_rest)
    y_td = jnp.where(to_slide, foot_ya, cs.y_td)
    foot_xa = q[0] - cp.mp.d * jnp.sin(q[2]) + q[5] * jnp.sin(q[3])
    x_st = jnp.where(mode == STANCE, cs.x_st, foot_xa)
    cs = cs.replace(l_rest=l_rest, y_td=y_td, x_st=x_st)
    st = stance_command(cp, cs, q, qd)
    u_st, F_st, lv, lvd, _ = st
    J = rm.jac6(cp.mp, q[:6])
    vfoot = J @ qd[:6]
    xr = qd[0] - vfoot[0]
    speed_ok = jnp.abs(xr - cs.xa) < 0.1 * jnp.abs(cs.xa)
    cone_ok = jnp.abs(F_st[0]) <= cp.mp.mu * F_st[1]
    to_stance = (mode == SLIDING) & speed_ok & cone_ok
    to_flight = (mode != FLIGHT) & (lv > cs.l_rest) & (lvd > 0)
    mode = jnp.where(to_slide, SLIDING, mode)
    mode = jnp.where(to_stance, STANCE, mode)
    # lift-off: estimate the energy error and apex speed, hand over to the other leg
    e_now, e_star, h_apex = _energy(cp, q, qd, y_td)
    a_trim = jnp.where(to_flight, jnp.clip(cs.a_trim + cp.ki_angle * (h_apex - cp.y_apex),
                                           -cp.a_trim_max, cp.a_trim_max), cs.a_trim)
    e_int = jnp.where(to_flight, jnp.clip(cs.e_int + (e_now - e_star), -cp.e_int_max, cp.e_int_max), cs.e_int)
    dE = jnp.where(to_flight, (e_now - e_star) + cp.ki_energy * e_int, cs.dE)
    xa = jnp.where(to_flight, qd[0], cs.xa)
    yg = jnp.where(mode != FLIGHT, foot_ya, cs.y_ground)
    new_leg = jnp.where(to_flight, 1 - leg, leg)
    mode = jnp.where(to_flight, FLIGHT, mode)
    cs_cmd = CtrlState(mode, leg, cs.dE, cs.xa, yg, cs.e_int, l_rest, y_td, cs.a_trim, x_st)

    # --- commands (in the local order of the current leg assignment)
    qp, qdp = predict_flight(cp, q, qd)
    u_fl, alpha = flight_command(cp, cs_cmd, qp, qdp)
    u_sl, _ = sliding_command(cp, cs_cmd, q, qd, st)
    u_loc = jnp.where(mode == FLIGHT, u_fl, jnp.where(mode == SLIDING, u_sl, u_st))
    u_loc = u_loc.at[:2].set(jnp.clip(u_loc[:2], -cp.tau_max, cp.tau_max))
    u = jnp.where(leg == 0, u_loc, u_loc[jnp.array([1, 0, 3, 2])])
    cs_new = CtrlState(mode, new_leg, dE, xa, yg, e_int, l_rest, y_td, a_trim, x_st)
    return cs_new, u, alpha
