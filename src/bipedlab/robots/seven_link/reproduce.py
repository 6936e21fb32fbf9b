"""The seven-link paper (Braun, Mitchell & Goldfarb) in ``bipedlab reproduce``: the walking
gait (Sec. IV, Figs. 8-9, Table II's ranges and claims on the boom setup it was tuned on), the free-swing experiments
(Fig. 6) and the low-gain PD experiment (Fig. 7), through :mod:`bipedlab.robots.seven_link.study`. Paper values:
``data/paper_seven_link.json``."""
from __future__ import annotations

from pathlib import Path

from bipedlab.report import Experiment, Failed, Figure, Measured, Paper, Sensitivity, Skip, dig

DATA = Path(__file__).parent / "data" / "paper_seven_link.json"
WALK_STEPS, QUICK_WALK_STEPS = 30, 10


def _walk(args, out, progress):
    from bipedlab.robots.seven_link import study

    return study.walk(args["steps"], args["params"], out=out, progress=progress, setup=args.get("setup", "planar"))


def _free_swing(args, out, progress):
    from bipedlab.robots.seven_link import study

    return study.free_swing(out=out, duration=args["duration_s"], progress=progress)


def _sensitivity(args, out, progress):
    from bipedlab.robots.seven_link import sensitivity

    return sensitivity.sensitivity(args["steps"], args["params"], step=args["step"], progress=progress)


def _low_gain_pd(args, out, progress):
    from bipedlab.robots.seven_link import study

    return study.low_gain_pd(out=out, duration=args["duration_s"], progress=progress)


EXPERIMENTS = (
    Experiment("walk", f"bipedlab walk seven-link --steps {WALK_STEPS}", _walk,
               dict(steps=WALK_STEPS, params="tuned"), dict(steps=QUICK_WALK_STEPS, params="tuned"),
               reduction=f"{QUICK_WALK_STEPS} steps instead of {WALK_STEPS} (gait figures over steps 7-10 only)",
               expected_s=100, quick_expected_s=40),
    Experiment("walk-table-ii", f"bipedlab walk seven-link --steps {WALK_STEPS} --params paper", _walk,
               dict(steps=WALK_STEPS, params="paper"), dict(steps=QUICK_WALK_STEPS, params="paper"),
               reduction=f"{QUICK_WALK_STEPS} steps instead of {WALK_STEPS} (the same compiled walk as the tuned one)",
               expected_s=50, quick_expected_s=10),
    Experiment("walk-table-ii-boom", f"bipedlab walk seven-link --steps {WALK_STEPS} --params paper --setup boom",
               _walk, dict(steps=WALK_STEPS, params="paper", setup="boom"),
               dict(steps=QUICK_WALK_STEPS, params="paper", setup="boom"),
               reduction=f"{QUICK_WALK_STEPS} steps requested instead of {WALK_STEPS}", expected_s=30,
               quick_expected_s=8),
    Experiment("sensitivity", f"bipedlab experiment seven-link sensitivity --steps {WALK_STEPS}", _sensitivity,
               dict(steps=WALK_STEPS, params="paper", step=0.01), None,
               skip_reason="not run in --quick (32 walks of 30 steps)", expected_s=800),
    Experiment("free-swing", "bipedlab experiment seven-link free-swing", _free_swing, dict(duration_s=6.0),
               dict(duration_s=6.0), reduction="as in the full run", expected_s=5, quick_expected_s=5),
    Experiment("low-gain-pd", "bipedlab experiment seven-link low-gain-pd", _low_gain_pd, dict(duration_s=8.0),
               dict(duration_s=8.0), reduction="as in the full run", expected_s=8, quick_expected_s=8),
)


def _ratio(a, b):
    return None if a is None or not b else a / b


