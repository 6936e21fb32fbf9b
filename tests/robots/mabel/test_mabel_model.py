"""MABEL's drivetrain and dynamic models (bipedlab.robots.mabel) against the published numbers
and against physics.

Sources: Park, Sreenath, Hurst & Grizzle, "Identification and dynamic model of a bipedal robot
with a cable-differential-based compliant drivetrain" (Tables IV-VIII, eqs. 1, 5-6, 23-30) and
Sreenath et al., "A compliant hybrid zero dynamics controller ... on MABEL" (eq. 1). Oracles:
the cable-differential equations written out with tables.RADII, energy conservation of the
lossless model under a 4th-order integrator, the instantaneous power balance dE/dt = power of
the non-conservative forces, d'Alembert's principle between the 13-DoF and 9-DoF models, and
static balance (COM over the toe; eq. 24 for a massless leg).
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.optimize import brentq

from bipedlab.mechanics import coupled as cp
from bipedlab.robots.mabel import dynamics as dy
from bipedlab.robots.mabel import model as mm
from bipedlab.robots.mabel import tables as tb
from bipedlab.robots.mabel import transmission as tr
from bipedlab.sim.integrators import rk4

G = 9.81
H13 = {c: i for i, c in enumerate(mm.COORDS_13)}
I9 = {c: i for i, c in enumerate(mm.COORDS_9)}
LOC = {c: i for i, c in enumerate(tr.LOCAL)}


@pytest.fixture(scope="module")
def models():
    return mm.hopping_model(), mm.rigid_model()


def _lossless(m):
    """Every non-conservative drivetrain term off: motor friction and amplifier bias, cable
    damping, spring damping and both hard-stop dampers."""
    d = m.drive
    z = jnp.zeros_like
    return m.replace(drive=d.replace(friction=z(d.friction), bias=z(d.bias), cable_d=z(d.cable_d),
                                     spring_d=z(d.spring_d), kvd1=z(d.kvd1), kvd2=z(d.kvd2)))


def _airborne_state(m):
    """Hip 1.3 m up, legs near hanging (la = pi -+ 0.2, ls = 0.2), left spring compressed
    (bsp = +0.03, on the spring), right one at the hard stop (bsp = -0.02), motors off their
    rigid values so both cables are stretched, and some velocity in every coordinate."""
    q = np.zeros(13)
    q[H13["x"]], q[H13["y"]], q[H13["tor"]] = 0.1, 1.3, 0.05
    for s, la, bsp in (("L", np.pi - 0.2, 0.03), ("R", np.pi + 0.2, -0.02)):
        q[H13[f"la_{s}"]], q[H13[f"ls_{s}"]], q[H13[f"bsp_{s}"]] = la, 0.2, bsp
        mla, mls = tr.rigid_motor_angles(la, 0.2, bsp)
        q[H13[f"mla_{s}"]], q[H13[f"mls_{s}"]] = mla + 0.05, mls - 0.04
    qd = np.array([0.3, 0.5, -0.4, 1.0, -0.5, -0.8, 0.6, 0.5, -0.3, -20.0, 10.0, 15.0, -12.0])
    if m.n == 9:  # the closest rigid-cable state
        E = mm.rigid_map()
        q, qd = (np.linalg.lstsq(E, a, rcond=None)[0] for a in (q, qd))
    return jnp.concatenate([jnp.asarray(q), jnp.asarray(qd), jnp.zeros(2)])


# ----- transmission ------------------------------------------------------------------------
def _pulleys(local):
    """Angles (relative to the torso) of every pulley for local coordinates (la, ls, bsp, mla, mls)."""
    return {k: float(np.dot(v, local)) for k, v in tr.pulley_rates().items()}


def test_cable_differentials_with_rigid_cables():
    """Each cable differential obeys r_A A + r_B B = (r_A + r_B) C (thigh: C = la + ls;
    shin: C = la - ls; spring: C = C_sp with inputs A_sp, B_sp), with B_thigh = B_shin driven
    by the leg-angle motor; MABEL's equal radii make this (A + B)/2 = C, hence B = 2 q_LA,
    C_sp = 2 q_LS. Eq. 1: q_LA = (C_th + C_sh)/2, q_LS = (C_th - C_sh)/2, checked on the
    model's own tree map. Each idler obeys A - B + r_D (1/r_A + 1/r_B) D = 0."""
    r = tb.RADII
    rng = np.random.default_rng(0)
    T = np.asarray(mm.hopping_model().body.T)
    lk = tr.linkage_rates()
    for _ in range(5):
        la, ls, bsp = rng.uniform(-3, 3), rng.uniform(-1, 1), rng.uniform(-0.5, 0.5)
        local = np.array([la, ls, bsp, rng.normal(), rng.normal()])
        p = _pulleys(local)
        c_th, c_sh = la + ls, la - ls
        assert r["Ath"] * p["Ath"] + r["Bth"] * p["Bth"] == pytest.approx((r["Ath"] + r["Bth"]) * c_th, abs=1e-12)
        assert r["Ash"] * p["Ash"] + r["Bsh"] * p["Bsh"] == pytest.approx((r["Ash"] + r["Bsh"]) * c_sh, abs=1e-12)
        assert p["Bth"] == p["Bsh"]
        assert (p["Ath"] + p["Bth"]) / 2 == pytest.approx(c_th, abs=1e-12)  # equal radii
        assert (p["Ash"] + p["Bsh"]) / 2 == pytest.approx(c_sh, abs=1e-12)
        assert p["Bth"] == pytest.approx(2 * la, abs=1e-12)
        c_sp = float(np.dot(lk["Csp"], local))
        assert c_sp == pytest.approx(2 * ls, abs=1e-12)
        assert r["Asp"] * p["Asp"] + r["Bsp"] * p["Bsp"] == pytest.approx((r["Asp"] + r["Bsp"]) * c_sp, abs=1e-12)
        assert p["Bsp"] == bsp
        for d, a, b in (("th", "Ath", "Bth"), ("sh", "Ash", "Bsh"), ("sp", "Asp", "Bsp")):
            D = p[f"D{d}"]
            assert p[a] - p[b] + r[f"D{d}"] * (1 / r[a] + 1 / r[b]) * D == pytest.approx(0.0, abs=1e-12)
        # eq. 1 through the model's tree map (left leg rows: thigh, shin-rel-thigh, csp, csh)
        qh = np.zeros(13)
        qh[[H13["la_L"], H13["ls_L"], H13["bsp_L"], H13["mla_L"], H13["mls_L"]]] = local
        thigh, knee, csp, csh = (T @ qh)[3:7]
        C_th, C_sh = thigh, thigh + knee
        assert ((C_th + C_sh) / 2, (C_th - C_sh) / 2) == pytest.approx((la, ls), abs=1e-12)
        assert csh == pytest.approx(C_sh, abs=1e-12) and csp == pytest.approx(c_sp, abs=1e-12)


