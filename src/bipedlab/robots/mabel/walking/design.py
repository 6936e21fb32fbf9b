"""Gait design for MABEL on the compliant hybrid zero dynamics (compliant-HZD paper, Section
III-D/E and Appendix B).

Decision variables (Table IV), with motor angles divided by the leg-shape gear 31.42 so that
every entry is O(1) (:data:`NAMES`): the pre-impact configuration (theta-, q_Bsp_st-,
q_LA_sw-, q_mLS_sw-, q_Tor-, q_mLS_st-) and rates (thetadot-, qdot_Bsp_st-, qdot_LA_sw-,
qdot_mLS_sw-; the stance motor leg shape and the torso are at rest before impact), the end of
the stance-compression phase theta_sc, and the free Bézier coefficients alpha_2, alpha_3 of the
stance-injection, torso and two swing constraints. The algorithm of Appendix B follows:

1. the pre-impact state z- (the stance motor leg shape is a decision variable here, with
   "swing toe on the ground" an equality constraint, instead of a Newton search inside);
2. z+ = Delta_s->s(z-), theta+ and thetadot+;
3. theta_mc and theta_si at 5 % and 70 % of [theta+, theta-]; the end coefficients of every
   Bézier from z+ and z-, so the post-impact state lies on the zero-dynamics manifold;
4. the zero dynamics integrated through MC, SC (to theta_sc), SI and SD (to theta-).

Equalities: periodicity (b, thetadot, bdot at theta- equal the decision values), the spring at
5 deg at theta_sc, the swing toe on the ground at z-, the walking speed. Inequalities:
thetadot > 0, positive normal force and |F_T / F_N| <= 0.6 along the step, the swing toe above
the ground between lift-off and touchdown, the lifting toe leaving the ground, the swing toe landing at >= 0.1 m/s, the spring
decompressing at theta_sc, the sub-phases in order, the spring compressed by at least BSP_MIN after MC, swing leg angle
<= 220 deg and stance leg angle >= 140 deg, the torso's range of travel over the step at most 5 deg (Appendix B; a soft range
on the RK4 nodes, within 0.2 deg of the range), the motor torques within 30 / 55
N m, and optionally a minimum step length.

Costs: ``torque``, the integral of |u|^2 dt per step length (eq. 39); ``cmt``, the positive
motor work per weight and distance (eqs. 40-41). SciPy's SLSQP with exact forward-mode
Jacobians solves the NLP.
"""
from __future__ import annotations

import dataclasses
import functools
import time

import jax
import jax.numpy as jnp
import numpy as np
import scipy.optimize

from bipedlab.robots.mabel.walking import catalog
from bipedlab.robots.mabel.walking import constraints as vcm
from bipedlab.robots.mabel.walking import controllers as ctl
from bipedlab.robots.mabel import tables as tb
from bipedlab.robots.mabel.walking import stance as wk
from bipedlab.robots.mabel.walking import zero_dynamics as zd

G_LS = tb.GEAR_LS
NAMES = ("theta-", "bsp-", "la_sw-", "mls_sw-/G", "tor-", "mls_st-/G", "thetadot-", "bspdot-",
         "la_sw_dot-", "mls_sw_dot-/G", "theta_sc", "a_si_2/G", "a_si_3/G", "a_tor_2", "a_tor_3",
         "a_la_2", "a_la_3", "a_mls_2/G", "a_mls_3/G")
#: RK4 steps per sub-phase (MC, SC, SI, SD)
NODES = (6, 16, 16, 12)
MU = 0.6
#: the spring must cross the 5 deg trigger decompressing at least this fast (rad/s), so the
#: SC -> SI event is transversal
SPRING_RATE_MARGIN = 0.5
#: the stance spring stays this far off its hard stop after MC (rad), as in Fig. 6
BSP_MIN = 0.03
#: the swing toe meets the ground descending at least this fast (m/s): a transversal touchdown
TOUCHDOWN_RATE = 0.1
#: range of travel of the torso over the step (Appendix B, "less than 5 deg"), rad
TORSO_TRAVEL = float(np.deg2rad(5.0))
#: sharpness of the soft range in :func:`torso_travel_margin`, 1/rad
TORSO_SHARPNESS = 2000.0
#: default upper bound on the step length (m): inactive unless a caller lowers it
MAX_STEP = 2.0


