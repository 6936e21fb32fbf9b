"""The five-link biped's commands: ``bipedlab optimize five-link`` and ``bipedlab walk
five-link``, and the anchor scenario of ``bipedlab bench`` (registered with
:mod:`bipedlab.registry`; study modules are imported inside ``run``)."""
from __future__ import annotations

import os

from bipedlab.commands import SEED, Command, Scenario, UsageError, add_out, add_save, float_in, int_in, text

ROBOT = "five-link"
CONTROLLERS = ["iolin", "pd"]
STEPS = int_in(1, 10_000)
SPEED = float_in(0.1, 2.0)  # m/s: a leg of 0.8 m walks, it does not run
PERTURB = float_in(0.0, 1.0)  # relative: 1 already doubles a state component at one sigma


def _out(p) -> None:
    add_out(p)


# ----------------------------------------------------------------------------- bench
def _standing(options, progress):
    """The anchor scenario of ``bipedlab bench`` (:mod:`.bench`)."""
    from bipedlab.robots.five_link import bench

    rec = bench.run(options.batches, options.seconds, options.threads, options.mujoco, progress=progress)
    return rec, bench.summary


SCENARIOS = [
    Scenario("five-link-standing", "the five-link biped standing under joint PD on the penalty ground, RK4 at "
             "0.25 ms, 1 kHz control", _standing),
]


# ----------------------------------------------------------------------------- optimize
def _optimize_arguments(p) -> None:
    p.add_argument("--speed", type=SPEED, default=0.8, help="walking speed, m/s")
    p.add_argument("--cost", choices=["torque", "cmt"], default="torque",
                   help="integral of squared torque per step length, or mechanical cost of transport")
    p.add_argument("--controller", choices=CONTROLLERS, default="iolin", help="controller for the Poincaré analysis")
    p.add_argument("--max-eigenvalue", type=float_in(0.01, 0.999), default=None, metavar="R",
                   help="bound the restricted Poincaré map's |eigenvalue| by R inside the design (default: no bound)")
    p.add_argument("--clearance", type=float_in(0.0, 0.5), default=0.0, metavar="M",
                   help="the swing foot at least M metres above the ground at mid-step (default 0: no bound)")
    add_save(p, "the gait (for walk --gait FILE)")
    _out(p)


def _optimize(args, progress):
    from bipedlab.robots.five_link import study as hz

    rec = hz.optimize(args.speed, args.cost, args.controller, save=args.save, out=args.out, progress=progress,
                      max_eigenvalue=args.max_eigenvalue, clearance=args.clearance)
    return rec, hz.summary_optimize


# ----------------------------------------------------------------------------- walk
def _walk_arguments(p) -> None:
    p.add_argument("--steps", type=STEPS, default=None, help="number of steps (default 50)")
    p.add_argument("--perturb", type=PERTURB, default=0.0,
                   help="relative size S of a random offset of the initial state: z0 = z* (1 + S N(0,1))")
    p.add_argument("--controller", choices=CONTROLLERS, default=None, help="iolin | pd (default iolin)")
    p.add_argument("--gait", type=text, metavar="GAIT", help="a gait file from optimize --save (default: the shipped gait)")
    p.add_argument("--seed", type=SEED, default=0, help="seed of the perturbation")
    p.add_argument("--walk-anyway", action="store_true",
                   help="walk a gait whose closed loop is unstable under its controller (refused otherwise)")
    _out(p)


def _walk_validate(args) -> None:
    if args.gait is not None and not os.path.isfile(args.gait):
        raise UsageError(f"--gait: {args.gait!r} is not a file")


def _walk(args, progress):
    from bipedlab.robots.five_link import study as hz

    try:
        hz.load_gait(args.gait)
    except ValueError as e:
        raise UsageError(str(e)) from None
    try:
        rec = hz.walk(args.steps or 50, args.perturb, args.controller or "iolin", args.gait, args.seed, out=args.out,
                      progress=progress, walk_anyway=args.walk_anyway)
    except ValueError as e:  # a gait unstable under its controller
        raise UsageError(str(e)) from None
    return rec, hz.summary_walk


COMMANDS = [
    Command("optimize", ROBOT, "design a periodic HZD walking gait by optimisation", _optimize_arguments, _optimize,
            bench=((),)),
    Command("walk", ROBOT, "closed-loop HZD walking on a designed gait, optionally from a perturbed state",
            _walk_arguments, _walk, validate=_walk_validate, bench=(("--steps", "10"),)),
]

from bipedlab.robots.five_link.robustness import COMMAND as _ROBUSTNESS  # noqa: E402  (no JAX at import)

COMMANDS.append(_ROBUSTNESS)