def test_model_rotor_rates_are_the_pulley_rates(models):
    """Every rotor of the 13-DoF body turns at the torso rate plus its pulley rate relative to
    the torso; the boom turns at (xd, yd) / R."""
    body = models[0].body
    R = np.asarray(body.R)
    rates = tr.pulley_rates()
    for k, name in enumerate(body.rotor_names):
        row = R[k]
        if name.startswith("boom"):
            expect = np.zeros(13)
            expect[H13["x" if name == "boom_yaw" else "y"]] = 1.0 / tb.BOOM["radius"]
        else:
            pulley, s = name.rsplit("_", 1)
            expect = np.zeros(13)
            expect[H13["tor"]] = 1.0
            for c, i in LOC.items():
                expect[H13[f"{c}_{s}"]] += rates[pulley][i]
        np.testing.assert_allclose(row, expect, atol=1e-15)
    assert len(body.rotor_names) == 2 * len(rates) + 2


def test_gear_ratios_and_cable_stretch():
    """Eqs. 5-6 / HZD eq. 1: q_mLA = -23.53 q_LA and q_LS = 0.0318 q_mLS + 0.193 q_Bsp (to
    1e-3 relative); rigid_map encodes the same relations; cable_stretch vanishes on them and
    is the motor's offset from them (linear). The spring differential's static torque ratio
    (r_Asp + r_Bsp)/r_Bsp is eq. 23's 2.59061 within 0.5 %, and the radii alone give the
    drivetrain ratios quoted in transmission.py (-25.21, 31.58, 6.08)."""
    la = np.linspace(-2.0, 4.0, 7)
    mla, _ = tr.rigid_motor_angles(la, 0.0, 0.0)
    np.testing.assert_allclose(mla, -23.53 * la, rtol=1e-15)
    a = float(tr.leg_shape(1.0, 0.0))
    b = float(tr.leg_shape(0.0, 1.0))
    assert a == pytest.approx(0.0318, rel=1e-3) and b == pytest.approx(0.193, rel=1e-3)
    assert float(tr.leg_shape(2.0, -3.0)) == pytest.approx(2 * a - 3 * b, rel=1e-14)  # linear

    rng = np.random.default_rng(1)
    E = mm.rigid_map()
    for _ in range(5):
        la, ls, bsp = rng.uniform(-3, 3), rng.uniform(-1, 1), rng.uniform(-0.5, 0.5)
        mla_r, mls_r = tr.rigid_motor_angles(la, ls, bsp)
        assert float(tr.leg_shape(mls_r, bsp)) == pytest.approx(ls, abs=1e-13)
        lam = tr.cable_stretch(la, ls, bsp, mla_r, mls_r)
        assert abs(float(lam[0])) < 1e-12 and abs(float(lam[1])) < 1e-12
        d1, d2 = rng.normal(size=2)
        lam = tr.cable_stretch(la, ls, bsp, mla_r + d1, mls_r + d2)
        assert (float(lam[0]), float(lam[1])) == pytest.approx((d1, d2), abs=1e-12)
        # off the rigid relation through the joint side: lambda_LA = q_mLA + 23.53 q_LA etc.
        lam = tr.cable_stretch(la + 0.1, ls + 0.01, bsp + 0.2, mla_r, mls_r)
        assert float(lam[0]) == pytest.approx(23.53 * 0.1, rel=1e-12)
        assert float(lam[1]) == pytest.approx(-31.42 * 0.01 + 31.42 / 5.18 * 0.2, rel=1e-12)
        # rigid_map: every 9-DoF state is a rigid-cable 13-DoF state
        qh = E @ rng.normal(size=9)
        for s in tb.SIDES:
            lam = tr.cable_stretch(*(qh[H13[f"{c}_{s}"]] for c in tr.LOCAL))
            assert abs(float(lam[0])) < 1e-12 and abs(float(lam[1])) < 1e-12

    r = tb.RADII
    assert (r["Asp"] + r["Bsp"]) / r["Bsp"] == pytest.approx(2.59061, rel=5e-3)
    la_ratio = 2.0 / ((r["LAsd_small"] / r["Bth"]) * (r["m"] / r["LAsd_big"]))
    a_sp = (r["LSsd_small"] / r["Asp"]) * (r["m"] / r["LSsd_big"])  # A_sp per rad of mLS
    ls_ratio = 2.0 * (r["Asp"] + r["Bsp"]) / (r["Asp"] * a_sp)
    bsp_ratio = 2.0 * (r["Asp"] + r["Bsp"]) / r["Bsp"]
    assert la_ratio == pytest.approx(25.21, rel=1e-3)
    assert ls_ratio == pytest.approx(31.58, rel=1e-3)
    assert ls_ratio / bsp_ratio == pytest.approx(6.08, rel=1e-3)


