"""The compass-gait walker's command: ``bipedlab walk compass-gait`` (registered with
:mod:`bipedlab.registry`; :mod:`bipedlab.robots.compass_gait.study` is imported inside ``run``).
The options are those of the study's ``add_arguments`` (same names, defaults and metavars),
with the step count and the displacement checked here."""
from __future__ import annotations

from bipedlab.commands import SEED, Command, add_out, float_in, int_in


def _walk_arguments(p) -> None:
    p.add_argument("--slope", type=float_in(0.1, 10.0), default=3.0, metavar="DEG",
                   help="slope angle, degrees (default 3; the gait search converges from its guess for 1 to 5)")
    p.add_argument("--steps", type=int_in(1, 10_000), default=20, metavar="N", help="steps to walk (default 20)")
    p.add_argument("--perturb", type=float_in(0.0, 1.0), default=0.0, metavar="S",
                   help="size of the initial displacement from the fixed point (default 0)")
    p.add_argument("--seed", type=SEED, default=0, metavar="K", help="seed of the displacement direction")
    add_out(p, "a stick-figure PNG")


def _walk(args, progress):
    from bipedlab.robots.compass_gait import study

    progress(f"compass gait: period-one gait on a {args.slope:g} deg slope, then {args.steps} steps")
    return study.walk(args.slope, args.steps, args.perturb, args.seed, out=args.out, progress=progress)


COMMANDS = [
    Command("walk", "compass-gait",
            "passive compass-gait walking down a slope: period-one gait, Poincaré eigenvalues, perturbed walk",
            _walk_arguments, _walk, bench=(("--steps", "10"),)),
]
