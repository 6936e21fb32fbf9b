"""The hybrid-zero-dynamics study of any point-foot planar biped: gait design, closed-loop
walking and Poincaré analysis, with one record format for every robot.

A robot enters as an :class:`HZDStudy`: its stance model (one foot pinned, the leg swap), its
virtual constraints' output matrix H0 and phase vector c, and its name for the records.
``design``: a fixed-point gait at a given speed from a given initial decision vector (SLSQP
on the zero dynamics, exact JAX derivatives), then its Poincaré analysis. ``walk``:
closed-loop steps from the (perturbed) fixed point under I/O linearisation or PD with u*
feedforward, events located exactly. The records' keys are the same for every robot.

Stability by design (:func:`choose_controller`). The restricted map's eigenvalue can be bounded
inside the design (``max_eigenvalue``, :mod:`bipedlab.gait.optimize`); the full closed loop's
map has it as its dominant eigenvalue only when the outputs converge fast enough (eq. 42 with eps
small: Morris and Grizzle 2009, Cor. 2). So after a design the I/O-linearising controller's eps
is searched, from the study's own down :data:`EPS_GRID` with its PD gains kp, kd kept (the
outputs' error poles a double root at -1/eps for kp = 1, kd = 2), the full map's Poincaré
Jacobian evaluated at each (one compiled program, the gains traced), and the first, the gentlest,
eps whose dominant |eigenvalue| is within :data:`MATCH` of the restricted map's is chosen; when
none is, the one of smallest |eigenvalue|, with the reason in the record. A gait whose closed
loop from the fixed point does not return to it (a swing point grazing the ground mid-step
touches down early) is not a fixed point of any gain: the search stops there and says so. The
gait file carries the chosen eps, kp, kd; ``walk`` uses them, and refuses a gait whose full map
is unstable under its controller (:class:`UnstableGait`) unless asked to walk it anyway.
"""
from __future__ import annotations

import dataclasses
import math
import time
from typing import Mapping

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.gait import gaitfile
from bipedlab.gait import optimize as go
from bipedlab.gait import walking as gw
from bipedlab.mechanics.dynamics import total_mass
from bipedlab.mechanics.stance import Stance
from bipedlab.outputs import json_safe
from bipedlab.sim.rollout import NONFINITE, STATUS_NAMES

#: Solver tolerance (SLSQP ftol) of the designs.
TOL = 1e-10
#: RK4 nodes over a step of the zero dynamics.
NODES = 40
#: The two closed loops: I/O linearisation (eq. 42 gains) and PD with u* feedforward.
CONTROLLERS = {
    "iolin": gw.Controller("iolin", eps=0.1, kp=1.0, kd=2.0),
    "pd": gw.Controller("pd", kp=400.0, kd=20.0),
}
#: The eps searched for the I/O-linearising controller, gentlest first: those from the study's own
#: eps down (0.1 and below for the default controller; see the module docstring).
EPS_GRID = (0.4, 0.3, 0.2, 0.15, 0.1, 0.07, 0.05, 0.035, 0.025, 0.018, 0.0125, 0.01)
#: How close the full map's dominant |eigenvalue| must come to the restricted map's.
MATCH = 0.05
#: Largest max |P(z*) - z*| (rad, rad/s) of a closed-loop fixed point: the closed loop (RK4 in time,
#: 1 ms) leaves the design's fixed point (RK4 in the phase, NODES steps) by 3e-7 on the shipped
#: planar test gait and 1.3e-4 on a 0.7 m/s gait of a heavier five-body model, whatever the time
#: step; a gait whose swing foot grazes the ground mid-step is off by 1-30.
PERIODIC_TOL = 1e-2
#: The remedies a design's controller note names (:func:`remedy_of` decides which, from the
#: figures): more swing clearance for a gait whose swing point reaches the ground early, a bound
#: on the restricted map's eigenvalue for a gait whose zero dynamics are themselves unstable.
REMEDY_CLEARANCE = "design it with --clearance M"
REMEDY_BOUND = "bound it in the design with --max-eigenvalue R"
#: A retried design's clearance, times the first design's (:func:`design_retrying`).
CLEARANCE_RETRY_FACTOR = 2.0
#: The bound on the restricted map's |eigenvalue| a retried design takes when the first design's
#: zero dynamics are unstable: a 1 % offset shrinks to a tenth within 11 steps.
RETRY_MAX_EIGENVALUE = 0.8


