"""MABEL's two papers in ``bipedlab reproduce``.

- ``identification`` (Park, Sreenath, Hurst & Grizzle): the system identification end to end on
  a synthetic robot (:mod:`bipedlab.robots.mabel.sysid.study`) and the hopping experiment with and
  without the event-based torso update (:mod:`bipedlab.robots.mabel.hopping.study`).
- ``hzd`` (Sreenath, Park, Poulakakis & Grizzle): the gait designs and their Poincaré maps
  (:mod:`bipedlab.robots.mabel.walking.study`) and Exps. 1-5 with Table I
  (:mod:`bipedlab.robots.mabel.walking.experiments`).

Paper values: ``data/paper_identification.json`` and ``data/paper_hzd.json``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from bipedlab.report import Experiment, Failed, Figure, Measured, NotIdentifiable, Paper, Skip, dig
from bipedlab.report.spec import with_sensitivity
from bipedlab.robots.mabel import tables as tb
from bipedlab.robots.mabel.walking import catalog

DATA = Path(__file__).parent / "data"
HOPS, QUICK_HOPS = 100, 20
NOT_QUICK = "not run in --quick"


# ----------------------------------------------------------------------------- identification
def _hop(args, out, progress):
    from bipedlab.robots.mabel.hopping import study

    return study.study(args["hops"], torso_update=args["torso_update"], poincare=args["poincare"],
                       out=out if args["torso_update"] else None, progress=progress)


def _identify(args, out, progress):
    from bipedlab.robots.mabel.sysid import study

    rec = study.study(seed=args["seed"], noise=args["noise"], quick=args["quick"], out=out, progress=progress)
    if out:
        rec.setdefault("figures", []).append(identified_vs_true(rec.get("parameters") or [], f"{out}/identified_vs_true.png"))
    return rec


def identified_vs_true(parameters: list, path: str) -> str:
    """Every identified parameter's relative error against its true value, by group (log scale)."""
    from bipedlab.viz import figures

    rows = [p for p in parameters if p.get("rel_error") is not None and p.get("true") not in (None, 0)]
    groups = sorted({p.get("group", "") for p in rows})
    fig, ax = figures.subplots(figsize=(8, 3.8))
    for k, g in enumerate(groups):
        err = [max(abs(p["rel_error"]), 1e-7) for p in rows if p.get("group", "") == g]
        ax.plot(np.full(len(err), k) + np.linspace(-0.15, 0.15, len(err)), err, "o", ms=4)
    ax.set_yscale("log")
    ax.set_xticks(range(len(groups)))
    ax.set_xticklabels([g.replace("_", " ") for g in groups], rotation=25, ha="right", fontsize=8)
    ax.set_ylabel("|estimate / true - 1|")
    ax.set_title("Identified against true parameters (synthetic robot)", fontsize=10)
    return figures.save(fig, path)


def eigenvalue_figure(eigs: dict, path: str) -> str:
    """Poincaré eigenvalues (complex, [re, im] pairs) of each map in the unit circle."""
    from bipedlab.viz import figures

    fig, ax = figures.subplots(figsize=(4.6, 4.6))
    t = np.linspace(0, 2 * np.pi, 200)
    ax.plot(np.cos(t), np.sin(t), "k-", lw=0.8)
    for (label, ev), marker in zip(eigs.items(), "ox^s"):
        ev = np.asarray(ev, float).reshape(-1, 2)
        ax.plot(ev[:, 0], ev[:, 1], marker, ms=6, mfc="none", label=label)
    ax.set_aspect("equal")
    ax.set_xlim(-1.1, 1.1)
    ax.set_ylim(-1.1, 1.1)
    ax.axhline(0, color="0.8", lw=0.5)
    ax.axvline(0, color="0.8", lw=0.5)
    ax.legend(fontsize=7, loc="lower left")
    ax.set_title("Poincaré eigenvalues in the unit circle", fontsize=10)
    return figures.save(fig, path)


IDENTIFICATION_EXPERIMENTS = (
    Experiment("identify", "bipedlab identify mabel --synthetic", _identify, dict(seed=0, noise=1.0, quick=False),
               dict(seed=0, noise=1.0, quick=True),
               reduction="reduced experiment design (shorter chirps, fewer postures and hops; the sysid study's quick design)",
               expected_s=240, quick_expected_s=60),
    Experiment("hop", f"bipedlab hop mabel --hops {HOPS}", _hop, dict(hops=HOPS, torso_update=True, poincare=True),
               dict(hops=QUICK_HOPS, torso_update=True, poincare=False),
               reduction=f"{QUICK_HOPS} hops instead of {HOPS}; no Poincaré analysis (it compiles for minutes)",
               expected_s=150, quick_expected_s=10),
    Experiment("hop-no-update", f"bipedlab hop mabel --hops {HOPS} --no-torso-update --no-poincare", _hop,
               dict(hops=HOPS, torso_update=False, poincare=False), dict(hops=QUICK_HOPS, torso_update=False, poincare=False),
               reduction=f"{QUICK_HOPS} hops instead of {HOPS}", expected_s=40, quick_expected_s=3),
)

GROUP_ROWS = ("motor_constant", "rotor_inertia_scale", "friction", "spring_stiffness", "cable_stretch")
#: The groups the single hop does not identify in full, their parameters, and the names the rows' texts use.
HOP_GROUPS = {"hard_stop": {"spring_d": "Kd_B", "kd1": "K_d1", "kvd1": "K_vd1", "kvd2": "K_vd2"},
              "ground": {"ground_stiffness": "stiffness", "ground_damping": "damping",
                         "ground_bristle_stiffness": "bristle stiffness", "ground_coulomb": "Coulomb friction"}}
#: The study's bar for a parameter it counts as identified (hopping_fit.IDENTIFIABLE).
IDENTIFIED_BAR = 0.1
#: Actuators in the order of the paper's Tables III-VI.
TABLE_ACTUATORS = ("mLS_L", "mLA_L", "mLS_R", "mLA_R")
#: Table row id -> parameter of the identification record (the estimate beside the paper's value).
TABLE_PARAMETERS = {
    **{f"table4_{k}_{a}": f"{k}_{a}" for a in TABLE_ACTUATORS for k in ("alpha", "kt")},
    **{f"table5_mu_{a}": f"friction_{a}" for a in TABLE_ACTUATORS},
    **{f"fig19_spring_k_{s}": f"spring_k_{s}" for s in ("L", "R")},
    **{f"fig19_preload_{s}": f"spring_preload_{s}" for s in ("L", "R")},
    **{f"table6_{k}": k for g in HOP_GROUPS.values() for k in g},
    **{f"table6_cable_{k}_{a}": f"cable_{k}_{a}" for a in TABLE_ACTUATORS for k in ("k", "d")},
}


def _estimate(params: dict, name: str):
    """A parameter's estimate with its synthetic truth and relative error as facts (the
    hopping fit's 1-sigma too); a parameter the hop does not identify is NotIdentifiable: its
    estimate stays near the published value the fit starts from, so beside the paper it would
    agree by construction."""
    p = params.get(name)
    if p is None or p.get("estimate") is None:
        return Skip("the identification did not report it")
    facts = dict(true=p.get("true"), rel_error=p.get("rel_error"))
    if p.get("identified") is False:
        return NotIdentifiable(f"the hop does not determine it (1-sigma relative error from the data "
                      f"{_sigma(p.get('rel_std'))}, identified below {IDENTIFIED_BAR:.0%}); its estimate, "
                      f"{p['estimate']:.4g}, is set by the fit's start at the published value and its prior towards "
                      f"it, not by the data, and is {p['rel_error']:.0%} off the synthetic truth {p['true']:.4g} "
                      "(experiment identify, not_identified)")
    return Measured(p["estimate"], facts)


def _sigma(sd) -> str:
    """A 1-sigma relative error in words (the study's summary prints those past 1000 % so)."""
    return "unbounded" if sd is None else ">1000%" if sd >= 10.0 else f"{sd:.0%}"


def _table3(ident: dict, params: dict, out: dict) -> None:
    """Table III: J_i^exp and mu_i^exp of each pulley combination (eq. 7, command units), with
    the synthetic truth (eq. 10: K_T (alpha J^rotor,man + J^CAD); K_T mu) as facts."""
    from bipedlab.robots.mabel.sysid import params as P

    for a in TABLE_ACTUATORS:
        row = dig(ident, "details", "transmission", a)
        kt, al = dig(params, f"kt_{a}", "true"), dig(params, f"alpha_{a}", "true")
        for i in range(3):
            J, mu = dig(row, "J_exp", i), dig(row, "mu_exp", i)
            tf = dig(params, f"trans_friction_{a}_{i + 1}", "true")
            for key, est, true in (("J", J, None if kt is None or al is None else
                                    kt * (al * P.rotor_inertia_manufacturer(a) + P.combination_inertia(a)[i])),
                                   ("mu", mu, None if kt is None or tf is None else kt * tf)):
                out[f"table3_{key}_{a}_{i + 1}"] = (
                    Skip("the identification did not report it") if est is None or true is None else
                    Measured(est, dict(true=true, rel_error=abs(est - true) / abs(true))))


