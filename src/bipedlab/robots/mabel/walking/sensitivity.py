"""How the HZD paper's designed gaits move with MABEL's published values: the elasticity
d ln(quantity) / d ln(parameter) of the torque-cost (``paper-nominal``) and c_mt-cost
(``paper-efficient``) gaits' step length, c_mt, spring share of the negative work and Poincaré
eigenvalues (restricted map, eq. 48, and the full map under PD + feedforward, eq. 44), for each
value of :data:`bipedlab.robots.mabel.model.SCALABLE` (Tables V-VIII of the identification
paper, Fig. 19's springs, the HZD paper's torque capacities; the leg lengths, which no source
prints, as assumed values).

A designed gait is the optimum of the design problem on the model, so a scaled value is a
different robot with its own optimum: the unscaled gaits are designed as the design experiment
designs them (``base``: the torque gait from the hand-set guess, the c_mt gait continued from
it, as ``optimize mabel`` on the paper's design model: the same optima), then each parameter is
scaled by 1 + ``step`` in the walking model and both gaits optimised again on it, each warm
from its unscaled optimum (the derivative along that optimum's branch: the c_mt design has
nearby local optima, one unit in the last place of the robot's mass moving it from one to
another), the PD + feedforward terms regressed again, and both Poincaré maps evaluated at their
own fixed points. Forward differences of smooth, deterministic functions of the model.

Each value's precision is its printed digits (half a unit of the last one,
:func:`bipedlab.report.spec.printed_precision`; the largest over a value printed per leg or
per motor)."""
from __future__ import annotations

import time

import numpy as np

from bipedlab.report.spec import printed_precision, reach
from bipedlab.robots.mabel import model as mm
from bipedlab.robots.mabel.walking import catalog
from bipedlab.robots.mabel.walking import design as md
from bipedlab.robots.mabel.walking import stance as wk

#: each scaled value as its sources print it (several forms: per leg or per motor)
PRINTED = {
    "torso mass": ("40.8953",), "torso COM height": ("0.18337",), "torso inertia": ("2.3727",),
    "thigh mass": ("3.2818",), "thigh inertia": ("0.1986",), "shin mass": ("1.5007",), "shin inertia": ("0.08813",),
    "thigh length": None, "shin length": None,
    "boom mass": ("7.2575",), "boom inertia": ("20.4951",),
    "leg-shape rotor inertia": ("9.0144e-4",), "leg-angle rotor inertia": ("4.4928e-4",),
    "spring stiffness": ("115.1", "111.7"), "spring damping": ("1.5",),
    "motor friction": ("9.844e-3", "4.316e-3", "9.027e-3", "4.615e-3"),
    "torque capacity": ("30", "55"),
}
PRECISION_SOURCE = ("the printed digits of the identification paper's Tables V-VIII and Fig. 19 and of the HZD "
                    "paper's torque capacities; the thigh and shin lengths (0.5 m) are printed by neither paper")
#: the gaits re-designed: row prefix -> (shipped gait, cost)
GAITS = {"nominal": ("paper-nominal", "torque"), "efficient": ("paper-efficient", "cmt")}
#: the design speed of both gaits (m/s)
SPEED = 0.8


def precision(name: str):
    """The relative precision of parameter ``name`` as printed (the largest over its printed
    forms), or None for a value no source prints."""
    forms = PRINTED[name]
    return None if forms is None else max(printed_precision(t) for t in forms)


