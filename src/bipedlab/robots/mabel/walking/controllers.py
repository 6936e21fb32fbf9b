"""Controllers that realise MABEL's walking virtual constraints (compliant-HZD paper, Section IV
and V).

- ``iolin``: the input-output linearising controller (eq. 42), ``u = (LgLfh)^-1 (v - Lf^2 h)``
  with ``v = -(Kp/eps^2) y - (Kd/eps) y-dot``; with hybrid-invariance corrections (eq. 45) when
  the constraints are updated at impact (:func:`~bipedlab.robots.mabel.walking.constraints.update_at_impact`).
- ``decentralized``: the same with the off-diagonal entries of the decoupling matrix zeroed
  in the feedback term (Exp. 5): ``u = u*(x_s) + diag(LgLfh)^-1 v``, where the feedforward
  ``u* = -(LgLfh)^-1 Lf^2 h`` of eq. 32 keeps the full matrix, so that an error in one output
  drives only its own motor.
- ``pdff``: PD plus feedforward (eq. 43), ``u = u*(theta, beta) - Kp y - Kd y-dot`` with u*
  regressed along the designed orbit on 5th-order Béziers in theta per sub-phase (beta) and
  the PD acting through each output's own motor (stance leg-shape motor -> q_mLS_st, swing
  leg-angle motor -> q_LA_sw, swing leg-shape motor -> q_mLS_sw, stance leg-angle motor ->
  q_Tor), with the sign of that motor's effect on its output.

The generic pieces (output Jacobian of a linear phase, decoupling matrix and Lf^2 h on the
reduced dynamics D_s qdd + H_s = B_s u, the outer loop, the linearising input, u*) come from
:mod:`bipedlab.control.hzd`; the sub-phase chains, the corrections and the saturation are
MABEL's.

All controllers saturate at the drivetrain's torque limits (30 N m leg angle, 55 N m leg
shape, or the lower limits of an experiment).
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.robots.mabel.walking import stance as wk
from bipedlab.control import bezier as bz
from bipedlab.control import hzd
from bipedlab.robots.mabel.walking import catalog
from bipedlab.robots.mabel.walking import constraints as vcm
from bipedlab.pytree import pytree

KINDS = catalog.CONTROLLERS
#: actuator (in u = (mLA_st, mLS_st, mLA_sw, mLS_sw)) driving each output (mLS_st, LA_sw, mLS_sw, Tor)
ACTUATOR_OF_OUTPUT = (1, 2, 3, 0)
_THETA_Q = jnp.asarray([-1.0, 0.0, 0.0, 0.0, 0.0, -1.0])


@pytree
class Gains:
    """kp, kd (4,) per output for pdff (motor N m per rad, per rad/s of the output);
    eps (4,) per output, kp_io, kd_io for eq. 42; beta (4 phases, 4 actuators, 6): u* Béziers; beta_bounds
    (4, 2): theta-domain of each phase's regression; signs (4,): sign of each output's motor;
    limit (4,): torque saturation (N m)."""

    kp: jax.Array
    kd: jax.Array
    eps: jax.Array
    kp_io: jax.Array
    kd_io: jax.Array
    beta: jax.Array
    beta_bounds: jax.Array
    signs: jax.Array
    limit: jax.Array


def output_jacobian(dh):
    """dy/dq_s (4, 6) given dh/dtheta (4,)."""
    H0 = jnp.zeros((4, 6)).at[jnp.arange(4), jnp.asarray(vcm.H0_INDEX)].set(1.0)
    return hzd.linear_phase_output_jacobian(H0, _THETA_Q, dh)


def decoupling(m, vc, phase, z, terms=None):
    """(y, y-dot, LgLfh (4, 4), Lf^2 h (4,)) at the stance state z; ``terms`` = (D_s, H_s, B_s)
    when the caller has them."""
    qs, qds = z[:6], z[6:]
    th, thd = vcm.theta(qs), vcm.theta_rate(qds)
    h, dh, ddh = vcm.desired_derivatives(vc, phase, th)
    D, H, B = wk.stance_terms(m, qs, qds) if terms is None else terms
    Jy = output_jacobian(dh)
    y = vcm.controlled(qs) - h
    yd = Jy @ qds
    A, lf2 = hzd.affine_decoupling(Jy, -ddh * thd**2, D, H, B)
    return y, yd, A, lf2


def iolin(m, vc, phase, z, g: Gains, decentralized: bool = False, terms=None):
    """Eq. 42 (decentralised: diagonal decoupling matrix)."""
    y, yd, A, lf2 = decoupling(m, vc, phase, z, terms)
    v = hzd.outer_loop(y, yd, g.eps, g.kp_io, g.kd_io)
    if decentralized:
        # u*(x_s) of eq. 32 in full; only the feedback sees the diagonal (each output's own motor)
        act = jnp.asarray(ACTUATOR_OF_OUTPUT)
        u = hzd.feedforward_input(A, lf2) + jnp.zeros(4).at[act].set(v / jnp.diag(A[:, act]))
    else:
        u = hzd.linearizing_input(A, lf2, v)
    return jnp.clip(u, -g.limit, g.limit)


def outer_loop_stiffness(A, g: Gains):
    """(stiffness N m/rad, damping N m s/rad), each (4,): the torque that eq. 42's outer loop
    puts on each output's own motor (:data:`ACTUATOR_OF_OUTPUT`) per rad, and per rad/s, of
    that output's error, given the decoupling matrix A = LgLfh (4, 4): (Kp/eps^2, Kd/eps)
    times that motor's entry of A^-1. The outer loop places the same poles on every output,
    so an output of small effective inertia (a motor angle) gets a soft loop; these are the
    figures to set beside pdff's kp, kd (times its signs)."""
    act = jnp.asarray(ACTUATOR_OF_OUTPUT)
    w = jnp.linalg.inv(A)[act, jnp.arange(4)]
    return g.kp_io / g.eps**2 * w, g.kd_io / g.eps * w


