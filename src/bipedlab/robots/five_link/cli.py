"""The five-link biped's commands: ``bipedlab bench``, ``bipedlab optimize five-link`` and
``bipedlab walk five-link`` (registered with :mod:`bipedlab.registry`; study modules are imported
inside ``run``)."""
from __future__ import annotations

import os

from bipedlab.commands import SEED, Command, UsageError, add_out, add_save, float_in, int_in, text

ROBOT = "five-link"
CONTROLLERS = ["iolin", "pd"]
STEPS = int_in(1, 10_000)
SPEED = float_in(0.1, 2.0)  # m/s: a leg of 0.8 m walks, it does not run
PERTURB = float_in(0.0, 1.0)  # relative: 1 already doubles a state component at one sigma


def _out(p) -> None:
    add_out(p)


# ----------------------------------------------------------------------------- bench
def _bench_arguments(p) -> None:
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


def _bench_validate(args) -> None:
    if args.studies is not None:
        from bipedlab import studybench

        try:
            studybench.select(args.studies, studybench.studies())
        except ValueError as e:
            raise UsageError(str(e)) from None


def _bench_cores(args) -> None:
    """Batched CPU rollouts use every core, as MuJoCo's do: set before JAX touches a device
    (not for --studies, whose studies run in their own processes with the user's settings)."""
    if args.studies is not None:
        return
    from bipedlab.sim import use_cpu_cores

    use_cpu_cores(args.threads)


def _bench(args, progress):
    if args.studies is not None:
        from bipedlab import studybench

        chosen = studybench.select(args.studies, studybench.studies())
        return studybench.run(chosen, warm=not args.cold_only, timeout=args.timeout, progress=progress), \
            studybench.summary
    from bipedlab.robots.five_link import bench

    rec = bench.run(args.batch, args.seconds, args.threads, not args.no_mujoco, progress=bench._eprint)
    return rec, bench.summary


# ----------------------------------------------------------------------------- optimize
def _optimize_arguments(p) -> None:
    p.add_argument("--speed", type=SPEED, default=0.8, help="walking speed, m/s")
    p.add_argument("--cost", choices=["torque", "cmt"], default="torque",
                   help="integral of squared torque per step length, or mechanical cost of transport")
    p.add_argument("--controller", choices=CONTROLLERS, default="iolin", help="controller for the Poincaré analysis")
    add_save(p, "the gait (for walk --gait FILE)")
    _out(p)


def _optimize(args, progress):
    from bipedlab.robots.five_link import study as hz

    rec = hz.optimize(args.speed, args.cost, args.controller, save=args.save, out=args.out, progress=progress)
    return rec, hz.summary_optimize


# ----------------------------------------------------------------------------- walk
def _walk_arguments(p) -> None:
    p.add_argument("--steps", type=STEPS, default=None, help="number of steps (default 50)")
    p.add_argument("--perturb", type=PERTURB, default=0.0,
                   help="relative size S of a random offset of the initial state: z0 = z* (1 + S N(0,1))")
    p.add_argument("--controller", choices=CONTROLLERS, default=None, help="iolin | pd (default iolin)")
    p.add_argument("--gait", type=text, metavar="GAIT", help="a gait file from optimize --save (default: the shipped gait)")
    p.add_argument("--seed", type=SEED, default=0, help="seed of the perturbation")
    _out(p)


def _walk_validate(args) -> None:
    if args.gait is not None and not os.path.isfile(args.gait):
        raise UsageError(f"--gait: {args.gait!r} is not a file")


def _walk(args, progress):
    from bipedlab.robots.five_link import study as hz

    try:
        hz.load_gait(args.gait)
    except ValueError as e:
        raise UsageError(str(e)) from None
    rec = hz.walk(args.steps or 50, args.perturb, args.controller or "iolin", args.gait, args.seed, out=args.out,
                  progress=progress)
    return rec, hz.summary_walk


COMMANDS = [
    Command("bench", None, "speed of the anchor scenario beside MuJoCo (single, batched, compile time)",
            _bench_arguments, _bench, compile_cache=False, before_jax=_bench_cores, validate=_bench_validate),
    Command("optimize", ROBOT, "design a periodic HZD walking gait by optimisation", _optimize_arguments, _optimize,
            bench=((),)),
    Command("walk", ROBOT, "closed-loop HZD walking on a designed gait, optionally from a perturbed state",
            _walk_arguments, _walk, validate=_walk_validate, bench=(("--steps", "10"),)),
]

from bipedlab.robots.five_link.robustness import COMMAND as _ROBUSTNESS  # noqa: E402  (no JAX at import)

COMMANDS.append(_ROBUSTNESS)
