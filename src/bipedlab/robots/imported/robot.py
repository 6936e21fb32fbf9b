"""A point-foot planar biped read from an MJCF or URDF file, set up for HZD walking.

Given the file's robot (:func:`bipedlab.io.read`) and the names of the stance and swing
points (sites), :func:`hzd_study` derives everything the HZD study needs from the model:

* **the legs and their swap**: each foot's chain of bodies from the root; the chains part at
  the last body they share (the hip's parent), and the two leg subtrees from there are paired
  body by body (children in file order). The pairing must be a symmetry: paired bodies have
  the same joint type, mass, COM, inertia, joint position and axis (to 1e-9), and the swing
  point is the stance point's image. The leg swap exchanges each pair's coordinates;
* **the outputs**: the actuated coordinates, in the file's actuator order (one degree of
  underactuation: the stance angle is free);
* **the phase**: the stance leg's absolute angle, theta = -psi with psi the angle of the
  hip-to-stance-point line from the downward vertical (counter-clockwise positive), linearised
  at the reference configuration: c = -d psi / d q_s (exact for a two-segment leg of equal
  segments, theta = -(root + hip + knee / 2));
* **the torque limits** of the actuators, as constraints of the design (none where the file
  sets none);
* **the initial guess**: legs at +-0.318 rad from the vertical (a 0.5 m step for a 0.8 m
  leg), the root leaning 0.05 rad forward, the joints between each hip and its foot bent 0.1
  rad (towards the side their range allows more, backwards by default), the stance leg turning
  at 2 v (0.8 m / L) rad/s and the swing hip at 0.75 of that, and the swing knee's free Bézier
  coefficients at 0.6 rad of bend for clearance.
"""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.gait import optimize as go
from bipedlab.gait import study as hzd_study
from bipedlab.io import Description, read
from bipedlab.mechanics.kinematics import frames, point_position
from bipedlab.mechanics.stance import Stance
from bipedlab.mechanics.tree import Model

ROBOT = "model"
#: Half the angle between the legs at impact in the initial guess, rad.
LEG_ANGLE_GUESS = 0.318
#: Forward lean of the root body in the initial guess, rad.
LEAN_GUESS = -0.05
#: Bend of each joint between hip and foot in the initial guess, rad (sign from the range).
BEND_GUESS = 0.1
#: Bend of the swing knee's free Bézier coefficients in the guess, rad.
SWING_BEND_GUESS = 0.6
#: Leg length at which the stance leg of the guess turns at 2 v rad/s, m.
REFERENCE_LEG = 0.8
TOL = 1e-9


@dataclasses.dataclass(frozen=True)
class Legs:
    """The leg structure found in a model: the stance and swing leg subtrees' bodies (paired,
    hip first), the bodies from each hip to its foot, and the leg swap of q."""

    stance_bodies: tuple[int, ...]
    swing_bodies: tuple[int, ...]
    stance_path: tuple[int, ...]
    swing_path: tuple[int, ...]
    swap: tuple[int, ...]


def _children(model: Model, b: int) -> list[int]:
    return [c for c in range(model.nb) if model.parents[c] == b]


def _point(desc: Description, name: str, role: str) -> int:
    names = desc.model.point_names
    if name not in names:
        known = ", ".join(names) or "none"
        raise ValueError(f"{desc.source}: site '{name}' (the {role} point) is not in the file; sites: {known}")
    return names.index(name)


def find_legs(desc: Description, stance: str, swing: str) -> Legs:
    """The legs of the stance and swing points and their swap; ValueError naming the file
    and the bodies when the two legs are not mirror images."""
    m = desc.model
    src = desc.source
    si, wi = _point(desc, stance, "stance"), _point(desc, swing, "swing")
    if si == wi:
        raise ValueError(f"{src}: the stance and swing points are the same site '{stance}'")
    cs, cw = m.ancestors(m.point_bodies[si]), m.ancestors(m.point_bodies[wi])
    k = 0
    while k < min(len(cs), len(cw)) and cs[k] == cw[k]:
        k += 1
    if k == len(cs) or k == len(cw):
        raise ValueError(f"{src}: sites '{stance}' and '{swing}' are not on two different legs "
                         f"(one hangs from the other's body '{m.body_names[cs[-1] if k == len(cw) else cw[-1]]}')")
    pairs: list[tuple[int, int]] = []

    def same(a, b) -> bool:
        a, b = np.asarray(a, float), np.asarray(b, float)
        return bool(np.all(np.abs(a - b) <= TOL * np.maximum(1.0, np.abs(a))))

    def match(a: int, b: int) -> None:
        na, nb_ = m.body_names[a], m.body_names[b]
        for what, x, y in (("mass", m.mass[a], m.mass[b]), ("COM", m.com[a], m.com[b]),
                           ("inertia", m.inertia[a], m.inertia[b]), ("joint position", m.offset[a], m.offset[b]),
                           ("joint axis", m.axis[a], m.axis[b])):
            if not same(x, y):
                raise ValueError(f"{src}: bodies '{na}' and '{nb_}' pair up as left and right but differ in {what}")
        if m.joints[a] != m.joints[b]:
            raise ValueError(f"{src}: bodies '{na}' and '{nb_}' pair up as left and right but differ in joint type")
        pairs.append((a, b))
        ca, cb = _children(m, a), _children(m, b)
        if len(ca) != len(cb):
            raise ValueError(f"{src}: bodies '{na}' and '{nb_}' pair up as left and right but carry "
                             f"{len(ca)} and {len(cb)} bodies")
        for x, y in zip(ca, cb):
            match(x, y)

    match(cs[k], cw[k])
    image = dict(pairs)
    if image.get(m.point_bodies[si]) != m.point_bodies[wi] or not same(m.point_offset[si], m.point_offset[wi]):
        raise ValueError(f"{src}: the swing point '{swing}' is not the mirror image of the stance point '{stance}'")
    swap = list(range(m.nq))
    for a, b in pairs:
        ia, ib = m.dof_of_body(a), m.dof_of_body(b)
        swap[ia], swap[ib] = ib, ia
    return Legs(tuple(a for a, _ in pairs), tuple(b for _, b in pairs), tuple(cs[k:]), tuple(cw[k:]), tuple(swap))