def test_spring_law_eq30():
    """Eq. 30 on B_spring: elastic part -K_B q (q > 0), -K_B q - K_d1 q^3 (q <= 0) is
    continuous with a continuous slope at q = 0 (finite differences) and equals -dV/dq of
    spring_potential (autodiff); the dissipative part -Kd_B qd (q > 0), -K_vd1 qd - [qd < 0]
    K_vd2 sqrt|qd| sign(qd) (q <= 0) never delivers power, is continuous in qd at 0 within
    each branch, and equals -c qd with spring_damping_coefficient's c; spring_torque is
    their sum."""
    k, d, kd1, kvd1, kvd2 = tb.SPRING_K["L"], tb.SPRING_DAMPING, tb.HARD_STOP["kd1"], tb.HARD_STOP["kvd1"], tb.HARD_STOP["kvd2"]
    qs = np.concatenate([np.linspace(-0.4, 0.6, 41), [-1e-9, 0.0, 1e-9]])
    qds = np.concatenate([np.linspace(-5, 5, 41), [-1e-6, 1e-6]])
    Q, QD = (a.ravel() for a in np.meshgrid(qs, qds, indexing="ij"))

    el = np.asarray(tr.spring_elastic(k, kd1, jnp.asarray(Q)))
    np.testing.assert_allclose(el, np.where(Q > 0, -k * Q, -k * Q - kd1 * Q**3), rtol=1e-15, atol=1e-300)
    dV = np.asarray(jax.vmap(jax.grad(lambda q: tr.spring_potential(k, kd1, q)))(jnp.asarray(Q)))
    np.testing.assert_allclose(el, -dV, rtol=1e-13, atol=1e-15)
    eps = 1e-7
    f = lambda q: float(tr.spring_elastic(k, kd1, q))  # noqa: E731
    assert abs(f(eps) - f(-eps)) < 3 * k * eps
    assert (f(eps) - f(0.0)) / eps == pytest.approx(-k, rel=1e-6)
    assert (f(0.0) - f(-eps)) / eps == pytest.approx(-k, rel=1e-6)
    Vf = lambda q: float(tr.spring_potential(k, kd1, q))  # noqa: E731
    assert Vf(0.0) == 0.0 and (Vf(eps) - Vf(-eps)) / (2 * eps) == pytest.approx(0.0, abs=1e-5)

    damp = np.asarray(tr.spring_damping_torque(d, kvd1, kvd2, jnp.asarray(Q), jnp.asarray(QD)))
    expect = np.where(Q > 0, -d * QD, -kvd1 * QD - np.where(QD < 0, kvd2 * np.sqrt(np.abs(QD)) * np.sign(QD), 0.0))
    np.testing.assert_allclose(damp, expect, rtol=1e-14, atol=1e-300)
    assert np.all(damp * QD <= 0.0)
    for q in (-0.1, 0.0, 0.2):
        for e in (1e-6, 1e-10):
            lo = float(tr.spring_damping_torque(d, kvd1, kvd2, q, -e))
            hi = float(tr.spring_damping_torque(d, kvd1, kvd2, q, e))
            bound = max(d, kvd1) * e + kvd2 * np.sqrt(e)
            assert abs(lo) <= bound and abs(hi) <= bound  # -> 0 as qd -> 0 from either side
        assert float(tr.spring_damping_torque(d, kvd1, kvd2, q, 0.0)) == 0.0

    big = np.abs(QD) > 1e-8
    c = np.asarray(tr.spring_damping_coefficient(d, kvd1, kvd2, jnp.asarray(Q), jnp.asarray(QD)))
    assert np.all(c >= 0.0)
    np.testing.assert_allclose((-c * QD)[big], damp[big], rtol=1e-12)
    tot = np.asarray(tr.spring_torque(k, d, kd1, kvd1, kvd2, jnp.asarray(Q), jnp.asarray(QD)))
    np.testing.assert_allclose(tot, el + damp, rtol=1e-15, atol=1e-300)


