"""The running study's vocabularies, as data: the terrains, the energy options and the
controller-model parameters a model error may scale. The study (:mod:`.study`) and the command
line (:mod:`.cli`) read them here; this module imports nothing, so that the command line's
parser builds without JAX."""
from __future__ import annotations

#: the controller-model parameters ``--model-error`` may scale
MODEL_ERRORS = ("mass", "inertia", "friction", "stiffness")
#: rough terrains (--terrain) -> bipedlab.contact.terrain.rough mode
ROUGH_MODES = {"rough": "paper", "rough-reflected": "bounded"}
#: terrains: flat ground, the rough terrains, a constant slope
TERRAINS = ("flat", *ROUGH_MODES, "slope")
#: stance energy management
ENERGY = ("conservation", "regulation")
#: the stance/flight controllers: the paper's as published, or with bipedlab's additions
#: (the additions each and what they change: :data:`ADDITIONS`)
CONTROLLERS = ("paper", "bipedlab")
#: bipedlab's additions to the paper's controller: name -> what it does (the controller
#: parameters that switch it off are in :func:`bipedlab.robots.atrias.controller.paper_controller`)
ADDITIONS = {
    "energy integral": "the lift-off energy error adds 0.3 times the sum of past errors (integral action)",
    "landing-angle trim": "each lift-off trims the landing angle by 0.25 rad/m of apex-height error (at most 0.03 rad)",
    "lift-off debounce": "lift-off counts only after 2 cm of leg compression or 40 ms of stance",
}