class UnstableGait(ValueError):
    """A walk asked of a gait whose full closed-loop Poincaré map is unstable (one line)."""


@dataclasses.dataclass(frozen=True)
class HZDStudy:
    """robot: the name in records and gait files; stance: the stance model; H0 (m, n) and c
    (n,): outputs and phase on the stance coordinates; torque_limits: (m,) N m per input, or
    None (then the design has no torque constraint)."""

    robot: str
    stance: Stance
    H0: np.ndarray
    c: np.ndarray
    order: int = 5
    nodes: int = NODES
    tol: float = TOL
    controllers: Mapping[str, gw.Controller] = dataclasses.field(default_factory=lambda: dict(CONTROLLERS))
    torque_limits: tuple | None = None


def problem(study: HZDStudy, speed: float, cost: str, max_eigenvalue: float | None = None,
            clearance: float = 0.0) -> go.GaitProblem:
    """The gait design problem; ``max_eigenvalue``: bound on the restricted map's |eigenvalue|
    (None: none); ``clearance``: m, the swing point's clearance at mid-step (0: none)."""
    return go.GaitProblem(study.stance, study.H0, study.c, order=study.order, nodes=study.nodes, speed=speed,
                          cost=cost, torque_limits=study.torque_limits, max_eigenvalue=max_eigenvalue,
                          clearance=clearance)


def _gains(ctrl: gw.Controller) -> dict:
    return dict(eps=float(ctrl.eps) if ctrl.kind == "iolin" else None, kp=float(ctrl.kp), kd=float(ctrl.kd))


def _full_map(study: HZDStudy, ctrl: gw.Controller, vc, z_minus) -> dict:
    """The closed loop's step from z- and its Poincaré Jacobian's eigenvalues (largest first)."""
    s, J = gw.poincare_step_program(vc, study.stance, ctrl, jnp.asarray(z_minus))
    ev = np.linalg.eigvals(np.asarray(J))
    ev = ev[np.argsort(-np.abs(ev))]
    ok = int(s.status) == 0
    residual = float(np.max(np.abs(np.asarray(s.z_minus) - np.asarray(z_minus)))) if ok else math.inf
    return dict(ev=ev, residual=residual, status=STATUS_NAMES[int(s.status)], duration=float(s.duration))


def _stable(full: dict) -> bool:
    return bool(full["residual"] <= PERIODIC_TOL and np.abs(full["ev"][0]) < 1.0)


def remedy_of(controller: str, periodicity_error: float | None, restricted_eigenvalue: float) -> str | None:
    """The design option that mends a closed loop with these figures: ``"clearance"`` when the
    step from the fixed point returns elsewhere (max |P(z*) - z*| finite and over
    :data:`PERIODIC_TOL`: the swing point reaches the ground early), ``"max_eigenvalue"`` when
    under eq. 42 it is periodic but the restricted map is itself unstable (no output convergence
    mends that), else None (a step that ends in no touchdown, None error, names no remedy)."""
    err = math.inf if periodicity_error is None else float(periodicity_error)
    if math.isfinite(err) and err > PERIODIC_TOL:
        return "clearance"
    if controller == "iolin" and err <= PERIODIC_TOL and abs(restricted_eigenvalue) >= 1.0:
        return "max_eigenvalue"
    return None


def _not_periodic(full: dict) -> str:
    if full["status"] != "ok":
        return f"the closed loop from the fixed point does not reach the next touchdown ({full['status']})"
    return (f"the closed loop from the fixed point does not return to it (touchdown after {full['duration']:.4f} s, "
            f"max |P(z*) - z*| {full['residual']:.2g}): the swing point reaches the ground before the end of the "
            f"step; no controller gain acts on the zero dynamics, so none helps ({REMEDY_CLEARANCE})")


