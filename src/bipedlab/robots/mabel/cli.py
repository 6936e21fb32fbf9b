"""MABEL's commands: ``bipedlab optimize|walk|experiment|hop|identify mabel`` (registered with
:mod:`bipedlab.registry`; the walking, hopping and sysid study modules are imported inside
``run``)."""
from __future__ import annotations

import argparse
import math
import os

from bipedlab.commands import SEED, Command, UsageError, add_out, add_save, float_in, int_in, parse_float, parse_int, text
from bipedlab.robots.mabel.walking import catalog

ROBOT = "mabel"
STEPS = int_in(1, 10_000)
SPEED = float_in(0.1, 2.0)         # m/s; the designed gaits span 0.6-1.6
STEP_LENGTH = float_in(0.2, 1.0)   # m; legs of 1 m, reached by continuation in 3 cm solves
CLEARANCE = float_in(0.0, 0.2)     # m; the shipped gaits lift the swing toe 1.6-17 cm at most
IMPACT_SCALE = float_in(0.5, 1.5)  # Table I spans 0.96-1
LEAN = float_in(-45.0, 45.0)       # deg
GROUND_SCALE = float_in(0.01, 100.0)  # the identified ground's stiffness and damping times this
EXPERIMENTS = catalog.EXPERIMENTS
PUSH_FORCE = catalog.PUSH_FORCE


def _out(p, what: str = "figures (PNG) and data (NPZ)") -> None:
    add_out(p, what)


def push_value(value: str) -> tuple:
    """argparse type of --push: 'FORCE@STEP' -> (force in N, step index)."""
    force, sep, step = value.partition("@")
    try:
        f, k = parse_float(force), parse_int(step)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected FORCE@STEP (e.g. 78@10, or --push=-71@30 for a backward push), got {value!r}") from None
    if not sep or not (math.isfinite(f) and abs(f) <= PUSH_FORCE) or not 0 <= k <= STEPS.hi - 1:
        raise argparse.ArgumentTypeError(f"expected FORCE@STEP with FORCE in [{-PUSH_FORCE:g}, {PUSH_FORCE:g}] N "
                                         f"and STEP in [0, {STEPS.hi - 1}], got {value!r}")
    return f, k


# ----------------------------------------------------------------------------- optimize
def _optimize_arguments(p) -> None:
    p.add_argument("--speed", type=SPEED, default=0.8, help="walking speed, m/s")
    p.add_argument("--step-length", type=STEP_LENGTH, default=None, metavar="L",
                   help="prescribe the step length in m (e.g. 0.575, the paper's nominal gait)")
    p.add_argument("--clearance", type=CLEARANCE, default=0.0, metavar="M",
                   help="the swing toe at least M * 4 s (1 - s) above the ground along the step (s its fraction; "
                        "M at mid-step); default 0, the paper's bound (above the ground)")
    p.add_argument("--cost", choices=catalog.COSTS, default="torque",
                   help="integral of squared torque per step length, or mechanical cost of transport")
    p.add_argument("--design-model", choices=catalog.DESIGN_MODELS, default="paper",
                   help="paper: the HZD paper's design model, rigid cables without motor friction or spring "
                        "damping (default; the shipped paper-nominal and paper-efficient gaits); full: with motor "
                        "friction (Table V) and spring damping in the zero dynamics (the shipped nominal and "
                        "efficient gaits the experiments walk)")
    p.add_argument("--no-poincare", action="store_true", help="skip the Poincaré analysis")
    add_save(p, "the gait (for walk --gait FILE)")
    _out(p)


def _optimize(args, progress):
    from bipedlab.robots.mabel.walking import study as wm

    rec = wm.optimize(args.speed, args.cost, save=args.save, out=args.out, poincare_check=not args.no_poincare,
                      progress=progress, step_length=args.step_length, design_model=args.design_model,
                      clearance=args.clearance)
    return rec, wm.summary_optimize


