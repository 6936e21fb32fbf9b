"""Planar robot descriptions read from MJCF and URDF through MuJoCo's own compiler.

MuJoCo parses and compiles both formats (``mujoco.MjSpec.from_file``, static bodies kept
apart so that a URDF's root link keeps its mass); this module reads the compiled model at its
reference configuration (``qpos0``, every joint at its ``ref``) and keeps the planar subset:

* the plane is spanned by two world axes ``plane`` (default ``"xz"``: x forward, z up, the
  normal -y, as :func:`bipedlab.mechanics.to_mjcf` writes); bipedlab's (x, y) are those two
  axes and its counter-clockwise angles turn about their cross product;
* the root is the one body under the world that moves or has mass. Either it carries a planar
  floating joint, two slide joints along the plane's axes (either first) and then one hinge normal
  to it (their names become the base coordinates' names), or it carries no joint at all
  (welded to the world, as a URDF's root link is): then a floating base is added at the
  root's frame origin, and the user's choice of stance point pins it later;
* every other body has one hinge normal to the plane or one slide in it; a body with no joint
  is welded to its parent and merged into it (mass, COM, inertia about the plane normal);
* masses, COMs (in-plane part) and the inertia about the plane normal through the COM; a COM
  off the plane changes nothing in the planar dynamics, whose joints all turn about the
  normal, so it is accepted;
* sites become named points (feet, toes, heels) of the body that carries them, and so does
  the origin of every body welded to its parent (a URDF's fixed-joint frames: a foot link);
* joint armature becomes a rotor inertia on that coordinate;
* actuators on joints give the actuated coordinates, gear ratios and the joint torque
  limits (from ``forcerange``, from ``ctrlrange`` times the gain for a motor, or from the
  joint's ``actuatorfrcrange``, e.g. a URDF's ``effort``); with no actuator in the file every
  joint is actuated; joint ranges are kept.

Anything else (a ball or free joint, an axis out of the plane, a body with two joints, an
equality constraint closing a loop, a tendon or site transmission, joint springs or damping,
gravity out of the plane) is rejected with one line naming the element and why. Coordinates
are ``q = sign * (qpos - qpos0)`` joint by joint (sign -1 where a hinge turns about the
opposite normal), plus the reference anchor for the base position.
"""
from __future__ import annotations

import contextlib
import dataclasses
import os
import warnings
from typing import Sequence

import numpy as np

from bipedlab.inputs import byte_order_mark, model_text
from bipedlab.mechanics.tree import PRISMATIC, REVOLUTE, Body, Model, Point, Rotor, build_model

AXES = {"x": 0, "y": 1, "z": 2}
#: how far (relative) a hinge axis may lean out of the plane normal, or a slide out of the plane
AXIS_TOL = 1e-9


@dataclasses.dataclass(frozen=True)
class Description:
    """A robot read from a file: the mechanics ``model`` and what the file says beyond it.

    qpos_index / qpos_sign / qpos_offset: MuJoCo's qpos entry, sign and reference behind each
    coordinate of q (``q = offset + sign (qpos - qpos0)``; index -1 for an added base
    coordinate). actuators: actuator names, one per actuated coordinate (``model.actuated``
    order); gear: their gear ratios; torque_limits: the largest joint torque of each
    actuated coordinate, N m (inf where the file sets none). ranges: (nq, 2) joint ranges in
    q's units (+-inf where unlimited). added_base: True when the root was welded to the world
    and the floating base was added here."""

    source: str
    model: Model
    qpos_index: tuple[int, ...]
    qpos_sign: tuple[float, ...]
    qpos_offset: tuple[float, ...]
    actuators: tuple[str, ...]
    gear: tuple[float, ...]
    torque_limits: tuple[float, ...]
    ranges: np.ndarray
    added_base: bool


def _fail(source: str, what: str) -> None:
    raise ValueError(f"{source}: {what}")


