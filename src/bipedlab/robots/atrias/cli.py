"""The ATRIAS-like biped's commands: ``bipedlab run atrias`` and ``bipedlab experiment atrias
sensitivity`` (registered with :mod:`bipedlab.registry`; the study modules are imported inside
``run``)."""
from __future__ import annotations

import argparse
import math

from bipedlab.commands import SEED, Command, UsageError, add_out, float_in, int_in, parse_float
from bipedlab.robots.atrias import catalog

MODEL_ERRORS = catalog.MODEL_ERRORS
MODEL_ERROR = float_in(-0.9, 2.0)  # relative: the controller assumes 0.1 to 3 times the true value


def model_error_value(value: str) -> tuple:
    """argparse type of one --model-error item: 'NAME=REL' -> (name, rel)."""
    name, sep, rel = value.partition("=")
    if not sep or name not in MODEL_ERRORS:
        raise argparse.ArgumentTypeError(f"expected NAME=REL with NAME one of {', '.join(MODEL_ERRORS)}, "
                                         f"got {value!r}")
    try:
        r = parse_float(rel)
    except ValueError:
        r = math.nan
    if not (math.isfinite(r) and MODEL_ERROR.lo <= r <= MODEL_ERROR.hi):
        raise argparse.ArgumentTypeError(f"expected {name}=REL with REL a number in {MODEL_ERROR.text}, got {value!r}")
    return name, r


def _run_arguments(p) -> None:
    p.add_argument("--terrain", choices=catalog.TERRAINS, default="flat",
                   help="flat ground; random steps every 3 m as derived from the paper (rough: independent levels "
                        "uniform in -H/2..H/2, changes up to H) or the former variant (rough-reflected: changes "
                        "uniform in -H..H, level reflected within -H..H); or a constant slope (default flat)")
    p.add_argument("--step-height", type=float_in(0.0, 0.5), default=None, metavar="H",
                   help="rough terrains: largest height change between steps in m (default 0.25)")
    p.add_argument("--slope", type=float_in(-30.0, 30.0), default=None, metavar="PCT",
                   help="slope: grade in percent (default 1)")
    span = p.add_mutually_exclusive_group()
    span.add_argument("--seconds", type=float_in(0.1, 600.0), default=None, metavar="T", help="simulated time in s")
    span.add_argument("--distance", type=float_in(1.0, 2000.0), default=None, metavar="D",
                      help="distance to run in m (default 60)")
    p.add_argument("--noise", action="store_true",
                   help="sensor noise of Section IV-C: +-3 deg, +-3 deg/s, +-3 cm, +-3 cm/s, sampled every 3 ms")
    p.add_argument("--delay-ms", type=float_in(0.0, 100.0), default=0.0, metavar="MS",
                   help="loop delay in ms: the controller sees every measurement MS late, so its forces act MS late "
                        "(Section IV-C); the controller does not know it")
    p.add_argument("--delay-compensation", action="store_true",
                   help="the controller knows the delay and bridges it (ballistic flight prediction, spring on the "
                        "predicted leg length, leg-length bandwidth cap); off by default")
    p.add_argument("--model-error", type=model_error_value, nargs="+", action="extend", default=[], metavar="NAME=REL",
                   help=f"relative error of a model parameter the controller assumes, e.g. mass=0.2 inertia=-0.5; "
                        f"NAME one of {', '.join(MODEL_ERRORS)}, REL in {MODEL_ERROR.text}, each NAME once")
    p.add_argument("--energy", choices=catalog.ENERGY, default="regulation",
                   help="stance energy management (default regulation)")
    p.add_argument("--trunk-offset", type=float_in(-45.0, 45.0), default=0.0, metavar="DEG",
                   help="pitch the trunk DEG away from its 10 deg reference at the start (Sec. IV-A's 10 deg "
                        "perturbation); a single run reports the steps until it settles (trunk_settle_steps)")
    p.add_argument("--controller", choices=catalog.CONTROLLERS, default="paper",
                   help="the paper's controller as published (default), or bipedlab's with two additions: "
                        + "; ".join(f"{k} ({v})" for k, v in catalog.ADDITIONS.items()))
    p.add_argument("--trials", type=int_in(1, 100_000), default=None, metavar="N",
                   help="run N random terrains (and noise / model-error draws) batched in one compiled call")
    p.add_argument("--seed", type=SEED, default=0, help="seed of the terrain and noise draws")
    add_out(p)


def _run_validate(args) -> None:
    names = [n for n, _ in args.model_error]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise UsageError(f"--model-error: {', '.join(twice)} given more than once")
    if args.delay_compensation and not args.delay_ms:
        raise UsageError("--delay-compensation applies with --delay-ms MS > 0")
    if args.step_height is not None and not args.terrain.startswith("rough"):
        raise UsageError(f"--step-height applies to --terrain rough, not {args.terrain}")
    if args.slope is not None and args.terrain == "flat":
        raise UsageError("--slope applies to --terrain slope or rough, not flat")


def _run(args, progress):
    """Run the study (options validated by _run_validate) with its own progress bar on stderr."""
    from bipedlab.robots.atrias import study as run_atrias

    errs = tuple(args.model_error)
    st = run_atrias.Settings(
        terrain=args.terrain, step_height=0.25 if args.step_height is None else float(args.step_height),
        slope=1.0 if args.slope is None else float(args.slope), seconds=args.seconds,
        rough_grade_percent=float(args.slope) if (args.slope is not None and args.terrain.startswith("rough")) else 0.0,
        distance=60.0 if args.distance is None else float(args.distance), noise=bool(args.noise),
        delay_ms=float(args.delay_ms), delay_compensation=bool(args.delay_compensation), model_error=errs,
        energy=args.energy, trials=args.trials, seed=int(args.seed), controller=args.controller,
        theta0_offset_deg=float(args.trunk_offset))
    return run_atrias.study(st, out_dir=args.out, progress=run_atrias.progress_bar), run_atrias.summary


def _experiment_arguments(p) -> None:
    p.add_argument("name", choices=catalog.EXPERIMENTS, help=" | ".join(catalog.EXPERIMENTS))
    p.add_argument("--trials", type=int_in(2, 100_000), default=None, metavar="N",
                   help="terrain draws of each batched run, at least 2: the standard errors are taken over them "
                        "(default: each row's own, 16 or 32)")
    p.add_argument("--distance", type=float_in(5.0, 2000.0), default=None, metavar="D",
                   help="distance of each run in m (default: each row's own, 60)")
    p.add_argument("--parameters", nargs="+", choices=list(catalog.SCALABLE), default=None, metavar="NAME",
                   help="the robot's values to scale (default all: " + ", ".join(catalog.SCALABLE) + ")")
    add_out(p)


def _experiment(args, progress):
    from bipedlab.robots.atrias import sensitivity

    rec = sensitivity.sensitivity(trials=args.trials, distance=args.distance, parameters=args.parameters, progress=progress)
    return rec, sensitivity.summary


COMMANDS = [
    Command("run", "atrias", "spring-mass running embedded in the articulated ATRIAS-like biped on unobserved terrain",
            _run_arguments, _run, validate=_run_validate, bench=(("--seconds", "2"),)),
    Command("experiment", "atrias", "the running study's experiments: sensitivity (the judged quantities' "
            "elasticities to the robot's values)", _experiment_arguments, _experiment,
            bench=(("sensitivity", "--trials", "2", "--distance", "10", "--parameters", "tau_max"),)),
]

from bipedlab.robots.atrias.robustness import COMMAND as _ROBUSTNESS  # noqa: E402  (no JAX at import)

COMMANDS.append(_ROBUSTNESS)