# ----- mass properties -----------------------------------------------------------------------
def test_mass_and_boom(models):
    """Table VII: the links weigh 57.66 kg (58 kg in the HZD paper); the boom adds
    I_boom / R^2 = 20.4951 / 2.25^2 = 4.05 kg to both hip translations (M[x,x] = M[y,y] =
    57.66 + 4.05, no x-y coupling, any configuration) and m_boom g r_com / R = 46.99 N of
    weight on y (the total vertical load is checked in test_static_balance_on_one_toe)."""
    full, rigid = models
    m_links = float(jnp.sum(full.body.tree.mass))
    assert m_links == pytest.approx(57.66, abs=5e-3)
    assert abs(m_links - 58.0) < 0.5
    m_boom = tb.BOOM["inertia"] / tb.BOOM["radius"] ** 2
    assert m_boom == pytest.approx(4.05, abs=5e-3)
    qs = np.random.default_rng(8).uniform(-3, 3, (4, 13))
    M = np.asarray(jax.jit(jax.vmap(cp.mass_matrix, (None, 0)))(full.body, jnp.asarray(qs)))
    np.testing.assert_allclose(M[:, 0, 0], m_links + m_boom, rtol=1e-13)
    np.testing.assert_allclose(M[:, 1, 1], m_links + m_boom, rtol=1e-13)
    assert np.all(np.abs(M[:, 0, 1]) < 1e-12)
    assert float(full.body.weight[1]) == pytest.approx(46.99, abs=5e-3)


# ----- dynamics ------------------------------------------------------------------------------
_RK4_C = jnp.array([0.0, 0.5, 0.5, 1.0])
_RK4_B = jnp.array([1.0, 2.0, 2.0, 1.0]) / 6.0


def _rk4_scan(f, x, u, h):
    """Classical RK4 (bipedlab.sim.integrators.rk4's tableau) with the stages in a scan, so
    the flow is traced and compiled once instead of four times."""
    def stage(carry, cb):
        k, acc = carry
        k = f(x + cb[0] * h * k, u)
        return (k, acc + cb[1] * k), None

    (_, acc), _ = jax.lax.scan(stage, (jnp.zeros_like(x), jnp.zeros_like(x)), jnp.stack([_RK4_C, _RK4_B], 1))
    return x + h * acc


@jax.jit
def _rk4_energy(m, x, h, nsub):
    """20 records of (energy, toe heights, bsp) every nsub RK4 steps of the exact flow, u = 0."""
    u = jnp.zeros(4)
    f = lambda x, u: dy.flow(m, x, u)  # noqa: E731
    Em = jnp.asarray(np.asarray(m.E))

    def rec(x, _):
        x = jax.lax.fori_loop(0, nsub, lambda i, x: _rk4_scan(f, x, u, h), x)
        qh = Em @ x[: m.n]
        return x, (dy.energy(m, x), dy.toe_positions(m, x[: m.n])[:, 1], qh[jnp.array([H13["bsp_L"], H13["bsp_R"]])])

    return jax.lax.scan(rec, x, None, length=20)[1]


def test_rk4_scan_is_rk4():
    """The scanned RK4 used below is bipedlab.sim.integrators.rk4 (same tableau)."""
    f = lambda x, u: jnp.stack([x[1], -jnp.sin(x[0]) + u * x[1] ** 2])  # noqa: E731
    x = jnp.array([0.7, -0.3])
    np.testing.assert_allclose(np.asarray(_rk4_scan(f, x, 0.2, 0.05)), np.asarray(rk4(f, x, 0.2, 0.05)), rtol=1e-15)


