"""Hybrid-zero-dynamics walking of the five-link biped: gait design and closed-loop walking.

``optimize``: a fixed-point gait at a given speed from the package's default initial guess
(SLSQP on the zero dynamics, exact JAX derivatives), then its Poincaré analysis.
``walk``: closed-loop steps from the (perturbed) fixed point under I/O linearisation or PD with
u* feedforward, events located exactly.
"""
from __future__ import annotations

import time

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.gait import gaitfile
from bipedlab.gait import optimize as go
from bipedlab.gait import walking as gw
from bipedlab.mechanics.dynamics import total_mass
from bipedlab.outputs import json_safe
from bipedlab.robots.five_link import robot as five_link
from bipedlab.sim.rollout import STATUS_NAMES

ROBOT = "five-link"
SHIPPED = "five_link_0.8"
#: Solver tolerance (SLSQP ftol) used for the designs.
TOL = 1e-10
NODES = 40
CONTROLLERS = {
    "iolin": gw.Controller("iolin", eps=0.1, kp=1.0, kd=2.0),
    "pd": gw.Controller("pd", kp=400.0, kd=20.0),
}


def problem(speed: float, cost: str) -> go.GaitProblem:
    H0, c = five_link.hzd_outputs()
    return go.GaitProblem(five_link.stance(), H0, c, order=5, nodes=NODES, speed=speed, cost=cost)


def initial_guess(prob: go.GaitProblem) -> np.ndarray:
    x0 = go.initial_guess(prob, five_link.gait_guess(prob.speed))
    z, free = go.unpack(prob, x0)
    free = np.array(free)
    free[3, :] = five_link.SWING_KNEE_GUESS
    return go.pack(z, free)


def poincare(vc, z_minus, controller: str) -> dict:
    """Eigenvalues of the full closed-loop Poincaré map (autodiff) and of the restricted map."""
    st = five_link.stance()
    J = np.asarray(jax.jit(lambda z: gw.poincare_jacobian(vc, st, CONTROLLERS[controller], z))(z_minus))
    ev = np.linalg.eigvals(J)
    ev = ev[np.argsort(-np.abs(ev))]
    rho = gw.restricted_eigenvalue(vc, st, float(vc.c @ z_minus[st.n:]), nodes=NODES)
    return dict(
        controller=controller,
        max_abs_eigenvalue=float(np.abs(ev[0])),
        poincare_eigenvalues=[float(a) for a in np.abs(ev)],
        poincare_eigenvalues_complex=[[float(e.real), float(e.imag)] for e in ev],
        restricted_eigenvalue=rho,
    )


def optimize(speed: float = 0.8, cost: str = "torque", controller: str = "iolin", save=None,
             out=None, progress=None) -> dict:
    say = progress or (lambda m: None)
    prob = problem(speed, cost)
    say(f"optimising a {speed:g} m/s gait ({cost} cost), compiling first")
    res = go.solve(prob, initial_guess(prob), tol=TOL)
    c, eq, ineq, met = jax.jit(lambda x: go.evaluate(prob, x))(jnp.asarray(res.x))
    vc, z_minus = met["vc"], met["z_minus"]
    say("Poincaré analysis")
    pc = poincare(vc, z_minus, controller)
    u = np.asarray(met["u"])
    rec = dict(
        robot=ROBOT, cost=cost, success=res.success, message=res.message, iterations=res.iterations,
        solver="scipy SLSQP", solver_tolerance=TOL,
        speed_mps=float(met["speed"]), step_length_m=float(met["step_length"]), period_s=float(met["period"]),
        cmt=float(met["cmt"]), torque_cost=float(met["torque_cost"]),
        peak_torques_nm=[float(v) for v in np.max(np.abs(u), 0)],
        periodicity_error=float(abs(eq[1])), max_constraint_violation=res.max_eq_violation,
        min_inequality=res.min_ineq,
        optimize_warm_s=res.warm_s, optimize_cold_s=res.cold_s, **pc,
    )
    if save:
        # strict JSON in the file: a figure that is not finite (a failed analysis) is saved as null
        gaitfile.save(save, ROBOT, vc, z_minus, design=json_safe({k: v for k, v in rec.items() if k != "message"}))
    if out:
        from bipedlab.robots.five_link import plots as hzd_plots

        hzd_plots.gait_figures(out, prob, met)
    return rec


def load_gait(path=None):
    """The gait in a file (default: the shipped one), every field checked before anything
    runs; ValueError naming the file and the field if it cannot drive the five-link biped."""
    H0, _ = five_link.hzd_outputs()
    sizes = (H0.shape[1], H0.shape[0])
    vc, z, rec = (gaitfile.load(path, sizes) if path
                  else gaitfile.shipped("bipedlab.robots.five_link", SHIPPED, sizes))
    if rec.get("robot") != ROBOT:
        raise ValueError(f"{path}: robot: a gait for {rec.get('robot')!r}, not {ROBOT!r}")
    return vc, z, rec


def walk(steps: int = 50, perturb: float = 0.0, controller: str = "iolin", gait=None, seed: int = 0,
         out=None, progress=None) -> dict:
    say = progress or (lambda m: None)
    vc, z_star, meta = load_gait(gait)
    st = five_link.stance()
    ctrl = CONTROLLERS[controller]
    rng = np.random.default_rng(seed)
    z0 = np.asarray(z_star) * (1.0 + perturb * rng.standard_normal(z_star.shape))
    say(f"walking {steps} steps ({controller}), compiling first")
    t0 = time.perf_counter()
    w = jax.jit(lambda z: gw.walk(vc, st, ctrl, z, steps))(jnp.asarray(z0))
    w = jax.tree_util.tree_map(np.asarray, w)
    wall = time.perf_counter() - t0
    ok = w.status == 0
    n_ok = int(np.sum(ok))
    dur, length = w.duration[ok], w.step_length[ok]
    mg = float(total_mass(st.model) * st.model.gravity)
    dist = float(np.sum(length))
    say("Poincaré analysis")
    pc = poincare(vc, z_star, controller)
    dev = np.linalg.norm(w.z_minus - np.asarray(z_star), axis=1)
    rec = dict(
        robot=ROBOT, controller=controller, perturb=perturb, seed=seed,
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
    if out:
        from bipedlab.robots.five_link import plots as hzd_plots

        hzd_plots.walk_figures(out, vc, st, ctrl, jnp.asarray(z0), w)
    return rec


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
