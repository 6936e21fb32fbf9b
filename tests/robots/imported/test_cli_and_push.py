"""Bad input to the ``model`` commands (exit 2, one line naming the file and the element), and
the hip push of ``robustness model`` against the impulse-momentum law."""
from __future__ import annotations

import json
from importlib import resources

import numpy as np
import pytest

from bipedlab import mechanics as mech
from helpers import expect_usage_error

pytest.importorskip("mujoco")

RABBIT = str(resources.files("bipedlab.robots.imported").joinpath("data", "rabbit.xml"))


def test_missing_file(capsys, tmp_path):
    missing = str(tmp_path / "robot.xml")
    expect_usage_error(["optimize", "model", missing, "--stance", "a", "--swing", "b"], capsys,
                       f"{missing}: no such file")


def test_unparsable_file(capsys, tmp_path):
    bad = tmp_path / "robot.xml"
    bad.write_text("<mujoco><worldbody><body name='a'></worldbody>")
    line = expect_usage_error(["optimize", "model", str(bad), "--stance", "a", "--swing", "b"], capsys,
                              f"{bad}: cannot be read as MJCF or URDF")
    assert "Line number=1" in line  # MuJoCo's own pointer to the element


def test_missing_site(capsys):
    expect_usage_error(["optimize", "model", RABBIT, "--stance", "left_toe", "--swing", "right_foot"], capsys,
                       f"{RABBIT}: site 'left_toe' (the stance point) is not in the file")


def test_out_of_subset(capsys, tmp_path):
    p = tmp_path / "ball.xml"
    p.write_text(open(RABBIT).read().replace('<joint name="left_knee" type="hinge" axis="0 -1 0"/>',
                                             '<joint name="left_knee" type="ball"/>'))
    expect_usage_error(["optimize", "model", str(p), "--stance", "left_foot", "--swing", "right_foot"], capsys,
                       "joint 'left_knee': a ball joint is not planar")


def test_walk_gait_not_from_optimize_model(capsys, tmp_path):
    g = tmp_path / "gait.json"
    g.write_text(json.dumps({"format": "bipedlab-gait/2", "robot": "model", "kind": "hzd", "payload": {}}))
    expect_usage_error(["walk", "model", RABBIT, "--gait", str(g)], capsys,
                       f"{g}: payload.design: no stance and swing points")


def test_walk_gait_unreadable(capsys, tmp_path):
    g = tmp_path / "gait.json"
    g.write_text("{not json")
    expect_usage_error(["walk", "model", RABBIT, "--gait", str(g)], capsys, str(g))


def test_robustness_missing_gait(capsys, tmp_path):
    expect_usage_error(["robustness", "model", RABBIT, "--gait", str(tmp_path / "none.json")], capsys,
                       "is not a file")


def test_hip_push_obeys_impulse_momentum():
    """After the push the stance foot is still at rest, and the angular momentum about it has
    grown by (hip - foot) x P: the ground's impulse acts at the foot and has no moment there."""
    import jax.numpy as jnp

    from bipedlab.mechanics.kinematics import frames
    from bipedlab.mechanics.stance import embed
    from bipedlab.robots.imported import robot as imported
    from bipedlab.robots.imported.robustness import push

    s = imported.load(RABBIT, "left_foot", "right_foot")
    st = s.study.stance
    hip = s.legs.stance_path[0]
    z = jnp.asarray(imported.gait_guess(s, 0.8))
    P = jnp.asarray([5.0, -3.0])
    z1 = push(st, hip, z, P)
    q, qd0 = embed(st, z)
    q1, qd1 = embed(st, z1)
    np.testing.assert_allclose(np.asarray(q1), np.asarray(q), atol=1e-15)
    foot = mech.point_position(st.model, q, st.stance)
    np.testing.assert_allclose(np.asarray(mech.point_velocity(st.model, q, qd1, st.stance)), 0.0, atol=1e-12)
    r = jnp.stack(frames(st.model, q).origin[hip]) - foot
    dL = mech.angular_momentum(st.model, q, qd1, foot) - mech.angular_momentum(st.model, q, qd0, foot)
    assert float(dL) == pytest.approx(float(r[0] * P[1] - r[1] * P[0]), abs=1e-11)


@pytest.mark.slow
def test_robustness_model_small_pushes_survive():
    """The ``robustness model`` study on the shipped RABBIT gait: pushes of at most 0.25 N s at
    the hip (under 0.01 m/s of the COM's 0.8 m/s) leave every trial walking its 3 steps back
    towards the fixed point."""
    from bipedlab.robots.imported import robustness as rm
    from bipedlab.robustness import engine

    gait = str(resources.files("bipedlab.robots.imported").joinpath("data", "rabbit_0.8.json"))
    small = engine.run(rm.study(RABBIT, gait, steps=3, push_max=0.25, bins=2, grid=True), 4, progress=False)
    assert small["trials"] == 4 and small["survival_rate"] == 1.0
    assert small["median_final_deviation"] < 0.05
    # 30 N s (0.94 m/s of the COM's speed): backwards the robot falls, forwards it walks on
    large = engine.run(rm.study(RABBIT, gait, steps=3, push_max=60.0, bins=2, grid=True), 4, progress=False)
    assert large["survival_map"] == [[0.0, 0.0], [1.0, 1.0]]