def _hop_group(params: dict, group: str):
    """The largest relative error of a group's parameters against the synthetic truth, with the
    per-parameter errors and 1-sigma errors as facts, where the hop identifies every one;
    NotIdentifiable (with their 1-sigma errors from the data) where it does not identify some:
    their errors then say how far the truth was drawn from the fit's start, not what the data
    hold."""
    names = HOP_GROUPS[group]
    rows = [params[n] for n in names if n in params and params[n].get("rel_error") is not None]
    if not rows:
        return Skip("the identification did not report the group")
    unid = [p for p in rows if p.get("identified") is False]
    pick = unid or rows
    value = max(p["rel_error"] for p in pick)
    facts = dict(unidentified=", ".join(names[p["name"]] for p in unid) or "none",
                 errors=", ".join(f"{names[p['name']]} {p['rel_error']:.0%}" for p in pick),
                 sigmas=", ".join(f"{names[p['name']]} {_sigma(p.get('rel_std'))}" for p in pick))
    if unid:
        return NotIdentifiable(
            f"the single hop does not determine {facts['unidentified']} (1-sigma relative errors from the data alone: "
            f"{facts['sigmas']}, identified below {IDENTIFIED_BAR:.0%}): their estimates are set by the fit's start at "
            f"the published values and its prior towards them, so their errors against the synthetic truth "
            f"({facts['errors']}) say how far the truth was drawn from those values, not what the data hold "
            "(experiment identify, not_identified)")
    return Measured(value, facts)


def measure_identification(records: dict, quick: bool) -> dict:
    ident, hop, free = records.get("identify"), records.get("hop"), records.get("hop-no-update")
    out = {}
    for g in GROUP_ROWS:
        out[f"sysid_{g}"] = dig(ident, "max_rel_error", g) if ident else Skip("not run")
    out["sysid_bias_nm"] = dig(ident, "max_abs_bias_error_nm") if ident else Skip("not run")
    out["sysid_validation_rms_deg"] = dig(ident, "validation_rms_deg") if ident else Skip("not run")
    if ident:
        params = {p["name"]: p for p in ident.get("parameters") or []}
        for g in HOP_GROUPS:
            out[f"sysid_{g}"] = _hop_group(params, g)
        for rid, name in TABLE_PARAMETERS.items():
            out[rid] = _estimate(params, name)
        _table3(ident, params, out)
        for a in TABLE_ACTUATORS:
            out[f"table4_bias_{a}"] = dig(ident, "details", "bias_arx", a, "bias_nm")
            out[f"table5_bias_{a}"] = dig(params, f"bias_{a}", "estimate")
        out["fig17_com_max_mm"] = dig(ident, "com_check", "max_abs_mm")
    else:
        for rid in ("sysid_hard_stop", "sysid_ground", "fig17_com_max_mm"):
            out[rid] = Skip("not run")
    if hop is not None:
        n, fell = dig(hop, "hops_completed"), dig(hop, "fell")
        if quick:
            out["hops_with_update"] = Skip(f"--quick simulates {QUICK_HOPS} hops ({n} completed"
                                           f"{', then fell' if fell else ' without a fall'}), fewer than the paper's 92")
        else:
            out["hops_with_update"] = n
        out["hop_period_s"] = dig(hop, "mean_hop_period_s")
        pm = dig(hop, "poincare")
        out["poincare_with_update"] = (Skip(NOT_QUICK + " (the hop-to-hop map compiles for minutes)") if quick
                                       else dig(pm, "with_torso_update", "max_abs_eigenvalue"))
        out["poincare_without_update"] = (Skip(NOT_QUICK + " (the hop-to-hop map compiles for minutes)") if quick
                                          else dig(pm, "without_torso_update", "max_abs_eigenvalue"))
    if free is not None:
        # the paper's robot fell (steady hopping 'was not achieved'): a simulation that does not fall departs
        out["hops_without_update"] = dig(free, "hops_completed") if dig(free, "fell") else Failed(
            f"did not fall within the {dig(free, 'hops_requested')} hops simulated: without the update the robot "
            "fell, typically after five hops")
    return out


# ----------------------------------------------------------------------------- hzd
def _designs(args, out, progress):
    """The nominal (torque) and efficient (c_mt) gaits: optimised again, or read from the gait
    files the package ships (written by ``optimize mabel --save``)."""
    from bipedlab.robots.mabel.walking import study as wm

    rec = {}
    for name, cost in (("nominal", "torque"), ("efficient", "cmt")):
        shipped = f"paper-{name}"  # what optimize mabel gives on its default (the paper's) design model
        if args["source"] == "optimize":
            progress(f"designing the {name} gait ({cost} cost) and its Poincaré maps")
            r = wm.optimize(0.8, cost, out=f"{out}/{name}" if out else None, poincare_check=True, progress=progress)
            pc = r.get("poincare") or {}
            rec[name] = dict(speed_mps=r["speed_mps"], step_length_m=r["step_length_m"], cmt=r["cmt"],
                             negative_work_fraction_spring=r["negative_work_fraction_spring"],
                             eig_hzd=r.get("max_abs_eigenvalue"), eig_pdff=r.get("max_abs_eigenvalue_pdff"),
                             eigenvalues_hzd=dig(pc, "hzd", "poincare_eigenvalues_complex"),
                             eigenvalues_pdff=dig(pc, "pdff", "poincare_eigenvalues_complex"),
                             torso_travel_deg=r["torso_travel_deg"], converged=r["converged"],
                             source="optimize mabel")
        else:
            from bipedlab.robots.mabel.walking import design as md

            _, _, g = wm.load_gait(shipped)
            d, pc = g["design"], g.get("poincare") or {}
            design = wm.design_from_record(g)
            m = md.design_model(kind=g.get("design_model", "full"))
            rec[name] = dict(speed_mps=d["speed"], step_length_m=d["step_length"], cmt=d["cmt"],
                             negative_work_fraction_spring=d["negative_work_fraction_spring"],
                             eig_hzd=dig(pc, "hzd", "max_abs_eigenvalue"), eig_pdff=dig(pc, "pdff", "max_abs_eigenvalue"),
                             eigenvalues_hzd=dig(pc, "hzd", "poincare_eigenvalues_complex"),
                             eigenvalues_pdff=dig(pc, "pdff", "poincare_eigenvalues_complex"),
                             torso_travel_deg=float(np.degrees(md.torso_travel(m, design))),
                             source=f"shipped gait file mabel_{shipped}.json")
            if out:
                from bipedlab.robots.mabel.walking import plots as wp

                rec[name]["figures"] = wp.gait_figures(f"{out}/{name}", m, design)
    eigs = {f"{g}, {label}": rec[g][key] for g in rec for key, label in
            (("eigenvalues_hzd", "restricted map"), ("eigenvalues_pdff", "PD + FF, full map")) if rec[g].get(key)}
    if out and eigs:
        rec["eigenvalue_figure"] = eigenvalue_figure(eigs, f"{out}/poincare_eigenvalues.png")
    rec["full_model"] = full_model_gaits()
    return rec


#: the shipped gaits designed on the full design model (friction and spring damping in the zero
#: dynamics: ``optimize mabel --design-model full``), the same costs as paper-nominal / paper-efficient
FULL_MODEL_GAITS = {"nominal": "nominal", "efficient": "efficient"}


def full_model_gaits() -> dict:
    """Designed figures of the full design model's torque and c_mt gaits (read from their gait
    files): the design model as a factor of the design rows (step, c_mt, the spring's share of
    the negative work)."""
    from bipedlab.robots.mabel.walking import study as wm

    out = {}
    for name, gait in FULL_MODEL_GAITS.items():
        d = wm.load_gait(gait)[2]["design"]
        out[name] = dict(gait=gait, step_length_m=d["step_length"], cmt=d["cmt"],
                         negative_work_fraction_spring=d["negative_work_fraction_spring"])
    return out


def _full_model_share(des: dict, g: str) -> str:
    """The spring's share on the full design model's gait of the same cost, for the row's text."""
    x = (des.get("full_model") or {}).get(g)
    if x is None:
        return "the full design model's gait was not read"
    return (f"on the full design model (friction and spring damping in the zero dynamics) the same cost's gait "
            f"{x['gait']} ({x['step_length_m']:.3f} m steps, designed c_mt {x['cmt']:.3f}) gives the spring "
            f"{x['negative_work_fraction_spring']:.0%}")


def _wx(name):
    def run(args, out, progress):
        from bipedlab.robots.mabel.walking import experiments as wx

        return wx.run(name, steps=args["steps"], out=out, progress=progress, **args.get("options", {}))
    return run


