"""The ``bipedlab robustness <robot>`` command's shared options and hooks (no JAX at import,
so building the parser stays fast).

Options every robustness command has: ``--trials N``, ``--seed S``, ``--chunk C`` (trials per
device per compiled call), ``--out DIR``, ``--devices D`` (CPU devices this process exposes;
default: all its cores; ignored on GPU, where every local GPU is a device), and the
multi-process launch:

``--coordinator HOST:PORT`` (default ``$JAX_COORDINATOR_ADDRESS``), ``--num-processes N``
(default ``$JAX_NUM_PROCESSES``, else 1), ``--process-id I`` (default ``$JAX_PROCESS_ID``),
``--init-timeout S`` (seconds to wait for the processes to join, default
:data:`INIT_TIMEOUT`). Under SLURM (``SLURM_NTASKS`` > 1) with none of them given,
``jax.distributed.initialize()`` reads the job itself. Every process runs the same command;
process 0 writes ``--out``. Pick the platform with ``JAX_PLATFORMS=cpu`` or
``JAX_PLATFORMS=cuda``.

Everything the launch reads is checked before any work, options and environment alike, each
refusal one line naming the option or the variable: integers are ASCII digits within their
range (``$SLURM_NTASKS`` and ``$JAX_NUM_PROCESSES`` from 1, ``$JAX_PROCESS_ID`` and
``$SLURM_PROCID`` below the process count), ``$JAX_LOCAL_DEVICE_IDS`` a comma-separated list of
them (checked in a single-process run too), the coordinator ``HOST:PORT`` with PORT in [1, 65535] (HOST a name, an IPv4 address or
a bracketed IPv6 one), and a SLURM job (``SLURM_NTASKS`` > 1) must also set the variables JAX
reads it from. A process that cannot join within ``--init-timeout`` (process 0: the others
did not connect; the others: no coordinator answered) ends with status 2 and one line.

Resuming: with ``--out DIR`` the outcomes are written chunk by chunk (one file per compiled
call) to ``DIR/chunks`` as they are computed, outside the staged outputs, so that they outlive
an interruption (SIGINT, SIGTERM, a killed process, a full disk). The same command run again
reads them back and computes only the rest, ending with the outcomes of an uninterrupted run,
bit for bit (:mod:`bipedlab.robustness.chunks`). What a run is — its options but the launch
options (:data:`LAUNCH_OPTIONS`), the files they name, the devices, the code — is recorded in
``DIR/chunks/manifest.json``; another run on the same DIR is refused in one line (status 2)
unless ``--restart``, which discards the chunks. A write that fails (a full disk) ends the run
with status 1 and one line, the chunks written so far kept. The chunks stay after a complete
run (a rerun reads everything back); delete ``DIR/chunks`` to free the space.

A robot's module builds its command with :func:`command`.
"""
from __future__ import annotations

import argparse
import os
import re
import sys
from typing import Callable

from bipedlab.commands import SEED, Command, UsageError, add_out, int_in, one_line
from bipedlab.outputs import final_path

TRIALS = int_in(1, 100_000)
PROCESSES = int_in(1, 65_536)
PROCESS_ID = int_in(0, 65_535)
INIT_TIMEOUT = 60
"""Default seconds a process waits for a multi-process run to come together."""
#: what JAX reads a SLURM job from (besides SLURM_NTASKS)
SLURM_JOB = ("SLURM_JOB_ID", "SLURM_STEP_NODELIST", "SLURM_PROCID", "SLURM_LOCALID")

_HOST = r"(?:[A-Za-z0-9](?:[A-Za-z0-9._-]*[A-Za-z0-9])?|\[[0-9A-Fa-f:.]+\])"
_ADDRESS = re.compile(rf"({_HOST}):([0-9]{{1,5}})", re.ASCII)
ADDRESS_FORM = "HOST:PORT with PORT in [1, 65535] (e.g. 127.0.0.1:12345 or [::1]:12345)"


def address_problem(value: str) -> str | None:
    """Why ``value`` is not a coordinator address HOST:PORT (None if it is one)."""
    m = _ADDRESS.fullmatch(value)
    if m is None or not 1 <= int(m.group(2)) <= 65_535:
        return f"expected {ADDRESS_FORM}, got {value!r}"
    return None


def address(value: str) -> str:
    """argparse type of ``--coordinator``: HOST:PORT (see :func:`address_problem`)."""
    problem = address_problem(value)
    if problem:
        raise argparse.ArgumentTypeError(problem)
    return value


