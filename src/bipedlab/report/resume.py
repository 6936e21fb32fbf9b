"""Resuming an interrupted ``bipedlab reproduce``.

Every experiment's result is stored in the result cache the moment it finishes, before the
next experiment starts (:mod:`bipedlab.report.runner`), so an interruption (SIGINT, SIGTERM, a
killed process) loses only the experiments that were running. What a run adds is
``DIR/progress.json``, written in place (not staged with the report) when the run starts: the
run's arguments (papers, ``--quick``, ``--rerun``, ``--only``), a run id that every entry it
stores carries, and ``"complete": false``. The complete version is staged with the report, so
it replaces the other only once the report is in place.

The same command run again after an interruption finds an incomplete ``progress.json`` of the
same arguments and takes over its run id: the experiments the interrupted run stored are
reused, also under ``--rerun`` (which recomputes every other experiment: a resumed ``--rerun``
finishes the one recomputation, it does not start another), and named. A finished run, or an
interrupted one with other arguments (said so), starts a new run: under ``--rerun`` every
experiment is computed again, without it every stored result is reused as always.
"""
from __future__ import annotations

import json
import os
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

from bipedlab.outputs import dumps_json, write_atomic

FILE = "progress.json"
FORMAT = 1


@dataclass
class Run:
    """A reproduction run: its id, arguments, when it started, what an interrupted run it
    resumes had finished ("paper/experiment"), and a line to show (None: nothing to say)."""

    id: str
    arguments: dict
    started: str
    resumed: list = field(default_factory=list)
    note: Optional[str] = None

    def progress(self, complete: bool) -> dict:
        return dict(format=FORMAT, run=self.id, arguments=self.arguments, started=self.started, complete=complete)


def arguments(papers: list, quick: bool, rerun: bool, only: Optional[set]) -> dict:
    """What makes two runs the same run: the papers (keys), --quick, --rerun and --only."""
    return dict(papers=[p.key for p in papers], quick=bool(quick), rerun=bool(rerun),
                only=sorted(only) if only else None)


def _read(path: Path) -> Optional[dict]:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and isinstance(data.get("run"), str) else None


def _write(path: Path, data: dict) -> None:
    text = dumps_json(data, indent=1, sort_keys=True)
    write_atomic(path, lambda fh: fh.write(text.encode()))


def _changes(then: dict, now: dict) -> str:
    keys = sorted(k for k in set(then) | set(now) if then.get(k) != now.get(k))
    return "; ".join(f"{k}: {json.dumps(then.get(k))} then, {json.dumps(now.get(k))} now" for k in keys)


def begin(folder, args: dict, papers: list, quick: bool, only: Optional[set]) -> Run:
    """Start or resume the run whose report goes to ``folder`` (the final ``--out``), writing
    ``folder/progress.json`` for a new run (the folder created if needed)."""
    from bipedlab.report import runner

    folder = Path(folder)
    old = _read(folder / FILE)
    if old is not None and not old.get("complete") and old.get("arguments") == args:
        run = Run(old["run"], args, str(old.get("started", "")))
        run.resumed = runner.stored_by(run.id, papers, quick, only)
        done = (f"{len(run.resumed)} experiment(s) it finished are taken as stored: {', '.join(run.resumed)}"
                if run.resumed else "none of its experiments had finished")
        run.note = f"resuming the interrupted run in {folder} (started {run.started}): {done}"
        return run
    run = Run(uuid.uuid4().hex, args, time.strftime("%Y-%m-%d %H:%M:%S"))
    if old is not None and not old.get("complete"):
        again = "every experiment is computed again (--rerun)" if args["rerun"] else "stored results are reused"
        run.note = (f"{folder} holds an interrupted run with other arguments ({_changes(old.get('arguments') or {}, args)})"
                    f"; starting a new run: {again}")
    os.makedirs(folder, exist_ok=True)
    _write(folder / FILE, run.progress(complete=False))
    return run


def finish(staged, run: Run) -> None:
    """Stage the complete ``progress.json`` with the report (under ``staged``, the folder the
    report is written to), so that it replaces the incomplete one with the report."""
    _write(Path(staged) / FILE, run.progress(complete=True))
