"""The core's ``bipedlab bench`` command: the speed of a registered scenario beside MuJoCo, or
(``--studies``) the first-run benchmark of the studies (:mod:`bipedlab.studybench`).

The scenarios are those the command modules declare in ``SCENARIOS``
(:class:`bipedlab.commands.Scenario`, found by :func:`bipedlab.registry.scenarios`); the core
names none of them. ``--scenario`` picks one (default: the first registered) and the scenario
runs with the parsed options as :class:`bipedlab.commands.BenchOptions`.
"""
from __future__ import annotations

import sys

from bipedlab.commands import BenchOptions, Command, UsageError, float_in, int_in, text


def _scenarios() -> list:
    from bipedlab import registry

    return registry.scenarios()


def _arguments(p) -> None:
    names = [s.name for s in _scenarios()]
    p.add_argument("--scenario", choices=names, default=names[0] if names else None, metavar="NAME",
                   help="the speed scenario: " + "; ".join(f"{s.name}: {s.help}" for s in _scenarios())
                        + (f" (default {names[0]})" if names else ""))
    p.add_argument("--batch", type=int_in(1, 1 << 20), nargs="+", default=[64, 256], metavar="N",
                   help="batch sizes for the batched bipedlab runs (64 is always run)")
    # at least 40 substeps of 0.25 ms, so that the rate is measured, not the call overhead
    p.add_argument("--seconds", type=float_in(0.01, 60.0), default=2.0, help="simulated seconds per rollout")
    p.add_argument("--threads", type=int_in(1, 1024), default=None,
                   help="CPU cores for MuJoCo threads and bipedlab batch sharding (default: all)")
    p.add_argument("--no-mujoco", action="store_true", help="skip the MuJoCo comparison")
    p.add_argument("--studies", nargs="*", type=text, default=None, metavar="NAME",
                   help="instead: the first-run benchmark of the studies (each study's short version from an "
                        "empty compilation cache, then warm: compile and run seconds, compiled programs, peak "
                        "memory); NAME selects studies by their leading words (default: all but the long ones)")
    p.add_argument("--cold-only", action="store_true", help="--studies: skip the warm runs")
    p.add_argument("--timeout", type=float_in(1.0, 86_400.0), default=None,
                   help="--studies: seconds after which one study run is stopped and reported as failed")


def _validate(args) -> None:
    if args.studies is not None:
        from bipedlab import studybench

        try:
            args.studies = studybench.select(args.studies, studybench.studies())
        except ValueError as e:
            raise UsageError(str(e)) from None
    elif args.scenario is None:
        raise UsageError("no speed scenario is registered (a command module declares them in SCENARIOS)")


def _cores(args) -> None:
    """Batched CPU rollouts use every core, as MuJoCo's do: set before JAX touches a device
    (not for --studies, whose studies run in their own processes with the user's settings)."""
    if args.studies is not None:
        return
    from bipedlab.sim import use_cpu_cores

    use_cpu_cores(args.threads)


def _progress(msg: str) -> None:
    print(f"[bench] {msg}", file=sys.stderr, flush=True)


def _run(args, progress):
    if args.studies is not None:  # the studies chosen by _validate
        from bipedlab import studybench

        return studybench.run(args.studies, warm=not args.cold_only, timeout=args.timeout, progress=progress), \
            studybench.summary
    scenario = next(s for s in _scenarios() if s.name == args.scenario)
    options = BenchOptions(batches=tuple(args.batch), seconds=args.seconds, threads=args.threads,
                           mujoco=not args.no_mujoco)
    return scenario.run(options, _progress)


COMMANDS = [
    Command("bench", None, "speed of the anchor scenario beside MuJoCo (single, batched, compile time)",
            _arguments, _run, compile_cache=False, before_jax=_cores, validate=_validate),
]