# ------------------------------------------------------------------ hzd, reduced (--quick) runs
# The reduced walks are the experiments' own options. They use two compiled loops in all (PD +
# feedforward, and the I/O-linearising HZD controller; the loop's gait, push, impact scale, lean
# and sensing are traced arguments), so the six experiments together compile about as much as
# two single walks.
QUICK_WALK_STEPS = 6
QUICK_PUSH_STEP, QUICK_PUSH_STEPS = 3, 9
QUICK_ETAS = (1.0, 0.98, 0.966)
QUICK_ETA_STEPS, QUICK_ETA_AVERAGE = 12, 5
QUICK_LEAN_STEPS, QUICK_FAST_STEPS = 10, 5
QUICK_PD_SCALES = (0.75, 1.0, 1.5)
QUICK_FULL_PLANT_STEPS = 8


def _walk_exp(name, command, full_steps, quick_steps, reduction, expected, quick_expected, walks, **options):
    return Experiment(name, command, _wx(name), dict(steps=full_steps), dict(steps=quick_steps, options=options),
                      reduction=reduction, expected_s=expected, quick_expected_s=quick_expected, gaits=tuple(walks))


#: the gaits each experiment walks or designs (the walking experiments' constants, e.g.
#: ``experiments.EXP3_GAIT``, ``PD_GAITS``, ``GAP_GAITS``; written out here so that listing the
#: papers imports no simulation code; a test holds them equal)
_GAITS = {"design": ("paper-nominal", "paper-efficient", "nominal", "efficient"), "nominal": ("paper-575",),
          "push": ("paper-575", "paper-nominal", "nominal"), "efficient": ("paper-efficient-clear",),
          "tracking": ("paper-575",), "impact-scaling": ("paper-575", "paper-nominal", "nominal"),
          "fast": ("paper-575", "fast"), "pd-gains": ("paper-nominal", "paper-efficient"), "exp4": ("paper-575",),
          "full-plant": ("paper-nominal", "paper-efficient", "paper-efficient-clear", "nominal", "efficient",
                         "paper-575"), "sensitivity": ("paper-nominal", "paper-efficient", "paper-575", "paper-efficient-clear")}

#: Exp. 3's gait (``experiments.EXP3_GAIT``)
EXP3_GAIT = _GAITS["efficient"][0]


def _zero_clearance_text(gap: dict) -> str:
    """How the c_mt gait without the swing-toe clearance (paper-efficient) fared under PD +
    feedforward on the 13-DoF plant (experiment full-plant's runs)."""
    x = gap.get("paper-efficient")
    if x is None:
        return "paper-efficient (no clearance) was not walked here"
    how = f"falls in step {x['steps_completed'] + 1}" if x["fell"] else f"walks {x['steps_completed']} steps"
    return f"without it (paper-efficient, the swing toe grazing the ground at mid-step) PD + feedforward {how}"


HZD_EXPERIMENTS = (
    Experiment("design", "bipedlab optimize mabel --speed 0.8 [--cost cmt]", _designs, dict(source="optimize"),
               dict(source="shipped"), reduction="reads the shipped gait files paper-nominal and paper-efficient "
               "(written by these commands, with their stored Poincaré eigenvalues) instead of optimising and "
               "linearising again", expected_s=360, quick_expected_s=10, gaits=_GAITS["design"]),
    _walk_exp("nominal", "bipedlab experiment mabel nominal", 100, QUICK_WALK_STEPS,
              f"{QUICK_WALK_STEPS} steps instead of 100", 70, 15, _GAITS["nominal"]),
    _walk_exp("push", "bipedlab experiment mabel push", 30, QUICK_PUSH_STEPS,
              f"the two pushes under PD + feedforward only, in step {QUICK_PUSH_STEP} of {QUICK_PUSH_STEPS}-step walks "
              "(instead of step 10 of 30, and the decentralised controller's pushes); no force search", 540, 15, _GAITS["push"],
              push_step=QUICK_PUSH_STEP, controllers=["pdff"], search=False, reference_from=1),
    _walk_exp("efficient", "bipedlab experiment mabel efficient", 100, QUICK_WALK_STEPS,
              f"{QUICK_WALK_STEPS} steps instead of 100", 30, 5, _GAITS["efficient"]),
    _walk_exp("tracking", "bipedlab experiment mabel tracking", 30, QUICK_WALK_STEPS,
              f"PD + feedforward and I/O linearisation only (not the decentralised form), {QUICK_WALK_STEPS} steps "
              "instead of 30; beside each walk the same walk with exact encoders and on the 13-DoF plant (the causes of "
              "the tracking difference)", 150, 45, _GAITS["tracking"], controllers=["pdff", "iolin"]),
    _walk_exp("impact-scaling", "bipedlab experiment mabel impact-scaling", 40, QUICK_ETA_STEPS,
              f"eta in {{{', '.join(f'{e:g}' for e in QUICK_ETAS)}}} only, {QUICK_ETA_STEPS} steps each with the speed "
              f"of the last {QUICK_ETA_AVERAGE} (instead of six values, 40 steps, the last 10); no PD + feedforward "
              "column, no other gait", 320, 15, _GAITS["impact-scaling"], etas=list(QUICK_ETAS), average=QUICK_ETA_AVERAGE, pdff_column=False,
              gait_factor=[]),
    _walk_exp("fast", "bipedlab experiment mabel fast", 100, QUICK_FAST_STEPS,
              f"the 0.7 rad lean in {QUICK_LEAN_STEPS} increments instead of 30, then {QUICK_FAST_STEPS} steps instead "
              "of 100; no comparison runs", 100, 8, _GAITS["fast"], lean_steps=QUICK_LEAN_STEPS, comparisons=False),
    Experiment("pd-gains", "bipedlab experiment mabel pd-gains", _wx("pd-gains"), dict(steps=None),
               dict(steps=None, options=dict(kp_scales=list(QUICK_PD_SCALES), kd_scales=list(QUICK_PD_SCALES))),
               reduction=f"factors {{{', '.join(f'{a:g}' for a in QUICK_PD_SCALES)}}} on kp and on kd (a 3 x 3 grid "
               "instead of 5 x 5)", expected_s=60, quick_expected_s=30, gaits=_GAITS["pd-gains"]),
    _walk_exp("exp4", "bipedlab experiment mabel exp4", 30, QUICK_WALK_STEPS,
              f"{QUICK_WALK_STEPS} steps instead of 30; no run without the 6/10 N m limits", 30, 5, _GAITS["exp4"],
              compare=False),
    _walk_exp("full-plant", "bipedlab experiment mabel full-plant", 100, QUICK_FULL_PLANT_STEPS,
              f"the paper model's torque gait and Exp. 3's gait only, {QUICK_FULL_PLANT_STEPS} steps each instead "
              "of 100 (not paper-efficient or the full-model gaits); no variants of the headline (velocity observer, "
              "scaled ground, cables, friction, eps selection)",
              360, 10, _GAITS["full-plant"], gaits=["paper-nominal", "paper-efficient-clear"], variants=False),
    Experiment("sensitivity", "bipedlab experiment mabel sensitivity", _wx("sensitivity"), dict(steps=None), None,
               skip_reason="not run in --quick (both gaits designed again on 18 models, the walking experiments walked "
               "again on 10 plants)", expected_s=4000,
               gaits=_GAITS["sensitivity"]),
)

ETAS = (1.0, 0.99, 0.98, 0.97, 0.966, 0.96)


def _paper_gaits() -> dict:
    """The paper's gaits each shipped gait stands for, their figures read from the paper-values
    rows (Sec. III-E, Fig. 5; the paper gives no step length for the c_mt gait)."""
    from bipedlab.report import values

    rows = {r["id"]: r for r in values.load(DATA / "paper_hzd.json")["rows"]}

    def fig(row_id):
        return rows[row_id]["paper"] if row_id in rows else None

    def gait(words, prefix):
        ids = [f"{prefix}_speed_mps", f"{prefix}_step_length_m", f"{prefix}_cmt"]
        return dict(gait=words, speed_mps=fig(ids[0]), step_length_m=fig(ids[1]), cmt=fig(ids[2]),
                    source="; ".join(dict.fromkeys(rows[i]["source"] for i in ids if i in rows)))

    return {"nominal": gait("the nominal gait", "nominal"), "efficient": gait("the c_mt gait", "efficient")}


_DESIGNED_ON = {"paper": "the paper's design model (rigid cables, no motor friction or spring damping)",
                "full": "the full design model (Table V motor friction, spring damping in the zero dynamics)"}


