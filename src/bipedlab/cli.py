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
}


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


def _positive_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}") from None
    if not (v > 0 and math.isfinite(v)):
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return v


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
    return p


def _emit(record: dict, as_json: bool, summary) -> None:
    if as_json:
        print(json.dumps(record, allow_nan=False, default=float))
    else:
        print(summary(record))


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.study is None:
        parser.print_help()
        return 0
    if args.study == "bench":
        from .sim import use_cpu_cores
        from .studies import bench

        use_cpu_cores(args.threads)  # batched CPU rollouts use every core, as MuJoCo's do

        rec = bench.run(args.batch, args.seconds, args.threads, not args.no_mujoco, progress=bench._eprint)
        _emit(rec, args.json, bench.summary)
    return 0


if __name__ == "__main__":
    sys.exit(main())
