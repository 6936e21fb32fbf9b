"""The seven-link biped with feet of Braun, Mitchell and Goldfarb (IEEE/ASME T-Mech 2012).

Coordinates (Section II): ``q = [x, y, theta, theta_1, ..., theta_6]``, the hip position (m)
and the absolute angles (rad, counter-clockwise from the +x axis, x forward, y up) of the
body, then leg 1 (thigh 1, shank 1, foot 1) and leg 2 (thigh 4, shank 5, foot 6). Body,
thigh and shank angles are those of the vector from the distal to the proximal joint (body:
hip to head), so an upright body and a hanging leg are at pi/2; a foot lying flat with its
toe forward is at 0. Joint angles (Section II)::

    phi = [theta_1 - theta, theta_2 - theta_1, theta_3 - theta_2 + pi/2,
           theta_4 - theta, theta_5 - theta_4, theta_6 - theta_5 + pi/2]

hip, knee, ankle per leg; knee flexion is phi_2 < 0 and the hyperextension stop holds
``phi_2 <= 0``; ankle dorsiflexion (toe up) is phi_3 > 0. Joint torques u act on phi, so
``Q_u = E u`` with the constant ``E = (d phi / d q)^T`` (9 x 6).

Parameters (Table I, total 14.3 kg, 1.2 m):

* body 0.390 m, COM 0.185 m above the hip, 6.12 kg, 0.021 kg m^2 (includes the 4.54 kg of
  weights 0.2 m above the hip, Section IV-A);
* thigh 0.295 m, COM 0.147 m below the hip, 0.67 kg, 0.0096 kg m^2;
* shank 0.298 m, COM 0.14 m below the knee, 0.55 kg, 0.0069 kg m^2;
* foot 0.183 m long, 0.36 kg, 0.0007 kg m^2; ankle h = 0.055 m above the sole, toe
  a = 0.137 m ahead of and heel b = 0.046 m behind the ankle (a + b = the foot length), COM
  c_x = 0.014 m ahead of and c_y = 0.035 m below the ankle;
* actuators (hip, knee, ankle): gear ratios 21, 12, 21; 0.84 kg each; reflected inertias
  0.0067, 0.0022, 0.0067 kg m^2; joint viscous damping 0.13, 0.11, 0.05 N m s.

Modelling choices the paper leaves open, stated here:

* "l_c" is measured from the proximal joint (hip for the thigh, knee for the shank), which
  matches l_c ~ l/2 for both.
* Each actuator's 0.84 kg is a point mass on its joint axis (the hip units at the hip, the
  knee units at the knee, the ankle units at the ankle); the link masses of Table I exclude
  them (6.12 + 2(0.67 + 0.55 + 0.36) + 6 x 0.84 = 14.32 kg = the stated total).
* J_a are the rotor inertias reflected through the gears: Table I's values are n^2 J_m with
  one rotor-plus-gearhead inertia J_m = 1.52e-5 kg m^2 (0.0067 / 21^2 = 1.519e-5,
  0.0022 / 12^2 = 1.528e-5; a Maxon RE40 rotor is 1.34e-5 kg m^2). They act on the joint
  rate (kinetic energy J_a phi_dot^2 / 2), the usual reflected-inertia model: any other gear
  ratio n gives n^2 J_m (Fig. 6's 105:1 and 60:1 comparison).
* Joint damping b is viscous on the joint rate; for another gear ratio it scales with n^2
  (motor-side viscous friction reflected through the gear), see :func:`model`.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.mechanics import Body, Point, build_model
from bipedlab.report import spec
from bipedlab.mechanics import coupled as cp
from bipedlab.mechanics import kinematics as kin
from bipedlab.pytree import pytree

# ----------------------------------------------------------------------------- Table I
#: Table I as printed (the digits state each value's precision: :func:`printed_precision`);
#: links: length l, COM distance l_c from the proximal joint (m), mass (kg), inertia about the
#: COM (kg m^2); the foot's a, b, h, c_x, c_y (m); actuators per joint: gear ratio n, mass (kg),
#: reflected inertia J_a (kg m^2), joint viscous damping b (N m s, printed "≈").
TABLE_I = dict(
    body=dict(length="0.390", com="0.185", mass="6.12", inertia="0.021"),
    thigh=dict(length="0.295", com="0.147", mass="0.67", inertia="0.0096"),
    shank=dict(length="0.298", com="0.14", mass="0.55", inertia="0.0069"),
    foot=dict(length="0.183", mass="0.36", inertia="0.0007", a="0.137", b="0.046", h="0.055", c_x="0.014",
              c_y="0.035"),
    hip=dict(n="21", mass="0.84", J="0.0067", b="0.13"),
    knee=dict(n="12", mass="0.84", J="0.0022", b="0.11"),
    ankle=dict(n="21", mass="0.84", J="0.0067", b="0.05"),
)
BODY, THIGH, SHANK, FOOT = ({k: float(v) for k, v in TABLE_I[part].items()} for part in ("body", "thigh", "shank", "foot"))
#: Per joint (hip, knee, ankle): gear ratio n, actuator mass (kg), reflected inertia J_a (kg m^2),
#: joint viscous damping b (N m s).
ACTUATORS = {j: {k: float(v) for k, v in TABLE_I[j].items()} for j in ("hip", "knee", "ankle")}


def printed_precision(part: str, key: str) -> float:
    """The relative precision of a Table I value as printed: half a unit of its last digit over
    the value (6.12 kg: 0.005 / 6.12)."""
    return spec.printed_precision(TABLE_I[part][key])
JOINTS = ("hip", "knee", "ankle")
#: Rotor-plus-gearhead inertia on the motor side (kg m^2), the mean of J_a / n^2 over Table I.
MOTOR_INERTIA = float(np.mean([ACTUATORS[j]["J"] / ACTUATORS[j]["n"] ** 2 for j in JOINTS]))
TOTAL_MASS = 14.3
HEIGHT = 1.2
GRAVITY = 9.81
#: Encoder resolution of Section IV-C1 (rad) per joint [hip, knee, ankle] x 2 legs.
ENCODER_RESOLUTION = np.deg2rad(np.array([4.2e-3, 7.3e-3, 4.2e-3, 4.2e-3, 7.3e-3, 4.2e-3]))
#: Gyro noise density (rad/s/sqrt(Hz)) and low-pass roll-off (Hz), Section IV-A.
GYRO_NOISE_DENSITY = float(np.deg2rad(0.05))
GYRO_CUTOFF_HZ = 50.0

COORDS = ("x", "y", "theta", "theta1", "theta2", "theta3", "theta4", "theta5", "theta6")
JOINT_NAMES = ("hip_1", "knee_1", "ankle_1", "hip_2", "knee_2", "ankle_2")
#: Contact points in constraint order: toe and heel of leg 1, toe and heel of leg 2.
CONTACTS = ("toe_1", "heel_1", "toe_2", "heel_2")
#: Joint-angle index of each knee (for the hyperextension stops phi_knee <= 0).
KNEES = (1, 4)
#: Leg swap (q and qd): leg 1 <-> leg 2.
LEG_SWAP = (0, 1, 2, 6, 7, 8, 3, 4, 5)
LEG_LENGTH = THIGH["length"] + SHANK["length"] + FOOT["h"]

# phi = JOINT_MAP @ q + JOINT_OFFSET
JOINT_MAP = np.zeros((6, 9))
for _leg in range(2):
    _t = 3 + 3 * _leg
    JOINT_MAP[3 * _leg + 0, [_t, 2]] = 1.0, -1.0
    JOINT_MAP[3 * _leg + 1, [_t + 1, _t]] = 1.0, -1.0
    JOINT_MAP[3 * _leg + 2, [_t + 2, _t + 1]] = 1.0, -1.0
JOINT_OFFSET = np.array([0.0, 0.0, np.pi / 2, 0.0, 0.0, np.pi / 2])
#: E in Q_u = E u (9 x 6): the joint torques' generalised forces in absolute coordinates.
E = JOINT_MAP.T.copy()


@pytree
class Setup:
    """What the experimental setup adds to the planar model (built and sourced in
    :mod:`bipedlab.robots.seven_link.setup`): mass_x, mass_y (kg) added to the hip's
    horizontal and vertical inertia (the boom reflected into the plane), load_y (N) of the
    boom's weight resting on the hip, coulomb (6,) N m of drive friction per joint with its
    regularising rate coulomb_rate (rad/s: the friction torque is ``coulomb tanh(phi_dot /
    coulomb_rate)``), and turn_drag (dimensionless) with turn_rate (m/s): the horizontal force
    ``-turn_drag tanh(x_dot / turn_rate)`` times the total normal force on the feet, the
    torsional friction of turning the feet on the ground seen through the boom (applied by
    :func:`bipedlab.robots.seven_link.contact.solve`)."""

    mass_x: jax.Array
    mass_y: jax.Array
    load_y: jax.Array
    coulomb: jax.Array
    coulomb_rate: jax.Array
    turn_drag: jax.Array
    turn_rate: jax.Array


@pytree
class SevenLink:
    """The robot (a frozen pytree): the mechanics as a :class:`~bipedlab.mechanics.coupled.Coupled`
    tree seen through absolute angles, reflected rotor inertias on the joint rates, and
    ``damping (6,)`` N m s and ``gear_ratio (6,)`` per joint [hip, knee, ankle] x 2.
    ``setup``: None for the planar model, or the experimental setup's additions
    (:class:`Setup`); being None or not is structural (part of the compiled program)."""

    coupled: cp.Coupled
    damping: jax.Array
    gear_ratio: jax.Array
    setup: Setup | None = None

    @property
    def nq(self) -> int:
        return 9


def _with_point_mass(mass, com, inertia, pm, at):
    """Body (mass, com, inertia about com) after adding point mass pm at body point ``at``."""
    com, at = np.asarray(com, float), np.asarray(at, float)
    m = mass + pm
    c = (mass * com + pm * at) / m
    I = inertia + mass * np.sum((com - c) ** 2) + pm * np.sum((at - c) ** 2)
    return m, tuple(c), float(I)


def _tree(body=BODY, thigh=THIGH, shank=SHANK, foot=FOOT, actuator_mass=(0.84, 0.84, 0.84), gravity=GRAVITY):
    """Tree in relative coordinates; link frames have +x along the distal-to-proximal axis
    (feet: heel-to-toe), origins at the proximal joint (the hip for the body)."""
    m_hip, m_knee, m_ankle = actuator_mass
    bm, bc, bi = _with_point_mass(body["mass"], (body["com"], 0.0), body["inertia"], 2 * m_hip, (0.0, 0.0))
    bodies = [Body("body", None, bm, bc, bi)]
    tm, tc, ti = _with_point_mass(thigh["mass"], (-thigh["com"], 0.0), thigh["inertia"], m_knee,
                                  (-thigh["length"], 0.0))
    sm, sc, si = _with_point_mass(shank["mass"], (-shank["com"], 0.0), shank["inertia"], m_ankle,
                                  (-shank["length"], 0.0))
    points = [Point("hip", "body", (0.0, 0.0)), Point("head", "body", (body["length"], 0.0))]
    for leg in ("1", "2"):
        bodies += [
            Body(f"thigh_{leg}", "body", tm, tc, ti),
            Body(f"shank_{leg}", f"thigh_{leg}", sm, sc, si, offset=(-thigh["length"], 0.0)),
            Body(f"foot_{leg}", f"shank_{leg}", foot["mass"], (foot["c_x"], -foot["c_y"]), foot["inertia"],
                 offset=(-shank["length"], 0.0)),
        ]
        points += [
            Point(f"toe_{leg}", f"foot_{leg}", (foot["a"], -foot["h"])),
            Point(f"heel_{leg}", f"foot_{leg}", (-foot["b"], -foot["h"])),
            Point(f"knee_{leg}", f"thigh_{leg}", (-thigh["length"], 0.0)),
            Point(f"ankle_{leg}", f"shank_{leg}", (-shank["length"], 0.0)),
        ]
    return build_model(bodies, points, gravity=gravity, actuated=())


def _tree_map() -> np.ndarray:
    """q_tree = T q: tree joints are the differences of absolute angles (no offsets)."""
    T = np.zeros((9, 9))
    T[0, 0] = T[1, 1] = T[2, 2] = 1.0
    for leg in range(2):
        t = 3 + 3 * leg
        T[t, [t, 2]] = 1.0, -1.0
        T[t + 1, [t + 1, t]] = 1.0, -1.0
        T[t + 2, [t + 2, t + 1]] = 1.0, -1.0
    return T


def model(gear_ratios=(21.0, 12.0, 21.0), damping=None, scale_damping_with_gear: bool = True,
          gravity: float = GRAVITY, scale: dict | None = None) -> SevenLink:
    """The seven-link biped of Table I.

    gear_ratios (hip, knee, ankle): reflected inertias are n^2 J_m (Table I's values for the
    default 21, 12, 21). damping: joint viscous damping (N m s, hip, knee, ankle); default
    Table I's, multiplied by (n / n_Table I)^2 when scale_damping_with_gear.
    scale: {(part, key): factor} on Table I's values (a part of :data:`TABLE_I`; an actuator's
    mass, J or b for both legs' joint): the robot the table's uncertainty allows, e.g.
    ``{("body", "mass"): 1.01}``. Every scaled value is data of the compiled programs.
    """
    scale = dict(scale or {})
    bad = [k for k in scale if k[0] not in TABLE_I or k[1] not in TABLE_I[k[0]] or k[1] == "n"]
    if bad:
        raise ValueError(f"seven-link: no Table I value {bad} to scale")
    links = {part: {k: v * scale.get((part, k), 1.0) for k, v in d.items()}
             for part, d in (("body", BODY), ("thigh", THIGH), ("shank", SHANK), ("foot", FOOT))}
    act = {j: {k: v * scale.get((j, k), 1.0) for k, v in ACTUATORS[j].items()} for j in JOINTS}
    n = np.asarray(gear_ratios, float)
    n0 = np.array([act[j]["n"] for j in JOINTS])
    if damping is None:
        b = np.array([act[j]["b"] for j in JOINTS])
        if scale_damping_with_gear:
            b = b * (n / n0) ** 2
    else:
        b = np.asarray(damping, float)
    J = n**2 * MOTOR_INERTIA
    if np.allclose(n, n0):
        J = np.array([act[j]["J"] for j in JOINTS])  # Table I exactly
    rotors = [(f"rotor_{JOINT_NAMES[3 * leg + k]}", float(J[k]), JOINT_MAP[3 * leg + k]) for leg in range(2)
              for k in range(3)]
    tree = _tree(links["body"], links["thigh"], links["shank"], links["foot"],
                 actuator_mass=tuple(act[j]["mass"] for j in JOINTS), gravity=gravity)
    c = cp.coupled(tree, _tree_map(), rotors, COORDS)
    return SevenLink(c, jnp.asarray(np.tile(b, 2)), jnp.asarray(np.tile(n, 2)))


# ----------------------------------------------------------------------------- maps
def joint_angles(q) -> jax.Array:
    """phi (6,) from q (Section II)."""
    return jnp.asarray(JOINT_MAP) @ q + jnp.asarray(JOINT_OFFSET)


def joint_rates(qd) -> jax.Array:
    return jnp.asarray(JOINT_MAP) @ qd


def absolute_angles(theta, phi) -> jax.Array:
    """Link angles [theta, theta_1..theta_6] from the body angle and the joint angles
    (Section V-A)."""
    th = [theta]
    for leg in range(2):
        a = theta + phi[3 * leg]
        b = a + phi[3 * leg + 1]
        c = b + phi[3 * leg + 2] - jnp.pi / 2
        th += [a, b, c]
    return jnp.stack(th)


# ----------------------------------------------------------------------------- dynamics
def _setup_mass(s: Setup) -> jax.Array:
    """The setup's added mass matrix (9 x 9): diag(mass_x, mass_y, 0, ...)."""
    return jnp.zeros((9, 9)).at[0, 0].set(s.mass_x).at[1, 1].set(s.mass_y)