def gait_table(records: dict, quick: bool) -> list:
    """The shipped gaits the HZD experiments walk (:data:`_GAITS`), each with its designed speed,
    step length, c_mt and torso travel (from its gait file, the travel on its design model's
    orbit) beside the paper's gait it stands for and Appendix B's bound on the torso travel."""
    from bipedlab.robots.mabel.walking import design as md
    from bipedlab.robots.mabel.walking import study as wm

    out, papers = [], _paper_gaits()
    walked = {g for gs in _GAITS.values() for g in gs}
    for name in (g for g in ("paper-nominal", "paper-efficient", "paper-efficient-clear", "paper-575", "nominal",
                             "efficient", "fast")
                 if g in walked):
        _, _, d = wm.load_gait(name)
        des, model = d["design"], d.get("design_model", "full")
        paper = papers.get(catalog.STANDS_FOR[name])
        cost = "c_mt" if d["cost"] == "cmt" else d["cost"]
        travel = float(np.degrees(md.torso_travel(md.design_model(kind=model), wm.design_from_record(d))))
        out.append(dict(name=name, designed_on=f"{_DESIGNED_ON[model]}, {cost} cost", design_model=model,
                        cost=d["cost"], speed_mps=des["speed"], step_length_m=des["step_length"], cmt=des["cmt"],
                        period_s=des["period"], torso_travel_deg=travel,
                        torso_travel_bound_deg=float(np.degrees(md.TORSO_TRAVEL)), paper=paper))
    return out


def _eta_key(eta: float) -> str:
    return f"{eta:g}".replace(".", "_")


def measure_hzd(records: dict, quick: bool) -> dict:
    out = {}
    des = records.get("design") or {}
    for g in ("nominal", "efficient"):
        d = des.get(g)
        for k in ("speed_mps", "step_length_m", "cmt", "negative_work_fraction_spring", "eig_hzd", "eig_pdff"):
            if (g, k) != ("efficient", "step_length_m"):  # the paper gives no step for the c_mt gait
                out[f"{g}_{k}"] = dig(d, k) if d is not None else Skip("not run")
        if d is not None:
            out[f"{g}_negative_work_fraction_spring"] = Measured(d["negative_work_fraction_spring"],
                                                                 dict(full_model=_full_model_share(des, g)))
    out["nominal_torso_travel_deg"] = dig(des.get("nominal"), "torso_travel_deg") if des else Skip("not run")
    for k in (1, 2):
        out[f"nominal_eig_hzd_minor_{k}"] = _minor_eigenvalue(des.get("nominal"), k) if des else Skip("not run")
    cn, ce = dig(des.get("nominal"), "cmt"), dig(des.get("efficient"), "cmt")
    out["design_cmt_change"] = (Measured(ce / cn - 1.0, dict(designed_nominal=cn, designed_efficient=ce)) if cn and ce is not None
                                else Skip("not run"))
    nom = records.get("nominal")
    skip = Skip(NOT_QUICK) if quick else Skip("not run")
    out["exp1_speed_mps"] = dig(nom, "speed_mps") if nom else skip
    out["exp1_cmt"] = dig(nom, "cmt") if nom else skip
    out["exp1_vs_hand_designed_cmt"] = Skip("the hand-designed virtual constraints of (Grizzle et al., 2009) are given in "
                                            "neither paper, so their gait cannot be walked here")
    push = records.get("push")
    if push:
        runs = {(r["controller"], r["force_n"]): r for r in push["runs"]}
        f, b = runs.get(("pdff", 78.0)), runs.get(("pdff", -71.0))
        out["push_forward_change"] = _pushed(f) or dig(f, "peak_speed_change")
        out["push_forward_steps"] = _pushed(f) or _recovered(f, quick)
        out["push_backward_change"] = _pushed(b) or dig(b, "peak_speed_change")
        out["push_backward_steps"] = _pushed(b) or _recovered(b, quick)
        out["push_forward_survived"] = _survived(f)
        for key, sign in (("push_force_plus_45pct_n", "plus"), ("push_force_minus_45pct_n", "minus")):
            out[key] = (Measured(dig(push, f"force_for_{sign}_45pct_n"), dict(gait_forces=_push_gait_text(push)))
                        if "searches" in push else
                        Skip("the force search (a dozen walks per direction) runs in the full run only"))
        if isinstance(out["push_backward_steps"], int):
            out["push_backward_steps"] = Measured(out["push_backward_steps"],
                                                  dict(gait_recovery=_push_recovery_text(push)))
        out.update(_full_plant_pushes(push))
    else:
        for k in ("push_forward_change", "push_forward_steps", "push_backward_change", "push_backward_steps",
                  "push_forward_survived", "push_force_plus_45pct_n", "push_force_minus_45pct_n") + FULL_PUSH_ROWS:
            out[k] = skip
    eff = records.get("efficient")
    out["exp3_cmt"] = dig(eff, "cmt") if eff else skip
    tr = records.get("tracking")
    for c in ("pdff", "iolin"):
        for o in ("tor", "mLS_st"):
            key = f"tracking_{c}_{o}_rms_deg"
            v = dig(tr, "controllers", c, "tracking_rms_deg", _output_name(tr, o)) if tr else skip
            out[key] = Measured(v, _tracking_orders(tr, _output_name(tr, o))) if tr and v is not None else v
    for o in ("tor", "mLS_st"):
        out[f"tracking_pdff_{o}_peak_deg"] = (dig(tr, "controllers", "pdff", "tracking_peak_deg", _output_name(tr, o))
                                              if tr else skip)
    imp = records.get("impact-scaling")
    for eta in ETAS:
        row = next((r for r in (imp or {}).get("rows", []) if abs(r["eta"] - eta) < 1e-9), None)
        out[f"table1_{_eta_key(eta)}"] = (row["steady_speed_mps"] if row is not None else skip)
    out["table1_dv_deta"] = (Failed("fewer than two etas walked without a fall") if imp and dig(imp, "dv_deta") is None
                             else Measured(dig(imp, "dv_deta"), dict(gait_slopes=_slope_gait_text(imp))) if imp
                             else skip)
    pdg = records.get("pd-gains")
    for g, gait in zip(("nominal", "efficient"), _GAITS["pd-gains"]):
        out[f"{g}_eig_pdff_closest_gains"] = _nearest_eigenvalue(pdg, gait) if pdg else Skip("not run")
    ex4 = records.get("exp4")
    fell4 = (f"the simulated Exp. 4 fell in step {ex4['steps_completed'] + 1} ({ex4['fell_at_s']:.2f} s in) under the "
             "6 / 10 N m limits" if ex4 and ex4["fell"] else None)
    for key, path, lost in (("exp4_speed_mps", ("speed_mps",), "a fallen run has no speed or c_mt"),
                            ("exp4_cmt", ("cmt",), "a fallen run has no speed or c_mt"),
                            ("exp4_tor_peak_deg", ("tracking_peak_deg", "Tor"), "its peak error is the fall's, not the walk's"),
                            ("exp4_mLS_st_peak_deg", ("tracking_peak_deg", "mLS_st"),
                             "its peak error is the fall's, not the walk's")):
        out[key] = (skip if not ex4 else Failed(f"{fell4}: {lost} (see experiment exp4)") if fell4
                    else dig(ex4, *path))
    out["exp4_closer_to_design_than_exp1"] = _closer_to_design(nom, ex4, out["exp4_speed_mps"], skip)
    gap = (records.get("full-plant") or {}).get("runs", {})
    for g, key in (("paper-nominal", "fullplant_nominal"), (EXP3_GAIT, "fullplant_efficient")):
        x = gap.get(g)
        if x is None:
            out[f"{key}_cmt"] = out[f"{key}_cmt_ratio"] = skip
        elif x["fell"]:
            out[f"{key}_cmt"] = out[f"{key}_cmt_ratio"] = Failed(
                f"the {g} gait fell on the 13-DoF plant in step {x['steps_completed'] + 1} ({x['fell_at_s']:.2f} s in): "
                "a fallen run has no c_mt (see experiment full-plant)")
        else:
            out[f"{key}_cmt"] = (Measured(x["cmt"], dict(zero_clearance=_zero_clearance_text(gap)))
                                 if g == EXP3_GAIT else x["cmt"])
            out[f"{key}_cmt_ratio"] = x["cmt_ratio"]
    x = gap.get("paper-nominal")
    out["fullplant_mls_st_rms_deg"] = skip if x is None else x["tracking_rms_deg"]["mLS_st"]
    n, e = gap.get("paper-nominal"), gap.get(EXP3_GAIT)
    if n is None or e is None:
        out["fullplant_exp3_vs_exp1_cmt_change"] = skip
    elif n["fell"] or e["fell"]:
        out["fullplant_exp3_vs_exp1_cmt_change"] = Failed(
            "the " + " and the ".join(g for g, x in (("paper-nominal", n), (EXP3_GAIT, e)) if x["fell"])
            + " gait fell on the 13-DoF plant: a fallen run has no c_mt (see experiment full-plant)")
    else:
        out["fullplant_exp3_vs_exp1_cmt_change"] = Measured(e["cmt"] / n["cmt"] - 1.0, dict(
            realised_exp1=n["cmt"], realised_exp3=e["cmt"], designed_exp1=n["cmt_designed"],
            designed_exp3=e["cmt_designed"], designed_change=e["cmt_designed"] / n["cmt_designed"] - 1.0,
            speed_exp1=n["speed_mps"], speed_exp3=e["speed_mps"]))
    _headline(records.get("full-plant"), quick, out)
    fast = records.get("fast")
    if fast and fast.get("fell"):  # a fallen walk sustains no speed
        out["fast_sustained_mps"] = out["fast_top_mps"] = Failed(
            f"the leaned walk under the {fast.get('controller')} controller fell in step {fast['steps_completed'] + 1} "
            f"({fast['fell_at_s']:.2f} s in; experiment fast's record)")
    else:
        out["fast_sustained_mps"] = dig(fast, "speed_after_lean_mps") if fast else skip
        out["fast_top_mps"] = (max(fast["speed_per_step"]) if fast and fast.get("speed_per_step") else skip)
    # the design rows' elasticities: the sensitivity finds the same optima again (within SLSQP's tolerance)
    sens = records.get("sensitivity")
    out.update(with_sensitivity(out, sens, rel=SAME_OPTIMUM))
    # the walking rows' on a scaled plant: the same walks as the rows', their base a plant that is data
    # of the loop (rounding apart: attached within three times the rows' rounding noise)
    out.update(with_sensitivity(out, (sens or {}).get("plant")))
    return out


