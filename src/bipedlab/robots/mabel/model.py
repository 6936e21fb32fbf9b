"""MABEL's dynamic models: the 13-DoF hopping model and the 9-DoF rigid-cable model.

Coordinates of the 13-DoF model (Section VIII-A's q_h, reordered so the motor and spring
coordinates, which couple only to their own leg and the torso, come last)::

    x, y            hip position in the sagittal plane (m)
    tor             torso angle from the upward vertical (rad, counter-clockwise positive)
    la_L, ls_L      left leg angle (relative to the torso; pi = leg straight down) and leg shape
    la_R, ls_R      right leg
    bsp_L, bsp_R    B_spring pulley angles (spring deflection; > 0 compressed)
    mla_L, mls_L    left leg-angle and leg-shape motor angles (relative to the torso)
    mla_R, mls_R    right

The 9-DoF model (the HZD paper's q_e, rigid cables) drops q_LS and q_mLA through
``q_LS = q_mLS/31.42 + q_Bsp/5.18`` and ``q_mLA = -23.53 q_LA``; its coordinates are
``x, y, tor, la_L, la_R, bsp_L, bsp_R, mls_L, mls_R``. Both are the same
:class:`~bipedlab.mechanics.coupled.Coupled` tree (torso; per leg thigh, shin, the C_spring
and C_shin links) seen through a constant map, so they agree exactly where cables are rigid.

The boom (Table VII) is modelled as in the papers by its mass and inertia only: moving the hip
by (dx, dy) turns the boom by (dx, dy)/R about its pivot, adding ``I_boom / R^2`` of inertia
to both hip translations, and its weight adds ``m_boom g r_com / R`` per metre of hip height.

Generalised forces (eq. 29): motor torque ``(u + b) / K_T`` on each motor coordinate (eq. 17)
with viscous friction ``-mu q_m_dot`` (Table V); the unilateral spring and hard stop (eq. 30)
on B_spring; cable stretch (eqs. 25-27); and the compliant ground at each toe.
"""
from __future__ import annotations


import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.pytree import pytree, static_field
from bipedlab.mechanics import Body, Point, build_model
from bipedlab.contact import compliant as cg
from bipedlab.mechanics import coupled as cp
from bipedlab.robots.mabel import tables as tb
from bipedlab.robots.mabel import transmission as tr

COORDS_13 = ("x", "y", "tor", "la_L", "ls_L", "la_R", "ls_R", "bsp_L", "bsp_R", "mla_L", "mls_L", "mla_R", "mls_R")
COORDS_9 = ("x", "y", "tor", "la_L", "la_R", "bsp_L", "bsp_R", "mls_L", "mls_R")
TOES = ("toe_L", "toe_R")
#: The papers' coordinate orders: q_h of the identification paper (Section VIII-A) and q_e of
#: the HZD paper (Section II-B1, with L in stance): ``paper_order`` maps to them.
PAPER_Q_H = ("la_L", "mla_L", "ls_L", "mls_L", "bsp_L", "la_R", "mla_R", "ls_R", "mls_R", "bsp_R", "tor", "x", "y")
PAPER_Q_E = ("la_L", "mls_L", "bsp_L", "la_R", "mls_R", "bsp_R", "tor", "x", "y")
_H = {c: i for i, c in enumerate(COORDS_13)}
#: The published values a model can be built with scaled (``scale``: pairs (name, factor) of
#: :func:`hopping_model`, :func:`rigid_model`, :func:`drivetrain`), each a row of
#: :mod:`~bipedlab.robots.mabel.tables`; for the sensitivity of the walking experiments
#: (:mod:`bipedlab.robots.mabel.walking.sensitivity`). Both sides' values scale together.
SCALABLE = {
    "torso mass": "Table VII", "torso COM height": "Table VII", "torso inertia": "Table VII",
    "thigh mass": "Table VII", "thigh inertia": "Table VII", "shin mass": "Table VII", "shin inertia": "Table VII",
    "thigh length": "THIGH_LENGTH", "shin length": "SHIN_LENGTH",
    "boom mass": "Table VII", "boom inertia": "Table VII",
    "leg-shape rotor inertia": "Table VIII", "leg-angle rotor inertia": "Table VIII",
    "spring stiffness": "Fig. 19", "spring damping": "Table VI", "motor friction": "Table V",
    "torque capacity": "HZD paper",
}


def factors(scale) -> dict:
    """{name: factor} of ``scale`` (pairs or a mapping), every name checked against SCALABLE."""
    f = dict(scale or ())
    unknown = sorted(set(f) - set(SCALABLE))
    if unknown:
        raise ValueError(f"unknown MABEL parameter(s) {', '.join(unknown)}; known: {', '.join(SCALABLE)}")
    return f