# ----------------------------------------------------------------------------- walk
def _walk_arguments(p) -> None:
    p.add_argument("--steps", type=STEPS, default=None, help="number of steps (default 100)")
    p.add_argument("--controller", choices=catalog.CONTROLLERS, default=None,
                   help=f"{' | '.join(catalog.CONTROLLERS)} (default {catalog.DEFAULT_CONTROLLER})")
    p.add_argument("--gait", type=text, metavar="GAIT", help=f"{' | '.join(catalog.GAITS)} or a gait file from "
                                                             f"optimize --save (default {catalog.DEFAULT_GAIT})")
    p.add_argument("--push", type=push_value, metavar="FORCE@STEP",
                   help=f"horizontal force (N, + forward, |FORCE| <= {PUSH_FORCE:g}) on the hip over the second "
                        "half of step STEP (counted from 0, before --steps); a backward push is written with '=', "
                        "e.g. --push=-71@30")
    p.add_argument("--impact-scale", type=IMPACT_SCALE, default=1.0, metavar="ETA",
                   help="impact scaling eta of Section VI-B (post-impact velocity / eta)")
    p.add_argument("--lean", type=LEAN, default=0.0, metavar="DEG",
                   help="lean the torso forward by DEG degrees (swing leg's absolute angle kept), ramped in over "
                        "--lean-steps steps, as in Exp. 5")
    p.add_argument("--lean-steps", type=STEPS, default=None, metavar="N",
                   help="steps over which --lean is ramped in (default 20)")
    p.add_argument("--sensing", choices=catalog.SENSING, default="encoders",
                   help="14-bit encoders with filtered differentiated velocities (default), the same encoders "
                        "with a model-based velocity observer, or the exact state")
    p.add_argument("--plant", choices=catalog.PLANTS, default="stance",
                   help="stance: the model the gaits are designed on (rigid cables, pinned toe, rigid impact; "
                        "default); full: the 13-DoF model with cable stretch, compliant ground with LuGre "
                        "friction, a free swing spring and hard stops")
    p.add_argument("--ground-scale", type=GROUND_SCALE, default=1.0, metavar="K",
                   help="--plant full: the compliant ground's stiffness and damping times K (default 1: the ground "
                        "identified from MABEL's hopping; a sensitivity, e.g. 10 for a floor ten times stiffer)")
    _out(p)


def _walk_validate(args) -> None:
    steps = args.steps or 100
    if args.push is not None and args.push[1] >= steps:
        raise UsageError(f"--push {args.push[0]:g}@{args.push[1]}: step {args.push[1]} is never reached in "
                         f"{steps} steps (0 to {steps - 1}); raise --steps or push earlier")
    if args.lean_steps is not None and args.lean == 0.0:
        raise UsageError("--lean-steps applies with a non-zero --lean")
    if args.plant == "full" and args.impact_scale != 1.0:
        raise UsageError("--plant full: --impact-scale applies to the stance plant only (the full plant's impact is "
                         "its compliant ground's)")
    if args.plant != "full" and args.ground_scale != 1.0:
        raise UsageError("--ground-scale applies to --plant full only (the stance plant pins its toe: it has no ground "
                         "to scale)")
    gait = args.gait or catalog.DEFAULT_GAIT
    if gait not in catalog.GAITS and not os.path.isfile(gait):
        raise UsageError(f"--gait: {gait!r} is neither a shipped gait ({', '.join(catalog.GAITS)}) nor a file")
    why = catalog.walk_refusal(gait, args.controller or catalog.DEFAULT_CONTROLLER, args.sensing, args.plant)
    if why is not None:
        raise UsageError(f"--gait {gait}: {why}")


def _walk(args, progress):
    from bipedlab.robots.mabel.walking import study as wm

    gait = args.gait or catalog.DEFAULT_GAIT
    try:  # every field of the gait, before anything compiles; the walk takes it as loaded
        loaded = wm.load_gait(gait)
    except ValueError as e:
        raise UsageError(str(e)) from None
    lean_steps = 20 if args.lean_steps is None else args.lean_steps
    rec = wm.walk(gait, args.controller or catalog.DEFAULT_CONTROLLER, args.steps or 100, push=args.push,
                  eta=args.impact_scale, sensing=args.sensing, out=args.out, progress=progress, lean_deg=args.lean,
                  lean_steps=lean_steps, plant=args.plant, loaded=loaded, ground=args.ground_scale)
    return rec, wm.summary_walk


# ----------------------------------------------------------------------------- experiment
def _experiment_arguments(p) -> None:
    p.add_argument("name", choices=EXPERIMENTS, help=" | ".join(EXPERIMENTS))
    p.add_argument("--steps", type=STEPS, default=None,
                   help=f"steps per walk (defaults per experiment; push: at least {catalog.PUSH_STEP + 1}, to reach "
                        f"the push in step {catalog.PUSH_STEP}; impact-scaling: at least {catalog.STEADY_STEPS}; not "
                        f"for {' and '.join(catalog.NO_STEPS)})")
    _out(p)


def _experiment_validate(args) -> None:
    if args.steps is None:
        return
    why = catalog.experiment_steps_refusal(args.name, args.steps)
    if why is not None:
        raise UsageError(f"{args.name}: {why}")


def _experiment(args, progress):
    from bipedlab.robots.mabel.walking import experiments as wx

    return wx.run(args.name, steps=args.steps, out=args.out, progress=progress), wx.summary


