"""One sampled-data closed loop for every robot: plant substeps between control samples, a
sensor stage, a controller with its own state, status and the failure sample, logged signals
chosen by the caller; batched with ``vmap`` and sharded over devices.

A sample of period ``T = loop.sample_time`` runs, as named stages:

1. ``sensor(params, sensor_state, x, t) -> (sensor_state, y)``: what the controller sees
   (quantised encoders, noise, delay, filtered differences ... see :mod:`bipedlab.sim.sensors`);
2. ``controller(params, ctrl_state, y, t) -> (ctrl_state, u)``: u is held over the sample
   (zero-order hold);
3. ``exogenous(params, x, t) -> d`` (optional): a disturbance held over the sample, e.g. a push;
4. ``loop.substeps`` plant substeps ``plant_step(params, x, u, d, h, t) -> x`` of length
   ``h = T / substeps``; a substep may locate an event inside itself and apply a reset
   (touchdown, impact, relabelling) — the plant state is any pytree, so it can carry event
   counters and accumulators;
5. ``fell(params, x_before, y, u, x) -> bool`` and finiteness: the first failure freezes the
   plant state and sets ``status`` (:data:`OK`, :data:`FELL`, :data:`NONFINITE`) and
   ``failed_at`` (the sample index); compiled code never raises;
6. ``log(params, x_before, y, u, x, ctrl_state) -> pytree`` (optional): one row per sample.

:func:`run` scans ``n`` samples in one compiled program (pure, jit/vmap-able), :func:`run_until`
repeats such chunks inside the program while a traced condition holds (each trial of a batch
until it has stopped), :func:`simulate` drives it from the host in compiled chunks until a stop
condition (steps reached, a fall), with progress, and :func:`batched` vmaps over initial states and parameters and shards the
batch over the devices.
"""
from __future__ import annotations

import dataclasses
from typing import Any, Callable

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.pytree import pytree

OK, FELL, NONFINITE = 0, 1, 2
STATUS_NAMES = {OK: "ok", FELL: "fell", NONFINITE: "non-finite"}


def _no_exogenous(params, x, t):
    return None


@dataclasses.dataclass(frozen=True)
class SampledLoop:
    """The stages of a closed loop (pure functions, see the module docstring) and its timing:
    ``sample_time`` (s), ``substeps`` plant substeps per sample; ``unroll`` unrolls the
    substep loop (faster for small plants, larger programs)."""

    plant_step: Callable
    sensor: Callable
    controller: Callable
    fell: Callable
    sample_time: float
    substeps: int = 1
    log: Callable | None = None
    exogenous: Callable = _no_exogenous
    unroll: bool = False

    @property
    def substep_time(self) -> float:
        return self.sample_time / self.substeps


@pytree
class LoopState:
    """Plant state ``x``, sensor and controller states, time ``t`` (s), sample index ``k``,
    ``status`` code and ``failed_at`` (sample index of the first failure, -1 while none)."""

    x: Any
    sensor: Any
    ctrl: Any
    t: jax.Array
    k: jax.Array
    status: jax.Array
    failed_at: jax.Array


def _strong(a):
    """``a`` as an array of its own dtype without JAX's weak type: a Python scalar in a state
    (``jnp.asarray(-1)``) is weakly typed, while the loop hands back strongly typed values, so
    the second chunk of a run would see a new signature and compile the whole loop again."""
    a = jnp.asarray(a)
    return jnp.asarray(a, dtype=a.dtype)


def strongly_typed(tree):
    """``tree`` with every leaf an array of its own dtype without JAX's weak type (see
    :func:`_strong`): for states and parameters handed to a compiled function more than once."""
    return jax.tree_util.tree_map(_strong, tree)


def initial_state(x0, sensor_state=None, ctrl_state=None, t0=0.0) -> LoopState:
    """The loop's state at its first sample (every leaf strongly typed, see :func:`_strong`)."""
    return strongly_typed(LoopState(x=x0, sensor=sensor_state, ctrl=ctrl_state, t=jnp.asarray(t0, float),
                                    k=jnp.asarray(0), status=jnp.asarray(OK), failed_at=jnp.asarray(-1)))


def _finite(tree) -> jax.Array:
    leaves = [jnp.all(jnp.isfinite(a)) for a in jax.tree_util.tree_leaves(tree)
              if jnp.issubdtype(jnp.asarray(a).dtype, jnp.inexact)]
    return jnp.all(jnp.stack(leaves)) if leaves else jnp.asarray(True)


def _select(keep, a, b):
    return jax.tree_util.tree_map(lambda u, v: jnp.where(keep, u, v), a, b)


