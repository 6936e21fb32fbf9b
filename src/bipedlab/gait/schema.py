"""Reading and checking gait files field by field, before anything is simulated.

Every problem raises ValueError with one line ``"<file>: <field>: <problem>"``, the field
written as a dotted path (``payload.feedforward.beta``). :func:`read_json` reads a file
(unreadable, a directory or another file that is not a regular one, left unopened, larger than :data:`MAX_BYTES`, not UTF-8, nested deeper than
:data:`MAX_DEPTH`, not JSON: each named); :func:`section`, :func:`array`, :func:`number`,
:func:`text` and :func:`optional_number` check one field of a JSON object; :func:`expect_robot`
refuses the gait of another robot, naming both.

Numbers must be JSON numbers (not strings, not true/false), finite, and within a bound
chosen from what a planar biped can do, so that a finite but absurd value is rejected here
rather than reported later as a fall:

* :data:`ANGLE` = 100 rad for angles and angle-valued coefficients (Bézier coefficients of
  joint or motor-side angles, phase limits, configurations): joint angles stay within a few
  radians, and motor-side angles of a geared joint (ratios up to about 30) within a few tens;
* :data:`RATE` = 1000 rad/s for angular rates (motor-side rates of a fast gait stay near
  150 rad/s);
* :data:`TORQUE` = 1000 N m for torque-valued coefficients (feedforward regressions; the
  motors of a planar biped saturate at tens of N m);
* :data:`COEFFICIENT` = 100 for dimensionless combination coefficients (output matrices and
  phase-variable gradients, entries of order one).
"""
from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np

from bipedlab.inputs import TextError, decode_text, special_kind

#: largest gait file read (bytes); gait files are a few kB
MAX_BYTES = 16 * 2**20
#: deepest nesting of arrays and objects (a gait file nests about 6 levels)
MAX_DEPTH = 32
#: bounds of angle-, rate-, torque-valued and dimensionless numbers (see the module docstring)
ANGLE = 100.0
RATE = 1.0e3
TORQUE = 1.0e3
COEFFICIENT = 100.0

_STRING = re.compile(r'"(?:[^"\\]|\\.)*"', re.S)
_MISSING = object()


def fail(source: str, field: str, problem: str):
    """Raise the one-line ValueError of a gait file's field."""
    raise ValueError(f"{source}: {field}: {problem}" if field else f"{source}: {problem}")


def nesting_depth(text: str) -> int:
    """Deepest nesting of ``[`` and ``{`` in JSON text (string contents ignored)."""
    b = np.frombuffer(_STRING.sub('""', text).encode("utf-8", "replace"), np.uint8)
    step = np.isin(b, (ord("["), ord("{"))).astype(np.int64) - np.isin(b, (ord("]"), ord("}")))
    return int(np.max(np.cumsum(step), initial=0))


def parse(text: str, source: str):
    """The JSON value of a text; ValueError naming ``source`` if it is not JSON or nests too deep."""
    depth = nesting_depth(text)
    if depth > MAX_DEPTH:
        fail(source, "", f"nested {depth} levels deep (a gait file nests at most {MAX_DEPTH})")
    try:
        return json.loads(text)
    except json.JSONDecodeError as e:
        fail(source, "", f"not valid JSON ({e.msg} at line {e.lineno})")
    except (ValueError, RecursionError) as e:  # integers of thousands of digits, pathological nesting
        fail(source, "", f"not valid JSON ({str(e).split(';')[0]})")


def read_json(path, unreadable: str = "cannot read"):
    """The JSON value in a file; ValueError naming the path and the problem."""
    p = Path(path)
    if "\0" in str(path):
        fail(str(path).replace("\0", "\\0"), "", f"{unreadable} (a NUL character in the name)")
    kind = special_kind(p)  # a FIFO or a device would block or never end: refused unopened
    if kind is not None:
        fail(str(path), "", f"{unreadable} ({kind}, not a file)")
    try:
        size = p.stat().st_size
        if size > MAX_BYTES:
            fail(str(path), "", f"{unreadable} ({size} bytes; a gait file has at most {MAX_BYTES})")
        raw = p.read_bytes()
    except OSError as e:
        fail(str(path), "", f"{unreadable} ({e.strerror or e.__class__.__name__})")
    try:  # UTF-8, or UTF-8 / UTF-16 / UTF-32 after the byte-order mark that names it
        text = decode_text(raw)
    except TextError as e:
        fail(str(path), "", str(e).removeprefix("is "))
    return parse(text, str(path))


# ----- what a JSON value is, in words -------------------------------------------------------
def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def shape_of(v):
    """The shape of a rectangular nested list of JSON numbers (() for a number), else None."""
    if _is_number(v):
        return ()
    if not isinstance(v, list):
        return None
    if not v:
        return (0,)
    inner = {shape_of(x) for x in v}
    if len(inner) != 1 or None in inner:
        return None
    return (len(v),) + inner.pop()


