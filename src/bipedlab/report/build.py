"""Assembling the report: rows (paper beside simulation), figures, run metadata, report.json
and index.html in one folder."""
from __future__ import annotations

import os
import platform
import shutil
import subprocess
import time
from pathlib import Path

import bipedlab
from bipedlab.outputs import dumps_json
from bipedlab.report import html, values
from bipedlab.report.spec import Failed, Measured, NotIdentifiable, Paper, Skip


def _device() -> dict:
    import jax

    d = jax.devices()[0]
    return dict(platform=d.platform, kind=getattr(d, "device_kind", d.platform), count=jax.device_count(),
                description=f"{d.platform} ({getattr(d, 'device_kind', '')}), {jax.device_count()} device(s), "
                            f"{os.cpu_count()} CPU core(s) visible")


def git_commit() -> str | None:
    """The commit of the source tree the package was imported from, if it is a git checkout."""
    where = Path(bipedlab.__file__).resolve().parent
    try:
        out = subprocess.run(["git", "-C", str(where), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=5)
        dirty = subprocess.run(["git", "-C", str(where), "status", "--porcelain", "--", "."], capture_output=True,
                               text=True, timeout=5)
    except (OSError, subprocess.SubprocessError):
        return None
    if out.returncode != 0:
        return None
    return out.stdout.strip() + (" (with local changes)" if dirty.stdout.strip() else "")


def metadata(quick: bool, wall_s: float, cpu_s: float) -> dict:
    import jax

    return dict(version=bipedlab.__version__, commit=git_commit(), jax=jax.__version__, python=platform.python_version(),
                device=_device(), dtype="float64" if jax.config.jax_enable_x64 else "float32", quick=quick,
                wall_s=wall_s, cpu_s=cpu_s, created=time.strftime("%Y-%m-%d %H:%M:%S %Z"))


def rows_for(paper: Paper, records: dict, quick: bool) -> list:
    """The paper's rows with the simulated values and the verdicts (:data:`values.VERDICTS`).

    Each row carries ``agrees`` (True / False / None: agreement with the paper; None for a
    self-check, whose outcome is ``met``), ``met`` (the tolerance's test on the value, for
    every row), ``verdict`` in words, ``self_check`` (the sentence, or None), the tolerance in
    words and as data (``tolerance_spec``: kind, value, derivation, and the row's ``sign``) and
    ``why``, its numbers filled from the run (:func:`values.render`; a name the run does not
    hold raises :class:`values.TemplateError`)."""
    data = values.load(paper.values)
    try:
        measured = paper.measure(records, quick)
    except Exception as e:  # a study whose record lacks a field: every row says so, the report still builds
        measured = {r["id"]: Skip(f"could not read the records: {type(e).__name__}: {e}") for r in data["rows"]}
    label = Path(paper.values).name
    out = []
    for r in data["rows"]:
        absent = "its experiment was not run" if any(rec is None for rec in records.values()) else \
            "not measured by this reproduction"
        v = measured.get(r["id"], Skip(absent))
        facts, sensitivity = {}, None
        if isinstance(v, Measured):
            v, facts, sensitivity = v.value, dict(v.facts), v.sensitivity
        reason, failed, unknown = None, None, None
        if isinstance(v, NotIdentifiable):
            unknown, v = v.reason, None
        elif isinstance(v, Skip):
            reason, v = v.reason, None
        elif isinstance(v, Failed):
            failed, v = v.reason, None
        elif v is None:
            reason = "the study did not report it (see the experiment's record)"
        tol, sign, self_check = r["tolerance"], r.get("sign"), r.get("self_check")
        met = False if failed is not None and tol["kind"] != "report" else values.agrees(v, tol, r["paper"], sign)
        namespace = {**{k: x for k, x in records.items() if x is not None}, **facts, "value": v, "paper": r["paper"]}
        where = f"{label}: row {r['id']!r}"
        unit = r.get("unit", "")
        if failed is not None and met is None:
            reason = failed
        if reason is None and met is None:
            reason = (values.render(tol["why"], namespace, where + " tolerance.why") if tol["kind"] == "report"
                      else "not comparable under this tolerance")
        if unknown is not None:
            word, reason = "not identifiable", unknown
        else:
            word = values.verdict(met, self_check, tol.get("derivation"))
        if met is True:
            head = word
            why = f"{head} {values.tolerance_text(tol, unit, sign)}: {values.render(tol['why'], namespace, where + ' tolerance.why')}"
        elif met is False:
            text = r.get("departs_why") or "departs (no explanation recorded)"
            why = failed if failed is not None else values.render(text, namespace, where + " departs_why")
            if self_check:
                why = f"self-check not met: {why}"
        else:
            why = reason
        closed = (values.closing(v, values.closing_target(r["paper"], tol, v), sensitivity)
                  if word == "departs" and sensitivity else None)
        if closed is not None:
            why = f"{why} {values.closing_text(closed)}"
        out.append(dict(id=r["id"], quantity=r["quantity"], paper=r["paper"], unit=unit, source=r["source"],
                        bipedlab=v, tolerance=values.tolerance_text(tol, unit, sign),
                        tolerance_spec=dict(kind=tol["kind"], value=tol.get("value"), derivation=tol.get("derivation"),
                                            sign=sign),
                        tolerance_why=tol["why"], derivation=tol.get("derivation"), self_check=self_check,
                        survival_only=bool(r.get("survival_only")), gait=r.get("gait"),
                        met=met, agrees=None if self_check else met, verdict=word, why=why, closing=closed))
    return out, data


def counts(rows: list) -> dict:
    """How many rows match, agree or depart (numbers; the departures sorted by
    :func:`values.closing` where the run measured their sensitivity), hold (of which how many on survival
    alone) or fail (claims), are self-checks (met or not), are not identifiable from the run's
    data or are not judged: each verdict class apart."""
    v = [r["verdict"] for r in rows]
    kinds = [(r.get("closing") or {}).get("kind") for r in rows if r["verdict"] == "departs"]
    return dict(rows=len(rows), matches=v.count("matches"), agrees=v.count("agrees"), departs=v.count("departs"),
                departs_within_uncertainty=kinds.count(values.WITHIN_UNCERTAINTY),
                departs_implementation=kinds.count(values.IMPLEMENTATION),
                claims_hold=v.count("claim holds"),
                claims_hold_survival_only=sum(r["verdict"] == "claim holds" and bool(r.get("survival_only")) for r in rows),
                claims_fail=v.count("claim fails"),
                self_checks=v.count("self-check met") + v.count("self-check not met"),
                self_checks_not_met=v.count("self-check not met"), not_identifiable=v.count("not identifiable"),
                not_judged=v.count("not judged"))


def _gaits_of(paper: Paper, name: str) -> list:
    return next((list(e.gaits) for e in paper.experiments if e.name == name), [])


def gait_table(paper: Paper, records: dict, quick: bool) -> list:
    """The paper's gaits (:attr:`Paper.gaits`), each with ``walked_by``: the experiments that
    walk or design it; [] for a paper without designed gaits."""
    if paper.gaits is None:
        return []
    table = [dict(g) for g in paper.gaits(records, quick)]
    for g in table:
        g["walked_by"] = [e.name for e in paper.experiments if g["name"] in e.gaits]
    return table


def _copy_files(res, paper_key: str, out_dir: Path) -> dict:
    """Copy an experiment's kept files to <out>/<paper>/<experiment>/: {name relative to the
    experiment's folder: path relative to out_dir}."""
    if not res.files:
        return {}
    src_root = Path(res.files[0])
    while src_root.name != "out":
        src_root = src_root.parent
    dest = out_dir / paper_key / res.name
    got = {}
    for f in res.files:
        rel = Path(f).relative_to(src_root)
        target = dest / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(f, target)
        got[rel.as_posix()] = target.relative_to(out_dir).as_posix()
    return got


def build(papers: list, results: dict, quick: bool, out_dir, wall_s: float, cpu_s: float) -> dict:
    """Write out_dir/report.json, out_dir/index.html and the figures; return the report."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    report = dict(metadata(quick, wall_s, cpu_s), papers={})
    for p in papers:
        res = results[p.key]
        records = {r.name: r.record for r in res}
        rows, data = rows_for(p, records, quick)
        copied = {r.name: _copy_files(r, p.key, out_dir) for r in res}
        figs = []
        for kind, items in (("figure", p.figures), ("animation", p.animations)):
            for f in items:
                path = copied.get(f.experiment, {}).get(f.file)
                skipped = next((r.skipped for r in res if r.name == f.experiment), None)
                figs.append(dict(kind=kind, experiment=f.experiment, file=path, caption=f.caption,
                                 missing=None if path else (skipped or "not produced in this run")))
        report["papers"][p.key] = dict(
            title=data["title"], citation=data["citation"], rows=rows,
            counts=counts(rows),
            experiments=[dict(r.summary(), gaits=_gaits_of(p, r.name), files=sorted(copied[r.name].values()),
                              record=r.record) for r in res],
            gaits=gait_table(p, records, quick),
            figures=[f for f in figs if f["kind"] == "figure"],
            animations=[f for f in figs if f["kind"] == "animation"],
            notes=list(p.notes))
    (out_dir / "report.json").write_text(dumps_json(report, indent=1))
    (out_dir / "index.html").write_text(html.page(report), encoding="utf-8")
    return report