def design_quantities(d, pc: dict, prefix: str) -> dict:
    """The design rows of a gait (``prefix``: nominal or efficient) from its Design and its
    Poincaré analysis (:func:`bipedlab.robots.mabel.walking.study.poincare`)."""
    f = d.figures
    out = {f"{prefix}_cmt": float(f["cmt"]), f"{prefix}_negative_work_fraction_spring":
           float(f["negative_work_fraction_spring"]),
           f"{prefix}_eig_hzd": (pc.get("hzd") or {}).get("max_abs_eigenvalue"),
           f"{prefix}_eig_pdff": (pc.get("pdff") or {}).get("max_abs_eigenvalue")}
    if prefix == "nominal":
        out["nominal_step_length_m"] = float(f["step_length"])
        ev = catalog.by_magnitude((pc.get("hzd") or {}).get("poincare_eigenvalues_complex"))
        for k in (1, 2):
            out[f"nominal_eig_hzd_minor_{k}"] = ev[k].real if len(ev) > k else None
    return out


def redesign(scale: tuple = (), start=None) -> tuple[dict, bool, dict]:
    """Both gaits designed again on the walking model built with ``scale`` (pairs (name,
    factor)): ({row: value}, every design converged, {gait prefix: decision vector}).
    ``start`` {prefix: decision vector}: each gait's warm start; None: the design experiment's
    own path (the torque gait from the hand-set guess, the c_mt gait continued from it, as
    ``optimize mabel``), so the unscaled rows are that experiment's optimum."""
    from bipedlab.robots.mabel.walking import study as wm

    m = wk.walking_model(scale=tuple(scale))
    rows, ok, xs = {}, True, {}
    for prefix, (gait, cost) in GAITS.items():
        if start is None:
            x0 = xs.get("nominal") if cost == "cmt" else None  # c_mt continues from the torque optimum
            d, info = md.optimize(SPEED, cost, x0=x0, model=m, kind="paper")
        else:
            d, info = md.optimize(SPEED, cost, x0=start[prefix], model=m, kind="paper")
        gains = md.controller_gains(md.design_model(m, "paper"), d)
        pc = wm.poincare(d, gains, ("pdff",), design_model="paper", model=m)
        ok = ok and info["success"]
        xs[prefix] = np.asarray(d.x)
        rows.update(design_quantities(d, pc, prefix))
    return rows, ok, xs


def _elasticity(scaled: dict, base: dict, step: float, ok: bool) -> dict:
    e = {}
    for k, b in base.items():
        a = scaled.get(k)
        e[k] = float((a - b) / (step * b)) if ok and None not in (a, b) and b != 0 else None
    return e


def sensitivity(step: float = 0.01, parameters=None, progress=None, redesign_fn=None) -> dict:
    """The elasticities of the designed gaits' rows to each parameter (JSON-ready): ``base``
    (the unscaled re-design's rows), ``parameters`` {name: value source, printed, precision,
    elasticity {row: value or None}, scaled {row: value}, converged}, ``failed`` (the
    parameters whose re-design did not converge: no elasticity). ``parameters``: names of
    :data:`~bipedlab.robots.mabel.model.SCALABLE` (default all); ``redesign_fn``: the
    re-design (default :func:`redesign`; a stand-in for tests)."""
    say = progress or (lambda m: None)
    run = redesign_fn or redesign
    names = list(mm.SCALABLE) if parameters is None else list(mm.factors({n: 1.0 for n in parameters}))
    t0 = time.perf_counter()
    say(f"mabel sensitivity: {len(names) + 1} re-designs of both gaits, each parameter x (1 + {step:g})")
    base, ok, start = run(())
    if not ok:
        raise RuntimeError("the unscaled gaits' re-design did not converge")
    rows = {}
    for i, name in enumerate(names):
        say(f"mabel sensitivity: {name} ({i + 1} of {len(names)})")
        scaled, ok, _ = run(((name, 1.0 + step),), start)
        rows[name] = dict(source=mm.SCALABLE[name], printed=PRINTED[name], precision=precision(name),
                          elasticity=_elasticity(scaled, base, step, ok), scaled=scaled, converged=ok)
    return dict(step=step, method=(
        f"forward differences: each value x (1 + {step:g}) in the walking model, both gaits optimised again on it "
        "(warm from the design experiment's optima), their Poincaré maps at their own fixed points"),
        precision_source=PRECISION_SOURCE, base=base, parameters=rows,
        failed=[k for k, r in rows.items() if not r["converged"]], designs=2 * (1 + len(rows)),
        wall_time_s=time.perf_counter() - t0)