def _mujoco():
    try:
        import mujoco
    except ImportError:
        raise ImportError("reading MJCF or URDF needs MuJoCo: pip install 'bipedlab[mujoco]'") from None
    return mujoco


def fold(text: str) -> str:
    """A multi-line message (MuJoCo's) as one line: every run of blanks and line breaks one space."""
    return " ".join(str(text).split())


@contextlib.contextmanager
def _warnings_kept(mujoco, kept: list):
    """MuJoCo's warnings appended to ``kept`` meanwhile, instead of printed on stderr and
    appended to MUJOCO_LOG.TXT in the working folder (its default handler)."""
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda msg: kept.append(fold(msg)))
    try:
        yield
    finally:
        mujoco.set_mju_user_warning(previous)


def _plain_utf8(path: str) -> bool:
    """Whether MuJoCo can read the file itself (UTF-8 without a byte-order mark)."""
    with open(path, "rb") as fh:
        return byte_order_mark(fh.read(4)) is None


def _compile(path: str):
    """(mujoco, the compiled model) of a file; ValueError in one line naming the file, with
    MuJoCo's message and warnings folded into it, if the compiler rejects it. Warnings of a
    file that compiles are issued as Python warnings, one line each."""
    mujoco = _mujoco()
    text = model_text(path)  # checked before MuJoCo reads it; ValueError naming the file
    kept: list = []
    try:
        with _warnings_kept(mujoco, kept):
            spec = mujoco.MjSpec.from_file(path) if _plain_utf8(path) else mujoco.MjSpec.from_string(text)
            spec.compiler.fusestatic = False
            m = spec.compile()
    except Exception as e:  # MuJoCo raises ValueError (parse) or its own errors (compile)
        warned = "".join(f" (MuJoCo warned: {w})" for w in dict.fromkeys(kept))
        _fail(path, f"cannot be read as MJCF or URDF: {fold(e)}{warned}")
    for w in dict.fromkeys(kept):
        warnings.warn(f"{path}: MuJoCo: {w}", RuntimeWarning, stacklevel=3)
    return mujoco, m


def _name(mujoco, m, kind, i: int, fallback: str) -> str:
    n = mujoco.mj_id2name(m, kind, i)
    return n if n else f"{fallback}{i}"


