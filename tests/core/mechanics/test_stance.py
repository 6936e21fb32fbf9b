"""The five-link stance model (stance foot pinned at the origin) and its impact map, against the
hand-written geometry and the Lagrangian of tests/oracles.py.

Oracles: the pinned model's own Lagrangian (the hip position written as a function of the
stance coordinates so that the toe stays at the origin; no constraint forces needed), the
floating Lagrangian for the constrained equations of motion, Newton's law for the centre of
mass, and momentum / energy balance through the impact."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bipedlab import mechanics as mech
from bipedlab.gait import gaitfile
from bipedlab.mechanics import stance as stm
from bipedlab.robots.five_link import robot as five_link
import oracles

N = 8
G = 9.81
B_FULL = np.vstack([np.zeros((3, 4)), np.eye(4)])  # joint torques act on q[3:7]


@pytest.fixture(scope="module")
def st():
    return five_link.stance()


@pytest.fixture(scope="module")
def states():
    """Walking-like stance states (the shipped pre-impact state first) and random inputs."""
    rng = np.random.default_rng(2024)
    _, z_star, _ = gaitfile.shipped("bipedlab.robots.five_link", "five_link_0.8")
    z = np.zeros((N, 10))
    z[:, 0] = rng.uniform(-0.3, 0.3, N)
    z[:, [1, 3]] = rng.uniform(-0.6, 0.6, (N, 2))
    z[:, [2, 4]] = rng.uniform(-0.9, 0.3, (N, 2))
    z[:, 5:] = 2.0 * rng.standard_normal((N, 5))
    z[0] = np.asarray(z_star)
    u = 20.0 * rng.standard_normal((N, 4))
    return jnp.asarray(z), jnp.asarray(u)


def _full(qs):
    """Floating coordinates with the hip placed so that foot_1 is at the origin (oracle)."""
    q0 = jnp.concatenate([jnp.zeros(2), qs])
    return q0.at[:2].set(-oracles.five_link_foot(q0, 0))


PINNED = oracles.Lagrangian(lambda qs: oracles.five_link_coms(_full(qs)),
                            lambda qs: oracles.five_link_angles(_full(qs)),
                            oracles.FIVE_MASSES, oracles.FIVE_INERTIAS)


@pytest.fixture(scope="module")
def stance_data(st, states):
    z, u = states
    L = oracles.FIVE_LINK
    foot = lambda q, leg: oracles.five_link_foot(q, leg)  # noqa: E731

    def one(z, u):
        q, qd = stm.embed(st, z)
        a, b, la, lb = stm.stance_affine(st, z)
        af, bf, _, _ = stm.constrained_affine(st.model, st.stance, q, qd)
        qdd = af + bf @ u
        lam = la + lb @ u
        J1 = jax.jacfwd(foot)(q, 0)
        Jd1 = jax.jvp(lambda q_: jax.jacfwd(foot)(q_, 0), (q,), (qd,))[1]
        Jc = jax.jacfwd(L.com)(q)
        Jcd = jax.jvp(jax.jacfwd(L.com), (q,), (qd,))[1]
        qs, qds = z[:5], z[5:]
        return dict(
            q=q, qd=qd, z_back=stm.reduce(q, qd),
            foot1=foot(q, 0), foot1_vel=J1 @ qd, foot1_acc=J1 @ qdd + Jd1 @ qd,
            foot2=foot(q, 1), swing_height=stm.swing_height(st, z), swing_position=stm.swing_position(st, z),
            qdd_s=a + b @ u, qdd_full=qdd, lam=lam,
            eom_residual=L.mass_matrix(q) @ qdd + L.bias(q, qd) - B_FULL @ u - J1.T @ lam,
            qdd_pinned=PINNED.accel(qs, qds, jnp.concatenate([jnp.zeros(1), u])),
            com_acc=Jc @ qdd + Jcd @ qd,
            flow=stm.stance_flow(st, z, u), grf=stm.ground_reaction(st, z, u),
        )

    return {k: np.asarray(v) for k, v in jax.jit(jax.vmap(one))(z, u).items()}


def test_embed_pins_the_stance_foot_at_the_origin_at_rest(stance_data, states):
    d = stance_data
    np.testing.assert_allclose(d["foot1"], 0.0, atol=1e-14)
    np.testing.assert_allclose(d["foot1_vel"], 0.0, atol=1e-13)
    np.testing.assert_allclose(d["z_back"], np.asarray(states[0]), atol=0)
    # the orientation and joints are carried over unchanged
    np.testing.assert_allclose(d["q"][:, 2:], np.asarray(states[0])[:, :5], atol=0)


def test_swing_foot_position_and_height(stance_data):
    d = stance_data
    np.testing.assert_allclose(d["swing_position"], d["foot2"], atol=1e-14)
    np.testing.assert_allclose(d["swing_height"], d["foot2"][:, 1], atol=1e-14)
    # the shipped pre-impact state has its swing toe on the ground, a step ahead
    assert abs(d["swing_height"][0]) < 1e-10
    assert 0.3 < d["swing_position"][0, 0] < 0.5


def test_stance_accelerations_keep_the_foot_still(stance_data):
    d = stance_data
    scale = np.abs(d["qdd_full"]).max()
    assert scale > 1.0
    np.testing.assert_allclose(d["foot1_acc"], 0.0, atol=1e-11 * scale)
    np.testing.assert_allclose(d["qdd_s"], d["qdd_full"][:, 2:], atol=1e-12 * scale)


def test_constrained_equations_of_motion(stance_data):
    """M qdd + bias = B u + J^T lambda with the oracle M, bias and foot Jacobian."""
    d = stance_data
    scale = np.abs(d["lam"]).max()
    assert scale > 10.0
    np.testing.assert_allclose(d["eom_residual"], 0.0, atol=1e-10 * scale)


def test_stance_accelerations_match_the_pinned_lagrangian(stance_data):
    """Independent reduced model: hip position a function of the stance coordinates."""
    d = stance_data
    np.testing.assert_allclose(d["qdd_s"], d["qdd_pinned"], rtol=1e-9, atol=1e-9 * np.abs(d["qdd_s"]).max())


def test_ground_reaction_obeys_newton_for_the_centre_of_mass(stance_data):
    """m a_com = lambda + m g: the ground reaction is the only external force besides gravity."""
    d = stance_data
    m = oracles.FIVE_TOTAL_MASS
    np.testing.assert_allclose(m * d["com_acc"], d["lam"] + m * np.array([0.0, -G]), atol=1e-9 * np.abs(d["lam"]).max())
    np.testing.assert_allclose(d["grf"], d["lam"], atol=1e-12 * np.abs(d["lam"]).max())
    np.testing.assert_allclose(d["flow"][:, :5], d["qd"][:, 2:], atol=0)
    np.testing.assert_allclose(d["flow"][:, 5:], d["qdd_s"], atol=1e-12 * np.abs(d["qdd_s"]).max())


def test_balanced_at_rest_the_ground_carries_the_weight(st):
    """With the centre of mass right above the toe and no motion, some torques hold the robot
    still (qdd = 0: 5 equations, 4 inputs, consistent only when balanced), and then the ground
    reaction is exactly the weight, with no horizontal force."""
    import scipy.optimize

    legs = np.array([-0.2, 0.3, 0.25, -0.1])
    com_x = lambda t: float(oracles.FIVE_LINK.com(_full(jnp.asarray(np.r_[t, legs])))[0])  # noqa: E731
    torso = scipy.optimize.brentq(com_x, -1.2, 1.2, xtol=1e-15)
    z = jnp.asarray(np.r_[torso, legs, np.zeros(5)])
    a, b, la, lb = (np.asarray(v) for v in stm.stance_affine(st, z))
    u, *_ = np.linalg.lstsq(b, -a, rcond=None)
    np.testing.assert_allclose(a + b @ u, 0.0, atol=1e-9)
    np.testing.assert_allclose(la + lb @ u, [0.0, oracles.FIVE_TOTAL_MASS * G], rtol=1e-10, atol=1e-9)
    # off balance, no torques can hold it: the torso term of the residual does not vanish
    z_off = z.at[0].add(0.1)
    a, b, _, _ = (np.asarray(v) for v in stm.stance_affine(st, z_off))
    u, *_ = np.linalg.lstsq(b, -a, rcond=None)
    assert np.abs(a + b @ u).max() > 0.1


# ---- impact ------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def impact_data(st, states):
    z, _ = states
    model = st.model
    L = oracles.FIVE_LINK
    perm = np.asarray(five_link.LEG_SWAP)

    def one(z):
        q, qd = stm.embed(st, z)
        p = oracles.five_link_foot(q, 1)  # the impact point (new stance toe)
        z_plus, impulse, step, lift = stm.impact(st, z)
        qdp_ref, impulse_ref = mech.impact_map(model, q, qd, "foot_2")
        qn, qdn = stm.embed(st, z_plus)
        J2 = jax.jacfwd(oracles.five_link_foot)(q, 1)
        return dict(
            p=p, step=step, impulse=impulse, impulse_ref=impulse_ref, lift=lift,
            lift_ref=jax.jacfwd(oracles.five_link_foot)(q, 0) @ qdp_ref,
            swing_foot_vel_plus=J2 @ qdp_ref,
            # after relabelling: full state with the new stance toe at the origin
            qn=qn, qdn=qdn, qn_expected=q[perm], qdn_expected=qdp_ref[perm],
            coms_minus=oracles.five_link_coms(q), coms_plus=oracles.five_link_coms(qn),
            new_stance_vel=jax.jacfwd(oracles.five_link_foot)(qn, 0) @ qdn,
            new_swing_vel=jax.jacfwd(oracles.five_link_foot)(qn, 1) @ qdn,
            L_minus=mech.angular_momentum(model, q, qd, p), L_plus=mech.angular_momentum(model, qn, qdn, jnp.zeros(2)),
            L_minus_ref=L.angular_momentum(q, qd, p), L_plus_ref=L.angular_momentum(qn, qdn, jnp.zeros(2)),
            T_minus=mech.kinetic_energy(model, q, qd), T_plus=mech.kinetic_energy(model, qn, qdn),
            T_loss_ref=0.5 * (qd - qdp_ref) @ L.mass_matrix(q) @ (qd - qdp_ref),
            impulse_residual=L.mass_matrix(q) @ (qdp_ref - qd) - J2.T @ impulse,
        )

    return {k: np.asarray(v) for k, v in jax.jit(jax.vmap(one))(z).items()}


def test_impact_returns_the_step_the_impulse_and_the_lift_off_velocity(impact_data):
    d = impact_data
    np.testing.assert_allclose(d["step"], d["p"], atol=1e-14)
    np.testing.assert_allclose(d["impulse"], d["impulse_ref"], rtol=1e-12, atol=1e-12)
    scale = np.abs(d["impulse"]).max()
    np.testing.assert_allclose(d["impulse_residual"], 0.0, atol=1e-10 * scale)
    np.testing.assert_allclose(d["lift"], d["lift_ref"], atol=1e-11)


def test_relabelled_state_is_the_same_body_shifted_to_the_new_toe(impact_data):
    """The legs swap roles and the origin moves to the impact point; nothing moves physically."""
    d = impact_data
    swap_bodies = [0, 3, 4, 1, 2]  # torso, thigh_1, shin_1, thigh_2, shin_2 -> swapped legs
    np.testing.assert_allclose(d["coms_plus"], d["coms_minus"][:, swap_bodies] - d["p"][:, None, :], atol=1e-13)
    np.testing.assert_allclose(d["qn"][:, 2:], d["qn_expected"][:, 2:], atol=0)
    np.testing.assert_allclose(d["qdn"], d["qdn_expected"], atol=1e-11)


def test_new_stance_foot_stops_and_old_one_moves_with_the_lift_velocity(impact_data):
    d = impact_data
    np.testing.assert_allclose(d["swing_foot_vel_plus"], 0.0, atol=1e-12)
    np.testing.assert_allclose(d["new_stance_vel"], 0.0, atol=1e-11)
    np.testing.assert_allclose(d["new_swing_vel"], d["lift"], atol=1e-11)


def test_angular_momentum_about_the_new_toe_is_conserved(impact_data):
    d = impact_data
    assert np.abs(d["L_minus"]).max() > 1.0
    np.testing.assert_allclose(d["L_plus"], d["L_minus"], rtol=1e-10, atol=1e-11)
    np.testing.assert_allclose(d["L_plus_ref"], d["L_minus_ref"], rtol=1e-10, atol=1e-11)
    np.testing.assert_allclose(d["L_minus"], d["L_minus_ref"], rtol=1e-12)


def test_kinetic_energy_never_increases(impact_data):
    d = impact_data
    assert np.all(d["T_plus"] <= d["T_minus"] + 1e-12)
    assert np.all(d["T_loss_ref"] > 0)
    # the loss is exactly the energy of the velocity jump (plastic impact)
    np.testing.assert_allclose(d["T_minus"] - d["T_plus"], d["T_loss_ref"], rtol=1e-9, atol=1e-11)


def test_shipped_touchdown_is_a_valid_impact(impact_data):
    """At the shipped fixed point the ground pushes up, inside the friction cone, and the old
    stance foot lifts off."""
    d = impact_data
    Fx, Fy = d["impulse"][0]
    assert Fy > 0 and abs(Fx) <= 0.6 * Fy + 1e-9
    assert d["lift"][0, 1] > -1e-9


def test_pinned_terms_match_the_lagrangian_at_the_embedded_state(st, states):
    """One kinematic pass at the base's origin gives the full state's M, bias, J and Jdot qd
    (translation invariance), checked against the independent Lagrangian and autodiff."""
    L = oracles.FIVE_LINK
    foot = lambda q: oracles.five_link_foot(q, 0)  # noqa: E731

    def one(z):
        q, qd = stm.embed(st, z)
        M, h, J, jd = stm.pinned_terms(st, z)
        Jd = jax.jvp(jax.jacfwd(foot), (q,), (qd,))[1] @ qd
        return dict(M=M - L.mass_matrix(q), h=h - L.bias(q, qd), J=J - jax.jacfwd(foot)(q), jd=jd - Jd,
                    scale_M=jnp.max(jnp.abs(L.mass_matrix(q))), scale_h=jnp.max(jnp.abs(L.bias(q, qd))))

    d = {k: np.asarray(v) for k, v in jax.jit(jax.vmap(one))(states[0]).items()}
    assert np.max(np.abs(d["M"])) <= 1e-12 * np.max(d["scale_M"])
    assert np.max(np.abs(d["h"])) <= 1e-11 * np.max(d["scale_h"])
    np.testing.assert_allclose(d["J"], 0.0, atol=1e-14)
    np.testing.assert_allclose(d["jd"], 0.0, atol=1e-11)