def _setup_load(s: Setup) -> jax.Array:
    """The setup's added gravity force (9,): load_y on the hip's height."""
    return jnp.zeros(9).at[1].set(s.load_y)


def mass_matrix(r: SevenLink, q) -> jax.Array:
    """M(q) (9 x 9), links plus reflected rotor inertias (plus the setup's added inertia)."""
    M = cp.mass_matrix(r.coupled, q)
    return M if r.setup is None else M + _setup_mass(r.setup)


def bias(r: SevenLink, q, qd) -> jax.Array:
    """h + G of eq. 1 (Coriolis, centrifugal and gravity), without the joint damping."""
    h = cp.bias(r.coupled, q, qd)
    return h if r.setup is None else h + _setup_load(r.setup)


def drive_friction(r: SevenLink, qd) -> jax.Array:
    """Joint torques (6,) of the setup's Coulomb drive friction, ``-F_c tanh(phi_dot / rate)``
    (zero for the planar model)."""
    if r.setup is None:
        return jnp.zeros(6)
    return -r.setup.coulomb * jnp.tanh(joint_rates(qd) / r.setup.coulomb_rate)


def damping_force(r: SevenLink, qd) -> jax.Array:
    """Generalised force of the joint viscous damping, -E diag(b) phi_dot, plus the setup's
    Coulomb drive friction (:func:`drive_friction`)."""
    f = -jnp.asarray(E) @ (r.damping * joint_rates(qd))
    return f if r.setup is None else f + jnp.asarray(E) @ drive_friction(r, qd)


