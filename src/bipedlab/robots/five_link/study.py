"""Hybrid-zero-dynamics walking of the five-link biped: gait design and closed-loop walking.

``optimize``: a fixed-point gait at a given speed from the package's default initial guess
(SLSQP on the zero dynamics, exact JAX derivatives), then its Poincaré analysis.
``walk``: closed-loop steps from the (perturbed) fixed point under I/O linearisation or PD with
u* feedforward, events located exactly. The study itself is the core's
(:mod:`bipedlab.gait.study`); this module gives it the five-link biped, its initial guess and
its shipped gait.
"""
from __future__ import annotations

import numpy as np

from bipedlab.gait import gaitfile
from bipedlab.gait import optimize as go
from bipedlab.gait import study as hzd_study
from bipedlab.robots.five_link import robot as five_link

ROBOT = "five-link"
SHIPPED = "five_link_0.8"
#: Solver tolerance (SLSQP ftol) used for the designs.
TOL = hzd_study.TOL
NODES = hzd_study.NODES
CONTROLLERS = hzd_study.CONTROLLERS


def study() -> hzd_study.HZDStudy:
    """The five-link biped's HZD study (outputs and phase of :func:`robot.hzd_outputs`)."""
    H0, c = five_link.hzd_outputs()
    return hzd_study.HZDStudy(ROBOT, five_link.stance(), H0, c, order=5, nodes=NODES, tol=TOL,
                              controllers=CONTROLLERS)


def problem(speed: float, cost: str) -> go.GaitProblem:
    return hzd_study.problem(study(), speed, cost)


def initial_guess(prob: go.GaitProblem) -> np.ndarray:
    x0 = go.initial_guess(prob, five_link.gait_guess(prob.speed))
    z, free = go.unpack(prob, x0)
    free = np.array(free)
    free[3, :] = five_link.SWING_KNEE_GUESS
    return go.pack(z, free)


def poincare(vc, z_minus, controller: str) -> dict:
    """Eigenvalues of the full closed-loop Poincaré map (autodiff) and of the restricted map."""
    return hzd_study.poincare(study(), vc, z_minus, controller)


def optimize(speed: float = 0.8, cost: str = "torque", controller: str = "iolin", save=None,
             out=None, progress=None, max_eigenvalue: float | None = None, clearance: float = 0.0) -> dict:
    """The design record (:func:`bipedlab.gait.study.design`); ``max_eigenvalue`` bounds the
    restricted map's |eigenvalue| and ``clearance`` (m) lifts the swing point at mid-step."""
    s = study()
    prob = hzd_study.problem(s, speed, cost, max_eigenvalue, clearance)
    rec, vc, z_minus, met = hzd_study.design(s, prob, initial_guess(prob), controller, cost, progress)
    if save:
        hzd_study.save_gait(s, save, vc, z_minus, rec)
    if out:
        from bipedlab.robots.five_link import plots as hzd_plots

        hzd_plots.gait_figures(out, prob, met)
    return rec


def load_gait(path=None):
    """The gait in a file (default: the shipped one), every field checked before anything
    runs; ValueError naming the file and the field if it cannot drive the five-link biped."""
    H0, _ = five_link.hzd_outputs()
    sizes = (H0.shape[1], H0.shape[0])
    vc, z, rec = (gaitfile.load(path, sizes, ROBOT) if path
                  else gaitfile.shipped("bipedlab.robots.five_link", SHIPPED, sizes, ROBOT))
    if rec.get("robot") != ROBOT:
        raise ValueError(f"{path}: robot: a gait for {rec.get('robot')!r}, not {ROBOT!r}")
    return vc, z, rec


def walk(steps: int = 50, perturb: float = 0.0, controller: str = "iolin", gait=None, seed: int = 0,
         out=None, progress=None, walk_anyway: bool = False) -> dict:
    """The walk record (:func:`bipedlab.gait.study.walk`: the gait's own gains; an unstable gait
    raises :class:`bipedlab.gait.study.UnstableGait` naming the gait file and the ``--walk-anyway`` that
    walks it, unless ``walk_anyway``)."""
    vc, z_star, meta = load_gait(gait)
    s = study()
    try:
        rec, w, z0 = hzd_study.walk(s, vc, z_star, meta, steps, perturb, controller, seed, progress, walk_anyway)
    except hzd_study.UnstableGait as e:
        raise hzd_study.UnstableGait(f"{gait or SHIPPED}: {e}; --walk-anyway walks it") from None
    if out:
        import jax.numpy as jnp

        from bipedlab.robots.five_link import plots as hzd_plots

        ctrl = hzd_study.controller_of(s, meta, controller)
        hzd_plots.walk_figures(out, vc, s.stance, ctrl, jnp.asarray(z0), w)
    return rec


summary_optimize = hzd_study.summary_optimize
summary_walk = hzd_study.summary_walk
