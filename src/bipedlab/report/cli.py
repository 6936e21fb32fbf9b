"""The core's own command: ``bipedlab reproduce [PAPER ...] [--quick] [--out DIR] [--json]``.

The papers are those the robot packages register (:mod:`bipedlab.report.registry`); every
paper's experiments run in one process (several papers side by side in worker processes,
``--jobs``), each result stored under a content hash, and the report is written to DIR (default ``./bipedlab-report``): index.html,
report.json and the figures.

Each experiment's result is stored the moment it finishes; the same command run again after an
interruption resumes the run, reusing what it finished, also under ``--rerun``
(:mod:`bipedlab.report.resume`; ``DIR/progress.json`` says which run DIR holds).
"""
from __future__ import annotations

import argparse
import os
import time

from bipedlab.commands import Command, UsageError, add_out, int_in, text

DEFAULT_OUT = "bipedlab-report"


def paper_name(value: str) -> str:
    """argparse type of a PAPER word: non-empty text (checked against the registered papers by
    the command's validate)."""
    return text(value)


def _arguments(p) -> None:
    p.add_argument("papers", nargs="*", type=paper_name, metavar="PAPER",
                   help="papers to reproduce (default: all); `bipedlab reproduce --list` names them")
    p.add_argument("--quick", action="store_true",
                   help="a reduced version of every experiment (fewer steps, trials, hops; a reduced sysid design), "
                        "each reduction stated in the report")
    p.add_argument("--rerun", action="store_true", help="run every experiment again instead of reusing stored results")
    p.add_argument("--list", action="store_true", help="list the papers and their experiments, run nothing")
    p.add_argument("--jobs", type=int_in(1, 64), default=None,
                   help="worker processes that run papers side by side, an experiment longer than the rest of its "
                        "paper in a worker of its own (default: one per core; 1 runs everything in this process)")
    p.add_argument("--only", type=text, action="append", default=None, metavar="PAPER/EXPERIMENT",
                   help=argparse.SUPPRESS)
    p.add_argument("--check", action="store_true",
                   help="run the quick reproduction (implies --quick) and say whether a published report's quick "
                        "rows still match it, row by row (exit status 1 if any differs)")
    p.add_argument("--published", type=text, default=None, metavar="DIR",
                   help="--check: the published report's folder, holding quick.json (default: the source checkout's "
                        "docs/report)")
    add_out(p, "index.html, report.json and the figures (default ./bipedlab-report)")
    p.set_defaults(out=DEFAULT_OUT)


def _known():
    from bipedlab.report import registry

    return registry.papers()


def _validate(args) -> None:
    if args.published is not None and not args.check:
        raise UsageError("--published applies with --check")
    if args.check:
        if args.list:
            raise UsageError("--check runs the quick reproduction; --list runs nothing")
        from bipedlab.report import check

        args.quick = True
        try:
            args._published = check.load(args.published or check.default_folder())
        except check.CheckError as e:
            raise UsageError(f"--check: {e}") from None
    if args.list:
        args.out = None  # a listing writes nothing
    known = _known()
    bad = [k for k in args.papers if k not in known]
    if bad:
        raise UsageError(f"unknown paper {bad[0]!r}; choose from {', '.join(known)}")
    chosen = [k for k in known if not args.papers or k in args.papers]
    for item in args.only or []:
        paper, sep, name = item.partition("/")
        if not sep or paper not in chosen or name not in [e.name for e in known[paper].experiments]:
            raise UsageError(f"--only {item!r}: expected PAPER/EXPERIMENT among the chosen papers' experiments")
        if known[paper].experiment(name).args(args.quick) is None:
            raise UsageError(f"--only {item!r}: not run {'with' if args.quick else 'without'} --quick")


def listing(known) -> str:
    lines = []
    for k, p in known.items():
        lines.append(f"{k}: {len(p.experiments)} experiments")
        for e in p.experiments:
            q = "skipped in --quick" if e.quick_args is None else f"--quick: {e.reduction or 'as in the full run'}"
            lines.append(f"  {e.name:<18} {e.command}  ({q})")
    return "\n".join(lines)


def _cpu_s() -> float:
    """CPU seconds of this process and of its finished worker processes."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def _run(args, progress):
    from bipedlab.report import build, runner

    known = _known()
    if args.list:
        return dict(papers={k: [e.name for e in p.experiments] for k, p in known.items()}), lambda r: listing(known)
    papers = [p for k, p in known.items() if not args.papers or k in args.papers]
    t0, c0 = time.perf_counter(), _cpu_s()
    only = set(args.only) if args.only else None
    from bipedlab.outputs import final_path
    from bipedlab.report import resume, workers

    run = resume.begin(final_path(args.out), resume.arguments(papers, args.quick, args.rerun, only), papers,
                       args.quick, only)
    if run.note:
        progress(run.note)
    jobs = args.jobs if args.jobs is not None else workers.default_jobs()
    results = runner.run_all(papers, args.quick, progress, use_cache=not args.rerun, only=only, jobs=jobs,
                             run_id=run.id)
    wall, cpu = time.perf_counter() - t0, _cpu_s() - c0
    progress("writing the report")
    report = build.build(papers, results, args.quick, args.out, wall, cpu)
    resume.finish(args.out, run)
    report["index_html"] = f"{args.out}/index.html"
    report["report_json"] = f"{args.out}/report.json"
    if args.check:
        from bipedlab.report import check

        report["check"] = check.compare(args._published, report, [p.key for p in papers])
        try:  # the experiments the published page holds under other result keys than the code's
            report["check"]["stale"] = sorted({f"{s['paper']}/{s['experiment']}" for s in
                                               check.stale(args.published or check.default_folder())
                                               if s["paper"] in {p.key for p in papers}})
        except check.CheckError:
            report["check"]["stale"] = None  # a folder without the full run's report.json
    return report, summary


def summary(report: dict) -> str:
    from bipedlab.report.html import counts_text

    lines = []
    for k, p in report["papers"].items():
        c = p["counts"]
        run = [e for e in p["experiments"] if not e["skipped"]]
        lines.append(f"{k:<15} {counts_text(c)} ({len(run)} experiments, "
                     f"{sum(e['wall_s'] for e in run):.0f} s of study time)")
    lines.append(f"report: {report['index_html']} (and report.json); {report['wall_s']:.0f} s wall, "
                 f"{report['cpu_s']:.0f} s CPU{', --quick' if report['quick'] else ''}")
    if "check" in report:
        from bipedlab.report import check

        lines.append(check.summary(report["check"]))
    return "\n".join(lines)


def exit_status(report: dict) -> int:
    """1 where ``--check`` found a row that differs from the published report, else 0."""
    return int("check" in report and not report["check"]["matches"])


COMMANDS = [
    Command("reproduce", None, "reproduce the four papers in one run: tables beside the papers' numbers, figures, "
            "animations, one HTML report", _arguments, _run, validate=_validate, exit_status=exit_status),
]
