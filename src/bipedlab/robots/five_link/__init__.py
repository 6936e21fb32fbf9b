"""The five-link planar biped (torso, two thighs, two shins, point feet): the speed anchors'
model, HZD gait design and walking (:mod:`.study`), the bench scenario (:mod:`.scenario`,
:mod:`.bench`) and its plots."""
from bipedlab.robots.five_link.robot import (LEG_SWAP, SHIN, STANDING_HIP_HEIGHT, STANDING_REFERENCE, SWING_KNEE_GUESS,
                                             THIGH, TORSO, gait_guess, hzd_outputs, mjcf, model, stance,
                                             standing_state)

__all__ = ["LEG_SWAP", "SHIN", "STANDING_HIP_HEIGHT", "STANDING_REFERENCE", "SWING_KNEE_GUESS", "THIGH", "TORSO",
           "gait_guess", "hzd_outputs", "mjcf", "model", "stance", "standing_state"]