@dataclasses.dataclass(frozen=True)
class Design:
    """A designed fixed point: decision vector x, the nominal constraints, the pre- and
    post-impact states, and its figures."""

    x: np.ndarray
    vc: vcm.Constraints
    z_minus: np.ndarray
    z_plus: np.ndarray
    figures: dict


def pre_impact_state(x):
    th, b, la, ms, tor, mst, thd, bd, lad, msd = (x[i] for i in range(10))
    qs = jnp.stack([jnp.pi - th - tor, mst * G_LS, b, la, ms * G_LS, tor])
    qds = jnp.stack([-thd, 0.0 * thd, bd, lad, msd * G_LS, 0.0 * thd])
    return jnp.concatenate([qs, qds])


def _ends(q0, v0, q1, v1, free, w, thd0, thd1):
    """Bézier coefficients with value/rate q0, v0 at the start and q1, v1 at the end of a
    theta-interval of width w (rates in time, divided by thetadot)."""
    M = vcm.ORDER
    return jnp.stack([q0, q0 + v0 * w / (M * thd0), free[0], free[1], q1 - v1 * w / (M * thd1), q1])


def constraints(x, z_plus):
    """The nominal virtual constraints implied by the decision vector and z+ = Delta(z-)."""
    zm = pre_impact_state(x)
    qp, qdp, qm, qdm = z_plus[:6], z_plus[6:], zm[:6], zm[6:]
    thp, thdp = vcm.theta(qp), vcm.theta_rate(qdp)
    thm, thdm = x[0], x[6]
    width = thm - thp
    th_mc, th_si = thp + 0.05 * width, thp + 0.7 * width
    mls_mc, rest = vcm.mc_piece(qp[1], qdp[1], thdp, thp, th_mc)
    mls_si = jnp.stack([rest, rest, x[11] * G_LS, x[12] * G_LS, qm[1], qm[1]])
    tor = _ends(qp[5], qdp[5], qm[5], 0.0, x[13:15], th_si - thp, thdp, thdm)
    la = _ends(qp[3], qdp[3], qm[3], qdm[3], x[15:17], width, thdp, thdm)
    ms = _ends(qp[4], qdp[4], qm[4], qdm[4], x[17:19] * G_LS, width, thdp, thdm)
    return vcm.Constraints(thp, thm, th_mc, x[10], th_si, mls_mc, rest, mls_si, qm[1], tor, la, ms,
                           jnp.zeros((3, 2)))


def node_grid(vc, nodes=NODES):
    """(thetas, steps, phases) of the fixed RK4 grid over the four sub-phases, and the index
    of the first node of each sub-phase (plus the end)."""
    bounds = (vc.theta_plus, vc.theta_mc, vc.theta_sc, vc.theta_si, vc.theta_minus)
    th, hs, ph = [], [], []
    for p, n in enumerate(nodes):
        h = (bounds[p + 1] - bounds[p]) / n
        th.append(bounds[p] + h * jnp.arange(n))
        hs.append(jnp.full(n, h))
        ph.append(jnp.full(n, p))
    starts = np.concatenate([[0], np.cumsum(nodes)])
    return jnp.concatenate(th), jnp.concatenate(hs), jnp.concatenate(ph), starts


def run_step(m, vc, w0, nodes=NODES):
    """The zero dynamics through one step with theta_sc and theta- fixed by vc; returns
    (final w, node samples (theta, w, u, q_s, qd_s), first node of each sub-phase)."""
    th, hs, ph, starts = node_grid(vc, nodes)
    wf, (ths, ws, (us, qss, qdss)) = zd.integrate_nodes(zd.zero_dynamics(m, vc), w0, th, hs, ph)
    return wf, (ths, ws, us, qss, qdss), starts


