"""Less common trees: prismatic joints on the base and on each other, and bodies without
mass (pure rotational inertias), against MuJoCo and hand-written Lagrangians."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bipedlab import mechanics as mech
from bipedlab.mechanics import Body, Point, build_model
from helpers import mj_full_inertia, random_states, rel_err
import oracles


def _rot(a, v):
    c, s = jnp.cos(a), jnp.sin(a)
    return jnp.stack([c * v[0] - s * v[1], s * v[0] + c * v[1]])


# ----- base -> prismatic -> prismatic -> revolute (declared depth-first: qpos == q) ---------
AX2 = np.array([1.0, 1.0]) / np.sqrt(2.0)
CHAIN = [
    Body("base", None, 3.0, (0.05, -0.02), 0.2),
    Body("lift", "base", 1.0, (0.0, 0.1), 0.03, joint="prismatic", offset=(0.1, 0.2), axis=(0.0, 1.0)),
    Body("skew", "lift", 0.8, (0.1, 0.0), 0.02, joint="prismatic", offset=(0.0, 0.1), axis=(1.0, 1.0)),
    Body("flap", "skew", 0.5, (0.15, 0.05), 0.01, offset=(0.2, 0.0)),
]
CHAIN_POINTS = [Point("flap_tip", "flap", (0.3, 0.0))]


def chain_geometry(q):
    th = q[2]
    o0 = q[:2]
    o1 = o0 + _rot(th, jnp.array([0.1, 0.2]) + q[3] * jnp.array([0.0, 1.0]))
    o2 = o1 + _rot(th, jnp.array([0.0, 0.1]) + q[4] * jnp.asarray(AX2))
    o3 = o2 + _rot(th, jnp.array([0.2, 0.0]))
    a3 = th + q[5]
    coms = jnp.stack([o0 + _rot(th, jnp.array([0.05, -0.02])), o1 + _rot(th, jnp.array([0.0, 0.1])),
                      o2 + _rot(th, jnp.array([0.1, 0.0])), o3 + _rot(a3, jnp.array([0.15, 0.05]))])
    return coms, jnp.stack([th, th, th, a3]), o3 + _rot(a3, jnp.array([0.3, 0.0]))


CHAIN_L = oracles.Lagrangian(lambda q: chain_geometry(q)[0], lambda q: chain_geometry(q)[1],
                             [3.0, 1.0, 0.8, 0.5], [0.2, 0.03, 0.02, 0.01])


@pytest.fixture(scope="module")
def chain_results(mujoco):
    model = build_model(CHAIN, CHAIN_POINTS)
    rng = np.random.default_rng(99)
    n = 100
    q, qd = random_states(rng, n, 6, qd_scale=2.0)
    q[:, 3:5] = rng.uniform(-0.5, 0.5, (n, 2))
    tau = 5.0 * rng.standard_normal((n, 6))

    @jax.jit
    def both(q, qd, tau):
        one = lambda q, qd, tau: (  # noqa: E731
            mech.mass_matrix(model, q), mech.bias(model, q, qd), mech.forward_dynamics(model, q, qd, tau),
            mech.point_position(model, q, "flap_tip"), mech.point_jdot_qd(model, q, qd, "flap_tip"),
            CHAIN_L.mass_matrix(q), CHAIN_L.bias(q, qd), CHAIN_L.accel(q, qd, tau), chain_geometry(q)[2],
            jax.jvp(lambda q: jax.jacfwd(lambda q: chain_geometry(q)[2])(q) @ qd, (q,), (qd,))[1],
        )
        return jax.vmap(one)(q, qd, tau)

    ours_and_oracle = [np.asarray(a) for a in both(q, qd, tau)]
    m = mujoco.MjModel.from_xml_string(mech.to_mjcf(model, floor=False))
    d = mujoco.MjData(m)
    site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "flap_tip")
    mj = [[], [], [], []]
    for k in range(n):
        d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q[k], qd[k], tau[k]
        mujoco.mj_forward(m, d)
        mj[0].append(mj_full_inertia(mujoco, m, d))
        mj[1].append(d.qfrc_bias.copy())
        mj[2].append(d.qacc.copy())
        mj[3].append(d.site_xpos[site][[0, 2]].copy())
    return ours_and_oracle, [np.asarray(a) for a in mj]


def _each_close(a, b, tol=1e-9):
    errs = [rel_err(x, y) for x, y in zip(a, b)]
    assert max(errs) < tol, f"state {int(np.argmax(errs))}: relative error {max(errs):.3e}"


def test_prismatic_chain_matches_mujoco(chain_results):
    (M, h, qdd, tip, *_), mj = chain_results
    _each_close(M, mj[0])
    _each_close(h, mj[1])
    _each_close(qdd, mj[2])
    np.testing.assert_allclose(tip, mj[3], atol=1e-12)


def test_prismatic_chain_matches_lagrangian(chain_results):
    (M, h, qdd, tip, a, M_ref, h_ref, qdd_ref, tip_ref, a_ref), _ = chain_results
    _each_close(M, M_ref)
    _each_close(h, h_ref)
    _each_close(qdd, qdd_ref)
    np.testing.assert_allclose(tip, tip_ref, atol=1e-13)
    np.testing.assert_allclose(a, a_ref, atol=1e-11)


# ----- massless bodies carrying rotational inertia ------------------------------------------
def test_massless_subtree_with_inertia():
    """build_model accepts mass 0; a subtree of massless bodies that still carry inertia has
    a well-defined, positive definite mass matrix (T = 1/2 I w^2 for those bodies)."""
    bodies = [Body("root", None, 1.0, (0.0, 0.0), 0.1),
              Body("a", "root", 0.0, (0.0, 0.0), 0.01, offset=(0.1, 0.0)),
              Body("b", "a", 0.0, (0.0, 0.0), 0.02, offset=(0.1, 0.0))]
    model = build_model(bodies)

    def geometry(q):
        return jnp.stack([q[:2]] * 3), jnp.stack([q[2], q[2] + q[3], q[2] + q[3] + q[4]])

    L = oracles.Lagrangian(lambda q: geometry(q)[0], lambda q: geometry(q)[1], [1.0, 0.0, 0.0], [0.1, 0.01, 0.02])
    q = jnp.array([0.3, -0.2, 0.1, 0.2, 0.3])
    qd = jnp.array([0.5, -1.0, 1.5, 2.0, -1.0])
    M_ref = np.asarray(L.mass_matrix(q))
    assert np.all(np.linalg.eigvalsh(M_ref) > 0)
    np.testing.assert_allclose(mech.kinetic_energy(model, q, qd), 0.5 * qd @ M_ref @ qd, rtol=1e-12)
    np.testing.assert_allclose(mech.mass_matrix(model, q), M_ref, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(mech.com_position(model, q), q[:2], atol=1e-15)
    np.testing.assert_allclose(mech.forward_dynamics(model, q, qd, jnp.zeros(5)),
                               L.accel(q, qd, jnp.zeros(5)), rtol=1e-10, atol=1e-12)
