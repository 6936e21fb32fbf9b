"""How Table II's walk on the boom setup moves with the robot's parameters: the elasticity
d ln(quantity) / d ln(parameter) of its speed, step length, step frequency and c_mt, by forward
differences of whole walks, for

* every value of Table I the dynamics use (links' lengths, COM distances, masses and inertias;
  the foot's geometry; the actuators' masses, reflected inertias and damping), scaled in the
  plant only: the controller keeps Table I, as the hardware's eq. 7 did. Each value's precision
  is the table's printed digits (half a unit of the last one; :func:`~bipedlab.robots.seven_link.robot.printed_precision`);
* the boom setup's assumed values (:mod:`bipedlab.robots.seven_link.setup`: the arm's mass, the
  foot-turning friction coefficient, the drive Coulomb friction read from Fig. 6, the knee lock
  torque), which the paper does not give: no precision.

Left out: the body's length (it places the head, a drawing point), the foot's length (its a and b
place the toe and heel) and the gear ratios (a design choice, printed as integers).

The walks are events (touchdowns, knee locks, contact switches), so the derivatives are finite
differences of whole walks: forward differences, each parameter scaled by 1 + ``step`` in a walk
of its own (32 walks of 30 steps, about 25 s each on a two-core CPU; a vmapped batch of the 63
walks of central differences, tried, had not finished after 17 min on a two-core CPU shared
with a reproduction); a parameter whose scaled walk falls has no elasticity (named in
``fell``). One compiled program serves every walk: every scaled value is data of it."""
from __future__ import annotations

import time

import jax

from bipedlab.report.spec import reach
from bipedlab.robots.seven_link import robot as sl
from bipedlab.robots.seven_link import setup as su
from bipedlab.robots.seven_link import study

#: the walk's quantities whose elasticities are measured (keys of :func:`study.gait_metrics`)
QUANTITIES = ("speed_mps", "step_length_m", "step_frequency_hz", "cmt")
#: Table I's values left out (see the module's text)
LEFT_OUT = (("body", "length"), ("foot", "length"))
#: the boom setup's assumed values: name -> (the option of :func:`study.run_walk` or of
#: :func:`bipedlab.robots.seven_link.setup.boom` it scales, its value)
SETUP = {"boom arm mass": ("arm_mass", su.BOOM_ARM_MASS), "foot-turning friction coefficient": ("mu", su.FRICTION_COEFFICIENT),
         "drive Coulomb friction (Fig. 6 reading)": ("friction_scale", 1.0),
         "knee lock torque": ("knee_lock_torque", su.KNEE_LOCK_TORQUE)}
PRECISION_SOURCE = "Table I's printed digits (half a unit of the last one); the boom setup's values are assumed"


def table_parameters() -> list:
    """(part, key) of every Table I value the sensitivity scales."""
    return [(part, k) for part, d in sl.TABLE_I.items() for k in d if k != "n" and (part, k) not in LEFT_OUT]


def _gait(steps: int, params: str, scale=None, boom_options=None, knee_lock_torque=su.KNEE_LOCK_TORQUE) -> dict:
    res = jax.device_get(study.run_walk(steps, params, setup="boom", scale=scale, boom_options=boom_options,
                                        knee_lock_torque=knee_lock_torque))
    weight = float(sl.total_mass(sl.model(scale=scale))) * sl.GRAVITY
    out = study.gait_metrics(res, weight)
    out["fell"] = study.walk_fell(res, steps)
    return out


def _elasticity(scaled: dict, base: dict, step: float) -> dict:
    e = {}
    for q in QUANTITIES:
        a, c = scaled.get(q), base.get(q)
        ok = None not in (a, c) and c != 0 and not (scaled["fell"] or base["fell"])
        e[q] = float((a - c) / (step * c)) if ok else None
    return e


def sensitivity(steps: int = 30, params: str = "paper", step: float = 0.01, progress=None) -> dict:
    """The elasticities of Table II's boom walk (``steps`` steps) to each parameter (JSON-ready):
    ``base`` (the unscaled walk's figures), ``parameters`` {name: value, precision (relative, or
    None for an assumed value), source, elasticity {quantity: value or None}, scaled (the scaled
    walk's figures)}, ``fell`` (the parameters whose scaled walk fell)."""
    say = progress or (lambda m: None)
    t0 = time.perf_counter()
    table = table_parameters()
    n = len(table) + len(SETUP)
    say(f"seven-link sensitivity: {n + 1} walks of {steps} steps, each parameter x (1 + {step:g})")
    base = _gait(steps, params)
    rows = {}
    for i, (part, key) in enumerate(table):
        name = f"{part}.{key}"
        say(f"seven-link sensitivity: {name} ({i + 1} of {n})")
        scaled = _gait(steps, params, scale={(part, key): 1.0 + step})
        rows[name] = dict(value=float(sl.TABLE_I[part][key]), printed=sl.TABLE_I[part][key],
                          precision=sl.printed_precision(part, key), source="Table I",
                          elasticity=_elasticity(scaled, base, step), scaled=scaled)
    for i, (name, (option, value)) in enumerate(SETUP.items()):
        say(f"seven-link sensitivity: {name} ({len(table) + i + 1} of {n})")
        v = value * (1.0 + step)
        scaled = (_gait(steps, params, knee_lock_torque=v) if option == "knee_lock_torque"
                  else _gait(steps, params, boom_options={option: v}))
        rows[name] = dict(value=float(value), printed=None, precision=None, source="assumed (the paper gives none)",
                          elasticity=_elasticity(scaled, base, step), scaled=scaled)
    fell = [k for k, r in rows.items() if r["scaled"]["fell"]]
    return dict(steps=steps, params=params, setup="boom", step=step, method=(
        f"forward differences of whole {steps}-step walks, each parameter x (1 + {step:g}) in the plant alone"),
                precision_source=PRECISION_SOURCE, quantities=list(QUANTITIES), base=base, parameters=rows,
                fell=fell, walks=1 + len(rows), wall_time_s=time.perf_counter() - t0)


def summary(rec: dict) -> str:
    """The elasticities as a table, the parameters whose scaled walk fell, and each quantity's
    reach within Table I's printed precision."""
    def f(v):
        return "    -" if v is None else f"{v:+6.2f}"

    b = rec["base"]
    lines = [f"seven-link sensitivity of Table II's boom walk ({rec['method']}; {rec['walks']} walks, "
             f"{rec['wall_time_s']:.0f} s)",
             f"  base: {b['speed_mps']:.3f} m/s, {b['step_length_m']:.3f} m steps, {b['step_frequency_hz']:.3f} Hz, "
             f"c_mt {b['cmt']:.3f}" if b.get("speed_mps") is not None else "  base: no gait window",
             "  d ln(quantity) / d ln(parameter)   speed  length    freq    c_mt   precision"]
    for name, r in rec["parameters"].items():
        e = r["elasticity"]
        prec = "assumed" if r["precision"] is None else f"{r['precision']:.2%}"
        lines.append(f"  {name:<38}" + "".join(f"{f(e[q])}  " for q in QUANTITIES) + prec)
    if rec["fell"]:
        lines.append("  a scaled walk fell (no elasticity): " + ", ".join(rec["fell"]))
    lines.append("  reach within Table I's printed precision (first order): "
                 + ", ".join(f"{q} {reach(rec, q):.2%}" for q in QUANTITIES))
    return "\n".join(lines)
