"""MABEL's drivetrain per leg: cable differentials, the unilateral spring and cable stretch.

Every pulley angle is relative to the torso. With rigid cables the thigh and shin angles
(relative to the torso) are ``C_thigh = q_LA + q_LS`` and ``C_shin = q_LA - q_LS`` (eq. 1), and
each differential obeys ``r_A A + r_B B = (r_A + r_B) C`` with its idler D given by
``A - B + r_D (1/r_A + 1/r_B) D = 0``. The leg-angle motor drives B_thigh = B_shin; the spring
differential's output C_spring drives A_thigh and A_shin. Solving these with the pulley radii
gives ``B = 2 q_LA`` and ``C_spring = 2 q_LS``.

Motor-to-joint maps use the identified gear ratios (eqs. 5-6; HZD paper eq. 1):
``q_mLA = -23.53 q_LA`` and ``q_LS = q_mLS / 31.42 + q_Bsp / 5.18``. The radii alone give
-25.21 and 31.58 / 6.08; so that both agree, the two step-down pulleys turn at the motor's
rigid-cable rate times the motor/step-down radius ratio, and the differential pulleys at the
rates the radii give from (q_LA, q_LS, q_Bsp).

Cable stretch (Section VII-B): the rigid relations are relaxed into a stretch
``lambda = (q_mLA - q_mLA_rigid(q_LA), q_mLS - q_mLS_rigid(q_LS, q_Bsp))`` measured at the
motors, i.e. ``lambda_LA = q_mLA + 23.53 q_LA`` and ``lambda_LS = q_mLS - 31.42 q_LS + 6.066
q_Bsp``; the cables pull back with ``K_C lambda + Kd_C lambda_dot`` (eq. 27). (Eq. 25 as
printed has the signs of the gear terms garbled; this form vanishes exactly on the rigid
relations (5)-(6).) The compliant segment is placed between each motor rotor and its
step-down pulley: only the rotor moves with q_m, every pulley follows the joint side.

Unilateral spring with hard stop (eq. 30), torque on B_spring:
``-K_B q - Kd_B qd`` while compressed (q > 0); ``-K_B q - K_d1 q^3 - K_vd1 qd`` at the stop
(q <= 0) moving out, plus ``- K_vd2 sqrt|qd| sign(qd)`` moving in.
"""
from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from bipedlab.robots.mabel import tables as tb

#: Per-leg local coordinates the rates below are written in.
LOCAL = ("la", "ls", "bsp", "mla", "mls")


def linkage_rates() -> dict:
    """Rates of A_th, A_sh, B, C_sp per unit (la, ls) from the differential equations."""
    r = tb.RADII
    # unknowns v = [A_th, A_sh, B, C_sp]; equations in order: thigh diff, shin diff, two C_sp links
    A = np.array([
        [r["Ath"], 0.0, r["Bth"], 0.0],
        [0.0, r["Ash"], r["Bsh"], 0.0],
        [r["Ath"], 0.0, 0.0, -r["Csp"]],
        [0.0, r["Ash"], 0.0, r["Csp"]],
    ])
    out = {}
    for name, (c_th, c_sh) in {"la": (1.0, 1.0), "ls": (1.0, -1.0)}.items():
        rhs = np.array([(r["Ath"] + r["Bth"]) * c_th, (r["Ash"] + r["Bsh"]) * c_sh, 0.0, 0.0])
        out[name] = np.linalg.solve(A, rhs)
    return {k: np.array([out["la"][i], out["ls"][i], 0.0, 0.0, 0.0]) for i, k in enumerate(("Ath", "Ash", "B", "Csp"))}


def _idler(rA, rB, rD, a, b):
    return -(a - b) / (rD * (1.0 / rA + 1.0 / rB))