def evaluate(m, x, speed, eta=1.0, min_step=0.0, max_step=MAX_STEP, clearance=0.0):
    """(figures, equalities, inequalities) of the decision vector x (all JAX). ``clearance``
    (m): the swing toe at least ``clearance * 4 s (1 - s)`` above the ground at every interior
    node, s the step's fraction of theta (0 the paper's bound: above the ground)."""
    zm = pre_impact_state(x)
    tr = wk.impact(m, zm, eta)
    zp = tr.z_plus
    vc = constraints(x, zp)
    w0 = jnp.concatenate([jnp.stack([zp[2], vcm.theta_rate(zp[6:]), zp[8]]), jnp.zeros(5)])
    wf, (thetas, ws, us, qss, qdss), starts = run_step(m, vc, w0)
    b_sc = ws[starts[2]]  # w at the end of SC
    step_length = tr.step[0]
    T = wf[3]
    v = step_length / T
    weight = zd.robot_mass(m) * 9.81
    zs = jnp.concatenate([qss, qdss], 1)
    grf = jax.vmap(lambda z, u: wk.ground_reaction(m, z, u))(zs, us)
    toe = jax.vmap(lambda z: wk.swing_toe(m, z)[1])(zs)
    n = toe.shape[0]
    interior = (jnp.arange(n) >= 2) & (jnp.arange(n) <= n - 2)
    frac = (thetas - vc.theta_plus) / (vc.theta_minus - vc.theta_plus)
    toe_rate = jax.jvp(lambda q: wk.swing_toe(m, jnp.concatenate([q, zm[6:]]))[1], (zm[:6],), (zm[6:],))[1]
    eq = jnp.stack([
        (wf[0] - x[1]) * 10, wf[1] - x[6], (wf[2] - x[7]) * 0.2,
        (b_sc[0] - vcm.SPRING_TRIGGER) * 10, wk.swing_toe(m, zm)[1] * 10, v - speed])
    ineq = jnp.concatenate([
        ws[:, 1] - 0.1,
        grf[:, 1] / weight - 0.05,
        (MU * grf[:, 1] - jnp.abs(grf[:, 0])) / weight,
        jnp.where(interior, (toe - clearance * 4.0 * frac * (1.0 - frac)) * 20, 1.0),
        jnp.stack([tr.lift_velocity[1] * 5, (-toe_rate - TOUCHDOWN_RATE) * 5, tr.toe_impulse[1],
                   MU * tr.toe_impulse[1] - jnp.abs(tr.toe_impulse[0]),
                   -b_sc[2] - SPRING_RATE_MARGIN, (vc.theta_sc - vc.theta_mc) * 10, (vc.theta_si - vc.theta_sc) * 10,
                   zp[8] * 0.2]),
        (ws[NODES[0]:, 0] - BSP_MIN) * 10,
        (jnp.deg2rad(220.0) - qss[:, 3]) * 5, (qss[:, 0] - jnp.deg2rad(140.0)) * 5,
        (1.0 - jnp.abs(us) / m.drive.torque_limit).ravel(),
        jnp.stack([(step_length - min_step) * 5, (max_step - step_length) * 5]),
        jnp.stack([torso_travel_margin(qss, starts, zm) * 5]),
    ])
    figures = dict(
        speed=v, step_length=step_length, period=T, torque_cost=wf[4] / step_length,
        cmt=wf[5] / (weight * step_length), neg_work_motor=wf[6], neg_work_spring=wf[7],
        peak_torques=jnp.max(jnp.abs(us), 0), theta_plus=vc.theta_plus)
    return figures, eq, ineq, dict(vc=vc, z_plus=zp, z_minus=zm, thetas=thetas, w=ws, u=us, z=zs,
                                   grf=grf, toe=toe, transition=tr)