# ----------------------------------------------------------------------------- hop
def _hop_arguments(p) -> None:
    p.add_argument("--hops", type=int_in(1, 10_000), default=100, help="hops to simulate (default 100)")
    p.add_argument("--no-torso-update", action="store_true",
                   help="the nominal controller, without the event-based torso update (44)")
    p.add_argument("--no-poincare", action="store_true", help="skip the Poincaré analysis")
    p.add_argument("--accuracy", action="store_true",
                   help="also compare the integrator against finer steps and RK4 on the first hop")
    p.add_argument("--robustness", type=int_in(1, 1000), default=None, metavar="N",
                   help="also drop the robot from N perturbed states and count hops with and without the update")
    _out(p)


def _hop(args, progress):
    from bipedlab.robots.mabel.hopping import study as hop_mabel

    rec = hop_mabel.study(args.hops, torso_update=not args.no_torso_update, poincare=not args.no_poincare,
                          accuracy=args.accuracy, robustness_samples=args.robustness, out=args.out, progress=progress)
    return rec, hop_mabel.summary


# ----------------------------------------------------------------------------- identify
def _identify_arguments(p) -> None:
    source = p.add_mutually_exclusive_group(required=True)
    source.add_argument("--synthetic", action="store_true",
                        help="generate the paper's experiments on a perturbed true robot and identify it")
    source.add_argument("--data", type=text, metavar="DIR",
                        help="identify from the CSV logs in DIR (format: bipedlab.robots.mabel.sysid.logs)")
    p.add_argument("--seed", type=SEED, default=None, help="synthetic: seed of the true robot and the noise (default 0)")
    p.add_argument("--noise", type=float_in(0.0, 100.0), default=None, metavar="LEVEL",
                   help="synthetic: rms encoder noise in counts, also scaling amplifier and scale noise (default 1)")
    p.add_argument("--noise-study", action="store_true",
                   help="synthetic: also repeat the identification at noise levels 0, 1, 2 and 4")
    p.add_argument("--quick", action="store_true", help=argparse.SUPPRESS)
    _out(p, "figures (PNG) and, for --synthetic, the logs (CSV)")


def _identify_validate(args) -> None:
    if args.data is not None and (args.seed is not None or args.noise is not None or args.noise_study):
        raise UsageError("--seed, --noise and --noise-study apply to --synthetic only")
    if args.data is not None and not os.path.isdir(args.data):
        raise UsageError(f"--data: {args.data!r} is not a folder")
    if args.data is not None:
        _check_log_files(args.data)


def _check_log_files(folder: str) -> None:
    """Every ``*.csv`` of the folder is a regular file (a FIFO or a device would block the
    reader or never end), found without opening any."""
    from pathlib import Path

    from bipedlab.inputs import special_kind

    for path in sorted(Path(folder).glob("*.csv")):
        kind = special_kind(path)
        if kind is not None:
            raise UsageError(f"--data: {path}: cannot be read ({kind}, not a regular file)")


def _identify(args, progress):
    from bipedlab.robots.mabel.sysid import LogError
    from bipedlab.robots.mabel.sysid import study as im

    try:
        rec = im.study(data=args.data, seed=args.seed or 0, noise=1.0 if args.noise is None else args.noise,
                       out=args.out, quick=args.quick, noise_levels=(0.0, 1.0, 2.0, 4.0) if args.noise_study else None,
                       progress=progress)
    except LogError as e:
        raise UsageError(str(e)) from None
    return rec, im.summary


COMMANDS = [
    Command("optimize", ROBOT, "design a compliant-HZD walking gait by optimisation", _optimize_arguments, _optimize,
            bench=(("--speed", "0.8"),)),
    Command("walk", ROBOT, "the experiments' closed loop: HZD walking on a designed gait, pushes, impact scaling, lean",
            _walk_arguments, _walk, validate=_walk_validate, bench=(("--steps", "3"),)),
    Command("experiment", ROBOT, "walking experiments: " + "|".join(EXPERIMENTS), _experiment_arguments, _experiment,
            validate=_experiment_validate, bench=(("long", "sweep"),)),
    Command("hop", ROBOT, "two-legged hopping on the 13-DoF model, with Poincaré analysis", _hop_arguments, _hop,
            bench=(("--hops", "5"),)),
    Command("identify", ROBOT, "system identification from synthetic experiments or logged data",
            _identify_arguments, _identify, validate=_identify_validate, bench=(("--synthetic", "--quick"),)),
]

from bipedlab.robots.mabel.robustness import HOPPING as _HOPPING, WALKING as _WALKING  # noqa: E402  (no JAX at import)

COMMANDS += [_WALKING, _HOPPING]