def pulley_rates() -> dict:
    """{pulley: (coefficients over LOCAL)} of each rotor's rate relative to the torso."""
    r = tb.RADII
    lk = linkage_rates()
    e = {k: np.eye(5)[i] for i, k in enumerate(LOCAL)}
    B = lk["B"]
    a_sp = ((r["Asp"] + r["Bsp"]) * lk["Csp"] - r["Bsp"] * e["bsp"]) / r["Asp"]
    mla_rigid = tb.GEAR_LA * e["la"]
    mls_rigid = tb.GEAR_LS * e["ls"] - (tb.GEAR_LS / tb.GEAR_BSP) * e["bsp"]
    return {
        "mLA": e["mla"],
        "mLS": e["mls"],
        "LAsd": (r["m"] / r["LAsd_big"]) * mla_rigid,
        "LSsd": -(r["m"] / r["LSsd_big"]) * mls_rigid,
        "Bth": B,
        "Bsh": B,
        "Ath": lk["Ath"],
        "Ash": lk["Ash"],
        "Dth": _idler(r["Ath"], r["Bth"], r["Dth"], lk["Ath"], B),
        "Dsh": _idler(r["Ash"], r["Bsh"], r["Dsh"], lk["Ash"], B),
        "Asp": a_sp,
        "Bsp": e["bsp"],
        "Dsp": _idler(r["Asp"], r["Bsp"], r["Dsp"], a_sp, e["bsp"]),
    }


def rigid_motor_angles(la, ls, bsp):
    """(q_mLA, q_mLS) that rigid cables would give (eqs. 5-6)."""
    return tb.GEAR_LA * la, tb.GEAR_LS * ls - (tb.GEAR_LS / tb.GEAR_BSP) * bsp


def leg_shape(mls, bsp):
    """q_LS from the leg-shape motor and the spring pulley with rigid cables (eq. 6)."""
    return mls / tb.GEAR_LS + bsp / tb.GEAR_BSP


def cable_stretch(la, ls, bsp, mla, mls):
    """(lambda_LA, lambda_LS): motor angle minus its rigid-cable value (rad, motor side)."""
    mla_r, mls_r = rigid_motor_angles(la, ls, bsp)
    return mla - mla_r, mls - mls_r


def spring_elastic(k_b, kd1, q):
    """Conservative part of eq. 30 (N m): -K_B q, stiffened by -K_d1 q^3 at the stop."""
    return -k_b * q - jnp.where(q <= 0.0, kd1 * q**3, 0.0)


def spring_potential(k_b, kd1, q):
    """Potential of :func:`spring_elastic` (J); continuous with continuous slope at q = 0."""
    return 0.5 * k_b * q**2 + jnp.where(q <= 0.0, 0.25 * kd1 * q**4, 0.0)


def spring_damping_torque(kd_b, kvd1, kvd2, q, qd):
    """Dissipative part of eq. 30 (N m); its power ``torque * qd`` is never positive."""
    at_stop = -kvd1 * qd - jnp.where(qd < 0.0, kvd2 * jnp.sqrt(jnp.abs(qd)) * jnp.sign(qd), 0.0)
    return jnp.where(q > 0.0, -kd_b * qd, at_stop)


def spring_damping_coefficient(kd_b, kvd1, kvd2, q, qd, floor: float = 1e-10):
    """c >= 0 with ``spring_damping_torque = -c qd`` (the sqrt term as a speed-dependent
    coefficient, bounded at tiny speeds), for implicit integration."""
    sqrt_term = jnp.where(qd < 0.0, kvd2 / jnp.sqrt(jnp.maximum(jnp.abs(qd), floor)), 0.0)
    return jnp.where(q > 0.0, kd_b, kvd1 + sqrt_term)


def spring_torque(k_b, kd_b, kd1, kvd1, kvd2, q, qd):
    """Eq. 30: total torque (N m) of the unilateral spring and hard stop on B_spring."""
    return spring_elastic(k_b, kd1, q) + spring_damping_torque(kd_b, kvd1, kvd2, q, qd)
