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
from bipedlab.report.spec import Paper, Skip


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
    """The paper's rows with the simulated values and the agrees / departs verdicts."""
    data = values.load(paper.values)
    try:
        measured = paper.measure(records, quick)
    except Exception as e:  # a study whose record lacks a field: every row says so, the report still builds
        measured = {r["id"]: Skip(f"could not read the records: {type(e).__name__}: {e}") for r in data["rows"]}
    out = []
    for r in data["rows"]:
        absent = "its experiment was not run" if any(rec is None for rec in records.values()) else \
            "not measured by this reproduction"
        v = measured.get(r["id"], Skip(absent))
        reason = None
        if isinstance(v, Skip):
            reason, v = v.reason, None
        elif v is None:
            reason = "the study did not report it (see the experiment's record)"
        ok = values.agrees(v, r["tolerance"], r["paper"])
        if reason is None and ok is None:
            reason = (r["tolerance"]["why"] if r["tolerance"]["kind"] == "report"
                      else "not comparable under this tolerance")
        if ok is True:
            why = f"agrees {values.tolerance_text(r['tolerance'], r.get('unit', ''))}: {r['tolerance']['why']}"
        elif ok is False:
            why = r.get("departs_why") or "departs (no explanation recorded)"
        else:
            why = reason
        out.append(dict(id=r["id"], quantity=r["quantity"], paper=r["paper"], unit=r.get("unit", ""), source=r["source"],
                        bipedlab=v, tolerance=values.tolerance_text(r["tolerance"], r.get("unit", "")),
                        tolerance_why=r["tolerance"]["why"], agrees=ok, why=why))
    return out, data


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
        n_ok = sum(r["agrees"] is True for r in rows)
        n_bad = sum(r["agrees"] is False for r in rows)
        report["papers"][p.key] = dict(
            title=data["title"], citation=data["citation"], rows=rows,
            counts=dict(rows=len(rows), agrees=n_ok, departs=n_bad, not_judged=len(rows) - n_ok - n_bad),
            experiments=[dict(r.summary(), record=r.record) for r in res],
            figures=[f for f in figs if f["kind"] == "figure"],
            animations=[f for f in figs if f["kind"] == "animation"],
            notes=list(p.notes))
    (out_dir / "report.json").write_text(dumps_json(report, indent=1))
    (out_dir / "index.html").write_text(html.page(report), encoding="utf-8")
    return report
