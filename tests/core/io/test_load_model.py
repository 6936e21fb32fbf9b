"""bipedlab.io.load_model against its oracles: the exporter (round trip to 1e-12), MuJoCo
itself on an MJCF written here by hand (mj_fullM and qfrc_bias to 1e-9 relative, with every
convention the reader must undo: hinges about +y, joint references, rotated body frames, a
body welded to its parent, full inertia tensors, COMs off the plane, armature, root joints in
another order), and the URDF of a robot against its MJCF."""
from __future__ import annotations

from importlib import resources

import jax
import numpy as np
import pytest

from bipedlab import mechanics as mech
from bipedlab.io import load_model, q_from_qpos, read
from helpers import mj_full_inertia, random_states, rel_err
from trees import make_model

N_STATES = 24

pytest.importorskip("mujoco")


def _data(name: str) -> str:
    return str(resources.files("bipedlab.robots.imported").joinpath("data", name))


@jax.jit
def _dyn(model, q, qd):
    return mech.mass_matrix(model, q), mech.bias(model, q, qd)


def _roundtrip(model, tmp_path):
    path = tmp_path / "exported.xml"
    path.write_text(mech.to_mjcf(model))
    return load_model(path, base_names=model.coord_names[:3])


@pytest.mark.parametrize("which", ["five_link", "branched_tree"])
def test_roundtrip_mass_matrix_and_bias(which, five, tmp_path):
    """to_mjcf then load_model: the same mass matrix and bias (1e-12) on random states; the
    branched tree is declared out of depth-first order, so its coordinates come back in
    MuJoCo's order (mjcf_coordinate_order)."""
    model = five if which == "five_link" else make_model()
    back = _roundtrip(model, tmp_path)
    order = np.asarray(mech.mjcf_coordinate_order(model))
    assert back.nq == model.nq
    assert [back.coord_names[i] for i in range(model.nq)] == [model.coord_names[i] for i in order]
    rng = np.random.default_rng(3)
    q, qd = random_states(rng, N_STATES, model.nq)
    for k in range(N_STATES):
        M0, h0 = _dyn(model, q[k], qd[k])
        M1, h1 = _dyn(back, q[k][order], qd[k][order])
        np.testing.assert_allclose(np.asarray(M1), np.asarray(M0)[np.ix_(order, order)], rtol=0, atol=1e-12)
        np.testing.assert_allclose(np.asarray(h1), np.asarray(h0)[order], rtol=0, atol=1e-12)
    for name in model.point_names:  # the points come back on the same bodies, at the same place
        p0 = mech.point_position(model, q[0], name)
        p1 = mech.point_position(back, q[0][order], name)
        np.testing.assert_allclose(np.asarray(p1), np.asarray(p0), atol=1e-12)


#: A 7-DoF planar robot written independently of the exporter, with the conventions the reader
#: must undo. Root joints in the order z, x, hinge (its anchor off the body origin); the thigh's hinge turns about +y (negative
#: counter-clockwise); the shin's frame is turned 0.4 rad about y and its hinge has a
#: reference of 0.3 rad; a foot welded to the shin (merged); full inertia tensors and COMs off
#: the plane (neither matters in the plane); armature on two joints; a slide in the plane at an
#: angle carrying a hinge.
HAND_MJCF = """
<mujoco model="hand">
  <compiler angle="radian" inertiafromgeom="false"/>
  <option gravity="0 0 -9.7"/>
  <worldbody>
    <geom name="floor" type="plane" size="10 10 0.1"/>
    <body name="pelvis" pos="0.1 0 1.0">
      <joint name="up" type="slide" axis="0 0 1"/>
      <joint name="fwd" type="slide" axis="1 0 0"/>
      <joint name="pitch" type="hinge" axis="0 -1 0" pos="0.02 0 -0.03"/>
      <inertial pos="0.03 0.02 0.1" mass="9.5" fullinertia="0.9 1.1 0.7 0.05 0.02 -0.03"/>
      <body name="thigh" pos="0.05 0.0 -0.1">
        <joint name="hip" type="hinge" axis="0 1 0" armature="0.03"/>
        <inertial pos="0.01 0.04 -0.15" mass="4.0" fullinertia="0.2 0.25 0.1 0.01 0.02 0.0"/>
        <body name="shin" pos="0.0 0 -0.35" euler="0 0.4 0">
          <joint name="knee" type="hinge" axis="0 -1 0" ref="0.3" armature="0.02"/>
          <inertial pos="0.02 -0.01 -0.2" mass="2.5" diaginertia="0.08 0.09 0.02"/>
          <body name="foot" pos="0.05 0 -0.4" euler="0 -0.2 0">
            <inertial pos="0.04 0 -0.02" mass="0.8" diaginertia="0.003 0.004 0.002"/>
            <site name="toe" pos="0.1 0 -0.05"/>
          </body>
        </body>
      </body>
      <body name="carriage" pos="-0.1 0 0.2">
        <joint name="slider" type="slide" axis="0.6 0 0.8"/>
        <inertial pos="0.0 0.0 0.05" mass="1.5" diaginertia="0.02 0.03 0.02"/>
        <body name="arm" pos="0.1 0 0.1">
          <joint name="elbow" type="hinge" axis="0 -1 0"/>
          <inertial pos="0.2 0.03 0.0" mass="1.1" diaginertia="0.01 0.04 0.03"/>
          <site name="hand" pos="0.4 0 0"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.fixture(scope="module")
def hand(tmp_path_factory):
    path = tmp_path_factory.mktemp("hand") / "hand.xml"
    path.write_text(HAND_MJCF)
    return path


def test_independent_mjcf_against_mujoco(hand, mujoco):
    """Mass matrix and bias of the read model against MuJoCo's own (mj_fullM, qfrc_bias) on
    random states, 1e-9 relative; the toe against MuJoCo's site position."""
    desc = read(hand)
    model = desc.model
    assert model.nq == 7 and model.body_names == ("pelvis", "thigh", "shin", "carriage", "arm")
    assert model.coord_names[:3] == ("fwd", "up", "pitch")
    assert float(model.gravity) == 9.7
    m = mujoco.MjModel.from_xml_path(str(hand))
    d = mujoco.MjData(m)
    idx = np.asarray(desc.qpos_index)
    sign = np.asarray(desc.qpos_sign)
    assert sign.tolist() == [1, 1, 1, -1, 1, 1, 1]
    rng = np.random.default_rng(11)
    worst_M = worst_h = 0.0
    for _ in range(N_STATES):
        d.qpos[:] = m.qpos0 + rng.uniform(-1.5, 1.5, m.nq)
        d.qvel[:] = 2.0 * rng.standard_normal(m.nv)
        mujoco.mj_forward(m, d)
        q = q_from_qpos(desc, d.qpos, m.qpos0)
        qd = sign * d.qvel[idx]
        Mmj = mj_full_inertia(mujoco, m, d)[np.ix_(idx, idx)] * np.outer(sign, sign)
        hmj = sign * d.qfrc_bias[idx]
        M, h = _dyn(model, q, qd)
        worst_M = max(worst_M, rel_err(M, Mmj))
        worst_h = max(worst_h, rel_err(h, hmj))
        toe = mech.point_position(model, q, "toe")
        np.testing.assert_allclose(np.asarray(toe), d.site("toe").xpos[[0, 2]], atol=1e-12)
    assert worst_M < 1e-9 and worst_h < 1e-9, (worst_M, worst_h)


