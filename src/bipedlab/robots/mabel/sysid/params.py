"""MABEL's identifiable parameters as one set: the published values, a perturbed "truth", and
the models built from a set.

A :class:`MabelParams` holds every number the identification of Park et al. determines
(Table II), in the units of :mod:`bipedlab.robots.mabel`:

* per actuator (``tables.ACTUATORS`` order ``mLA_L, mLS_L, mLA_R, mLS_R``): the torque
  constant ``kt`` (motor torque = (u + b) / K_T, eq. 17, so K_T is command N m per N m of
  motor torque), the rotor-inertia scale ``alpha`` (eq. 9), the amplifier ``bias`` b (command
  N m), the viscous friction of the isolated rotor (``motor_friction``, the Appendix A rig),
  of the three pulley combinations of Section IV (``trans_friction`` (4, 3)) and of the
  drivetrain with the legs attached (``friction``, Table V; the model's value), all N m s/rad
  of motor torque; the cable-stretch stiffness and damping ``cable_k``, ``cable_d``
  (N m/rad, N m s/rad at the motor, Table VI);
* per leg (L, R): the unilateral spring's stiffness ``spring_k`` (N m/rad at B_spring) and
  preload ``spring_preload`` (N m, the intercept of Fig. 19);
* the hard stop of eq. 30: ``spring_d`` (Kd_B, N m s/rad), ``kd1`` (N m/rad^3), ``kvd1``
  (N m s/rad), ``kvd2`` (N m (s/rad)^0.5);
* the ground (:mod:`bipedlab.contact.compliant` parameters, Table VI);
* ``torso_com_offset`` (m, torso frame): how far the real torso's centre of mass sits from the
  CAD value (Table VII); zero in the published set.

What is not identified is taken from the CAD model (Tables VII-VIII) in both the truth and the
estimators: link masses, centres of mass, inertias and pulley inertias.

The pulley combinations of Figs. 9-10 (1, 3, 5 pulleys on the leg-angle path, 1, 3, 4 on the
leg-shape path) are not drawn in the text. Their lumped "CAD" inertias (pulleys and cables,
reflected to the motor) are reconstructed from Tables III-IV: ``J_i = J_i^exp / K_T - alpha
J^rotor,man`` (eq. 10 solved for the CAD term), averaged over the left and right motors of a
kind. The leg-angle step-down pulley alone reflects 6.8e-5 kg m^2 through the radii of
:mod:`bipedlab.robots.mabel.transmission`, beside 7.5e-5 here. Their frictions are Table
III's mu_i^exp / K_T. The isolated rotor's friction is not published; half the first
combination's is used.
"""
from __future__ import annotations

import dataclasses

import jax.numpy as jnp
import numpy as np

from bipedlab.pytree import pytree
from bipedlab.contact import compliant as cg
from bipedlab.robots.mabel import model as mm
from bipedlab.robots.mabel import tables as tb

ACTUATORS = tb.ACTUATORS
SIDES = tb.SIDES
#: Number of pulleys in each combination of Figs. 9 (leg angle) and 10 (leg shape).
COMBINATIONS = {"mLA": (1, 3, 5), "mLS": (1, 3, 4)}

# Table III: identified J_i^exp (kg m^2) and mu_i^exp (N m s/rad), command units (x K_T).
# (mLS_L's J_3 is printed 1.112e-04, a typo for 1.112e-03: it must exceed J_2.)
TABLE_III_J = {"mLS_L": (8.819e-4, 1.099e-3, 1.112e-3), "mLA_L": (5.514e-4, 7.223e-4, 7.436e-4),
               "mLS_R": (1.104e-3, 1.360e-3, 1.431e-3), "mLA_R": (5.217e-4, 6.900e-4, 7.328e-4)}
TABLE_III_MU = {"mLS_L": (5.655e-3, 6.518e-3, 7.142e-3), "mLA_L": (2.332e-3, 4.365e-3, 3.858e-3),
                "mLS_R": (6.545e-3, 9.811e-3, 9.879e-3), "mLA_R": (1.718e-3, 4.048e-3, 4.703e-3)}
# Table IV: amplifier biases from the Appendix A procedure (the model uses Table V's).
TABLE_IV_BIAS = {"mLS_L": -0.1076, "mLA_L": -0.04652, "mLS_R": 0.02995, "mLA_R": -0.001672}


def _cad_combination_inertia() -> dict:
    out = {}
    for kind in ("mLA", "mLS"):
        rows = []
        for s in SIDES:
            a = f"{kind}_{s}"
            rows.append([J / tb.KT[a] - tb.ALPHA[a] * tb.ROTOR_INERTIA[kind] for J in TABLE_III_J[a]])
        out[kind] = tuple(float(v) for v in np.mean(rows, axis=0))
    return out


#: Lumped CAD inertia (kg m^2, reflected to the motor) of each pulley combination, per motor kind.
COMBINATION_INERTIA = _cad_combination_inertia()

GROUND_KEYS = ("stiffness", "exponent", "damping_in", "damping_out", "bristle_stiffness", "bristle_damping",
               "viscous", "coulomb", "static", "stribeck_velocity", "relax")


def actuator_index(name: str) -> int:
    """Index of an actuator in ``tables.ACTUATORS``; a clear error for unknown names."""
    try:
        return ACTUATORS.index(name)
    except ValueError:
        raise ValueError(f"unknown actuator {name!r}; expected one of {', '.join(ACTUATORS)}") from None


def combination_inertia(actuator: str) -> np.ndarray:
    """CAD inertias (3,) of the pulley combinations of an actuator (kg m^2 at the motor)."""
    return np.asarray(COMBINATION_INERTIA[actuator[:3]])