def summary(rec: dict) -> str:
    """The elasticities as a table (rows down, parameters across would not fit: one line per
    parameter with its largest elasticities), the failed re-designs and each row's reach; then
    the plant tier's likewise (each elasticity with its standard error)."""
    lines = [f"mabel sensitivity of the designed gaits ({rec['method']}; {rec['designs']} designs, "
             f"{rec['wall_time_s']:.0f} s)"] + _table(rec)
    if rec["failed"]:
        lines.append("  a re-design did not converge (no elasticity): " + ", ".join(rec["failed"]))
    p = rec.get("plant")
    if p:
        lines += [f"mabel sensitivity of the walking experiments' rows to the plant ({p['method']}; "
                  f"{1 + len(REPLICAS) + len(p['parameters'])} plants, {p['wall_time_s']:.0f} s)"] + _table(p)
    return "\n".join(lines)


def _table(rec: dict) -> list:
    lines = ["  base: " + ", ".join(f"{k} {v:.5g}" for k, v in rec["base"].items() if v is not None),
             "  d ln(row) / d ln(parameter), precision, then the three largest:"]
    for name, r in rec["parameters"].items():
        e = {k: v for k, v in r["elasticity"].items() if v is not None}
        se = r.get("standard_error") or {}
        top = sorted(e, key=lambda k: -abs(e[k]))[:3]
        prec = "assumed" if r["precision"] is None else f"{r['precision']:.1e}"
        lines.append(f"  {name:<24} {prec:>8}  " + ", ".join(
            f"{k} {e[k]:+.3g}" + (f" +- {se[k]:.2g}" if se.get(k) is not None else "") for k in top))
    lines.append("  reach within the printed precision (first order): "
                 + ", ".join(f"{k} {reach(rec, k):.2e}" for k in rec["base"]))
    return lines


# ----------------------------------------------------------------------------- the plant tier
#: the walking experiments whose rows the plant tier measures, each with the options that keep
#: the walks its rows come from (reproduce's full run) and leave out those that feed none
PLANT_RUNS = {"nominal": {}, "efficient": {}, "tracking": dict(controllers=["pdff", "iolin"], causes=False),
              "exp4": dict(compare=False), "impact-scaling": dict(pdff_column=False, gait_factor=[]),
              "fast": dict(comparisons=False), "push": dict(controllers=["pdff"], search=False),
              "full-plant": dict(gaits=["paper-nominal", "paper-efficient-clear"], headline=["paper-575"],
                                 variants=False)}
#: rows those reduced runs give otherwise than the full run (the fewest steps over every
#: headline gait: the plant tier walks the judged one only)
NOT_PLANT_ROWS = ("fullplant_hzd_steps",)


def plant_rows(scale: tuple = (), runs=None, progress=None) -> dict:
    """The HZD paper's rows of the walking experiments ``runs`` (default :data:`PLANT_RUNS`)
    walked on a plant built with ``scale`` (pairs (name, factor); () the published values, as
    data of the loop like every scaled plant), the controllers knowing the published model:
    {row: value}, the numbers :func:`bipedlab.robots.mabel.reproduce.measure_hzd` gives from
    those records."""
    from bipedlab.report.values import is_number
    from bipedlab.robots.mabel import reproduce as mr
    from bipedlab.robots.mabel.walking import experiments as wx

    runs = PLANT_RUNS if runs is None else runs
    records = {name: wx.run(name, progress=progress, plant_scale=tuple(scale), **opts) for name, opts in runs.items()}
    out = mr.measure_hzd(records, quick=False)
    rows = {}
    for k, v in out.items():
        v = getattr(v, "value", v)
        if is_number(v) and k not in NOT_PLANT_ROWS:
            rows[k] = float(v)
    return rows


