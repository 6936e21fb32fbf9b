"""The payload of MABEL's gait files (kind ``mabel-compliant-hzd``), checked field by field.

:func:`check` runs on every file read, before anything is simulated; a problem raises
ValueError ``"<file>: payload.<field>: <problem>"``. Bounds are those of
:mod:`bipedlab.gait.schema` (angles 100 rad, motor-side included; rates 1000 rad/s;
feedforward torques 1000 N m), and:

* ``constraints``: the phase ends theta_plus < theta_mc < theta_sc < theta_si < theta_minus
  (rad; each Bézier is evaluated on the interval between two of them); the constants
  ``mls_sc``, ``mls_sd``; the Béziers ``mls_mc``, ``mls_si``, ``tor``, ``la_sw``, ``mls_sw``
  (ORDER + 1 coefficients each); ``corr`` (3 x 2);
* ``feedforward``: ``beta`` (4 phases x 4 actuators x ORDER + 1, N m), ``bounds`` (4 x 2, each
  phase's theta-interval, lower < upper), ``signs`` (4, each +1 or -1);
* ``z_minus``, ``z_plus``: 6 stance coordinates (rad) then 6 rates (rad/s);
* ``design``: ``period`` (s, within [:data:`MIN_PERIOD`, :data:`MAX_PERIOD`]) and ``speed``
  (m/s) required, ``step_length`` (m) optional, other figures free;
* optional: ``name``, ``cost`` and ``design_model`` (strings), ``speed`` (m/s), ``clearance`` (m, the
  design's swing-toe clearance at mid-step), ``x`` (the decision vector),
  ``poincare`` (null, or per controller an object whose ``max_abs_eigenvalue`` is a number).
"""
from __future__ import annotations

import math

from bipedlab.gait import schema as sc
from bipedlab.robots.mabel.walking import constraints as vcm

#: a step lasts at least one 1 ms sample of the loop, and at most 10 s
MIN_PERIOD = 1e-3
MAX_PERIOD = 10.0
#: walking speeds and step lengths of a planar biped stay far below these (m/s, m)
MAX_SPEED = 100.0
MAX_STEP = 10.0
#: stance coordinates (and rates) of the state
N_COORDS = 6
PHASE_ENDS = ("theta_plus", "theta_mc", "theta_sc", "theta_si", "theta_minus")
CONSTANTS = ("mls_sc", "mls_sd")
BEZIERS = ("mls_mc", "mls_si", "tor", "la_sw", "mls_sw")


def _state(d: dict, key: str, source: str, pre: str) -> None:
    z = sc.array(d, key, source, pre, (2 * N_COORDS,), bound=math.inf)
    sc.within(z[:N_COORDS], source, pre + key, sc.ANGLE, "rad")
    sc.within(z[N_COORDS:], source, pre + key, sc.RATE, "rad/s", offset=N_COORDS)


def _constraints(d: dict, source: str, pre: str) -> None:
    c = sc.section(d, "constraints", source, pre)
    p = pre + "constraints."
    ends = {k: sc.number(c, k, source, p) for k in PHASE_ENDS}
    for k in CONSTANTS:
        sc.number(c, k, source, p)
    for k in BEZIERS:
        sc.array(c, k, source, p, (vcm.ORDER + 1,))
    sc.array(c, "corr", source, p, (3, 2))
    sc.increasing(ends, source, p)


def _feedforward(d: dict, source: str, pre: str) -> None:
    ff = sc.section(d, "feedforward", source, pre)
    p = pre + "feedforward."
    sc.array(ff, "beta", source, p, (4, 4, vcm.ORDER + 1), sc.TORQUE, "N m")
    bounds = sc.array(ff, "bounds", source, p, (4, 2))
    for i, (a, b) in enumerate(bounds):
        if not a < b:
            sc.fail(source, f"{p}bounds[{i}]", f"[{a:g}, {b:g}] is not an interval (lower < upper)")
    signs = sc.array(ff, "signs", source, p, (4,), 1.0, "")
    for i, s in enumerate(signs):
        if abs(s) != 1.0:
            sc.fail(source, f"{p}signs[{i}]", f"{s:g}; expected +1 or -1")


def _design(d: dict, source: str, pre: str) -> None:
    des = sc.section(d, "design", source, pre)
    p = pre + "design."
    sc.number(des, "period", source, p, MAX_PERIOD, "s", low=MIN_PERIOD)
    sc.number(des, "speed", source, p, MAX_SPEED, "m/s")
    sc.optional_number(des, "step_length", source, p, MAX_STEP, "m")
    sc.record_arrays(des, source, p)


def _poincare(d: dict, source: str, pre: str) -> None:
    pc = sc.section(d, "poincare", source, pre, required=False)
    for key in pc or {}:
        entry = sc.section(pc, key, source, f"{pre}poincare.")
        sc.optional_number(entry, "max_abs_eigenvalue", source, f"{pre}poincare.{key}.")
        sc.record_arrays(entry, source, f"{pre}poincare.{key}.")


def check(d: dict, source: str, pre: str = "payload.") -> None:
    """ValueError naming the source and the field unless ``d`` (an opened payload; ``pre``
    names its fields) is a complete MABEL gait."""
    _constraints(d, source, pre)
    _feedforward(d, source, pre)
    for key in ("z_minus", "z_plus"):
        _state(d, key, source, pre)
    _design(d, source, pre)
    _poincare(d, source, pre)
    for key in ("name", "cost", "design_model"):
        sc.text(d, key, source, pre, required=False)
    sc.optional_number(d, "speed", source, pre, MAX_SPEED, "m/s")
    sc.optional_number(d, "clearance", source, pre, MAX_STEP, "m")
    if d.get("x") is not None:
        sc.array(d, "x", source, pre, (None,), sc.RATE, "")

