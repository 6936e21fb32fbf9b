"""Files outside the planar subset, and files that cannot be read, give one line naming the
file, the element and why."""
from __future__ import annotations

import pytest

from bipedlab.io import load_model

pytest.importorskip("mujoco")

ROOT = """<joint name="x" type="slide" axis="1 0 0"/><joint name="z" type="slide" axis="0 0 1"/>
<joint name="pitch" type="hinge" axis="0 -1 0"/>"""
LINK = '<inertial pos="0 0 -0.1" mass="1" diaginertia="0.1 0.1 0.1"/>'


def _mjcf(body: str, root: str = ROOT, extra: str = "") -> str:
    return f"""<mujoco><compiler angle="radian" inertiafromgeom="false"/><worldbody>
<body name="trunk" pos="0 0 1">{root}
<inertial pos="0 0 0.1" mass="5" diaginertia="0.5 0.5 0.5"/>{body}</body></worldbody>{extra}</mujoco>"""


CASES = {
    "ball joint": (_mjcf(f'<body name="leg"><joint name="hipball" type="ball"/>{LINK}</body>'),
                   "joint 'hipball': a ball joint is not planar"),
    "free root": (_mjcf("", root='<freejoint name="float"/>'), "joint 'float': a free joint is not planar"),
    "axis out of plane": (_mjcf(f'<body name="leg"><joint name="abduct" type="hinge" axis="1 0 0"/>{LINK}</body>'),
                          "joint 'abduct': hinge axis [1.0, 0.0, 0.0] (world) is not normal to the xz plane"),
    "tilted axis": (_mjcf(f'<body name="leg"><joint name="tilt" type="hinge" axis="0.1 -1 0"/>{LINK}</body>'),
                    "joint 'tilt': hinge axis"),
    "slide out of plane": (_mjcf(f'<body name="leg"><joint name="side" type="slide" axis="0 1 0"/>{LINK}</body>'),
                           "joint 'side': slide axis [0.0, 1.0, 0.0] (world) leaves the xz plane"),
    "two joints": (_mjcf(f'<body name="leg"><joint name="a" axis="0 1 0"/><joint name="b" axis="0 1 0"/>{LINK}</body>'),
                   "body 'leg': 2 joints"),
    "closed loop": (_mjcf(f'<body name="l1"><joint name="a" axis="0 1 0"/>{LINK}<site name="s1"/></body>'
                          f'<body name="l2"><joint name="b" axis="0 1 0"/>{LINK}<site name="s2"/></body>',
                          extra='<equality><connect name="loop" site1="s1" site2="s2"/></equality>'),
                    "equality 'loop': closes a loop"),
    "root with one hinge": (_mjcf("", root='<joint name="pin" type="hinge" axis="0 1 0"/>'),
                            "body 'trunk': the root needs two slides and one hinge"),
    "hinge before slides": (_mjcf("", root='<joint name="pitch" axis="0 1 0"/><joint name="x" type="slide" '
                                           'axis="1 0 0"/><joint name="z" type="slide" axis="0 0 1"/>'),
                            "joint 'pitch': the root's hinge must come after its two slides"),
    "damping": (_mjcf(f'<body name="leg"><joint name="hip" axis="0 1 0" damping="2"/>{LINK}</body>'),
                "joint 'hip': stiffness, damping or friction loss is not modelled"),
    "tendon actuator": (_mjcf(f'<body name="leg"><joint name="hip" axis="0 1 0"/>{LINK}<site name="s"/></body>',
                              extra='<actuator><motor name="push" site="s" gear="1 0 0 0 0 0"/></actuator>'),
                        "actuator 'push': only joint transmissions are read"),
    "gravity off the plane": (_mjcf("").replace("<mujoco>", '<mujoco><option gravity="0 -9.81 0"/>'),
                              "gravity [0.0, -9.81, 0.0] is not along -z"),
    "two robots": (_mjcf("").replace("</worldbody>", '<body name="other"><joint name="o" type="slide" '
                                                     'axis="1 0 0"/><inertial pos="0 0 0" mass="1" '
                                                     'diaginertia="1 1 1"/></body></worldbody>'),
                   "worldbody: expected one robot root body under the world, found 2 (trunk, other)"),
    "unparsable": ("<mujoco><worldbody><body name='a'></worldbody>", "cannot be read as MJCF or URDF"),
    "not a robot file": ("just text", "cannot be read as MJCF or URDF"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_rejected_with_one_line(case, tmp_path):
    text, needle = CASES[case]
    path = tmp_path / "robot.xml"
    path.write_text(text)
    with pytest.raises(ValueError) as e:
        load_model(path)
    msg = str(e.value)
    assert "\n" not in msg
    assert msg.startswith(f"{path}: ") and needle in msg, msg


def test_missing_file(tmp_path):
    with pytest.raises(ValueError, match=r"nothere\.xml: no such file$"):
        load_model(tmp_path / "nothere.xml")


def test_bad_plane(tmp_path):
    with pytest.raises(ValueError, match="plane must be two distinct axes"):
        load_model(tmp_path / "x.xml", plane="xx")
