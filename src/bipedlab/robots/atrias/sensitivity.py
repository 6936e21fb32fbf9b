"""How the running study's judged quantities move with the robot's values: the elasticity
d ln(quantity) / d ln(value) of every row of the experiments in :data:`EXPERIMENTS` (the ones
whose rows depart from the paper), for every value of
:data:`~bipedlab.robots.atrias.catalog.SCALABLE`: the robot's masses, inertias and geometry, its
torque limit, its spring-mass model's stiffness and rest length, and the ground's values.

A value is scaled in the plant and the controller alike (a different robot, with the controller
and the swing policy made for it, as the paper's simulation knows its own robot); a model error of
Sec. IV-C stays the same relative error of the scaled value.

Each experiment runs as its row runs it (the same settings, terrain draws and seed) once as it is
and once per value scaled by 1 + ``step`` (backward differences at -10 % by default: a shorter
leg still reaches the 1.05 m apex). On rough terrain the statistics are those of a chaotic
process: a 1 % change re-draws each run's foothold sequence within a few steps, so the difference
is mostly sampling noise (measured on the rough terrain under energy conservation, 32 draws: the
trunk mass's elasticity of the bounce-height s.d. 8.0 +- 5.4 at 1 %, 1.0 +- 0.8 at 10 %). Each
elasticity of a batched experiment therefore carries its standard error, from a jackknife over
the terrain draws of the difference of the pooled statistic (the paired draws share their
terrain); the single flat-ground runs are deterministic and carry none. One compiled chunk per
scaled robot (the robot's values are constants of the chunk; the controller's are data)."""
from __future__ import annotations

import dataclasses
import time

import numpy as np

from bipedlab.report.spec import reach
from bipedlab.report.values import is_number
from bipedlab.robots.atrias import catalog

#: the experiments (of :mod:`bipedlab.robots.atrias.reproduce`) whose rows the sensitivity covers
EXPERIMENTS = ("flat", "rough", "rough-conservation", "slope", "delay", "mass+20pct", "mass-20pct",
               "stiffness+20pct", "stiffness-20pct")
STEP = -0.1
PRECISION_SOURCE = ("the printed digits of the ATRIAS parameter sheet and of Geyer & Herr 2010's ground; the paper "
                    "gives only about 60 kg and legs about 1 m")


def _settings(name: str, trials=None, distance=None):
    from bipedlab.robots.atrias import reproduce

    args = dict(next(e for e in reproduce.EXPERIMENTS if e.name == name).full_args)
    if trials is not None and args.get("trials") is not None:
        args["trials"] = int(trials)
    if distance is not None:
        args["distance"] = float(distance)
    return reproduce.study_settings(args)


#: a pooled statistic -> the key of a batched record that holds it (:func:`study.study`)
RECORD_KEYS = {"sd": "apex_height_sd_m", "height": "apex_height_error_mean_m", "speed": "speed_error_mean_mps"}


def _values(records: dict, settings: dict) -> dict:
    """The rows' numbers: of a single run (deterministic) every row reproduce's measure gives
    from it, rates left out; of a batched run the pooled statistics of :func:`row_statistics`
    (whose noise the jackknife measures), as its record holds them."""
    from bipedlab.report.spec import Measured
    from bipedlab.robots.atrias import reproduce

    out = {}
    for exp, rec in records.items():
        if settings[exp].trials is None:
            for k, v in reproduce.measure({exp: rec}, quick=False).items():
                v = v.value if isinstance(v, Measured) else v
                if is_number(v) and not k.endswith("_success"):
                    out[k] = float(v)
    for row, (exp, path, stat) in row_statistics().items():
        rec = records.get(exp)
        for k in path:
            rec = (rec or {}).get(k)
        v = (rec or {}).get(RECORD_KEYS[stat])
        if exp in records and settings[exp].trials is not None and is_number(v):
            out[row] = float(v)
    return out


def row_statistics() -> dict:
    """Row id -> (experiment, record path, statistic) of every row that is a pooled statistic
    of a batched experiment's apexes: "sd" (bounce height s.d.), "height" or "speed" (mean
    error)."""
    from bipedlab.robots.atrias import reproduce

    stats = {"apex_sd_m": "sd", "apex_error_m": "height", "speed_error_mps": "speed"}
    prefixes = dict(reproduce.BATCHED_PREFIXES)
    prefixes.update({reproduce.error_name(n, r): reproduce.error_name(n, r) for n, r in reproduce.ERRORS})
    out = {f"{prefix}_{q}": (name, (), s) for name, prefix in prefixes.items() for q, s in stats.items()}
    out["rough_slip_apex_sd_m"] = ("rough", ("slip_model",), "sd")
    return out


