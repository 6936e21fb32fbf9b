"""One global mesh over every device of every process, and a batch map sharded over it.

:func:`initialize` joins a ``jax.distributed`` job (CPU collectives over gloo, so that CPU-only
processes can gather); :func:`sharded_map` runs ``vmap(fn)`` over a batch whose leading axis is
split across ``jax.devices()`` — all processes' devices — with ``NamedSharding(mesh,
P('batch'))``. Each process builds only its addressable shards from the host batch (which every
process holds whole), computes them, and the outcomes are gathered back to every process with
``multihost_utils.process_allgather`` (in one process: a plain device-to-host copy). Trials are
independent, so the program has no communication: per device it is the same vmapped loop.
"""
from __future__ import annotations

import contextlib
import os
import sys
from typing import Callable

import jax
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec as P

AXIS = "batch"


def initialize(coordinator: str | None = None, num_processes: int | None = None, process_id: int | None = None,
               cpu_devices: int | None = None) -> None:
    """Join a multi-process JAX job; call before JAX touches a device. ``cpu_devices`` exposes
    that many CPU devices in this process. With ``num_processes`` of 1 (or None and no
    coordinator) nothing but the CPU device count is set. Under SLURM with ``coordinator`` None
    and ``num_processes`` None, ``jax.distributed.initialize()`` detects the job by itself."""
    if cpu_devices:
        try:
            jax.config.update("jax_num_cpu_devices", int(cpu_devices))
        except Exception:  # the backend is already up: keep what it has
            pass
    slurm = int(os.environ.get("SLURM_NTASKS", "1") or 1) > 1 and coordinator is None and num_processes is None
    if not slurm and (num_processes or 1) <= 1:
        return
    try:  # gather on CPU processes needs CPU collectives (an option since JAX 0.4.2x)
        jax.config.update("jax_cpu_collectives_implementation", "gloo")
    except Exception:
        pass
    with _stdout_to_stderr():  # the collectives library announces its peers on stdout (fd 1)
        if slurm:
            jax.distributed.initialize()
        else:
            jax.distributed.initialize(coordinator_address=coordinator, num_processes=num_processes,
                                       process_id=process_id)
        jax.devices()  # the backend (and its collectives) comes up here, still on stderr


@contextlib.contextmanager
def _stdout_to_stderr():
    """File descriptor 1 pointed at stderr meanwhile, so that what native libraries print
    keeps stdout for the command's own output (``--json``)."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        os.dup2(2, 1)
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)


def process_count() -> int:
    return jax.process_count()


def process_index() -> int:
    return jax.process_index()


def global_mesh(devices=None) -> Mesh:
    """A 1-D mesh named 'batch' over ``devices`` (default: every device of every process)."""
    return Mesh(np.asarray(jax.devices() if devices is None else devices), (AXIS,))


def device_label(mesh: Mesh) -> str:
    d = mesh.devices.flat[0]
    kind = getattr(d, "device_kind", "") or ""
    return f"{d.platform}" + (f" ({kind})" if kind and kind.lower() != d.platform else "")


def _global(host: np.ndarray, sharding: NamedSharding):
    return jax.make_array_from_callback(host.shape, sharding, lambda idx: host[idx])


class ShardedMap:
    """``vmap(fn)`` over the leading axis of a pytree of host arrays (its length a multiple of
    the mesh size), sharded over the mesh, outcomes gathered as NumPy arrays on every process.
    :meth:`compile` compiles ahead of time for a batch's shapes (and returns the seconds it
    took); calls with the same shapes reuse the program."""

    def __init__(self, fn: Callable, mesh: Mesh | None = None):
        self.mesh = global_mesh() if mesh is None else mesh
        spec = P(AXIS)
        self.sharding = NamedSharding(self.mesh, spec)
        self._jit = jax.jit(jax.shard_map(jax.vmap(fn), mesh=self.mesh, in_specs=spec, out_specs=spec,
                                          check_vma=False))
        self._compiled: dict = {}

    def _arrays(self, batch):
        n = jax.tree_util.tree_leaves(batch)[0].shape[0]
        if n % self.mesh.size:
            raise ValueError(f"batch of {n} is not a multiple of the {self.mesh.size} devices")
        return jax.tree_util.tree_map(lambda a: _global(np.asarray(a), self.sharding), batch)

    def _program(self, arrays):
        key = jax.tree_util.tree_structure(arrays), tuple((a.shape, a.dtype) for a in jax.tree_util.tree_leaves(arrays))
        prog = self._compiled.get(key)
        if prog is None:
            prog = self._compiled[key] = self._jit.lower(arrays).compile()
        return prog

    def compile(self, batch) -> float:
        import time

        t0 = time.perf_counter()
        self._program(self._arrays(batch))
        return time.perf_counter() - t0

    def __call__(self, batch):
        arrays = self._arrays(batch)
        out = self._program(arrays)(arrays)
        if jax.process_count() > 1:
            from jax.experimental import multihost_utils

            return jax.tree_util.tree_map(np.asarray, multihost_utils.process_allgather(out, tiled=True))
        return jax.tree_util.tree_map(np.asarray, jax.device_get(out))


def sharded_map(fn: Callable, mesh: Mesh | None = None) -> ShardedMap:
    """``run(batch) -> outcomes``: see :class:`ShardedMap`."""
    return ShardedMap(fn, mesh)
