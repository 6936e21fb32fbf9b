"""What eq. 42's outer loop asks of each motor (compliant-HZD paper, Sec. V-D).

The outer loop v = -(Kp/eps^2) y - (Kd/eps) y-dot gives every output the same poles; through
LgLfh^-1 that is a torque per rad of error proportional to the output's effective inertia. The
stance leg-shape output is a motor angle (rotor and pulley inertia, about 1e-3 kg m^2), so with
eps = 0.05 its own motor sees about 0.4 N m/rad, an eighth of PD + feedforward's 3.5 N m/rad:
the I/O-linearising loop was the softer one on that output, whatever the model mismatch it
meets. controllers.EPS is the largest at which no output's own motor gets less than pdff's kp on
any shipped gait; the shipped eps per output (controllers.EPS_OUTPUTS) stiffens the stance
leg-shape output further, as its selection on the 13-DoF plant found.
"""
from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

import bipedlab  # noqa: F401
from bipedlab.robots.mabel.walking import constraints as vcm
from bipedlab.robots.mabel.walking import controllers as ctl
from bipedlab.robots.mabel.walking import stance as wk
from bipedlab.robots.mabel.walking import study as wm


def _at_touchdown(gait="paper-nominal"):
    vc, g, rec = wm.load_gait(gait)
    A = ctl.decoupling(wk.without_stop(wk.walking_model()), vc, vcm.MC, jnp.asarray(rec["z_plus"]))[2]
    return A, g


def test_stance_leg_shape_motor_loop_was_softer_than_pd_at_eps_005():
    A, g = _at_touchdown()
    g = g.replace(eps=jnp.asarray(0.05))
    k, d = (np.asarray(v) for v in ctl.outer_loop_stiffness(A, g))
    pd = np.asarray(g.kp) * np.asarray(g.signs)
    assert 0.2 < k[0] < 1.0, k          # mLS_st: N m per rad of motor angle
    assert k[0] < pd[0] / 5.0, (k, pd)
    assert np.all(np.sign(k) == np.sign(pd)), (k, pd)  # each motor pushes its output back
    assert np.allclose(d, k * (g.kd_io / g.kp_io) * g.eps)


@pytest.mark.parametrize("gait", ["nominal", "paper-nominal", "efficient", "paper-efficient", "fast"])
def test_eps_is_nowhere_softer_than_pd_and_the_stance_motor_binds(gait):
    """At controllers.EPS on every output, each output's own motor gets at least pdff's kp at the
    gait's touchdown state, and the stance leg-shape motor is the binding one: 1 % more eps would
    leave it softer than pdff (eps enters as 1/eps^2), while the others keep over 1.5 times. The
    shipped gains (EPS_OUTPUTS) keep EPS on the other outputs and stiffen the stance leg-shape
    output by (EPS / its eps)^2 = 32."""
    A, g = _at_touchdown(gait)
    np.testing.assert_array_equal(np.asarray(g.eps), np.asarray(ctl.EPS_OUTPUTS))
    k = np.asarray(ctl.outer_loop_stiffness(A, g.replace(eps=jnp.full(4, ctl.EPS)))[0])
    pd = np.asarray(g.kp) * np.asarray(g.signs)
    ratio = k / pd
    assert np.all(ratio >= 1.0), ratio
    assert ratio[0] < 1.01 ** 2, ratio
    assert np.all(ratio[1:] > 1.5), ratio
    shipped = np.asarray(ctl.outer_loop_stiffness(A, g)[0]) / pd
    np.testing.assert_allclose(shipped / ratio, [32.0, 1.0, 1.0, 1.0], rtol=1e-12)


def test_the_eps_grid_and_its_choice():
    """EPS_GRID halves the loop's stiffness-per-eps in steps of sqrt(2) in eps from EPS down to
    EPS / 16; EPS_OUTPUTS takes its values from it (stance leg shape: EPS / 2^2.5)."""
    grid = np.asarray(ctl.EPS_GRID)
    assert grid[0] == ctl.EPS and len(grid) == 9
    np.testing.assert_allclose(grid[:-1] / grid[1:], np.sqrt(2.0), rtol=1e-14)
    assert all(e in ctl.EPS_GRID for e in ctl.EPS_OUTPUTS)
    np.testing.assert_allclose(ctl.EPS_OUTPUTS[0], ctl.EPS / 2 ** 2.5, rtol=1e-14)


def test_stiffness_scales_as_inverse_eps_squared_and_ignores_output_scaling():
    A, g = _at_touchdown()
    k = np.asarray(ctl.outer_loop_stiffness(A, g)[0])
    k2 = np.asarray(ctl.outer_loop_stiffness(A, g.replace(eps=g.eps / 2))[0])
    assert np.asarray(g.eps).shape == (4,)
    assert np.allclose(k2, 4.0 * k)
    # normalising the outputs (rows of A and y scaled alike) leaves the torque per rad unchanged
    S = jnp.diag(jnp.asarray([1 / 31.42, 1.0, 1 / 31.42, 1.0]))
    kn = np.asarray(ctl.outer_loop_stiffness(S @ A, g)[0]) * np.diag(np.asarray(S))
    assert np.allclose(kn, k)
