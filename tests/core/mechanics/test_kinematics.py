"""Point kinematics, COM and momentum identities (checked by autodiff of positions and by
Newton's laws in free fall), on the five-link and on the branched prismatic tree."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bipedlab import mechanics as mech
from helpers import random_states
import oracles
from trees import make_model as make_branched

N = 24


def _models():
    from bipedlab.robots.five_link import robot as five_link

    return {"five_link": five_link.model(), "branched": make_branched()}


@pytest.fixture(scope="module", params=["five_link", "branched"])
def case(request):
    model = _models()[request.param]
    rng = np.random.default_rng(3)
    q, qd = random_states(rng, N, model.nq, qd_scale=2.0)
    if request.param == "branched":
        q[:, 4] = rng.uniform(-0.3, 0.6, N)
    return request.param, model, jnp.asarray(q), jnp.asarray(qd)


def _point_checks(model, q, qd):
    out = {}
    for name in model.point_names:
        pos = lambda q: mech.point_position(model, q, name)  # noqa: E731
        J = mech.point_jacobian(model, q, name)
        Jq = lambda q: mech.point_jacobian(model, q, name) @ qd  # noqa: E731
        _, jdot_qd_ref = jax.jvp(Jq, (q,), (qd,))
        out[name] = dict(
            J=J, J_ref=jax.jacfwd(pos)(q),
            v=mech.point_velocity(model, q, qd, name), v_ref=J @ qd,
            a=mech.point_jdot_qd(model, q, qd, name), a_ref=jdot_qd_ref,
            # second-order check: d/dt (J qd) with qdd = 0 equals the acceleration of the point
            a_ref2=jax.jvp(lambda q: jax.jacfwd(pos)(q) @ qd, (q,), (qd,))[1],
        )
    return out


def test_point_jacobian_velocity_and_jdot(case):
    _, model, q, qd = case
    res = jax.jit(jax.vmap(lambda q, qd: _point_checks(model, q, qd)))(q, qd)
    assert set(res) == set(model.point_names)
    for name, r in res.items():
        np.testing.assert_allclose(r["J"], r["J_ref"], atol=1e-13, err_msg=name)
        np.testing.assert_allclose(r["v"], r["v_ref"], atol=1e-12, err_msg=name)
        np.testing.assert_allclose(r["a"], r["a_ref"], atol=1e-11, err_msg=name)
        np.testing.assert_allclose(r["a"], r["a_ref2"], atol=1e-11, err_msg=name)
    # not trivially zero (the base origin 'hip' alone has no velocity-product acceleration)
    assert max(np.abs(np.asarray(r["a"])).max() for r in res.values()) > 1e-2


def test_five_link_feet_velocity_against_oracle():
    from bipedlab.robots.five_link import robot as five_link

    model = five_link.model()
    rng = np.random.default_rng(11)
    q, qd = (jnp.asarray(a) for a in random_states(rng, N, 7))

    def one(q, qd):
        ours = jnp.stack([mech.point_velocity(model, q, qd, f) for f in ("foot_1", "foot_2")])
        ref = jnp.stack([jax.jacfwd(oracles.five_link_foot)(q, leg) @ qd for leg in (0, 1)])
        return ours, ref

    ours, ref = jax.jit(jax.vmap(one))(q, qd)
    np.testing.assert_allclose(ours, ref, atol=1e-12)


def _momentum_checks(model, q, qd, P):
    qdd = mech.forward_dynamics(model, q, qd, jnp.zeros_like(q))  # free fall, no input
    L = lambda q, qd: mech.angular_momentum(model, q, qd, P)  # noqa: E731
    Ldot = jax.grad(L, 0)(q, qd) @ qd + jax.grad(L, 1)(q, qd) @ qdd
    c = mech.com_position(model, q)
    m = mech.total_mass(model)
    vc = mech.com_velocity(model, q, qd)
    ac = jax.jacfwd(lambda q: mech.com_velocity(model, q, qd))(q) @ qd + jax.jacfwd(
        lambda qd: mech.com_velocity(model, q, qd))(qd) @ qdd
    return dict(
        Ldot=Ldot, moment=-(c[0] - P[0]) * m * model.gravity,
        vc=vc, vc_ref=jax.jacfwd(lambda q: mech.com_position(model, q))(q) @ qd,
        ac=ac, L=L(q, qd),
        # momentum about P equals momentum about the COM plus m (c - P) x vc
        L_split=mech.angular_momentum(model, q, qd, c) + m * ((c[0] - P[0]) * vc[1] - (c[1] - P[1]) * vc[0]),
    )


def test_free_fall_momentum_laws(case):
    _, model, q, qd = case
    P = jnp.array([0.7, -0.4])
    r = jax.jit(jax.vmap(lambda q, qd: _momentum_checks(model, q, qd, P)))(q, qd)
    scale = np.abs(np.asarray(r["moment"])).max()
    assert scale > 1.0
    np.testing.assert_allclose(r["Ldot"], r["moment"], atol=1e-10 * scale)
    np.testing.assert_allclose(r["vc"], r["vc_ref"], atol=1e-12)
    g = float(model.gravity)
    np.testing.assert_allclose(r["ac"], np.broadcast_to([0.0, -g], (N, 2)), atol=1e-10 * g)
    np.testing.assert_allclose(r["L_split"], r["L"], rtol=1e-12, atol=1e-12)


def test_body_poses_match_oracle():
    from bipedlab.robots.five_link import robot as five_link

    model = five_link.model()
    q = jnp.asarray(random_states(np.random.default_rng(5), 1, 7)[0][0])
    angles, origins, coms = mech.body_poses(model, q)
    coms_ref, angles_ref, _ = oracles.five_link_geometry(q)
    np.testing.assert_allclose(angles, angles_ref, atol=1e-14)
    np.testing.assert_allclose(coms, coms_ref, atol=1e-14)
    np.testing.assert_allclose(origins[0], q[:2], atol=0)