def rotor_inertia_manufacturer(actuator: str) -> float:
    """J^rotor,man of Table VIII (kg m^2)."""
    return float(tb.ROTOR_INERTIA[actuator[:3]])


@pytree
class MabelParams:
    """One value of every identified parameter (numpy float64; see the module docstring for
    the units). Arrays per actuator follow ``tables.ACTUATORS``; per leg ``tables.SIDES``."""

    kt: np.ndarray
    alpha: np.ndarray
    bias: np.ndarray
    motor_friction: np.ndarray
    trans_friction: np.ndarray
    friction: np.ndarray
    cable_k: np.ndarray
    cable_d: np.ndarray
    spring_k: np.ndarray
    spring_preload: np.ndarray
    spring_d: float
    kd1: float
    kvd1: float
    kvd2: float
    ground: dict
    torso_com_offset: np.ndarray




def published() -> MabelParams:
    """The paper's values (Tables III-VI, Fig. 19) and the package's ground reading."""
    per = lambda d: np.array([d[a] for a in ACTUATORS], float)  # noqa: E731
    return MabelParams(
        kt=per(tb.KT), alpha=per(tb.ALPHA), bias=per(tb.BIAS),
        motor_friction=np.array([0.5 * TABLE_III_MU[a][0] / tb.KT[a] for a in ACTUATORS]),
        trans_friction=np.array([[mu / tb.KT[a] for mu in TABLE_III_MU[a]] for a in ACTUATORS]),
        friction=per(tb.FRICTION), cable_k=per(tb.CABLE_K), cable_d=per(tb.CABLE_D),
        spring_k=np.array([tb.SPRING_K[s] for s in SIDES], float), spring_preload=np.array([2.214, 5.377]),
        spring_d=float(tb.SPRING_DAMPING), kd1=float(tb.HARD_STOP["kd1"]), kvd1=float(tb.HARD_STOP["kvd1"]),
        kvd2=float(tb.HARD_STOP["kvd2"]), ground={k: float(tb.GROUND[k]) for k in GROUND_KEYS},
        torso_com_offset=np.zeros(2),
    )


#: Ground parameters a perturbation leaves alone (the force law's exponent and two numbers the
#: paper does not give, see tables.py).
_GROUND_FIXED = ("exponent", "stribeck_velocity", "relax")


def perturbed(seed: int = 0, spread: float = 0.05, bias_sd: float = 0.01, com_sd: float = 0.002) -> MabelParams:
    """A "true" robot: every published value times ``1 + spread * N(0, 1)`` (the normal draw
    clipped at +-2.5), biases plus ``bias_sd * N(0, 1)`` N m, and the torso's centre of mass
    moved by ``com_sd * N(0, 1)`` m along each torso axis. Same seed, same robot."""
    rng = np.random.default_rng(seed)
    pub = published()

    def mul(v):
        v = np.asarray(v, float)
        return v * (1.0 + spread * np.clip(rng.standard_normal(v.shape), -2.5, 2.5))

    ground = {k: (v if k in _GROUND_FIXED else float(mul(v))) for k, v in pub.ground.items()}
    ground["damping_out"] = ground["damping_in"]  # the published reading has one damping
    return MabelParams(
        kt=mul(pub.kt), alpha=mul(pub.alpha), bias=pub.bias + bias_sd * rng.standard_normal(4),
        motor_friction=mul(pub.motor_friction), trans_friction=mul(pub.trans_friction), friction=mul(pub.friction),
        cable_k=mul(pub.cable_k), cable_d=mul(pub.cable_d), spring_k=mul(pub.spring_k),
        spring_preload=mul(pub.spring_preload), spring_d=float(mul(pub.spring_d)), kd1=float(mul(pub.kd1)),
        kvd1=float(mul(pub.kvd1)), kvd2=float(mul(pub.kvd2)), ground=ground,
        torso_com_offset=com_sd * np.clip(rng.standard_normal(2), -2.5, 2.5),
    )


def with_rotor_inertia(body, alpha) -> object:
    """A coupled body whose motor rotors have inertia alpha J^rotor,man (alpha per actuator)."""
    J = body.rotor_inertia
    for k, a in enumerate(ACTUATORS):
        i = body.rotor_names.index(a)
        J = J.at[i].set(alpha[k] * tb.ROTOR_INERTIA[a[:3]])
    return body.replace(rotor_inertia=J)


def with_torso_com(body, offset) -> object:
    """A coupled body whose torso centre of mass is moved by offset (m, torso frame)."""
    tree = body.tree
    com = tree.com.at[tree.body_index("torso")].add(jnp.asarray(offset, dtype=jnp.float64))
    return body.replace(tree=dataclasses.replace(tree, com=com))


def drivetrain(p: MabelParams) -> mm.Drivetrain:
    """The model's drivetrain pytree for a parameter set (torque limits as published)."""
    f = lambda v: jnp.asarray(v, dtype=jnp.float64)  # noqa: E731
    base = mm.drivetrain()
    return base.replace(kt=f(p.kt), bias=f(p.bias), friction=f(p.friction), cable_k=f(p.cable_k),
                        cable_d=f(p.cable_d), spring_k=f(p.spring_k), spring_d=f(p.spring_d), kd1=f(p.kd1),
                        kvd1=f(p.kvd1), kvd2=f(p.kvd2))


def ground(p: MabelParams) -> cg.CompliantGround:
    return cg.make(**p.ground)


def model(p: MabelParams) -> mm.Mabel:
    """The 13-DoF hopping model (cable stretch, springs, hard stops, ground) of a parameter set."""
    m = mm.hopping_model(ground=ground(p), drive=drivetrain(p))
    body = with_torso_com(with_rotor_inertia(m.body, p.alpha), p.torso_com_offset)
    return m.replace(body=body)
