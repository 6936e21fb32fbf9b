"""A chunked closed-loop run compiles its chunk once: the state handed back by a chunk has the
same signature (dtypes, shapes and weak types) as the initial state, whatever Python scalars
the initial state was built from. A second compilation of a large loop (MABEL's walking loop)
costs minutes."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.sim import loop as sl


def _oscillator_loop():
    """A damped unit oscillator x'' = u under a PD controller with an integer sample counter as
    the sensor's state (an integer state is where a weak type slips in)."""
    def plant_step(p, x, u, d, h, t):
        return x + h * jnp.stack([x[1], u])

    def sensor(p, last, x, t):
        return last + jnp.ones((), dtype=int), x  # a strongly typed result, as in real sensors

    def controller(p, c, y, t):
        u = -p * y[0] - 0.5 * y[1]
        return c, u

    def fell(p, x0, y, u, x):
        return jnp.abs(x[0]) > 10.0

    return sl.SampledLoop(plant_step=plant_step, sensor=sensor, controller=controller, fell=fell,
                          sample_time=1e-2, substeps=2)


def test_chunks_share_one_compiled_program():
    loop = _oscillator_loop()
    # Python scalars in the initial state: weakly typed once wrapped
    s0 = sl.initial_state(jnp.array([1.0, 0.0]), jnp.asarray(-1), jnp.asarray(0.0), 0.0)
    runner = sl.compiled_runner(loop, 10, key="oscillator-test")
    s, _ = sl.simulate(loop, 4.0, s0, 40, chunk=10, key="oscillator-test")
    assert runner._cache_size() == 1
    # the physics ran: 40 samples counted by the sensor, and the oscillator decayed
    assert int(s.sensor) == 39 and int(s.k) == 40
    assert abs(float(s.x[0])) < 1.0


def test_initial_state_has_no_weak_types():
    s0 = sl.initial_state(jnp.zeros(2), jnp.asarray(-1), jnp.asarray(0.0), 0.0)
    weak = [jax.tree_util.keystr(p) for p, a in jax.tree_util.tree_leaves_with_path(s0)
            if jax.typeof(a).weak_type]
    assert weak == []
    assert np.asarray(s0.sensor).dtype == np.asarray(jnp.asarray(-1)).dtype


def test_run_until_stops_between_chunks_inside_the_program():
    """run_until: chunks until the condition fails (checked between chunks) or the sample bound;
    the same state as the chunks run one by one, for each row of a vmapped batch."""
    loop = _oscillator_loop()
    s0 = sl.initial_state(jnp.array([1.0, 0.0]), jnp.asarray(-1), jnp.asarray(0.0), 0.0)
    going = lambda s: s.x[0] > 0.5  # noqa: E731
    s = jax.jit(lambda p, s: sl.run_until(loop, p, s, 10, going, 200))(4.0, s0)
    ref = s0
    while bool(going(ref)) and int(ref.k) < 200:
        ref = sl.run(loop, 4.0, ref, 10)[0]
    assert int(s.k) == int(ref.k) and 0 < int(s.k) < 200 and int(s.k) % 10 == 0
    np.testing.assert_array_equal(np.asarray(s.x), np.asarray(ref.x))
    assert int(jax.jit(lambda p, s: sl.run_until(loop, p, s, 10, lambda s: s.k >= 0, 30))(4.0, s0).k) == 30
    ks = jax.vmap(lambda p: sl.run_until(loop, p, s0, 10, going, 200).k)(jnp.array([1.0, 4.0, 9.0]))
    assert len(set(int(k) for k in ks)) > 1