def feedforward(g: Gains, phase, th):
    """u*(theta, beta) of eq. 43 (phase saturated outside its interval as the constraints are)."""
    a, b = g.beta_bounds[phase, 0], g.beta_bounds[phase, 1]
    return bz.bezier(g.beta[phase], vcm.saturated_phase(th, a, b))


def pd_feedforward(phase, y, yd, th, g: Gains):
    """Eq. 43 from the outputs (y, y-dot) and theta."""
    pd = -(g.kp * y + g.kd * yd) * g.signs
    u = feedforward(g, phase, th) + jnp.zeros(4).at[jnp.asarray(ACTUATOR_OF_OUTPUT)].set(pd)
    return jnp.clip(u, -g.limit, g.limit)


def pdff(m, vc, phase, z, g: Gains):
    y, yd = vcm.outputs(vc, phase, z[:6], z[6:])
    return pd_feedforward(phase, y, yd, vcm.theta(z[:6]), g)


def control(kind: str, m, vc, phase, z, g: Gains, terms=None):
    """The torque of controller ``kind`` (one of :data:`KINDS`) at the stance state z."""
    if kind == "pdff":
        return pdff(m, vc, phase, z, g)
    return iolin(m, vc, phase, z, g, decentralized=(kind == "decentralized"), terms=terms)


def regress_feedforward(thetas, us, phases, bounds, order: int = 5):
    """beta (4, 4, order+1): least-squares Bézier fit of u* against theta in each sub-phase
    (samples thetas (N,), us (N, 4), phases (N,); bounds (4, 2) the phase domains)."""
    thetas, us, phases, bounds = (np.asarray(a) for a in (thetas, us, phases, bounds))
    beta = np.zeros((4, 4, order + 1))
    for p in range(4):
        sel = phases == p
        s = (thetas[sel] - bounds[p, 0]) / (bounds[p, 1] - bounds[p, 0])
        basis = np.asarray(bz.bernstein(order, jnp.asarray(s)))
        beta[p] = np.linalg.lstsq(basis, us[sel], rcond=None)[0].T
    return beta


@jax.jit
def _decoupling_matrix(m, vc, z):
    return decoupling(m, vc, vcm.MC, z)[2]


def output_signs(m, vc, z):
    """Sign of each output's own motor in the decoupling matrix at z (phase MC)."""
    A = _decoupling_matrix(m, vc, z)
    return np.sign(np.asarray(A)[np.arange(4), list(ACTUATOR_OF_OUTPUT)])


