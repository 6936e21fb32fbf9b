"""Paper values as data: one JSON file per paper, one row per quantity.

File format::

    {"paper": "<key>", "title": "...", "citation": "...",
     "rows": [{"id": "...", "quantity": "...", "paper": 0.8, "unit": "m/s",
               "source": "Sec. III-E, Fig. 5",
               "tolerance": {"kind": "rel", "value": 0.05, "why": "..."},
               "departs_why": "one sentence pointing at the figure or row that shows it"}]}

``paper`` is the published number (or a short text where the paper states a claim rather than
a number); ``source`` is where it stands (section, table, figure or equation). The tolerance
kinds, for a simulated value v:

- ``rel``: |v - paper| <= value * |paper|
- ``abs``: |v - paper| <= value
- ``at_least`` / ``at_most``: v >= value / v <= value (claims such as "stable", "over 90 hops")
- ``range``: value[0] <= v <= value[1]
- ``equals``: v == value (a yes/no claim)
- ``report``: shown beside the paper, not judged (the paper gives the quantity only in a
  figure, or no number to compare with); ``why`` says so

Every row states why its tolerance is what it is (``tolerance.why``). ``departs_why`` is the
sentence shown when the simulation departs.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

KINDS = ("rel", "abs", "at_least", "at_most", "range", "equals", "report")
REQUIRED = ("id", "quantity", "paper", "source", "tolerance")


class ValuesError(ValueError):
    """A paper-values file that does not follow the format (one line naming file and row)."""


def _number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def check_tolerance(tol, where: str) -> None:
    if not isinstance(tol, dict) or tol.get("kind") not in KINDS:
        raise ValuesError(f"{where}: tolerance.kind must be one of {', '.join(KINDS)}")
    if not isinstance(tol.get("why"), str) or not tol["why"].strip():
        raise ValuesError(f"{where}: tolerance.why must say why the tolerance is what it is")
    v = tol.get("value")
    kind = tol["kind"]
    if kind == "range":
        ok = isinstance(v, list) and len(v) == 2 and all(_number(a) for a in v) and v[0] <= v[1]
    elif kind == "equals":
        ok = isinstance(v, (bool, int, float, str))
    elif kind == "report":
        ok = v is None
    else:
        ok = _number(v) and (v >= 0 or kind in ("at_least", "at_most"))
    if not ok:
        raise ValuesError(f"{where}: tolerance.value {v!r} does not fit kind {kind!r}")


def check(data: dict, label: str = "paper values") -> dict:
    """Raise ValuesError unless ``data`` follows the format; returns it."""
    if not isinstance(data, dict) or not isinstance(data.get("rows"), list) or not data["rows"]:
        raise ValuesError(f"{label}: expected an object with a non-empty 'rows' list")
    for key in ("paper", "title", "citation"):
        if not isinstance(data.get(key), str) or not data[key].strip():
            raise ValuesError(f"{label}: '{key}' must be a non-empty string")
    seen = set()
    for i, row in enumerate(data["rows"]):
        where = f"{label}: rows[{i}]"
        if not isinstance(row, dict):
            raise ValuesError(f"{where}: expected an object")
        for key in REQUIRED:
            if key not in row:
                raise ValuesError(f"{where}: missing '{key}'")
        where = f"{label}: row {row['id']!r}"
        for key in ("id", "quantity", "source"):
            if not isinstance(row[key], str) or not row[key].strip():
                raise ValuesError(f"{where}: '{key}' must be a non-empty string")
        if row["id"] in seen:
            raise ValuesError(f"{where}: id given twice")
        seen.add(row["id"])
        if not (_number(row["paper"]) or isinstance(row["paper"], (str, bool))):
            raise ValuesError(f"{where}: 'paper' must be a number, a yes/no or a short text")
        check_tolerance(row["tolerance"], where)
        if "departs_why" in row and not isinstance(row["departs_why"], str):
            raise ValuesError(f"{where}: 'departs_why' must be a sentence")
    return data


def load(path) -> dict:
    """Read and check one paper-values file."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeError, json.JSONDecodeError) as e:
        raise ValuesError(f"{path}: cannot read paper values: {e}") from None
    return check(data, str(path.name))


def agrees(value, tolerance: dict, paper=None):
    """True / False whether ``value`` agrees with the paper under ``tolerance``; None when the
    value is missing (not measured) or not a number where a number is needed."""
    if value is None:
        return None
    kind, t = tolerance["kind"], tolerance.get("value")
    if kind == "report":
        return None
    if kind == "equals":
        return bool(value == t)
    if isinstance(value, bool) or not _number(value):
        return None
    if kind == "at_least":
        return bool(value >= t)
    if kind == "at_most":
        return bool(value <= t)
    if kind == "range":
        return bool(t[0] <= value <= t[1])
    if not _number(paper):
        return None
    err = abs(value - paper)
    return bool(err <= (t * abs(paper) if kind == "rel" else t) * (1 + 1e-12))


def _g(v) -> str:
    return f"{v:g}" if _number(v) else str(v)


def tolerance_text(tolerance: dict, unit: str = "") -> str:
    """The tolerance in words, e.g. 'within 5 %', 'at least 90', 'in [0.5, 1]'."""
    kind, t = tolerance["kind"], tolerance.get("value")
    u = f" {unit}" if unit else ""
    if kind == "report":
        return "reported, not judged"
    if kind == "rel":
        return f"within {_g(100 * t)} %"
    if kind == "abs":
        return f"within ±{_g(t)}{u}"
    if kind == "at_least":
        return f"at least {_g(t)}{u}"
    if kind == "at_most":
        return f"at most {_g(t)}{u}"
    if kind == "range":
        return f"in [{_g(t[0])}, {_g(t[1])}]{u}"
    return f"equal to {str(t).lower() if isinstance(t, bool) else t}"