def test_armature_is_a_rotor_and_welded_body_merged(hand):
    model = load_model(hand)
    assert model.rotor_names == ("hip_armature", "knee_armature")
    np.testing.assert_allclose(np.asarray(model.rotor_inertia), [0.03, 0.02])
    # the foot's 0.8 kg is part of the shin; its origin is a point
    np.testing.assert_allclose(float(mech.total_mass(model)), 9.5 + 4.0 + 2.5 + 0.8 + 1.5 + 1.1)
    assert "foot" in model.point_names and "toe" in model.point_names


def test_urdf_gives_the_mjcf_model():
    """The shipped robot's URDF and MJCF: the same mass matrix, bias, feet and limits."""
    a, b = read(_data("rabbit.xml")), read(_data("rabbit.urdf"))
    assert b.added_base and not a.added_base
    assert a.model.actuated == b.model.actuated and a.torque_limits == b.torque_limits
    rng = np.random.default_rng(5)
    q, qd = random_states(rng, N_STATES, 7)
    for k in range(N_STATES):
        Ma, ha = _dyn(a.model, q[k], qd[k])
        Mb, hb = _dyn(b.model, q[k], qd[k])
        np.testing.assert_allclose(np.asarray(Mb), np.asarray(Ma), rtol=0, atol=1e-12)
        np.testing.assert_allclose(np.asarray(hb), np.asarray(ha), rtol=0, atol=1e-12)
        for foot in ("left_foot", "right_foot"):
            np.testing.assert_allclose(np.asarray(mech.point_position(b.model, q[k], foot)),
                                       np.asarray(mech.point_position(a.model, q[k], foot)), atol=1e-12)


def test_plane_option(hand, tmp_path):
    """The same robot drawn in the y-z plane (every axis turned from x to y) reads as the same
    model with plane='yz'."""
    xml = HAND_MJCF
    # turn the world 90 degrees about z: x -> y, y -> -x (a hinge about -y becomes one about +x)
    xml = xml.replace('<worldbody>', '<worldbody>\n<body name="turn" euler="0 0 1.5707963267948966">', 1)
    xml = xml.replace('</worldbody>', '</body>\n</worldbody>', 1)
    xml = xml.replace('<geom name="floor" type="plane" size="10 10 0.1"/>', '')
    p = tmp_path / "turned.xml"
    p.write_text(xml)
    a, b = read(hand), read(p, plane="yz")
    rng = np.random.default_rng(2)
    q, qd = random_states(rng, 6, 7)
    for k in range(6):
        Ma, ha = _dyn(a.model, q[k], qd[k])
        Mb, hb = _dyn(b.model, q[k], qd[k])
        np.testing.assert_allclose(np.asarray(Mb), np.asarray(Ma), rtol=0, atol=1e-12)
        np.testing.assert_allclose(np.asarray(hb), np.asarray(ha), rtol=0, atol=1e-12)
