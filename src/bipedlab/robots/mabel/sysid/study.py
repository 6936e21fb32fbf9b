"""Study: MABEL's system identification (Park, Sreenath, Hurst & Grizzle), end to end.

``--synthetic``: a "true" MABEL (the published values, each perturbed by a seeded few-%
draw; :func:`bipedlab.robots.mabel.sysid.params.perturbed`) runs every experiment of the paper under the
robot's sensors (14-bit encoders, commanded torque only, 1 kHz; the noise LEVEL is the rms
encoder noise in counts, which also scales the amplifier's torque noise, 2 mN m per count,
and the scale's, 0.5 N per count); :func:`bipedlab.robots.mabel.sysid.identify` identifies every parameter
from those logs alone, and the record compares each with its true value.

``--data DIR``: the same pipeline on logs in the CSV format of :mod:`bipedlab.robots.mabel.sysid.logs`;
no truth, so the record gives the estimates, their uncertainties where the fit gives them,
and the validation of the identified models against the logs.

What the logs do not determine is said, not left to be inferred from null accuracy figures:
the record's ``not_identified`` lists, per group, the parameters that keep their published
values and why (the log each one needs, or the hop's 1-sigma error for the hopping fit's
undetermined variables), every row of ``parameters`` carries ``identified``, and one progress
line on stderr names the groups. A folder that identifies only some groups still exits 0: a
researcher often logs one experiment at a time (the biases again after an amplifier change,
one leg's friction), and the published values beside the identified ones, each marked, are
the useful answer. A folder whose logs determine nothing at all (every estimate would be a
published value, e.g. a single transmission log, which cannot separate K_T from alpha) is
refused before any fit, with status 2 and one line saying what is needed: such a record would
only repeat the tables.

:func:`noise_study` repeats the synthetic identification at several noise levels.
"""
from __future__ import annotations

import time

import numpy as np

from bipedlab.robots.mabel import sysid
from bipedlab.robots.mabel.sysid import pipeline as sid

NOISE_UNITS = ("rms encoder noise in counts (1 count = 2 pi / 2^14 rad); also scales the amplifier's torque "
               "noise (2 mN m per count, white at 1 kHz) and the scale's (0.5 N per count)")
IDENTIFIABILITY = (
    "K_T, alpha, biases, frictions, spring stiffness and cable stiffness and damping are each determined by "
    "experiments built for them. From the single hop of Section VIII the spring damping Kd_B is identified and the "
    "ground's normal stiffness is (just) identified; the ground's damping is marginal; the hard stop's K_d1 (its "
    "cubic term never exceeds 1e-6 N m at the millimetre-scale penetrations of a hop), K_vd1, K_vd2 and the ground's "
    "friction are not identified: their estimates stay near the published values the fit starts from and is weakly "
    "pulled towards (a factor-3 log-normal prior), so their errors say how far the truth was drawn from those "
    "values, nothing about the data. The 1-sigma relative errors under 'identifiability' come from the data alone "
    "and include the effect of the initial-state uncertainty on the open-loop replay.")


def _design(quick: bool) -> sysid.Design:
    return sysid.quick_design() if quick else sysid.Design()


def _validation_summary(validation: dict) -> tuple[float | None, float | None]:
    """(largest joint-angle rms over the leg experiments and the hop, largest cable-stretch rms)."""
    joints = [v for k, v in validation.items() if not k.startswith("hopping_cable")]
    cables = [v for k, v in validation.items() if k.startswith("hopping_cable")]
    return (max(joints) if joints else None), (max(cables) if cables else None)


