"""Stick/slip point contact (Geyer & Herr 2010 ground): force laws and the switch."""
import jax.numpy as jnp
import pytest

from bipedlab.contact import stick_slip as ss
from bipedlab.contact import terrain as tr

G = ss.StickSlipGround(k_y=6e4, k_x=6e3)
FLAT = tr.flat()


def test_normal_force_is_a_unilateral_spring_with_velocity_scaled_damping():
    pos, vel = jnp.array([0.5, -0.005]), jnp.array([0.0, -0.01])
    F0, C, on = ss.contact_terms(G, FLAT, pos, vel, 0.5, True)
    assert bool(on)
    assert float(F0[1]) == pytest.approx(G.k_y * 0.005)
    assert float(C[1]) == pytest.approx(G.k_y * 0.005 / G.v_max)
    fy = float(F0[1] - C[1] * vel[1])
    assert fy == pytest.approx(G.k_y * 0.005 * (1 - vel[1] / G.v_max))
    assert float(ss.normal_force(G, FLAT, pos, vel)) == pytest.approx(fy)
    # leaving faster than v_max: no force; above the ground: no force
    F0, C, on = ss.contact_terms(G, FLAT, pos, jnp.array([0.0, 0.05]), 0.5, True)
    assert not bool(on) and float(F0[1]) == 0.0 and float(C[1]) == 0.0
    assert float(ss.normal_force(G, FLAT, jnp.array([0.5, 0.01]), vel)) == 0.0


def test_stiction_spring_and_sliding_friction():
    pos, vel = jnp.array([0.52, -0.005]), jnp.array([0.3, 0.0])
    F0, C, _ = ss.contact_terms(G, FLAT, pos, vel, 0.5, True)
    assert float(F0[0]) == pytest.approx(-G.k_x * 0.02) and float(C[0]) == pytest.approx(G.k_x * 0.02 / G.v_max)
    F0, C, _ = ss.contact_terms(G, FLAT, pos, vel, 0.5, False)
    assert float(F0[0]) == pytest.approx(-G.mu_slide * G.k_y * 0.005) and float(C[0]) == 0.0


def test_transition_slips_outside_the_cone_and_sticks_when_slow():
    on = jnp.asarray(True)
    stick, anchor = ss.transition(G, on, jnp.asarray(True), 0.1, jnp.array([95.0, 100.0]), 0.3, 0.5)
    assert bool(~stick) and float(anchor) == 0.3            # |Fx| > 0.9 Fy: slip, anchor follows
    stick, anchor = ss.transition(G, on, jnp.asarray(True), 0.1, jnp.array([85.0, 100.0]), 0.3, 0.5)
    assert bool(stick) and float(anchor) == 0.1             # inside the cone: keeps its anchor
    stick, anchor = ss.transition(G, on, jnp.asarray(False), 0.1, jnp.array([80.0, 100.0]), 0.3, 0.005)
    assert bool(stick) and float(anchor) == 0.3             # slow sliding point sticks where it is
    stick, _ = ss.transition(G, jnp.asarray(False), jnp.asarray(False), 0.1, jnp.zeros(2), 0.3, 2.0)
    assert bool(stick)                                      # off the ground: reset to sticking
