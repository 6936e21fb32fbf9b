"""The running study's vocabularies, as data: the terrains, the energy options and the
controller-model parameters a model error may scale. The study (:mod:`.study`) and the command
line (:mod:`.cli`) read them here; this module imports nothing, so that the command line's
parser builds without JAX."""
from __future__ import annotations

#: the experiments of ``bipedlab experiment atrias``
EXPERIMENTS = ("sensitivity",)
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
#: the robot's values a sensitivity may scale (plant and controller alike): name -> (what it is,
#: the relative precision its source states it to (half a unit of the last printed digit), or None
#: for a value chosen here, where the paper gives none, and the source). The paper itself gives
#: only "about 60kg" and legs "about 1m" (Sec. II-B).
SCALABLE = {
    "m": ("trunk mass (59 kg)", None, "chosen (the paper: about 60 kg in all)"),
    "I_t": ("trunk inertia (1.37 kg m^2)", 0.005 / 1.37, "ATRIAS parameter sheet, printed digits"),
    "d": ("COM above the hip (0.1 m)", None, "chosen"),
    "I_m": ("hip inertia per leg (1.0 kg m^2)", None, "chosen"),
    "m_f": ("foot mass (0.2 kg)", None, "chosen"),
    "tau_max": ("hip torque limit (250 N m)", None, "chosen"),
    "k0": ("spring-mass leg stiffness (32 kN/m)", None, "a later controller of the robot"),
    "l0": ("spring-mass leg rest length (1 m)", None, "chosen (the paper: legs about 1 m)"),
    "depth_y": ("ground normal depth (weight / stiffness, 0.01 m)", 0.005 / 0.01, "Geyer & Herr 2010, printed digits"),
    "depth_x": ("ground stiction depth (weight / stiffness, 0.1 m)", 0.05 / 0.1, "Geyer & Herr 2010, printed digits"),
    "v_max": ("ground damping speed (0.03 m/s)", 0.005 / 0.03, "Geyer & Herr 2010, printed digits"),
    "mu_stick": ("ground stiction limit (0.9)", 0.05 / 0.9, "Geyer & Herr 2010, printed digits"),
    "mu_slide": ("ground sliding friction (0.8)", 0.05 / 0.8, "Geyer & Herr 2010, printed digits"),
}