#: eq. 42's eps (the paper gives none): the largest at which the outer loop is nowhere softer than
#: PD + FF, i.e. puts at least pdff's kp on every output's own motor (:func:`outer_loop_stiffness`)
#: at every shipped gait's touchdown state. The stance leg-shape motor binds (a motor angle of
#: about 1e-3 kg m^2 effective inertia; 3.5 N m/rad needs 0.01738-0.01741 on the five gaits); the
#: other outputs then get 1.6-6.2 times pdff's stiffness. At the earlier 0.05 that motor saw an
#: eighth of pdff's (measured, 13-DoF plant, paper-nominal, 100 steps on the encoders: stance leg
#: shape 12.2 deg rms against pdff's 6.8; at this eps 2.2). The base of :data:`EPS_OUTPUTS`.
EPS = 0.0173

#: the grid :data:`EPS_OUTPUTS` is chosen on: EPS * 2^(-k/2), k = 0 ... 8 (EPS down to EPS / 16)
EPS_GRID = tuple(EPS * 2.0 ** (-k / 2) for k in range(9))
#: how much an output's stiffer loop may raise the walk's c_mt over the loop at EPS
EPS_CMT_RISE = 0.10
#: grid steps of margin: the chosen eps's next stiffer grid value must meet the c_mt bound too
EPS_MARGIN = 1

#: eq. 42's eps per output (mLS_st, LA_sw, mLS_sw, Tor). The outer loop gives every output of one
#: eps the same poles, and eq. 42 does not ask that (Kp/eps^2 and Kd/eps may differ per output;
#: the paper gives none). Each output's eps is the stiffest value of :data:`EPS_GRID` at which the
#: 13-DoF plant on the experiments' gait (paper-575, encoders at 1 kHz) keeps its c_mt within
#: EPS_CMT_RISE of the loop at EPS under eq. 42 and its decentralised form, with the other
#: outputs at EPS and EPS_MARGIN grid steps of margin: a stiffer loop than that turns the
#: quantised, filtered rate estimate into motor work (the drives chatter) before it tracks better.
#: Measured (:func:`bipedlab.robots.mabel.walking.experiments.eps_selection`, 30 steps, two-core
#: Xeon; c_mt at EPS 0.264 eq. 42 / 0.189 decentralised): the stance leg-shape output keeps c_mt
#: within 1 % from EPS down to EPS / 5.7 = 0.0031, rises +3.4 % / +5.0 % at 0.0022 and chatters at
#: 0.0015 (drives saturated 43 % of the samples, c_mt x 7): 0.0031 with one step of margin. The
#: swing leg angle, swing leg shape and torso raise c_mt by 11 / 8 / 25 % (eq. 42) and 7 / 7 / 15 %
#: (decentralised) at their first stiffer value, EPS / 1.41, and by 20 % or more at the next:
#: they keep EPS. (At a 5 % bound the decentralised form's +5.0 % at 0.0022 sits on the bound:
#: 10 % keeps every decision one that a run-to-run change of a few tenths of a percent cannot
#: turn.) The stance leg-shape output is a motor angle on a loaded leg; the swing leg's motors
#: and the torso's (through the stance leg-angle motor) excite the cables and the ground.
EPS_OUTPUTS = (EPS_GRID[5], EPS, EPS, EPS)


def default_gains(beta, bounds, signs, limit=None) -> Gains:
    """PD gains (tuned on the nominal gait: stable Poincaré map, small tracking error) and the
    eq. 42 gains eps = :data:`EPS_OUTPUTS` (per output), Kp = 1, Kd = 2 (a double pole at -1/eps
    on each output)."""
    f = lambda v: jnp.asarray(v, float)  # noqa: E731
    lim = f([30.0, 55.0, 30.0, 55.0] if limit is None else limit)
    return Gains(kp=f([3.5, 45.0, 3.5, 60.0]), kd=f([0.05, 1.2, 0.05, 3.0]), eps=f(EPS_OUTPUTS), kp_io=f(1.0),
                 kd_io=f(2.0), beta=f(beta), beta_bounds=f(bounds), signs=f(signs), limit=lim)
