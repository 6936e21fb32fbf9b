"""A branched tree with a prismatic joint (and a revolute body riding on the slider)
against MuJoCo via to_mjcf and against a hand-written Lagrangian; rotor inertias."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bipedlab import mechanics as mech
from bipedlab.mechanics import Rotor
from helpers import mj_full_inertia, random_states, rel_err
import oracles
from trees import ORDER, POINTS, SPEC, make_model

N_STATES = 112
TOL = 1e-9


def _lagrangian(rotors=()):
    masses = [SPEC[k]["mass"] for k in ORDER]
    inertias = [SPEC[k]["inertia"] for k in ORDER]
    coms = lambda q: oracles.branched_geometry(q, SPEC)[0]  # noqa: E731
    angles = lambda q: oracles.branched_geometry(q, SPEC)[1]  # noqa: E731
    return oracles.Lagrangian(coms, angles, masses, inertias,
                              rotors=[(r.inertia, r.ratios) for r in rotors])


@pytest.fixture(scope="module")
def states():
    rng = np.random.default_rng(7)
    q, qd = random_states(rng, N_STATES, 7, qd_scale=2.5)
    q[:, 4] = rng.uniform(-0.5, 0.8, N_STATES)  # slider extension, m
    tau = 10.0 * rng.standard_normal((N_STATES, 7))
    return q, qd, tau


def _ours(model, q, qd, tau):
    @jax.jit
    def f(model, q, qd, tau):
        one = lambda q, qd, tau: (  # noqa: E731
            mech.mass_matrix(model, q), mech.bias(model, q, qd),
            mech.forward_dynamics(model, q, qd, tau), mech.kinetic_energy(model, q, qd),
            mech.angular_momentum(model, q, qd, jnp.array([0.3, -0.2])),
        )
        return jax.vmap(one)(q, qd, tau)

    return [np.asarray(a) for a in f(model, q, qd, tau)]


def _oracle(L, q, qd, tau):
    @jax.jit
    def f(q, qd, tau):
        one = lambda q, qd, tau: (  # noqa: E731
            L.mass_matrix(q), L.bias(q, qd), L.accel(q, qd, tau), L.kinetic(q, qd),
            L.angular_momentum(q, qd, jnp.array([0.3, -0.2])),
        )
        return jax.vmap(one)(q, qd, tau)

    return [np.asarray(a) for a in f(q, qd, tau)]


@pytest.fixture(scope="module")
def ours(states):
    return _ours(make_model(), *states)


@pytest.fixture(scope="module")
def oracle(states):
    return _oracle(_lagrangian(), *states)


def _mujoco_order(mujoco, m, model):
    """perm with MuJoCo dof i == bipedlab coordinate perm[i], matched by joint name."""
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(m.njnt)]
    assert list(m.jnt_dofadr) == list(range(m.njnt)) and sorted(names) == sorted(model.coord_names)
    return np.array([model.coord_names.index(n) for n in names])


@pytest.fixture(scope="module")
def mujoco_ref(mujoco, states):
    """MuJoCo's M, bias, qacc and site positions, mapped back to bipedlab's coordinate order
    by joint name (so the physics is compared even if the export reorders the dofs)."""
    q, qd, tau = states
    model = make_model()
    m = mujoco.MjModel.from_xml_string(mech.to_mjcf(model, floor=False))
    d = mujoco.MjData(m)
    assert (m.nq, m.nv) == (7, 7)
    perm = _mujoco_order(mujoco, m, model)
    inv = np.argsort(perm)
    sites = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, p.name) for p in POINTS]
    M, h, qdd, pts = [], [], [], []
    for k in range(N_STATES):
        d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q[k][perm], qd[k][perm], tau[k][perm]
        mujoco.mj_forward(m, d)
        M.append(mj_full_inertia(mujoco, m, d)[np.ix_(inv, inv)])
        h.append(d.qfrc_bias[inv])
        qdd.append(d.qacc[inv])
        pts.append(np.stack([d.site_xpos[s][[0, 2]] for s in sites]))
    return np.asarray(M), np.asarray(h), np.asarray(qdd), np.asarray(pts)


def test_mjcf_qpos_order(mujoco, five):
    """MuJoCo numbers joints depth-first: mjcf_coordinate_order names the coordinate behind
    each qpos entry (this tree declares a branch between a body and its descendants), and it
    is the identity for a depth-first declaration such as the five-link biped."""
    model = make_model()
    m = mujoco.MjModel.from_xml_string(mech.to_mjcf(model, floor=False))
    names = tuple(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(m.njnt))
    order = mech.mjcf_coordinate_order(model)
    assert names == tuple(model.coord_names[i] for i in order)
    assert order != tuple(range(model.nq))
    m5 = mujoco.MjModel.from_xml_string(mech.to_mjcf(five, floor=False))
    names5 = tuple(mujoco.mj_id2name(m5, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(m5.njnt))
    assert names5 == five.coord_names
    assert mech.mjcf_coordinate_order(five) == tuple(range(five.nq))


def _each_close(a, b, tol=TOL):
    errs = [rel_err(x, y) for x, y in zip(a, b)]
    worst = int(np.argmax(errs))
    assert errs[worst] < tol, f"state {worst}: relative error {errs[worst]:.3e}"


def test_structure():
    model = make_model()
    assert model.nq == 7
    assert model.coord_names == ("x", "y", "theta") + ORDER[1:]
    assert model.joints[ORDER.index("slide")] == "prismatic"
    np.testing.assert_allclose(np.asarray(model.axis)[2], [0.6, 0.8], rtol=1e-15)  # normalised
    np.testing.assert_array_equal(model.actuation_matrix(), np.eye(7)[:, 3:])


def test_mass_matrix_and_bias_match_mujoco(ours, mujoco_ref):
    M, h, qdd = ours[:3]
    M_mj, h_mj, qdd_mj, _ = mujoco_ref
    _each_close(M, M_mj)
    _each_close(h, h_mj)
    _each_close(qdd, qdd_mj)


def test_mass_matrix_and_bias_match_lagrangian(ours, oracle):
    for a, b in zip(ours[:3], oracle[:3]):
        _each_close(a, b)
    np.testing.assert_allclose(ours[3], oracle[3], rtol=1e-12)
    np.testing.assert_allclose(ours[4], oracle[4], rtol=1e-11, atol=1e-12)


def test_cross_branch_entries_vanish(ours):
    # 'leg' (coordinate 5) shares no body with 'arm', 'slide', 'tip' (3, 4, 6)
    M = ours[0]
    for j in (3, 4, 6):
        assert np.all(M[:, 5, j] == 0.0) and np.all(M[:, j, 5] == 0.0)


def test_points_match_mujoco_sites(states, mujoco_ref):
    q = states[0]
    model = make_model()
    f = jax.jit(jax.vmap(lambda q: jnp.stack([mech.point_position(model, q, p.name) for p in POINTS])))
    np.testing.assert_allclose(np.asarray(f(q)), mujoco_ref[3], atol=1e-12)


def test_forward_dynamics_is_solve(ours, states):
    M, h, qdd = ours[:3]
    tau = states[2]
    _each_close(qdd, np.linalg.solve(M, (tau - h)[..., None])[..., 0])
    assert np.all(np.linalg.eigvalsh(M) > 0)
    np.testing.assert_allclose(M, np.swapaxes(M, 1, 2), rtol=0, atol=1e-14 * np.abs(M).max())


ROTORS = (
    Rotor("hip_motor", 0.8, (0.0, 0.0, 1.0, 12.0, 0.0, 0.0, 0.0)),  # geared to the arm joint
    Rotor("coupled", 0.3, (0.0, 0.0, 0.0, 2.0, 0.0, -3.0, 1.5)),  # couples two branches
)


@pytest.fixture(scope="module")
def with_rotors(states):
    return _ours(make_model(rotors=ROTORS), *states)


def test_rotors_add_outer_products(ours, with_rotors, states):
    added = sum(r.inertia * np.outer(r.ratios, r.ratios) for r in ROTORS)
    M0, h0 = ours[0], ours[1]
    M1, h1, qdd1, T1, _ = with_rotors
    np.testing.assert_allclose(M1, M0 + added, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(h1, h0, rtol=1e-13, atol=1e-12)  # constant ratios: no bias
    q, qd, tau = states
    np.testing.assert_allclose(T1, 0.5 * np.einsum("ni,nij,nj->n", qd, M1, qd), rtol=1e-12)
    # the LTDL solve must cope with the fill-in a cross-branch rotor creates
    _each_close(qdd1, np.linalg.solve(M1, (tau - h1)[..., None])[..., 0])


def test_rotors_match_lagrangian(with_rotors, states):
    ref = _oracle(_lagrangian(ROTORS), *states)
    for a, b in zip(with_rotors[:3], ref[:3]):
        _each_close(a, b)
    np.testing.assert_allclose(with_rotors[4], ref[4], rtol=1e-11, atol=1e-12)


def test_rotor_models_refuse_mjcf_export():
    with pytest.raises(ValueError, match="rotor"):
        mech.to_mjcf(make_model(rotors=ROTORS))