def torso_travel_margin(qss, starts, zm):
    """Appendix B's "range of travel of torso less than 5 deg" as one smooth inequality:
    TORSO_TRAVEL minus a soft range (log-sum-exp maximum minus minimum, sharpness
    TORSO_SHARPNESS) of the torso angles sampled on the step (the nodes up to theta_si, after
    which the torso constraint holds it at q_Tor-, and the pre-impact state). The soft range
    exceeds the range by at most 2 ln(n) / TORSO_SHARPNESS (0.2 deg for the 39 samples), so the
    constraint is met with that margin at most; a pairwise form (every pair of samples within 5
    deg) is exact but degenerate at its optimum, where SLSQP's line search stalls."""
    tor = jnp.concatenate([qss[:starts[3], 5], zm[5:6]])
    k = TORSO_SHARPNESS
    soft_range = (jax.nn.logsumexp(k * tor) + jax.nn.logsumexp(-k * tor)) / k
    return TORSO_TRAVEL - soft_range


def initial_guess(speed: float = 0.8) -> np.ndarray:
    """A hand-set starting point: legs +-0.3 rad about the vertical, knees bent ~0.3 rad."""
    th = 0.30
    return np.array([
        th, 0.03, np.pi + th + 0.02, 0.10, -0.02, 0.094, 1.25 * speed / 0.8, -0.3, 0.2, -0.1,
        -0.03, 0.10, 0.10, -0.02, -0.02, np.pi - 0.1, np.pi + 0.1, 0.5, 0.5])


#: design models: ``full``, the walking model with motor friction (Table V of the
#: identification paper) and spring damping in the zero dynamics (the shipped gaits were
#: designed with it); ``paper``, the HZD paper's design model: rigid cables and no drivetrain
#: dissipation. The paper's zero dynamics (eq. 36) carries the spring torque and no friction
#: term, it gives no friction or damping coefficients, its Section VI-C names friction (with
#: cable stretch) as what raised the realised c_mt above the designed one, and the spring
#: damping was identified later, from the hopping experiments (identification paper, Table VI).
DESIGN_MODELS = catalog.DESIGN_MODELS


def design_model(m=None, kind: str = "full"):
    """The walking model used for design: the hard stop's stiffening and damping are left out
    (the spring stays compressed along a designed step, an inequality constraint), so a trial
    point that pushes the pulley into the stop does not make the zero dynamics stiff; ``kind``
    ``paper`` also leaves out motor friction and spring damping (:data:`DESIGN_MODELS`)."""
    if kind not in DESIGN_MODELS:
        raise ValueError(f"design model must be one of {', '.join(DESIGN_MODELS)}, got {kind!r}")
    m = wk.without_stop(wk.walking_model() if m is None else m)
    return wk.without_losses(m) if kind == "paper" else m


def _scalar_cost(fig, cost):
    return fig["torque_cost"] / 100.0 if cost == "torque" else fig["cmt"] * 20.0


BOUNDS = ((0.1, 0.6), (0.03, 0.3), (np.pi, np.pi + 0.8), (0.0, 0.6), (-0.3, 0.3), (-0.1, 0.6), (0.3, 4.0),
          (-5.0, 5.0), (-4.0, 4.0), (-4.0, 4.0), (-0.5, 0.5), (-0.2, 0.8), (-0.2, 0.8), (-0.4, 0.4),
          (-0.4, 0.4), (np.pi - 0.9, np.pi + 0.9), (np.pi - 0.9, np.pi + 0.9), (-0.1, 1.2), (-0.1, 1.2))


