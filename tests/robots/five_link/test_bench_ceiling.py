"""The bench's FLOP ceiling: the work of one substep as XLA counts it, and the CPU's peak."""
from __future__ import annotations

import jax
import pytest

from bipedlab.robots.five_link import bench
from bipedlab.robots.five_link import scenario as scenarios


def _flow_flops():
    params, x0, spec = bench._scenario(0.01)
    u = scenarios.pd_policy(params, x0, 0)
    c = jax.jit(lambda p, x, u: scenarios.flow(p, x, u)).lower(params, x0, u).compile()
    cost = c.cost_analysis()
    return float((cost[0] if isinstance(cost, (list, tuple)) else cost)["flops"])


def test_an_rk4_substep_costs_four_flow_evaluations():
    w = bench.flops_per_substep()
    f = _flow_flops()
    # RK4 evaluates the flow four times (plus a few vector updates of 14 states); XLA's
    # fusions of the four stages recompute some shared scalars, measured at about 25 % more
    assert 4 * f <= w["flops"] <= 6 * f
    assert w["flops"] > 1000  # a 7-DoF tree with two penalty contacts is not a toy


@pytest.mark.parametrize("flags, per_cycle", [("fpu sse2 avx avx2 fma", 16), ("sse2 avx2 fma avx512f", 32),
                                              ("fpu sse2", 4)])
def test_peak_follows_the_vector_width(monkeypatch, tmp_path, flags, per_cycle):
    text = "".join(f"processor\t: {i}\ncpu MHz\t\t: 2000.000\nflags\t\t: {flags}\n\n" for i in range(2))
    real_open = open

    def fake_open(path, *a, **k):
        return real_open(tmp_path / "cpuinfo", *a, **k) if path == "/proc/cpuinfo" else real_open(path, *a, **k)

    (tmp_path / "cpuinfo").write_text(text)
    monkeypatch.setattr("builtins.open", fake_open)
    p = bench.cpu_peak_flops(2)
    assert p["flops_per_cycle"] == per_cycle
    assert p["peak_flops"] == pytest.approx(2 * 2.0e9 * per_cycle)
