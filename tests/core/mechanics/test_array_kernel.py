"""The array-form kernel of a revolute tree (bipedlab.mechanics.arrays) against the scalar
kernel (composite rigid bodies and Newton-Euler, unrolled) on random states, and against
MuJoCo for MABEL's walking model through the coupled transmission."""
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bipedlab.mechanics import arrays as ar
from bipedlab.mechanics import coupled as cp
from bipedlab.mechanics import dynamics as dyn
from bipedlab.mechanics import kinematics as kin
from bipedlab.robots.mabel.walking import stance as wk


def _trees():
    from bipedlab.robots.five_link.robot import model as five_link

    return {"mabel": wk.walking_model().body.tree, "five-link": five_link()}


@pytest.mark.parametrize("name", ["mabel", "five-link"])
def test_array_kernel_matches_scalar_kernel(name):
    tree = _trees()[name]
    assert ar.applies(tree)
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = jnp.asarray(rng.normal(size=tree.nq))
        qd = jnp.asarray(3.0 * rng.normal(size=tree.nq))
        M = np.asarray(ar.mass_matrix(tree, q))
        np.testing.assert_allclose(M, np.asarray(dyn.mass_matrix(tree, q)), atol=1e-12 * np.abs(M).max())
        b = np.asarray(ar.bias(tree, q, qd))
        np.testing.assert_allclose(b, np.asarray(dyn.bias(tree, q, qd)), atol=1e-12 * np.abs(b).max())
        for k in range(len(tree.point_names)):
            np.testing.assert_allclose(ar.point_position(tree, q, k), kin.point_position(tree, q, k), atol=1e-14)
            np.testing.assert_allclose(ar.point_jacobian(tree, q, k), kin.point_jacobian(tree, q, k), atol=1e-14)
            np.testing.assert_allclose(ar.point_jdot_qd(tree, q, qd, k), kin.point_jdot_qd(tree, q, qd, k),
                                       atol=1e-12)


def test_array_kernel_bias_is_lagrangian():
    """bias = d/dt(dL/dqd)|qdd=0 - dL/dq, from the kernel's own kinetic and potential energy
    by automatic differentiation (an oracle independent of both kernels' recursions)."""
    tree = _trees()["mabel"]
    rng = np.random.default_rng(4)
    q = jnp.asarray(rng.normal(size=tree.nq))
    qd = jnp.asarray(rng.normal(size=tree.nq))
    T = lambda q, v: 0.5 * v @ ar.mass_matrix(tree, q) @ v  # noqa: E731
    V = lambda q: dyn.potential_energy(tree, q)  # noqa: E731
    dTdv_dq = jax.jacfwd(jax.grad(T, argnums=1), argnums=0)(q, qd)
    expected = dTdv_dq @ qd - jax.grad(T, argnums=0)(q, qd) + jax.grad(V)(q)
    np.testing.assert_allclose(ar.bias(tree, q, qd), expected, rtol=1e-10, atol=1e-10)


def test_coupled_model_uses_the_small_kernel():
    """MABEL's 9-DoF mass matrix through the transmission: equal to the scalar entries, and a
    program an order of magnitude shorter (the size of every walking program follows it)."""
    from bipedlab.studybench import count_eqns

    m = wk.walking_model().body
    q = jnp.asarray(np.random.default_rng(5).normal(size=m.n))
    fr = kin.frames(m.tree, cp.tree_coordinates(m, q))
    scalar = cp.dense(cp.mass_matrix_entries(m, fr), q[0])
    np.testing.assert_allclose(cp.mass_matrix(m, q), scalar, atol=1e-12 * float(jnp.abs(scalar).max()))
    small = count_eqns(jax.make_jaxpr(lambda q: cp.mass_matrix(m, q))(q))
    big = count_eqns(jax.make_jaxpr(lambda q: cp.dense(cp.mass_matrix_entries(
        m, kin.frames(m.tree, cp.tree_coordinates(m, q))), q[0]))(q))
    assert small * 5 < big


def test_a_mechanism_that_locks_joints_keeps_the_scalar_form():
    """A model restricted to a few coordinates (MABEL's leg rig: 2 of 11 tree joints move)
    uses the scalar entries, whose structural zeros skip the locked bodies; its mass matrix
    and bias equal the array kernel's projected through the constant map, and the full
    walking model still takes the array form."""
    from bipedlab.robots.mabel import sysid
    from bipedlab.robots.mabel.sysid import rigs

    rig = rigs.leg_rig(sysid.perturbed(0), "L").body
    assert not cp.array_form(rig) and cp.array_form(wk.walking_model().body)
    T = jnp.asarray(np.asarray(rig.T))
    R = jnp.asarray(np.asarray(rig.R).reshape(-1, rig.n))
    rng = np.random.default_rng(6)
    for _ in range(3):
        q, qd = jnp.asarray(rng.normal(size=rig.n)), jnp.asarray(5.0 * rng.normal(size=rig.n))
        M = T.T @ ar.mass_matrix(rig.tree, T @ q) @ T + R.T @ (rig.rotor_inertia[:, None] * R)
        np.testing.assert_allclose(cp.mass_matrix(rig, q), M, atol=1e-12 * float(jnp.abs(M).max()))
        b = T.T @ ar.bias(rig.tree, T @ q, T @ qd) + rig.weight
        np.testing.assert_allclose(cp.bias(rig, q, qd), b, atol=1e-12 * float(jnp.abs(b).max()))


def test_the_batched_kernel_is_the_scalar_form_with_the_same_dynamics():
    """cp.batched picks the scalar form (the faster one under vmap) for a model the array form
    would take; both give the walking model's mass matrix, bias and toe Jacobian to rounding,
    and restrict keeps the choice."""
    m = wk.walking_model().body
    s = cp.batched(m)
    assert cp.array_form(m) and not cp.array_form(s) and s.kernel == "scalar"
    assert wk.walking_model(kernel="scalar").body.kernel == "scalar"
    assert cp.restrict(s, np.eye(s.n), s.coord_names).kernel == "scalar"
    with pytest.raises(ValueError, match="kernel must be one of auto, array, scalar, got 'arrays'"):
        cp.mass_matrix(m.replace(kernel="arrays"), jnp.zeros(m.n))
    rng = np.random.default_rng(7)
    q, qd = jnp.asarray(rng.normal(size=m.n)), jnp.asarray(3.0 * rng.normal(size=m.n))
    for f in (lambda b: cp.mass_matrix(b, q), lambda b: cp.bias(b, q, qd),
              lambda b: cp.point_jacobian(b, q, b.tree.point_names[-1])):
        a = np.asarray(f(m))
        np.testing.assert_allclose(np.asarray(f(s)), a, atol=1e-12 * np.abs(a).max())
