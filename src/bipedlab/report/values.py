"""Paper values as data: one JSON file per paper, one row per quantity.

File format::

    {"paper": "<key>", "title": "...", "citation": "...",
     "rows": [{"id": "...", "quantity": "...", "paper": 0.575, "unit": "m",
               "source": "Sec. III-E, Fig. 5 caption",
               "tolerance": {"kind": "abs", "value": 0.0005, "derivation": "precision",
                             "why": "printed to the millimetre"},
               "sign": "+",
               "departs_why": "this model's optimum takes {value:.3f} m steps; see Fig. 5's counterpart"}]}

``paper`` is the published number (or a short text where the paper states a claim rather than
a number); ``source`` is where it stands (section, table, figure or equation). The tolerance
kinds, for a simulated value v:

- ``rel``: |v - paper| <= value * |paper|, value at most 1
- ``abs``: |v - paper| <= value, value at most |paper|
- ``factor``: v has the paper's sign and max(v / paper, paper / v) <= value, 1 < value <= 2
  (a sign and a size: the band never reaches farther from the paper than its own magnitude)
- ``at_least`` / ``at_most``: v >= value / v <= value (claims such as "stable", "over 90 hops")
- ``range``: value[0] <= v <= value[1]
- ``equals``: v == value (a yes/no claim)
- ``report``: shown beside the paper, not judged (the paper gives the quantity only in a
  figure, or no number to compare with); ``why`` says so

No ``rel``, ``abs`` or ``factor`` band is wider than the paper's number itself: a tolerance that
would be is not a tolerance on the number but on its sign, and says so (``sign`` with a band
of at most |paper|).

``tolerance.derivation`` says how the tolerance follows from what the paper's number can mean
(every kind but ``report``): ``precision`` (the printed digits: half a unit of the last one, or
what the printed numbers it is computed from allow), ``spread`` (the spread of repeated
measurements: a standard deviation, the standard error of a mean or of a s.d.), ``size`` (a
sign and a size, kind ``factor``, for a number the paper gives as a size or a rough count),
``claim`` (an explicit test of a stated claim: a bound, a range or a yes/no) or ``own_target``
(a self-check: the target the method sets itself). ``tolerance.why`` gives the arithmetic.

``survival_only`` (true), on a claim row (derivation ``claim``) whose test is only that the
robot did not fall (or that a share of runs did not): the row says so beside its verdict and
the counts line counts such claims apart, since surviving is not the property the paper
states (a gait "stabilised", "very little effect").

``sign`` ("+" or "-"), where the paper states a direction: the value must have that sign to
agree, and no band may reach across zero. ``self_check``, a sentence, marks a row where the
method checks itself (against its own targets on a synthetic robot, a constraint it imposes, or
a parameter chosen by its closeness to the paper's number: a fit): its verdict is shown as a
self-check and never counts as agreement with the paper.

``gait`` names the gait (or gaits, comma-separated) the row's experiment walked or designed,
for papers whose experiments walk designed gaits; the report shows it beside the quantity and
the paper's gait table gives each gait's designed figures.

``departs_why`` is the sentence shown when the simulation departs, ``tolerance.why`` the one
shown when it agrees. Either may cite numbers of the run as ``{name}`` or ``{name:fmt}`` (a
format spec, e.g. ``{value:+.3f}``), with an optional scale ``{name*100:.1f}`` (metres as
centimetres): ``value`` (the row's simulated value), ``paper``, the facts the paper's measure
gives for the row, or a path into an experiment's record, ``experiment.key.key``. A name the
run does not hold is an error (:class:`TemplateError`); ``{{`` and ``}}`` are literal braces.
"""
from __future__ import annotations

import json
import math
import re
from pathlib import Path

from bipedlab.inputs import TextError, decode_text

KINDS = ("rel", "abs", "factor", "at_least", "at_most", "range", "equals", "report")
DERIVATIONS = ("precision", "spread", "size", "claim", "own_target")
#: the kinds each derivation may use
DERIVATION_KINDS = {"precision": ("rel", "abs", "range", "at_least", "at_most"),
                    "spread": ("rel", "abs", "range", "at_least", "at_most"),
                    "size": ("factor",),
                    "claim": ("at_least", "at_most", "range", "equals"),
                    "own_target": ("rel", "abs", "at_least", "at_most", "range", "equals")}
