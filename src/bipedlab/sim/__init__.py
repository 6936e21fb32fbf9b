"""Integrators, compiled and batched rollouts, and simulation scenarios."""
from bipedlab.sim.integrators import heun, rk4, semi_implicit_euler
from bipedlab.sim.rollout import (
    FELL,
    NONFINITE,
    OK,
    STATUS_NAMES,
    RolloutResult,
    RolloutSpec,
    batched_rollout,
    rollout,
    use_cpu_cores,
)

__all__ = ["heun", "rk4", "semi_implicit_euler", "FELL", "NONFINITE", "OK", "STATUS_NAMES",
           "RolloutResult", "RolloutSpec", "batched_rollout", "rollout", "use_cpu_cores"]
