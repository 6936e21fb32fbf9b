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
