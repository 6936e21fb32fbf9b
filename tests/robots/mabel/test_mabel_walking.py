"""MABEL's walking model (compliant HZD paper, Section II-B): stance constraints, lossless
stance energy, and the stance-to-stance transition map (eqs. 14-20)."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import bipedlab  # noqa: F401
from bipedlab.mechanics import coupled as cp
from bipedlab.robots.mabel import dynamics as md
from bipedlab.robots.mabel import tables as tb
from bipedlab.robots.mabel import transmission as tr
from bipedlab.robots.mabel.walking import stance as w

E = {c: i for i, c in enumerate(w.COORDS_9)}


def _z(seed=0):
    rng = np.random.default_rng(seed)
    qs = np.array([np.pi + 0.15, 31.42 * 0.25, 0.05, np.pi - 0.25, 31.42 * 0.35, 0.05]) + 0.02 * rng.standard_normal(6)
    qds = np.array([0.5, 2.0, 0.3, -1.0, 5.0, 0.2]) * (1 + 0.2 * rng.standard_normal(6))
    return jnp.asarray(np.concatenate([qs, qds]))


@pytest.fixture(scope="module")
def m():
    return w.walking_model()


def test_embedding_pins_the_stance_toe_and_the_swing_spring(m):
    """Upsilon_s: stance toe at the origin with zero velocity, swing spring at rest; Pi_s
    inverts it."""
    z = _z()
    q, qd = w.embed(m, z)
    assert np.asarray(cp.point_position(m.body, q, "toe_L")) == pytest.approx([0, 0], abs=1e-14)
    assert np.asarray(cp.point_jacobian(m.body, q, "toe_L") @ qd) == pytest.approx([0, 0], abs=1e-13)
    assert float(q[E["bsp_R"]]) == 0.0 and float(qd[E["bsp_R"]]) == 0.0
    assert np.asarray(w.reduce(q, qd)) == pytest.approx(np.asarray(z), abs=1e-15)


def test_relabelling_swaps_the_legs():
    s = np.asarray(w.SWAP)
    assert list(s[s]) == list(range(9))
    names = [w.COORDS_9[i] for i in s]
    assert names[E["la_L"]] == "la_R" and names[E["mls_R"]] == "mls_L" and names[E["tor"]] == "tor"


def test_constrained_accelerations_keep_the_toe_fixed(m):
    """G qdd + Gdot qd = 0: the stance toe does not accelerate, the swing spring stays."""
    z = _z(1)
    q, qd = w.embed(m, z)
    u = jnp.asarray([1.0, -3.0, 0.5, 2.0])
    qdd, lam = w.constrained(m, q, qd, u)
    J = cp.point_jacobian(m.body, q, "toe_L")
    jdot = jax.jvp(lambda q: cp.point_jacobian(m.body, q, "toe_L") @ qd, (q,), (qd,))[1]
    assert np.asarray(J @ qdd + jdot) == pytest.approx([0, 0], abs=1e-9)
    assert float(qdd[E["bsp_R"]]) == pytest.approx(0.0, abs=1e-9)
    # the stance flow is these accelerations in stance coordinates
    zd = np.asarray(w.stance_flow(m, z, u))
    assert zd[6:] == pytest.approx(np.asarray(qdd)[w._S], rel=1e-12, abs=1e-9)


def test_lossless_stance_conserves_energy(m):
    """No friction, no spring damping, u = 0: the pinned-toe dynamics conserve the energy of
    links, boom and the stance spring (RK4, 4th order)."""
    d = m.drive
    z0 = jnp.zeros(())
    m0 = m.replace(drive=d.replace(friction=0 * d.friction, spring_d=z0, kvd1=z0, kvd2=z0))
    z = _z(2)
    f = lambda z: w.stance_flow(m0, z, jnp.zeros(4))  # noqa: E731

    def energy(z):
        q, qd = w.embed(m0, z)
        return md.energy(m0, jnp.concatenate([q, qd, jnp.zeros(2)]))

    def run(h, n):
        def body(z, _):
            k1 = f(z); k2 = f(z + 0.5 * h * k1); k3 = f(z + 0.5 * h * k2); k4 = f(z + h * k3)  # noqa: E702
            z = z + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            return z, energy(z)
        return np.asarray(jax.jit(lambda z: jax.lax.scan(body, z, None, length=n)[1])(z))

    e0 = float(energy(z))
    drift = np.abs(run(1e-3, 60) - e0).max()
    drift_fine = np.abs(run(5e-4, 120) - e0).max()
    assert drift < 1e-5 * abs(e0)
    assert drift_fine < drift / 8 or drift_fine < 1e-10 * abs(e0)


def test_impact_map_constraints_and_dissipation(m):
    """Eqs. (16)-(18): after impact the new stance toe and the old stance spring are at rest,
    the impulses balance the momentum jump, kinetic energy does not increase; T_mLS keeps the
    old stance leg's shape; the old stance toe lifts off."""
    z = _z(3)
    q, qd = w.embed(m, z)
    t = w.impact(m, z)
    swap = np.asarray(w.SWAP)
    D = np.asarray(cp.mass_matrix(m.body, q))
    Jt = np.asarray(cp.point_jacobian(m.body, q, "toe_R"))
    A = np.vstack([Jt, np.eye(9)[E["bsp_L"]]])
    # the post-impact velocity solves the KKT system of (16)-(18); solve it independently
    K = np.block([[D, -A.T], [A, np.zeros((3, 3))]])
    sol = np.linalg.solve(K, np.concatenate([D @ np.asarray(qd), np.zeros(3)]))
    v = sol[:9]
    assert Jt @ v == pytest.approx([0, 0], abs=1e-10)
    assert v[E["bsp_L"]] == pytest.approx(0.0, abs=1e-12)
    assert D @ (v - np.asarray(qd)) == pytest.approx(A.T @ sol[9:], abs=1e-9)
    assert np.asarray(t.toe_impulse) == pytest.approx(sol[9:11])
    assert 0.5 * v @ D @ v <= 0.5 * np.asarray(qd) @ D @ np.asarray(qd) + 1e-12
    # the stance-coordinate velocities of z_plus are v relabelled
    assert np.asarray(t.z_plus)[6:] == pytest.approx(v[swap][w._S], abs=1e-10)
    # T_mLS: old stance spring at rest, same leg shape
    ls_before = float(tr.leg_shape(q[E["mls_L"]], q[E["bsp_L"]]))
    new_swing_mls, new_swing_bsp = float(t.z_plus[w.STANCE.index("mls_R")]), 0.0
    assert float(tr.leg_shape(new_swing_mls, new_swing_bsp)) == pytest.approx(ls_before, abs=1e-12)
    assert float(t.z_plus[w.STANCE.index("la_L")]) == pytest.approx(float(q[E["la_R"]]))
    assert float(t.lift_velocity[1]) > 0.0
    assert tb.GEAR_LS / tb.GEAR_BSP == pytest.approx(6.0656, rel=1e-4)


def test_paper_coordinate_orders():
    """q_h (identification paper, VIII-A) and q_e (HZD paper, II-B1) orders."""
    from bipedlab.robots.mabel import model as mm

    h = mm.hopping_model()
    q = jnp.arange(13.0)
    out = np.asarray(mm.paper_order(h, q))
    assert [h.coord_names[int(i)] for i in out] == list(mm.PAPER_Q_H)
    e = mm.rigid_model()
    out = np.asarray(mm.paper_order(e, jnp.arange(9.0)))
    assert [e.coord_names[int(i)] for i in out] == list(mm.PAPER_Q_E)