@pytest.mark.parametrize("variant", ["13", "9"])
def test_lossless_energy_conservation(models, variant):
    """With every damper, the motor friction and the amplifier bias off and the robot in the
    air (toes > 0.15 m up), u = 0, the mechanical energy (kinetic incl. rotors and boom,
    gravity incl. the boom's weight, spring and hard-stop, cable stretch) is conserved:
    RK4 on flow at h = 1e-4 for 0.2 s drifts < 1e-9 relative, and the drift is a truncation
    error of order >= 4 (halving h from 1e-3 divides it by >= 12) unless already at
    round-off. Stretched cables, the hard stop (bsp < 0) and the spring (bsp > 0) are all
    exercised: the undamped right spring bounces between them."""
    m = _lossless(models[0] if variant == "13" else models[1])
    x0 = _airborne_state(m)
    E0 = float(dy.energy(m, x0))
    drift = {}
    for h, nsub in ((1e-4, 100), (1e-3, 10), (5e-4, 20)):
        en, toes, bsp = (np.asarray(a) for a in _rk4_energy(m, x0, h, nsub))
        drift[h] = np.max(np.abs(en - E0))
        assert toes.min() > 0.15
        assert bsp[:, 1].min() < 0.0 < bsp[:, 1].max()  # right spring: stop and spring branch
    assert drift[1e-4] / abs(E0) < 1e-9
    roundoff = 1e-12 * abs(E0)
    assert drift[5e-4] < roundoff or drift[1e-3] / drift[5e-4] > 12.0, drift
    assert drift[1e-4] <= drift[5e-4] + roundoff


def _expected_power(m, x, u):
    """Power of the non-conservative forces, written from the tables: motor torque
    (u + b)/K_T and friction -mu qd_m on each motor, cable damping -Kd_C lambda_dot^2 with
    lambda_LA = q_mLA + 23.53 q_LA, lambda_LS = q_mLS - 31.42 q_LS + (31.42/5.18) q_Bsp, the
    spring/hard-stop damping of eq. 30 times qd_Bsp, and the ground force times the toe
    velocity."""
    d = m.drive
    n = m.n
    Em = jnp.asarray(np.asarray(m.E))
    qh, qdh = Em @ x[:n], Em @ x[n:2 * n]
    P = 0.0
    for k, s in enumerate(tb.SIDES):
        for a, c in ((2 * k, f"mla_{s}"), (2 * k + 1, f"mls_{s}")):
            w = qdh[H13[c]]
            P = P + ((u[a] + d.bias[a]) / d.kt[a] - d.friction[a] * w) * w
        dl_la = qdh[H13[f"mla_{s}"]] + 23.53 * qdh[H13[f"la_{s}"]]
        dl_ls = qdh[H13[f"mls_{s}"]] - 31.42 * qdh[H13[f"ls_{s}"]] + (31.42 / 5.18) * qdh[H13[f"bsp_{s}"]]
        P = P - d.cable_d[2 * k] * dl_la**2 - d.cable_d[2 * k + 1] * dl_ls**2
        q, w = qh[H13[f"bsp_{s}"]], qdh[H13[f"bsp_{s}"]]
        tau = jnp.where(q > 0, -d.spring_d * w, -d.kvd1 * w + jnp.where(w < 0, d.kvd2 * jnp.sqrt(jnp.abs(w)), 0.0))
        P = P + tau * w
    F = dy.ground_forces(m, x)
    for k, toe in enumerate(mm.TOES):
        v = cp.point_jacobian(m.body, x[:n], toe) @ x[n:2 * n]
        P = P + F[k] @ v
    return P


@jax.jit
def _power_balance(m, xs, us):
    """(dE/dt along flow, the expected power, flow) at each state: one program per model, which
    the tests of step and of the rigid model reuse for their flows (16 states each)."""
    def one(x, u):
        f = dy.flow(m, x, u)
        dEdt = jax.jvp(lambda x: dy.energy(m, x), (x,), (f,))[1]
        return dEdt, _expected_power(m, x, u), f

    return jax.vmap(one)(xs, us)


_toes = jax.jit(lambda m, qs: jax.vmap(lambda q: dy.toe_positions(m, q))(qs))
_grounds = jax.jit(lambda m, xs: jax.vmap(lambda x: dy.ground_forces(m, x))(xs))


def _random_states(m, rng, N, contact):
    x0 = np.asarray(_airborne_state(m))
    n = m.n
    xs = np.tile(x0, (N, 1))
    xs[:, n:2 * n] *= rng.uniform(-2, 2, (N, n))
    xs[:, : n] += 0.05 * rng.normal(size=(N, n))
    b = [I9, H13][n == 13]
    for s in tb.SIDES:  # springs on either side of the stop, moving either way
        xs[:, b[f"bsp_{s}"]] = rng.uniform(-0.05, 0.1, N)
        xs[:, n + b[f"bsp_{s}"]] = rng.uniform(-1.0, 1.0, N)
    xs[:, 2 * n:] = rng.normal(0.0, 2e-3, (N, 2))
    if contact:  # lower the hip so the left toe is 0-3 mm into the ground
        toe_y = np.asarray(_toes(m, jnp.asarray(xs[:, :n])))[:, 0, 1]
        xs[:, 1] -= toe_y + rng.uniform(0.0, 3e-3, N)
    return jnp.asarray(xs)