#: relative difference within which the sensitivity's unscaled re-design is the design experiment's
#: optimum (the same path from the hand-set guess, so the same numbers; the bound only guards
#: against a row computed elsewhere)
SAME_OPTIMUM = 1e-4


FULL_PUSH_ROWS = ("fullplant_push_force_plus_45pct_n", "fullplant_push_force_minus_45pct_n", "fullplant_push_forward_steps",
                  "fullplant_push_backward_steps", "fullplant_push_recovery_asymmetry")


def _push_gait_text(push: dict) -> str:
    """Exp. 2's PD + feedforward forces for +45 % / -45 % on each gait walked (experiment push's
    searches on its gait and its ``gait_factor``), with the forward over backward ratio."""
    rows = [(push["gait"], None, push.get("force_for_plus_45pct_n"), push.get("force_for_minus_45pct_n"))]
    rows += [(x["gait"], x["step_length_m"], x["force_for_plus_45pct_n"], x["force_for_minus_45pct_n"])
             for x in push.get("gait_factor") or []]
    if len(rows) < 2:
        return "no other gait was searched"
    parts = [f"{g}{'' if step is None else f' ({step:.3f} m steps)'} {p:+.0f} / {m:+.0f} N ({abs(p / m):.2f})"
             for g, step, p, m in rows]
    fw, bw = push["paper"]["forward"]["force_n"], push["paper"]["backward"]["force_n"]
    return ("forward / backward force by gait: " + ", ".join(parts)
            + f" against the paper's {fw:+.0f} / {bw:+.0f} N ({abs(fw / bw):.2f})")


def _push_recovery_text(push: dict) -> str:
    """The steps back within 2 % after the searched +45 % / -45 % pushes on each gait walked."""
    rows = []
    if len(push.get("searches") or []) >= 2:
        plus, minus = push["searches"][:2]
        rows.append((push["gait"], plus.get("steps_to_recover"), minus.get("steps_to_recover")))
    rows += [(x["gait"], x["steps_to_recover_plus"], x["steps_to_recover_minus"]) for x in push.get("gait_factor") or []]
    if len(rows) < 2:
        return "the pushes were not searched on other gaits (--quick)"
    return ("after the searched +45 % / -45 % pushes, back within 2 % after " + ", ".join(
        f"{'never' if a is None else a} / {'never' if b is None else b} steps on {g}" for g, a, b in rows)
        + f" (paper: {push['paper']['forward']['steps_to_recover']} / {push['paper']['backward']['steps_to_recover']})")


def _slope_gait_text(imp: dict) -> str:
    """dv/deta under the compliant-HZD controller on each gait experiment impact-scaling walked."""
    rows = [(imp["gait"], imp.get("dv_deta"))] + [(x["gait"], x["dv_deta"])
                                                                   for x in imp.get("gait_factor") or []]
    if len(rows) < 2:
        return "no other gait was walked (--quick)"
    slopes, paper = [v for _, v in rows if v is not None], imp["dv_deta_paper"]
    where = "within" if slopes and min(slopes) <= paper <= max(slopes) else "outside"
    return ("by gait: " + ", ".join(f"{g} {'n/a' if v is None else f'{v:+.2f}'}" for g, v in rows)
            + f"; the paper's {paper:+.2f} lies {where} that spread")


def _full_plant_pushes(push: dict) -> dict:
    """Exp. 2 on the 13-DoF plant (experiment push's ``full_plant``): the forces that change the
    speed by +45 % / -45 % under PD + feedforward, the steps back within 2 % after each, and the
    forward recovery's steps minus the backward one's (the paper: 10 against 3)."""
    fp = push.get("full_plant")
    if not fp:
        return {k: Skip("the 13-DoF force searches run in the full run only") for k in FULL_PUSH_ROWS}
    plus, minus = fp["searches"]
    out = {}
    for rid, x, stance in ((FULL_PUSH_ROWS[0], plus, push.get("force_for_plus_45pct_n")),
                           (FULL_PUSH_ROWS[1], minus, push.get("force_for_minus_45pct_n"))):
        out[rid] = Measured(x["force_n"], dict(change=x["speed_change"], stance=stance, converged=x["converged"]))
    back = {}
    for rid, x in ((FULL_PUSH_ROWS[2], plus), (FULL_PUSH_ROWS[3], minus)):
        if x["fell"]:
            out[rid] = Failed(f"the {x['force_n']:+.0f} N push's walk fell in step {x['steps_completed'] + 1}")
        elif x.get("steps_to_recover") is None:
            out[rid] = Failed(f"not back within 2 % of the unpushed speed in the {len(x['speed_per_step']) - x['step']} "
                              "steps simulated after the push")
        else:
            back[rid] = x["steps_to_recover"]
            settle = x["steps_to_recover_5pct"]
            out[rid] = Measured(back[rid], dict(force=x["force_n"], change=x["speed_change"],
                                                settle="never" if settle is None else f"{settle} steps"))
    if len(back) < 2:
        out[FULL_PUSH_ROWS[4]] = Failed("a recovery was not measured (rows fullplant_push_forward_steps, "
                                        "fullplant_push_backward_steps)")
    else:
        f, b = back[FULL_PUSH_ROWS[2]], back[FULL_PUSH_ROWS[3]]
        out[FULL_PUSH_ROWS[4]] = Measured(f - b, dict(forward=f, backward=b, gait_recovery=_push_recovery_text(push)))
    return out


def _nearest_eigenvalue(pdg: dict, gait: str):
    """The PD + feedforward map's dominant eigenvalue at the pd-gains grid point nearest the
    paper's in the complex plane (the experiment's ``closest_to_paper``; Sec. IV-A: 0.6921 and
    0.8194, real and positive): its real part, with the gains, the imaginary part and the
    distance as facts. A nearest eigenvalue with an imaginary part past the row's band is Failed
    (a real number cannot stand for it)."""
    c = dig(pdg, "closest_to_paper", gait)
    if c is None:
        return Failed("no grid point had a fixed point")
    e, paper = c["dominant_eigenvalue"], c["paper_abs"]
    if abs(e["im"]) > 0.05:
        return Failed(f"the grid point nearest the paper's {paper} (kp x {c['kp_scale']:g}, kd x {c['kd_scale']:g}) "
                      f"has the complex dominant eigenvalue {e['re']:+.4f} {e['im']:+.4f}i, {c['difference']:.3f} "
                      "from it; see experiment pd-gains (pd_gains_eigenvalues.png)")
    return Measured(e["re"], dict(kp_scale=c["kp_scale"], kd_scale=c["kd_scale"], im=e["im"], distance=c["difference"]))


def _headline(fp, quick: bool, out: dict) -> None:
    """The headline comparison on the 13-DoF plant (Sec. V-D): PD + feedforward's stance leg-shape
    and torso RMS errors over the compliant controller's on the record's judged gait (the one
    closest to the paper's), and the fewest steps the eq. 42 controllers walk on every headline
    gait (a fall: Failed rows for the ratios)."""
    hzd = (fp or {}).get("hzd_runs")
    ids = ("fullplant_exp4_mls_st_rms_ratio", "fullplant_exp4_tor_rms_ratio", "fullplant_hzd_steps")
    if not hzd:
        out.update({i: Skip("experiment full-plant was not run, or ran without the headline walks")
                    for i in ids + ("fullplant_one_eps_mls_st_rms_ratio",) + MORE_ROWS})
        return
    judged = fp.get("judged_gait", "paper-nominal")
    pd, io = hzd[judged]["pdff"], hzd[judged]["iolin"]
    if io["fell"] or pd["fell"]:
        who = "the compliant controller" if io["fell"] else "PD + feedforward"
        x = io if io["fell"] else pd
        out[ids[0]] = out[ids[1]] = Failed(f"{who} fell on the 13-DoF plant ({judged}) in step "
                                           f"{x['steps_completed'] + 1}: a fallen run has no steady tracking error")
    else:
        for rid, key in ((ids[0], "mLS_st"), (ids[1], "Tor")):
            a, b = pd["tracking_rms_deg"][key], io["tracking_rms_deg"][key]
            joint = (dict(pdff_joint=pd["mLS_st_rms_joint_deg"], hzd_joint=io["mLS_st_rms_joint_deg"])
                     if key == "mLS_st" else {})  # the joint side is the leg shape's (gear 31.42)
            out[rid] = Measured(a / b, dict(pdff=a, hzd=b, **joint))
        if isinstance(out[ids[0]], Measured):
            out[ids[0]].facts["traced"] = _traced(fp)
    least, which = _fewest_steps(hzd)
    if quick and which == "none":
        out[ids[2]] = Skip(f"the --quick run walks {fp['steps']} steps, fewer than the 78 the row asks")
    else:
        out[ids[2]] = Measured(least, dict(which=which, cable=_cable_text(fp)))
    _headline_variants(fp, out, judged)
    _one_eps(fp.get("eps_selection"), out)
    out.update(_headline_more(fp, judged))


