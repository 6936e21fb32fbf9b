"""Integrators, the event locator, the hybrid step, the sampled-data closed loop, sensors, rollouts."""
from bipedlab.sim import events, hybrid, integrators, loop
from bipedlab.sim.integrators import heun, rk4, rk4_with_stage, semi_implicit_euler
from bipedlab.sim.loop import LoopState, SampledLoop
from bipedlab.sim.rollout import (FELL, NONFINITE, OK, STATUS_NAMES, RolloutResult, RolloutSpec, batched_rollout,
                                  rollout, use_cpu_cores)

__all__ = ["events", "hybrid", "integrators", "loop", "heun", "rk4", "rk4_with_stage", "semi_implicit_euler", "LoopState",
           "SampledLoop", "FELL", "NONFINITE", "OK", "STATUS_NAMES", "RolloutResult", "RolloutSpec", "batched_rollout",
           "rollout", "use_cpu_cores"]
