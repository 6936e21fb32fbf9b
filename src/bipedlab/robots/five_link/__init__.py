"""The five-link planar biped (torso, two thighs, two shins, point feet): the speed anchors'
model, HZD gait design and walking (:mod:`.study`), the bench scenario (:mod:`.scenario`,
:mod:`.bench`) and its plots.

The names below (from :mod:`.robot`) load on first use, so that the command line's discovery
of this package imports nothing heavy."""
from __future__ import annotations

import importlib

__all__ = ["LEG_SWAP", "SHIN", "STANDING_HIP_HEIGHT", "STANDING_REFERENCE", "SWING_KNEE_GUESS", "THIGH", "TORSO",
           "gait_guess", "hzd_outputs", "mjcf", "model", "stance", "standing_state"]


def __getattr__(name):
    if name in __all__:
        return getattr(importlib.import_module("bipedlab.robots.five_link.robot"), name)
    raise AttributeError(f"module 'bipedlab.robots.five_link' has no attribute {name!r}")