def describe(v) -> str:
    """What a JSON value is, for messages ("a string", "a 4 x 5 array", ...)."""
    if v is _MISSING:
        return "nothing"
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "true/false"
    if _is_number(v):
        return "a number"
    if isinstance(v, str):
        return "a string"
    if isinstance(v, dict):
        return "an object"
    s = shape_of(v)
    if s is None:
        return "an array of mixed or ragged entries"
    if s == (0,):
        return "an empty array"
    if len(s) == 1:
        return f"an array of {s[0]} numbers"
    return f"a {' x '.join(map(str, s))} array"


def _shape_words(shape) -> str:
    if len(shape) == 1:
        return f"an array of {'N' if shape[0] is None else shape[0]}"
    return "a " + " x ".join("N" if k is None else str(k) for k in shape) + " array of"


def _first_bad(v, at: str = ""):
    """(index, problem) of the first entry that keeps a nested list from being a rectangular
    array of numbers; every non-rectangular list gets one (rows of equal length whose entries
    differ in depth or in shape further in, e.g. ``[[[], []], [1, 2]]``, included)."""
    if not isinstance(v, list):
        return at, f"expected a number, got {describe(v)}"
    lists = [isinstance(x, list) for x in v]
    if any(lists) and not all(lists):  # mixed depths: point at the entry unlike most
        if 2 * sum(lists) >= len(v):
            k = lists.index(False)
            return f"{at}[{k}]", f"expected an array like its neighbours, got {describe(v[k])}"
        k = lists.index(True)
        return f"{at}[{k}]", f"expected a number like its neighbours, got {describe(v[k])}"
    shapes = [shape_of(x) for x in v]
    for k, s in enumerate(shapes):
        if s is None:
            return _first_bad(v[k], f"{at}[{k}]")
    # the entry that differs from the shape most entries share (the first entry's on a tie)
    common = max(shapes, key=lambda s: (shapes.count(s), -shapes.index(s)))
    j = shapes.index(common)
    k = next((i for i, s in enumerate(shapes) if s != common), None)
    if k is None:  # rectangular after all: nothing in it to point at
        return at, f"expected an array of numbers, got {describe(v)}"
    if len(v[k]) != len(v[j]):
        return f"{at}[{k}]", f"has {len(v[k])} entries where {at}[{j}] has {len(v[j])} (ragged)"
    return f"{at}[{k}]", f"is {describe(v[k])} where {at}[{j}] is {describe(v[j])} (ragged)"


def _fmt(x) -> str:
    return f"{x:g}" if isinstance(x, float) else str(x)


# ----- field checks -------------------------------------------------------------------------
def get(d: dict, key: str, source: str, field: str, required: bool = True):
    """``d[key]``; ValueError naming the field when it is required and absent."""
    if key in d:
        return d[key]
    if required:
        fail(source, field, "missing")
    return _MISSING


def expect_robot(d, source: str, robot: str) -> None:
    """ValueError naming both robots when a gait file's JSON value says it is another robot's
    (its top-level ``robot`` a different string). A file that names no robot, or not as a
    string, passes: its envelope's own checks say what is wrong with it."""
    got = d.get("robot") if isinstance(d, dict) else None
    if isinstance(got, str) and got != robot:
        fail(source, "robot", f"a gait of the robot {got!r}, not of {robot!r} (the robot this command drives)")


def section(d: dict, key: str, source: str, prefix: str = "", required: bool = True) -> dict | None:
    """A nested JSON object ``d[key]`` (None when optional and absent or null)."""
    field = prefix + key
    v = get(d, key, source, field, required)
    if v is _MISSING or (v is None and not required):
        return None
    if not isinstance(v, dict):
        fail(source, field, f"expected an object, got {describe(v)}")
    return v


def text(d: dict, key: str, source: str, prefix: str = "", required: bool = True) -> str | None:
    field = prefix + key
    v = get(d, key, source, field, required)
    if v is _MISSING:
        return None
    if not isinstance(v, str):
        fail(source, field, f"expected a string, got {describe(v)}")
    return v


def _index(shape, flat: int) -> str:
    return "".join(f"[{i}]" for i in np.unravel_index(flat, shape)) if shape else ""


def _values(v, source: str, field: str, want: str) -> np.ndarray:
    try:
        a = np.array(v, dtype=float)
    except OverflowError:
        fail(source, field, f"expected {want}, got an integer too large for a float")
    bad = ~np.isfinite(a)
    if bad.any():
        k = int(np.flatnonzero(bad.ravel())[0])
        fail(source, field + _index(a.shape, k), f"expected a finite number, got {a.ravel()[k]}")
    return a


