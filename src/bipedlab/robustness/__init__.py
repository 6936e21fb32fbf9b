"""Robustness studies: batched Monte Carlo of a closed loop, sharded over every device of one
global mesh, on one machine or many (``jax.distributed``).

A study is a :class:`Study`: a pure, vmappable per-trial function and a sampler of the trials'
parameters. The engine (:func:`run`) does the rest::

    from bipedlab import robustness as rb

    def trial(p):                          # p: dict of scalars (one trial), traced under vmap
        out = my_walk(p["push"], p["phase"])  # the robot's own closed loop
        return dict(status=out.status,     # int: sim.loop OK / FELL / NONFINITE
                    completed=out.steps,   # int: steps (hops, strides) completed
                    speed=out.speed)       # any further per-trial scalars

    axes = (rb.Axis("push", 0.0, 100.0, 8, "N"), rb.Axis("phase", 0.0, 1.0, 8))
    study = rb.Study(
        name="my-robot pushes", trial=trial, horizon=10, unit="steps", axes=axes,
        sample=lambda rng, n: rb.uniform(rng, n, axes),  # {name: (n,) array}
    )
    rec = rb.run(study, trials=256, seed=0, out="atlas")   # progress bar on stderr
    print(rb.summary(rec))

A command is one line: ``COMMAND = options.command("my-robot", "help", build, add_options)``
with ``build(args, progress) -> Study`` (see :mod:`bipedlab.robustness.options`), appended to
the robot package's ``cli.COMMANDS``.

Contract of ``trial(params) -> dict``: ``params`` is one trial's slice of what ``sample``
returned (a dict of arrays); it must return at least ``status`` (int, see
:data:`bipedlab.sim.loop.STATUS_NAMES`) and ``completed`` (int: units completed before the
failure, ``horizon`` when it survived); every other entry is a per-trial scalar (or small
array) kept in the NPZ. ``sample(rng, n)`` is host code (a ``numpy.random.Generator`` seeded
with ``--seed``) returning ``{name: (n, ...) array}``; it must be deterministic in (seed, n),
since every process draws the whole batch and keeps its own shard.

The record :func:`run` returns (JSON-able) holds ``trials``, ``survival_rate``,
``trials_per_s``, ``device``, ``devices``, ``processes``, ``seed``, ``axes`` (name, range,
bins, unit), ``survival_map`` (per-cell survival, null where a cell has no trial),
``cell_trials``, ``fell``, ``nonfinite``, ``fell_at_histogram`` and the figure/NPZ paths.

Distributed runs: :func:`initialize` (``jax.distributed.initialize`` with CPU collectives over
gloo, waited for up to a timeout; :class:`JoinError` when the job cannot be joined) before
anything touches a device; then every process calls :func:`run` with the same
arguments; the batch is sharded over ``jax.devices()`` (all processes) with
``NamedSharding(mesh, P('batch'))``, each process computes its addressable shard, and the
outcomes are gathered with ``multihost_utils.process_allgather``; only process 0 writes files.
:mod:`bipedlab.robustness.options` adds the command-line options (``--trials``, ``--seed``,
``--chunk``, ``--devices``, ``--coordinator``, ``--num-processes``, ``--process-id``,
``--init-timeout``, each checked with the environment variables they default to before any
work) and the hooks a robot's ``robustness`` command uses.
"""
import importlib

_EXPORTS = {
    "Axis": "engine", "Study": "engine", "run": "engine", "summary": "engine", "uniform": "engine", "grid": "engine",
    "outcome_arrays": "engine", "survival_map": "engine",
    "initialize": "distributed", "global_mesh": "distributed", "sharded_map": "distributed",
    "process_count": "distributed", "process_index": "distributed", "JoinError": "distributed",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name):  # lazy: the command-line options (robustness.options) load without JAX
    if name in _EXPORTS:
        return getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