#: Exp. 2's force rows: row -> (plant, index into the experiment's TARGET_CHANGES and PUSHES)
FORCE_ROWS = {"push_force_plus_45pct_n": ("stance", 0), "push_force_minus_45pct_n": ("stance", 1),
              "fullplant_push_force_plus_45pct_n": ("full", 0), "fullplant_push_force_minus_45pct_n": ("full", 1)}
#: the 13-DoF recovery rows read from the walks at the searched forces (report.FULL_PUSH_ROWS)
FULL_RECOVERY_ROWS = ("fullplant_push_forward_steps", "fullplant_push_backward_steps", "fullplant_push_recovery_asymmetry")
#: relative force step of the change's slope at a searched force
FORCE_STEP = 0.02
#: Exp. 2's walks (steps; experiment push's default)
PUSH_WALK = 30


def force_base(progress=None) -> dict:
    """Exp. 2's PD + feedforward force searches (stance model and 13-DoF plant) on the
    published plant as data (``plant_scale`` ()): per row of :data:`FORCE_ROWS`, the force F*,
    the peak speed change c* its walk reached, the slope dc/dF there (a second walk at
    F* (1 + FORCE_STEP)) and the walk's recovery (``steps_to_recover``)."""
    from bipedlab.robots.mabel.walking import experiments as wx

    out, refs = {}, {}
    for row, (plant, i) in FORCE_ROWS.items():
        if plant not in refs:
            refs[plant] = _reference(plant, (), progress)
        x = wx.search_push("pdff", wx.TARGET_CHANGES[i], wx.PUSHES[i], refs[plant], PUSH_WALK, progress=progress,
                           plant=plant, plant_scale=())
        f = x["force_n"]
        y = wx.push_at(wx.GAIT, "pdff", f * (1.0 + FORCE_STEP), refs[plant], PUSH_WALK, progress=progress, plant=plant,
                       plant_scale=(), direction=np.sign(wx.TARGET_CHANGES[i]))
        slope = (None if x["speed_change"] is None or y["speed_change"] is None
                 else (y["speed_change"] - x["speed_change"]) / (FORCE_STEP * f))
        out[row] = dict(plant=plant, force_n=f, change=x["speed_change"], slope=slope, converged=x["converged"],
                        steps_to_recover=x["steps_to_recover"], fell=x["fell"])
    return out


def _reference(plant: str, scale: tuple, progress=None) -> float:
    from bipedlab.robots.mabel.walking import experiments as wx
    from bipedlab.robots.mabel.walking import study as wm

    r = wm.walk(wx.GAIT, "pdff", PUSH_WALK, plant=plant, plant_scale=tuple(scale), progress=progress)
    return wx.mean_speed(r, wx.REFERENCE_FROM)


def force_rows(scale: tuple, base: dict, progress=None) -> dict:
    """The force rows on a plant built with ``scale``, to first order from the searches on the
    published one (``base``, :func:`force_base`): F* - (c(F*) - c*) / (dc/dF), c(F*) the change
    the searched force makes on this plant (against its own unpushed speed), so the published
    plant gives F* exactly; and the 13-DoF recovery rows from those walks (at the published
    plant's forces)."""
    from bipedlab.robots.mabel.walking import experiments as wx

    rows, refs, back = {}, {}, {}
    for row, b in base.items():
        plant = b["plant"]
        if plant not in refs:
            refs[plant] = _reference(plant, scale, progress)
        x = wx.push_at(wx.GAIT, "pdff", b["force_n"], refs[plant], PUSH_WALK, progress=progress, plant=plant,
                       plant_scale=tuple(scale))
        if x["speed_change"] is not None and b["change"] is not None and b["slope"]:
            rows[row] = b["force_n"] - (x["speed_change"] - b["change"]) / b["slope"]
        if plant == "full" and x["steps_to_recover"] is not None:
            back[FULL_RECOVERY_ROWS[FORCE_ROWS[row][1]]] = x["steps_to_recover"]
    rows.update({k: float(v) for k, v in back.items()})
    if len(back) == 2:
        rows[FULL_RECOVERY_ROWS[2]] = float(back[FULL_RECOVERY_ROWS[0]] - back[FULL_RECOVERY_ROWS[1]])
    return rows


