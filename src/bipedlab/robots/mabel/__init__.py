"""MABEL: five links, a boom, and a cable-differential drivetrain with unilateral springs.

* :mod:`.tables` - the published numbers (identification paper Tables IV-VIII, HZD paper).
* :mod:`.transmission` - differentials, gear ratios, cable stretch, spring and hard stop.
* :mod:`.model` - the 13-DoF hopping model and the 9-DoF rigid-cable model.
* :mod:`.dynamics` - equations of motion, energy, and the time step for the stiff stop.
* :mod:`.walking` - the stance model on the 9-DoF model and the stance-to-stance transition.
"""
from . import dynamics, model, tables, transmission, walking
from .dynamics import energy, flow, step, toe_positions
from .model import COORDS_9, COORDS_13, Mabel, hopping_model, rigid_model

__all__ = ["dynamics", "model", "tables", "transmission", "walking", "energy", "flow", "step", "toe_positions",
           "COORDS_9", "COORDS_13", "Mabel", "hopping_model", "rigid_model"]