SIGNS = {"+": 1, "-": -1}
REQUIRED = ("id", "quantity", "paper", "source", "tolerance")
#: the verdict classes: a number within the paper's printed precision *matches*; within a band
#: derived from a spread or a size it *agrees*; outside either it *departs*; a stated claim
#: (a bound, a range or a yes/no, derivation ``claim``) *holds* or *fails*; a self-check is met
#: or not; a parameter the run's data cannot determine (its 1-sigma error from the data past the
#: study's bar) is not identifiable; a row the run did not measure, or that the paper gives no
#: number for, is not judged. Numeric agreement, claims and self-checks are counted apart.
VERDICTS = ("matches", "agrees", "departs", "claim holds", "claim fails", "self-check met", "self-check not met",
            "not identifiable", "not judged")
#: the counts of a paper's rows (:func:`bipedlab.report.build.counts`), in the counts line's order
COUNT_KEYS = ("rows", "matches", "agrees", "departs", "departs_within_uncertainty", "departs_implementation",
              "claims_hold", "claims_hold_survival_only", "claims_fail", "self_checks", "self_checks_not_met",
              "not_identifiable", "not_judged")


class ValuesError(ValueError):
    """A paper-values file that does not follow the format (one line naming file and row)."""


class TemplateError(ValuesError):
    """A why / departs_why text that names a number the run does not hold."""


def is_number(x) -> bool:
    """A finite real number (not a bool)."""
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


#: the two kinds of numeric departure (:func:`closing`)
WITHIN_UNCERTAINTY, IMPLEMENTATION = "within model uncertainty", "implementation or setup"


def _counted(sensitivity) -> tuple[dict, list]:
    """({parameter: elasticity} counted, [parameters within two standard errors of zero])."""
    e = {k: float(x) for k, x in sensitivity.elasticity.items() if is_number(x)}
    se = {k: float(x) for k, x in (sensitivity.standard_error or {}).items() if is_number(x)}
    noise = sorted(k for k, x in e.items() if se.get(k, 0.0) > 0 and abs(x) <= 2.0 * se[k])
    return {k: x for k, x in e.items() if k not in noise}, noise


def reach_of(sensitivity) -> float:
    """The largest relative change of a value, to first order, with every parameter whose
    precision is stated within it: sum of precision |elasticity| over the counted elasticities
    (:func:`closing`'s ``reach``)."""
    e, _ = _counted(sensitivity)
    return float(sum(abs(x) * sensitivity.precision[k] for k, x in e.items()
                     if sensitivity.precision.get(k) is not None))


def closing(value, paper, sensitivity) -> dict | None:
    """What would close a numeric departure, to first order in the robot's parameters, from the
    value's :class:`~bipedlab.report.spec.Sensitivity` (its elasticities e_k = d ln v / d ln p_k):

    - ``needed``: the relative change of the value that reaches the paper's number, paper / v - 1;
    - ``smallest``: the parameter whose change alone would make it with the smallest relative
      change, needed / e_k (and ``smallest_stated``: the same among the parameters whose precision
      the paper states);
    - ``reach``: the largest relative change of the value with every stated parameter within its
      stated precision s_k, sum of s_k |e_k|;
    - ``kind``: *within model uncertainty* when |needed| <= reach, else *implementation or setup*
      (a first-order test: it sorts departures, it widens no band);
    - ``within_noise``: the parameters whose elasticity lies within two of its standard errors of
      zero (a noisy statistic's), counted nowhere above.

    None when the value or the paper's number is not a nonzero number."""
    if not (is_number(value) and is_number(paper)) or value == 0:
        return None
    needed = paper / value - 1.0
    e, noise = _counted(sensitivity)
    singles = {k: needed / x for k, x in e.items() if x != 0}
    stated = {k: x for k, x in singles.items() if sensitivity.precision.get(k) is not None}
    reach = reach_of(sensitivity)

    def best(d):
        if not d:
            return None
        k = min(d, key=lambda k: abs(d[k]))
        return dict(parameter=k, relative_change=d[k], elasticity=e[k], precision=sensitivity.precision.get(k))

    return dict(needed=needed, reach=reach, kind=WITHIN_UNCERTAINTY if abs(needed) <= reach else IMPLEMENTATION,
                smallest=best(singles), smallest_stated=best(stated), parameters=len(e), within_noise=noise,
                source=sensitivity.source, method=sensitivity.method)


def closing_target(paper, tolerance: dict, value):
    """The number a departing row's closing aims at (:func:`closing`'s ``paper``): the paper's
    number where it prints one; where it gives text with a band (a range, e.g. a ratio of two
    printed numbers), the band's bound nearer the value (the smallest change that makes it
    agree); else None (nothing to close to)."""
    if is_number(paper):
        return paper
    if tolerance.get("kind") == "range" and is_number(value):
        lo, hi = tolerance["value"]
        return lo if value < lo else hi if value > hi else None
    return None