#: h-coordinate index of each actuator's motor, in tables.ACTUATORS order.
MOTOR_INDEX = tuple(_H[a[:3].lower() + "_" + a[-1]] for a in tb.ACTUATORS)


def _tree(f: dict):
    thigh, shin = tb.THIGH_LENGTH * f.get("thigh length", 1.0), tb.SHIN_LENGTH * f.get("shin length", 1.0)
    bodies = [_body(f, "torso", None)]
    points = [Point("hip", "torso", (0.0, 0.0)), Point("head", "torso", (0.0, 0.6))]
    for s in tb.SIDES:
        bodies += [_body(f, "thigh", "torso", s), _body(f, "shin", f"thigh_{s}", s, (0.0, thigh)),
                   _body(f, "csp", "torso", s), _body(f, "csh", "torso", s)]
        points += [Point(f"toe_{s}", f"shin_{s}", (0.0, shin)), Point(f"knee_{s}", f"thigh_{s}", (0.0, thigh))]
    return build_model(bodies, points, base_names=("x", "y", "tor"), actuated=())


def link(kind: str, scale=()) -> tuple:
    """Table VII's (mass, COM, inertia about the joint) of link ``kind``, scaled by ``scale``."""
    f = factors(scale)
    m, com, i_joint = tb.LINKS[kind]
    return (m * f.get(f"{kind} mass", 1.0), (com[0], com[1] * f.get(f"{kind} COM height", 1.0)),
            i_joint * f.get(f"{kind} inertia", 1.0))


def _body(f: dict, kind, parent, side=None, offset=(0.0, 0.0)):
    m, com, i_joint = link(kind, f)
    i_com = i_joint - m * (com[0] ** 2 + com[1] ** 2)
    name = kind if side is None else f"{kind}_{side}"
    return Body(name, parent, m, com, i_com, offset=offset)


def _tree_map() -> np.ndarray:
    """T with tree coordinates (x, y, tor, then per leg thigh, shin-rel-thigh, csp, csh) = T q_h."""
    rates_csp = tr.linkage_rates()["Csp"]
    T = np.zeros((11, 13))
    T[0, 0] = T[1, 1] = T[2, 2] = 1.0
    for k, s in enumerate(tb.SIDES):
        la, ls = _H[f"la_{s}"], _H[f"ls_{s}"]
        row = 3 + 4 * k
        T[row, [la, ls]] = 1.0, 1.0            # C_thigh = la + ls
        T[row + 1, ls] = -2.0                  # shin relative to thigh = C_shin - C_thigh
        T[row + 2, [la, ls]] = rates_csp[0], rates_csp[1]  # C_spring (= 2 ls with MABEL's radii)
        T[row + 3, [la, ls]] = 1.0, -1.0        # C_shin = la - ls
    return T


def _rotors(f: dict):
    rates = tr.pulley_rates()
    out = []
    for s in tb.SIDES:
        idx = [_H[f"{c}_{s}"] for c in tr.LOCAL]
        for name, local in rates.items():
            ratio = np.zeros(13)
            ratio[2] = 1.0  # absolute rate = torso rate + relative rate
            ratio[idx] += local
            if name in ("mLA", "mLS"):
                act = f"{name}_{s}"
                what = "leg-shape" if name == "mLS" else "leg-angle"
                inertia = tb.ALPHA[act] * tb.ROTOR_INERTIA[name] * f.get(f"{what} rotor inertia", 1.0)
            else:
                inertia = tb.PULLEY_INERTIA[name]
            out.append((f"{name}_{s}", inertia, ratio))
    R = tb.BOOM["radius"]
    boom = tb.BOOM["inertia"] * f.get("boom inertia", 1.0)
    out.append(("boom_yaw", boom, np.eye(13)[0] / R))
    out.append(("boom_pitch", boom, np.eye(13)[1] / R))
    return out


def rigid_map() -> np.ndarray:
    """E with q_h = E q_e (13 x 9): rigid cables."""
    E = np.zeros((13, 9))
    e = {c: i for i, c in enumerate(COORDS_9)}
    for c in ("x", "y", "tor", "la_L", "la_R", "bsp_L", "bsp_R", "mls_L", "mls_R"):
        E[_H[c], e[c]] = 1.0
    for s in tb.SIDES:
        E[_H[f"ls_{s}"], e[f"mls_{s}"]] = 1.0 / tb.GEAR_LS
        E[_H[f"ls_{s}"], e[f"bsp_{s}"]] = 1.0 / tb.GEAR_BSP
        E[_H[f"mla_{s}"], e[f"la_{s}"]] = tb.GEAR_LA
    return E


