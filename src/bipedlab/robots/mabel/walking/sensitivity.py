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
              "fast": dict(comparisons=False)}


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
        if is_number(v):
            rows[k] = float(v)
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
    (default :func:`plant_rows`; a stand-in for tests)."""
    say = progress or (lambda m: None)
    run = rows_fn or (lambda scale: plant_rows(scale, progress=progress))
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
              for k in base}
        rows[name] = dict(source=mm.SCALABLE[name], printed=PRINTED[name], precision=precision(name), elasticity=e,
                          standard_error=se, scaled=scaled)
    return dict(step=step, method=(
        f"forward differences: each value x (1 {step:+g}) in the plant alone (the controllers keep the published "
        f"model), the experiments' row walks again; standard errors from {len(REPLICAS)} rounding replicas of the "
        "unscaled plant"), precision_source=PRECISION_SOURCE, base=base, noise=noise, parameters=rows,
        walks_per_plant=len(PLANT_RUNS), wall_time_s=time.perf_counter() - t0)