def closing_text(c: dict) -> str:
    """One sentence of :func:`closing`'s outcome, for a departing row's text."""
    def one(b):
        return f"{b['parameter']} by {b['relative_change']:+.1%}"

    text = (f"Closing it ({c['method']}): the value must change by {c['needed']:+.1%}; the parameters the "
            f"paper states, each within its precision ({c['source']}), move it by at most {c['reach']:.2%} "
            f"(first order): {c['kind']}.")
    if c.get("within_noise"):
        text += (f" Not counted, their elasticity within two standard errors of zero: "
                 f"{', '.join(c['within_noise'])}.")
    if c["smallest"] is not None:
        text += f" The smallest single change that closes it: {one(c['smallest'])}"
        if c["smallest_stated"] is not None and c["smallest_stated"]["parameter"] != c["smallest"]["parameter"]:
            text += f" (of the stated parameters: {one(c['smallest_stated'])})"
        text += " (first order)."
    return text


def band(tolerance: dict, paper, sign=None):
    """(low, high) of the values that agree under a numeric tolerance (``factor`` with the
    paper's sign), or None where the kind has no numeric band (equals, report) or the paper no
    number. ``sign`` narrows the band to its side of zero (the zero itself excluded)."""
    kind, t = tolerance["kind"], tolerance.get("value")
    if kind == "range":
        lo, hi = t
    elif kind == "at_least":
        lo, hi = t, math.inf
    elif kind == "at_most":
        lo, hi = -math.inf, t
    elif kind in ("rel", "abs", "factor") and is_number(paper):
        if kind == "factor":
            lo, hi = sorted((paper / t, paper * t))
        else:
            w = t * abs(paper) if kind == "rel" else t
            lo, hi = paper - w, paper + w
    else:
        return None
    s = SIGNS.get(sign)
    if s == 1:
        lo = max(lo, 0.0)
    elif s == -1:
        hi = min(hi, 0.0)
    return lo, hi


def too_wide(row: dict) -> str | None:
    """Why the row's tolerance is wider than its paper value allows, or None: a rel / abs /
    factor band reaching farther from the paper's number than the number's magnitude, or a band
    that holds values of both signs where the row states a sign."""
    tol, p = row["tolerance"], row["paper"]
    kind, t = tol["kind"], tol.get("value")
    if kind in ("rel", "abs", "factor") and is_number(p):
        w = {"rel": (t * abs(p)) if is_number(t) else None, "abs": t,
             "factor": abs(p) * (t - 1) if is_number(t) else None}[kind]
        if w is None or w > abs(p) * (1 + 1e-12):
            return f"a {kind} tolerance of {t!r} reaches {w!r} from the paper's {p!r}, farther than |paper|"
    if row.get("sign") in SIGNS and kind in ("rel", "abs", "factor", "range", "at_least", "at_most"):
        b = band(tol, p)
        if b is not None and b[0] < 0 < b[1]:
            return f"the row states the sign {row['sign']} but its band [{b[0]:g}, {b[1]:g}] holds both signs"
    return None


_FIELD = re.compile(r"\{\{|\}\}|\{([^{}:*]+)(?:\*([^{}:]+))?(?::([^{}]*))?\}|[{}]")


def fields(text: str) -> list:
    """The names a text's placeholders cite, in order; ValuesError on a stray brace."""
    out = []
    for m in _FIELD.finditer(text or ""):
        tok = m.group(0)
        if tok in ("{{", "}}"):
            continue
        if m.group(1) is None:
            raise ValuesError(f"a stray {tok!r} (write {tok * 2} for a literal brace)")
        if m.group(2) is not None:
            try:
                float(m.group(2))
            except ValueError:
                raise ValuesError(f"{{{m.group(1)}*{m.group(2)}}}: the scale must be a number") from None
        out.append(m.group(1).strip())
    return out


_MISSING = object()


def lookup(name: str, namespace: dict):
    """``namespace[name]``, or a dotted path into it (``delay.fell``: namespace['delay']['fell'];
    a number steps into a list); the module's ``_MISSING`` where a step is absent."""
    if name in namespace:
        return namespace[name]
    x = namespace
    for part in name.split("."):
        if isinstance(x, dict) and part in x:
            x = x[part]
        elif isinstance(x, list) and part.isdigit() and int(part) < len(x):
            x = x[int(part)]
        else:
            return _MISSING
    return x