def integer_problem(raw: str, lo: int, hi: int) -> str | None:
    """Why the text of an integer variable is not an integer in [lo, hi] (None if it is):
    ASCII digits, blanks around them allowed."""
    v = raw.strip()
    if not (v.isascii() and v.isdigit() and lo <= int(v) <= hi):
        return f"expected an integer in [{lo}, {hi}], got {raw!r}"
    return None


def env_text(name: str, environ=None) -> str | None:
    """The value of an environment variable, None when unset or blank."""
    v = (os.environ if environ is None else environ).get(name)
    return v if v is not None and v.strip() else None


def env_int(name: str, lo: int, hi: int, environ=None) -> int | None:
    """An integer environment variable in [lo, hi], None when unset or blank; UsageError
    naming the variable otherwise."""
    v = env_text(name, environ)
    if v is None:
        return None
    problem = integer_problem(v, lo, hi)
    if problem:
        raise UsageError(f"${name}: {problem}")
    return int(v)


def _env_address(environ=None) -> str | None:
    v = env_text("JAX_COORDINATOR_ADDRESS", environ)
    problem = None if v is None else address_problem(v)
    if problem:
        raise UsageError(f"$JAX_COORDINATOR_ADDRESS: {problem}")
    return v


def _check_device_ids(environ=None) -> None:
    v = env_text("JAX_LOCAL_DEVICE_IDS", environ)
    if v is not None and any(integer_problem(x, 0, 65_535) for x in v.split(",")):
        raise UsageError(f"$JAX_LOCAL_DEVICE_IDS: expected integers in [0, 65535] separated by commas, got {v!r}")


def _check_slurm_job(tasks: int, environ=None) -> None:
    """A SLURM launch (``SLURM_NTASKS`` > 1) needs the job's other variables, as JAX reads them."""
    for name in SLURM_JOB:
        if env_text(name, environ) is None:
            raise UsageError(f"$SLURM_NTASKS is {tasks} but ${name} is not set (run the command under srun, or give "
                             "--coordinator, --num-processes and --process-id)")
    env_int("SLURM_JOB_ID", 0, 2**63 - 1, environ)
    env_int("SLURM_PROCID", 0, tasks - 1, environ)
    env_int("SLURM_LOCALID", 0, 65_535, environ)


def add_arguments(p, trials: int, chunk: int) -> None:
    p.add_argument("--trials", type=TRIALS, default=trials, help=f"number of trials (default {trials})")
    p.add_argument("--seed", type=SEED, default=0, help="seed of the trials' draws")
    p.add_argument("--chunk", type=int_in(1, 1 << 20), default=chunk,
                   help=f"trials per device per compiled call (default {chunk})")
    p.add_argument("--devices", type=int_in(1, 4096), default=None,
                   help="CPU devices of this process (default: its CPU cores; GPUs: every local GPU)")
    p.add_argument("--coordinator", type=address, metavar="HOST:PORT", default=None,
                   help="coordinator of a multi-process run, process 0's host and a free port on it "
                        "(default $JAX_COORDINATOR_ADDRESS)")
    p.add_argument("--num-processes", type=PROCESSES, default=None,
                   help="processes of a multi-process run (default $JAX_NUM_PROCESSES, else 1)")
    p.add_argument("--process-id", type=PROCESS_ID, default=None,
                   help="this process's index (default $JAX_PROCESS_ID)")
    p.add_argument("--init-timeout", type=int_in(1, 3600), default=INIT_TIMEOUT, metavar="S",
                   help="seconds a multi-process run waits for its processes to join (process 0) or for the "
                        f"coordinator to answer (the others) before it gives up (default {INIT_TIMEOUT})")
    add_out(p, "the trials' outcomes (outcomes.npz) and survival figures (PNG); the outcomes are written chunk by "
               "chunk to DIR/chunks as they are computed, and the same command run again after an interruption "
               "resumes from them")
    p.add_argument("--restart", action="store_true",
                   help="discard the chunks an earlier run left in DIR/chunks and start over")


