"""build_model validates its input with one clear ValueError per mistake."""
from __future__ import annotations

import pytest

from bipedlab.mechanics import Body, Point, Rotor, build_model


def _bodies():
    return [
        Body("root", None, 1.0, (0.0, 0.0), 0.1),
        Body("upper", "root", 1.0, (0.0, -0.1), 0.1, offset=(0.0, -0.1)),
        Body("lower", "upper", 1.0, (0.0, -0.1), 0.1, offset=(0.0, -0.2)),
    ]


def test_valid_model_builds():
    m = build_model(_bodies(), [Point("tip", "lower", (0.0, -0.2))])
    assert m.nq == 5 and m.point_index("tip") == 0
    assert m.parents == (-1, 0, 1)


def test_parent_declared_after_child():
    b = _bodies()
    with pytest.raises(ValueError, match=r"'lower'.*parent 'upper'.*before"):
        build_model([b[0], b[2], b[1]])


def test_unknown_parent():
    b = _bodies()
    b[2] = Body("lower", "nowhere", 1.0, (0.0, 0.0), 0.1)
    with pytest.raises(ValueError, match="nowhere"):
        build_model(b)


def test_duplicate_names():
    b = _bodies()
    b[2] = Body("upper", "upper", 1.0, (0.0, 0.0), 0.1)
    with pytest.raises(ValueError, match=r"(?i)unique|duplicate"):
        build_model(b)


def test_unknown_point_body():
    with pytest.raises(ValueError, match=r"'toe'.*unknown body 'foot'"):
        build_model(_bodies(), [Point("toe", "foot", (0.0, 0.0))])


def test_root_must_have_no_parent():
    b = _bodies()
    b[0] = Body("root", "upper", 1.0, (0.0, 0.0), 0.1)
    with pytest.raises(ValueError, match="root"):
        build_model(b)


def test_other_inconsistencies():
    with pytest.raises(ValueError, match="at least one body"):
        build_model([])
    b = _bodies()
    b[1] = Body("upper", "root", 1.0, (0.0, 0.0), 0.1, joint="ball")
    with pytest.raises(ValueError, match="joint"):
        build_model(b)
    b = _bodies()
    b[1] = Body("upper", "root", -1.0, (0.0, 0.0), 0.1)
    with pytest.raises(ValueError, match="non-negative"):
        build_model(b)
    with pytest.raises(ValueError, match=r"rotor 'r'.*5 ratios"):
        build_model(_bodies(), rotors=[Rotor("r", 0.1, (0.0, 1.0))])
    with pytest.raises(ValueError, match="unknown coordinate 'elbow'"):
        build_model(_bodies(), actuated=["elbow"])
    with pytest.raises(ValueError, match="unknown point 'heel'"):
        build_model(_bodies()).point_index("heel")
