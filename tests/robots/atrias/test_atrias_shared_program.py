"""The running study's variants share one compiled batched chunk: the controller parameters
(energy option, model errors), the noise amplitude and the delay are traced arguments of
:func:`bipedlab.robots.atrias.loop.make_chunk`, so a second and a third variant of the same
trial count and terrain length compile nothing, and give what a program built for them alone
gives."""
import jax
import numpy as np

from bipedlab.robots.atrias import loop as ar
from bipedlab.robots.atrias import study as ra
from bipedlab.sim import sensors

COMPILE = "/jax/core/compile/backend_compile_duration"
KEYS = ("status", "x", "n_apex", "bounce", "speed", "apex_y", "apex_x", "pitch_rms")


def test_indexed_delay_line_equals_the_fixed_delay_lines():
    """Oracle: sensors.delay_push on a line of exactly n samples (n >= 1) and no line (n = 0);
    the indexed line of DELAY_LINE samples read n back gives the same values, bit for bit."""
    rng = np.random.default_rng(1)
    z0 = rng.standard_normal(4)
    zs = rng.standard_normal((24, 4))
    for n in (0, 1, 3, 10, ar.DELAY_LINE - 1):
        fixed = sensors.delay_init(z0, n) if n else None
        line = sensors.delay_init(z0, ar.DELAY_LINE)
        for z in zs:
            if fixed is None:
                want = z
            else:
                fixed, want = sensors.delay_push(fixed, z)
            line, got = sensors.delay_read(line, z, n)
            np.testing.assert_array_equal(np.asarray(got), np.asarray(want))
    assert ar.program(ar.RunConfig(delay=10)) == ar.program(ar.RunConfig(delay=0, noise=True))
    assert ar.program(ar.RunConfig(delay=ar.DELAY_LINE)).delay_line == ar.DELAY_LINE + 1


def _run(st, n=2):
    out, _ = ra.simulate(st, n)
    return {k: np.asarray(out[k]) for k in KEYS}


def test_variants_share_one_program_and_match_a_fresh_build():
    """Three variants, 2 terrains of 3 m each: energy conservation with a +20 % inertia error,
    regulation with noise and a 10 ms delay, conservation with a -20 % mass error on a 1 %
    slope. After the first, the others add no compiled chunk and no XLA compilation (JAX's
    compile events); the last then run on a freshly built program (the chunk cache and JAX's
    in-memory caches emptied: traced and lowered again, its executable compiled or taken from the
    persistent compilation cache) equals the shared program's run within 1e-12."""
    common = dict(terrain="rough", distance=3.0, seed=2)
    variants = [ra.Settings(energy="conservation", model_error=(("inertia", 0.5),), **common),
                ra.Settings(energy="regulation", noise=True, delay_ms=10.0, **common),
                ra.Settings(energy="conservation", model_error=(("mass", -0.2),), rough_grade_percent=1.0,
                            **common)]
    for st in variants:  # the controller parameters (swing policy, gains) outside the count
        ra.build(st)
    compiles = []

    def listen(name, duration, **_):
        if name == COMPILE:
            compiles.append(duration)

    first = _run(variants[0])
    n_programs = len(ra._CHUNKS)
    jax.monitoring.register_event_duration_secs_listener(listen)
    try:
        shared = [_run(st) for st in variants[1:]]
    finally:
        jax.monitoring.unregister_event_duration_listener(listen)
    assert compiles == [] and len(ra._CHUNKS) == n_programs
    assert all(np.all(r["status"] == ar.OK) for r in [first, *shared])
    # the variants differ (noise, delay, model errors reach the run)
    assert not np.array_equal(shared[0]["x"], first["x"]) and not np.array_equal(shared[1]["x"], first["x"])

    ra._CHUNKS.clear()
    jax.clear_caches()
    jax.monitoring.register_event_duration_secs_listener(listen)
    try:
        fresh = _run(variants[2])
    finally:
        jax.monitoring.unregister_event_duration_listener(listen)
    assert compiles, "the listener sees the fresh build's compilations"
    for k in KEYS:
        np.testing.assert_allclose(shared[1][k], fresh[k], rtol=0, atol=1e-12, err_msg=k)
