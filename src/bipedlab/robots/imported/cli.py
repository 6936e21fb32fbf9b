"""Commands on a biped read from a file: ``bipedlab optimize model FILE --stance SITE --swing
SITE`` and ``bipedlab walk model FILE --gait GAIT`` (registered with :mod:`bipedlab.cli`;
study modules are imported inside ``run``). FILE is an MJCF or URDF file, or the name of a
shipped example (``rabbit.xml``, ``rabbit.urdf``)."""
from __future__ import annotations

import os

from bipedlab.inputs import model_text
from bipedlab.commands import SEED, Command, UsageError, add_save, float_in, int_in, text

ROBOT = "model"
CONTROLLERS = ["iolin", "pd"]
STEPS = int_in(1, 10_000)
SPEED = float_in(0.1, 2.0)
PERTURB = float_in(0.0, 1.0)
PLANES = ["xz", "yz", "zx", "zy", "xy", "yx"]
EIGENVALUE = float_in(0.01, 0.999)
CLEARANCE = float_in(0.0, 0.5)


def _file(p) -> None:
    p.add_argument("file", type=text, metavar="FILE", help="the robot: an MJCF (.xml) or URDF (.urdf) file")
    p.add_argument("--plane", choices=PLANES, default="xz",
                   help="the sagittal plane as (forward axis, up axis) of the file's world (default xz)")


def _check_file(args) -> None:
    from bipedlab.robots.imported.study import EXAMPLES

    if not (args.file in EXAMPLES and not os.path.lexists(args.file)):  # not a shipped example
        try:
            model_text(args.file)  # a regular text file, no xacro macro, every number finite
        except ValueError as e:
            raise UsageError(str(e)) from None


def _study(fn, *a, **k):
    try:
        return fn(*a, **k)
    except (ValueError, ImportError) as e:
        raise UsageError(str(e)) from None


# ----------------------------------------------------------------------------- optimize
def _optimize_arguments(p) -> None:
    _file(p)
    p.add_argument("--stance", type=text, required=True, metavar="SITE", help="the stance foot's site")
    p.add_argument("--swing", type=text, required=True, metavar="SITE", help="the swing foot's site")
    p.add_argument("--speed", type=SPEED, default=0.8, help="walking speed, m/s")
    p.add_argument("--cost", choices=["torque", "cmt"], default="torque",
                   help="integral of squared torque per step length, or mechanical cost of transport")
    p.add_argument("--controller", choices=CONTROLLERS, default="iolin", help="controller for the Poincaré analysis")
    p.add_argument("--max-eigenvalue", type=EIGENVALUE, default=None, metavar="R",
                   help="bound the restricted Poincaré map's |eigenvalue| by R inside the design (default: no bound)")
    p.add_argument("--clearance", type=CLEARANCE, default=None, metavar="M",
                   help="the swing foot at least M metres above the ground at mid-step (default: 3 %% of the "
                        "leg's hip-to-foot length, retried at twice that if the swing foot still lands early; "
                        "0: no bound)")
    add_save(p, "the gait (for walk model FILE --gait GAIT)")


def _optimize(args, progress):
    from bipedlab.robots.imported import study

    rec = _study(study.optimize, args.file, args.stance, args.swing, args.speed, args.cost, args.controller,
                 save=args.save, plane=args.plane, progress=progress, max_eigenvalue=args.max_eigenvalue,
                 clearance=args.clearance)
    return rec, study.summary_optimize


# ----------------------------------------------------------------------------- walk
def _walk_arguments(p) -> None:
    _file(p)
    p.add_argument("--gait", type=text, required=True, metavar="GAIT", help="a gait file from optimize model --save")
    p.add_argument("--steps", type=STEPS, default=50, help="number of steps")
    p.add_argument("--perturb", type=PERTURB, default=0.0,
                   help="relative size S of a random offset of the initial state: z0 = z* (1 + S N(0,1))")
    p.add_argument("--controller", choices=CONTROLLERS, default="iolin", help="iolin | pd")
    p.add_argument("--seed", type=SEED, default=0, help="seed of the perturbation")
    p.add_argument("--walk-anyway", action="store_true",
                   help="walk a gait whose closed loop is unstable under its controller (refused otherwise)")


def _walk_validate(args) -> None:
    _check_file(args)
    if not os.path.isfile(args.gait):
        raise UsageError(f"--gait: {args.gait!r} is not a file")


def _walk(args, progress):
    from bipedlab.robots.imported import study

    _study(study.load_gait, args.file, args.gait, args.plane)
    rec = _study(study.walk, args.file, args.gait, args.steps, args.perturb, args.controller, args.seed,
                 plane=args.plane, progress=progress, walk_anyway=args.walk_anyway)
    return rec, study.summary_walk


COMMANDS = [
    Command("optimize", ROBOT, "design a periodic HZD walking gait for a biped in an MJCF or URDF file",
            _optimize_arguments, _optimize, validate=_check_file),
    Command("walk", ROBOT, "closed-loop HZD walking of a biped in an MJCF or URDF file on a designed gait",
            _walk_arguments, _walk, validate=_walk_validate),
]

from bipedlab.robots.imported.robustness import COMMAND as _ROBUSTNESS  # noqa: E402  (no JAX at import)

COMMANDS.append(_ROBUSTNESS)
