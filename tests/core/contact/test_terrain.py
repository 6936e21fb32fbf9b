"""The one terrain type: flat, steps, slope, sampled height functions; batching."""
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bipedlab.contact import terrain as tr


def test_flat_steps_and_slope():
    assert float(tr.ground(tr.flat(), 17.3)) == 0.0
    t = tr.steps([0.0, 0.1, -0.2], step_len=2.0, x0=1.0)
    assert [float(tr.ground(t, x)) for x in (0.5, 1.5, 3.5, 9.0)] == pytest.approx([0.0, 0.1, -0.2, -0.2])
    s = tr.slope(2.0)
    assert float(s(10.0)) == pytest.approx(0.2) and float(tr.height_function(s)(5.0)) == pytest.approx(0.1)


def test_rough_is_bounded_and_flat_at_the_start():
    t = tr.rough(np.random.default_rng(0), 0.25, 60.0)
    h = np.asarray(t.heights)
    assert h[0] == 0.0 and np.all(np.abs(h) <= 0.25 + 1e-12) and np.all(np.abs(np.diff(h)) <= 0.25 + 1e-12)
    assert float(t(2.9)) == 0.0


def test_height_function_sampled_as_steps():
    t = tr.from_function(lambda x: 0.1 * np.sin(x), length=10.0, step_len=0.01)
    xs = np.linspace(0.0, 9.0, 50)
    np.testing.assert_allclose([float(t(x)) for x in xs], 0.1 * np.sin(xs), atol=1e-3 * 0.6)


def test_terrains_stack_and_vmap():
    ts = tr.stack([tr.rough(np.random.default_rng(k), 0.2, 30.0) for k in range(3)])
    g = jax.vmap(lambda h: tr.ground(tr.Terrain(h, ts.step_len, ts.x0, ts.grade), 7.0))(ts.heights)
    assert g.shape == (3,)
    assert float(g[1]) == float(tr.ground(tr.Terrain(ts.heights[1], ts.step_len, ts.x0, ts.grade), 7.0))
    jnp.asarray(g)