def choose_controller(study: HZDStudy, vc, z_minus, controller: str = "iolin", rho: float | None = None):
    """(the controller, the full map's analysis under it, the eps searched [(eps, |eig|)], a
    one-line note on the choice). For 'iolin' the search of the module docstring; for 'pd' the
    study's gains, unsearched."""
    base = study.controllers[controller]
    st = study.stance
    if rho is None:
        rho = gw.restricted_eigenvalue(vc, st, float(vc.c @ z_minus[st.n:]), nodes=study.nodes)
    if controller != "iolin":
        full = _full_map(study, base, vc, z_minus)
        note = "the study's PD gains (not searched)"
        return base, full, [], note if full["residual"] <= PERIODIC_TOL else f"{note}; {_not_periodic(full)}"
    grid = [base.eps] + [e for e in EPS_GRID if e < base.eps]
    tried: list = []
    for eps in grid:
        ctrl = gw.Controller("iolin", eps=float(eps), kp=base.kp, kd=base.kd)
        full = _full_map(study, ctrl, vc, z_minus)
        lam = float(np.abs(full["ev"][0]))
        tried.append((float(eps), lam, ctrl, full))
        if full["residual"] > PERIODIC_TOL:
            return ctrl, full, [(e, m) for e, m, _, _ in tried], _not_periodic(full)
        if abs(lam - abs(rho)) <= MATCH:
            note = (f"eps {eps:g}: the full map's max |eig| {lam:.4f} is within {MATCH:g} of the restricted "
                    f"map's {rho:.4f}")
            break
    else:
        eps, lam, ctrl, full = min(tried, key=lambda t: t[1])
        note = (f"no eps from {grid[0]:g} to {grid[-1]:g} brings the full map's max |eig| within {MATCH:g} of the "
                f"restricted map's {rho:.4f}; eps {eps:g} gives the smallest, {lam:.4f}")
    if remedy_of("iolin", full["residual"], rho) == "max_eigenvalue":
        note += f"; the restricted map is itself unstable, which no output convergence mends ({REMEDY_BOUND})"
    return ctrl, full, [(e, m) for e, m, _, _ in tried], note


def remedy(rec: dict) -> str | None:
    """The design option that mends an unstable design record (:func:`remedy_of` on its
    controller, closed-loop periodicity error and restricted eigenvalue; the option its
    controller note names), or None (stable, or no remedy the design applies)."""
    if rec.get("stable"):
        return None
    return remedy_of(rec["controller"], rec.get("closed_loop_periodicity_error"), rec["restricted_eigenvalue"])


def design_retrying(make, clearance: float, max_eigenvalue: float | None, clearance_defaulted: bool,
                    retry: bool = True, progress=None):
    """(record, vc, z-, metrics) of ``make(max_eigenvalue, clearance)`` (a :func:`design` of one
    problem and initial guess), made once more when its closed loop is not stable and the
    remedy (:func:`remedy`) is on an option left to its default: :data:`CLEARANCE_RETRY_FACTOR`
    times a defaulted clearance, or the bound :data:`RETRY_MAX_EIGENVALUE` when
    ``max_eigenvalue`` is None. One line through ``progress`` says so; the record's ``retried``
    says what was retried and why, with the first design's figures (None when nothing was). An
    explicit option is the caller's: a design with it is reported as it is."""
    say = progress or (lambda m: None)
    rec, vc, z_minus, met = make(max_eigenvalue, clearance)
    retried = None
    fix = remedy(rec) if retry else None
    if fix == "clearance" and clearance_defaulted:
        retried = dict(clearance=CLEARANCE_RETRY_FACTOR * clearance)
    elif fix == "max_eigenvalue" and max_eigenvalue is None:
        retried = dict(max_eigenvalue=RETRY_MAX_EIGENVALUE)
    if retried is not None:
        retried["because"] = instability(rec)
        retried["first_max_abs_eigenvalue"] = rec["max_abs_eigenvalue"]
        retried["first_closed_loop_periodicity_error"] = rec["closed_loop_periodicity_error"]
        what = ", ".join(f"--{k.replace('_', '-')} {retried[k]:g}" for k in ("clearance", "max_eigenvalue")
                         if k in retried)
        say(f"retrying the design with {what}: {retried['because']}")
        rec, vc, z_minus, met = make(retried.get("max_eigenvalue", max_eigenvalue), retried.get("clearance", clearance))
    rec["retried"] = retried
    return rec, vc, z_minus, met


def _eigen_record(controller: str, full: dict, rho: float) -> dict:
    ev = full["ev"]
    return dict(
        controller=controller,
        max_abs_eigenvalue=float(np.abs(ev[0])),
        poincare_eigenvalues=[float(a) for a in np.abs(ev)],
        poincare_eigenvalues_complex=[[float(e.real), float(e.imag)] for e in ev],
        restricted_eigenvalue=rho,
    )


