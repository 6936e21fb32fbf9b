"""The seven-link biped's commands: ``bipedlab walk seven-link`` and ``bipedlab experiment
seven-link free-swing|low-gain-pd|sensitivity`` (registered with :mod:`bipedlab.registry`; the study module is
imported inside ``run``)."""
from __future__ import annotations

from bipedlab.commands import Command, UsageError, add_out, int_in
from bipedlab.robots.seven_link import catalog

ROBOT = "seven-link"
EXPERIMENTS = catalog.EXPERIMENTS
STEPS = int_in(1, 10_000)


def _out(p) -> None:
    add_out(p)


def _walk_arguments(p) -> None:
    p.add_argument("--steps", type=STEPS, default=None, help="number of steps (default 30)")
    p.add_argument("--params", choices=catalog.PARAMS, default=None,
                   help="the controller's Table II parameters as published, or retuned for the planar model "
                        f"(default {catalog.DEFAULT_PARAMS})")
    p.add_argument("--setup", choices=catalog.SETUPS, default=None,
                   help="the plant: the planar model, or the experimental setup (the 1.6 m boom's inertia, turning "
                        "the feet on the ground, Coulomb drive friction identified from Fig. 6, the knee lock "
                        f"torque of Fig. 8) (default {catalog.DEFAULT_SETUP})")
    _out(p)


def _walk(args, progress):
    from bipedlab.robots.seven_link import study as walk_seven_link

    rec = walk_seven_link.walk(args.steps if args.steps is not None else 30, args.params or catalog.DEFAULT_PARAMS,
                               out=args.out, progress=progress, setup=args.setup or catalog.DEFAULT_SETUP)
    return rec, walk_seven_link.summary_walk


def _experiment_arguments(p) -> None:
    p.add_argument("name", choices=EXPERIMENTS, help=" | ".join(EXPERIMENTS))
    p.add_argument("--steps", type=STEPS, default=None,
                   help="sensitivity only: steps of each walk (default 30)")
    _out(p)


def _experiment(args, progress):
    from bipedlab.robots.seven_link import study as walk_seven_link

    if args.name == "sensitivity":
        from bipedlab.robots.seven_link import sensitivity

        return (sensitivity.sensitivity(args.steps if args.steps is not None else 30, progress=progress),
                sensitivity.summary)
    if args.steps is not None:
        raise UsageError(f"experiment seven-link {args.name}: --steps is an option of the sensitivity experiment only")
    run = walk_seven_link.free_swing if args.name == "free-swing" else walk_seven_link.low_gain_pd
    return run(out=args.out, progress=progress), walk_seven_link.summary_experiment


COMMANDS = [
    Command("walk", ROBOT, "nonkinematic walking: configuration-switched spring-damper control on rigid feet",
            _walk_arguments, _walk, bench=(("--steps", "5"),)),
    Command("experiment", ROBOT, "validation experiments: " + "|".join(EXPERIMENTS), _experiment_arguments,
            _experiment, bench=(("free-swing",),)),
]

from bipedlab.robots.seven_link.robustness import COMMAND as _ROBUSTNESS  # noqa: E402  (no JAX at import)

COMMANDS.append(_ROBUSTNESS)