#: the headline block's further rows (Sec. V-D, V-E, VI-A, VI-C): :func:`_headline_more`
MORE_ROWS = ("fullplant_joint_rms_pdff", "fullplant_joint_rms_hzd", "fullplant_joint_peak_pdff", "fullplant_joint_peak_hzd",
             "fullplant_decentralized_tracking", "fullplant_torque_noise_hzd_over_pd",
             "fullplant_torque_noise_hzd_over_decentralized", "fullplant_torque_peaks", "fullplant_stance_speed_ratio",
             "fullplant_cable_cmt_rise", "fullplant_friction_cmt_rise")


def _noise(x) -> float:
    """A walk's torque noise over its four motors: the rms of the per-motor rms changes."""
    v = np.asarray(list(x["torque_noise_rms_nm"].values()), float)
    return float(np.sqrt(np.mean(v ** 2)))


def _headline_more(fp: dict, judged: str) -> dict:
    """The judged gait's headline runs read further: the stance leg shape's joint-side rms and
    peak under PD + feedforward and eq. 42 (Sec. V-D), the decentralised controller's tracking
    against eq. 42's, the torque noise of eq. 42 against PD + feedforward and against the
    decentralised form, the peak torques against the capacities, PD + feedforward's left- and
    right-stance speeds (Sec. VI-A), and c_mt's rise with the cables' stretch and with the
    motor friction (Sec. VI-C, the variant runs ``cmt_factor_runs``); ``judged``: the gait they
    are read on."""
    by = fp["hzd_runs"][judged]
    pd, io, dc = by["pdff"], by["iolin"], by["decentralized"]
    out = {}
    fallen = [c for c, x in by.items() if x["fell"]]
    if fallen:
        why = Failed(f"{', '.join(fallen)} fell on the 13-DoF plant ({judged}): a fallen run has no steady figures")
        out.update({k: why for k in MORE_ROWS[:9]})
    else:
        for rid, x, kind in ((MORE_ROWS[0], pd, "rms"), (MORE_ROWS[1], io, "rms"), (MORE_ROWS[2], pd, "peak"),
                             (MORE_ROWS[3], io, "peak")):
            out[rid] = Measured(x[f"mLS_st_{kind}_joint_deg"], dict(motor=x[f"tracking_{kind}_deg"]["mLS_st"]))
        out[MORE_ROWS[4]] = Measured(dc["tracking_rms_deg"]["mLS_st"] / io["tracking_rms_deg"]["mLS_st"],
                                     dict(decentralized=dc["tracking_rms_deg"]["mLS_st"], hzd=io["tracking_rms_deg"]["mLS_st"],
                                          tor_decentralized=dc["tracking_rms_deg"]["Tor"], tor_hzd=io["tracking_rms_deg"]["Tor"]))
        out[MORE_ROWS[5]] = Measured(_noise(io) / _noise(pd), dict(hzd=_noise(io), pdff=_noise(pd)))
        out[MORE_ROWS[6]] = Measured(_noise(io) / _noise(dc), dict(hzd=_noise(io), decentralized=_noise(dc)))
        cap = np.asarray([tb.TORQUE_CAPACITY[a[:3]] for a in catalog.ACTUATORS], float)
        ratio = {c: np.abs(np.asarray(x["peak_torques_nm"], float)) / cap for c, x in by.items()}
        out[MORE_ROWS[7]] = Measured(float(max(r.max() for r in ratio.values())), dict(peaks="; ".join(
            f"{c}: " + ", ".join(f"{a} {t:.1f} N m" for a, t in zip(catalog.ACTUATORS, by[c]["peak_torques_nm"]))
            for c in by)))
        left, right = pd["speed_left_stance_mps"], pd["speed_right_stance_mps"]
        out[MORE_ROWS[8]] = (Measured(left / right, dict(left=left, right=right)) if left and right
                             else Failed("PD + feedforward's walk has no step on one of the legs"))
    runs = fp.get("cmt_factor_runs")
    if not runs:
        out.update({k: Skip("the --quick run walks no c_mt variants") for k in MORE_ROWS[9:]})
        return out
    for rid, x, key in ((MORE_ROWS[9], runs["cables"], "cables"), (MORE_ROWS[10], runs["friction"], "friction")):
        if x["fell"] or pd["fell"]:
            out[rid] = Failed(f"a walk fell ({key} variant or the identified plant's): a fallen run has no c_mt")
        elif key == "cables":
            out[rid] = Measured(pd["cmt"] / x["cmt"] - 1.0, dict(identified=pd["cmt"], stiff=x["cmt"]))
        else:
            out[rid] = Measured(x["cmt"] / pd["cmt"] - 1.0, dict(identified=pd["cmt"], doubled=x["cmt"]))
    return out


def _one_eps(sel, out: dict) -> None:
    """The row of eq. 42's gain choice (shown, not judged): PD + feedforward's stance leg-shape
    RMS error over eq. 42's with one eps on every output, from experiment full-plant's
    eps_selection, with the eps it chose per output and what the c_mt rule saw."""
    rid = "fullplant_one_eps_mls_st_rms_ratio"
    if not sel:
        out[rid] = Skip("the --quick run walks no eps selection")
        return
    pd, base = sel["pdff"], sel["base"]
    if pd["fell"] or base["iolin"]["fell"]:
        out[rid] = Failed("a controller fell at one eps on every output (experiment full-plant, eps_selection)")
        return
    a = pd["tracking_rms_deg"]["mLS_st"]
    ratio = {c: a / x["tracking_rms_deg"]["mLS_st"] for c, x in base.items() if not x["fell"]}
    first = [sel["trials"]["iolin"][i][0] for i in range(1, 4)]
    kept = [x for x in sel["trials"]["iolin"][0] if x["met"]]
    facts = dict(pdff=a, hzd=base["iolin"]["tracking_rms_deg"]["mLS_st"], steps=sel["steps"], one_eps=sel["grid"][0],
                 decentralized=ratio.get("decentralized", float("nan")), rise=sel["cmt_rise"],
                 chosen=", ".join(f"{e:.4f}" for e in sel["eps"]),
                 shipped="the shipped controllers.EPS_OUTPUTS" if sel["shipped"] else "NOT the shipped EPS_OUTPUTS",
                 kept=(f"{100 * max(x['cmt_rise'] for x in kept):+.1f} % down to {kept[-1]['eps']:.4f}" if kept
                       else "none"),
                 others=", ".join(f"{sel['outputs'][i + 1]} " + ("fell" if x["cmt_rise"] is None
                                                                 else f"{100 * x['cmt_rise']:+.0f} %")
                                  for i, x in enumerate(first)))
    out[rid] = Measured(ratio["iolin"], facts)


def _cable_text(fp: dict) -> str:
    """What experiment full-plant's cable variant shows: the cable gait under each eq. 42
    controller with the identified cables (the headline run) and with the stiffer cables, steps
    walked and the stance leg-shape cable's peak stretch (motor side)."""
    runs, g = fp.get("cable_runs"), fp.get("cable_gait")
    identified = fp.get("cable_runs_identified") or fp.get("hzd_runs", {}).get(g)
    if not runs or not identified:
        return "the cable variant was not run here"

    def walked(x):
        return (f"falls in step {x['steps_completed'] + 1}" if x["fell"] else f"walks {x['steps_completed']} steps") + \
            f", stance leg-shape cable stretched {x['cable_stretch_peak_deg']['mLS_st']:.0f} deg"

    parts = [f"{c} on {g}: identified cables {walked(identified[c])}; cables x {fp['cable_scale']:g} "
             f"{walked(x)}" for c, x in runs.items() if c != "pdff"]
    return "; ".join(parts) + " (experiment full-plant, cable_runs)"


def _fewest_steps(hzd: dict):
    """The fewest steps the eq. 42 controllers walked in headline runs ``hzd[gait][controller]``,
    and which of them fell ("none" where none did)."""
    runs = [(g, c, x) for g, by in hzd.items() for c, x in by.items() if c != "pdff"]
    fell = [f"{c} on {g}" for g, c, x in runs if x["fell"]]
    return min(x["steps_completed"] for _, _, x in runs), ", ".join(fell) or "none"