def actuation(u) -> jax.Array:
    """Q_u = E u."""
    return jnp.asarray(E) @ u


def kinetic_energy(r: SevenLink, q, qd) -> jax.Array:
    T = cp.kinetic_energy(r.coupled, q, qd)
    return T if r.setup is None else T + 0.5 * (r.setup.mass_x * qd[0] ** 2 + r.setup.mass_y * qd[1] ** 2)


def potential_energy(r: SevenLink, q) -> jax.Array:
    V = cp.potential_energy(r.coupled, q)
    return V if r.setup is None else V + r.setup.load_y * q[1]


def energy(r: SevenLink, q, qd) -> jax.Array:
    return kinetic_energy(r, q, qd) + potential_energy(r, q)


def total_mass(r: SevenLink) -> jax.Array:
    return jnp.sum(r.coupled.tree.mass)


def point_position(r: SevenLink, q, name: str) -> jax.Array:
    return cp.point_position(r.coupled, q, name)


def point_jacobian(r: SevenLink, q, name: str) -> jax.Array:
    return cp.point_jacobian(r.coupled, q, name)


def contact_kinematics(r: SevenLink, q, qd):
    """Positions (4, 2), velocities (4, 2), Jacobians (4, 2, 9) and J-dot qd (4, 2) of the
    toe and heel points in :data:`CONTACTS` order."""
    return dynamics_terms(r, q, qd)[2:]


