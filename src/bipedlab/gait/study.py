"""The hybrid-zero-dynamics study of any point-foot planar biped: gait design, closed-loop
walking and Poincaré analysis, with one record format for every robot.

A robot enters as an :class:`HZDStudy`: its stance model (one foot pinned, the leg swap), its
virtual constraints' output matrix H0 and phase vector c, and its name for the records.
``design``: a fixed-point gait at a given speed from a given initial decision vector (SLSQP
on the zero dynamics, exact JAX derivatives), then its Poincaré analysis. ``walk``:
closed-loop steps from the (perturbed) fixed point under I/O linearisation or PD with u*
feedforward, events located exactly. The records' keys are the same for every robot.
"""
from __future__ import annotations

import dataclasses
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
from bipedlab.sim.rollout import STATUS_NAMES

#: Solver tolerance (SLSQP ftol) of the designs.
TOL = 1e-10
#: RK4 nodes over a step of the zero dynamics.
NODES = 40
#: The two closed loops: I/O linearisation (eq. 42 gains) and PD with u* feedforward.
CONTROLLERS = {
    "iolin": gw.Controller("iolin", eps=0.1, kp=1.0, kd=2.0),
    "pd": gw.Controller("pd", kp=400.0, kd=20.0),
}


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


def problem(study: HZDStudy, speed: float, cost: str) -> go.GaitProblem:
    return go.GaitProblem(study.stance, study.H0, study.c, order=study.order, nodes=study.nodes, speed=speed,
                          cost=cost, torque_limits=study.torque_limits)


def poincare(study: HZDStudy, vc, z_minus, controller: str) -> dict:
    """Eigenvalues of the full closed-loop Poincaré map (autodiff) and of the restricted map."""
    st = study.stance
    ctrl = study.controllers[controller]
    J = np.asarray(gw.poincare_program(vc, st, ctrl, jnp.asarray(z_minus)))
    ev = np.linalg.eigvals(J)
    ev = ev[np.argsort(-np.abs(ev))]
    rho = gw.restricted_eigenvalue(vc, st, float(vc.c @ z_minus[st.n:]), nodes=study.nodes)
    return dict(
        controller=controller,
        max_abs_eigenvalue=float(np.abs(ev[0])),
        poincare_eigenvalues=[float(a) for a in np.abs(ev)],
        poincare_eigenvalues_complex=[[float(e.real), float(e.imag)] for e in ev],
        restricted_eigenvalue=rho,
    )


def design(study: HZDStudy, prob: go.GaitProblem, x0, controller: str = "iolin", cost: str | None = None,
           progress=None):
    """(record, virtual constraints, fixed point z-, metrics of the gait) of the gait solved
    from the decision vector x0."""
    say = progress or (lambda m: None)
    cost = prob.cost if cost is None else cost
    say(f"optimising a {prob.speed:g} m/s gait ({cost} cost), compiling first")
    res = go.solve(prob, x0, tol=study.tol)
    c, eq, ineq, met = go.evaluator(prob)(jnp.asarray(res.x))
    vc, z_minus = met["vc"], met["z_minus"]
    say("Poincaré analysis")
    pc = poincare(study, vc, z_minus, controller)
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
         controller: str = "iolin", seed: int = 0, progress=None):
    """(record, the walk's steps (numpy), initial state z0) of ``steps`` closed-loop steps from
    the fixed point z_star perturbed as z0 = z* (1 + perturb N(0, 1))."""
    say = progress or (lambda m: None)
    st = study.stance
    ctrl = study.controllers[controller]
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
    say("Poincaré analysis")
    pc = poincare(study, vc, z_star, controller)
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
        wall_s=wall,
    )
    return rec, w, z0


def summary_optimize(r: dict) -> str:
    return "\n".join([
        f"optimize {r['robot']}: {'converged' if r['success'] else 'NOT converged: ' + r['message']} "
        f"in {r['iterations']} iterations ({r['solver']}, tol {r['solver_tolerance']:g})",
        f"speed {r['speed_mps']:.4f} m/s, step length {r['step_length_m']:.4f} m, period {r['period_s']:.4f} s",
        f"cost of transport c_mt {r['cmt']:.4f}, torque cost {r['torque_cost']:.1f} N^2 m s",
        f"peak torques {', '.join(f'{v:.1f}' for v in r['peak_torques_nm'])} N m",
        f"Poincaré ({r['controller']}): max |eig| {r['max_abs_eigenvalue']:.4f}; restricted map {r['restricted_eigenvalue']:.4f}",
        f"solve time: warm {r['optimize_warm_s']:.2f} s, cold {r['optimize_cold_s']:.1f} s (incl. compilation)",
    ])


def summary_walk(r: dict) -> str:
    head = f"walk {r['robot']} ({r['controller']}, perturbation {r['perturb']:g}): "
    head += f"{'FELL after' if r['fell'] else 'completed'} {r['steps_completed']} steps"
    lines = [head]
    if r["steps_completed"]:
        lines += [
            f"speed {r['speed_mps']:.4f} m/s, step length {r['step_length_m']:.4f} m, period {r['step_period_s']:.4f} s",
            f"c_mt {r['cmt']:.4f}, tracking rms {r['tracking_rms_rad']:.2e} rad",
            f"distance to the fixed point: {r['initial_deviation']:.2e} at start, {r['final_deviation']:.2e} after the last step",
        ]
    lines.append(f"Poincaré max |eig| {r['max_abs_eigenvalue']:.4f} (restricted map {r['restricted_eigenvalue']:.4f})")
    return "\n".join(lines)
