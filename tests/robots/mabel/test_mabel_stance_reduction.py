"""MABEL's walking model, reduced forms: the stance terms (D_s, H_s, B_s) of eqs. (11)-(12)
against the constrained 9-DoF dynamics, the impact scaling eta of Section VI-B, and the
unilateral spring's hard-stop damping (eq. 30)."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import bipedlab  # noqa: F401
from bipedlab.mechanics import coupled as cp
from bipedlab.robots.mabel import tables as tb
from bipedlab.robots.mabel.walking import stance as w

from .test_mabel_walking import _z

E = {c: i for i, c in enumerate(w.COORDS_9)}


def _pre_impact():
    """The shipped nominal gait's pre-impact stance state (swing toe on the ground,
    descending)."""
    from bipedlab.robots.mabel.walking import study as wm

    return jnp.asarray(wm.load_gait("nominal")[2]["z_minus"], float)


@pytest.fixture(scope="module")
def m():
    return w.walking_model()


@pytest.fixture(scope="module")
def flow(m):
    return jax.jit(lambda z, u, f: w.stance_flow(m, z, u, f))


@pytest.fixture(scope="module")
def terms(m):
    return jax.jit(lambda qs, qds, f: w.stance_terms(m, qs, qds, f))


@pytest.fixture(scope="module")
def impact(m):
    return jax.jit(lambda z, eta: w.impact(m, z, eta))


@pytest.mark.parametrize("seed", [0, 3])
def test_stance_terms_reproduce_the_constrained_accelerations(seed, flow, terms):
    """D_s qdd_s + H_s = B_s u with qdd_s from the 9-DoF constrained dynamics (the constraint
    forces drop out of the reduction), torques and a hip push included."""
    z = _z(seed)
    rng = np.random.default_rng(10 + seed)
    u = jnp.asarray(rng.uniform(-5.0, 5.0, 4))
    f = jnp.asarray([40.0, -15.0])
    qdd = np.asarray(flow(z, u, f))[6:]
    D, H, B = (np.asarray(a) for a in terms(z[:6], z[6:], f))
    # symmetric positive definite reduced inertia
    assert np.allclose(D, D.T, rtol=1e-12, atol=1e-12)
    assert np.all(np.linalg.eigvalsh(D) > 0)
    qdd_terms = np.linalg.solve(D, B @ np.asarray(u) - H)
    assert np.max(np.abs(qdd_terms - qdd)) <= 1e-9 * np.max(np.abs(qdd))
    # the residual of eq. 12 with the flow's accelerations
    res = D @ qdd + H - B @ np.asarray(u)
    assert np.max(np.abs(res)) <= 1e-9 * max(np.max(np.abs(H)), 1.0)


def test_stance_terms_input_matrix_is_the_drive_and_the_push_enters_H(terms, flow):
    """B_s does not depend on the hip force (it is affine in u); the push changes only H_s,
    and by the generalised force J_hip^T f pulled back to q_s: the flow's acceleration change
    solves D_s dqdd = -(H_s(f) - H_s(0))."""
    z = _z(5)
    f = jnp.asarray([78.0, 0.0])
    D0, H0, B0 = (np.asarray(a) for a in terms(z[:6], z[6:], jnp.zeros(2)))
    D1, H1, B1 = (np.asarray(a) for a in terms(z[:6], z[6:], f))
    assert np.allclose(B0, B1, rtol=1e-12, atol=1e-12) and np.allclose(D0, D1, rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(H1 - H0)) > 1.0  # a 78 N push is felt
    u = jnp.zeros(4)
    dq = np.asarray(flow(z, u, f))[6:] - np.asarray(flow(z, u, jnp.zeros(2)))[6:]
    assert dq == pytest.approx(np.linalg.solve(D0, -(H1 - H0)), rel=1e-8, abs=1e-9)


def test_impact_scaling_divides_the_post_impact_velocity(impact):
    """eta scales the rigid post-impact velocity: qd+ (eta) = qd+ (1) / eta, same positions."""
    zm = _pre_impact()
    t1, t97 = impact(zm, 1.0), impact(zm, 0.97)
    z1, z97 = np.asarray(t1.z_plus), np.asarray(t97.z_plus)
    assert z97[:6] == pytest.approx(z1[:6], rel=1e-14, abs=1e-14)
    assert z97[6:] == pytest.approx(z1[6:] / 0.97, rel=1e-12, abs=1e-13)
    assert np.asarray(t97.step) == pytest.approx(np.asarray(t1.step), abs=1e-14)
    assert np.asarray(t97.lift_velocity) == pytest.approx(np.asarray(t1.lift_velocity) / 0.97, rel=1e-12, abs=1e-13)


@pytest.mark.parametrize("eta", [1.0, 0.97])
def test_impact_satisfies_the_constraints_and_the_impulse_balance(m, impact, eta):
    """Eqs. (16)-(18): after impact the new stance toe (old swing toe) is at rest and the old
    stance spring does not move, and D (qd+ - qd-) = J_toe^T F + e_bsp tau for the rigid map
    (eta = 1); the swing spring of the new stance (the old stance spring) is put at rest."""
    zm = _pre_impact()
    tr = impact(zm, eta)
    q, qd_minus = w.embed(m, zm)
    # post-impact velocities in the old labelling: the embedding of z+ pins the new stance
    # toe, so its hip velocity is the one the impact produced
    _, qd_new = w.embed(m, tr.z_plus)
    qd_plus = qd_new[np.asarray(w.SWAP)]
    Jt = cp.point_jacobian(m.body, q, "toe_R")
    assert np.asarray(Jt @ qd_plus) == pytest.approx([0.0, 0.0], abs=1e-12)
    assert float(qd_plus[E["bsp_L"]]) == pytest.approx(0.0, abs=1e-14)
    D = cp.mass_matrix(m.body, q)
    lhs = np.asarray(D @ (eta * qd_plus - qd_minus))
    gen = np.asarray(Jt.T @ tr.toe_impulse) + np.eye(9)[E["bsp_L"]] * float(tr.spring_impulse)
    assert lhs == pytest.approx(gen, abs=1e-10 * np.max(np.abs(lhs)))
    # the ground pushes up on the landing toe
    assert float(tr.toe_impulse[1]) > 0.0
    # the pre-impact swing toe is the new stance toe: the step vector is its position
    assert np.asarray(tr.step) == pytest.approx(np.asarray(cp.point_position(m.body, q, "toe_R")), abs=1e-14)


def test_impact_post_state_is_at_the_new_stance_toe(m, impact):
    """The relabelled post-impact state, embedded, has the new stance toe at the origin with
    zero velocity and the new swing spring (old stance spring, set back on its stop) at zero."""
    zp = impact(_pre_impact(), 0.97).z_plus
    q, qd = w.embed(m, zp)
    assert np.asarray(cp.point_jacobian(m.body, q, "toe_L") @ qd) == pytest.approx([0, 0], abs=1e-12)
    assert float(q[E["bsp_R"]]) == 0.0 and float(qd[E["bsp_R"]]) == 0.0


def test_old_stance_spring_deflection_is_taken_up_by_the_motor(impact):
    """T_mLS: the old stance leg keeps its shape q_LS = q_mLS/G_LS + q_Bsp/G_Bsp (eq. 1), so the
    new swing motor leg shape is the old stance one plus (G_LS / G_Bsp) q_Bsp-."""
    zm = _pre_impact()
    zp = np.asarray(impact(zm, 1.0).z_plus)
    assert zp[4] == pytest.approx(float(zm[1]) + tb.GEAR_LS / tb.GEAR_BSP * float(zm[2]), rel=1e-14)
    # and the old swing leg angle becomes the stance one, unchanged by the impact
    assert zp[0] == pytest.approx(float(zm[3]), rel=1e-14)
    assert zp[5] == pytest.approx(float(zm[5]), rel=1e-14)


def test_spring_leaving_the_stop_feels_only_its_damping(m):
    """At b = 0 moving outward (bd > 0), no hard-stop damping: tau = -K_B*0 - Kd_B bd."""
    kd_b = float(m.drive.spring_d)
    assert kd_b > 0
    for leg in (0, 1):
        for bd in (0.1, 2.0):
            tau = float(w.spring_torque(m, jnp.asarray(0.0), jnp.asarray(bd), leg))
            assert tau == pytest.approx(-kd_b * bd, rel=1e-14)
    # also below the stop but leaving it: spring law (with the cubic stiffening) and Kd_B only
    b, bd = -0.01, 0.5
    k = float(m.drive.spring_k[0])
    tau = float(w.spring_torque(m, jnp.asarray(b), jnp.asarray(bd), 0))
    assert tau == pytest.approx(-k * b - tb.HARD_STOP["kd1"] * b**3 - kd_b * bd, rel=1e-13)


def test_spring_pressing_into_the_stop_is_damped_by_the_stop(m):
    """b < 0 closing (bd < 0): the stop's damper of eq. 30, K_vd1 |bd| + K_vd2 sqrt|bd| opposing
    the motion, instead of the spring's Kd_B."""
    b, bd = -0.01, -0.4
    k, kd_b = float(m.drive.spring_k[1]), float(m.drive.spring_d)
    hs = tb.HARD_STOP
    tau = float(w.spring_torque(m, jnp.asarray(b), jnp.asarray(bd), 1))
    expected = -k * b - hs["kd1"] * b**3 + hs["kvd1"] * abs(bd) + hs["kvd2"] * np.sqrt(abs(bd))
    assert tau == pytest.approx(expected, rel=1e-13)
    assert tau != pytest.approx(-k * b - hs["kd1"] * b**3 - kd_b * bd, rel=1e-3)
    # dissipative: the damping part does negative power
    assert (tau - (-k * b - hs["kd1"] * b**3)) * bd < 0
    # at b = 0 exactly, closing: the stop damps as well
    tau0 = float(w.spring_torque(m, jnp.asarray(0.0), jnp.asarray(bd), 1))
    assert tau0 == pytest.approx(hs["kvd1"] * abs(bd) + hs["kvd2"] * np.sqrt(abs(bd)), rel=1e-13)
    # compressed (b > 0) the spring's own damping acts whatever the direction
    for v in (-0.4, 0.4):
        t = float(w.spring_torque(m, jnp.asarray(0.05), jnp.asarray(v), 1))
        assert t == pytest.approx(-k * 0.05 - kd_b * v, rel=1e-13)