def poincare(study: HZDStudy, vc, z_minus, controller: str, ctrl: gw.Controller | None = None) -> dict:
    """Eigenvalues of the full closed-loop Poincaré map (autodiff) under ``ctrl`` (default: the
    study's controller of that name) and of the restricted map, the gains and whether the
    closed loop is stable (its fixed point one of the closed loop, every |eigenvalue| < 1)."""
    st = study.stance
    ctrl = study.controllers[controller] if ctrl is None else ctrl
    full = _full_map(study, ctrl, vc, z_minus)
    rho = gw.restricted_eigenvalue(vc, st, float(vc.c @ z_minus[st.n:]), nodes=study.nodes)
    return dict(_eigen_record(controller, full, rho), **_gains(ctrl), stable=_stable(full),
                closed_loop_periodicity_error=full["residual"])


def design_poincare(study: HZDStudy, vc, z_minus, controller: str) -> dict:
    """The record's Poincaré section of a design: the restricted map, the controller chosen by
    :func:`choose_controller` and the full map under it."""
    st = study.stance
    rho = gw.restricted_eigenvalue(vc, st, float(vc.c @ z_minus[st.n:]), nodes=study.nodes)
    ctrl, full, tried, note = choose_controller(study, vc, z_minus, controller, rho)
    return dict(_eigen_record(controller, full, rho), **_gains(ctrl), stable=_stable(full),
                closed_loop_periodicity_error=full["residual"],
                eps_search=[dict(eps=e, max_abs_eigenvalue=m) for e, m in tried], controller_note=note)


def controller_of(study: HZDStudy, meta: dict, controller: str) -> gw.Controller:
    """The controller of that name with the gains a gait file's design chose for it (its
    ``eps``, ``kp``, ``kd`` when the design's ``controller`` is this one), else the study's."""
    base = study.controllers[controller]
    design = (meta or {}).get("design") or {}
    if design.get("controller") != controller or design.get("kp") is None or design.get("kd") is None:
        return base
    eps = design.get("eps") if controller == "iolin" and design.get("eps") is not None else base.eps
    return gw.Controller(controller, eps=float(eps), kp=float(design["kp"]), kd=float(design["kd"]))


def instability(rec: dict) -> str:
    """One line on why a gait's closed loop under the record's controller is not stable."""
    gains = f"eps {rec['eps']:g}, " if rec.get("eps") is not None else ""
    gains += f"kp {rec['kp']:g}, kd {rec['kd']:g}"
    if rec["closed_loop_periodicity_error"] > PERIODIC_TOL:
        return (f"the gait is not a fixed point of its closed loop ({rec['controller']}, {gains}): the step from "
                f"it ends {rec['closed_loop_periodicity_error']:.2g} away from it (an early touchdown)")
    return (f"the gait's full Poincaré map is unstable under {rec['controller']} ({gains}): max |eig| "
            f"{rec['max_abs_eigenvalue']:.4f} >= 1 (restricted map {rec['restricted_eigenvalue']:.4f})")


def design(study: HZDStudy, prob: go.GaitProblem, x0, controller: str = "iolin", cost: str | None = None,
           progress=None):
    """(record, virtual constraints, fixed point z-, metrics of the gait) of the gait solved
    from the decision vector x0, with the controller chosen for it (:func:`choose_controller`)."""
    say = progress or (lambda m: None)
    cost = prob.cost if cost is None else cost
    say(f"optimising a {prob.speed:g} m/s gait ({cost} cost), compiling first")
    res = go.solve(prob, x0, tol=study.tol)
    c, eq, ineq, met = go.evaluator(prob)(jnp.asarray(res.x))
    vc, z_minus = met["vc"], met["z_minus"]
    say("Poincaré analysis and the choice of the output convergence")
    pc = design_poincare(study, vc, z_minus, controller)
    u = np.asarray(met["u"])
    rec = dict(
        robot=study.robot, cost=cost, success=res.success, message=res.message, iterations=res.iterations,
        solver="scipy SLSQP", solver_tolerance=study.tol,
        speed_mps=float(met["speed"]), step_length_m=float(met["step_length"]), period_s=float(met["period"]),
        cmt=float(met["cmt"]), torque_cost=float(met["torque_cost"]),
        peak_torques_nm=[float(v) for v in np.max(np.abs(u), 0)],
        periodicity_error=float(abs(eq[1])), max_constraint_violation=res.max_eq_violation,
        min_inequality=res.min_ineq,
        optimize_warm_s=res.warm_s, optimize_cold_s=res.cold_s, **pc,
        max_eigenvalue_bound=prob.max_eigenvalue, clearance_m=prob.clearance,
    )
    return rec, vc, z_minus, met


