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
"""
from bipedlab.robots.mabel import dynamics, model, tables, transmission
from bipedlab.robots.mabel.dynamics import energy, flow, step, toe_positions
from bipedlab.robots.mabel.model import COORDS_9, COORDS_13, Mabel, hopping_model, rigid_model

__all__ = ["dynamics", "model", "tables", "transmission", "energy", "flow", "step", "toe_positions",
           "COORDS_9", "COORDS_13", "Mabel", "hopping_model", "rigid_model"]
