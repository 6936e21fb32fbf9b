"""The walking studies' vocabularies and measured facts, as data: the names the studies take
(gaits, controllers, sensing, plants, design models, costs, experiments) and what the studies
measured about the shipped gaits (which pairings fall, which gait strikes the ground behind
the stance toe), with the reasons ``walk mabel`` and ``experiment mabel`` refuse a request.

The studies (:mod:`.study`, :mod:`.controllers`, :mod:`.design`, :mod:`.experiments`) and the
command line (:mod:`bipedlab.robots.mabel.cli`, :mod:`bipedlab.robots.mabel.robustness`) read
these names from here. This module imports nothing, so that the command line's parser builds
without JAX.
"""
from __future__ import annotations

#: shipped gaits: ``nominal``, ``efficient`` and ``fast`` designed on the full design model;
#: ``paper-nominal`` and ``paper-efficient`` are what ``optimize mabel --speed 0.8 --cost
#: torque|cmt`` gives on the default (paper) design model; ``paper-575`` is the torque gait of
#: that model at the paper's nominal step, ``optimize mabel --speed 0.8 --step-length 0.575``
#: (the gait closest to the paper's Exp. 1 gait: restricted map 0.709); ``paper-efficient-clear``
#: is the c_mt gait of that model with EFFICIENT_CLEARANCE of swing-toe clearance at mid-step,
#: ``optimize mabel --speed 0.8 --cost cmt --clearance 0.01`` (Exp. 3's gait)
GAITS = ("nominal", "efficient", "fast", "paper-nominal", "paper-efficient", "paper-575", "paper-efficient-clear")
#: the swing toe's clearance at mid-step of Exp. 3's gait (m). Appendix B asks only that the swing
#: toe stay above the ground; the c_mt optimum of the paper's design model (paper-efficient)
#: then grazes it (0 mm at a third of the step, 1.6 cm at most) and on the 13-DoF plant the
#: swing toe scuffs the ground as the legs cross and every controller falls in steps 1-4.
#: Measured on the 13-DoF plant, encoders, 100 steps, the same design with a clearance of
#: 0.5 * 2^k cm: 0.5 cm, the decentralised controller falls in step 2 (PD + feedforward and eq.
#: 42 walk); 1 cm, all three walk (designed c_mt 0.0410 against 0.0392 without). The smallest of
#: that grid with which all three walk.
EFFICIENT_CLEARANCE = 0.01
DEFAULT_GAIT = "nominal"
#: the paper's gait each shipped gait stands for (its Exp. 1 ``nominal`` gait, its c_mt-optimal
#: ``efficient`` gait); ``fast`` has no designed counterpart in the paper (Exp. 5 leaned the
#: nominal gait forward)
STANDS_FOR = {"nominal": "nominal", "paper-nominal": "nominal", "paper-575": "nominal",
              "efficient": "efficient", "paper-efficient": "efficient", "paper-efficient-clear": "efficient",
              "fast": None}
#: the gait of the experiments that compare with the robot's walks (Exps. 1, 2, 4 and 5, the
#: tracking comparison, Table I): ``paper-575``, the paper's design model at the paper's nominal
#: step (0.575 m), the gait closest to the one the robot walked. Its designed torque cost is
#: 4.75 against 3.83 at the model's free optimum (a 0.457 m step): the paper's step is reachable
#: at that measured extra cost. ``nominal`` (full design model, 0.656 m steps) stays a shipped
#: gait and the default of ``walk mabel``.
EXPERIMENT_GAIT = "paper-575"
#: the walking controllers' torques, in their order (a walk record's ``peak_torques_nm``,
#: ``saturation_fraction``)
ACTUATORS = ("mLA_st", "mLS_st", "mLA_sw", "mLS_sw")
#: controllers of the walking loop: PD + feedforward (eq. 43), I/O linearisation with the
#: hybrid-invariance corrections, and its decentralised form
CONTROLLERS = ("pdff", "iolin", "decentralized")
DEFAULT_CONTROLLER = "pdff"
#: sensing options: 14-bit encoders with the filtered backward difference (the experiments'),
#: the same encoders with the model-based velocity observer, or the exact state
SENSING = ("encoders", "observer", "ideal")
#: plants ``walk mabel`` can drive: the stance model the gaits are designed on (rigid cables,
#: pinned toe, swing spring at rest, rigid impact), or the 13-DoF model with cable stretch, the
#: compliant ground and a free swing spring (:mod:`.full_plant`)
PLANTS = ("stance", "full")
#: design models of a gait: with motor friction and spring damping in the zero dynamics
#: (``full``), or the HZD paper's, without them (``paper``)
DESIGN_MODELS = ("full", "paper")
#: costs of the gait design: integral of squared torque per step length, or mechanical c_mt
COSTS = ("torque", "cmt")
#: the experiments of ``experiment mabel`` (:mod:`.experiments`)
EXPERIMENTS = ("nominal", "push", "efficient", "tracking", "impact-scaling", "fast", "sweep", "pd-gains", "exp4",
               "full-plant", "sensitivity")
#: the push experiment's step (counted from 0)
PUSH_STEP = 10
#: impact-scaling: the steady speed is the mean over the last STEADY_STEPS steps
STEADY_STEPS = 10
#: experiments that walk no fixed number of steps, and why --steps does not apply to them
NO_STEPS = {"sweep": "the sweep designs gaits, it does not walk them",
            "pd-gains": "the eigenvalues come from the return map, not a walk",
            "sensitivity": "the sensitivity designs the gaits again on scaled models, it does not walk them"}
