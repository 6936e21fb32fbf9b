"""What a paper's reproduction is made of: experiments, figures, an animation and the rows that
compare the paper's numbers with the simulation's.

A robot package that reproduces a paper holds a ``reproduce`` module whose ``PAPERS`` lists
:class:`Paper` objects (found by :func:`bipedlab.report.registry.papers`). The paper's numbers
are data: a JSON file shipped beside the package (:mod:`bipedlab.report.values`); the code only
says how each row's simulated value is read from the experiments' records (``measure``).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Optional

from bipedlab.report.values import is_number, reach_of


@dataclass(frozen=True)
class Experiment:
    """One run of an existing study.

    name: unique within its paper (also the folder of its figures in the report).
    command: the equivalent command line (shown in the report).
    run(args, out, progress) -> record: calls the study in-process; ``args`` is ``full_args`` or
        ``quick_args``; ``out`` a folder for figures (or None); progress a one-argument callable.
    full_args / quick_args: JSON-able arguments; they enter the result cache's key.
        ``quick_args=None``: not run with ``--quick``; ``skip_reason`` says why.
    reduction: what ``--quick`` reduces, in words (stated in the report).
    expected_s / quick_expected_s: expected wall seconds from an empty compile cache on a
        two-core CPU (for the progress display and the announced duration).
    gaits: the gaits the experiment walks or designs, by name (shown beside it in the report;
        the paper's :attr:`Paper.gaits` table gives each one's designed figures).
    """

    name: str
    command: str
    run: Callable[[dict, Optional[str], Callable[[str], None]], dict]
    full_args: dict
    quick_args: Optional[dict]
    reduction: str = ""
    expected_s: float = 60.0
    quick_expected_s: float = 30.0
    skip_reason: str = "not run in --quick"
    gaits: tuple = ()

    def args(self, quick: bool) -> Optional[dict]:
        return self.quick_args if quick else self.full_args


@dataclass(frozen=True)
class Figure:
    """A file an experiment writes into its ``out`` folder, shown with a caption (which names
    the paper's figure it corresponds to). ``kind``: "image" (PNG/SVG) or "animation" (HTML
    page with an inline player, or an animated SVG)."""

    experiment: str
    file: str
    caption: str
    kind: str = "image"


@dataclass(frozen=True)
class Skip:
    """A row value that was not measured, with the reason (e.g. the experiment is not run in
    ``--quick``); its row neither agrees nor departs."""

    reason: str


@dataclass(frozen=True)
class Failed:
    """A row value the run could not measure because its experiment failed at what the paper
    reports working (a fall, a push not recovered, no fixed point): the row departs, with the
    reason as its text."""

    reason: str


@dataclass(frozen=True)
class NotIdentifiable:
    """A row value the run's data cannot determine (an estimate whose 1-sigma error from the data
    is past the study's bar for an identified parameter, so it stays where the fit started): the
    row is neither met nor departed, its verdict is *not identifiable*, and ``reason`` gives the
    1-sigma error that shows it."""

    reason: str


@dataclass(frozen=True)
class Sensitivity:
    """How a row's value moves with the robot's parameters, measured by the run: ``elasticity``
    {parameter: d ln(value) / d ln(parameter)}; ``precision`` {parameter: the relative precision
    the paper states it to (None for a value the paper does not give: an assumed one)};
    ``source``: where the precisions come from; ``method``: how the derivatives were measured;
    ``standard_error`` {parameter: the elasticity's standard error} where it was measured on a
    noisy statistic (an elasticity within two of them of zero is not counted).
    A departing row with one is sorted (:func:`bipedlab.report.values.closing`)."""

    elasticity: dict
    precision: dict
    source: str
    method: str
    standard_error: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Measured:
    """A row's simulated value with the numbers of the run its texts cite: ``{name}`` in the
    row's ``tolerance.why`` or ``departs_why`` is filled from ``facts`` (beside ``value``,
    ``paper`` and the experiments' records; :func:`bipedlab.report.values.render`);
    ``sensitivity``: the value's :class:`Sensitivity` to the robot's parameters, if measured."""

    value: Any
    facts: dict = field(default_factory=dict)
    sensitivity: Optional[Sensitivity] = None


@dataclass(frozen=True)
class Paper:
    """One paper's reproduction.

    key: the command-line name (``bipedlab reproduce KEY``).
    values: path of the paper-values JSON file.
    measure(records, quick) -> {row id: value | Measured | Skip}: the simulated value of each
        row from the experiments' records (``records[name]`` is None for an experiment not
        run); :class:`Measured` adds the facts the row's texts cite.
    figures / animations: :class:`Figure` s shown in the paper's section.
    notes: sentences shown under the section's figures.
    order: position of the paper in the report (then by key).
    gaits(records, quick) -> [dict]: for papers whose experiments walk designed gaits, one entry
        per gait (``name``, what it was designed on, its designed figures and the paper's beside
        them); the report adds which experiments walk it (:attr:`Experiment.gaits`).
    """

    key: str
    title: str
    values: str
    experiments: tuple
    measure: Callable[[dict, bool], dict]
    figures: tuple = ()
    animations: tuple = ()
    notes: tuple = field(default_factory=tuple)
    order: int = 100
    gaits: Optional[Callable[[dict, bool], list]] = None

    def experiment(self, name: str) -> Experiment:
        for e in self.experiments:
            if e.name == name:
                return e
        raise KeyError(name)


def dig(record: Any, *path, default=None):
    """record[path[0]][path[1]]... or ``default`` where a step is missing or None."""
    x = record
    for p in path:
        if x is None:
            return default
        try:
            x = x[p]
        except (KeyError, IndexError, TypeError):
            return default
    return default if x is None else x


def printed_precision(text: str) -> float:
    """The relative precision a value's printed form states: half a unit of its last digit over
    the value ("40.8953": 0.00005 / 40.8953; "9.0144e-4": 0.00005e-4 / 9.0144e-4; "30": 0.5 / 30)."""
    from decimal import Decimal, InvalidOperation

    try:
        d = Decimal(text.strip())
    except (InvalidOperation, AttributeError):
        raise ValueError(f"not a printed number: {text!r}") from None
    if not d.is_finite() or d == 0:
        raise ValueError(f"a printed precision needs a finite nonzero number, got {text!r}")
    return float(Decimal("0.5").scaleb(d.as_tuple().exponent) / abs(d))


def with_sensitivity(values: dict, rec: Optional[dict], rel: float = 1e-9, noise: float = 3.0) -> dict:
    """The rows of ``values`` ({row id: value or :class:`Measured`}) that a sensitivity record
    measured, each as a :class:`Measured` carrying its :class:`Sensitivity`, where the record's
    unscaled value (``rec["base"][row]``) is the row's own within ``rel`` (the same run, or the
    same optimum found again). ``rec``: ``base`` {row: value}; ``parameters`` {name: {precision,
    elasticity {row: value or None}, standard_error {row: value} (optional)}}; ``precision_source``;
    ``method``; optionally ``noise`` {row: s.d. of the row's value between runs that differ only
    by rounding}, within ``noise`` of which times it the base is the row's own too. A parameter
    whose elasticity of a row is None (its scaled run failed) is left out of that row's."""
    if not rec:
        return {}
    new = {}
    for row, base in rec["base"].items():
        v = values.get(row)
        value, facts = (v.value, v.facts) if isinstance(v, Measured) else (v, {})
        if not (is_number(value) and is_number(base)):
            continue
        if abs(value - base) > max(rel * abs(base), noise * ((rec.get("noise") or {}).get(row) or 0.0)):
            continue
        new[row] = Measured(value, facts, sensitivity=sensitivity_of(rec, row))
    return new


def sensitivity_of(rec: dict, row: str) -> Sensitivity:
    """Row ``row``'s :class:`Sensitivity` from a sensitivity record (the format of
    :func:`with_sensitivity`'s ``rec``); its reach: :func:`bipedlab.report.values.reach_of`."""
    params = {k: r for k, r in rec["parameters"].items() if r["elasticity"].get(row) is not None}
    return Sensitivity(
        elasticity={k: r["elasticity"][row] for k, r in params.items()},
        precision={k: r["precision"] for k, r in params.items()}, source=rec["precision_source"],
        method=rec["method"],
        standard_error={k: r["standard_error"][row] for k, r in params.items()
                        if (r.get("standard_error") or {}).get(row) is not None})


def reach(rec: dict, row: str) -> float:
    """The largest relative change of ``row``'s value, to first order, with every stated value
    within its precision (:func:`bipedlab.report.values.reach_of` of :func:`sensitivity_of`)."""
    return reach_of(sensitivity_of(rec, row))