@pytest.mark.parametrize("variant", ["13", "9"])
def test_power_balance(models, variant):
    """dE/dt along flow (jvp of energy) equals the power of the non-conservative forces
    written independently from the tables, at random states in the air and with the left toe
    in the ground, with random motor torques (within the limits; beyond them the HZD paper's
    capacities 30 N m (LA) and 55 N m (LS) are what acts). With u = 0 and the
    amplifier bias off, in the air, dE/dt <= 0: every damper of the model (motor friction,
    cable damping, spring damping, both hard-stop dampers) dissipates."""
    m = models[0] if variant == "13" else models[1]
    rng = np.random.default_rng(21)
    N = 16
    for contact in (False, True):
        xs = _random_states(m, rng, N, contact)
        us = jnp.asarray(rng.uniform(-10, 10, (N, 4)))
        dEdt, P, _ = (np.asarray(a) for a in _power_balance(m, xs, us))
        scale = np.abs(P) + 1.0
        assert np.all(np.abs(dEdt - P) < 1e-8 * scale), np.max(np.abs(dEdt - P) / scale)
        if contact:
            F = np.asarray(_grounds(m, xs))
            # the ground really pushes (except where the toe withdraws faster than k / lam)
            assert np.count_nonzero(F[:, 0, 1] > 0.0) >= N // 2
            assert np.any(F[:, :, 0] != 0.0)  # and friction acts
    # commands beyond the capacities (30 / 55 N m) act as the saturated torque
    us = jnp.asarray(rng.choice([-1.0, 1.0], (N, 4)) * 200.0)
    lim = np.asarray(m.drive.torque_limit)
    np.testing.assert_allclose(lim, [30.0, 55.0, 30.0, 55.0])
    dEdt, _, _ = _power_balance(m, xs, us)
    _, P_sat, _ = _power_balance(m, xs, jnp.clip(us, -lim, lim))
    np.testing.assert_allclose(np.asarray(dEdt), np.asarray(P_sat), rtol=1e-8, atol=1e-8)
    m0 = m.replace(drive=m.drive.replace(bias=jnp.zeros(4)))
    xs = _random_states(m0, rng, N, False)
    dEdt, P, _ = (np.asarray(a) for a in _power_balance(m0, xs, jnp.zeros((N, 4))))
    assert np.all(dEdt <= 1e-10 * (np.abs(P) + 1.0)) and np.all(P < 0.0)


@jax.jit
def _step_energy(m, x, u, h, nsub):
    """200 records of (energy, bsp_R, state) every nsub steps of length h from x under u: one
    program for both tests of step (h a Python float, so that every h shares it)."""
    def rec(x, _):
        x = jax.lax.fori_loop(0, nsub, lambda i, x: dy.step(m, x, u, h), x)
        return x, (dy.energy(m, x), x[H13["bsp_R"]], x)

    return jax.lax.scan(rec, x, None, length=200)[1]


def test_step_dissipates_and_is_stable_at_the_hard_stop(models):
    """step (semi-implicit Euler, spring and hard-stop damping implicit) with the default
    dampers, amplifier bias off and u = 0, in the air for 0.2 s: the energy never rises
    (sampled every 1 ms) and ends below the start, at h = 1e-4 and at h = 1e-3, although the
    hard stop's damper (1000 N m s/rad on ~1e-2 kg m^2) has a time constant near 1e-5 s,
    where an explicit step would diverge. The right spring stays at the stop (bsp < 0)."""
    m = models[0]
    m = m.replace(drive=m.drive.replace(bias=jnp.zeros(4)))
    x0 = _airborne_state(m)
    E0 = float(dy.energy(m, x0))
    for h, nsub in ((1e-4, 10), (1e-3, 1)):
        en, bsp_r, _ = (np.asarray(a) for a in _step_energy(m, x0, jnp.zeros(4), h, nsub))
        assert np.all(np.isfinite(en))
        assert np.all(np.diff(en) <= 1e-9 * E0)
        assert en[0] <= E0 and en[-1] < E0 - 0.1
        assert np.all(bsp_r < 0.0) and np.all(bsp_r > -0.03)


def test_step_is_consistent_with_flow(models):
    """One step of length h, (x_{k+1} - x_k)/h, tends to flow(x) at first order (halving h
    halves the gap): the implicitly taken spring / hard-stop damping and the ground's
    tangential viscous part enter with the right sign and size, and the bristle update
    matches z' of LuGre. States: a toe in the ground, the right spring on its hard stop moving
    in (the sqrt damper), random motor torques, default drivetrain."""
    full = models[0]
    rng = np.random.default_rng(17)
    xs = np.array(_random_states(full, rng, 16, True))
    xs[:, H13["bsp_R"]] = -0.01
    xs[:, 13 + H13["bsp_R"]] = -0.4
    us = rng.uniform(-10, 10, (16, 4))  # rows 0-2: the torques of the three states checked
    flows = np.asarray(_power_balance(full, jnp.asarray(xs), jnp.asarray(us))[2])
    n = full.n
    for x, u, f in zip(xs[:3], us[:3], flows[:3]):
        hs = np.array([1e-7, 5e-8])
        # one step of each h: the first record of _step_energy (one step per record)
        steps = np.stack([(np.asarray(_step_energy(full, jnp.asarray(x), jnp.asarray(u), float(h), 1)[2][0]) - x) / h
                          for h in hs])
        # semi-implicit: q_{k+1} = q_k + h qd_{k+1}
        np.testing.assert_allclose(steps[:, :n], x[n:2 * n] + hs[:, None] * steps[:, n:2 * n], rtol=1e-6, atol=1e-6)
        gap = [np.linalg.norm(s[n:] - f[n:]) / np.linalg.norm(f[n:]) for s in steps]  # qdd and z'
        assert np.max(np.abs(f[2 * n:])) > 0.0
        assert gap[1] < 1e-2
        assert gap[0] / gap[1] == pytest.approx(2.0, rel=0.1)


