"""How the HZD paper's designed gaits move with MABEL's published values: the elasticity
d ln(quantity) / d ln(parameter) of the torque-cost (``paper-nominal``) and c_mt-cost
(``paper-efficient``) gaits' step length, c_mt, spring share of the negative work and Poincaré
eigenvalues (restricted map, eq. 48, and the full map under PD + feedforward, eq. 44), for each
value of :data:`bipedlab.robots.mabel.model.SCALABLE` (Tables V-VIII of the identification
paper, Fig. 19's springs, the HZD paper's torque capacities; the leg lengths, which no source
prints, as assumed values).

A designed gait is the optimum of the design problem on the model, so a scaled value is a
different robot with its own optimum: each parameter is scaled by 1 + ``step`` in the walking
model, both gaits are optimised again on it (SLSQP warm from the shipped gait's decision vector,
as ``optimize mabel`` on the paper's design model), the PD + feedforward terms regressed again,
and both Poincaré maps evaluated at their own fixed points; the unscaled gaits are found again
the same way (``base``). Forward differences of smooth, deterministic functions of the model.

Each value's precision is its printed digits (half a unit of the last one,
:func:`bipedlab.report.spec.printed_precision`; the largest over a value printed per leg or
per motor)."""
from __future__ import annotations

import time

import numpy as np

from bipedlab.report.spec import printed_precision, reach
from bipedlab.robots.mabel import model as mm
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
        ev = (pc.get("hzd") or {}).get("poincare_eigenvalues_complex") or []
        ev = sorted((complex(re, im) for re, im in ev), key=abs, reverse=True)
        for k in (1, 2):
            out[f"nominal_eig_hzd_minor_{k}"] = ev[k].real if len(ev) > k else None
    return out


def redesign(scale: tuple = (), progress=None) -> tuple[dict, bool]:
    """Both gaits designed again on the walking model built with ``scale`` (pairs (name,
    factor)): ({row: value}, every design converged)."""
    from bipedlab.robots.mabel.walking import study as wm

    m = wk.walking_model(scale=tuple(scale))
    rows, ok = {}, True
    for prefix, (gait, cost) in GAITS.items():
        x0 = np.asarray(wm.load_gait(gait)[2]["x"], float)
        d, info = md.optimize(SPEED, cost, x0=x0, model=m, kind="paper")
        gains = md.controller_gains(md.design_model(m, "paper"), d)
        pc = wm.poincare(d, gains, ("pdff",), design_model="paper", model=m)
        ok = ok and info["success"]
        rows.update(design_quantities(d, pc, prefix))
    return rows, ok


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
    names = list(mm.SCALABLE) if parameters is None else list(parameters)
    unknown = [n for n in names if n not in mm.SCALABLE]
    if unknown:
        raise ValueError(f"unknown MABEL parameter(s) {', '.join(unknown)}; known: {', '.join(mm.SCALABLE)}")
    t0 = time.perf_counter()
    say(f"mabel sensitivity: {len(names) + 1} re-designs of both gaits, each parameter x (1 + {step:g})")
    base, ok = run(())
    if not ok:
        raise RuntimeError("the unscaled gaits' re-design did not converge")
    rows = {}
    for i, name in enumerate(names):
        say(f"mabel sensitivity: {name} ({i + 1} of {len(names)})")
        scaled, ok = run(((name, 1.0 + step),))
        rows[name] = dict(source=mm.SCALABLE[name], printed=PRINTED[name], precision=precision(name),
                          elasticity=_elasticity(scaled, base, step, ok), scaled=scaled, converged=ok)
    return dict(step=step, method=(
        f"forward differences: each value x (1 + {step:g}) in the walking model, both gaits optimised again on it "
        "(warm from the shipped gaits), their Poincaré maps at their own fixed points"),
        precision_source=PRECISION_SOURCE, base=base, parameters=rows,
        failed=[k for k, r in rows.items() if not r["converged"]], designs=2 * (1 + len(rows)),
        wall_time_s=time.perf_counter() - t0)


def summary(rec: dict) -> str:
    """The elasticities as a table (rows down, parameters across would not fit: one line per
    parameter with its largest elasticities), the failed re-designs and each row's reach."""
    lines = [f"mabel sensitivity of the designed gaits ({rec['method']}; {rec['designs']} designs, "
             f"{rec['wall_time_s']:.0f} s)",
             "  base: " + ", ".join(f"{k} {v:.5g}" for k, v in rec["base"].items() if v is not None),
             "  d ln(row) / d ln(parameter), precision, then the three largest:"]
    for name, r in rec["parameters"].items():
        e = {k: v for k, v in r["elasticity"].items() if v is not None}
        top = sorted(e, key=lambda k: -abs(e[k]))[:3]
        prec = "assumed" if r["precision"] is None else f"{r['precision']:.1e}"
        lines.append(f"  {name:<24} {prec:>8}  " + ", ".join(f"{k} {e[k]:+.3g}" for k in top))
    if rec["failed"]:
        lines.append("  a re-design did not converge (no elasticity): " + ", ".join(rec["failed"]))
    lines.append("  reach within the printed precision (first order): "
                 + ", ".join(f"{k} {reach(rec, k):.2e}" for k in rec["base"]))
    return "\n".join(lines)