def save_gait(study: HZDStudy, path, vc, z_minus, rec: dict, extra: dict | None = None) -> None:
    """The gait file of a design record (strict JSON: a figure that is not finite, from a
    failed analysis, is saved as null); ``extra`` adds figures to its design section."""
    design_rec = json_safe({k: v for k, v in rec.items() if k != "message"})
    if extra:
        design_rec.update(extra)
    gaitfile.save(path, study.robot, vc, z_minus, design=design_rec)


def walk(study: HZDStudy, vc, z_star, meta: dict, steps: int = 50, perturb: float = 0.0,
         controller: str = "iolin", seed: int = 0, progress=None, walk_anyway: bool = False):
    """(record, the walk's steps (numpy), initial state z0) of ``steps`` closed-loop steps from
    the fixed point z_star perturbed as z0 = z* (1 + perturb N(0, 1)), under the controller
    with the gait's gains (:func:`controller_of`). The Poincaré analysis comes first: a gait
    unstable under that controller raises :class:`UnstableGait` (one line), or with
    ``walk_anyway`` is walked after one line of warning through ``progress``."""
    say = progress or (lambda m: None)
    st = study.stance
    ctrl = controller_of(study, meta, controller)
    pc = poincare(study, vc, z_star, controller, ctrl)  # first: an unstable gait is refused in one line
    if not pc["stable"]:
        if not walk_anyway:
            raise UnstableGait(instability(pc))
        say(f"warning: {instability(pc)}; walking it anyway")
    rng = np.random.default_rng(seed)
    z0 = np.asarray(z_star) * (1.0 + perturb * rng.standard_normal(z_star.shape))
    say(f"walking {steps} steps ({controller}), compiling first")
    t0 = time.perf_counter()
    w = gw.walk_program(vc, st, ctrl, jnp.asarray(z0), steps)
    w = jax.tree_util.tree_map(np.asarray, w)
    wall = time.perf_counter() - t0
    ok = w.status == 0
    n_ok = int(np.sum(ok))
    dur, length = w.duration[ok], w.step_length[ok]
    mg = float(total_mass(st.model) * st.model.gravity)
    dist = float(np.sum(length))
    with np.errstate(over="ignore", invalid="ignore"):  # a state that blew up is far, not an error
        dev = np.linalg.norm(w.z_minus - np.asarray(z_star), axis=1)
    rec = dict(
        robot=study.robot, controller=controller, perturb=perturb, seed=seed,
        fell=bool(n_ok < steps), status=STATUS_NAMES[int(w.status[-1])], steps_completed=n_ok,
        speed_mps=float(dist / np.sum(dur)) if n_ok else 0.0,
        step_length_m=float(np.mean(length)) if n_ok else 0.0,
        step_period_s=float(np.mean(dur)) if n_ok else 0.0,
        cmt=float(np.sum(w.positive_work[ok]) / (mg * dist)) if n_ok else None,
        tracking_rms_rad=float(np.sqrt(np.sum(w.y_sq[ok]) / np.sum(dur))) if n_ok else None,
        max_abs_eigenvalue=pc["max_abs_eigenvalue"], poincare_eigenvalues=pc["poincare_eigenvalues"],
        restricted_eigenvalue=pc["restricted_eigenvalue"],
        initial_deviation=float(np.linalg.norm(z0 - np.asarray(z_star))),
        final_deviation=float(dev[n_ok - 1]) if n_ok else None,
        deviation_per_step=[float(v) for v in dev[:n_ok]],
        gait_speed_mps=(meta.get("design") or {}).get("speed_mps"),
        wall_s=wall, eps=pc["eps"], kp=pc["kp"], kd=pc["kd"], stable=pc["stable"],
    )
    rec["fall_reason"] = fall_reason(vc, st, w, n_ok) if n_ok < steps else None
    rec["note"] = far_from_gait(rec, (meta.get("design") or {}).get("period_s"))
    return rec, w, z0