@jax.jit
def _on_manifold(rigid, xes):
    """The 13-DoF states (q_h = E q_e, qd_h = E qd_e, same bristles) of 9-DoF states."""
    E = jnp.asarray(np.asarray(rigid.E))
    n = rigid.n
    return jax.vmap(lambda xe: jnp.concatenate([E @ xe[:n], E @ xe[n:2 * n], xe[2 * n:]]))(xes)


@jax.jit
def _dalembert(full, rigid, xh, u, fe, fh):
    """E^T M_h (E qdd_e - qdd_h), its scale E^T M_h E qdd_e, and the 13-DoF drivetrain forces."""
    E = jnp.asarray(np.asarray(rigid.E))
    n = rigid.n
    Mh = cp.mass_matrix(full.body, xh[:13])
    resid = E.T @ (Mh @ (E @ fe[n:2 * n] - fh[13:26]))
    gen = jnp.stack(dy.drivetrain_forces(full, xh[:13], xh[13:26], u, False))
    return resid, E.T @ (Mh @ (E @ fe[n:2 * n])), gen


def test_rigid_model_is_the_constrained_hopping_model(models):
    """On the rigid-cable manifold (q_h = E q_e, qd_h = E qd_e) the cables carry no force,
    so the 13-DoF generalised forces on q_LA and q_LS vanish, and by d'Alembert the 9-DoF
    accelerations satisfy E^T M_h (E qdd_e - qdd_h) = 0 with qdd_h from the 13-DoF flow (the
    constraint forces do no work along E); also with a toe in the ground and random
    motor torques. The bristle rates agree."""
    full, rigid = models
    rng = np.random.default_rng(5)
    for contact in (False, True):
        xs = _random_states(rigid, rng, 16, contact)
        # the first four states, each with its random torques (the flows of both models come
        # from _power_balance's programs, on all 16 states: the other 12 with u = 0)
        us = jnp.asarray(np.concatenate([rng.uniform(-10, 10, (4, 4)), np.zeros((12, 4))]))
        xhs = _on_manifold(rigid, xs)
        fes, fhs = (np.asarray(_power_balance(m, x, us)[2]) for m, x in ((rigid, xs), (full, xhs)))
        for u, xh, fe, fh in zip(np.asarray(us)[:4], np.asarray(xhs)[:4], fes[:4], fhs[:4]):
            resid, scale, gen = (np.asarray(a) for a in _dalembert(full, rigid, xh, u, fe, fh))
            assert np.linalg.norm(resid) < 1e-10 * np.linalg.norm(scale)
            np.testing.assert_allclose(fe[18:], fh[26:], rtol=1e-12, atol=1e-15)
            for s in tb.SIDES:
                assert abs(gen[H13[f"la_{s}"]]) < 1e-10 and abs(gen[H13[f"ls_{s}"]]) < 1e-10
                lam = tr.cable_stretch(*(xh[H13[f"{c}_{s}"]] for c in tr.LOCAL))
                assert abs(float(lam[0])) < 1e-12 and abs(float(lam[1])) < 1e-12


# ----- statics (identification paper, Sections VI and VII-A) ---------------------------------
def _pinned_q(body, v, mls_L):
    """9-DoF configuration with the left toe pinned at the origin, q_LA_L = pi, the left
    leg-shape motor locked at mls_L, and the right leg folded and tied (la = pi - 1,
    ls = 1.2, bsp = 0); free: v = (torso angle, bsp_L)."""
    q = jnp.zeros(9)
    q = q.at[I9["tor"]].set(v[0]).at[I9["la_L"]].set(jnp.pi).at[I9["bsp_L"]].set(v[1]).at[I9["mls_L"]].set(mls_L)
    q = q.at[I9["la_R"]].set(jnp.pi - 1.0).at[I9["mls_R"]].set(tb.GEAR_LS * 1.2)
    toe = cp.point_position(body, q, "toe_L")
    return q.at[0].set(-toe[0]).at[1].set(-toe[1])