def _leg_angle(model: Model, hip_body: int, point: int):
    """psi(q_s): angle of the hip-to-point line from the downward vertical (CCW positive)."""
    def psi(qs):
        q = jnp.concatenate([jnp.zeros(2), qs])
        hip = frames(model, q).origin[hip_body]
        p = point_position(model, q, point)
        return jnp.arctan2(p[0] - hip[0], -(p[1] - hip[1]))
    return psi


def leg_length(model: Model, legs: Legs, stance_point: int) -> float:
    q = jnp.zeros(model.nq)
    hip = frames(model, q).origin[legs.stance_path[0]]
    p = point_position(model, q, stance_point)
    return float(jnp.hypot(p[0] - hip[0], p[1] - hip[1]))


@dataclasses.dataclass(frozen=True)
class Setup:
    """The HZD study of an imported biped and what its guess needs."""

    study: hzd_study.HZDStudy
    desc: Description
    legs: Legs
    stance_name: str
    swing_name: str
    c_swing: np.ndarray
    leg: float


def hzd_setup(desc: Description, stance: str, swing: str) -> Setup:
    """The HZD study of the biped in ``desc`` walking on ``stance`` with ``swing`` the other
    foot (see the module docstring). ValueError naming the file and the element."""
    m = desc.model
    legs = find_legs(desc, stance, swing)
    si, wi = m.point_index(stance), m.point_index(swing)
    n = m.nq - 2
    if m.nu != n - 1:
        raise ValueError(f"{desc.source}: {m.nu} actuated joints of {n - 1}; the HZD walking study needs every "
                         "joint actuated (one degree of underactuation, the stance foot)")
    H0 = np.zeros((m.nu, n))
    for r, i in enumerate(m.actuated):
        H0[r, i - 2] = 1.0
    zero = jnp.zeros(n)
    c = -np.asarray(jax.grad(_leg_angle(m, legs.stance_path[0], si))(zero))
    c_sw = -np.asarray(jax.grad(_leg_angle(m, legs.swing_path[0], wi))(zero))
    if abs(c[0]) < 1e-9:
        raise ValueError(f"{desc.source}: the stance leg's angle does not depend on the root angle")
    lim = tuple(float(v) for v in desc.torque_limits)
    st = Stance(m, si, wi, legs.swap)
    study = hzd_study.HZDStudy(ROBOT, st, H0, c, torque_limits=lim if any(np.isfinite(lim)) else None)
    return Setup(study, desc, legs, stance, swing, c_sw, leg_length(m, legs, si))


def load(path, stance: str, swing: str, plane: str = "xz") -> Setup:
    return hzd_setup(read(path, plane), stance, swing)


def _bend_sign(desc: Description, i: int) -> float:
    lo, hi = desc.ranges[i]
    if np.isfinite(lo) and np.isfinite(hi) and (lo + hi) != 0:
        return 1.0 if (lo + hi) > 0 else -1.0
    return -1.0


def gait_guess(s: Setup, speed: float) -> np.ndarray:
    """The pre-impact stance state of the initial guess (see the module docstring)."""
    m = s.desc.model
    n = m.nq - 2
    q = np.zeros(n)
    qd = np.zeros(n)
    q[0] = LEAN_GUESS
    w = 2.0 * speed * (REFERENCE_LEG / s.leg)
    for path, c, target, rate in ((s.legs.stance_path, s.study.c, LEG_ANGLE_GUESS, -w),
                                  (s.legs.swing_path, s.c_swing, -LEG_ANGLE_GUESS, 0.75 * w)):
        hip = m.dof_of_body(path[0]) - 2
        for b in path[1:]:
            i = m.dof_of_body(b)
            q[i - 2] = _bend_sign(s.desc, i) * BEND_GUESS
        rest = float(c @ q) - c[hip] * q[hip]
        q[hip] = (target - rest) / c[hip]
        qd[hip] = rate
    return np.concatenate([q, qd])


def initial_guess(s: Setup, prob: go.GaitProblem) -> np.ndarray:
    """Decision vector of the initial guess, the swing knee's free coefficients bent."""
    x0 = go.initial_guess(prob, gait_guess(s, prob.speed))
    z, free = go.unpack(prob, x0)
    free = np.array(free)
    m = s.desc.model
    if len(s.legs.swing_path) > 1:
        i = m.dof_of_body(s.legs.swing_path[1])
        rows = [r for r, a in enumerate(m.actuated) if a == i]
        if rows:
            free[rows[0], :] = _bend_sign(s.desc, i) * SWING_BEND_GUESS
    return go.pack(z, free)
