"""The model-based velocity observer of MABEL's sampled closed loop against the filtered
backward difference, on an exactly integrated 1 ms period of the stance dynamics."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import bipedlab  # noqa: F401
from bipedlab.robots.mabel.walking import stance as wk
from bipedlab.robots.mabel.walking import loop as sw
from bipedlab.robots.mabel.walking import study as wm


@pytest.fixture(scope="module")
def period():
    """(model, setups by sensing, z0, z1 one sample later under a held torque, u)."""
    vc, gains, rec = wm.load_gait("nominal")
    m = wk.walking_model()
    mc = wk.without_stop(m)  # the observer's model, used here as the truth as well
    z0 = jnp.asarray(rec["z_plus"])
    u = jnp.asarray([1.5, -3.0, 0.8, 0.4])
    # move into the step, away from the impact: 40 ms under the held torque
    flow = jax.jit(lambda z: sw._rk4(mc, z, u, jnp.zeros(2), sw.SAMPLE / 16))
    for _ in range(40 * 16):
        z0 = flow(z0)
    z1 = z0
    for _ in range(16):
        z1 = flow(z1)
    setups = {s: wm.setup_for(vc, gains, rec["design"]["period"], sensing=s) for s in ("encoders", "observer")}
    return m, setups, z0, z1, u


def _estimate(m, setup, z0, z1, u):
    c = sw.initial_state(setup, z0).ctrl.replace(q_prev=z0[:6], v_est=z0[6:], u_prev=u)
    return np.asarray(jax.jit(lambda c, q: sw._rate_estimate(m, setup, c, q))(c, z1[:6]))


def test_observer_tracks_the_velocity_to_second_order_where_the_difference_lags(period):
    m, setups, z0, z1, u = period
    truth = np.asarray(z1[6:])
    mc = wk.without_stop(m)
    a0, a1 = (np.asarray(wk.stance_flow(mc, z, u)[6:]) for z in (z0, z1))
    mean_accel = (truth - np.asarray(z0[6:])) / sw.SAMPLE
    plain = _estimate(m, setups["encoders"], z0, z1, u)
    obs = _estimate(m, setups["observer"], z0, z1, u)
    # the filtered difference lags: its error is first order, (1 - (1 - F) / 2) a T
    lag = (1.0 - 0.5 * (1.0 - sw.VELOCITY_FILTER)) * mean_accel * sw.SAMPLE
    second_order = 0.75 * np.abs(a1 - a0) * sw.SAMPLE + 1e-4
    assert np.all(np.abs(np.abs(plain - truth) - np.abs(lag)) <= second_order)
    # the observer's error is second order: bounded by the change of acceleration over the
    # period (the stance spring's fast mode changes it by ~100 rad/s^2 per ms here)
    assert np.all(np.abs(obs - truth) <= second_order)
    assert np.max(np.abs(obs - truth)) < 0.2 * np.max(np.abs(plain - truth))


def test_observer_is_off_by_default_and_selected_by_sensing(period):
    _, setups, _, _, _ = period
    assert float(setups["encoders"].observer) == 0.0
    assert float(setups["observer"].observer) == 1.0
    assert float(setups["observer"].quantised) == 1.0
    with pytest.raises(ValueError, match="sensing"):
        vc, gains, rec = wm.load_gait("nominal")
        wm.setup_for(vc, gains, 0.8, sensing="laser")