def _compiled(cost):
    """One compiled call giving cost, equalities, inequalities and their Jacobians for a
    (model, x, speed); the speed is traced, so a sweep compiles once per cost."""
    if cost not in _COMPILED:
        def parts(m, x, speed, window):
            fig, eq, ineq, _ = evaluate(m, x, speed, min_step=window[0], max_step=window[1], clearance=window[2])
            y = jnp.concatenate([_scalar_cost(fig, cost)[None], eq, ineq])
            return y, y

        def value_and_jacobian(m, x, speed, window):  # the value is the jvp's primal: traced once
            J, y = jax.jacfwd(parts, argnums=1, has_aux=True)(m, x, speed, window)
            return y, J

        _COMPILED[cost] = jax.jit(value_and_jacobian)
    return _COMPILED[cost]


_COMPILED: dict = {}


def _functions(m, speed, cost, window):
    """Cost, equalities, inequalities and Jacobians as SciPy callbacks, memoised on x."""
    both = _compiled(cost)
    memo = {}

    def get(x):
        key = np.asarray(x, float).tobytes()
        if key not in memo:
            memo.clear()
            v, j = both(m, jnp.asarray(x, float), jnp.asarray(speed, float), jnp.asarray(window, float))
            memo[key] = (np.asarray(v), np.asarray(j))
        return memo[key]

    ne = 6
    return (lambda x: get(x)[0][0], lambda x: get(x)[1][0], lambda x: get(x)[0][1:1 + ne],
            lambda x: get(x)[1][1:1 + ne], lambda x: get(x)[0][1 + ne:], lambda x: get(x)[1][1 + ne:])


def _problem(speed, cost, model=None, window=(0.0, MAX_STEP, 0.0), kind="full"):
    return _functions(design_model(model, kind), speed, cost, window)


def compile_problem(speed: float, cost: str, model=None, kind: str = "full") -> None:
    """Compile the NLP's functions (one call at the hand-set guess), so that a later
    :func:`optimize` measures the solve alone (the model is an argument of the compiled
    functions, so every design model shares the program)."""
    _problem(speed, cost, model, kind=kind)[0](initial_guess(speed))


def optimize(speed: float = 0.8, cost: str = "torque", x0=None, maxiter: int = 500, ftol: float = 1e-9,
             model=None, min_step: float = 0.0, max_step: float = MAX_STEP, kind: str = "full",
             clearance: float = 0.0):
    """Solve the gait-design NLP from x0 (default: :func:`initial_guess`) on the design model
    ``kind`` (:data:`DESIGN_MODELS`), the step length kept within [min_step, max_step] (m;
    equal bounds prescribe it), the swing toe's mid-step clearance at least ``clearance`` (m,
    :func:`evaluate`); returns (Design, info) with info: success, message,
    iterations, wall_s, eq_residual, ineq_violation."""
    m = design_model(model, kind)
    f, fj, e, ej, i, ij = _problem(speed, cost, model, (min_step, max_step, clearance), kind)
    x0 = initial_guess(speed) if x0 is None else np.asarray(x0, float)
    t0 = time.perf_counter()
    x0 = feasible_start(f, e, ej, i, ij, x0)
    scale = min(1.0, 0.05 / max(np.linalg.norm(fj(x0)), 1e-12))  # a first SLSQP step of modest length
    res = scipy.optimize.minimize(
        lambda x: scale * f(x), x0, jac=lambda x: scale * fj(x), method="SLSQP", bounds=BOUNDS,
        constraints=[dict(type="eq", fun=e, jac=ej), dict(type="ineq", fun=i, jac=ij)],
        options=dict(maxiter=maxiter, ftol=ftol))
    wall = time.perf_counter() - t0
    design = make_design(m, res.x, speed)
    info = dict(success=bool(res.success), message=str(res.message), iterations=int(res.nit), wall_s=wall,
                eq_residual=float(np.max(np.abs(e(res.x)))), ineq_violation=float(max(0.0, -np.min(i(res.x)))))
    return design, info


