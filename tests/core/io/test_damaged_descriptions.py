"""Robot description files (MJCF and URDF) are checked completely on reading: every damaged copy
of a shipped robot (an attribute's value replaced, an element dropped or doubled, a tag renamed,
the bytes cut or spoiled) is read as a planar robot or refused with one ValueError line naming
the file; nothing else escapes (property-based, hypothesis). The slow tier runs ten times the
examples."""
from __future__ import annotations

import copy
import importlib.resources
import warnings
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mutations import spoiled

from bipedlab.io import description

pytest.importorskip("mujoco")

DATA = importlib.resources.files("bipedlab.robots.imported") / "data"
SOURCES = {name: (DATA / name).read_text() for name in ("rabbit.xml", "rabbit.urdf")}
VALUES = ["nan", "inf", "-inf", "-1", "0", "1e300", "-1e300", "1e-300", "", "abc", "0 0", "0 0 0 0 0",
          "1 nan 0", "0 0 nan", "0x10", "1,5", "-0"]
SETTINGS = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def _elements(root):
    return list(root.iter())


@st.composite
def damaged(draw):
    """(file suffix, bytes) of a damaged shipped robot file."""
    name = draw(st.sampled_from(sorted(SOURCES)))
    root = ET.fromstring(SOURCES[name])
    for _ in range(draw(st.integers(1, 3))):
        elements = _elements(root)
        k = draw(st.integers(0, len(elements) - 1))
        el = elements[k]
        op = draw(st.sampled_from(["value", "value", "value", "drop_attribute", "drop", "double", "rename"]))
        if op == "value" and el.attrib:
            key = draw(st.sampled_from(sorted(el.attrib)))
            el.set(key, draw(st.one_of(st.sampled_from(VALUES),
                                       st.floats(allow_nan=True).map(repr), st.text(max_size=6))))
        elif op == "drop_attribute" and el.attrib:
            del el.attrib[draw(st.sampled_from(sorted(el.attrib)))]
        elif op in ("drop", "double") and k > 0:
            parent = next(p for p in elements if el in list(p))
            if op == "drop":
                parent.remove(el)
            else:
                parent.insert(list(parent).index(el), copy.deepcopy(el))
        elif op == "rename" and k > 0:
            el.tag = draw(st.sampled_from(["body", "joint", "link", "geom", "inertial", "x", "robot", "mujoco"]))
    raw = draw(spoiled(ET.tostring(root), bad=(b"\xff", b"\x00", b"\xe9", b"<", b"&"),
                       kinds=("cut", "byte", "bom", "empty")))
    return name.rsplit(".", 1)[1], raw


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("descriptions")


def _check(folder, drawn):
    suffix, raw = drawn
    path = folder / f"robot.{suffix}"
    path.write_bytes(raw)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            desc = description.read(str(path))
    except ValueError as e:
        msg = str(e)
        assert msg.startswith(f"{path}: ") or msg.startswith(f"{path} "), msg
        assert "\n" not in msg and "\r" not in msg, msg
        return
    m = desc.model
    for leaf in (m.mass, m.com, m.inertia):
        assert np.all(np.isfinite(np.asarray(leaf))), (leaf, raw)


def test_the_shipped_files_read(folder):
    for name, text in SOURCES.items():
        _check(folder, (name.rsplit(".", 1)[1], text.encode()))


@settings(max_examples=100, **SETTINGS)
@given(drawn=damaged())
def test_damaged_descriptions_read_or_fail_on_one_line(folder, drawn):
    _check(folder, drawn)


@pytest.mark.slow
@settings(max_examples=1000, **SETTINGS)
@given(drawn=damaged())
def test_damaged_descriptions_read_or_fail_on_one_line_many(folder, drawn):
    _check(folder, drawn)
