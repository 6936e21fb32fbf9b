"""Speed benchmark on the anchor scenario, bipedlab beside MuJoCo in one process.

Scenario: the five-link biped under joint PD (kp 400, kd 20) on the penalty ground, RK4 at
0.25 ms, control at 1 kHz, 2 s per rollout (8000 substeps). The torso is unactuated, so in
this scenario the robot topples; both engines simulate the same interval and the benchmark
measures throughput, not posture. Fall detection is off so every rollout does the same work.

MuJoCo runs the five-link model exported to MJCF (exact inertias, position actuators with the
same gains, MuJoCo's own soft contact) in two forms: the anchors' model, whose links are
capsules that all collide with the floor and each other (the reference of
``ratio_vs_mujoco`` and ``batched_ratio_vs_mujoco``, as in the published anchor figures), and
a point-feet model whose only contacts are two small foot spheres, the same contact set as
bipedlab's (cheaper for MuJoCo; reported beside it as ``*_point_feet``). Each is timed as a
single ``mj_step`` loop, a single-threaded ``mujoco.rollout`` (the faster of the two is the
single-thread figure), and ``mujoco.rollout`` over 64 initial states with one thread per core.
"""
from __future__ import annotations

import dataclasses
import os
import time
from typing import Callable, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.robots.five_link import robot as five_link
from bipedlab.robots.five_link import scenario as scenarios
from bipedlab.sim.rollout import batched_rollout, rollout

MUJOCO_BATCH = 64


#: Timed repetitions of every measurement, both engines; the fastest counts (shared machines).
REPEATS = 3


def _best_of(fn: Callable) -> float:
    best = float("inf")
    for _ in range(REPEATS):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def _timed(fn: Callable, *args):
    """(seconds of the first call incl. compilation, fastest later call, result)."""
    t = time.perf_counter()
    out = jax.block_until_ready(fn(*args))
    first = time.perf_counter() - t
    return first, _best_of(lambda: jax.block_until_ready(fn(*args))), out


def _batch_states(x0, n: int):
    """n initial states spread over hip x in [0, 1] m (the anchors' batching)."""
    return jnp.tile(x0, (n, 1)).at[:, 0].set(jnp.linspace(0.0, 1.0, n))


def _scenario(seconds: float):
    """The anchor scenario with fall detection off (every rollout does the same work)."""
    params, x0, spec = scenarios.standing(seconds=seconds)
    return dataclasses.replace(params, min_height=jnp.asarray(-jnp.inf)), x0, spec


def bipedlab_single(seconds: float):
    params, x0, spec = _scenario(seconds)
    fn = jax.jit(lambda p, x: rollout(scenarios.flow, scenarios.pd_policy, scenarios.fell, spec, p, x))
    first, run_s, res = _timed(fn, params, x0)
    return dict(
        substeps=spec.total_substeps,
        compile_s=first - run_s,
        run_s=run_s,
        substeps_per_s=spec.total_substeps / run_s,
        final_hip_height_m=float(res.final[1]),
    )


def bipedlab_batched(seconds: float, batch: int):
    params, x0, spec = _scenario(seconds)
    fn = jax.jit(lambda p, x: batched_rollout(scenarios.flow, scenarios.pd_policy, scenarios.fell, spec, p, x))
    first, run_s, res = _timed(fn, params, _batch_states(x0, batch))
    return dict(
        batch=batch,
        compile_s=first - run_s,
        run_s=run_s,
        substeps_per_s=batch * spec.total_substeps / run_s,
        all_finite=bool(np.all(np.isfinite(np.asarray(res.final)))),
    )


def flops_per_substep() -> dict:
    """Floating-point operations of one RK4 substep of the scenario (four evaluations of the
    flow: dynamics with contacts, under a held PD torque), as XLA's cost analysis of the
    compiled substep counts them (adds, multiplies, divides, compares of the optimised
    program; sines and cosines counted apart as transcendentals)."""
    from bipedlab.sim import integrators

    params, x0, spec = _scenario(0.01)
    u = scenarios.pd_policy(params, x0, 0)
    step = integrators.get(spec.integrator)
    c = jax.jit(lambda p, x, u: step(lambda x, u: scenarios.flow(p, x, u), x, u, spec.dt)).lower(params, x0, u).compile()
    cost = c.cost_analysis()
    cost = cost[0] if isinstance(cost, (list, tuple)) else cost
    return dict(flops=float(cost.get("flops", float("nan"))), transcendentals=float(cost.get("transcendentals", 0.0)))


