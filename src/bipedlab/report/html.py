"""The report page: one self-contained HTML file (no network, no script except inside the
animation players, which are separate pages shown in iframes). Figures are PNG files next to it."""
from __future__ import annotations

import math
from html import escape

from bipedlab.report.values import COUNT_KEYS

CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Helvetica,Arial,sans-serif;margin:0 auto;max-width:1180px;
padding:1.2em 1.6em;color:#1d1d1f;line-height:1.45}
h1{font-size:1.7em;margin-bottom:.2em}h2{margin-top:2em;border-bottom:2px solid #ddd;padding-bottom:.2em}
h3{margin-top:1.4em}
table{border-collapse:collapse;width:100%;font-size:.9em;margin:.6em 0}
th,td{border:1px solid #d0d0d0;padding:.3em .5em;vertical-align:top;text-align:left}
th{background:#f3f3f3}td.num{text-align:right;white-space:nowrap;font-variant-numeric:tabular-nums}
tr.matches td.verdict,tr.agrees td.verdict{background:#e3f4e1;color:#1b5e20;font-weight:600}
tr.departs td.verdict{background:#fde7e4;color:#8e1c0e;font-weight:600}
tr.claimholds td.verdict{background:#eef7ec;color:#2e6b2a}
tr.claimfails td.verdict{background:#fdeeea;color:#8e1c0e}
tr.notjudged td.verdict{background:#f1f1f1;color:#555}
tr.notidentifiable td.verdict{background:#f5efe2;color:#6b4e12;font-style:italic}
tr.selfcheck td.verdict{background:#e8eef8;color:#1f3f73;font-style:italic}
.src{color:#666;font-size:.85em}.why{font-size:.88em}
figure{display:inline-block;margin:.5em 1em .8em 0;vertical-align:top;max-width:540px}
figure img{max-width:100%;border:1px solid #e0e0e0}figcaption{font-size:.85em;color:#333}
iframe.animation{width:700px;max-width:100%;height:730px;border:1px solid #ccc;background:#fff}
dl.meta{display:grid;grid-template-columns:max-content auto;gap:.1em 1em;font-size:.9em}dl.meta dt{font-weight:600}
.counts{font-weight:600}.note{font-size:.88em;color:#444}
table.experiments details ul{margin:.2em 0;padding-left:1.1em;font-size:.9em}
nav a{margin-right:1em}
"""


def _val(v, unit: str = "") -> str:
    if v is None:
        return "—"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        if not math.isfinite(v):
            return "—"
        a = abs(v)
        s = f"{v:.3g}" if (a >= 1e4 or (0 < a < 1e-3)) else f"{v:.4g}"
    else:
        s = str(v)
    return f"{s} {unit}".strip() if unit and not isinstance(v, str) else s


def _verdict(row) -> tuple[str, str]:
    """(CSS class, words) of a row's verdict; a self-check is shown as one, never as agreement."""
    v = row.get("verdict") or {True: "agrees", False: "departs"}.get(row.get("agrees"), "not judged")
    cls = {"matches": "matches", "agrees": "agrees", "departs": "departs", "claim holds": "claimholds",
           "claim fails": "claimfails", "not identifiable": "notidentifiable",
           "not judged": "notjudged"}.get(v, "selfcheck")
    return cls, v


def counts_text(c: dict) -> str:
    """'N rows: m match the paper's printed precision, a agree within a band, d depart; claims:
    h hold (v of them on survival alone), f fail; s self-checks (k not met); u not identifiable
    from the data; n not judged.' (each class apart; the survival and not-identifiable clauses
    only where there are such rows)"""
    sc = c.get("self_checks", 0)
    ni = c.get("not_identifiable", 0)
    return (f'{c["rows"]} rows: {c.get("matches", 0)} match the paper\'s printed precision, {c["agrees"]} agree '
            f'within a band, {c["departs"]} depart'
            + _sorted_departures(c) + f'; claims: {c.get("claims_hold", 0)} hold'
            + (f' ({c["claims_hold_survival_only"]} of them on survival alone)' if c.get("claims_hold_survival_only")
               else '') + ', '
            f'{c.get("claims_fail", 0)} fail; {sc} self-check{"s" if sc != 1 else ""} '
            f'({c.get("self_checks_not_met", 0)} not met); '
            + (f'{ni} not identifiable from the data; ' if ni else '') + f'{c["not_judged"]} not judged.')


def _sorted_departures(c: dict) -> str:
    """' (w within model uncertainty, i implementation or setup, n not sorted)' where any
    departure was sorted by its measured sensitivity, else ''."""
    w, i = c.get("departs_within_uncertainty", 0), c.get("departs_implementation", 0)
    if not (w or i):
        return ""
    return f' ({w} within model uncertainty, {i} implementation or setup, {c["departs"] - w - i} not sorted)'


def _table(rows: list) -> str:
    out = ['<table class="rows"><thead><tr><th>quantity</th><th>paper (source)</th><th>bipedlab</th>'
           '<th>verdict</th><th>tolerance</th><th>why</th></tr></thead><tbody>']
    for r in rows:
        cls, word = _verdict(r)
        if r.get("survival_only"):
            word += '<br><span class="src">survival only</span>'
        gait = f'<br><span class="src">gait: {escape(r["gait"])}</span>' if r.get("gait") else ""
        out.append(f'<tr class="{cls}" id="row-{escape(r["id"])}"><td>{escape(r["quantity"])}{gait}</td>'
                   f'<td>{escape(_val(r["paper"], r["unit"]))}<br><span class="src">{escape(r["source"])}</span></td>'
                   f'<td class="num">{escape(_val(r["bipedlab"], r["unit"]))}</td><td class="verdict">{word}</td>'
                   f'<td class="src">{escape(r["tolerance"])}{_derivation(r)}</td><td class="why">{escape(r["why"] or "")}</td></tr>')
    out.append("</tbody></table>")
    return "\n".join(out)


def _derivation(r) -> str:
    d = r.get("derivation")
    sc = r.get("self_check")
    out = f'<br><span class="src">({escape(DERIVATION_WORDS.get(d, d))})</span>' if d else ""
    if sc:
        out += f'<br><span class="src">self-check: {escape(sc)}</span>'
    return out


DERIVATION_WORDS = {"precision": "from the printed digits", "spread": "from the spread of repeated measurements",
                    "size": "a sign and a size", "claim": "an explicit test of the claim",
                    "own_target": "the method's own target"}


def _torso(g: dict) -> str:
    """A gait's designed torso travel, and whether it exceeds the design's bound."""
    t, bound = g.get("torso_travel_deg"), g.get("torso_travel_bound_deg")
    if t is None:
        return "—"
    over = f" (over the design's bound of {_val(bound)})" if bound is not None and t > bound + 0.01 else ""
    return escape(_val(t) + over)


def _gaits(gaits: list) -> str:
    """The paper's gait table: each gait's designed figures (the torso's travel where the paper
    bounds it), the paper's beside them, and the experiments that walk it."""
    torso = any("torso_travel_deg" in g for g in gaits)
    out = ['<table class="gaits"><thead><tr><th>gait</th><th>designed on</th><th>speed (m/s)</th>'
           '<th>step (m)</th><th>c_mt</th>' + ('<th>torso travel (deg)</th>' if torso else '')
           + '<th>the paper\'s gait it stands for</th><th>walked by</th></tr></thead><tbody>']
    for g in gaits:
        p = g.get("paper") or {}
        figs = ", ".join(f"{what} {_val(p[k], unit)}" if p.get(k) is not None else f"no {what} given"
                         for k, what, unit in (("speed_mps", "speed", "m/s"), ("step_length_m", "step", "m"),
                                               ("cmt", "c_mt", "")))
        paper = (f'{escape(p["gait"])}: {escape(figs)}<br><span class="src">{escape(p.get("source", ""))}</span>'
                 if p else "—")
        out.append(f'<tr id="gait-{escape(g["name"])}"><td>{escape(g["name"])}</td><td>{escape(g["designed_on"])}</td>'
                   f'<td class="num">{escape(_val(g["speed_mps"]))}</td><td class="num">{escape(_val(g["step_length_m"]))}</td>'
                   f'<td class="num">{escape(_val(g["cmt"]))}</td>'
                   + (f'<td class="num">{_torso(g)}</td>' if torso else '') + f'<td>{paper}</td>'
                   f'<td>{escape(", ".join(g["walked_by"]) or "—")}</td></tr>')
    out.append("</tbody></table>")
    return "\n".join(out)


def _experiments(exps: list) -> str:
    out = ['<table class="experiments"><thead><tr><th>experiment</th><th>command</th><th>gaits</th><th>--quick reduction</th>'
           '<th>compile (s)</th><th>run (s)</th><th>wall (s)</th><th>note</th><th>files</th></tr></thead><tbody>']
    for e in exps:
        if e["skipped"]:
            note = e["skipped"]
            c = w = r = "—"
        else:
            c, w = f'{e["compile_s"]:.1f}', f'{e["wall_s"]:.1f}'
            r = f'{max(e["wall_s"] - e["compile_s"], 0.0):.1f}'
            note = "stored result (content hash unchanged)" if e["cached"] else ""
        gaits = ", ".join(e.get("gaits") or []) or "—"
        out.append(f'<tr><td>{escape(e["name"])}</td><td><code>{escape(e["command"])}</code></td><td>{escape(gaits)}</td>'
                   f'<td>{escape(e["reduction"] or "")}</td><td class="num">{c}</td><td class="num">{r}</td>'
                   f'<td class="num">{w}</td><td class="note">{escape(note)}</td><td>{_files(e)}</td></tr>')
    out.append("</tbody></table>")
    return "\n".join(out)


def _files(e) -> str:
    """Every file the experiment wrote (figures, animations, data), each a link named by its path
    inside the experiment's folder, folded away; "—" where it wrote none."""
    files = e.get("files") or []
    if not files:
        return "—"
    links = "".join(f'<li><a href="{escape(f)}">{escape(f.split("/", 2)[-1])}</a></li>' for f in files)
    return f'<details><summary>{len(files)} file{"s" if len(files) > 1 else ""}</summary><ul>{links}</ul></details>'


def _media(items: list, render) -> str:
    """Each figure or animation through ``render``, or, where its file is missing, why."""
    return "\n".join(render(f) if f["file"] is not None else
                     f'<p class="note">{escape(f["caption"])}: {escape(f["missing"] or "not produced")}.</p>'
                     for f in items)


def _figure(f) -> str:
    return (f'<figure><img src="{escape(f["file"])}" alt="{escape(f["caption"])}" loading="eager">'
            f'<figcaption>{escape(f["caption"])}</figcaption></figure>')


def _animation(a) -> str:
    return (f'<figure class="animation"><iframe class="animation" src="{escape(a["file"])}" '
            f'title="{escape(a["caption"])}"></iframe><figcaption>{escape(a["caption"])} '
            f'(<a href="{escape(a["file"])}">open</a>)</figcaption></figure>')


def _figures(figs: list) -> str:
    return _media(figs, _figure)


def _animations(anims: list) -> str:
    return _media(anims, _animation)


def page(report: dict) -> str:
    papers = report["papers"]
    dev = report["device"]
    total = {k: sum(p["counts"].get(k, 0) for p in papers.values())
             for k in COUNT_KEYS}
    head = (f'<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>bipedlab reproduction report</title>'
            f'<meta name="viewport" content="width=device-width, initial-scale=1"><style>{CSS}</style></head><body>')
    parts = [head, "<h1>bipedlab: the four papers, reproduced</h1>",
             f'<p>Each section sets the paper\'s numbers beside the simulation\'s, with the tolerance for agreement and '
             f'why a row departs. A number <em>matches</em> within the paper\'s printed precision, '
             f'<em>agrees</em> within a band derived from a spread or a size, or <em>departs</em>; a stated '
             f'claim (a bound, a range, a yes/no) <em>holds</em> or <em>fails</em>; a self-check (the method '
             f'against its own target, or a number it was fitted to) is met or not. The classes are counted '
             f'apart: a claim or a self-check never counts as agreement with a number. A departing number whose '
             f'run measured its sensitivity to the robot\'s parameters is sorted, to first order: <em>within model '
             f'uncertainty</em> when the parameters the paper states, each within its stated precision, could '
             f'close it, else <em>implementation or setup</em>; its text gives the smallest single change that '
             f'would close it. '
             f'{"A <strong>--quick</strong> run: every experiment reduced as stated in its table; " if report["quick"] else ""}'
             f'<span class="counts">{escape(counts_text(total))}</span></p>',
             "<nav>" + "".join(f'<a href="#{escape(k)}">{escape(p["title"])}</a>' for k, p in papers.items())
             + '<a href="#metadata">run metadata</a></nav>']
    for key, p in papers.items():
        c = p["counts"]
        parts += [f'<section class="paper" id="{escape(key)}"><h2>{escape(p["title"])}</h2>',
                  f'<p class="src">{escape(p["citation"])} — <code>bipedlab reproduce {escape(key)}</code></p>',
                  f'<p class="counts">{escape(counts_text(c))}</p>', _table(p["rows"])]
        if p["figures"]:
            parts += ["<h3>Figures</h3>", _figures(p["figures"])]
        if p["animations"]:
            parts += ["<h3>Gait animation</h3>", _animations(p["animations"])]
        for n in p["notes"]:
            parts.append(f'<p class="note">{escape(n)}</p>')
        if p.get("gaits"):
            parts += ["<h3>Gaits</h3>", '<p class="note">The gaits the experiments walk, with the figures their design '
                      'produced (speed, step length, c_mt of the designed orbit) beside the paper\'s gait each stands for; '
                      'a row\'s gait is named under its quantity.</p>', _gaits(p["gaits"])]
        parts += ["<h3>Experiments</h3>", _experiments(p["experiments"]), "</section>"]
    meta = [("bipedlab", report["version"]), ("commit", report["commit"] or "not a git checkout"),
            ("JAX", report["jax"]), ("Python", report["python"]), ("device", dev["description"]),
            ("dtype", report["dtype"]), ("--quick", "yes" if report["quick"] else "no"),
            ("wall time", f'{report["wall_s"]:.1f} s'), ("CPU time (this process)", f'{report["cpu_s"]:.1f} s'),
            ("created", report["created"])]
    parts += ['<section id="metadata"><h2>Run metadata</h2><dl class="meta">']
    parts += [f"<dt>{escape(k)}</dt><dd>{escape(str(v))}</dd>" for k, v in meta]
    parts += ["</dl><p class=\"note\">Compile time is the tracing, lowering and XLA compilation JAX reports while an "
              "experiment runs (persistent-cache hits make it small); run time is wall time minus compile time. "
              "report.json holds every row and every experiment's full record.</p></section></body></html>"]
    return "\n".join(parts)