#: the largest horizontal push force of ``walk mabel --push``, N (the robot weighs about 650 N)
PUSH_FORCE = 1000.0

#: the shipped ``fast`` gait (designed at 1.52 m/s) under each (controller, sensing) pairing of
#: ``walk mabel``: (step, counted from 1, in which its swing toe strikes the ground behind the
#: stance toe, 0.03-0.05 s into that step; touchdowns before the fall; time of the fall in s),
#: measured on the closed loop (:func:`bipedlab.robots.mabel.walking.study.walk`, 5 steps
#: asked; the eq. 42 pairings at controllers.EPS_OUTPUTS, 0.05-0.06 s into the first step). After
#: the strike the hip drops below the walking range (PD + feedforward) or the torso pitches
#: forward past 75 deg (I/O linearisation).
FAST_GAIT_FALLS = {
    ("pdff", "encoders"): (1, 2, 0.535), ("pdff", "observer"): (1, 2, 0.569), ("pdff", "ideal"): (1, 2, 0.539),
    ("iolin", "encoders"): (1, 1, 0.180), ("iolin", "observer"): (1, 1, 0.169), ("iolin", "ideal"): (1, 1, 0.110),
    ("decentralized", "encoders"): (1, 1, 0.175), ("decentralized", "observer"): (1, 1, 0.105),
    ("decentralized", "ideal"): (1, 1, 0.162),
}

#: the other shipped gaits' (gait, controller, sensing) pairings that do not walk 100 steps on the
#: stance plant: (touchdowns before the fall, time of the fall in s), measured with
#: :func:`bipedlab.robots.mabel.walking.study.walk` (100 steps asked) at eq. 42's shipped eps
#: per output (controllers.EPS_OUTPUTS); every pairing not listed walks 100 steps (the 24 eq. 42
#: pairings of nominal, paper-nominal, paper-efficient, efficient and paper-575 measured again
#: at EPS_OUTPUTS on a two-core Xeon, PD + feedforward's unchanged). At one eps on every output
#: (controllers.EPS) eq. 42 with the velocity observer fell on efficient in step 4 (0.74 s in) and
#: the decentralised form with exact sensing walked it; at the earlier 0.05 the decentralised
#: controller fell on efficient (encoders, observer). paper-efficient-clear's nine pairings
#: (PD + feedforward included), measured when it was added: all walk 100 steps.
GAIT_FALLS = {
    ("efficient", "decentralized", "ideal"): (1, 0.21),
}
#: the full-model ``efficient`` gait: its swing toe clears the ground by at most 1.9 cm on the
#: designed orbit, and under each pairing (measured: PD + feedforward on encoders, step lengths
#: -0.21, +0.54, -0.26 m, ...) it strikes the ground behind the stance toe in the first step,
#: about 0.17 s in, so the walk alternates backward and forward touchdowns (or falls, GAIT_FALLS)
TOE_STRIKES = {"efficient"}


def walk_refusal(gait: str, controller: str, sensing: str, plant: str) -> str | None:
    """Why ``walk mabel`` refuses a shipped gait under a (controller, sensing) pairing on a
    plant, from the measurements above; None when it walks (or ``gait`` is a file)."""
    pairing = (controller, sensing)
    if gait == "fast" and pairing in FAST_GAIT_FALLS:
        strike, steps, t = FAST_GAIT_FALLS[pairing]
        return (f"the shipped fast gait falls under every controller in this model ({controller} with {sensing} "
                f"sensing: its swing toe strikes the ground behind the stance toe in step {strike} and it falls "
                f"{t:.2f} s in, in step {steps + 1}); for fast walking lean the nominal gait forward (experiment "
                f"mabel fast)")
    key = (gait, controller, sensing)
    if plant == "stance" and gait in TOE_STRIKES and key not in GAIT_FALLS:
        return ("its swing toe clears the ground by 1.9 cm at most and strikes it behind the stance toe in the first "
                "step, so the walk alternates backward and forward touchdowns; walk paper-efficient, the c_mt gait of "
                "the paper's design model")
    if plant == "stance" and key in GAIT_FALLS:
        steps, t = GAIT_FALLS[key]
        rest = ("its swing toe also strikes the ground behind the stance toe in the first step; walk paper-efficient, "
                "the c_mt gait of the paper's design model" if gait in TOE_STRIKES else
                "the other sensing options walk it")
        return (f"falls under {controller} with {sensing} sensing in this model (in step {steps + 1}, {t:.2f} s in, "
                f"of 100 asked); {rest}")
    return None


def experiment_steps_refusal(name: str, steps: int) -> str | None:
    """Why ``experiment mabel NAME --steps N`` cannot mean anything; None when it can."""
    if name in NO_STEPS:
        return f"--steps does not apply ({NO_STEPS[name]})"
    if name == "push" and steps <= PUSH_STEP:
        return (f"--steps must be at least {PUSH_STEP + 1} to reach the push in step {PUSH_STEP} (counted from 0), "
                f"got {steps}")
    if name == "impact-scaling" and steps < STEADY_STEPS:
        return (f"--steps must be at least {STEADY_STEPS} (the steady speed is the mean of the last {STEADY_STEPS} "
                f"steps), got {steps}")
    return None


def by_magnitude(pairs) -> list:
    """The eigenvalues a record stores as (re, im) pairs, as complex numbers, the largest modulus
    first (the order in which the restricted map's dominant, second and third are named)."""
    return sorted((complex(re, im) for re, im in pairs or ()), key=abs, reverse=True)
