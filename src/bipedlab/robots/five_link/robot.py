"""The five-link planar biped of the speed anchors (torso, two thighs, two shins, point feet).

Coordinates ``q = [x_hip, y_hip, torso, hip_1, knee_1, hip_2, knee_2]``: hip position (m),
torso angle (rad, 0 upright, counter-clockwise positive), and relative joint angles (rad):
thigh angle = torso + hip, shin angle = thigh + knee, with a hanging leg at zero.

Parameters (the anchor's): torso 12 kg, 1.33 kg m^2, length 0.63 m, COM 0.24 m above the hip;
thighs 6.8 kg, 0.47 kg m^2, 0.4 m, COM 0.11 m below the hip; shins 3.2 kg, 0.2 kg m^2, 0.4 m,
COM 0.24 m below the knee. Inertias are about each link's COM. Gravity 9.81 m/s^2.
"""
from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from bipedlab.mechanics import Body, Point, build_model

TORSO = dict(mass=12.0, inertia=1.33, length=0.63, com=0.24)
THIGH = dict(mass=6.8, inertia=0.47, length=0.4, com=0.11)
SHIN = dict(mass=3.2, inertia=0.2, length=0.4, com=0.24)

#: Standing posture of the anchor scenario: joint references [hip_1, knee_1, hip_2, knee_2].
STANDING_REFERENCE = np.array([-0.3, 0.6, 0.3, 0.0])
#: Hip height (m) at which the anchor scenario starts.
STANDING_HIP_HEIGHT = 0.78


def model(torso=TORSO, thigh=THIGH, shin=SHIN, gravity: float = 9.81):
    """The five-link biped as a :class:`bipedlab.mechanics.Model` (joints actuated, base not)."""
    bodies = [Body("torso", None, torso["mass"], (0.0, torso["com"]), torso["inertia"])]
    for side in ("1", "2"):
        bodies.append(Body(f"hip_{side}", "torso", thigh["mass"], (0.0, -thigh["com"]), thigh["inertia"]))
        bodies.append(
            Body(f"knee_{side}", f"hip_{side}", shin["mass"], (0.0, -shin["com"]), shin["inertia"],
                 offset=(0.0, -thigh["length"]))
        )
    points = [
        Point("foot_1", "knee_1", (0.0, -shin["length"])),
        Point("foot_2", "knee_2", (0.0, -shin["length"])),
        Point("torso_top", "torso", (0.0, torso["length"])),
        Point("hip", "torso", (0.0, 0.0)),
        Point("knee_1_point", "hip_1", (0.0, -thigh["length"])),
        Point("knee_2_point", "hip_2", (0.0, -thigh["length"])),
    ]
    return build_model(bodies, points, gravity=gravity, base_names=("x_hip", "y_hip", "torso"))


def standing_state() -> jnp.ndarray:
    """The anchor scenario's initial state x = [q, qd] (hip at 0.78 m, at rest)."""
    x = np.zeros(14)
    x[1] = STANDING_HIP_HEIGHT
    x[3:7] = STANDING_REFERENCE
    return jnp.asarray(x)


#: Relabelling permutation that swaps leg 1 and leg 2 (for q and for qd).
LEG_SWAP = (0, 1, 2, 5, 6, 3, 4)


def mjcf(**kwargs) -> str:
    """MJCF of the five-link biped with exact inertias (see :func:`bipedlab.mechanics.mjcf.to_mjcf`)."""
    from bipedlab.mechanics.mjcf import to_mjcf

    return to_mjcf(model(), **kwargs)


def stance():
    """The five-link biped in single support on foot_1, swing foot foot_2; stance coordinates
    z = [torso, hip_st, knee_st, hip_sw, knee_sw, and their rates]."""
    from bipedlab.mechanics.stance import stance_from_names

    return stance_from_names(model(), "foot_1", "foot_2", LEG_SWAP)


def hzd_outputs():
    """(H0, c) for walking: the four joint angles are controlled, and the phase is
    theta = -(torso + hip_st + knee_st / 2), the angle of the stance leg's hip-to-toe line
    behind the vertical (equal thigh and shin lengths), which grows over a forward step."""
    H0 = np.eye(5)[1:]
    c = np.array([-1.0, -1.0, -0.5, 0.0, 0.0])
    return H0, c


def gait_guess(speed: float = 0.8) -> np.ndarray:
    """A pre-impact stance state to start gait optimisation from: symmetric legs 0.5 m apart,
    knees bent 0.1 rad forward, torso leaning 0.05 rad forward, the stance leg rotating at
    2 speed rad/s about the toe."""
    w = 2.0 * speed
    return np.array([-0.05, -0.218, -0.1, 0.418, -0.1, 0.0, -w, 0.0, 0.75 * w, 0.0])


#: Initial guess of the free Bézier coefficients' swing-knee row: flexed in mid-swing so the
#: swing foot clears the ground.
SWING_KNEE_GUESS = -0.6