@pytree
class Drivetrain:
    """Actuator and compliance parameters (leaves). Per actuator (tables.ACTUATORS order):
    kt, bias (N m), friction (N m s/rad), cable_k (N m/rad), cable_d (N m s/rad); per leg
    (L, R): spring_k (N m/rad); shared: spring_d (Kd_B), kd1 (N m/rad^3), kvd1 (N m s/rad),
    kvd2 (N m (s/rad)^0.5); torque_limit per actuator (N m)."""

    kt: jax.Array
    bias: jax.Array
    friction: jax.Array
    cable_k: jax.Array
    cable_d: jax.Array
    spring_k: jax.Array
    spring_d: jax.Array
    kd1: jax.Array
    kvd1: jax.Array
    kvd2: jax.Array
    torque_limit: jax.Array



def drivetrain(scale=()) -> Drivetrain:
    """The published drivetrain (``scale``: as :func:`hopping_model`'s)."""
    k = factors(scale)
    f = lambda v, name=None: jnp.asarray(v, dtype=jnp.float64) * k.get(name, 1.0)  # noqa: E731
    per = lambda d, name=None: f([d[a] for a in tb.ACTUATORS], name)  # noqa: E731
    return Drivetrain(
        kt=per(tb.KT), bias=per(tb.BIAS), friction=per(tb.FRICTION, "motor friction"), cable_k=per(tb.CABLE_K),
        cable_d=per(tb.CABLE_D), spring_k=f([tb.SPRING_K[s] for s in tb.SIDES], "spring stiffness"),
        spring_d=f(tb.SPRING_DAMPING, "spring damping"),
        kd1=f(tb.HARD_STOP["kd1"]), kvd1=f(tb.HARD_STOP["kvd1"]), kvd2=f(tb.HARD_STOP["kvd2"]),
        torque_limit=f([tb.TORQUE_CAPACITY[a[:3]] for a in tb.ACTUATORS], "torque capacity"),
    )


@pytree
class Mabel:
    """A MABEL model (frozen pytree): the coupled mechanism in the variant's coordinates,
    the drivetrain, the ground, and the static map E with ``q_h = E q``."""

    body: cp.Coupled
    drive: Drivetrain
    ground: cg.CompliantGround
    E: tuple = static_field()

    @property
    def n(self) -> int:
        return self.body.n

    @property
    def rigid(self) -> bool:
        return self.body.n == 9

    @property
    def coord_names(self) -> tuple[str, ...]:
        return self.body.coord_names



def hopping_model(ground=None, drive=None, scale=()) -> Mabel:
    """The 13-DoF model with cable stretch (Section VIII-A). ``scale``: pairs (name, factor)
    of :data:`SCALABLE` values built scaled (the drivetrain's only where ``drive`` is not given);
    the model's leaves change, its structure does not, so compiled programs taking the model as
    an argument serve every scaled one."""
    f = factors(scale)
    w = np.zeros(13)
    w[1] = tb.BOOM["mass"] * f.get("boom mass", 1.0) * 9.81 * tb.BOOM["com"] / tb.BOOM["radius"]
    body = cp.coupled(_tree(f), _tree_map(), _rotors(f), COORDS_13, weight=w)
    return Mabel(body, drive or drivetrain(scale), ground or cg.make(**tb.GROUND), cp.static_matrix(np.eye(13)))


def rigid_model(ground=None, drive=None, scale=()) -> Mabel:
    """The 9-DoF rigid-cable model (HZD paper, q_e); ``scale`` as :func:`hopping_model`'s."""
    full = hopping_model(ground, drive, scale)
    E = rigid_map()
    return full.replace(body=cp.restrict(full.body, E, COORDS_9), E=cp.static_matrix(E))


# ----- maps between coordinates ------------------------------------------------------------
def full_coordinates(m: Mabel, q) -> jax.Array:
    """q_h (13) for the model's coordinates q."""
    return jnp.asarray(np.asarray(m.E)) @ q


def paper_order(m: Mabel, q) -> jax.Array:
    """q (or qd) in the paper's order: q_h for the 13-DoF model, q_e for the 9-DoF model."""
    order = PAPER_Q_E if m.rigid else PAPER_Q_H
    return jnp.stack([q[m.coord_names.index(c)] for c in order])


def named(m: Mabel, q) -> dict:
    """Every 13-DoF coordinate by name (leg shape and motor angles included for 9-DoF)."""
    qh = full_coordinates(m, q)
    return {c: qh[i] for i, c in enumerate(COORDS_13)}
