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
import math
import os
import sys
from typing import Callable

import jax
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec as P

AXIS = "batch"


class JoinError(RuntimeError):
    """A multi-process job could not be joined; the message is one line. ``stuck``: the join
    is still blocked inside JAX (which ends the process itself some time later), so the caller
    must end the process now, without interpreter teardown."""

    def __init__(self, message: str, stuck: bool = False):
        super().__init__(message)
        self.stuck = stuck


#: seconds JAX's own initialization timeout runs past :func:`initialize`'s, so that the
#: caller's timeout always comes first (JAX aborts the process when its own expires)
JAX_GRACE = 60


def slurm_tasks(environ=None) -> int:
    """``$SLURM_NTASKS`` (1 when unset or blank); ValueError naming it unless a positive integer."""
    raw = (os.environ if environ is None else environ).get("SLURM_NTASKS", "")
    v = raw.strip()
    if not v:
        return 1
    if not (v.isascii() and v.isdigit() and int(v) >= 1):
        raise ValueError(f"$SLURM_NTASKS: expected a positive integer, got {raw!r}")
    return int(v)


def listen_problem(port: int) -> str | None:
    """Why process 0 could not listen on ``port`` on every interface, as JAX's coordinator
    does (None if it can): the port is taken, or not this user's to open."""
    import errno
    import socket

    for family, host in ((socket.AF_INET6, "::"), (socket.AF_INET, "0.0.0.0")):
        try:
            s = socket.socket(family, socket.SOCK_STREAM)
        except OSError:
            continue
        with s:
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            if family == socket.AF_INET6:
                with contextlib.suppress(OSError):
                    s.setsockopt(socket.IPPROTO_IPV6, socket.IPV6_V6ONLY, 0)
            try:
                s.bind((host, port))
                return None
            except OSError as e:
                if e.errno == errno.EADDRNOTAVAIL:
                    continue
                why = "in use" if e.errno == errno.EADDRINUSE else (e.strerror or str(e))
                return f"process 0 cannot listen on port {port} ({why})"
    return None


def reach(address: str, seconds: float = 1.0) -> str:
    """What a TCP connection to HOST:PORT finds, in words (for a message)."""
    import socket

    host, _, port = address.rpartition(":")
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=seconds):
            return "something listens there, but the run did not start"
    except socket.gaierror:
        return f"the host {host} is not known"
    except ConnectionRefusedError:
        return "nothing listens there"
    except OSError as e:
        return f"it cannot be reached ({e.strerror or e.__class__.__name__})"


def join_failure(coordinator: str | None, num_processes: int | None, process_id: int | None, seconds: float,
                 found: str | None = None) -> str:
    """The one-line reason a process did not join within ``seconds``."""
    if coordinator is None:
        return f"the SLURM job's processes did not all join within {seconds:g} s"
    if not process_id:
        others = (num_processes or 2) - 1
        return (f"process 0 waited {seconds:g} s at {coordinator} for the other {others} "
                f"process{'es' if others > 1 else ''}, which did not join")
    return (f"process {process_id} found no coordinator at {coordinator} within {seconds:g} s"
            + (f" ({found})" if found else ""))


def _supports(name: str) -> bool:
    import inspect

    try:
        return name in inspect.signature(jax.distributed.initialize).parameters
    except (TypeError, ValueError):
        return False


def _join(kwargs: dict, timeout: float | None):
    """jax.distributed.initialize(**kwargs) in a worker thread, waited for up to ``timeout``
    seconds: (finished, the exception it raised or None)."""
    import threading

    box = {}

    def work():
        try:
            jax.distributed.initialize(**kwargs)
        except BaseException as e:  # noqa: BLE001 - reported by the caller
            box["error"] = e

    t = threading.Thread(target=work, name="bipedlab-join", daemon=True)
    t.start()
    t.join(timeout)
    return not t.is_alive(), box.get("error")


def initialize(coordinator: str | None = None, num_processes: int | None = None, process_id: int | None = None,
               cpu_devices: int | None = None, timeout: float | None = None, slurm: bool | None = None) -> None:
    """Join a multi-process JAX job; call before JAX touches a device. ``cpu_devices`` exposes
    that many CPU devices in this process. With ``num_processes`` of 1 (or None and no
    coordinator) nothing but the CPU device count is set. Under SLURM (``slurm``; by default
    ``$SLURM_NTASKS`` > 1 with ``coordinator`` and ``num_processes`` None),
    ``jax.distributed.initialize()`` detects the job by itself.

    ``timeout``: seconds to wait for every process to join (None: JAX's own default). Raises
    :class:`JoinError` (one line) when the job cannot be joined: process 0 cannot listen on
    the coordinator's port, JAX refuses the launch, or the time runs out (then ``stuck``)."""
    if cpu_devices:
        try:
            jax.config.update("jax_num_cpu_devices", int(cpu_devices))
        except Exception:  # the backend is already up: keep what it has
            pass
    if slurm is None:
        try:
            slurm = slurm_tasks() > 1 and coordinator is None and num_processes is None
        except ValueError as e:
            raise JoinError(str(e)) from None
    if not slurm and (num_processes or 1) <= 1:
        return
    if not slurm and not process_id and not os.environ.get("JAX_COORDINATOR_BIND_ADDRESS"):
        problem = listen_problem(int(coordinator.rpartition(":")[2]))
        if problem:
            raise JoinError(f"{problem}, the port of the coordinator {coordinator}")
    try:  # gather on CPU processes needs CPU collectives (an option since JAX 0.4.2x)
        jax.config.update("jax_cpu_collectives_implementation", "gloo")
    except Exception:
        pass
    kwargs = {} if slurm else dict(coordinator_address=coordinator, num_processes=num_processes,
                                   process_id=process_id)
    if timeout is not None and _supports("initialization_timeout"):
        kwargs["initialization_timeout"] = int(math.ceil(timeout)) + JAX_GRACE
    with stdout_to_stderr():  # the collectives library announces its peers on stdout (fd 1)
        finished, error = _join(kwargs, timeout)
        if not finished:
            found = reach(coordinator) if coordinator is not None and process_id else None
            raise JoinError(join_failure(None if slurm else coordinator, num_processes, process_id, timeout, found),
                            stuck=True)
        if error is not None:
            first = (str(error).strip().splitlines() or [error.__class__.__name__])[0]
            raise JoinError(f"jax.distributed.initialize failed: {first}") from error
        jax.devices()  # the backend (and its collectives) comes up here, still on stderr


@contextlib.contextmanager
def stdout_to_stderr():
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