def fall_reason(vc, st, w, k: int) -> str:
    """Why step ``k`` (counted from 0) of the walk ``w`` (numpy) is not a step, in words."""
    n = st.n
    c = np.asarray(vc.c)
    phase, mid = float(c @ np.asarray(w.z_plus[k])[:n]), float(gw.arming_phase(vc))
    where = f"touchdown {k + 1}"
    if int(w.status[k]) == NONFINITE:
        return f"{where}: the state became non-finite"
    if phase > mid:
        return (f"{where} is spurious: the swing began at phase {phase:.3g}, already past the middle of the step "
                f"({mid:.3g}) where the touchdown is armed, so the foot came down after {1e3 * float(w.duration[k]):.0f} ms"
                " without a swing (the robot was thrown out of the gait)")
    if float(w.duration[k]) >= gw.MAX_STEP_TIME - 1e-9:
        return f"{where}: no touchdown within {gw.MAX_STEP_TIME:g} s"
    return f"{where}: the hip went below the ground or the phase stopped advancing"


def far_from_gait(rec: dict, gait_period) -> str | None:
    """A note when the steps completed look nothing like the gait (a step period under a tenth of
    the gait's, a cost of transport above 10), saying so; None otherwise."""
    if not rec["steps_completed"]:
        return None
    odd = []
    if gait_period and rec["step_period_s"] < 0.1 * float(gait_period):
        odd.append(f"a step period of {rec['step_period_s']:.3g} s, under a tenth of the gait's {float(gait_period):.3g} s")
    if rec["cmt"] is not None and rec["cmt"] > 10:
        odd.append(f"a cost of transport c_mt of {rec['cmt']:.3g}")
    if not odd:
        return None
    return "the steps completed are far from the gait (" + "; ".join(odd) + "): averages over a recovery, not a gait"


def summary_optimize(r: dict) -> str:
    return "\n".join([
        f"optimize {r['robot']}: {'converged' if r['success'] else 'NOT converged: ' + r['message']} "
        f"in {r['iterations']} iterations ({r['solver']}, tol {r['solver_tolerance']:g})",
        f"speed {r['speed_mps']:.4f} m/s, step length {r['step_length_m']:.4f} m, period {r['period_s']:.4f} s",
        f"cost of transport c_mt {r['cmt']:.4f}, torque cost {r['torque_cost']:.1f} N^2 m s",
        f"peak torques {', '.join(f'{v:.1f}' for v in r['peak_torques_nm'])} N m",
        f"Poincaré ({r['controller']}): max |eig| {r['max_abs_eigenvalue']:.4f}; restricted map {r['restricted_eigenvalue']:.4f}"
        + (f" (bounded by {r['max_eigenvalue_bound']:g})" if r.get("max_eigenvalue_bound") is not None else ""),
        f"controller: {_gain_text(r)}: {'stable' if r['stable'] else 'NOT stable'}; {r['controller_note']}",
        f"solve time: warm {r['optimize_warm_s']:.2f} s, cold {r['optimize_cold_s']:.1f} s (incl. compilation)",
    ])


def _gain_text(r: dict) -> str:
    return (f"eps {r['eps']:g}, " if r.get("eps") is not None else "") + f"kp {r['kp']:g}, kd {r['kd']:g}"


def summary_walk(r: dict) -> str:
    head = f"walk {r['robot']} ({r['controller']}, perturbation {r['perturb']:g}): "
    head += f"{'FELL after' if r['fell'] else 'completed'} {r['steps_completed']} steps"
    lines = [head] + [r[k] for k in ("fall_reason", "note") if r.get(k)]
    if r["steps_completed"]:
        lines += [
            f"speed {r['speed_mps']:.4f} m/s, step length {r['step_length_m']:.4f} m, period {r['step_period_s']:.4f} s",
            f"c_mt {r['cmt']:.4f}, tracking rms {r['tracking_rms_rad']:.2e} rad",
            f"distance to the fixed point: {r['initial_deviation']:.2e} at start, {r['final_deviation']:.2e} after the last step",
        ]
    lines.append(f"Poincaré max |eig| {r['max_abs_eigenvalue']:.4f} (restricted map {r['restricted_eigenvalue']:.4f}; "
                 f"{_gain_text(r)}: {'stable' if r['stable'] else 'NOT stable'})")
    return "\n".join(lines)
