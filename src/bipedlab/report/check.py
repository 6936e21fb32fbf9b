"""Whether a published report still matches the code: ``bipedlab reproduce --check``.

A published report is a folder (the repository's ``docs/report``) holding a full run's report
(``index.html``, ``report.json``, the figures) and, beside it, the ``report.json`` of a quick
run of the same commit as ``quick.json``. ``--check`` runs the quick reproduction with the
code at hand (stored results are reused as by any run) and compares its rows with
``quick.json``, row by row: a row matches when its verdict is the same and its value is the
same (numbers to a relative :data:`RTOL`, :data:`ATOL` absolute; texts, flags and missing
values exactly). The full run's rows are not recomputed (it takes about twenty minutes); the
quick rows are the part of the published report a check can afford.

The comparison is pure data (:func:`compare`); the command prints one line per row that
differs, is missing or is new, and exits with status 1 when any does.
"""
from __future__ import annotations

import html
import json
import math
import re
from pathlib import Path
from typing import Optional

from bipedlab.inputs import TextError, decode_text

QUICK_FILE = "quick.json"
"""The quick run's report.json inside a published report's folder."""
RTOL = 1e-6
"""Relative tolerance on a number: float64 runs of the same code on other CPUs (other vector
units, other XLA builds) round differently, and closed loops amplify the last bits; a change
of the code moves a value by far more."""
ATOL = 1e-12


class CheckError(ValueError):
    """A published report that cannot be read (one line)."""


def default_folder() -> Path:
    """``docs/report`` of the source checkout the package runs from, if it has one, else
    ``./docs/report``."""
    import bipedlab

    here = Path(bipedlab.__file__).resolve().parent
    for root in (here.parent.parent, Path.cwd()):
        if (root / "docs" / "report" / QUICK_FILE).is_file():
            return root / "docs" / "report"
    return Path("docs") / "report"


def load(folder) -> dict:
    """The published quick report of ``folder`` (its ``quick.json``); CheckError otherwise."""
    path = Path(folder) / QUICK_FILE
    if not path.is_file():
        raise CheckError(f"no published quick report at {path} (give the folder of a published report)")
    try:
        data = json.loads(decode_text(path.read_bytes()))  # a BOM, CRLF or UTF-16 from an editor too
    except (OSError, TextError, json.JSONDecodeError) as e:
        raise CheckError(f"{path} is not a report's JSON: {e}") from None
    if not isinstance(data, dict) or not isinstance(data.get("papers"), dict) or not data.get("quick"):
        raise CheckError(f"{path} is not the report.json of a quick reproduction")
    return data


def same(a, b) -> bool:
    """Two row values agree: numbers to RTOL / ATOL (NaN with NaN), lists element by element,
    everything else exactly."""
    if isinstance(a, bool) or isinstance(b, bool):
        return isinstance(a, bool) and isinstance(b, bool) and a == b
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        if math.isnan(a) or math.isnan(b):
            return math.isnan(a) and math.isnan(b)
        return abs(a - b) <= ATOL + RTOL * max(abs(a), abs(b))
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    return a == b


def _rows(report: dict, papers: Optional[list]) -> dict:
    return {(k, r["id"]): r for k, p in report["papers"].items() if papers is None or k in papers
            for r in p["rows"]}


def compare(published: dict, report: dict, papers: Optional[list] = None) -> dict:
    """Row-by-row comparison of a published quick report with this run's (``papers``: the
    paper keys to compare, default those of this run). Returns {published: {commit,
    created, version}, rows, matched, differs: [...], missing: [...], new: [...], matches}."""
    papers = list(report["papers"]) if papers is None else papers
    old, new = _rows(published, papers), _rows(report, papers)
    differs, missing, added = [], [], []
    for key, r in new.items():
        o = old.get(key)
        if o is None:
            added.append(dict(paper=key[0], id=key[1], now=r["bipedlab"], verdict=r["verdict"]))
        elif o["verdict"] != r["verdict"] or not same(o["bipedlab"], r["bipedlab"]):
            differs.append(dict(paper=key[0], id=key[1], published=o["bipedlab"], now=r["bipedlab"],
                                published_verdict=o["verdict"], verdict=r["verdict"]))
    for key, o in old.items():
        if key not in new:
            missing.append(dict(paper=key[0], id=key[1], published=o["bipedlab"], published_verdict=o["verdict"]))
    matched = sum(1 for k in new if k in old) - len(differs)
    return dict(published={k: published.get(k) for k in ("commit", "created", "version", "jax")},
                papers=papers, rows=len(new), matched=matched, differs=differs, missing=missing, new=added,
                rtol=RTOL, atol=ATOL, matches=not (differs or missing or added))