def _missing(name: str, namespace: dict, none: bool) -> str:
    """Where the path ``name`` stops in ``namespace``, in words (for TemplateError)."""
    if none:
        return "is None in this run (the study did not report it)"
    x, walked = namespace, []
    for part in name.split("."):
        if isinstance(x, dict) and part in x:
            x, walked = x[part], walked + [part]
        elif isinstance(x, list) and part.isdigit() and int(part) < len(x):
            x, walked = x[int(part)], walked + [part]
        else:
            break
    if isinstance(x, dict):
        have = ", ".join(sorted(map(str, x))[:16]) + (", ..." if len(x) > 16 else "")
    else:
        have = f"a {type(x).__name__}, not a mapping"
    at = ".".join(walked) if walked else "the run"
    return f"names nothing this run holds: {at} has no {name.split('.')[len(walked)]!r} ({at} holds {have})"


def render(text: str, namespace: dict, where: str = "text") -> str:
    """``text`` with its ``{name[*scale][:fmt]}`` placeholders filled from ``namespace``;
    TemplateError naming ``where`` and the missing name (and what there is) otherwise."""
    if not text:
        return text

    def one(m):
        tok = m.group(0)
        if tok in ("{{", "}}"):
            return tok[0]
        if m.group(1) is None:
            raise TemplateError(f"{where}: a stray {tok!r} (write {tok * 2} for a literal brace)")
        name, scale, fmt = m.group(1).strip(), m.group(2), m.group(3) or ""
        x = lookup(name, namespace)
        if x is _MISSING or x is None:
            raise TemplateError(f"{where}: {{{name}}} " + _missing(name, namespace, x is None))
        if scale is not None:
            if not is_number(x):
                raise TemplateError(f"{where}: {{{name}*{scale}}} scales {x!r}, which is not a number")
            x = x * float(scale)
        try:
            return format(x, fmt)
        except (ValueError, TypeError) as e:
            raise TemplateError(f"{where}: {{{name}:{fmt}}} cannot format {x!r}: {e}") from None

    return _FIELD.sub(one, text)


def check_tolerance(tol, where: str) -> None:
    if not isinstance(tol, dict) or tol.get("kind") not in KINDS:
        raise ValuesError(f"{where}: tolerance.kind must be one of {', '.join(KINDS)}")
    if not isinstance(tol.get("why"), str) or not tol["why"].strip():
        raise ValuesError(f"{where}: tolerance.why must say why the tolerance is what it is")
    v = tol.get("value")
    kind = tol["kind"]
    if kind == "range":
        ok = isinstance(v, list) and len(v) == 2 and all(is_number(a) for a in v) and v[0] <= v[1]
    elif kind == "equals":
        ok = isinstance(v, (bool, int, float, str))
    elif kind == "report":
        ok = v is None
    elif kind == "factor":
        ok = is_number(v) and 1 < v <= 2
    elif kind == "rel":
        ok = is_number(v) and 0 <= v <= 1
    else:
        ok = is_number(v) and (v >= 0 or kind in ("at_least", "at_most"))
    if not ok:
        raise ValuesError(f"{where}: tolerance.value {v!r} does not fit kind {kind!r}")
    d = tol.get("derivation")
    if kind == "report":
        if d is not None:
            raise ValuesError(f"{where}: a 'report' row is not judged and has no derivation")
        return
    if d not in DERIVATIONS:
        raise ValuesError(f"{where}: tolerance.derivation must say how the tolerance was derived: one of "
                          f"{', '.join(DERIVATIONS)}")
    if kind not in DERIVATION_KINDS[d]:
        raise ValuesError(f"{where}: a {d!r} derivation cannot use kind {kind!r} "
                          f"(it uses {', '.join(DERIVATION_KINDS[d])})")


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
        if not (is_number(row["paper"]) or isinstance(row["paper"], (str, bool))):
            raise ValuesError(f"{where}: 'paper' must be a number, a yes/no or a short text")
        check_tolerance(row["tolerance"], where)
        if "departs_why" in row and not isinstance(row["departs_why"], str):
            raise ValuesError(f"{where}: 'departs_why' must be a sentence")
        if "gait" in row and (not isinstance(row["gait"], str) or not row["gait"].strip()):
            raise ValuesError(f"{where}: 'gait' must name the gait (or gaits) the row's experiment walked")
        if "sign" in row:
            if row["sign"] not in SIGNS:
                raise ValuesError(f"{where}: 'sign' must be '+' or '-'")
            if is_number(row["paper"]) and row["paper"] * SIGNS[row["sign"]] <= 0:
                raise ValuesError(f"{where}: 'sign' {row['sign']} is not the sign of the paper's {row['paper']!r}")
        if "survival_only" in row and (row["survival_only"] is not True or row["tolerance"].get("derivation") != "claim"):
            raise ValuesError(f"{where}: 'survival_only' is true on a claim row (derivation 'claim') or absent")
        if "self_check" in row:
            if not isinstance(row["self_check"], str) or not row["self_check"].strip():
                raise ValuesError(f"{where}: 'self_check' must say in a sentence what the method checks itself against")
        elif row["tolerance"].get("derivation") == "own_target":
            raise ValuesError(f"{where}: an 'own_target' tolerance belongs to a self-check row ('self_check')")
        wide = too_wide(row)
        if wide:
            raise ValuesError(f"{where}: {wide}")
        for key, text in (("tolerance.why", row["tolerance"]["why"]), ("departs_why", row.get("departs_why"))):
            try:
                fields(text)
            except ValuesError as e:
                raise ValuesError(f"{where}: {key}: {e}") from None
    return data