def feasible_start(f, e, ej, i, ij, x0, weight: float = 3.0):
    """Phase one: a trust-region least-squares solve of the equalities and the inequality
    violations (SciPy's least_squares, bounded), so that SLSQP starts where its linearised
    constraints are compatible. Returns x0 unchanged when it is already feasible."""
    def r(x):
        return np.concatenate([e(x), weight * np.minimum(i(x), 0.0)])

    def jac(x):
        active = (i(x) < 0.0)[:, None]
        return np.concatenate([ej(x), weight * np.where(active, ij(x), 0.0)])

    if np.max(np.abs(r(x0))) < 1e-9:
        return x0
    lo, hi = np.array(BOUNDS).T
    res = scipy.optimize.least_squares(r, np.clip(x0, lo + 1e-9, hi - 1e-9), jac=jac, bounds=(lo, hi),
                                       xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=200)
    return res.x


@jax.jit
def _evaluate_jit(m, x, speed):
    return evaluate(m, x, speed)


def make_design(m, x, speed) -> Design:
    fig, eq, ineq, data = _evaluate_jit(m, jnp.asarray(x), jnp.asarray(speed, float))
    figures = {k: np.asarray(v).tolist() for k, v in fig.items()}
    wn, ws = figures["neg_work_motor"], figures["neg_work_spring"]
    figures["negative_work_fraction_spring"] = ws / (wn + ws) if wn + ws > 0 else 0.0
    return Design(np.asarray(x), jax.tree_util.tree_map(np.asarray, data["vc"]), np.asarray(data["z_minus"]),
                  np.asarray(data["z_plus"]), figures)


#: RK4 steps per sub-phase for the u* regression of eq. 43
FINE_NODES = (16, 48, 48, 40)


@functools.partial(jax.jit, static_argnames="nodes")
def _orbit_samples(m, vc, zp, nodes):
    w0 = jnp.concatenate([jnp.stack([zp[2], vcm.theta_rate(zp[6:]), zp[8]]), jnp.zeros(5)])
    return run_step(m, vc, w0, nodes)[1]


def orbit(m, design: Design, nodes=FINE_NODES):
    """The designed orbit sampled on a fine theta grid: (thetas, w, u*, z, phases, bounds)
    (one compiled program per node grid; the model and the design are its arguments)."""
    vc = jax.tree_util.tree_map(jnp.asarray, design.vc)
    zp = jnp.asarray(design.z_plus)
    th, w, u, qs, qds = _orbit_samples(m, vc, zp, tuple(nodes))
    phases = np.repeat(np.arange(4), nodes)
    bounds = np.array([[vc.theta_plus, vc.theta_mc], [vc.theta_mc, vc.theta_sc], [vc.theta_sc, vc.theta_si],
                       [vc.theta_si, vc.theta_minus]], float)
    return np.asarray(th), np.asarray(w), np.asarray(u), np.concatenate([np.asarray(qs), np.asarray(qds)], 1), phases, bounds


def controller_gains(m, design: Design, limit=None):
    """Controller parameters for a design: u* regressed on Béziers per sub-phase (eq. 43),
    the PD signs, the default gains."""
    th, _, u, z, phases, bounds = orbit(m, design)
    beta = ctl.regress_feedforward(th, u, phases, bounds)
    signs = ctl.output_signs(m, jax.tree_util.tree_map(jnp.asarray, design.vc), jnp.asarray(design.z_plus))
    return ctl.default_gains(beta, bounds, signs, limit)


def torso_travel(m, design: Design) -> float:
    """Range of the torso angle q_Tor over the designed step (rad): the orbit sampled on the
    fine grid, and the pre-impact state."""
    z = orbit(m, design)[3]
    tor = np.concatenate([z[:, 5], [np.asarray(design.z_minus)[5]]])
    return float(np.max(tor) - np.min(tor))


def section_state(m, design: Design):
    """The designed orbit's stance state at theta_si (the Poincaré section S_si->sd) and the
    zero-dynamics coordinates (q_Bsp, thetadot, qdot_Bsp) there."""
    th, w, _, z, phases, _ = orbit(m, design)
    k = int(np.argmax(phases == vcm.SD))
    return z[k], w[k, :3]