def cpu_peak_flops(cores: int) -> dict:
    """Double-precision peak of this CPU from /proc/cpuinfo: cores x clock x flops per cycle,
    with 2 fused-multiply-add units per core of the widest vector the flags show (AVX-512: 8
    doubles, 32 flops/cycle; AVX2 + FMA: 4 doubles, 16; otherwise SSE2: 2 doubles, add and
    multiply, 4). The clock is the highest 'cpu MHz' listed (the running clock, not a turbo
    bin). A ceiling to compare with, not a promise: the dynamics are mostly scalar code."""
    mhz, flags = 0.0, set()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("cpu MHz"):
                    mhz = max(mhz, float(line.split(":")[1]))
                elif line.startswith("flags") and not flags:
                    flags = set(line.split(":")[1].split())
    except (OSError, ValueError):
        return dict(peak_flops=None, note="no /proc/cpuinfo")
    per_cycle = 32 if "avx512f" in flags else 16 if {"avx2", "fma"} <= flags else 4
    isa = "AVX-512" if per_cycle == 32 else "AVX2+FMA" if per_cycle == 16 else "SSE2"
    return dict(peak_flops=cores * mhz * 1e6 * per_cycle if mhz else None, clock_mhz=mhz, flops_per_cycle=per_cycle,
                isa=isa, cores=cores)


#: Collision capsules of the anchors' MuJoCo model: (end in the body frame, radius).
ANCHOR_CAPSULES = {
    "torso": ((0.0, five_link.TORSO["length"]), 0.05),
    "hip_1": ((0.0, -five_link.THIGH["length"]), 0.04),
    "hip_2": ((0.0, -five_link.THIGH["length"]), 0.04),
    "knee_1": ((0.0, -five_link.SHIN["length"]), 0.03),
    "knee_2": ((0.0, -five_link.SHIN["length"]), 0.03),
}

#: The two MuJoCo models: the anchors' (capsule links, every link colliding, MuJoCo contact)
#: and one with bipedlab's physics (point feet only touching the floor).
MUJOCO_MODELS = {
    "anchor": dict(capsules=ANCHOR_CAPSULES),
    "point_feet": dict(contact_points=("foot_1", "foot_2"), contact_radius=0.001),
}


def _mujoco_model(mujoco, kind: str):
    xml = five_link.mjcf(pd_gains=(400.0, 20.0), **MUJOCO_MODELS[kind])
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    x0 = np.asarray(five_link.standing_state())
    d.qpos[:] = x0[:7]
    d.ctrl[:] = five_link.STANDING_REFERENCE
    return m, d


def mujoco_runs(seconds: float, threads: int, kind: str = "anchor"):
    """MuJoCo single-thread loop, single-thread rollout, and threaded rollout of 64."""
    import mujoco
    from mujoco import rollout as mj_rollout

    m, d = _mujoco_model(mujoco, kind)
    n = int(round(seconds / m.opt.timestep))
    final_hip = []

    def loop():
        m, d = _mujoco_model(mujoco, kind)
        for _ in range(n):
            mujoco.mj_step(m, d)
        final_hip.append(float(d.qpos[1]))

    loop_rate = n / _best_of(loop)
    final_hip = final_hip[-1]

    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    s0 = np.zeros((1, mujoco.mj_stateSize(m, spec)))
    mujoco.mj_getState(m, d, s0[0], spec)
    ctrl = five_link.STANDING_REFERENCE.reshape(1, 1, -1)  # held, tiled by MuJoCo
    roll1_rate = n / _best_of(lambda: mj_rollout.rollout(m, d, s0, ctrl, nstep=n))

    states = np.repeat(s0, MUJOCO_BATCH, axis=0)
    states[:, 1] = np.linspace(0.0, 1.0, MUJOCO_BATCH)  # qpos[0] (hip x) follows time in the state
    datas = [mujoco.MjData(m) for _ in range(threads)]
    batch_rate = MUJOCO_BATCH * n / _best_of(
        lambda: mj_rollout.rollout([m] * MUJOCO_BATCH, datas, states, ctrl, nstep=n))
    return dict(
        model=kind,
        version=mujoco.__version__,
        loop_substeps_per_s=loop_rate,
        rollout_substeps_per_s=roll1_rate,
        single_substeps_per_s=max(loop_rate, roll1_rate),
        batched_substeps_per_s=batch_rate,
        threads=threads,
        final_hip_height_m=final_hip,
    )


