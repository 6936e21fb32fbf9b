"""MABEL's equations of motion, energy, and a time step for its stiff hard stop.

State ``x = [q (n), qd (n), z (2)]``: coordinates and velocities of the model variant and the
LuGre bristle deflection at each toe. Input ``u`` (4,): commanded motor torques in
``tables.ACTUATORS`` order, saturated at the drivetrain's torque limits.

The hard stop of the unilateral spring is a damper of 1000 N m s/rad on a pulley whose
effective inertia is of order 1e-2 kg m^2: a time constant near 10 us. :func:`step` is
therefore semi-implicit Euler with the spring's damping taken implicitly, the scheme MuJoCo
calls "implicit damping": ``(M + h C) dv = h (f - C v)`` with ``C`` the damping of eq. 30 at
the start of the step. It is first order and unconditionally stable for that damper; every
other force is explicit. :func:`flow` is the exact vector field for explicit integrators.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.contact import compliant as cg
from bipedlab.mechanics import coupled as cp
from bipedlab.robots.mabel import tables as tb
from bipedlab.robots.mabel import transmission as tr
from bipedlab.robots.mabel.model import COORDS_13, TOES, Mabel

_H = {c: i for i, c in enumerate(COORDS_13)}


def _leg(qh, s):
    return [qh[_H[f"{c}_{s}"]] for c in tr.LOCAL]


def drivetrain_forces(m: Mabel, qh, qdh, u, implicit_spring_damping: bool):
    """Generalised forces in the 13 coordinates from motors, friction, cables and springs."""
    d = m.drive
    out = [0.0 * qh[0]] * 13
    u = jnp.clip(u, -d.torque_limit, d.torque_limit)

    def add(name, val):
        out[_H[name]] = out[_H[name]] + val

    for k, s in enumerate(tb.SIDES):
        la, ls, bsp, mla, mls = _leg(qh, s)
        dla, dls, dbsp, dmla, dmls = _leg(qdh, s)
        a_la, a_ls = 2 * k, 2 * k + 1  # actuator slots (mLA_s, mLS_s)
        for a, coord, rate in ((a_la, f"mla_{s}", dmla), (a_ls, f"mls_{s}", dmls)):
            add(coord, (u[a] + d.bias[a]) / d.kt[a] - d.friction[a] * rate)
        lam_la, lam_ls = tr.cable_stretch(la, ls, bsp, mla, mls)
        dlam_la, dlam_ls = tr.cable_stretch(dla, dls, dbsp, dmla, dmls)
        f_la = d.cable_k[a_la] * lam_la + d.cable_d[a_la] * dlam_la
        f_ls = d.cable_k[a_ls] * lam_ls + d.cable_d[a_ls] * dlam_ls
        add(f"mla_{s}", -f_la)
        add(f"la_{s}", tb.GEAR_LA * f_la)
        add(f"mls_{s}", -f_ls)
        add(f"ls_{s}", tb.GEAR_LS * f_ls)
        add(f"bsp_{s}", -(tb.GEAR_LS / tb.GEAR_BSP) * f_ls)
        spring = tr.spring_elastic(d.spring_k[k], d.kd1, bsp)
        if not implicit_spring_damping:
            spring = spring + tr.spring_damping_torque(d.spring_d, d.kvd1, d.kvd2, bsp, dbsp)
        add(f"bsp_{s}", spring)
    return out


def _forces(m: Mabel, x, u, implicit: bool, f_hip=None):
    """(H lower triangle, rhs list, contact data, q_h, qd_h, dampers) for the state x.

    With ``implicit``, the spring/hard-stop damping and the ground's tangential viscous
    terms are left out of rhs and returned as dampers [(c, {coordinate: direction})].
    ``f_hip``: an external force (Fx, Fy) in N on the hip (a push), or None."""
    n = m.n
    q, qd, z = x[:n], x[n:2 * n], x[2 * n:]
    Em = jnp.asarray(np.asarray(m.E))
    qh, qdh = Em @ q, Em @ qd
    fr, vel = cp.state_frames(m.body, q, qd)
    h = cp.bias_entries(m.body, fr, vel)
    gen = cp.pull_back(m.E, drivetrain_forces(m, qh, qdh, u, implicit))
    rhs = [gen[i] - h[i] for i in range(n)]
    dampers, contacts = [], []
    if implicit:
        d = m.drive
        for k, (s, row) in enumerate(zip(tb.SIDES, _spring_rows(m))):
            i = _H[f"bsp_{s}"]
            dampers.append((tr.spring_damping_coefficient(d.spring_d, d.kvd1, d.kvd2, qh[i], qdh[i]), row))
    for k, toe in enumerate(TOES):
        idx = m.body.tree.point_index(toe)
        p, v = cp.point_motion(m.body, fr, vel, idx)
        if implicit:
            fn, rest, c_t = cg.contact_split(m.ground, p, v, z[k])
            F = (rest, fn)
            row = {j: a for j, a in enumerate(cp.point_force(m.body, fr, idx, (1.0, 0.0))) if a is not None}
            dampers.append((c_t, row))
            contacts.append((fn, v[0]))
        else:
            F, zd = cg.contact(m.ground, p, v, z[k])
            contacts.append(zd)
        for j, val in enumerate(cp.point_force(m.body, fr, idx, F)):
            if val is not None:
                rhs[j] = rhs[j] + val
    if f_hip is not None:
        idx = m.body.tree.point_index("hip")
        for j, val in enumerate(cp.point_force(m.body, fr, idx, (f_hip[0], f_hip[1]))):
            if val is not None:
                rhs[j] = rhs[j] + val
    return cp.mass_matrix_entries(m.body, fr), rhs, contacts, dampers


def flow(m: Mabel, x, u) -> jax.Array:
    """xdot for the state x under input u (every force evaluated exactly)."""
    n = m.n
    H, rhs, zdot, _ = _forces(m, x, u, implicit=False)
    qdd = jnp.stack(cp.solve(H, rhs))
    return jnp.concatenate([x[n:2 * n], qdd, jnp.stack(zdot)])


def _spring_rows(m: Mabel):
    """Per leg: {coordinate j: E[bsp_s, j]} (the direction of q_bsp in model coordinates)."""
    return [{j: v for j, v in enumerate(m.E[_H[f"bsp_{s}"]]) if v != 0.0} for s in tb.SIDES]


def _damped_acceleration(m: Mabel, x, u, h: float, f_hip=None):
    """(qdd, contacts) with the stiff dampers taken implicitly over a step h:
    ``(M + h sum c a a^T) qdd = f - sum c a a^T qd``."""
    n = m.n
    H, rhs, contacts, dampers = _forces(m, x, u, implicit=True, f_hip=f_hip)
    qd = x[n:2 * n]
    H = [list(row) for row in H]
    for c, row in dampers:
        v = sum(a * qd[j] for j, a in row.items())
        for j, a in row.items():
            rhs[j] = rhs[j] - a * c * v
            for jj, b in row.items():
                if jj <= j:
                    term = (h * a * b) * c
                    H[j][jj] = term if H[j][jj] is None else H[j][jj] + term
    return jnp.stack(cp.solve(H, rhs)), contacts


def step(m: Mabel, x, u, h: float, f_hip=None) -> jax.Array:
    """One semi-implicit Euler step of length h; the spring/hard-stop damping and the
    ground's tangential viscous terms are implicit: ``(M + h sum c a a^T) dv = h (f - sum c a a^T v)``."""
    n = m.n
    qdd, contacts = _damped_acceleration(m, x, u, h, f_hip)
    qd = x[n:2 * n]
    qd_new = qd + h * qdd
    q_new = x[:n] + h * qd_new
    z = x[2 * n:]
    z_new = jnp.stack([cg.bristle_step(m.ground, fn, vx, z[k], h) for k, (fn, vx) in enumerate(contacts)])
    return jnp.concatenate([q_new, qd_new, z_new])


