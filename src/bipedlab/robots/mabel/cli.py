"""MABEL's commands: ``bipedlab optimize|walk|experiment|hop|identify mabel`` (registered with
:mod:`bipedlab.cli`; the walking, hopping and sysid study modules are imported inside
``run``)."""
from __future__ import annotations

import argparse
import math

from bipedlab.cli import Command, UsageError, nonnegative_float, positive_float, positive_int

ROBOT = "mabel"
EXPERIMENTS = ["nominal", "push", "efficient", "tracking", "impact-scaling", "fast", "sweep"]


def _out(p, what: str = "figures (PNG) and data (NPZ)") -> None:
    p.add_argument("--out", metavar="DIR", help=f"write {what} to DIR")


# ----------------------------------------------------------------------------- optimize
def _optimize_arguments(p) -> None:
    p.add_argument("--speed", type=positive_float, default=0.8, help="walking speed, m/s")
    p.add_argument("--step-length", type=positive_float, default=None, metavar="L",
                   help="prescribe the step length in m (e.g. 0.575, the paper's nominal gait)")
    p.add_argument("--cost", choices=["torque", "cmt"], default="torque",
                   help="integral of squared torque per step length, or mechanical cost of transport")
    p.add_argument("--no-poincare", action="store_true", help="skip the Poincaré analysis")
    p.add_argument("--save", metavar="FILE", help="write the gait to FILE (for walk --gait FILE)")
    _out(p)


def _optimize(args, progress):
    from bipedlab.robots.mabel.walking import study as wm

    rec = wm.optimize(args.speed, args.cost, save=args.save, out=args.out, poincare_check=not args.no_poincare,
                      progress=progress, step_length=args.step_length)
    return rec, wm.summary_optimize


# ----------------------------------------------------------------------------- walk
def _walk_arguments(p) -> None:
    p.add_argument("--steps", type=positive_int, default=None, help="number of steps (default 100)")
    p.add_argument("--controller", choices=["pdff", "iolin", "decentralized"], default=None,
                   help="pdff | iolin | decentralized (default pdff)")
    p.add_argument("--gait", metavar="GAIT", help="nominal | efficient | fast or a gait file from optimize --save "
                                                  "(default nominal)")
    p.add_argument("--push", metavar="FORCE@STEP", help="horizontal force (N, + forward) on the hip over the second "
                                                        "half of step STEP")
    p.add_argument("--impact-scale", type=positive_float, default=1.0, metavar="ETA",
                   help="impact scaling eta of Section VI-B (post-impact velocity / eta)")
    p.add_argument("--lean", type=float, default=0.0, metavar="DEG",
                   help="lean the torso forward by DEG degrees (swing leg's absolute angle kept), ramped in over "
                        "--lean-steps steps, as in Exp. 5")
    p.add_argument("--lean-steps", type=positive_int, default=20, metavar="N",
                   help="steps over which --lean is ramped in (default 20)")
    p.add_argument("--sensing", choices=["encoders", "observer", "ideal"], default="encoders",
                   help="14-bit encoders with filtered differentiated velocities (default), the same encoders "
                        "with a model-based velocity observer, or the exact state")
    _out(p)


def _walk(args, progress):
    from bipedlab.robots.mabel.walking import study as wm

    gait = args.gait or "nominal"
    try:
        wm.load_gait(gait)
        wm.parse_push(args.push)
    except ValueError as e:
        raise UsageError(str(e)) from None
    if not (math.isfinite(args.lean) and abs(args.lean) <= 45.0):
        raise UsageError(f"mabel: --lean must be within +-45 degrees, got {args.lean}")
    rec = wm.walk(gait, args.controller or "pdff", args.steps or 100, push=args.push, eta=args.impact_scale,
                  sensing=args.sensing, out=args.out, progress=progress, lean_deg=args.lean, lean_steps=args.lean_steps)
    return rec, wm.summary_walk


# ----------------------------------------------------------------------------- experiment
def _experiment_arguments(p) -> None:
    p.add_argument("name", choices=EXPERIMENTS, help=" | ".join(EXPERIMENTS))
    p.add_argument("--steps", type=positive_int, default=None, help="steps per walk (defaults per experiment)")
    _out(p)


def _experiment(args, progress):
    from bipedlab.robots.mabel.walking import experiments as wx

    return wx.run(args.name, steps=args.steps, out=args.out, progress=progress), wx.summary


# ----------------------------------------------------------------------------- hop
def _hop_arguments(p) -> None:
    p.add_argument("--hops", type=positive_int, default=100, help="hops to simulate (default 100)")
    p.add_argument("--no-torso-update", action="store_true",
                   help="the nominal controller, without the event-based torso update (44)")
    p.add_argument("--no-poincare", action="store_true", help="skip the Poincaré analysis")
    p.add_argument("--accuracy", action="store_true",
                   help="also compare the integrator against finer steps and RK4 on the first hop")
    p.add_argument("--robustness", type=positive_int, default=None, metavar="N",
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
    source.add_argument("--data", metavar="DIR",
                        help="identify from the CSV logs in DIR (format: bipedlab.robots.mabel.sysid.logs)")
    p.add_argument("--seed", type=int, default=None, help="synthetic: seed of the true robot and the noise (default 0)")
    p.add_argument("--noise", type=nonnegative_float, default=None, metavar="LEVEL",
                   help="synthetic: rms encoder noise in counts, also scaling amplifier and scale noise (default 1)")
    p.add_argument("--noise-study", action="store_true",
                   help="synthetic: also repeat the identification at noise levels 0, 1, 2 and 4")
    p.add_argument("--quick", action="store_true", help=argparse.SUPPRESS)
    _out(p, "figures (PNG) and, for --synthetic, the logs (CSV)")


def _identify(args, progress):
    from bipedlab.robots.mabel.sysid import LogError
    from bipedlab.robots.mabel.sysid import study as im

    if args.data is not None and (args.seed is not None or args.noise is not None or args.noise_study):
        raise UsageError("--seed, --noise and --noise-study apply to --synthetic only")
    try:
        rec = im.study(data=args.data, seed=args.seed or 0, noise=1.0 if args.noise is None else args.noise,
                       out=args.out, quick=args.quick, noise_levels=(0.0, 1.0, 2.0, 4.0) if args.noise_study else None,
                       progress=progress)
    except LogError as e:
        raise UsageError(str(e)) from None
    return rec, im.summary


COMMANDS = [
    Command("optimize", ROBOT, "design a compliant-HZD walking gait by optimisation", _optimize_arguments, _optimize),
    Command("walk", ROBOT, "the experiments' closed loop: HZD walking on a designed gait, pushes, impact scaling, lean",
            _walk_arguments, _walk),
    Command("experiment", ROBOT, "walking experiments: " + "|".join(EXPERIMENTS), _experiment_arguments, _experiment),
    Command("hop", ROBOT, "two-legged hopping on the 13-DoF model, with Poincaré analysis", _hop_arguments, _hop),
    Command("identify", ROBOT, "system identification from synthetic experiments or logged data",
            _identify_arguments, _identify),
]