def validate(args) -> None:
    """Fill the launch options from the environment and check them (see the module
    docstring); ``args.slurm`` says whether JAX reads the job from SLURM. A process other than
    0 writes no ``--out`` (process 0 writes the gathered outcomes)."""
    if args.coordinator is None:
        args.coordinator = _env_address()
    if args.num_processes is None:
        args.num_processes = env_int("JAX_NUM_PROCESSES", 1, PROCESSES.hi)
    if args.process_id is None:
        args.process_id = env_int("JAX_PROCESS_ID", 0, PROCESS_ID.hi)
    args.slurm = False
    if args.coordinator is None and args.num_processes is None:
        tasks = env_int("SLURM_NTASKS", 1, PROCESSES.hi)
        if tasks is not None and tasks > 1:
            _check_slurm_job(tasks)
            args.slurm = True
    n = args.num_processes
    _check_device_ids()  # JAX reads it in a single process too
    if n is not None and n > 1:
        if args.coordinator is None:
            raise UsageError("--num-processes > 1 needs --coordinator HOST:PORT (or $JAX_COORDINATOR_ADDRESS)")
        if args.process_id is None:
            raise UsageError("--num-processes > 1 needs --process-id (or $JAX_PROCESS_ID)")
        if args.process_id >= n:
            raise UsageError(f"--process-id {args.process_id} is not below --num-processes {n}")
    elif args.process_id not in (None, 0):
        raise UsageError(f"--process-id {args.process_id} needs --num-processes above it")
    pid = args.process_id if args.process_id is not None else env_int("SLURM_PROCID", 0, PROCESS_ID.hi)
    if pid:
        args.out = None


def before_jax(args) -> None:
    """Join the multi-process run (if any). A process that cannot join within
    ``--init-timeout`` ends with status 2 and one line; if the join is still blocked inside
    JAX, it ends at once, without interpreter teardown (:func:`bipedlab.interrupt.end`)."""
    from bipedlab import interrupt
    from bipedlab.robustness import distributed

    cpu = args.devices or (None if "cuda" in os.environ.get("JAX_PLATFORMS", "") else os.cpu_count())
    try:
        distributed.initialize(args.coordinator, args.num_processes, args.process_id, cpu_devices=cpu,
                               timeout=getattr(args, "init_timeout", None), slurm=getattr(args, "slurm", None))
    except distributed.JoinError as e:
        message = f"{args._command.name}: could not start the multi-process run: {e}"
        if e.stuck:
            message += "; start every process with the same launch options, or raise --init-timeout"
            interrupt.end(one_line(f"bipedlab: error: {message}"), 2)
        raise UsageError(message) from None


#: options that say how and where a run goes, not what it computes (left out of its identity)
LAUNCH_OPTIONS = ("out", "json", "restart", "devices", "coordinator", "num_processes", "process_id", "init_timeout",
                  "slurm")


def run_arguments(args) -> dict:
    """What defines a run beside the engine's own layout: the command and its options (the
    launch options left out), and the sha256 of every file an option names, so that a resume
    with other options or another file is refused."""
    from bipedlab import provenance

    opts = {k: v for k, v in sorted(vars(args).items()) if not k.startswith("_") and k not in LAUNCH_OPTIONS}
    files = {}
    for k, v in opts.items():
        for x in (v if isinstance(v, (list, tuple)) else [v]):
            if isinstance(x, str) and os.path.isfile(x):
                files[x] = provenance.file_sha256(x)
    command = getattr(args, "_command", None)
    plain = (bool, int, float, str, type(None), list, tuple)
    return dict(command=command.name if command is not None else None,  # an object by its repr, no address
                options={k: v if isinstance(v, plain) else re.sub(r" at 0x[0-9a-fA-F]+", "", repr(v))
                         for k, v in opts.items()}, files=files)


def _inside(path, folder: str) -> bool:
    if not isinstance(path, (str, bytes, os.PathLike)):
        return False
    p, f = os.path.abspath(os.fsdecode(path)), os.path.abspath(folder)
    return p == f or p.startswith(f + os.sep)


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
        from bipedlab.robustness import chunks, engine

        study = build(args, progress)
        store = os.path.join(final_path(args.out), "chunks") if args.out else None
        progress(f"{args.trials} trials of {study.name}" + (f", chunks in {store}" if store else ""))
        try:
            rec = engine.run(study, args.trials, args.seed, args.chunk, out=args.out, store=store,
                             restart=getattr(args, "restart", False), key=run_arguments(args))
        except chunks.ResumeError as e:
            raise UsageError(f"{args._command.name}: --out: {e}; run the command it was started with to resume it, add --restart to "
                             "discard its chunks, or choose another --out") from None
        except OSError as e:
            if store is None or not _inside(e.filename, store):
                raise
            # one line and status 1, the chunks written so far kept (the core reports an error
            # of the staged outputs so)
            if getattr(sys.stderr, "mid_line", False):  # after a progress bar's last redraw
                print(file=sys.stderr)
            raise OSError(e.errno, f"{e.strerror or e} (writing {e.filename}); the chunks written so far are kept "
                                   f"in {store}: run the same command again to resume", args.out) from None
        return rec, engine.summary

    return Command("robustness", robot, help, add, run, before_jax=before_jax, validate=check_all)
