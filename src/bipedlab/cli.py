"""The ``bipedlab`` command: a thin layer over :mod:`bipedlab.studies`.

``bipedlab <study> [options]`` prints a short summary; ``--json`` prints one JSON object and
nothing else on stdout; progress goes to stderr; bad input exits with status 2 and one line
``bipedlab: error: ...``.
"""
from __future__ import annotations

import argparse
import json
import math
import sys

STUDIES = {
    "bench": "speed of the anchor scenario beside MuJoCo (single, batched, compile time)",
    "optimize": "design a periodic HZD walking gait by optimisation (five-link, mabel)",
    "walk": "closed-loop walking: HZD from a designed gait (five-link, mabel), nonkinematic (seven-link)",
    "experiment": "walking experiments: mabel nominal|push|efficient|tracking|impact-scaling|fast|sweep; seven-link free-swing|low-gain-pd",
    "run": "spring-mass running embedded in the articulated ATRIAS-like biped on unobserved terrain (atrias)",
    "hop": "two-legged hopping on MABEL's 13-DoF model, with Poincaré analysis (mabel)",
    "identify": "MABEL's system identification from synthetic experiments or logged data (mabel)",
}


MABEL_EXPERIMENTS = ["nominal", "push", "efficient", "tracking", "impact-scaling", "fast", "sweep"]
SEVEN_LINK_EXPERIMENTS = ["free-swing", "low-gain-pd"]


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, status 2, no usage dump
        print(f"bipedlab: error: {message}", file=sys.stderr)
        raise SystemExit(2)


def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if v <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return v


def _number(text: str, strict: bool) -> float:
    kind = "positive" if strict else "non-negative"
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a {kind} number, got {text!r}") from None
    if not (math.isfinite(v) and (v > 0 if strict else v >= 0)):
        raise argparse.ArgumentTypeError(f"expected a {kind} number, got {text!r}")
    return v


def _positive_float(text: str) -> float:
    return _number(text, strict=True)


def _nonnegative_float(text: str) -> float:
    return _number(text, strict=False)


def _progress(msg: str) -> None:
    print(f"[bipedlab] {msg}", file=sys.stderr, flush=True)


def _enable_compile_cache() -> None:
    """Keep compiled programs between runs (first runs compile; later ones start fast)."""
    import os

    import jax

    path = os.environ.get("BIPEDLAB_CACHE_DIR") or os.path.join(os.path.expanduser("~"), ".cache", "bipedlab", "xla")
    try:
        os.makedirs(path, exist_ok=True)
        jax.config.update("jax_compilation_cache_dir", path)
    except OSError:
        pass


