"""The golden cases (no bipedlab import): data file name -> how to recompute it, whether it
is slow, and its tolerances. Shared by record.py and the tests."""
from __future__ import annotations

from typing import NamedTuple


class Case(NamedTuple):
    func: str            # adapter function name (or "cli" for a CLI record)
    args: tuple = ()     # positional args (the argv for "cli")
    slow: bool = False
    rtol: float = 1e-9
    atol: float = 1e-12
    #: per-key tolerances (dotted path prefix -> (rtol, atol)), see adapter.py's docstring
    special: tuple = ()


EIG = (("eigenvalue_moduli", 1e-7, 1e-9), ("jacobian", 1e-9, 1e-10))
#: MABEL's walks on CPUs with and without AVX-512 (the records were made on an AMD EPYC with
#: AVX2 only; XLA vectorises, and so rounds, differently with AVX-512): measured up to 2.2e-7
#: relative in the logged states of the 3-step walks (walk_mabel_pdff / _iolin), and in the
#: CLI records, where a last-bit difference flips an encoder count or moves a touchdown by one
#: 1 ms sample, 4.2e-4 in a duration (one sample in 2.4 s) and 1.4e-3 in c_mt (the positive
#: work sums |u w| over noisy encoder rates). The walks are held to those sizes with a margin.
CROSS_CPU_WALK = 1e-6
CROSS_CPU_RECORD = 5e-3
#: the records' peaks and RMS errors move most: a flipped count is a one-sample spike in the
#: differentiated rate and so in the torque (measured up to 14 % in a peak torque, 8.1 % in the
#: smallest normal force, 3.8 % in a peak tracking error, 1.2 % in an RMS error)
CROSS_CPU_PEAKS = (("tracking_peak_deg", 0.2, 1e-9), ("peak_torques_nm", 0.2, 1e-9), ("min_normal_force_n", 0.2, 1e-9),
                   ("max_friction_ratio", 0.2, 1e-9), ("tracking_rms_deg", 0.05, 1e-9),
                   # the rate estimate's error is the differentiated encoder noise (an RMS, as the
                   # tracking's); the cable stretch follows the torques (peaks as theirs, RMS as
                   # the tracking's); a saturated sample more or less, or one sample later
                   ("rate_estimate_error_rms", 0.05, 1e-9), ("cable_stretch_peak_deg", 0.2, 1e-9),
                   ("cable_stretch_rms_deg", 0.05, 1e-9), ("saturation_fraction", 0.0, 2e-3),
                   ("first_saturation_s", 0.0, 2e-3))
#: sysid least-squares iterates: ``rel_error`` = estimate / true - 1 loses three digits to
#: cancellation (|rel_error| ~ 1e-3), so it is held in absolute terms: abs 1e-6 is the estimate
#: itself to 1e-6 relative, the case's tolerance for every estimate (measured change up to
#: 1.4e-8, from the rotor-cable rig's 1e-16 RK4 reassociation amplified by the fit);
#: ``rel_std`` comes from the fit's Jacobian at the iterate, rel 1e-5 (measured 1.4e-6).
SYSID = (("*rel_error", 0.0, 1e-6), ("*rel_std", 1e-5, 1e-9))

#: MABEL's gaits of the paper's design model (the design rows', Exps. 1-5's and Exp. 3's)
PAPER_GAITS = ("paper-nominal", "paper-575", "paper-efficient", "paper-efficient-clear")
#: the shipped RABBIT (robot file, gait file) of the imported robots
RABBIT = ("rabbit.xml", "rabbit_0.8.json")