def _gait_rows(rec, name: str, prefix: str, quick_skip: str) -> dict:
    """The gait-phase rows of one walk record (``gait_phases`` of
    :func:`bipedlab.robots.seven_link.study.walk`): Fig. 8's ranges, the extended-knee stance,
    Fig. 9's pre-emptive push-off and rolling double support."""
    keys = [f"{prefix}fig8_{j}_{q}_range_{u}" for j in ("hip", "knee", "ankle")
            for q, u in (("angle", "deg"), ("torque", "nm"))]
    keys += [f"{prefix}{k}" for k in ("knee_extended_stance_fraction", "preemptive_push_off_fraction",
                                      "push_off_ankle_work_j", "rolling_double_support_fraction")]
    if not rec:
        return {k: Skip(quick_skip) for k in keys}
    g = rec.get("gait_phases")
    if not g:
        why = (f"the walk fell after {rec.get('steps_completed', 0)} touchdowns, too few steps to analyse "
               f"(see experiment {name})") if rec.get("fell") else "too few steps after the transient"
        return {k: (Failed(why) if rec.get("fell") else Skip(why)) for k in keys}
    out = {}
    win = dict(first_touchdown=g["window_touchdowns"][0], last_touchdown=g["window_touchdowns"][1])
    for j in ("hip", "knee", "ankle"):
        r = g["ranges"][j]
        out[f"{prefix}fig8_{j}_angle_range_deg"] = Measured(r["angle_max_deg"] - r["angle_min_deg"],
                                                             dict(low=r["angle_min_deg"], high=r["angle_max_deg"], **win))
        out[f"{prefix}fig8_{j}_torque_range_nm"] = Measured(r["torque_max_nm"] - r["torque_min_nm"],
                                                             dict(low=r["torque_min_nm"], high=r["torque_max_nm"], **win))
    steps = g["steps"]
    ns = len(steps)
    out[f"{prefix}knee_extended_stance_fraction"] = Measured(
        g["heel_on_knee_extended_fraction"], dict(max_flexion=g["max_heel_on_knee_flexion_deg"], **win))
    pre = [s for s in steps if s["toe_only_before_strike"]]
    out[f"{prefix}preemptive_push_off_fraction"] = Measured(
        len(pre) / ns, dict(steps=ns, preemptive=len(pre), heel_strikes=sum(s["heel_strike"] for s in steps),
                            lead_min=min(s["heel_off_lead_s"] for s in steps),
                            lead_max=max(s["heel_off_lead_s"] for s in steps), **win))
    work = [s["push_off_ankle_work_j"] for s in steps]
    out[f"{prefix}push_off_ankle_work_j"] = Measured(min(work), dict(steps=ns, work_max=max(work), **win))
    roll = [s for s in steps if s["rolling_double_support"]]
    ds = [s["double_support_s"] for s in steps]
    out[f"{prefix}rolling_double_support_fraction"] = Measured(
        len(roll) / ns, dict(steps=ns, rolling=len(roll), ds_min=min(ds), ds_max=max(ds),
                             sample=g["log_sample_s"], **win))
    return out


def _sensitivity_of(rec: dict, quantity: str) -> Sensitivity:
    """A boom-walk quantity's :class:`~bipedlab.report.spec.Sensitivity` from the sensitivity
    experiment's record (the parameters whose scaled walk fell left out)."""
    rows = {k: r for k, r in rec["parameters"].items() if r["elasticity"][quantity] is not None}
    fell = f"; scaled by 1 %, {', '.join(rec['fell'])} made the walk fall (no elasticity)" if rec["fell"] else ""
    return Sensitivity(elasticity={k: r["elasticity"][quantity] for k, r in rows.items()},
                       precision={k: r["precision"] for k, r in rows.items()}, source=rec["precision_source"],
                       method=rec["method"] + " (experiment sensitivity)" + fell)


