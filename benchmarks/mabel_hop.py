"""Speed of MABEL's 13-DoF hopping simulation: 100 hops against real time (target <= 1/5).

Run: python benchmarks/mabel_hop.py [hops]. Times compilation and the run separately (best
of three runs of the same compiled program) and prints the device, dtype and step.
"""
from __future__ import annotations

import sys
import time

import jax

import bipedlab  # noqa: F401  (float64)
from bipedlab.robots.mabel.hopping import controller as hop
from bipedlab.robots.mabel.hopping import study as hm


def main(hops: int = 100) -> None:
    m = hm.mm.hopping_model()
    p = hop.paper_params()
    x0 = hm.initial_state(m, p)
    c0 = hop.initial_state(p, hm.sense(m, p, x0)[0])
    steps = int((hops + 1) * 0.62 / float(p.period))
    t0 = time.perf_counter()
    run = hm.run_samples_jit.lower(m, p, x0, c0, steps=steps).compile()
    compile_s = time.perf_counter() - t0
    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        out = jax.block_until_ready(run(m, p, x0, c0))
        best = min(best, time.perf_counter() - t0)
    sim_s = steps * float(p.period)
    print(f"device {jax.devices()[0].device_kind}, dtype {out[0].dtype}, dt {hm.DT * 1e3:.3f} ms, "
          f"{hm.SUBSTEPS} steps per 1 ms control sample")
    print(f"simulated {sim_s:.1f} s ({steps * hm.SUBSTEPS} steps) in {best:.2f} s: "
          f"{best / sim_s:.3f} of real time, {steps * hm.SUBSTEPS / best:,.0f} steps/s; compile {compile_s:.1f} s")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 100)
