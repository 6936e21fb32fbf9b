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
}
#: the paper's standard deviations of the bounce height (m) and apex speed (m/s) on the rough
#: terrain with steps up to 25 cm (Sec. IV-B, IV-C; one run each), by case: the robot under
#: energy regulation (flat on average, and on the 1 % slope), under energy conservation (without
#: and with sensor noise), and the pure spring-mass model
PAPER_ROUGH_SD = {"regulation": (0.104, 0.255), "regulation-slope": (0.102, 0.264), "conservation": (0.053, 0.202),
                  "conservation-noise": (0.101, 0.261), "spring-mass": (0.018, 0.186)}