def record(ident: sysid.Identification, truth: sysid.MabelParams | None, missing: dict | None = None) -> dict:
    """The JSON-ready record of an identification (compared with truth when given);
    ``missing``: :func:`pipeline.coverage` of its logs, reported as ``not_identified`` with
    the hopping fit's undetermined variables added."""
    cmp = sid.compare(truth, ident)
    why = sid.unfitted(ident, missing or {})
    for row in cmp["parameters"]:
        row.setdefault("identified", row["name"] not in why)
    if truth is not None:
        # the targets judge what was identified: a parameter the logs do not fit keeps its
        # published value, and a group with none identified has no target met or missed
        ident_err = {}
        for row in cmp["parameters"]:
            if row["group"] != "bias" and row["identified"] and row["rel_error"] is not None:
                ident_err[row["group"]] = max(ident_err.get(row["group"], 0.0), row["rel_error"])
        cmp["max_rel_error_identified"] = {g: ident_err.get(g) for g in cmp["max_rel_error_identified"]}
        cmp["targets_met"] = {g: (met if g == "bias" else None if g not in ident_err else ident_err[g] <= sid.TARGETS[g])
                              for g, met in cmp["targets_met"].items()}
    joints, cables = _validation_summary(ident.details.get("validation", {}))
    hop = ident.details.get("hopping", {})
    rec = {
        "max_rel_error": cmp.get("max_rel_error"),
        "max_rel_error_identified": cmp.get("max_rel_error_identified"),
        "max_abs_bias_error_nm": cmp.get("max_abs_bias_error_nm"),
        "max_abs_bias_error_arx_nm": cmp.get("max_abs_bias_error_arx_nm"),
        "validation_rms_deg": joints,
        "validation_cable_stretch_rms_deg": cables,
        "validation": ident.details.get("validation", {}),
        "targets": cmp.get("targets"),
        "targets_met": cmp.get("targets_met"),
        "parameters": cmp["parameters"],
        "not_identified": sid.not_identified(why),
        "identifiability": {k: dict(rel_std=hop["rel_std"][k], identified=hop["identified"][k])
                            for k in hop.get("rel_std", {})},
        "identifiability_note": IDENTIFIABILITY,
        "com_check": ident.details.get("com_check"),
        "details": {k: v for k, v in ident.details.items() if k not in ("validation", "com_check")},
        "notes": ident.notes,
    }
    if truth is not None and "torso_com_shift_error_mm" in cmp:
        rec["com_check"] = dict(rec["com_check"] or {}, true_torso_com_shift_mm=(1e3 * truth.torso_com_offset).tolist(),
                                shift_error_mm=cmp["torso_com_shift_error_mm"])
    return rec


def synthetic(seed: int = 0, noise: float = 1.0, quick: bool = False, progress=None):
    """(truth, logs, identification) of one synthetic run."""
    truth = sysid.perturbed(seed)
    logs = sysid.generate(truth, sysid.Sensors(noise=noise, seed=seed), _design(quick), progress=progress)
    return truth, logs, sysid.identify(logs, progress=progress, hop_max_nfev=5 if quick else 8)


def noise_study(levels=(0.0, 1.0, 2.0, 4.0), seed: int = 0, quick: bool = False, progress=None) -> dict:
    """The synthetic identification at several noise levels (same truth, same seed): per level
    the largest relative error per group and the largest bias error."""
    say = progress or (lambda msg: None)
    rows = []
    for level in levels:
        say(f"noise study: level {level:g}")
        truth, _, ident = synthetic(seed, level, quick, progress=None)
        cmp = sid.compare(truth, ident)
        rows.append(dict(noise=level, max_rel_error=cmp["max_rel_error"],
                         max_abs_bias_error_nm=cmp["max_abs_bias_error_nm"],
                         max_abs_bias_error_arx_nm=cmp["max_abs_bias_error_arx_nm"],
                         validation_rms_deg=_validation_summary(ident.details["validation"])[0],
                         targets_met=cmp["targets_met"]))
    return dict(levels=list(levels), noise_units=NOISE_UNITS, seed=seed, rows=rows)


def study(synthetic_data: bool = True, data: str | None = None, seed: int = 0, noise: float = 1.0,
          out: str | None = None, quick: bool = False, noise_levels=None, progress=None) -> dict:
    """Identify MABEL from synthetic experiments (or the logs in ``data``); optionally write
    figures and logs to ``out`` and run the noise study over ``noise_levels``."""
    t0 = time.perf_counter()
    if data is not None:
        logs = sysid.read_logs(data)
        missing = sid.coverage(logs)
        if sid.identifies_nothing(logs, missing):
            raise sysid.LogError(f"{data}: these {len(logs)} log{'s' if len(logs) > 1 else ''} identify no parameter "
                                 f"(every estimate would be a published value): "
                                 + "; ".join(dict.fromkeys(missing.values())))
        truth = None
        ident = sysid.identify(logs, progress=progress)
    else:
        truth, logs, ident = synthetic(seed, noise, quick, progress)
        missing = sid.coverage(logs)
    rec = {"robot": "mabel", "mode": "data" if data is not None else "synthetic"}
    if data is not None:
        rec["data"] = str(data)
        rec["logs"] = len(logs)
    else:
        rec.update(seed=seed, noise_level=noise, noise_units=NOISE_UNITS, design="quick" if quick else "paper")
    rec.update(record(ident, truth, missing))
    if progress and rec["not_identified"]:
        progress(not_identified_line(rec["not_identified"]))
    if noise_levels:
        rec["noise_study"] = noise_study(noise_levels, seed, quick, progress)
    if out:
        from bipedlab.robots.mabel.sysid import plots as identify_plots

        if progress:
            progress(f"writing figures and logs to {out}")
        rec["figures"] = identify_plots.write_figures(ident, out, say=progress)
        if data is None:
            rec["logs_written"] = len(sysid.write_logs(logs, f"{out}/logs"))
    rec["wall_time_s"] = time.perf_counter() - t0
    return clean(rec)