QUANTITIES = {
    "gait_five_link_0.8": Case("five_link_gait"),
    "gait_mabel_nominal": Case("mabel_gait", ("nominal",)),
    "gait_mabel_efficient": Case("mabel_gait", ("efficient",)),
    "gait_mabel_fast": Case("mabel_gait", ("fast",)),
    # the paper-model gaits the experiments walk (file contents: exact)
    **{f"gait_mabel_{g.replace('-', '_')}": Case("mabel_gait", (g,)) for g in PAPER_GAITS},
    "gait_rabbit": Case("imported_gait", RABBIT),
    # MABEL's maps at the gaits the experiments walk: restricted (eq. 48) and full (eq. 44)
    # under PD + feedforward
    **{f"poincare_mabel_{g.replace('-', '_')}": Case("mabel_poincare", (g,), slow=True, special=EIG)
       for g in ("nominal",) + PAPER_GAITS},
    "poincare_rabbit": Case("imported_poincare", RABBIT, slow=True, special=EIG),
    # a biped written for the tests, designed with optimize model's defaults (clearance, retry)
    "optimize_heron": Case("imported_design", ("heron.xml", "foot_l", "foot_r", 0.8), slow=True, rtol=1e-6, atol=1e-9),
    "poincare_five_link_restricted": Case("five_link_restricted"),
    "poincare_five_link_iolin": Case("five_link_poincare", ("iolin",), slow=True, special=EIG),
    "poincare_five_link_pd": Case("five_link_poincare", ("pd",), slow=True, special=EIG),
    "poincare_mabel_restricted_nominal": Case("mabel_restricted", ("nominal",), slow=True, special=EIG),
    "walk_five_link_iolin": Case("five_link_walk", ("iolin",), slow=True),
    "walk_five_link_pd": Case("five_link_walk", ("pd",), slow=True),
    "walk_mabel_pdff": Case("mabel_walk", ("pdff",), rtol=CROSS_CPU_WALK, atol=1e-9),
    "walk_mabel_iolin": Case("mabel_walk", ("iolin",), slow=True, rtol=CROSS_CPU_WALK, atol=1e-9),
    # paper-575, the gait of Exps. 1, 2, 4, 5, under each controller (stance model, encoders)
    **{f"walk_mabel_{c}_paper_575": Case("mabel_walk", (c, 1, "encoders", "paper-575"), slow=True,
                                         rtol=CROSS_CPU_WALK, atol=1e-9) for c in ("pdff", "iolin", "decentralized")},
    "walk_rabbit": Case("imported_walk", RABBIT, slow=True, rtol=1e-7, atol=1e-9),
    # five steps: the program of the seven-link tests' short walks (test_walk_seven_link,
    # test_seven_link_boom, test_seven_link_contact_sequence), compiled once per run
    "walk_seven_link": Case("seven_link_walk", (5,)),
    "run_atrias": Case("atrias_run"),
    "run_slip": Case("slip_run"),
    "hop_mabel": Case("mabel_hop"),
    "bench_standing": Case("bench_standing"),
    "optimize_five_link": Case("five_link_optimize", slow=True, rtol=1e-6, atol=1e-9),
}

CLI = {
    "cli_walk_five_link": Case("cli", ("walk", "five-link", "--steps", "3"), slow=True),
    "cli_walk_five_link_pd": Case("cli", ("walk", "five-link", "--steps", "3", "--controller", "pd"), slow=True),
    "cli_walk_mabel": Case("cli", ("walk", "mabel", "--steps", "3"), slow=True, rtol=CROSS_CPU_RECORD,
                           special=CROSS_CPU_PEAKS),
    "cli_walk_mabel_iolin": Case("cli", ("walk", "mabel", "--steps", "3", "--controller", "iolin"), slow=True,
                                 rtol=CROSS_CPU_RECORD, special=CROSS_CPU_PEAKS),
    "cli_walk_mabel_decentralized": Case("cli", ("walk", "mabel", "--steps", "3", "--controller", "decentralized"),
                                         slow=True, rtol=CROSS_CPU_RECORD, special=CROSS_CPU_PEAKS),
    # the 13-DoF plant under each controller, on the gait the experiments walk and on the
    # paper-model gait (the compliant ground's impacts, cable stretch, eq. 42's default eps)
    **{f"cli_walk_mabel_full_{c}_{g.replace('-', '_')}": Case(
        "cli", ("walk", "mabel", "--plant", "full", "--steps", "3", "--controller", c, "--gait", g), slow=True,
        rtol=CROSS_CPU_RECORD, special=CROSS_CPU_PEAKS)
       for c in ("pdff", "iolin", "decentralized") for g in ("nominal", "paper-nominal", "paper-575")},
    "cli_walk_seven_link": Case("cli", ("walk", "seven-link", "--steps", "2"), slow=True),
    "cli_experiment_seven_link_free_swing": Case("cli", ("experiment", "seven-link", "free-swing")),
    "cli_run_atrias": Case("cli", ("run", "atrias", "--seconds", "1", "--controller", "bipedlab")),
    "cli_run_atrias_trials": Case("cli", ("run", "atrias", "--trials", "2", "--seconds", "1", "--controller", "bipedlab"),
                                 slow=True),
    "cli_hop_mabel": Case("cli", ("hop", "mabel", "--hops", "2", "--no-poincare")),
    "cli_identify_mabel_quick": Case("cli", ("identify", "mabel", "--synthetic", "--quick"), slow=True,
                                     rtol=1e-6, atol=1e-9, special=SYSID),
    "cli_optimize_five_link": Case("cli", ("optimize", "five-link"), slow=True, rtol=1e-6, atol=1e-9),
}

#: cases derived from another case's result (recorded beside it, not run on their own):
#: the sysid estimates of the identify record
DERIVED = {
    "sysid_quick": Case("sysid_quick", slow=True, rtol=1e-6, atol=1e-9, special=SYSID),
}

ALL = {**QUANTITIES, **CLI}
#: every name _check.check accepts
CHECKED = {**ALL, **DERIVED}