def load(path) -> dict:
    """Read and check one paper-values file."""
    path = Path(path)
    try:
        data = json.loads(decode_text(path.read_bytes()))  # a BOM, CRLF or UTF-16 from an editor too
    except (OSError, TextError, json.JSONDecodeError) as e:
        raise ValuesError(f"{path}: cannot read paper values: {e}") from None
    return check(data, str(path.name))


def agrees(value, tolerance: dict, paper=None, sign=None):
    """True / False whether ``value`` agrees with the paper under ``tolerance`` (and has the
    stated ``sign``, "+" or "-", where one is given); None when the value is missing (not
    measured) or not a number where a number is needed."""
    if value is None:
        return None
    kind, t = tolerance["kind"], tolerance.get("value")
    if kind == "report":
        return None
    if kind == "equals":
        return bool(value == t)
    if isinstance(value, bool) or not is_number(value):
        return None
    if sign in SIGNS and not value * SIGNS[sign] > 0:
        return False
    if kind == "at_least":
        return bool(value >= t)
    if kind == "at_most":
        return bool(value <= t)
    if kind == "range":
        return bool(t[0] <= value <= t[1])
    if not is_number(paper):
        return None
    if kind == "factor":
        if paper == 0 or value * paper <= 0:
            return False
        return bool(max(value / paper, paper / value) <= t * (1 + 1e-12))
    err = abs(value - paper)
    return bool(err <= (t * abs(paper) if kind == "rel" else t) * (1 + 1e-12))


def verdict(ok, self_check=None, derivation=None) -> str:
    """The verdict word of a row (one of :data:`VERDICTS`) from its test's outcome ``ok``
    (True / False / None), whether it is a self-check and its tolerance's ``derivation``."""
    if ok is None:
        return "not judged"
    if self_check:
        return "self-check met" if ok else "self-check not met"
    if derivation == "claim":
        return "claim holds" if ok else "claim fails"
    if not ok:
        return "departs"
    return "matches" if derivation == "precision" else "agrees"


def _g(v) -> str:
    if is_number(v) and 1e-7 <= abs(v) < 1e-4:
        return f"{v:.7f}".rstrip("0")
    return f"{v:g}" if is_number(v) else str(v)


def tolerance_text(tolerance: dict, unit: str = "", sign=None) -> str:
    """The tolerance in words, e.g. 'within 5 %', 'at least 90', 'in [0.5, 1]'."""
    kind, t = tolerance["kind"], tolerance.get("value")
    u = f" {unit}" if unit else ""
    s = {"+": ", positive", "-": ", negative"}.get(sign, "")
    if kind == "report":
        return "reported, not judged"
    if kind == "rel":
        return f"within {_g(100 * t)} %{s}"
    if kind == "abs":
        return f"within ±{_g(t)}{u}{s}"
    if kind == "factor":
        return f"the paper's sign, within a factor {_g(t)}"
    if kind == "at_least":
        return f"at least {_g(t)}{u}{s}"
    if kind == "at_most":
        return f"at most {_g(t)}{u}{s}"
    if kind == "range":
        return f"in [{_g(t[0])}, {_g(t[1])}]{u}{s}"
    return f"equal to {str(t).lower() if isinstance(t, bool) else t}"
