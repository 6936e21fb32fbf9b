"""Five-link mass matrix, bias and forward dynamics against MuJoCo and against an
independent autodiff Lagrangian (tests/oracles.py)."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bipedlab import mechanics as mech
from bipedlab.robots.five_link import robot as five_link
from helpers import mj_full_inertia, random_states, rel_err
import oracles

N_STATES = 128
TOL = 1e-9


@pytest.fixture(scope="module")
def states():
    rng = np.random.default_rng(20240611)
    q, qd = random_states(rng, N_STATES, 7, qd_scale=3.0)
    tau = 50.0 * rng.standard_normal((N_STATES, 7))
    return q, qd, tau


@pytest.fixture(scope="module")
def ours(five, states):
    """bipedlab's quantities on all states, one compiled vmapped call."""
    q, qd, tau = states

    @jax.jit
    def f(model, q, qd, tau):
        one = lambda q, qd, tau: (  # noqa: E731
            mech.mass_matrix(model, q),
            mech.bias(model, q, qd),
            mech.forward_dynamics(model, q, qd, tau),
            mech.gravity_forces(model, q),
            mech.kinetic_energy(model, q, qd),
            mech.potential_energy(model, q),
            mech.com_position(model, q),
            jnp.stack([mech.point_position(model, q, n) for n in ("foot_1", "foot_2")]),
        )
        return jax.vmap(one)(q, qd, tau)

    keys = ("M", "bias", "qdd", "grav", "T", "V", "com", "feet")
    return dict(zip(keys, (np.asarray(a) for a in f(five, q, qd, tau))))


@pytest.fixture(scope="module")
def oracle(states):
    q, qd, tau = states
    L = oracles.FIVE_LINK

    @jax.jit
    def f(q, qd, tau):
        one = lambda q, qd, tau: (  # noqa: E731
            L.mass_matrix(q), L.bias(q, qd), L.accel(q, qd, tau), L.bias(q, 0 * qd),
            L.kinetic(q, qd), L.potential(q), L.com(q), oracles.five_link_geometry(q)[2],
        )
        return jax.vmap(one)(q, qd, tau)

    keys = ("M", "bias", "qdd", "grav", "T", "V", "com", "feet")
    return dict(zip(keys, (np.asarray(a) for a in f(q, qd, tau))))


@pytest.fixture(scope="module")
def mujoco_ref(mujoco, states):
    q, qd, tau = states
    m = mujoco.MjModel.from_xml_string(five_link.mjcf(floor=False))
    d = mujoco.MjData(m)
    assert m.nq == m.nv == 7
    out = dict(M=[], bias=[], qdd=[], com=[], feet=[])
    sites = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, n) for n in ("foot_1", "foot_2")]
    for k in range(N_STATES):
        d.qpos[:] = q[k]
        d.qvel[:] = qd[k]
        d.qfrc_applied[:] = tau[k]
        mujoco.mj_forward(m, d)
        out["M"].append(mj_full_inertia(mujoco, m, d))
        out["bias"].append(d.qfrc_bias.copy())
        out["qdd"].append(d.qacc.copy())
        out["com"].append(d.subtree_com[1][[0, 2]].copy())
        out["feet"].append(np.stack([d.site_xpos[s][[0, 2]] for s in sites]))
    return {k: np.asarray(v) for k, v in out.items()}


def _each_close(a, b, tol=TOL):
    errs = [rel_err(x, y) for x, y in zip(a, b)]
    worst = int(np.argmax(errs))
    assert errs[worst] < tol, f"state {worst}: relative error {errs[worst]:.3e}"


def test_oracle_is_not_degenerate(oracle):
    # the oracle itself: symmetric PD, total mass in the translational block, nonzero bias
    M = oracle["M"]
    np.testing.assert_allclose(M[:, :2, :2], np.broadcast_to(oracles.FIVE_TOTAL_MASS * np.eye(2), (N_STATES, 2, 2)),
                               rtol=1e-13)
    assert np.all(np.linalg.eigvalsh(M) > 0)
    assert np.min(np.linalg.norm(oracle["bias"] - oracle["grav"], axis=1)) > 1e-3


