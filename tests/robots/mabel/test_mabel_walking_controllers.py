"""MABEL's walking controllers (compliant-HZD paper, Section IV-V): input-output linearisation
(eq. 42) against the full stance dynamics, its decentralised form (Exp. 5), and the u*
regression of eq. 43."""
from __future__ import annotations

from math import comb

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import bipedlab  # noqa: F401
from bipedlab.robots.mabel.walking import constraints as vcm
from bipedlab.robots.mabel.walking import controllers as ctl
from bipedlab.robots.mabel.walking import zero_dynamics as zd
from bipedlab.robots.mabel.walking import stance as wk
from bipedlab.robots.mabel.walking import study as wm

ACT = list(ctl.ACTUATOR_OF_OUTPUT)


@pytest.fixture(scope="module")
def m():
    return wk.walking_model()


@pytest.fixture(scope="module")
def gait():
    return wm.load_gait("nominal")


@pytest.fixture(scope="module")
def fns(m):
    return dict(
        iolin=jax.jit(lambda vc, p, z, g: ctl.iolin(m, vc, p, z, g)),
        dec=jax.jit(lambda vc, p, z, g: ctl.iolin(m, vc, p, z, g, decentralized=True)),
        decoupling=jax.jit(lambda vc, p, z: ctl.decoupling(m, vc, p, z)),
        flow=jax.jit(lambda z, u: wk.stance_flow(m, z, u)),
        zd=jax.jit(lambda vc, p, th, b, thd, bd: zd.zd_accelerations(m, vc, p, th, b, thd, bd)),
    )


OFFSET = np.array([0.004, -0.03, 0.002, -0.006, 0.04, 0.003, 0.02, -0.2, 0.05, -0.05, 0.3, -0.02])


def _states(gait, fns):
    """Off-manifold stance states near the nominal orbit in MC, SC, SI and SD: an orbit point
    (zero-dynamics state reconstructed from a mid-phase theta) plus small offsets."""
    vc, _, rec = gait
    zp = np.asarray(rec["z_plus"])
    bounds = [(vc.theta_plus, vc.theta_mc), (vc.theta_mc, vc.theta_sc), (vc.theta_sc, vc.theta_si),
              (vc.theta_si, vc.theta_minus)]
    out = []
    for p, (a, b) in enumerate(bounds):
        th = 0.5 * (float(a) + float(b))
        # spring and rates roughly those of the orbit (b stays compressed after MC)
        w = np.array([max(zp[2], 0.05), float(vcm.theta_rate(jnp.asarray(zp[6:]))), 0.0])
        _, _, _, qs, qds = fns["zd"](vc, p, jnp.asarray(th), *map(jnp.asarray, w))
        z = np.concatenate([np.asarray(qs), np.asarray(qds)]) + OFFSET * (0.5 + 0.25 * p)
        out.append((p, jnp.asarray(z)))
    return out


def _ydd(vc, p, z, qdd):
    qs, qds = z[:6], z[6:]
    th, thd = vcm.theta(qs), vcm.theta_rate(qds)
    _, dh, ddh = (np.asarray(a) for a in vcm.desired_derivatives(vc, p, th))
    thdd = float(vcm.theta_rate(jnp.asarray(qdd)))
    return qdd[list(vcm.H0_INDEX)] - dh * thdd - ddh * float(thd) ** 2


def test_iolin_imposes_the_linear_output_dynamics(gait, fns):
    """Eq. 42 below saturation: the full stance dynamics under u give
    y-dd = -(Kp/eps^2) y - (Kd/eps) y-dot exactly, each output with its own eps."""
    vc, g, _ = gait
    for p, z in _states(gait, fns):
        u = np.asarray(fns["iolin"](vc, p, z, g))
        assert np.all(np.abs(u) < 0.99 * np.asarray(g.limit)), (p, u)
        qdd = np.asarray(fns["flow"](z, jnp.asarray(u)))[6:]
        y, yd = (np.asarray(a) for a in vcm.outputs(vc, p, z[:6], z[6:]))
        assert np.max(np.abs(y)) > 1e-3  # off the manifold
        eps = np.asarray(g.eps)  # per output
        assert eps.shape == (4,)
        target = -(float(g.kp_io) / eps ** 2) * y - (float(g.kd_io) / eps) * yd
        ydd = _ydd(vc, p, z, qdd)
        assert ydd == pytest.approx(target, rel=1e-8, abs=1e-8 * max(1.0, np.max(np.abs(target))))


def test_decoupling_matrix_is_the_input_to_output_acceleration_map(gait, fns):
    """y-dd = LgLfh u + Lf^2 h for any u (affine in u): checked against the full dynamics with
    two different torques."""
    vc, _, _ = gait
    p, z = _states(gait, fns)[1]
    _, _, A, lf2 = (np.asarray(a) for a in fns["decoupling"](vc, p, z))
    for u in (np.zeros(4), np.array([2.0, -5.0, 1.0, 3.0])):
        qdd = np.asarray(fns["flow"](z, jnp.asarray(u)))[6:]
        assert _ydd(vc, p, z, qdd) == pytest.approx(A @ u + lf2, rel=1e-8, abs=1e-8 * np.max(np.abs(lf2)))


