"""Compiled rollouts: n control steps in one ``lax.scan``, batched with ``vmap``.

A rollout integrates ``xdot = flow(params, x, u)`` with a fixed-step integrator, holding the
control ``u = policy(params, x, k)`` for ``substeps`` integration steps (zero-order hold at
the control rate). After every control step it checks ``fell(params, x)`` and finiteness;
the first failure freezes the state and is reported as a status code, never raised.
"""
from __future__ import annotations

import dataclasses
from typing import Callable

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.mechanics.fusion import stage_barriers
from bipedlab.sim import integrators, loop
from bipedlab.sim.loop import FELL, NONFINITE, OK, STATUS_NAMES, SampledLoop  # noqa: F401



@dataclasses.dataclass(frozen=True)
class RolloutSpec:
    """Static rollout settings. dt: integration step (s); substeps: integration steps per
    control step; steps: control steps; integrator: 'rk4' | 'heun' | 'semi_implicit_euler';
    record: keep the state after every control step (else only the final state);
    compact: the substeps are a loop (the program holds one substep, its integrator's stages
    written out) instead of one copy per substep. Measured with ``bipedlab bench`` (a planar
    biped standing, three runs side by side on 2 cores): compile 4-6.5 s per program instead
    of 9-14 s, with single and batched throughput at least as high; scanning RK4's four stages
    as well (:func:`~bipedlab.sim.integrators.rk4_scan`) compiles in 1-3.4 s but runs the
    batches 15-20 % slower, so it is not used here. Same numbers up to the contraction of
    multiply-adds."""

    dt: float = 2.5e-4
    substeps: int = 4
    steps: int = 2000
    integrator: str = "rk4"
    record: bool = False
    compact: bool = True

    @property
    def control_period(self) -> float:
        return self.dt * self.substeps

    @property
    def total_substeps(self) -> int:
        return self.steps * self.substeps


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class RolloutResult:
    """Final state (nx,), status code (OK/FELL/NONFINITE), index of the control step at
    which it failed (``steps`` when it did not), and the recorded states (steps, nx) or None."""

    final: jax.Array
    status: jax.Array
    failed_at: jax.Array
    states: jax.Array | None


def _loop(flow: Callable, policy: Callable, fell: Callable, spec: RolloutSpec) -> SampledLoop:
    """The rollout as a :class:`~bipedlab.sim.loop.SampledLoop`: exact state sensed, a
    stateless policy (its state is the sample index), the integrator's step as the substep."""
    step = integrators.get(spec.integrator)

    def plant_step(params, x, u, d, h, t):
        return step(lambda z, v: flow(params, z, v), x, u, h)

    def controller(params, k, x, t):
        return k + 1, policy(params, x, k)

    return SampledLoop(plant_step=plant_step, sensor=lambda p, s, x, t: (s, x), controller=controller,
                       fell=lambda p, x0, y, u, x: fell(p, x), sample_time=spec.dt * spec.substeps,
                       substeps=spec.substeps, unroll=not spec.compact,
                       log=(lambda p, x0, y, u, x, c: x) if spec.record else None)


def rollout(flow: Callable, policy: Callable, fell: Callable, spec: RolloutSpec, params, x0) -> RolloutResult:
    """Simulate one rollout from x0. ``flow(params, x, u)``, ``policy(params, x, k)`` and
    ``fell(params, x)`` are pure functions; vmap this function to batch it. This is the
    closed loop of :mod:`bipedlab.sim.loop` with a stateless policy and exact sensing."""
    s0 = loop.initial_state(jnp.asarray(x0), ctrl_state=jnp.asarray(0))
    s, states = loop.run(_loop(flow, policy, fell, spec), params, s0, spec.steps)
    failed_at = jnp.where(s.failed_at < 0, spec.steps, s.failed_at)
    return RolloutResult(s.x, s.status, failed_at, states)


def batched_rollout(flow: Callable, policy: Callable, fell: Callable, spec: RolloutSpec, params, x0,
                    params_axis=None, shard: bool = True) -> RolloutResult:
    """Rollouts of a batch of initial states x0 (B, nx); ``params_axis=0`` also batches the
    parameters (a pytree whose leaves have a leading batch axis).

    With ``shard`` and several devices of the default backend (several GPUs, or CPU cores
    exposed as devices by :func:`use_cpu_cores`), the batch is split across them when B is
    a multiple of the device count."""
    vrun = jax.vmap(lambda p, x: rollout(flow, policy, fell, spec, p, x), in_axes=(params_axis, 0))

    def run(p, x):
        with stage_barriers():
            return vrun(p, x)

    devices = jax.devices()
    if not shard or len(devices) == 1 or x0.shape[0] % len(devices):
        return run(params, x0)
    mesh = jax.sharding.Mesh(np.array(devices), ("batch",))
    spec_b = jax.sharding.PartitionSpec("batch")
    p_spec = jax.tree_util.tree_map(lambda _: spec_b if params_axis == 0 else jax.sharding.PartitionSpec(), params)
    out_spec = RolloutResult(spec_b, spec_b, spec_b, spec_b if spec.record else None)
    return jax.shard_map(run, mesh=mesh, in_specs=(p_spec, spec_b), out_specs=out_spec, check_vma=False)(params, x0)


def use_cpu_cores(n: int | None = None) -> int:
    """Expose n CPU cores (default: all) as separate JAX devices so batched rollouts run on
    all of them. Must be called before JAX first touches a device; returns the count set."""
    import os

    n = n or os.cpu_count() or 1
    try:
        jax.config.update("jax_num_cpu_devices", n)
    except Exception:  # backend already initialised, or an older JAX without the option
        return len(jax.devices("cpu"))
    return n
