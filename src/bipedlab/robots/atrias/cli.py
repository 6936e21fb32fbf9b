"""The ATRIAS-like biped's command: ``bipedlab run atrias`` (registered with
:mod:`bipedlab.cli`; the study module is imported inside ``run``)."""
from __future__ import annotations

import math

from bipedlab.cli import Command, UsageError, nonnegative_float, positive_float, positive_int


def _run_arguments(p) -> None:
    p.add_argument("--terrain", choices=["flat", "rough", "slope"], default="flat",
                   help="flat ground, random steps every 3 m, or a constant slope (default flat)")
    p.add_argument("--step-height", type=nonnegative_float, default=None, metavar="H",
                   help="rough: largest step height in m, steps uniform in [-H, H] (default 0.25)")
    p.add_argument("--slope", type=float, default=None, metavar="PCT", help="slope: grade in percent (default 1)")
    span = p.add_mutually_exclusive_group()
    span.add_argument("--seconds", type=positive_float, default=None, metavar="T", help="simulated time in s")
    span.add_argument("--distance", type=positive_float, default=None, metavar="D",
                      help="distance to run in m (default 60)")
    p.add_argument("--noise", action="store_true",
                   help="sensor noise of Section IV-C: +-3 deg, +-3 deg/s, +-3 cm, +-3 cm/s, sampled every 3 ms")
    p.add_argument("--delay-ms", type=nonnegative_float, default=0.0, metavar="MS", help="sensing delay in ms")
    p.add_argument("--model-error", nargs="+", action="extend", default=[], metavar="NAME=REL",
                   help="relative error of a model parameter the controller assumes, e.g. mass=0.2 inertia=-0.5")
    p.add_argument("--energy", choices=["conservation", "regulation"], default="regulation",
                   help="stance energy management (default regulation)")
    p.add_argument("--trials", type=positive_int, default=None, metavar="N",
                   help="run N random terrains (and noise / model-error draws) batched in one compiled call")
    p.add_argument("--seed", type=int, default=0, help="seed of the terrain and noise draws")
    p.add_argument("--out", metavar="DIR", help="write figures (PNG) and data (NPZ) to DIR")


def _run(args, progress):
    """Validate the options (UsageError on bad input), then run the study with its own
    progress bar on stderr."""
    from bipedlab.robots.atrias import study as run_atrias

    try:
        errs = run_atrias.parse_model_errors(args.model_error or [])
    except ValueError as e:
        raise UsageError(str(e)) from None
    if args.step_height is not None and args.terrain != "rough":
        raise UsageError(f"--step-height applies to --terrain rough, not {args.terrain}")
    if args.slope is not None and args.terrain == "flat":
        raise UsageError("--slope applies to --terrain slope or rough, not flat")
    if args.slope is not None and not (math.isfinite(args.slope) and abs(args.slope) <= 30.0):
        raise UsageError(f"--slope must be a grade within +-30 percent, got {args.slope}")
    st = run_atrias.Settings(
        terrain=args.terrain, step_height=0.25 if args.step_height is None else float(args.step_height),
        slope=1.0 if args.slope is None else float(args.slope), seconds=args.seconds,
        rough_grade_percent=float(args.slope) if (args.slope is not None and args.terrain == "rough") else 0.0,
        distance=60.0 if args.distance is None else float(args.distance), noise=bool(args.noise),
        delay_ms=float(args.delay_ms), model_error=errs, energy=args.energy, trials=args.trials, seed=int(args.seed))
    return run_atrias.study(st, out_dir=args.out, progress=run_atrias.progress_bar), run_atrias.summary


COMMANDS = [
    Command("run", "atrias", "spring-mass running embedded in the articulated ATRIAS-like biped on unobserved terrain",
            _run_arguments, _run),
]
