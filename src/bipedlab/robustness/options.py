"""The ``bipedlab robustness <robot>`` command's shared options and hooks (no JAX at import,
so building the parser stays fast).

Options every robustness command has: ``--trials N``, ``--seed S``, ``--chunk C`` (trials per
device per compiled call), ``--out DIR``, ``--devices D`` (CPU devices this process exposes;
default: all its cores; ignored on GPU, where every local GPU is a device), and the
multi-process launch:

``--coordinator HOST:PORT`` (default ``$JAX_COORDINATOR_ADDRESS``), ``--num-processes N``
(default ``$JAX_NUM_PROCESSES``, else 1), ``--process-id I`` (default ``$JAX_PROCESS_ID``).
Under SLURM (``SLURM_NTASKS`` > 1) with none of them given, ``jax.distributed.initialize()``
reads the job itself. Every process runs the same command; process 0 writes ``--out``.
Pick the platform with ``JAX_PLATFORMS=cpu`` or ``JAX_PLATFORMS=cuda``.

A robot's module builds its command with :func:`command`.
"""
from __future__ import annotations

import os
from typing import Callable

from bipedlab.cli import SEED, Command, UsageError, add_out, int_in, text

TRIALS = int_in(1, 10_000_000)
PROCESSES = int_in(1, 65_536)


def _env_int(name: str):
    v = os.environ.get(name)
    try:
        return int(v) if v not in (None, "") else None
    except ValueError:
        return None


def add_arguments(p, trials: int, chunk: int) -> None:
    p.add_argument("--trials", type=TRIALS, default=trials, help=f"number of trials (default {trials})")
    p.add_argument("--seed", type=SEED, default=0, help="seed of the trials' draws")
    p.add_argument("--chunk", type=int_in(1, 1 << 20), default=chunk,
                   help=f"trials per device per compiled call (default {chunk})")
    p.add_argument("--devices", type=int_in(1, 4096), default=None,
                   help="CPU devices of this process (default: its CPU cores; GPUs: every local GPU)")
    p.add_argument("--coordinator", type=text, metavar="HOST:PORT", default=None,
                   help="coordinator of a multi-process run (default $JAX_COORDINATOR_ADDRESS)")
    p.add_argument("--num-processes", type=PROCESSES, default=None,
                   help="processes of a multi-process run (default $JAX_NUM_PROCESSES, else 1)")
    p.add_argument("--process-id", type=int_in(0, 65_535), default=None,
                   help="this process's index (default $JAX_PROCESS_ID)")
    add_out(p, "the trials' outcomes (outcomes.npz) and survival figures (PNG)")


def validate(args) -> None:
    """Fill the launch options from the environment and check them; a process other than 0
    writes no ``--out`` (process 0 writes the gathered outcomes)."""
    args.coordinator = args.coordinator or os.environ.get("JAX_COORDINATOR_ADDRESS") or None
    if args.num_processes is None:
        args.num_processes = _env_int("JAX_NUM_PROCESSES")
    if args.process_id is None:
        args.process_id = _env_int("JAX_PROCESS_ID")
    n = args.num_processes
    if n is not None and n > 1:
        if args.coordinator is None:
            raise UsageError("--num-processes > 1 needs --coordinator HOST:PORT (or $JAX_COORDINATOR_ADDRESS)")
        if args.process_id is None:
            raise UsageError("--num-processes > 1 needs --process-id (or $JAX_PROCESS_ID)")
        if args.process_id >= n:
            raise UsageError(f"--process-id {args.process_id} is not below --num-processes {n}")
    elif args.process_id not in (None, 0):
        raise UsageError(f"--process-id {args.process_id} needs --num-processes above it")
    pid = args.process_id if args.process_id is not None else _env_int("SLURM_PROCID")
    if pid:
        args.out = None


def before_jax(args) -> None:
    from bipedlab.robustness import distributed

    cpu = args.devices or (None if "cuda" in os.environ.get("JAX_PLATFORMS", "") else os.cpu_count())
    distributed.initialize(args.coordinator, args.num_processes, args.process_id, cpu_devices=cpu)


def command(robot: str, help: str, build: Callable, add_options: Callable | None = None, trials: int = 64,
            chunk: int = 16, check: Callable | None = None) -> Command:
    """The ``robustness <robot>`` Command: ``build(args, progress) -> Study`` makes the study
    (imports inside), ``add_options(parser)`` adds the robot's own options, ``check(args)`` its
    own validation; the engine runs it with the shared options above."""

    def add(p):
        if add_options is not None:
            add_options(p)
        add_arguments(p, trials, chunk)

    def check_all(args):
        validate(args)
        if check is not None:
            check(args)

    def run(args, progress):
        from bipedlab.robustness import engine

        study = build(args, progress)
        progress(f"{args.trials} trials of {study.name}, compiling first")
        rec = engine.run(study, args.trials, args.seed, args.chunk, out=args.out)
        return rec, engine.summary

    return Command("robustness", robot, help, add, run, before_jax=before_jax, validate=check_all)
