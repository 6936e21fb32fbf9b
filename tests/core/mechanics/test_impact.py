"""Rigid (plastic, no-slip) impact of a point foot, and leg relabelling."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bipedlab import mechanics as mech
from bipedlab.robots.five_link import robot as five_link
import oracles

N = 16


def _pre_impact_states(model, rng, n):
    """Walking-like postures with foot_2 1e-5 m above the ground, moving down at 0.3-1 m/s."""
    q = np.zeros((n, 7))
    q[:, 0] = rng.uniform(-1, 1, n)
    q[:, 2] = rng.uniform(-0.3, 0.3, n)
    q[:, [3, 5]] = rng.uniform(-0.6, 0.6, (n, 2))
    q[:, [4, 6]] = rng.uniform(0.0, 0.9, (n, 2))
    qd = 1.5 * rng.standard_normal((n, 7))
    for k in range(n):
        foot = np.asarray(oracles.five_link_foot(jnp.asarray(q[k]), 1))
        q[k, 1] += 1e-5 - foot[1]
        J = np.asarray(jax.jacfwd(oracles.five_link_foot)(jnp.asarray(q[k]), 1))
        vy = J[1] @ qd[k]
        qd[k, 1] += -rng.uniform(0.3, 1.0) - vy  # the hip's vertical speed sets the foot's
    return jnp.asarray(q), jnp.asarray(qd)


@pytest.fixture(scope="module")
def impacts(five):
    q, qd_minus = _pre_impact_states(five, np.random.default_rng(42), N)
    L = oracles.FIVE_LINK

    def one(q, qdm):
        qdp, impulse = mech.impact_map(five, q, qdm, "foot_2")
        p = mech.point_position(five, q, "foot_2")
        M = L.mass_matrix(q)
        J = jax.jacfwd(oracles.five_link_foot)(q, 1)
        return dict(
            qdp=qdp, impulse=impulse, foot_p=p,
            v_foot_plus=J @ qdp, v_foot_minus=J @ qdm,
            L_minus=mech.angular_momentum(five, q, qdm, p), L_plus=mech.angular_momentum(five, q, qdp, p),
            L_minus_ref=L.angular_momentum(q, qdm, p), L_plus_ref=L.angular_momentum(q, qdp, p),
            T_minus=L.kinetic(q, qdm), T_plus=L.kinetic(q, qdp),
            T_jump=0.5 * (qdm - qdp) @ M @ (qdm - qdp),
            residual=M @ (qdp - qdm) - J.T @ impulse,
            dp=oracles.FIVE_TOTAL_MASS * (mech.com_velocity(five, q, qdp) - mech.com_velocity(five, q, qdm)),
        )

    return {k: np.asarray(v) for k, v in jax.jit(jax.vmap(one))(q, qd_minus).items()}


def test_pre_impact_states_are_touchdowns(impacts):
    np.testing.assert_allclose(impacts["foot_p"][:, 1], 1e-5, atol=1e-12)
    assert np.all(impacts["v_foot_minus"][:, 1] < -0.29)


def test_foot_stops(impacts):
    assert np.abs(impacts["v_foot_plus"]).max() < 1e-12


def test_angular_momentum_about_impact_point_conserved(impacts):
    for a, b in (("L_plus", "L_minus"), ("L_plus_ref", "L_minus_ref")):
        np.testing.assert_allclose(impacts[a], impacts[b], rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(impacts["L_minus"], impacts["L_minus_ref"], rtol=1e-12)


def test_impulse_equations(impacts):
    scale = np.abs(impacts["impulse"]).max()
    assert scale > 1.0
    np.testing.assert_allclose(impacts["residual"], 0.0, atol=1e-11 * scale)
    # linear momentum jumps by exactly the ground impulse
    np.testing.assert_allclose(impacts["dp"], impacts["impulse"], atol=1e-11 * scale)


def test_kinetic_energy_lost_never_gained(impacts):
    assert np.all(impacts["T_plus"] <= impacts["T_minus"])
    # Carnot: the loss of a plastic impact is the kinetic energy of the velocity jump
    np.testing.assert_allclose(impacts["T_minus"] - impacts["T_plus"], impacts["T_jump"], rtol=1e-9)
    assert np.all(impacts["T_jump"] > 1e-3)


def test_relabel_swaps_legs(five):
    rng = np.random.default_rng(1)
    q = jnp.asarray(rng.uniform(-1, 1, 7))
    qs = mech.relabel(q, five_link.LEG_SWAP)
    np.testing.assert_array_equal(qs, np.asarray(q)[[0, 1, 2, 5, 6, 3, 4]])
    np.testing.assert_array_equal(mech.relabel(qs, five_link.LEG_SWAP), q)
    np.testing.assert_allclose(mech.point_position(five, qs, "foot_1"), mech.point_position(five, q, "foot_2"),
                               atol=1e-15)
    np.testing.assert_allclose(mech.point_position(five, qs, "foot_2"), mech.point_position(five, q, "foot_1"),
                               atol=1e-15)
    # the dynamics are symmetric under the swap: M(Pq) = P M(q) P^T
    P = np.eye(7)[list(five_link.LEG_SWAP)]
    np.testing.assert_allclose(mech.mass_matrix(five, qs), P @ np.asarray(mech.mass_matrix(five, q)) @ P.T,
                               rtol=1e-14, atol=1e-14)
    # batched states: the last axis is permuted, with optional signs
    X = jnp.asarray(rng.standard_normal((3, 7)))
    sign = np.array([1, 1, 1, -1, 1, -1, 1.0])
    np.testing.assert_array_equal(mech.relabel(X, five_link.LEG_SWAP, sign),
                                  np.asarray(X)[:, list(five_link.LEG_SWAP)] * sign)