def _pinned_V(body, v, mls_L, k_b, kd1):
    """Potential (gravity, boom weight, left spring) of the pinned robot."""
    return cp.potential_energy(body, _pinned_q(body, v, mls_L)) + tr.spring_potential(k_b, kd1, v[1])


_pinned_q_jit = jax.jit(_pinned_q)
_dV = jax.jit(jax.grad(_pinned_V, argnums=1))


@jax.jit
def _statics(m, q):
    """(links' COM, dV/dq of the 9-DoF body, dV/dq_h of the same tree in 13-DoF coordinates)."""
    full = mm.hopping_model().body.replace(tree=m.body.tree, weight=jnp.zeros(13).at[1].set(m.body.weight[1]))
    qh = mm.full_coordinates(m, q)
    return (dy.com_position(m, q), jax.grad(cp.potential_energy, argnums=1)(m.body, q),
            jax.grad(cp.potential_energy, argnums=1)(full, qh))


@pytest.mark.parametrize("massless_legs", [False, True])
def test_static_balance_on_one_toe(models, massless_legs):
    """The robot pinned at its left toe, leg straight down from the torso (q_LA = 180 deg),
    leg-shape motor locked, other leg tied up: (a) the torso angle where rotation about the
    toe is in balance (brentq on dV/dtheta with bsp fixed) puts the weighted centre of the
    robot and the boom's weight (46.99 N at the hip) over the toe, and the links' COM alone
    over it when the boom weight is removed; (b) at the joint equilibrium of torso angle and
    spring deflection, eq. 24 K_B q_Bsp = W sin(q_LS) / 5.18 with W = dV/dy (links' weight +
    boom weight): exactly (times cos(torso), the leg's tilt) when the leg links are
    massless (W then acts only through the toe), within 3 % with MABEL's leg masses (the
    identification's approximation). Equilibrium leg shapes span 10-30 deg."""
    rigid = models[1]
    body = rigid.body
    if massless_legs:
        body = body.replace(tree=body.tree.replace(mass=body.tree.mass.at[1:].set(0.0)))
    k_b, kd1 = rigid.drive.spring_k[0], rigid.drive.kd1
    m_links = float(jnp.sum(body.tree.mass))
    w_y = float(body.weight[1])
    for ls_deg in (15.0, 20.0, 25.0):
        mls = jnp.asarray(tb.GEAR_LS * np.deg2rad(ls_deg - 4.0))
        # (a) rotation about the toe only (bsp held at 0.2)
        for b in (body, body.replace(weight=jnp.zeros_like(body.weight))):
            bsp0 = jnp.asarray(0.2)
            tor = brentq(lambda t: float(_dV(b, jnp.stack([jnp.asarray(t), bsp0]), mls, k_b, kd1)[0]), -0.5, 0.5,
                         xtol=1e-14)
            m_b = rigid.replace(body=b)
            q = _pinned_q_jit(b, jnp.array([tor, 0.2]), mls)
            com = np.asarray(_statics(m_b, q)[0])
            wb = float(b.weight[1])
            x_bal = (m_links * G * com[0] + wb * float(q[0])) / (m_links * G + wb)
            assert abs(x_bal) < 1e-6
            if wb == 0.0:
                assert abs(com[0]) < 1e-6
        # (b) torso and spring free: Newton on grad V = 0 (a saddle: the torso balance is
        # unstable), Hessian by central differences of the autodiff gradient
        grad = lambda v: np.asarray(_dV(body, jnp.asarray(v), mls, k_b, kd1))  # noqa: E731
        v = np.array([0.0, 0.3])
        for _ in range(12):
            Hs = np.stack([(grad(v + 1e-6 * e) - grad(v - 1e-6 * e)) / 2e-6 for e in np.eye(2)], 1)
            v = v - np.linalg.solve(Hs, grad(v))
        assert np.max(np.abs(grad(v))) < 1e-9
        tor, bsp = float(v[0]), float(v[1])
        v = jnp.asarray(v)
        m_b = rigid.replace(body=body)
        q = _pinned_q_jit(body, v, mls)
        ls = float(tr.leg_shape(mls, bsp))
        assert 10.0 <= np.rad2deg(ls) <= 30.0 and bsp > 0.0
        _, ge, gh = (np.asarray(a) for a in _statics(m_b, q))
        W = float(ge[I9["y"]])
        assert W == pytest.approx(m_links * G + w_y, rel=1e-12)
        rhs = W * np.sin(ls) / tb.GEAR_BSP
        if massless_legs:
            assert float(k_b) * bsp == pytest.approx(rhs * np.cos(tor), rel=1e-10)
        else:
            assert float(k_b) * bsp == pytest.approx(rhs, rel=3e-2)
        # gravity reaches B_spring only through q_LS = ... + q_Bsp / 5.18
        assert gh[H13["bsp_L"]] == 0.0
        assert ge[I9["bsp_L"]] == pytest.approx(gh[H13["ls_L"]] / tb.GEAR_BSP, rel=1e-12)