def measure(records: dict, quick: bool) -> dict:
    w, p = records.get("walk"), records.get("walk-table-ii")
    fs, pd = records.get("free-swing"), records.get("low-gain-pd")
    out = {}
    for key in ("speed_mps", "step_length_m", "step_frequency_hz", "cmt"):
        out[f"walk_{key}"] = dig(w, key) if w else Skip("not run")
    b = records.get("walk-table-ii-boom")
    for rec, name, prefix, where in ((p, "walk-table-ii", "walk_table_ii_", "on the planar model"),
                                     (b, "walk-table-ii-boom", "walk_table_ii_boom_", "on the boom setup")):
        for key in ("speed_mps", "step_length_m", "step_frequency_hz", "cmt"):
            if rec and rec.get("fell"):  # figures of a walk that fell are no gait's
                out[f"{prefix}{key}"] = Failed(
                    f"Table II does not walk {where}: it fell after {dig(rec, 'steps_completed', default=0)} "
                    f"touchdowns (see experiment {name})")
            else:
                out[f"{prefix}{key}"] = dig(rec, key) if rec else Skip("not run in --quick" if quick else "not run")
    sens = records.get("sensitivity")
    if b and not b.get("fell") and sens:
        for key in ("speed_mps", "step_length_m", "step_frequency_hz", "cmt"):
            out[f"walk_table_ii_boom_{key}"] = Measured(out[f"walk_table_ii_boom_{key}"],
                                                        sensitivity=_sensitivity_of(sens, key))
    hip, knee = dig(fs, "joints", "hip", default={}), dig(fs, "joints", "knee", default={})
    out["free_swing_hip_half_cycles"] = dig(hip, "21:1 (Table I)", "half_cycles")
    out["free_swing_knee_half_cycles"] = dig(knee, "12:1 (Table I)", "half_cycles")
    out["free_swing_hip_geared_ratio"] = _ratio(dig(hip, "105:1", "amplitude_after_1s_deg"),
                                                dig(hip, "21:1 (Table I)", "amplitude_after_1s_deg"))
    out["free_swing_knee_geared_ratio"] = _ratio(dig(knee, "60:1", "amplitude_after_1s_deg"),
                                                 dig(knee, "12:1 (Table I)", "amplitude_after_1s_deg"))
    for j, case in (("hip", "21:1 (Table I)"), ("knee", "12:1 (Table I)")):
        m = dig(fs, "joints", j, case)
        if not m:
            out[f"free_swing_{j}_period_s"] = out[f"free_swing_{j}_log_decrement"] = Skip("not run")
            continue
        out[f"free_swing_{j}_period_s"] = Measured(m.get("period_s"), dict(half_cycles=m.get("half_cycles")))
        out[f"free_swing_{j}_log_decrement"] = Measured(
            m.get("log_decrement_per_cycle"), dict(settling=m.get("settling_time_s"),
                                                  after_1s=m.get("amplitude_after_1s_deg")))
    for j in ("hip", "knee", "ankle"):
        out[f"pd_{j}_amplitude_ratio"] = dig(pd, "joints", j, "amplitude_ratio")
    # Fig. 8's ranges and Fig. 9's claims on the setup Table II was tuned on and walks (Sec. V-C)
    out.update(_gait_rows(b, "walk-table-ii-boom", "walk_table_ii_", "not run in --quick" if quick else "not run"))
    tuned = _gait_rows(w, "walk", "walk_", "not run")
    for k in ("knee_extended_stance_fraction", "preemptive_push_off_fraction", "rolling_double_support_fraction"):
        out[f"walk_{k}"] = tuned[f"walk_{k}"]
    return out


PAPERS = [Paper(
    key="seven-link", title="Actuated dynamic walking of a seven-link biped", values=str(DATA),
    experiments=EXPERIMENTS, measure=measure, order=40,
    figures=(Figure("walk-table-ii-boom", "angles_torques.png",
                    "Joint angles and torques while walking: Table II as published, boom setup (cf. paper Fig. 8)"),
             Figure("walk-table-ii-boom", "stick_figures.png",
                    "Stick-figure sequence of the gait: Table II as published, boom setup (cf. paper Fig. 9)"),
             Figure("walk-table-ii", "angles_torques.png",
                    "Joint angles and torques: Table II as published on the planar model, which falls"),
             Figure("walk", "angles_torques.png",
                    "Joint angles and torques while walking: bipedlab's gains (Table II retuned toward the paper's "
                    "0.5 m/s), planar model"),
             Figure("free-swing", "free_swing.png",
                    "Free swing of hip and knee, Table I gearing against 105:1 / 60:1 (cf. paper Fig. 6)"),
             Figure("low-gain-pd", "pd_experiment.png", "Low-gain PD with a modulated equilibrium (cf. paper Fig. 7)")),
    animations=(Figure("walk", "walk.html", "The seven-link biped walking with bipedlab's gains (Table II retuned "
                       "toward the paper's 0.5 m/s), planar model (logged trajectory, stick figure)",
                       kind="animation"),),
)]