def within(a: np.ndarray, source: str, field: str, bound: float, unit: str, offset: int = 0) -> None:
    """ValueError naming the first entry of ``a`` beyond +-bound (``a`` is the field's entries
    from ``offset`` on, indexed alike)."""
    out = np.abs(a) > bound
    if out.any():
        k = int(np.flatnonzero(out.ravel())[0])
        at = f"[{k + offset}]" if offset else _index(a.shape, k)
        fail(source, field + at,
             f"{a.ravel()[k]:g} is outside +-{bound:g}{' ' + unit if unit else ''}")


def array(d: dict, key: str, source: str, prefix: str = "", shape=(None,), bound: float = ANGLE,
          unit: str = "rad", required: bool = True) -> np.ndarray | None:
    """``d[key]`` as a float array of the given shape (an int fixes a size, None leaves it free
    but at least 1), every entry a finite JSON number within +-bound."""
    field = prefix + key
    v = get(d, key, source, field, required)
    if v is _MISSING:
        return None
    want = f"{_shape_words(shape)} finite numbers"
    s = shape_of(v)
    if s is None and isinstance(v, list):
        at, problem = _first_bad(v)
        fail(source, field + at, problem)
    if s is None or len(s) != len(shape) or any(k == 0 or (w is not None and k != w) for k, w in zip(s, shape)):
        fail(source, field, f"expected {want}, got {describe(v)}")
    a = _values(v, source, field, want)
    within(a, source, field, bound, unit)
    return a


def number(d: dict, key: str, source: str, prefix: str = "", bound: float = ANGLE, unit: str = "rad",
           low: float = -math.inf, high: float = math.inf, required: bool = True) -> float | None:
    """``d[key]``: a finite JSON number within +-bound and within [low, high]."""
    field = prefix + key
    v = get(d, key, source, field, required)
    if v is _MISSING:
        return None
    if not _is_number(v):
        fail(source, field, f"expected a number, got {describe(v)}")
    x = float(_values(v, source, field, "a finite number"))
    within(np.asarray(x), source, field, bound, unit)
    if not low <= x <= high:
        fail(source, field, f"{x:g} is outside [{_fmt(low)}, {_fmt(high)}]{' ' + unit if unit else ''}")
    return x


def optional_number(d: dict, key: str, source: str, prefix: str = "", bound: float = math.inf,
                    unit: str = "") -> float | None:
    """``d[key]`` when present and not null: a finite number within +-bound."""
    if d.get(key) is None:
        return None
    return number(d, key, source, prefix, bound, unit)


def optional_array(d: dict, key: str, source: str, prefix: str = "", shape=(None,), bound: float = math.inf,
                   unit: str = "") -> np.ndarray | None:
    """``d[key]`` when present and not null: an array as :func:`array` checks it."""
    if d.get(key) is None:
        return None
    return array(d, key, source, prefix, shape, bound, unit)


#: the design record's arrays a gait file carries beside its constraints (read back into walk
#: records, figures and the report): each checked as an array of its shape when present
RECORD_ARRAYS = {
    "peak_torques_nm": ((None,), TORQUE, "N m"),
    "peak_torques": ((None,), TORQUE, "N m"),
    "poincare_eigenvalues": ((None,), math.inf, ""),
    "poincare_eigenvalues_complex": ((None, 2), math.inf, ""),
}


def record_arrays(d: dict, source: str, prefix: str = "") -> None:
    """ValueError naming the field unless every array of :data:`RECORD_ARRAYS` present in the
    record ``d`` is a finite array of its shape."""
    for key, (shape, bound, unit) in RECORD_ARRAYS.items():
        optional_array(d, key, source, prefix, shape, bound, unit)
    limits = d.get("torque_limits_nm")  # per actuator: N m, or null where the file sets no limit
    if limits is not None:
        if not isinstance(limits, list):
            fail(source, prefix + "torque_limits_nm", f"expected a list, got {type(limits).__name__}")
        for i, v in enumerate(limits):
            if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float))
                                  or not 0.0 < v <= TORQUE):
                fail(source, f"{prefix}torque_limits_nm[{i}]",
                     f"expected null (no limit) or a torque in (0, {TORQUE:g}] N m, got {v!r}")


def increasing(values: dict, source: str, prefix: str = "") -> None:
    """ValueError unless the named numbers, in the order given, strictly increase."""
    names = list(values)
    for a, b in zip(names, names[1:]):
        if not values[a] < values[b]:
            fail(source, prefix + b, f"{values[b]:g} must exceed {a} ({values[a]:g}): "
                                     f"the phase must grow through {', '.join(names)}")
