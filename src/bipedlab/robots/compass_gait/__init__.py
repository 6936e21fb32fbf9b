"""The passive compass-gait walker (Goswami, Thuilot & Espiau), written only against the
robot-agnostic core: :mod:`.model` (model, flow, guard, reset), :mod:`.walker` (step, return
map, period-one gait), :mod:`.study` (the ``walk`` study) and :mod:`.cli` (its command).

The names below load on first use, so that the command line's discovery of this package
imports nothing heavy."""
from __future__ import annotations

import importlib

_NAMES = {"CompassGaitParams": "model", "params": "model", "Gait": "walker", "period_one_gait": "walker",
          "return_map": "walker", "step": "walker"}

__all__ = list(_NAMES)


def __getattr__(name):
    if name in _NAMES:
        return getattr(importlib.import_module(f"bipedlab.robots.compass_gait.{_NAMES[name]}"), name)
    raise AttributeError(f"module 'bipedlab.robots.compass_gait' has no attribute {name!r}")