def pooled(per_trial: dict, statistic: str, keep) -> float | None:
    """A pooled statistic over the apexes of the trials ``keep`` (indices) from their counts,
    means and s.d.s (:func:`bipedlab.robots.atrias.study.per_trial`): the mean bounce-height or
    speed error, or the bounce height's s.d. (as np.std over all their apexes)."""
    rows = [i for i in keep if per_trial["apexes"][i]]
    if not rows:
        return None
    n = np.array([per_trial["apexes"][i] for i in rows], float)
    key = "speed_error_mean_mps" if statistic == "speed" else "apex_height_error_mean_m"
    m = np.array([per_trial[key][i] for i in rows], float)
    mean = float(n @ m / n.sum())
    if statistic != "sd":
        return mean
    sd = np.array([per_trial["apex_height_sd_m"][i] for i in rows], float)
    return float(np.sqrt(n @ (sd ** 2 + (m - mean) ** 2) / n.sum()))


def jackknife_se(base: dict, scaled: dict, statistic: str) -> float | None:
    """The jackknife standard error, over the terrain draws, of the difference scaled - base of
    a pooled statistic (the two runs share their draws)."""
    n = len(base["apexes"])
    if n < 2:
        return None
    d = []
    for i in range(n):
        keep = [j for j in range(n) if j != i]
        a, b = pooled(scaled, statistic, keep), pooled(base, statistic, keep)
        if a is None or b is None:
            return None
        d.append(a - b)
    d = np.asarray(d)
    return float(np.sqrt((n - 1) / n * np.sum((d - d.mean()) ** 2)))


def _per_trial(rec, path):
    for k in path:
        rec = (rec or {}).get(k)
    return (rec or {}).get("per_trial")


def sensitivity(step: float = STEP, trials=None, distance=None, parameters=None, experiments=EXPERIMENTS,
                progress=None) -> dict:
    """The elasticities of the rows of ``experiments`` to each value of ``parameters`` (default
    all of :data:`~bipedlab.robots.atrias.catalog.SCALABLE`), JSON-ready: ``base`` {row: value},
    ``parameters`` {name: what, precision (relative, None for a chosen value), source, elasticity
    {row: value or None}, standard_error {row: value or None}, scaled {row: value}}.
    ``trials`` and ``distance`` shorten the batched runs (default: the rows' own)."""
    from bipedlab.robots.atrias import study

    say = progress or (lambda m: None)
    t0 = time.perf_counter()
    names = list(parameters or catalog.SCALABLE)
    bad = sorted(set(names) - set(catalog.SCALABLE))
    if bad:
        raise ValueError(f"sensitivity: unknown value {bad[0]!r}; choose from {', '.join(catalog.SCALABLE)}")
    settings = {e: _settings(e, trials, distance) for e in experiments}

    def records(scale):
        return {e: study.study(dataclasses.replace(st, scale=scale)) for e, st in settings.items()}

    say(f"running sensitivity: {len(experiments)} experiments x {len(names) + 1} robots, each value x (1 {step:+g})")
    base_rec = records(())
    base = _values(base_rec, settings)
    stats = row_statistics()
    rows = {}
    for i, name in enumerate(names):
        say(f"running sensitivity: {name} ({i + 1} of {len(names)})")
        rec = records(((name, 1.0 + step),))
        scaled = _values(rec, settings)
        e, se = {}, {}
        for row, v in base.items():
            s = scaled.get(row)
            e[row] = (s - v) / (step * v) if s is not None and v != 0 else None
            se[row] = None
            if row in stats and e[row] is not None:
                exp, path, stat = stats[row]
                pb, ps = _per_trial(base_rec.get(exp), path), _per_trial(rec.get(exp), path)
                d = jackknife_se(pb, ps, stat) if pb and ps else None
                se[row] = None if d is None else d / abs(step * v)
        what, precision, source = catalog.SCALABLE[name]
        rows[name] = dict(what=what, precision=precision, source=source, elasticity=e, standard_error=se,
                          scaled=scaled)
    return dict(step=step, experiments=list(experiments), trials=trials, distance_m=distance,
                method=(f"each value {abs(step):.0%} {'smaller' if step < 0 else 'larger'} in plant and controller alike, "
                        "the runs repeated on the rows' own terrain draws, jackknife standard errors over the draws"),
                precision_source=PRECISION_SOURCE, base=base, parameters=rows, runs=len(experiments) * (1 + len(names)),
                wall_time_s=time.perf_counter() - t0)


def summary(rec: dict) -> str:
    """The elasticities (with their standard errors) by row and value, and each row's reach."""
    lines = [f"running sensitivity ({rec['method']}; {rec['runs']} runs, {rec['wall_time_s']:.0f} s)"]
    for row, v in rec["base"].items():
        lines.append(f"  {row} = {v:.4g}: reach within the stated precisions {reach(rec, row):.2%} (first order)")
        for name, r in rec["parameters"].items():
            e, se = r["elasticity"].get(row), r["standard_error"].get(row)
            if e is None:
                continue
            prec = "chosen" if r["precision"] is None else f"{r['precision']:.2%}"
            lines.append(f"    {name:<9} {e:+8.3f}" + (f" +- {se:.3f}" if se is not None else "          ")
                         + f"   {prec}")
    return "\n".join(lines)