#: the values the plant tier scales (each plant walks every row's walks again: about 5 min on two
#: cores): the torso, whose mass, COM and inertia the stance dynamics carry most of, the leg-shape
#: rotor the controllers' largest reflected inertia, and the drivetrain's compliance and losses
PLANT_PARAMETERS = ("torso mass", "torso COM height", "torso inertia", "leg-shape rotor inertia", "spring stiffness",
                    "spring damping", "motor friction")
#: the rounding replicas of the plant tier's base: plants whose values differ from the published
#: ones by a part in 1e12 (no physical change), each walk rounding differently; the spread of their
#: rows is the rows' noise (an encoder-quantised walk amplifies rounding: a peak can move by 10 %)
REPLICAS = (("torso mass", 1.0 + 1e-12), ("boom inertia", 1.0 + 1e-12))


def plant_sensitivity(step: float = 0.1, parameters=None, progress=None, rows_fn=None) -> dict:
    """The elasticities of the walking experiments' rows to each value scaled in the plant
    alone (the controllers keep the published model, as the robot's did), by forward differences
    of ``step``: the common record format (:func:`sensitivity`'s) with ``standard_error``
    {row: s.e. of the elasticity} from the rows' noise: the s.d. over the base and its rounding
    :data:`REPLICAS`, times sqrt(2) / (step |base|). ``rows_fn(scale)``: the rows of a plant
    (default :func:`plant_rows` and :func:`force_rows`, the searches of :func:`force_base` run
    once, on the first plant; record key ``searches``; a stand-in for tests)."""
    say = progress or (lambda m: None)
    searches = {}

    def rows_of(scale):
        rows = plant_rows(scale, progress=progress)
        if not searches:
            searches.update(force_base(progress))
        rows.update(force_rows(scale, searches, progress))
        return rows

    run = rows_fn or rows_of
    names = list(mm.SCALABLE) if parameters is None else list(mm.factors({n: 1.0 for n in parameters}))
    t0 = time.perf_counter()
    say(f"mabel plant sensitivity: {1 + len(REPLICAS) + len(names)} plants, each value x (1 {step:+g})")
    base = run(())
    reps = [run((r,)) for r in REPLICAS]
    noise = {}
    for k, b in base.items():
        vals = [b] + [r.get(k) for r in reps]
        vals = [v for v in vals if v is not None]
        noise[k] = float(np.std(vals, ddof=1)) if len(vals) > 1 else None
    rows = {}
    for i, name in enumerate(names):
        say(f"mabel plant sensitivity: {name} ({i + 1} of {len(names)})")
        scaled = run(((name, 1.0 + step),))
        e = _elasticity(scaled, base, step, True)
        se = {k: (None if e[k] is None or noise.get(k) is None else float(np.sqrt(2.0) * noise[k] / abs(step * base[k])))
              for k in base}  # e[k] is None where base[k] is 0
        rows[name] = dict(source=mm.SCALABLE[name], printed=PRINTED[name], precision=precision(name), elasticity=e,
                          standard_error=se, scaled=scaled)
    return dict(step=step, method=(
        f"forward differences: each value x (1 {step:+g}) in the plant alone (the controllers keep the published "
        f"model), the experiments' row walks again (Exp. 2's searched forces to first order: the change each force "
        f"makes, over its slope); standard errors from {len(REPLICAS)} rounding replicas of the unscaled plant"), precision_source=PRECISION_SOURCE, base=base, noise=noise, parameters=rows,
        experiments_per_plant=len(PLANT_RUNS), searches=searches or None, wall_time_s=time.perf_counter() - t0)