def _stance_ratio(by: dict):
    """PD + feedforward's stance leg-shape RMS error over eq. 42's in one headline block, or None
    where either fell."""
    pd, io = by["pdff"], by["iolin"]
    return None if pd["fell"] or io["fell"] else pd["tracking_rms_deg"]["mLS_st"] / io["tracking_rms_deg"]["mLS_st"]


def _ratio_text(by: dict) -> str:
    """:func:`_stance_ratio` as text ("2.7x"), or eq. 42's fall with the ratio over the steps
    walked before it."""
    pd, io = by["pdff"], by["iolin"]
    v = pd["tracking_rms_deg"]["mLS_st"] / io["tracking_rms_deg"]["mLS_st"]
    if pd["fell"] or io["fell"]:
        who = "eq. 42" if io["fell"] else "PD + feedforward"
        return f"{who} falls in step {(io if io['fell'] else pd)['steps_completed'] + 1} ({v:.1f}x before)"
    return f"{v:.1f}x"


#: how the factor grid's rate estimates are named in the rows' texts
_ESTIMATE = {"encoders": "filtered difference", "observer": "bipedlab's observer", "ideal": "exact rates"}


def _traced(fp: dict) -> str:
    """What experiment full-plant's factor grid shows of the headline ratio's cause: the ratio
    on each ground with each rate estimate, and the cell where it is largest."""
    grid = fp.get("factor_runs")
    if not grid:
        return "the variants that trace it (the ground, the rate estimate) were not run here"
    cells = [(k, sn, by) for k, row in grid.items() for sn, by in row.items()]
    text = "; ".join(f"ground x {k}, {_ESTIMATE.get(sn, sn)}: {_ratio_text(by)}" for k, sn, by in cells)
    walked = [(_stance_ratio(by), k, sn) for k, sn, by in cells if _stance_ratio(by) is not None]
    if not walked:
        return text
    best, k, sn = max(walked)
    return f"{text}; the largest ratio, {best:.1f}x, on the ground x {k} with the {_ESTIMATE.get(sn, sn)}"


def _headline_variants(fp: dict, out: dict, judged: str) -> None:
    """The rows of the headline's labelled variants (shown, not judged): the stance leg-shape
    ratio and the fewest eq. 42 steps with the velocity observer; on the stiffest ground of the
    factor grid, the ratio with exact rates and the steps eq. 42 walks on the encoders."""
    obs, grid = fp.get("hzd_runs_observer"), fp.get("factor_runs")
    ids = ("fullplant_observer_mls_st_rms_ratio", "fullplant_observer_hzd_steps", "fullplant_ground_mls_st_rms_ratio",
           "fullplant_ground_encoders_hzd_steps")
    if not obs or not grid:
        out.update({i: Skip("the --quick run walks no variants of the headline") for i in ids})
        return
    scale = max(grid, key=float)
    stiff = grid[scale]
    base = dict(encoders=_ratio_text(fp["hzd_runs"][judged]))
    for rid, by, facts in ((ids[0], obs[judged], base),
                           (ids[2], stiff["ideal"], dict(scale=float(scale), identified=_ratio_text(grid["1"]["ideal"])
                                                         if "1" in grid else "not run"))):
        v = _stance_ratio(by)
        out[rid] = (Failed(f"a controller fell on this variant: {_ratio_text(by)}") if v is None
                    else Measured(v, dict(pdff=by["pdff"]["tracking_rms_deg"]["mLS_st"],
                                          hzd=by["iolin"]["tracking_rms_deg"]["mLS_st"], **facts)))
    least, which = _fewest_steps(obs)
    enc_least, enc_which = _fewest_steps(fp["hzd_runs"])
    out[ids[1]] = Measured(least, dict(which=which, encoders=enc_least, encoders_which=enc_which,
                                       exp3_ratio=_ratio_text(obs[EXP3_GAIT]) if EXP3_GAIT in obs else "not run"))
    io = stiff["encoders"]["iolin"]
    exact_walks = not stiff["ideal"]["iolin"]["fell"]
    reading = ("with exact rates it walks: on this floor the rate estimate decides whether eq. 42 walks" if io["fell"]
               and exact_walks else f"with exact rates it {'walks' if exact_walks else 'falls too'}")
    out[ids[3]] = Measured(io["steps_completed"], dict(scale=float(scale), fell=io["fell"], reading=reading,
                                                       ratio=_ratio_text(stiff["encoders"]),
                                                       observer=_ratio_text(stiff["observer"])))


def _survived(run):
    """Whether a pushed walk survived: it did not fall, and its pinned stance toe never pulled on
    the ground (a toe that pulls would lift off: the stance model cannot see that fall), with the
    contact record as facts for the row's texts."""
    if run is None:
        return Skip("the push was not walked")
    facts = {k: run.get(k) for k in ("fell", "steps_completed", "toe_pulled", "toe_pulled_step", "min_normal_force_n",
                                     "friction_cone_exceeded", "max_friction_ratio", "force_n")}
    facts["how"] = ("fell" if run.get("fell") else
                    f"did not fall, but {_toe_pulled(run)}" if run.get("toe_pulled") else "survived")
    return Measured(bool(not run.get("fell", True) and not run.get("toe_pulled", False)), facts)


def _closer_to_design(nom, ex4, exp4_speed, skip):
    """Exp. 4's distance from the designed speed minus Exp. 1's (Sec. V-D: Exp. 4 is the closer),
    with both speeds and the design's as facts; Failed where Exp. 4's speed is."""
    if not nom or not ex4:
        return skip
    if isinstance(exp4_speed, Failed):
        return exp4_speed
    if nom.get("fell"):
        return Failed("Exp. 1 fell: a fallen walk has no speed (see experiment nominal)")
    v1, v4, vd = nom["speed_mps"], ex4["speed_mps"], nom["designed_speed_mps"]
    return Measured(abs(v4 - vd) - abs(v1 - vd), dict(v_exp1=v1, v_exp4=v4, v_designed=vd))


def _pushed(run):
    """Failed where a pushed walk has no speed change or recovery to report: it fell, or its pinned
    stance toe pulled on the ground (the foot would have lifted, so the walk after it is not the
    robot's); None where the walk is valid."""
    if dig(run, "fell"):
        return Failed("fell after the push")
    if dig(run, "toe_pulled"):
        return Failed(f"the pushed walk is not a physical one: {_toe_pulled(run)}; see row push_forward_survived")
    return None


def _toe_pulled(run) -> str:
    """What a pushed walk's pulled stance toe means, with the contact record's figures."""
    return (f"its stance toe pulled on the ground ({run['min_normal_force_n']:.0f} N in step {run['toe_pulled_step']}), "
            "which the pinned toe of the stance model hides: the foot would have lifted")


def _recovered(run: dict, quick: bool):
    """Steps until the speed is back within 2 % of the unpushed one, or, where it was not back
    within the steps simulated, a Failed (the full run's 20 steps after the push) or a Skip
    (``--quick``'s few steps may end before a recovery the full run would see)."""
    back = dig(run, "steps_to_recover")
    if back is not None:
        return back
    after = len(dig(run, "speed_per_step", default=[])) - int(dig(run, "step", default=0))
    return (Skip if quick else Failed)(f"not back within 2 % of the unpushed speed in the {after} steps simulated "
                                       "after the push" + (" (--quick)" if quick else ""))


def _minor_eigenvalue(design, k: int):
    """The restricted map's eigenvalue of the k-th largest magnitude after the dominant one
    (k = 1, 2: eq. 49's second and third), its real part, with its modulus and imaginary part
    as facts."""
    ev = dig(design, "eigenvalues_hzd")
    if not ev or len(ev) <= k:
        return Skip("the design record holds no restricted-map eigenvalues")
    ev = catalog.by_magnitude(ev)
    return Measured(ev[k].real, dict(abs=abs(ev[k]), im=ev[k].imag, dominant=abs(ev[0])))


def _tracking_order(tr, output: str, *where) -> str:
    """Which of PD + feedforward and I/O linearisation tracks ``output`` with the smaller rms
    error in experiment tracking's walks (``where``: () for the stance model on the encoders,
    ("ideal_sensing",) or ("full_plant",)), and by what factor."""
    a = dig(tr, "controllers", "pdff", *where, "tracking_rms_deg", output)
    b = dig(tr, "controllers", "iolin", *where, "tracking_rms_deg", output)
    if a is None or b is None or min(a, b) <= 0.0:
        return "the two cannot be compared"
    if b < a:
        return f"I/O linearisation tracks {a / b:.1f} times better, the paper's order"
    return f"PD + feedforward tracks {b / a:.1f} times better, against the paper's order"


def _tracking_orders(tr, output: str) -> dict:
    """The facts of the tracking rows' texts: the order of the two controllers on the encoders,
    with exact sensing and on the 13-DoF plant (:func:`_tracking_order`)."""
    return dict(order=_tracking_order(tr, output), ideal_order=_tracking_order(tr, output, "ideal_sensing"),
                full_order=_tracking_order(tr, output, "full_plant"))


