"""The compass-gait walker's command: ``bipedlab walk compass-gait`` (registered with
:mod:`bipedlab.cli`; :mod:`bipedlab.robots.compass_gait.study` is imported inside ``run``).
The options are those of the study's ``add_arguments`` (same names, defaults and metavars),
with the step count and the displacement checked here."""
from __future__ import annotations

from bipedlab.cli import Command, nonnegative_float, positive_float, positive_int


def _walk_arguments(p) -> None:
    p.add_argument("--slope", type=positive_float, default=3.0, metavar="DEG", help="slope angle, degrees (default 3)")
    p.add_argument("--steps", type=positive_int, default=20, metavar="N", help="steps to walk (default 20)")
    p.add_argument("--perturb", type=nonnegative_float, default=0.0, metavar="S",
                   help="size of the initial displacement from the fixed point (default 0)")
    p.add_argument("--seed", type=int, default=0, metavar="K", help="seed of the displacement direction")
    p.add_argument("--out", default=None, metavar="DIR", help="write a stick-figure PNG into DIR")


def _walk(args, progress):
    from bipedlab.robots.compass_gait import study

    progress(f"compass gait: period-one gait on a {args.slope:g} deg slope, then {args.steps} steps")
    return study.walk(args.slope, args.steps, args.perturb, args.seed, out=args.out)


COMMANDS = [
    Command("walk", "compass-gait",
            "passive compass-gait walking down a slope: period-one gait, Poincaré eigenvalues, perturbed walk",
            _walk_arguments, _walk),
]