def sample(loop: SampledLoop, params, s: LoopState):
    """One control sample: sense, control, integrate, check. Returns (state, log row)."""
    sensor_state, y = loop.sensor(params, s.sensor, s.x, s.t)
    ctrl_state, u = loop.controller(params, s.ctrl, y, s.t)
    d = loop.exogenous(params, s.x, s.t)
    h = loop.substep_time

    def sub(i, x):
        return loop.plant_step(params, x, u, d, h, s.t + i * h)

    if loop.substeps == 1:
        x = sub(0, s.x)
    else:
        x = jax.lax.fori_loop(0, loop.substeps, sub, s.x, unroll=loop.unroll)
    finite = _finite(x)
    down = loop.fell(params, s.x, y, u, x)
    alive = s.status == OK
    new_status = jnp.where(~finite, NONFINITE, jnp.where(down, FELL, OK))
    x_keep = _select(alive & finite, x, s.x)
    failed_at = jnp.where(alive & (new_status != OK), s.k, s.failed_at)
    status = jnp.where(alive, new_status, s.status)
    row = None if loop.log is None else loop.log(params, s.x, y, u, x_keep, ctrl_state)
    new = LoopState(x=x_keep, sensor=sensor_state, ctrl=ctrl_state, t=s.t + loop.sample_time, k=s.k + 1,
                    status=status, failed_at=failed_at)
    return new, row


def run(loop: SampledLoop, params, s0: LoopState, n: int):
    """``n`` samples in one ``lax.scan``: (final state, logs stacked over samples)."""
    return jax.lax.scan(lambda s, _: sample(loop, params, s), s0, None, length=n)


def run_until(loop: SampledLoop, params, s0: LoopState, chunk: int, going: Callable, max_samples: int):
    """Chunks of ``chunk`` samples (:func:`run`, logs dropped) in one compiled ``lax.while_loop``
    while ``going(state)`` holds and fewer than ``max_samples`` samples have run (the check
    between chunks, so up to ``chunk - 1`` samples more): the in-program counterpart of
    :func:`simulate`'s host loop, for a vmapped batch whose trials stop at different samples.
    Returns the final state."""
    return jax.lax.while_loop(lambda s: going(s) & (s.k < max_samples), lambda s: run(loop, params, s, chunk)[0], s0)


_RUNNERS: dict = {}


def compiled_runner(loop: SampledLoop, chunk: int, key=None):
    """A jitted ``(params, state) -> (state, logs)`` over ``chunk`` samples, cached per loop."""
    key = (loop if key is None else key, chunk)
    fn = _RUNNERS.get(key)
    if fn is None:
        fn = _RUNNERS[key] = jax.jit(lambda p, s: run(loop, p, s, chunk))
    return fn


def simulate(loop: SampledLoop, params, s0: LoopState, max_samples: int, chunk: int = 500,
             until: Callable | None = None, progress: Callable | None = None, key=None):
    """Run compiled chunks of ``chunk`` samples from the host until ``max_samples`` samples,
    a failure, or ``until(state)`` (a host-side check, e.g. enough steps). Returns (final state,
    logs as NumPy arrays concatenated over the chunks, or None). ``progress(state)`` is called
    after each chunk."""
    step = compiled_runner(loop, chunk, key)
    s, logs, done = s0, [], 0
    while True:
        s, row = step(params, s)
        done += chunk
        if row is not None:
            logs.append(jax.tree_util.tree_map(np.asarray, row))
        if progress is not None:
            progress(s)
        if int(s.status) != OK or done >= max_samples or (until is not None and until(s)):
            break
    out = jax.tree_util.tree_map(lambda *a: np.concatenate(a), *logs) if logs else None
    return s, out


def batched(fn: Callable, params, states, params_axis=None, shard: bool = True):
    """``vmap`` of ``fn(params, state)`` over a leading batch axis of ``states`` (and of
    ``params`` with ``params_axis=0``), split across the default backend's devices (GPUs, or
    CPU cores exposed by :func:`bipedlab.sim.use_cpu_cores`) when the batch divides evenly."""
    vrun = jax.vmap(fn, in_axes=(params_axis, 0))
    devices = jax.devices()
    batch = jax.tree_util.tree_leaves(states)[0].shape[0]
    if not shard or len(devices) == 1 or batch % len(devices):
        return vrun(params, states)
    mesh = jax.sharding.Mesh(np.array(devices), ("batch",))
    spec_b = jax.sharding.PartitionSpec("batch")
    p_spec = jax.tree_util.tree_map(lambda _: spec_b if params_axis == 0 else jax.sharding.PartitionSpec(), params)
    s_spec = jax.tree_util.tree_map(lambda _: spec_b, states)
    out_shape = jax.eval_shape(vrun, params, states)
    o_spec = jax.tree_util.tree_map(lambda _: spec_b, out_shape)
    return jax.shard_map(vrun, mesh=mesh, in_specs=(p_spec, s_spec), out_specs=o_spec, check_vma=False)(params, states)