def _output_name(rec, short: str):
    """The tracking record's key for an output ('tor', 'mLS_st')."""
    names = list(dig(rec, "controllers", "pdff", "tracking_rms_deg", default={}))
    for n in names:
        if short.lower() in n.lower():
            return n
    return short


PAPERS = [
    Paper(key="identification", title="MABEL: identification of the model, validated by hopping",
          values=str(DATA / "paper_identification.json"), experiments=IDENTIFICATION_EXPERIMENTS,
          measure=measure_identification, order=10,
          figures=(Figure("hop", "hop_joints.png", "Hopping with the torso update on the 13-DoF model: "
                          "joint angles and hip position (cf. paper Fig. 21, the robot)"),
                   Figure("hop", "hop_torques.png", "Hopping with the torso update, same run: motor torques (cf. paper Fig. 22)"),
                   Figure("hop", "hop_cable_stretch.png", "Hopping with the torso update, same run: cable stretch in motor coordinates (cf. paper Fig. 23)"),
                   Figure("hop", "hop_periods.png", "Hopping with the torso update, same run: the period of each hop"),
                   Figure("identify", "identify_transmission.png", "Transmission experiment on the synthetic robot: chirp input and response, its log against the identified model (cf. paper Fig. 13)"),
                   Figure("identify", "identify_legs_siso.png", "Leg model validation on the synthetic robot, SISO: its log against the identified model (cf. paper Fig. 15)"),
                   Figure("identify", "identify_legs_mimo.png", "Leg model validation on the synthetic robot, MIMO: its log against the identified model (cf. paper Fig. 16)"),
                   Figure("identify", "identify_com.png", "Synthetic robot: centre of mass against the supporting toe and the hip in the balanced postures (cf. paper Fig. 17; dashed: the paper's 6 mm bound)"),
                   Figure("identify", "identify_springs.png", "Synthetic robot: spring stiffness and preload fitted to its spring logs (cf. paper Fig. 19; dashed: the paper's two fitted lines, 115.1 q + 2.214 and 111.7 q + 5.377 N m)"),
                   Figure("identify", "identify_hop_joints.png", "A self-check, not the paper's data: the synthetic robot's hop (its \"measured\" log) against the identified model replaying it (cf. paper Fig. 21, where the robot's hop is replayed)"),
                   Figure("identify", "identify_hop_cable.png", "A self-check: cable stretch of the synthetic robot's hop against the identified model's (cf. paper Fig. 23)"),
                   Figure("identify", "identified_vs_true.png", "Every identified parameter against its true value, by "
                          "group (the paper's Tables III-VI are the groups)")),
          animations=(Figure("hop", "hop.html", "MABEL hopping with the torso update (13-DoF model, logged "
                             "trajectory, stick figure)", kind="animation"),),
          notes=("The identification runs on a synthetic MABEL (published values perturbed by a seeded few-% draw) "
                 "whose true parameters are known, so each group's accuracy can be measured; the paper, on the real "
                 "robot, has no ground truth. Those rows are self-checks, the method against its own targets: shown "
                 "as such and not counted as agreement with the paper.",)),
    Paper(key="hzd", title="MABEL: compliant hybrid zero dynamics walking", values=str(DATA / "paper_hzd.json"),
          experiments=HZD_EXPERIMENTS, measure=measure_hzd, order=20, gaits=gait_table,
          figures=(Figure("nominal", "walk_tracking.png", "Exp. 1 in simulation: the paper-575 gait (the paper's nominal step) under PD + feedforward on the stance model with 14-bit encoders, tracking errors of the virtual constraints (cf. paper Fig. 12a, the robot)"),
                   Figure("nominal", "walk_torques.png", "Exp. 1, same walk: motor torques (cf. paper Fig. 13a; dashed: the paper's 30 / 55 N m capacities)"),
                   Figure("nominal", "walk_spring_torso.png", "Exp. 1, same walk: stance B_spring and torso (cf. paper Figs. 14, 20)"),
                   Figure("nominal", "walk_speed.png", "Exp. 1, same walk: speed per step"),
                   Figure("tracking", "iolin/walk_tracking.png", "Exp. 4 in simulation: the paper-575 gait under the compliant zero-dynamics controller (eq. 42) on the stance model with 14-bit encoders, tracking errors of the virtual constraints (cf. paper Fig. 12b, the robot)"),
                   Figure("tracking", "iolin/walk_torques.png", "Exp. 4, same walk: motor torques (cf. paper Fig. 13b; dashed: the 30 / 55 N m capacities)"),
                   Figure("tracking", "iolin/walk_spring_torso.png", "Exp. 4, same walk: stance B_spring and torso (cf. paper Fig. 19)"),
                   Figure("tracking", "decentralized/walk_tracking.png", "Exp. 5's controller in simulation: the paper-575 gait under the decentralised zero-dynamics controller, stance model, 14-bit encoders, tracking errors (cf. paper Figs. 11b, 12c)"),
                   Figure("tracking", "decentralized/walk_torques.png", "Exp. 5's controller, same walk: motor torques (cf. paper Fig. 13c; dashed: the 30 / 55 N m capacities)"),
                   Figure("push", "pdff_+78N/walk_speed.png", "Exp. 2 in simulation: the paper-575 gait, PD + feedforward, stance model: speed per step after a 78 N forward push (cf. paper Fig. 16; dashed: the paper's roughly 45 % change and its recovery horizon)"),
                   Figure("push", "pdff_-71N/walk_speed.png", "Exp. 2, same setting: speed per step after a 71 N backward push (cf. paper Fig. 16; dashed: the paper's roughly 45 % change and its recovery horizon)"),
                   Figure("design", "nominal/gait_constraints.png", "The torque-cost gait of optimize mabel --speed 0.8 on the paper's design model (--quick: the shipped paper-nominal file it wrote; its step length: row nominal_step_length_m; the paper's Fig. 5 gait takes 0.575 m steps): virtual constraints (cf. paper Fig. 5)"),
                   Figure("design", "nominal/gait_spring.png", "The same torque-cost gait: leg shape and stance B_spring (cf. paper Fig. 6)"),
                   Figure("design", "nominal/gait_torques.png", "The same torque-cost gait: actuator torques (cf. paper Fig. 7; dashed: the paper's 30 / 55 N m capacities)"),
                   Figure("design", "nominal/gait_toe_com.png", "The same torque-cost gait: swing toe height and centre of mass (cf. paper Fig. 8)"),
                   Figure("design", "efficient/gait_power.png", "The c_mt-cost gait of optimize mabel --speed 0.8 --cost cmt on the paper's design model (--quick: the shipped paper-efficient file): power at the stance leg shape, motor and spring (cf. paper Fig. 9)"),
                   Figure("design", "poincare_eigenvalues.png", "Poincaré eigenvalues of both gaits in the unit circle "
                          "(cf. paper Sec. IV, eq. 49)"),
                   Figure("full-plant", "paper-nominal/walk_fig20_spring_torso.png", "Exp. 1 on the 13-DoF plant "
                          "(paper-nominal gait, PD + feedforward): stance B_spring and torso per step, left and right "
                          "leg in stance, against the stance model's fixed point at eta = 0.966 (cf. paper Fig. 20)"),
                   Figure("pd-gains", "pd_gains_eigenvalues.png", "PD + feedforward, full map (eq. 44): dominant "
                          "|eigenvalue| against common factors on the shipped kp and kd, beside the paper's 0.6921 / "
                          "0.8194 (cf. paper Sec. IV-A)")),
          animations=(Figure("nominal", "walk.html", "MABEL walking the paper-575 gait under PD + feedforward (logged "
                             "trajectory, stick figure; stance leg blue)", kind="animation"),),
          notes=("The gait-design rows are the gaits optimize mabel designs on the paper's design model (rigid cables, "
                 "no motor friction or spring damping; shipped as paper-nominal and paper-efficient). Exps. 1, 2, 4, 5, "
                 "the tracking comparison and Table I walk paper-575, the torque gait of that model at the paper's "
                 "0.575 m step (the gait closest to the one the robot walked; its designed torque cost 4.75 against the "
                 "free optimum's 3.83), on the stance model; the shipped nominal gait (full design model, 0.656 m "
                 "steps) stays the default of walk mabel and full-plant walks it beside the others; Exp. 3 walks "
                 "paper-efficient-clear, the c_mt gait of the paper's design model with 1 cm of swing-toe clearance at "
                 "mid-step (paper-efficient's swing toe grazes the ground at mid-step and every controller falls on the "
                 "13-DoF plant; the full-model efficient gait's swing toe strikes the ground behind the stance toe); "
                 "pd-gains grids the gains on the two designs of the paper's model; the full-plant rows walk the "
                 "paper-model gaits on the 13-DoF model (cable stretch, compliant ground).",)),
]