def run(batches: Sequence[int] = (64, 256), seconds: float = 2.0, threads: int | None = None,
        with_mujoco: bool = True, progress: Callable[[str], None] | None = None) -> dict:
    """Run the benchmark and return its result record (see the module docstring)."""
    say = progress or (lambda msg: None)
    threads = threads or os.cpu_count() or 1
    dev = jax.devices()[0]
    say("bipedlab single rollout")
    single = bipedlab_single(seconds)
    batched = []
    for b in sorted(set(int(b) for b in batches) | {MUJOCO_BATCH}):
        say(f"bipedlab batch {b}")
        batched.append(bipedlab_batched(seconds, b))
    mj = mjp = None
    if with_mujoco:
        try:
            say(f"MuJoCo (anchor model) single thread and rollout of {MUJOCO_BATCH} on {threads} threads")
            mj = mujoco_runs(seconds, threads, "anchor")
            say(f"MuJoCo (point-feet model) single thread and rollout of {MUJOCO_BATCH} on {threads} threads")
            mjp = mujoco_runs(seconds, threads, "point_feet")
        except ImportError:
            say("MuJoCo is not installed: pip install 'bipedlab[bench]' to compare")
    b64 = next(r for r in batched if r["batch"] == MUJOCO_BATCH)
    work = flops_per_substep()
    peak = cpu_peak_flops(threads) if dev.platform == "cpu" else dict(peak_flops=None)
    ceiling = peak["peak_flops"] / work["flops"] if peak.get("peak_flops") and work["flops"] > 0 else None
    best = max(r["substeps_per_s"] for r in batched)
    return dict(
        scenario="five-link standing under PD, penalty ground, RK4 0.25 ms, 1 kHz control",
        seconds_per_rollout=seconds,
        substeps_per_rollout=single["substeps"],
        device=f"{dev.platform}:{getattr(dev, 'device_kind', dev.platform)}",
        dtype=str(jnp.zeros(()).dtype),
        jax_version=jax.__version__,
        cpu_count=os.cpu_count(),
        devices=len(jax.devices()),
        bipedlab_substeps_per_s=single["substeps_per_s"],
        compile_s=single["compile_s"],
        mujoco_substeps_per_s=mj["single_substeps_per_s"] if mj else None,
        ratio_vs_mujoco=single["substeps_per_s"] / mj["single_substeps_per_s"] if mj else None,
        mujoco_batched_substeps_per_s=mj["batched_substeps_per_s"] if mj else None,
        batched_ratio_vs_mujoco=b64["substeps_per_s"] / mj["batched_substeps_per_s"] if mj else None,
        mujoco=mj,
        mujoco_point_feet=mjp,
        ratio_vs_mujoco_point_feet=single["substeps_per_s"] / mjp["single_substeps_per_s"] if mjp else None,
        batched_ratio_vs_mujoco_point_feet=b64["substeps_per_s"] / mjp["batched_substeps_per_s"] if mjp else None,
        batched=batched,
        final_hip_height_m=single["final_hip_height_m"],
        flops_per_substep=work["flops"],
        transcendentals_per_substep=work["transcendentals"],
        cpu_peak=peak,
        ceiling_substeps_per_s=ceiling,
        single_fraction_of_ceiling=single["substeps_per_s"] / ceiling if ceiling else None,
        batched_fraction_of_ceiling=best / ceiling if ceiling else None,
    )


def summary(r: dict) -> str:
    """A short human-readable report of a :func:`run` record."""
    lines = [
        f"bench: {r['scenario']}, {r['seconds_per_rollout']:g} s ({r['substeps_per_rollout']} substeps) per rollout",
        f"device {r['device']} (batches split over {r['devices']} device(s)), dtype {r['dtype']}, "
        f"jax {r['jax_version']}, {r['cpu_count']} cores",
        f"bipedlab single rollout: {r['bipedlab_substeps_per_s']:>12,.0f} substeps/s (compile {r['compile_s']:.1f} s)",
    ]
    for key, label in (("mujoco", "anchor model"), ("mujoco_point_feet", "point-feet model")):
        mj = r[key]
        if mj:
            lines.append(
                f"MuJoCo {mj['version']} {label}, 1 thread: {mj['single_substeps_per_s']:,.0f} substeps/s "
                f"(mj_step loop {mj['loop_substeps_per_s']:,.0f}, rollout {mj['rollout_substeps_per_s']:,.0f})"
            )
    if r["mujoco"]:
        lines.append(f"ratio single vs MuJoCo: {r['ratio_vs_mujoco']:.2f}x (anchor model), "
                     f"{r['ratio_vs_mujoco_point_feet']:.2f}x (point-feet model)")
    for b in r["batched"]:
        lines.append(
            f"bipedlab batch {b['batch']:>7}: {b['substeps_per_s']:>14,.0f} substeps/s (compile {b['compile_s']:.1f} s)"
        )
    for key, label in (("mujoco", "anchor model"), ("mujoco_point_feet", "point-feet model")):
        mj = r[key]
        if mj:
            lines.append(f"MuJoCo {label} rollout batch {MUJOCO_BATCH} on {mj['threads']} threads: "
                         f"{mj['batched_substeps_per_s']:,.0f} substeps/s")
    if r["mujoco"]:
        lines.append(f"ratio batch {MUJOCO_BATCH} vs MuJoCo multi-threaded: {r['batched_ratio_vs_mujoco']:.2f}x "
                     f"(anchor model), {r['batched_ratio_vs_mujoco_point_feet']:.2f}x (point-feet model)")
    else:
        lines.append("MuJoCo not run: no ratios")
    if r.get("ceiling_substeps_per_s"):
        pk = r["cpu_peak"]
        lines.append(f"ceiling: {r['flops_per_substep']:,.0f} flops per substep (XLA cost analysis) against "
                     f"{pk['peak_flops'] / 1e9:.0f} GFLOP/s ({pk['cores']} cores x {pk['clock_mhz']:.0f} MHz x "
                     f"{pk['flops_per_cycle']} ({pk['isa']})) = {r['ceiling_substeps_per_s']:,.0f} substeps/s; "
                     f"single {100 * r['single_fraction_of_ceiling']:.1f} %, best batch "
                     f"{100 * r['batched_fraction_of_ceiling']:.1f} % of it")
    return "\n".join(lines)