def test_decentralized_feedback_uses_only_the_diagonal(gait, fns):
    """Exp. 5: u = u* + diag(A)^-1 v with the full eq. 32 feedforward u* = -A^-1 Lf2 h: on the
    constraint surface (v = 0) it equals the full controller; off it, an output error moves only
    that output's own actuator, A[i, act(i)] du_act(i) = v_i, unlike the full solve."""
    vc, g, _ = gait
    for p, z in _states(gait, fns):
        y, yd, A, lf2 = (np.asarray(a) for a in fns["decoupling"](vc, p, z))
        eps = np.asarray(g.eps)  # per output
        v = -(float(g.kp_io) / eps ** 2) * y - (float(g.kd_io) / eps) * yd
        u = np.asarray(fns["dec"](vc, p, z, g))
        assert np.all(np.abs(u) < np.asarray(g.limit))
        u_star = np.linalg.solve(A, -lf2)
        du = u - u_star
        assert A[np.arange(4), ACT] * du[ACT] == pytest.approx(v, rel=1e-10, abs=1e-10)
        # the decoupling matrix is not diagonal in this pairing, so the answer differs from iolin
        u_full = np.asarray(fns["iolin"](vc, p, z, g))
        assert u_full - u_star == pytest.approx(np.linalg.solve(A, v), rel=1e-8, abs=1e-10)
        assert np.max(np.abs(u - u_full)) > 1e-3


def test_iolin_saturates_at_the_torque_limits(gait, fns):
    """With an experiment's lower limits the torques are the unsaturated eq. 42 torques clipped
    to +-limit, actuator by actuator."""
    vc, g, _ = gait
    p, z = _states(gait, fns)[1]
    free = np.asarray(fns["iolin"](vc, p, z, g.replace(limit=jnp.full(4, 1e6))))
    lim = 0.5 * np.abs(free)
    lim[0] = 2.0 * abs(free[0])  # one actuator left unsaturated
    u = np.asarray(fns["iolin"](vc, p, z, g.replace(limit=jnp.asarray(lim))))
    assert u == pytest.approx(np.clip(free, -lim, lim), rel=1e-12)
    assert u[0] == pytest.approx(free[0], rel=1e-12) and np.all(np.abs(u[1:]) == lim[1:])


def _bernstein(s, M=5):
    s = np.asarray(s)[:, None]
    k = np.arange(M + 1)
    return np.array([comb(M, i) for i in k]) * s**k * (1 - s) ** (M - k)


def test_regress_feedforward_recovers_known_beziers():
    """Eq. 43's least squares is exact on data generated by order-5 Béziers per phase, with
    samples unevenly spread and each phase on its own theta-domain."""
    rng = np.random.default_rng(7)
    bounds = np.array([[-0.33, -0.30], [-0.30, -0.05], [-0.05, 0.20], [0.20, 0.31]])
    beta = rng.normal(0.0, 5.0, (4, 4, 6))
    thetas, us, phases = [], [], []
    for p in range(4):
        n = 12 + 5 * p
        s = np.sort(rng.uniform(0.0, 1.0, n))
        th = bounds[p, 0] + s * (bounds[p, 1] - bounds[p, 0])
        thetas.append(th)
        us.append(_bernstein(s) @ beta[p].T)
        phases.append(np.full(n, p))
    perm = rng.permutation(sum(len(t) for t in thetas))  # order of samples must not matter
    thetas, us, phases = (np.concatenate(a)[perm] for a in (thetas, us, phases))
    got = ctl.regress_feedforward(thetas, us, phases, bounds)
    assert got.shape == (4, 4, 6)
    assert got == pytest.approx(beta, rel=1e-8, abs=1e-8)
    # and the feedforward evaluates those Béziers at theta
    g = ctl.default_gains(got, bounds, np.ones(4))
    th = 0.5 * (bounds[2, 0] + bounds[2, 1])
    assert np.asarray(ctl.feedforward(g, 2, jnp.asarray(th))) == pytest.approx(_bernstein([0.5])[0] @ beta[2].T, rel=1e-9)


def test_shipped_feedforward_matches_the_zero_dynamics_torque(gait, fns):
    """The shipped u* regression reproduces u* of the zero dynamics along the orbit (a few
    per cent of the torque range)."""
    vc, g, rec = gait
    zp = np.asarray(rec["z_plus"])
    # u* at theta+ on the manifold from the designed post-impact state
    thd = vcm.theta_rate(jnp.asarray(zp[6:]))
    u = np.asarray(fns["zd"](vc, vcm.MC, vc.theta_plus, jnp.asarray(zp[2]), thd, jnp.asarray(zp[8]))[2])
    ff = np.asarray(ctl.feedforward(g, vcm.MC, vc.theta_plus))
    scale = np.max(np.abs(rec["design"]["peak_torques"]))
    assert np.max(np.abs(ff - u)) < 0.05 * scale