def read(path, plane: str = "xz", base_names: Sequence[str] | None = None) -> Description:
    """Read the planar robot in an MJCF or URDF file (see the module docstring).
    ValueError with one line naming the file and the offending element."""
    path = os.fspath(path)
    if not (isinstance(plane, str) and len(plane) == 2 and plane[0] in AXES and plane[1] in AXES
            and plane[0] != plane[1]):
        raise ValueError(f"plane must be two distinct axes of x, y, z (e.g. 'xz'), got {plane!r}")
    mujoco, m = _compile(path)
    src = path
    e1 = np.zeros(3); e1[AXES[plane[0]]] = 1.0
    e2 = np.zeros(3); e2[AXES[plane[1]]] = 1.0
    nrm = np.cross(e1, e2)
    OBJ = mujoco.mjtObj
    body_name = lambda b: _name(mujoco, m, OBJ.mjOBJ_BODY, b, "body")  # noqa: E731
    joint_name = lambda j: _name(mujoco, m, OBJ.mjOBJ_JOINT, j, "joint")  # noqa: E731

    g = np.asarray(m.opt.gravity, float)
    gmag = float(-g @ e2)
    if np.linalg.norm(g - (g @ e2) * e2) > 1e-9 * max(np.linalg.norm(g), 1.0) or gmag < 0:
        _fail(src, f"gravity {g.tolist()} is not along -{plane[1]} (the plane's vertical)")
    if m.neq:
        _fail(src, f"equality '{_name(mujoco, m, OBJ.mjOBJ_EQUALITY, 0, 'equality')}': closes a loop or couples "
                   "joints; only open kinematic trees are read")
    if m.ntendon:
        _fail(src, f"tendon '{_name(mujoco, m, OBJ.mjOBJ_TENDON, 0, 'tendon')}': tendons are not read")

    d = mujoco.MjData(m)
    d.qpos[:] = m.qpos0
    mujoco.mj_kinematics(m, d)

    def inplane(v):
        return np.array([v @ e1, v @ e2])

    # ----- the root
    movers = [b for b in range(1, m.nbody) if m.body_parentid[b] == 0
              and (m.body_jntnum[b] > 0 or m.body_subtreemass[b] > 0)]
    if len(movers) != 1:
        names = ", ".join(body_name(b) for b in movers) or "none"
        _fail(src, f"worldbody: expected one robot root body under the world, found {len(movers)} ({names})")
    root = movers[0]
    while not m.body_jntnum[root] and m.body_mass[root] == 0:  # a massless frame around the robot
        kids = [b for b in range(m.nbody) if m.body_parentid[b] == root and b != root]
        if len(kids) != 1:
            break
        root = kids[0]
    for j in range(m.njnt):
        if int(m.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_FREE), int(mujoco.mjtJoint.mjJNT_BALL)):
            kind = "free" if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE else "ball"
            _fail(src, f"joint '{joint_name(j)}': a {kind} joint is not planar (use two slides and a hinge "
                       f"normal to the {plane} plane)")
    for j in range(m.njnt):
        if m.jnt_stiffness[j] != 0 or m.dof_damping[m.jnt_dofadr[j]] != 0 or m.dof_frictionloss[m.jnt_dofadr[j]] != 0:
            _fail(src, f"joint '{joint_name(j)}': stiffness, damping or friction loss is not modelled (set it to 0)")

    def hinge_sign(j) -> float:
        ax = np.asarray(d.xaxis[j], float)
        s = float(ax @ nrm)
        if abs(abs(s) - 1.0) > AXIS_TOL or np.linalg.norm(ax - s * nrm) > AXIS_TOL:
            _fail(src, f"joint '{joint_name(j)}': hinge axis {np.round(ax, 6).tolist()} (world) is not normal to "
                       f"the {plane} plane")
        return 1.0 if s > 0 else -1.0

    def slide_axis(j) -> np.ndarray:
        ax = np.asarray(d.xaxis[j], float)
        if abs(ax @ nrm) > AXIS_TOL:
            _fail(src, f"joint '{joint_name(j)}': slide axis {np.round(ax, 6).tolist()} (world) leaves the "
                       f"{plane} plane")
        return inplane(ax)

    base_j = list(range(m.body_jntadr[root], m.body_jntadr[root] + m.body_jntnum[root]))
    qidx, qsign, qoff = [-1, -1, -1], [1.0, 1.0, 1.0], [0.0, 0.0, 0.0]
    if base_j:
        kinds = sorted(int(m.jnt_type[j]) for j in base_j)
        want = sorted([int(mujoco.mjtJoint.mjJNT_SLIDE)] * 2 + [int(mujoco.mjtJoint.mjJNT_HINGE)])
        if kinds != want:
            _fail(src, f"body '{body_name(root)}': the root needs two slides and one hinge (a planar floating "
                       f"joint) or no joint at all; it has {len(base_j)} joint(s)")
        names = ["", "", ""]
        hinge = next(j for j in base_j if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE)
        if hinge != base_j[-1]:  # MuJoCo moves a later slide along the axis the hinge has turned
            _fail(src, f"joint '{joint_name(hinge)}': the root's hinge must come after its two slides")
        anchor = inplane(np.asarray(d.xanchor[hinge], float))
        for j in base_j:
            if j == hinge:
                k, s = 2, hinge_sign(j)
            else:
                a = slide_axis(j)
                k = 0 if abs(a[0]) > 1 - AXIS_TOL else 1 if abs(a[1]) > 1 - AXIS_TOL else -1
                if k < 0:
                    _fail(src, f"joint '{joint_name(j)}': a root slide must run along {plane[0]} or {plane[1]}")
                s = float(np.sign(a[k]))
                if qidx[k] != -1:
                    _fail(src, f"joint '{joint_name(j)}': two root slides along the same axis")
            qidx[k], qsign[k], names[k] = int(m.jnt_qposadr[j]), s, joint_name(j)
        qoff = [float(anchor[0]), float(anchor[1]), 0.0]
        origin = anchor
        base = tuple(base_names) if base_names else tuple(names)
    else:
        origin = inplane(np.asarray(d.xpos[root], float))
        qoff = [float(origin[0]), float(origin[1]), 0.0]
        base = tuple(base_names) if base_names else ("x", "y", "theta")

    # ----- the tree: bodies with one joint; jointless bodies merge into their parent
    owner = {root: 0}          # MuJoCo body -> bipedlab body index
    groups: list[list[int]] = [[root]]
    anchors = [origin]
    parent_of: list[int] = [-1]
    kinds: list[str] = ["floating"]
    axes: list[np.ndarray] = [np.array([1.0, 0.0])]
    for b in range(1, m.nbody):
        if b == root:
            continue
        p = int(m.body_parentid[b])
        if p not in owner:
            continue  # static scenery (a floor), or the massless frames around the root
        nj = int(m.body_jntnum[b])
        if nj == 0:
            owner[b] = owner[p]
            groups[owner[p]].append(b)
            continue
        if nj > 1:
            _fail(src, f"body '{body_name(b)}': {nj} joints; the planar subset has one hinge or slide per body")
        j = int(m.body_jntadr[b])
        if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE:
            s = hinge_sign(j)
            kinds.append(REVOLUTE)
            axes.append(np.array([1.0, 0.0]))
        else:
            s = 1.0
            kinds.append(PRISMATIC)
            axes.append(slide_axis(j))
        owner[b] = len(groups)
        groups.append([b])
        parent_of.append(owner[p])
        anchors.append(inplane(np.asarray(d.xanchor[j], float)))
        qidx.append(int(m.jnt_qposadr[j]))
        qsign.append(s)
        qoff.append(0.0)

    # ----- inertial data per bipedlab body (merged groups)
    bodies = []
    names = []
    for k, grp in enumerate(groups):
        mass = float(sum(m.body_mass[b] for b in grp))
        pos = [np.asarray(d.xipos[b], float) for b in grp]
        if mass > 0:
            com3 = sum(m.body_mass[b] * p for b, p in zip(grp, pos)) / mass
        else:
            com3 = np.asarray(d.xpos[grp[0]], float)
        inertia = 0.0
        for b, p in zip(grp, pos):
            R = np.asarray(d.ximat[b], float).reshape(3, 3)
            I = R @ np.diag(np.asarray(m.body_inertia[b], float)) @ R.T
            r = inplane(p - com3)
            inertia += float(nrm @ I @ nrm) + float(m.body_mass[b]) * float(r @ r)
        bname = body_name(grp[0])
        names.append(bname)
        com = inplane(com3) - anchors[k]
        if k == 0:
            bodies.append(Body(bname, None, mass, tuple(com), inertia))
        else:
            off = anchors[k] - anchors[parent_of[k]]
            bodies.append(Body(bname, names[parent_of[k]], mass, tuple(com), inertia, joint=kinds[k],
                               offset=tuple(off), axis=tuple(axes[k])))

    points = []
    for k, grp in enumerate(groups):  # a body welded to its parent: a point at its origin (a URDF frame)
        for b in grp[1:]:
            points.append(Point(body_name(b), names[k], tuple(inplane(np.asarray(d.xpos[b], float)) - anchors[k])))
    for s in range(m.nsite):
        b = int(m.site_bodyid[s])
        if b not in owner:
            continue
        k = owner[b]
        points.append(Point(_name(mujoco, m, OBJ.mjOBJ_SITE, s, "site"), names[k],
                            tuple(inplane(np.asarray(d.site_xpos[s], float)) - anchors[k])))

    nq = len(qidx)
    coord_of_qpos = {qi: i for i, qi in enumerate(qidx) if qi >= 0}
    joint_of_coord = {}
    for j in range(m.njnt):
        i = coord_of_qpos.get(int(m.jnt_qposadr[j]))
        if i is not None:
            joint_of_coord[i] = j

    rotors = []
    for i in range(nq):
        j = joint_of_coord.get(i)
        if j is None:
            continue
        arm = float(m.dof_armature[m.jnt_dofadr[j]])
        if arm > 0:
            ratios = [0.0] * nq
            ratios[i] = 1.0
            rotors.append(Rotor(f"{joint_name(j)}_armature", arm, tuple(ratios)))

    ranges = np.full((nq, 2), [-np.inf, np.inf])
    for i, j in joint_of_coord.items():
        if m.jnt_limited[j] and i >= 3:
            lo, hi = (np.asarray(m.jnt_range[j], float) - m.qpos0[m.jnt_qposadr[j]]) * qsign[i]
            ranges[i] = sorted((lo, hi))

    # ----- actuators
    act_coords, act_names, gears, limits = [], [], [], []
    for a in range(m.nu):
        aname = _name(mujoco, m, OBJ.mjOBJ_ACTUATOR, a, "actuator")
        if m.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_JOINT:
            _fail(src, f"actuator '{aname}': only joint transmissions are read")
        j = int(m.actuator_trnid[a, 0])
        i = coord_of_qpos.get(int(m.jnt_qposadr[j]))
        if i is None or i < 3:
            _fail(src, f"actuator '{aname}': drives joint '{joint_name(j)}', which is not a joint of the robot's tree")
        if i in act_coords:
            _fail(src, f"actuator '{aname}': a second actuator on joint '{joint_name(j)}'")
        gear = float(m.actuator_gear[a, 0])
        lim = np.inf
        if m.actuator_forcelimited[a]:
            lim = min(lim, float(np.max(np.abs(m.actuator_forcerange[a]))))
        motor = (m.actuator_gaintype[a] == mujoco.mjtGain.mjGAIN_FIXED
                 and m.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_NONE)
        if motor and m.actuator_ctrllimited[a]:
            lim = min(lim, float(np.max(np.abs(m.actuator_ctrlrange[a]))) * abs(float(m.actuator_gainprm[a, 0])))
        lim = lim * abs(gear)
        if m.jnt_actfrclimited[j]:
            lim = min(lim, float(np.max(np.abs(m.jnt_actfrcrange[j]))))
        act_coords.append(i)
        act_names.append(aname)
        gears.append(gear)
        limits.append(lim)
    if m.nu == 0:
        for i in range(3, nq):
            j = joint_of_coord[i]
            act_coords.append(i)
            act_names.append(joint_name(j))
            gears.append(1.0)
            limits.append(float(np.max(np.abs(m.jnt_actfrcrange[j]))) if m.jnt_actfrclimited[j] else np.inf)

    coord = list(base) + names[1:]
    try:
        model = build_model(bodies, points, rotors, actuated=[coord[i] for i in act_coords], gravity=gmag,
                            base_names=base)
    except ValueError as e:
        _fail(src, str(e))
    desc = Description(src, model, tuple(qidx), tuple(qsign), tuple(qoff), tuple(act_names), tuple(gears),
                       tuple(limits), ranges, not base_j)
    return desc


def q_from_qpos(desc: Description, qpos, qpos0) -> np.ndarray:
    """Bipedlab q of a MuJoCo qpos (an added base's coordinates at their reference)."""
    qpos, qpos0 = np.asarray(qpos, float), np.asarray(qpos0, float)
    return np.array([off + (s * (qpos[i] - qpos0[i]) if i >= 0 else 0.0)
                     for i, s, off in zip(desc.qpos_index, desc.qpos_sign, desc.qpos_offset)])


def load_model(path, plane: str = "xz", base_names: Sequence[str] | None = None) -> Model:
    """The frozen :class:`bipedlab.mechanics.Model` of the planar robot in an MJCF or URDF
    file (see :func:`read` for the subset read and the options)."""
    return read(path, plane, base_names).model
