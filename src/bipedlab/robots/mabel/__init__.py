"""MABEL: five links, a boom, and a cable-differential drivetrain with unilateral springs.

* :mod:`.tables` - the published numbers (identification paper Tables IV-VIII, HZD paper).
* :mod:`.transmission` - differentials, gear ratios, cable stretch, spring and hard stop.
* :mod:`.model` - the 13-DoF hopping model and the 9-DoF rigid-cable model.
* :mod:`.dynamics` - equations of motion, energy, and the time step for the stiff stop.
* :mod:`.walking` - compliant-HZD walking (HZD paper): stance model and transition map,
  sub-phase virtual constraints, controllers, zero dynamics, gait design, Poincaré maps, the
  sampled closed loop, studies and plots.
* :mod:`.hopping` - the two-legged hopping controller (identification paper, Appendix C), its
  study and Poincaré analysis.
* :mod:`.sysid` - the system identification: experiments, estimators, logs, study.

The names below load on first use, so that the command line's discovery of this package
imports nothing heavy.
"""
from __future__ import annotations

import importlib

_NAMES = {"energy": "dynamics", "flow": "dynamics", "step": "dynamics", "toe_positions": "dynamics",
          "COORDS_9": "model", "COORDS_13": "model", "Mabel": "model", "hopping_model": "model",
          "rigid_model": "model"}
_MODULES = ("dynamics", "model", "tables", "transmission")

__all__ = ["dynamics", "model", "tables", "transmission", "energy", "flow", "step", "toe_positions",
           "COORDS_9", "COORDS_13", "Mabel", "hopping_model", "rigid_model"]


def __getattr__(name):
    if name in _MODULES:
        return importlib.import_module(f"bipedlab.robots.mabel.{name}")
    if name in _NAMES:
        return getattr(importlib.import_module(f"bipedlab.robots.mabel.{_NAMES[name]}"), name)
    raise AttributeError(f"module 'bipedlab.robots.mabel' has no attribute {name!r}")
