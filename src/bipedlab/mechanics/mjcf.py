"""Export a planar :class:`Model` to MuJoCo's MJCF, for MuJoCo to serve as an oracle.

The plane (x, y) of bipedlab maps to MuJoCo's (x, z); hinges turn about -y so that positive
angles are counter-clockwise in that plane, as in bipedlab. Each body carries an exact
``<inertial>`` element: its mass, its COM, and its planar inertia as the principal moment
about y (the moments about x and z are set equal to it; planar motion never excites them).
The floating base is two slide joints (x, z) and a hinge. MuJoCo numbers joints depth-first
through the nested bodies, so ``qpos`` equals q when the bodies were declared depth-first
(every subtree contiguous, as for the robots shipped here); otherwise
:func:`mjcf_coordinate_order` gives the coordinate behind each qpos entry. Joint names are the
coordinate names. Rotors are not representable as MJCF bodies and are rejected.
"""
from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from bipedlab.mechanics.tree import PRISMATIC, Model


def _f(v) -> str:
    return " ".join(repr(float(x)) for x in np.atleast_1d(v))


def _depth_first(model: Model) -> list[int]:
    order: list[int] = []

    def visit(b: int) -> None:
        order.append(b)
        for c in range(model.nb):
            if model.parents[c] == b:
                visit(c)

    visit(0)
    return order


def mjcf_coordinate_order(model: Model) -> tuple[int, ...]:
    """Index into q of each of MuJoCo's qpos entries for the exported model
    (``qpos = q[order]``); the identity when bodies were declared depth-first."""
    return (0, 1, 2) + tuple(model.dof_of_body(b) for b in _depth_first(model)[1:])


def to_mjcf(
    model: Model,
    timestep: float = 2.5e-4,
    integrator: str = "RK4",
    contact_points: Sequence[str] = (),
    contact_radius: float = 0.0,
    pd_gains: tuple[float, float] | None = None,
    floor: bool = True,
    capsules: Mapping[str, tuple[tuple[float, float], float]] | None = None,
) -> str:
    """MJCF text for the model. ``contact_points`` get spheres of ``contact_radius`` that
    collide with the floor only; ``pd_gains=(kp, kd)`` adds position actuators on the
    actuated joints; without a floor the robot flies free. ``capsules`` maps a body name to
    ``((x, y) end in the body frame, radius)``: a massless capsule from the body's joint to
    that end which collides with the floor and with other capsules (MuJoCo's own contact)."""
    if model.rotor_names:
        raise ValueError("models with rotor inertias cannot be exported to MJCF")
    mass = np.asarray(model.mass)
    com = np.asarray(model.com)
    inertia = np.asarray(model.inertia)
    offset = np.asarray(model.offset)
    axis = np.asarray(model.axis)
    poff = np.asarray(model.point_offset)
    children = {b: [c for c in range(model.nb) if model.parents[c] == b] for b in range(model.nb)}
    contact = {model.point_index(n) for n in contact_points}

    def body_xml(b: int, indent: str) -> list[str]:
        name = model.body_names[b]
        pos = "0 0 0" if b == 0 else f"{_f(offset[b, 0])} 0 {_f(offset[b, 1])}"
        lines = [f'{indent}<body name="{name}" pos="{pos}">']
        ind = indent + "  "
        if b == 0:
            x, y, th = model.coord_names[:3]
            lines += [
                f'{ind}<joint name="{x}" type="slide" axis="1 0 0" limited="false"/>',
                f'{ind}<joint name="{y}" type="slide" axis="0 0 1" limited="false"/>',
                f'{ind}<joint name="{th}" type="hinge" axis="0 -1 0" limited="false"/>',
            ]
        elif model.joints[b] == PRISMATIC:
            lines.append(f'{ind}<joint name="{name}" type="slide" axis="{_f(axis[b, 0])} 0 {_f(axis[b, 1])}" limited="false"/>')
        else:
            lines.append(f'{ind}<joint name="{name}" type="hinge" axis="0 -1 0" limited="false"/>')
        I = max(float(inertia[b]), 1e-12)
        lines.append(
            f'{ind}<inertial pos="{_f(com[b, 0])} 0 {_f(com[b, 1])}" mass="{_f(max(mass[b], 1e-12))}" '
            f'diaginertia="{_f(I)} {_f(I)} {_f(I)}"/>'
        )
        if capsules and name in capsules:
            (ex, ey), rad = capsules[name]
            lines.append(
                f'{ind}<geom name="{name}_capsule" type="capsule" fromto="0 0 0 {_f(ex)} 0 {_f(ey)}" '
                f'size="{_f(rad)}" mass="0" contype="1" conaffinity="3"/>'
            )
        for k, pb in enumerate(model.point_bodies):
            if pb != b:
                continue
            pos = f"{_f(poff[k, 0])} 0 {_f(poff[k, 1])}"
            lines.append(f'{ind}<site name="{model.point_names[k]}" pos="{pos}"/>')
            if k in contact and contact_radius > 0:
                lines.append(
                    f'{ind}<geom name="{model.point_names[k]}_geom" type="sphere" size="{_f(contact_radius)}" '
                    f'pos="{pos}" mass="0" contype="1" conaffinity="2"/>'
                )
        for c in children[b]:
            lines += body_xml(c, ind)
        lines.append(f"{indent}</body>")
        return lines

    out = [
        '<mujoco model="bipedlab">',
        '  <compiler angle="radian" inertiafromgeom="false"/>',
        f'  <option timestep="{_f(timestep)}" integrator="{integrator}" gravity="0 0 {_f(-float(model.gravity))}"/>',
        "  <worldbody>",
    ]
    if floor:
        out.append('    <geom name="floor" type="plane" size="100 5 0.1" contype="2" conaffinity="1"/>')
    out += body_xml(0, "    ")
    out.append("  </worldbody>")
    if pd_gains is not None:
        kp, kd = pd_gains
        out.append("  <actuator>")
        for i in model.actuated:
            out.append(f'    <position joint="{model.coord_names[i]}" kp="{_f(kp)}" kv="{_f(kd)}"/>')
        out.append("  </actuator>")
    out.append("</mujoco>")
    return "\n".join(out)