def build_parser() -> argparse.ArgumentParser:
    epilog = "studies:\n" + "\n".join(f"  {k:<10} {v}" for k, v in STUDIES.items())
    p = _Parser(prog="bipedlab", description="Planar bipedal robots: models, controllers, batched simulation.",
                epilog=epilog, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="study", metavar="<study>", parser_class=_Parser)
    b = sub.add_parser("bench", help=STUDIES["bench"], description=STUDIES["bench"])
    b.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    b.add_argument("--batch", type=_positive_int, nargs="+", default=[64, 256], metavar="N",
                   help="batch sizes for the batched bipedlab runs (64 is always run)")
    b.add_argument("--seconds", type=_positive_float, default=2.0, help="simulated seconds per rollout")
    b.add_argument("--threads", type=_positive_int, default=None, help="CPU cores for MuJoCo threads and bipedlab batch sharding (default: all)")
    b.add_argument("--no-mujoco", action="store_true", help="skip the MuJoCo comparison")

    o = sub.add_parser("optimize", help=STUDIES["optimize"], description=STUDIES["optimize"])
    o.add_argument("robot", choices=["five-link", "mabel"])
    o.add_argument("--speed", type=_positive_float, default=0.8, help="walking speed, m/s")
    o.add_argument("--step-length", type=_positive_float, default=None, metavar="L",
                   help="mabel: prescribe the step length in m (e.g. 0.575, the paper's nominal gait)")
    o.add_argument("--cost", choices=["torque", "cmt"], default="torque",
                   help="integral of squared torque per step length, or mechanical cost of transport")
    o.add_argument("--controller", choices=["iolin", "pd"], default="iolin",
                   help="five-link: controller for the Poincaré analysis (MABEL reports PD + feedforward and HZD)")
    o.add_argument("--no-poincare", action="store_true", help="mabel: skip the Poincaré analysis")
    o.add_argument("--save", metavar="FILE", help="write the gait to FILE (for walk --gait FILE)")
    o.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    o.add_argument("--out", metavar="DIR", help="write figures (PNG) and data (NPZ) to DIR")

    w = sub.add_parser("walk", help=STUDIES["walk"], description=STUDIES["walk"])
    w.add_argument("robot", choices=["five-link", "mabel", "seven-link"])
    w.add_argument("--steps", type=_positive_int, default=None, help="number of steps (five-link 50, mabel 100, seven-link 30)")
    w.add_argument("--params", choices=["paper", "tuned"], default=None,
                   help="seven-link: the controller's Table II parameters as published, or retuned for the planar model (default tuned)")
    w.add_argument("--perturb", type=_nonnegative_float, default=0.0,
                   help="five-link: relative size S of a random offset of the initial state: z0 = z* (1 + S N(0,1))")
    w.add_argument("--controller", choices=["iolin", "pd", "pdff", "decentralized"], default=None,
                   help="five-link: iolin | pd (default iolin); mabel: pdff | iolin | decentralized (default pdff)")
    w.add_argument("--gait", metavar="GAIT",
                   help="a gait file from optimize --save; mabel also takes nominal | efficient | fast (default nominal)")
    w.add_argument("--push", metavar="FORCE@STEP", help="mabel: horizontal force (N, + forward) on the hip over the second half of step STEP")
    w.add_argument("--impact-scale", type=_positive_float, default=1.0, metavar="ETA",
                   help="mabel: impact scaling eta of Section VI-B (post-impact velocity / eta)")
    w.add_argument("--lean", type=float, default=0.0, metavar="DEG",
                   help="mabel: lean the torso forward by DEG degrees (swing leg's absolute angle kept), ramped in over --lean-steps steps, as in Exp. 5")
    w.add_argument("--lean-steps", type=_positive_int, default=20, metavar="N", help="mabel: steps over which --lean is ramped in (default 20)")
    w.add_argument("--sensing", choices=["encoders", "observer", "ideal"], default="encoders",
                   help="mabel: 14-bit encoders with filtered differentiated velocities (default), the same encoders "
                        "with a model-based velocity observer, or the exact state")
    w.add_argument("--seed", type=int, default=0, help="seed of the perturbation")
    w.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    w.add_argument("--out", metavar="DIR", help="write figures (PNG) and data (NPZ) to DIR")

    e = sub.add_parser("experiment", help=STUDIES["experiment"], description=STUDIES["experiment"])
    e.add_argument("robot", choices=["mabel", "seven-link"])
    e.add_argument("name", choices=MABEL_EXPERIMENTS + SEVEN_LINK_EXPERIMENTS,
                   help="mabel: " + " | ".join(MABEL_EXPERIMENTS) + "; seven-link: " + " | ".join(SEVEN_LINK_EXPERIMENTS))
    e.add_argument("--steps", type=_positive_int, default=None, help="steps per walk (defaults per experiment)")
    e.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    e.add_argument("--out", metavar="DIR", help="write figures (PNG) and data (NPZ) to DIR")

    h = sub.add_parser("hop", help=STUDIES["hop"], description=STUDIES["hop"])
    h.add_argument("robot", choices=["mabel"])
    h.add_argument("--hops", type=_positive_int, default=100, help="hops to simulate (default 100)")
    h.add_argument("--no-torso-update", action="store_true",
                   help="the nominal controller, without the event-based torso update (44)")
    h.add_argument("--no-poincare", action="store_true", help="skip the Poincaré analysis")
    h.add_argument("--accuracy", action="store_true",
                   help="also compare the integrator against finer steps and RK4 on the first hop")
    h.add_argument("--robustness", type=_positive_int, default=None, metavar="N",
                   help="also drop the robot from N perturbed states and count hops with and without the update")
    h.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    h.add_argument("--out", metavar="DIR", help="write figures (PNG) and data (NPZ) to DIR")

    r = sub.add_parser("run", help=STUDIES["run"], description=STUDIES["run"])
    r.add_argument("robot", choices=["atrias"])
    r.add_argument("--terrain", choices=["flat", "rough", "slope"], default="flat",
                   help="flat ground, random steps every 3 m, or a constant slope (default flat)")
    r.add_argument("--step-height", type=_nonnegative_float, default=None, metavar="H",
                   help="rough: largest step height in m, steps uniform in [-H, H] (default 0.25)")
    r.add_argument("--slope", type=float, default=None, metavar="PCT", help="slope: grade in percent (default 1)")
    span = r.add_mutually_exclusive_group()
    span.add_argument("--seconds", type=_positive_float, default=None, metavar="T", help="simulated time in s")
    span.add_argument("--distance", type=_positive_float, default=None, metavar="D",
                      help="distance to run in m (default 60)")
    r.add_argument("--noise", action="store_true",
                   help="sensor noise of Section IV-C: +-3 deg, +-3 deg/s, +-3 cm, +-3 cm/s, sampled every 3 ms")
    r.add_argument("--delay-ms", type=_nonnegative_float, default=0.0, metavar="MS", help="sensing delay in ms")
    r.add_argument("--model-error", nargs="+", action="extend", default=[], metavar="NAME=REL",
                   help="relative error of a model parameter the controller assumes, e.g. mass=0.2 inertia=-0.5")
    r.add_argument("--energy", choices=["conservation", "regulation"], default="regulation",
                   help="stance energy management (default regulation)")
    r.add_argument("--trials", type=_positive_int, default=None, metavar="N",
                   help="run N random terrains (and noise / model-error draws) batched in one compiled call")
    r.add_argument("--seed", type=int, default=0, help="seed of the terrain and noise draws")
    r.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    r.add_argument("--out", metavar="DIR", help="write figures (PNG) and data (NPZ) to DIR")

    i = sub.add_parser("identify", help=STUDIES["identify"], description=STUDIES["identify"])
    i.add_argument("robot", choices=["mabel"])
    source = i.add_mutually_exclusive_group(required=True)
    source.add_argument("--synthetic", action="store_true",
                        help="generate the paper's experiments on a perturbed true robot and identify it")
    source.add_argument("--data", metavar="DIR", help="identify from the CSV logs in DIR (format: bipedlab.robots.mabel.sysid.logs)")
    i.add_argument("--seed", type=int, default=None, help="synthetic: seed of the true robot and the noise (default 0)")
    i.add_argument("--noise", type=_nonnegative_float, default=None, metavar="LEVEL",
                   help="synthetic: rms encoder noise in counts, also scaling amplifier and scale noise (default 1)")
    i.add_argument("--noise-study", action="store_true",
                   help="synthetic: also repeat the identification at noise levels 0, 1, 2 and 4")
    i.add_argument("--quick", action="store_true", help=argparse.SUPPRESS)
    i.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    i.add_argument("--out", metavar="DIR", help="write figures (PNG) and, for --synthetic, the logs (CSV) to DIR")
    return p