def skeleton(r: SevenLink, q) -> dict:
    """World positions (2,) of the named points for drawing: head, hip, knees, ankles, toes,
    heels."""
    names = ("head", "hip", "knee_1", "ankle_1", "toe_1", "heel_1", "knee_2", "ankle_2", "toe_2", "heel_2")
    return {n: point_position(r, q, n) for n in names}


# ----------------------------------------------------------------------------- postures
def configuration(theta, phi, anchor: str = "heel_1", anchor_xy=(0.0, 0.0), r: SevenLink | None = None):
    """q with the given body angle and joint angles, translated so that the named point is at
    anchor_xy."""
    r = r or model()
    th = absolute_angles(jnp.asarray(theta, float), jnp.asarray(phi, float))
    q0 = jnp.concatenate([jnp.zeros(2), th])
    p = point_position(r, q0, anchor)
    return q0.at[:2].set(jnp.asarray(anchor_xy, float) - p)


def _mass_check() -> float:
    """Total modelled mass (kg), for the docstring's 14.32 kg."""
    return float(total_mass(model()))


def dynamics_terms(r: SevenLink, q, qd):
    """(M, h, P, V, J, Jdot_qd) from one pass over the tree: mass matrix, bias (Coriolis,
    centrifugal, gravity), and the contact points' positions, velocities, Jacobians and
    velocity-product accelerations (:func:`contact_kinematics`)."""
    c = r.coupled
    T = jnp.asarray(np.asarray(c.T))
    fr = kin.frames(c.tree, T @ q)
    vel = kin.velocities(c.tree, fr, T @ qd)
    M = cp.dense(cp.mass_matrix_entries(c, fr), q[0])
    h = jnp.stack(cp.bias_entries(c, fr, vel))
    if r.setup is not None:
        M = M + _setup_mass(r.setup)
        h = h + _setup_load(r.setup)
    tree = c.tree
    P, V, A, J = [], [], [], []
    zero = jnp.zeros_like(q[0])
    for name in CONTACTS:
        k = tree.point_index(name)
        b = tree.point_bodies[k]
        p, v, a = kin.point_velocity_accel(tree, fr, vel, b, kin.point_offset(tree, k))
        cols = kin.jacobian_columns(tree, fr, b, p)
        Jt = jnp.stack([jnp.stack([cols[j][i] + zero if j in cols else zero for j in range(tree.nq)])
                        for i in range(2)])
        P.append(jnp.stack(p))
        V.append(jnp.stack(v))
        A.append(jnp.stack(a))
        J.append(Jt @ T)
    return M, h, jnp.stack(P), jnp.stack(V), jnp.stack(J), jnp.stack(A)