# ----- energy and kinematics ---------------------------------------------------------------
def energy(m: Mabel, x) -> jax.Array:
    """Kinetic + gravitational (links and boom) + spring + cable-stretch potential (J)."""
    n = m.n
    q, qd = x[:n], x[n:2 * n]
    qh = jnp.asarray(np.asarray(m.E)) @ q
    d = m.drive
    V = cp.potential_energy(m.body, q)
    for k, s in enumerate(tb.SIDES):
        la, ls, bsp, mla, mls = _leg(qh, s)
        V = V + tr.spring_potential(d.spring_k[k], d.kd1, bsp)
        lam = tr.cable_stretch(la, ls, bsp, mla, mls)
        V = V + 0.5 * (d.cable_k[2 * k] * lam[0] ** 2 + d.cable_k[2 * k + 1] * lam[1] ** 2)
    return cp.kinetic_energy(m.body, q, qd) + V


def toe_positions(m: Mabel, q) -> jax.Array:
    """World positions of the left and right toes (2, 2)."""
    return jnp.stack([cp.point_position(m.body, q, t) for t in TOES])


def ground_forces(m: Mabel, x) -> jax.Array:
    """(Fx, Fy) at each toe (2, 2)."""
    n = m.n
    q, qd, z = x[:n], x[n:2 * n], x[2 * n:]
    fr, vel = cp.state_frames(m.body, q, qd)
    out = []
    for k, toe in enumerate(TOES):
        p, v = cp.point_motion(m.body, fr, vel, m.body.tree.point_index(toe))
        F, _ = cg.contact(m.ground, p, v, z[k])
        out.append(jnp.stack(F))
    return jnp.stack(out)


def com_position(m: Mabel, q) -> jax.Array:
    """Centre of mass of the robot's links (m), boom excluded."""
    from bipedlab.mechanics import dynamics as dyn

    return dyn.com_position(m.body.tree, cp.tree_coordinates(m.body, q))
