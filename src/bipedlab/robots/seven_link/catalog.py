"""The seven-link studies' vocabularies, as data: the controller's parameter sets, the plants
and the validation experiments. The studies (:mod:`.study`, :mod:`.setup`) and the command
line (:mod:`.cli`, :mod:`.robustness`) read them here; this module imports nothing, so that the
command line's parser builds without JAX."""
from __future__ import annotations

#: the controller's Table II parameters as published, or retuned for the planar model
PARAMS = ("paper", "tuned")
DEFAULT_PARAMS = "tuned"
#: the plants: the planar model, or the experimental setup (:mod:`.setup`)
SETUPS = ("planar", "boom")
DEFAULT_SETUP = "planar"
#: the validation experiments of ``experiment seven-link``
EXPERIMENTS = ("free-swing", "low-gain-pd", "sensitivity")