def test_mass_matrix_matches_mujoco(ours, mujoco_ref):
    _each_close(ours["M"], mujoco_ref["M"])


def test_bias_matches_mujoco(ours, mujoco_ref):
    _each_close(ours["bias"], mujoco_ref["bias"])


def test_forward_dynamics_matches_mujoco(ours, mujoco_ref):
    _each_close(ours["qdd"], mujoco_ref["qdd"])


def test_mjcf_sites_and_com_match_kinematics(ours, mujoco_ref):
    np.testing.assert_allclose(ours["feet"], mujoco_ref["feet"], atol=1e-12)
    np.testing.assert_allclose(ours["com"], mujoco_ref["com"], atol=1e-12)


def test_mass_matrix_matches_lagrangian_oracle(ours, oracle):
    _each_close(ours["M"], oracle["M"])


def test_bias_matches_lagrangian_oracle(ours, oracle):
    _each_close(ours["bias"], oracle["bias"])
    _each_close(ours["grav"], oracle["grav"])


def test_energies_com_and_feet_match_oracle(ours, oracle):
    np.testing.assert_allclose(ours["T"], oracle["T"], rtol=1e-12)
    np.testing.assert_allclose(ours["V"], oracle["V"], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(ours["com"], oracle["com"], atol=1e-13)
    np.testing.assert_allclose(ours["feet"], oracle["feet"], atol=1e-13)


def test_mass_matrix_symmetric_positive_definite(ours):
    M = ours["M"]
    np.testing.assert_allclose(M, np.swapaxes(M, 1, 2), rtol=0, atol=1e-13 * np.abs(M).max())
    eig = np.linalg.eigvalsh(M)
    assert np.all(eig > 1e-6), eig.min()


def test_forward_dynamics_is_solve_of_mass_matrix(ours, states):
    _, _, tau = states
    ref = np.linalg.solve(ours["M"], (tau - ours["bias"])[..., None])[..., 0]
    _each_close(ours["qdd"], ref)


def test_kinetic_energy_is_quadratic_form(ours, states):
    _, qd, _ = states
    np.testing.assert_allclose(ours["T"], 0.5 * np.einsum("ni,nij,nj->n", qd, ours["M"], qd), rtol=1e-12)


def test_standing_pose_geometry():
    """Hand-computed numbers for the standing reference (no autodiff involved)."""
    model = five_link.model()
    q = np.asarray(five_link.standing_state()[:7])
    foot_y = 0.78 - 0.4 * np.cos(-0.3) - 0.4 * np.cos(0.3)
    foot_x = 0.4 * np.sin(-0.3) + 0.4 * np.sin(0.3)
    np.testing.assert_allclose(mech.point_position(model, q, "foot_1"), [foot_x, foot_y], atol=1e-14)
    np.testing.assert_allclose(mech.point_position(model, q, "foot_2"), [0.8 * np.sin(0.3), foot_y], atol=1e-14)
    assert float(mech.total_mass(model)) == pytest.approx(32.0, abs=1e-12)


def test_mjcf_actuators_and_contact_geoms(mujoco):
    """The bench's MuJoCo model: position actuators give the joint PD torques, and only the
    feet carry collision spheres of the requested radius."""
    kp, kd = 400.0, 20.0
    xml = five_link.mjcf(contact_points=("foot_1", "foot_2"), contact_radius=0.02, pd_gains=(kp, kd))
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(8)
    q, qd = rng.uniform(-1, 1, 7), rng.standard_normal(7)
    d.qpos[:], d.qvel[:] = q, qd
    d.qpos[1] += 2.0  # in the air
    d.ctrl[:] = five_link.STANDING_REFERENCE
    mujoco.mj_forward(m, d)
    B = five_link.model().actuation_matrix()
    u = kp * (five_link.STANDING_REFERENCE - q[3:]) - kd * qd[3:]
    np.testing.assert_allclose(d.qfrc_actuator, B @ u, rtol=1e-12, atol=1e-10)
    spheres = [g for g in range(m.ngeom) if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_SPHERE]
    assert len(spheres) == 2 and np.allclose(m.geom_size[spheres, 0], 0.02)
    assert d.ncon == 0