def not_identified_line(rows: list) -> str:
    """One line naming the groups ``not_identified`` lists (the record holds the parameters and why)."""
    groups = ", ".join(f"{r['group']} ({len(r['parameters'])})" for r in rows)
    return f"not identified from these logs, published values kept: {groups}; see not_identified in the record"


def clean(obj):
    """JSON-ready copy: numpy scalars and arrays to Python, non-finite numbers to None."""
    if isinstance(obj, dict):
        return {str(k): clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [clean(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return clean(obj.tolist())
    if isinstance(obj, (np.bool_, bool)):
        return bool(obj)
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return float(obj) if np.isfinite(obj) else None
    return obj


def _fmt(v, spec=".2%", scale: float = 1.0):
    """A number of the record formatted, or "-" where it is null (a value no fit gave)."""
    return "-" if v is None else format(scale * v, spec)


def summary(rec: dict) -> str:
    """Human-readable summary of :func:`study`; a null value (an estimate no fit gave, a
    non-finite number) prints as "-"."""
    lines = [f"MABEL system identification ({rec['mode']}"
             + (f", seed {rec['seed']}, noise {rec['noise_level']:g} counts, {rec['design']} design)"
                if rec["mode"] == "synthetic" else f", {rec['logs']} logs from {rec['data']})")]
    if rec.get("max_rel_error"):
        met = rec.get("targets_met") or {}
        targets = rec.get("targets") or {}
        identified = rec.get("max_rel_error_identified") or {}
        lines.append("  largest relative error per group (target; identified only):")
        for g, v in rec["max_rel_error"].items():
            t = targets.get(g)
            verdict = "not identified" if g in met and met[g] is None else ("met" if met.get(g) else "MISSED")
            flag = "" if t is None else f"  (target {t:.0%}: {verdict})"
            vi = identified.get(g)
            lines.append(f"    {g:<20} {_fmt(v)}" + (f"  [identified: {_fmt(vi)}]" if vi != v else "") + flag)
        lines.append(f"  largest bias error: {_fmt(rec.get('max_abs_bias_error_nm'), '.2f', 1e3)} mN m (eq. 20; "
                     f"Appendix A {_fmt(rec.get('max_abs_bias_error_arx_nm'), '.2f', 1e3)} mN m; target 5 mN m: "
                     f"{'met' if met.get('bias') else 'MISSED'})")
    else:
        lines.append("  estimates:")
        for p in rec.get("parameters") or []:
            lines.append(f"    {p['name']:<26} {_fmt(p.get('estimate'), '.5g')} {p['unit']}"
                         + ("  (published)" if p.get("identified") is False else ""))
    if rec.get("not_identified"):
        lines.append("  not identified (published values kept):")
        for r in rec["not_identified"]:
            lines.append(f"    {r['group']:<20} {len(r['parameters'])} parameters: {r['why']}")
    if rec.get("validation_rms_deg") is not None:
        lines.append(f"  validation rms (simulated vs measured joint angles): {rec['validation_rms_deg']:.3f} deg max; "
                     f"cable stretch {_fmt(rec.get('validation_cable_stretch_rms_deg'), '.3f')} deg (motor side)")
    cc = rec.get("com_check")
    if cc:
        postures = sum(len(v or []) for v in (cc.get("distance_mm") or {}).values())
        lines.append(f"  COM check (Section VI): largest distance {_fmt(cc.get('max_abs_mm'), '.1f')} mm over "
                     f"{postures} postures; torso COM shift "
                     + ", ".join(_fmt(v, ".1f") for v in cc.get("torso_com_shift_mm") or []) + " mm")
    ident = rec.get("identifiability") or {}
    if ident:
        lines.append("  hopping fit, 1-sigma relative error (identified below 10 %):")
        lines.append("    " + ", ".join(f"{k} {v['rel_std']:.1%}{'' if v['identified'] else ' (not identified)'}"
                                        if v["rel_std"] is not None and v["rel_std"] < 10.0
                                        else f"{k} >1000% (not identified)"
                                        for k, v in ident.items()))
    ns = rec.get("noise_study")
    if ns and ns.get("rows"):
        lines.append("  noise study (largest relative error per group; bias in mN m):")
        groups = list(ns["rows"][0]["max_rel_error"])
        lines.append("    level  " + "  ".join(f"{g[:10]:>10}" for g in groups) + "   bias")
        for r in ns["rows"]:
            lines.append(f"    {r['noise']:5g}  " + "  ".join(f"{_fmt(r['max_rel_error'].get(g), '.2%'):>10}"
                                                          for g in groups)
                         + f"  {_fmt(r.get('max_abs_bias_error_nm'), '.2f', 1e3)}")
    for n in rec.get("notes", []):
        lines.append(f"  note: {n}")
    for f in rec.get("figures", []):
        lines.append(f"  figure: {f}")
    lines.append(f"  wall time {_fmt(rec.get('wall_time_s'), '.0f')} s")
    return "\n".join(lines)