def _json_safe(x):
    """Non-finite floats (a fallen trial's statistics) -> None, so the JSON stays strict."""
    if isinstance(x, dict):
        return {k: _json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_json_safe(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def _emit(record: dict, as_json: bool, summary) -> None:
    if as_json:
        print(json.dumps(_json_safe(record), allow_nan=False, default=float))
    else:
        print(summary(record))


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.study is None:
        parser.print_help()
        return 0
    if args.study == "bench":
        from bipedlab.sim import use_cpu_cores
        from bipedlab.robots.five_link import bench

        use_cpu_cores(args.threads)  # batched CPU rollouts use every core, as MuJoCo's do

        rec = bench.run(args.batch, args.seconds, args.threads, not args.no_mujoco, progress=bench._eprint)
        _emit(rec, args.json, bench.summary)
        return 0
    _enable_compile_cache()
    if args.study == "hop":
        from bipedlab.robots.mabel.hopping import study as hop_mabel

        rec = hop_mabel.study(args.hops, torso_update=not args.no_torso_update, poincare=not args.no_poincare,
                              accuracy=args.accuracy, robustness_samples=args.robustness, out=args.out,
                              progress=_progress)
        _emit(rec, args.json, hop_mabel.summary)
        return 0
    if args.study == "identify":
        return _identify(parser, args)
    if args.study == "run":
        from bipedlab.robots.atrias import study as run_atrias

        rec, summary = run_atrias.cli_record(parser, args, progress=run_atrias.progress_bar)
        _emit(rec, args.json, summary)
        return 0
    if getattr(args, "robot", None) == "seven-link":
        from bipedlab.robots.seven_link import study as walk_seven_link

        rec, summary = walk_seven_link.cli_record(parser, args, progress=_progress)
        _emit(rec, args.json, summary)
        return 0
    if args.study == "experiment":
        if args.name not in MABEL_EXPERIMENTS:
            parser.error(f"mabel: experiment must be one of {', '.join(MABEL_EXPERIMENTS)}, got {args.name}")
        from bipedlab.robots.mabel.walking import experiments as wx

        rec = wx.run(args.name, steps=args.steps, out=args.out, progress=_progress)
        _emit(rec, args.json, wx.summary)
        return 0
    if getattr(args, "params", None) is not None:
        parser.error("--params applies to seven-link only")
    if getattr(args, "robot", None) == "mabel":
        return _mabel(parser, args)
    if args.study == "walk":
        if args.controller not in (None, "iolin", "pd"):
            parser.error(f"five-link: --controller must be iolin or pd, got {args.controller}")
        if args.push or args.impact_scale != 1.0 or args.lean:
            parser.error("five-link: --push, --impact-scale and --lean apply to mabel only")
        args.controller = args.controller or "iolin"
        args.steps = args.steps or 50
    from bipedlab.robots.five_link import study as hz

    if args.study == "optimize":
        if args.step_length is not None:
            parser.error("five-link: --step-length applies to mabel only")
        rec = hz.optimize(args.speed, args.cost, args.controller, save=args.save, out=args.out, progress=_progress)
        _emit(rec, args.json, hz.summary_optimize)
    elif args.study == "walk":
        try:
            hz.load_gait(args.gait)
        except ValueError as e:
            parser.error(str(e))
        rec = hz.walk(args.steps, args.perturb, args.controller, args.gait, args.seed, out=args.out, progress=_progress)
        _emit(rec, args.json, hz.summary_walk)
    return 0


def _identify(parser, args) -> int:
    from bipedlab.robots.mabel.sysid import study as im
    from bipedlab.robots.mabel.sysid import LogError

    if args.data is not None and (args.seed is not None or args.noise is not None or args.noise_study):
        parser.error("--seed, --noise and --noise-study apply to --synthetic only")
    try:
        rec = im.study(data=args.data, seed=args.seed or 0, noise=1.0 if args.noise is None else args.noise,
                       out=args.out, quick=args.quick, noise_levels=(0.0, 1.0, 2.0, 4.0) if args.noise_study else None,
                       progress=_progress)
    except LogError as e:
        parser.error(str(e))
    _emit(rec, args.json, im.summary)
    return 0


def _mabel(parser, args) -> int:
    from bipedlab.robots.mabel.walking import study as wm

    if args.study == "optimize":
        rec = wm.optimize(args.speed, args.cost, save=args.save, out=args.out, poincare_check=not args.no_poincare,
                          progress=_progress, step_length=args.step_length)
        _emit(rec, args.json, wm.summary_optimize)
        return 0
    controller = args.controller or "pdff"
    if controller == "pd":
        parser.error("mabel: --controller must be pdff, iolin or decentralized")
    if args.perturb:
        parser.error("mabel: --perturb applies to five-link; use --push or --impact-scale")
    gait = args.gait or "nominal"
    try:
        wm.load_gait(gait)
        wm.parse_push(args.push)
    except ValueError as e:
        parser.error(str(e))
    if not (math.isfinite(args.lean) and abs(args.lean) <= 45.0):
        parser.error(f"mabel: --lean must be within +-45 degrees, got {args.lean}")
    rec = wm.walk(gait, controller, args.steps or 100, push=args.push, eta=args.impact_scale, sensing=args.sensing,
                  out=args.out, progress=_progress, lean_deg=args.lean, lean_steps=args.lean_steps)
    _emit(rec, args.json, wm.summary_walk)
    return 0


if __name__ == "__main__":
    sys.exit(main())