def _v(x) -> str:
    return f"{x:.6g}" if isinstance(x, float) else str(x)


def summary(check: dict) -> str:
    """The comparison in words: a headline, then one line per row that differs, is missing or
    is new."""
    pub = check["published"]
    head = (f"published report (commit {str(pub.get('commit') or 'unknown')[:12]}, {pub.get('created') or 'undated'}): "
            f"{check['matched']} of {check['rows']} quick rows match")
    lines = [head + (" - the published values still hold" if check["matches"] else " - differences below")]
    for d in check["differs"]:
        lines.append(f"  differs  {d['paper']}/{d['id']}: published {_v(d['published'])} ({d['published_verdict']}), "
                     f"now {_v(d['now'])} ({d['verdict']})")
    for d in check["missing"]:
        lines.append(f"  missing  {d['paper']}/{d['id']}: published {_v(d['published'])} ({d['published_verdict']}), "
                     "not in this run")
    for d in check["new"]:
        lines.append(f"  new      {d['paper']}/{d['id']}: {_v(d['now'])} ({d['verdict']}), not in the published report")
    if check.get("stale"):
        lines.append(f"the published report's results were computed from other source than the code at hand for "
                     f"{len(check['stale'])} experiments ({', '.join(check['stale'])}): regenerate it")
    return "\n".join(lines)


def stale(folder=None) -> list[dict]:
    """The experiments whose stored result keys in a published report are not the keys the code
    at hand gives them, computed without running anything (:func:`bipedlab.report.runner.cache_key`
    from the source, the arguments and the paper's values file, the key ``reproduce`` stores
    its results under): for the full run's ``report.json`` (full arguments) and the quick run's
    ``quick.json`` (quick arguments). Each entry: ``{report, paper, experiment, published,
    current}`` (``published`` None for an experiment the report lacks, ``current`` None for one
    the code no longer has). Empty when the published page is the code's. The keys are computed
    for the JAX version the report records, so another JAX installed here does not make a page
    computed from the same source stale."""
    from bipedlab.report import registry, runner

    folder = Path(folder) if folder is not None else default_folder()
    papers = registry.papers()
    out = []
    for name, quick in (("report.json", False), (QUICK_FILE, True)):
        path = folder / name
        if not path.is_file():
            raise CheckError(f"no published report at {path}")
        data = json.loads(decode_text(path.read_bytes()))
        published = data.get("papers", {})
        for key, paper in papers.items():
            stored = {e["name"]: e.get("cache_key") for e in published.get(key, {}).get("experiments", [])}
            for exp in paper.experiments:
                args = exp.args(quick)
                # the page's own JAX: the question is the source, not the JAX installed here
                current = None if args is None else runner.cache_key(
                    paper.key, exp.name, args, runner.robot_package(exp.run), paper.values, data.get("jax"))
                if stored.get(exp.name) != current:
                    out.append(dict(report=name, paper=key, experiment=exp.name, published=stored.get(exp.name),
                                    current=current))
            for gone in sorted(set(stored) - {e.name for e in paper.experiments}):
                out.append(dict(report=name, paper=key, experiment=gone, published=stored[gone], current=None))
    return out


def unlinked(folder) -> list:
    """The files of a published report's folder that its page does not link (``href`` or
    ``src`` of ``index.html``), as paths relative to the folder; the page, ``report.json``,
    ``quick.json`` and the run's progress file themselves apart. An empty list: the page reaches
    every file it was built with."""
    from bipedlab.report import resume

    folder = Path(folder)
    page = (folder / "index.html").read_text(encoding="utf-8")
    linked = {html.unescape(m) for m in re.findall(r'(?:href|src)="([^"#]+)"', page)}
    own = {"index.html", "report.json", QUICK_FILE, resume.FILE}
    files = sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file())
    return [f for f in files if f not in own and f not in linked]
