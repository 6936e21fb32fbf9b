"""Running a report's experiments: one progress display over the whole run, compile and run
time per experiment, and a result cache keyed by a content hash.

The cache key of an experiment hashes the source and data files its result can depend on (the
package without the report's own modules, the other robots' packages and the paper's values
file: :func:`bipedlab.provenance.results_hash`), the experiment's paper, name and arguments,
and the JAX version: re-running with unchanged code and inputs reuses
the stored record and figures (``<cache>/reproduce/<key>/``), so rebuilding a report takes
seconds. The cache folder is ``$BIPEDLAB_CACHE_DIR`` or ``~/.cache/bipedlab``, as for the
compiled programs.

Each experiment's entry is stored the moment the experiment finishes, before the next one
starts (its files in a temporary folder, ``record.json`` fsynced, the folder renamed into
place), so an interrupted run loses at most the experiments that were running. A stored record
carries the id of the run that computed it (``run``): ``use_cache=False`` (``reproduce
--rerun``) recomputes every experiment except those the same run (``run_id``) has already
stored, which is how an interrupted ``--rerun`` resumes (:mod:`bipedlab.report.resume`).
"""
from __future__ import annotations

import hashlib
import json
import os
import shutil
import socket
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional

from bipedlab.outputs import dumps_json, fsync_dir, write_atomic
from bipedlab.provenance import results_hash
from bipedlab.report.spec import Experiment, Paper

COMPILE_EVENTS = ("/jax/core/compile/jaxpr_trace_duration", "/jax/core/compile/jaxpr_to_mlir_module_duration",
                  "/jax/core/compile/backend_compile_duration")
"""JAX monitoring events whose durations count as compile time (tracing, lowering, XLA)."""
KEPT_SUFFIXES = (".png", ".svg", ".html", ".gif")
"""Files of an experiment's output folder that are kept in the cache and copied to the report."""


def cache_root() -> Path:
    base = os.environ.get("BIPEDLAB_CACHE_DIR") or os.path.join(os.path.expanduser("~"), ".cache", "bipedlab")
    return Path(base) / "reproduce"


def robot_package(run: Callable) -> Optional[str]:
    """``"robots/<name>"`` for an experiment function defined in a robot's package, else None."""
    parts = getattr(run, "__module__", "").split(".")
    return "/".join(parts[1:3]) if len(parts) > 2 and parts[:2] == ["bipedlab", "robots"] else None


def _values_file(values: Optional[str]) -> tuple:
    """The paper's values file relative to the package folder (skipped by the key), if inside it."""
    if not values:
        return ()
    import bipedlab

    try:
        return (Path(values).resolve().relative_to(Path(bipedlab.__file__).resolve().parent).as_posix(),)
    except ValueError:
        return ()


def cache_key(paper: str, experiment: str, args: dict, package: Optional[str] = None,
              values: Optional[str] = None, jax_version: Optional[str] = None) -> str:
    """The key of an experiment's stored result. ``package``: the robot package its function
    lives in (:func:`robot_package`), ``values``: the paper's values file; the key changes
    with every file the result can depend on and with none of the others. ``jax_version``:
    the key a run under that JAX would store (default: the JAX at hand)."""
    import jax

    source = results_hash(package, _values_file(values))
    text = json.dumps(dict(source=source, paper=paper, experiment=experiment, args=args,
                           jax=jax_version or jax.__version__, x64=bool(jax.config.jax_enable_x64)),
                      sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


class _CompileClock:
    """Sums JAX's compile-event durations while active (one listener for the process)."""

    total = 0.0
    _registered = False

    @classmethod
    def install(cls) -> None:
        if cls._registered:
            return
        import jax

        def listen(name, duration, **_):
            if name in COMPILE_EVENTS:
                cls.total += float(duration)

        jax.monitoring.register_event_duration_secs_listener(listen)
        cls._registered = True


@dataclass
class Result:
    paper: str
    name: str
    command: str
    args: Optional[dict]
    record: Optional[dict]
    wall_s: float = 0.0
    compile_s: float = 0.0
    cpu_s: float = 0.0
    cached: bool = False
    skipped: Optional[str] = None
    reduction: str = ""
    files: list = field(default_factory=list)   # kept output files (absolute paths in the cache)
    key: str = ""
    resumed: bool = False                        # stored by this same run before it was interrupted

    def summary(self) -> dict:
        return dict(name=self.name, command=self.command, args=self.args, wall_s=self.wall_s,
                    compile_s=self.compile_s, cpu_s=self.cpu_s, cached=self.cached, skipped=self.skipped,
                    reduction=self.reduction or None, cache_key=self.key or None, resumed=self.resumed)


def _fmt_s(s: float) -> str:
    s = max(0.0, float(s))
    return f"{s:.0f} s" if s < 120 else f"{s / 60:.1f} min"


class Progress:
    """One display over the whole run on stderr: experiment k of n, elapsed, expected left.
    With ``jobs`` workers the time left is the expected work left shared among them, scaled by
    how this machine has done so far."""

    def __init__(self, plan: list, say: Callable[[str], None], jobs: int = 1, wall_expected: Optional[float] = None):
        self.plan = plan            # [(paper, Experiment, expected_s)]
        self.say = say
        self.jobs = max(1, int(jobs))
        self.t0 = time.perf_counter()
        self.done_expected = 0.0
        self.total_expected = sum(e for _, _, e in plan)
        self.wall_expected = self.total_expected / self.jobs if wall_expected is None else wall_expected

    def left(self) -> float:
        el = time.perf_counter() - self.t0
        left = max(self.total_expected - self.done_expected, 0.0) / self.jobs
        if self.done_expected > 30.0:  # scale the estimate by how this machine has done so far
            left *= min(max(el * self.jobs / self.done_expected, 0.5), 4.0)
        return left

    def start(self, k: int, label: str, expected: float, cached: bool) -> None:
        el = time.perf_counter() - self.t0
        what = "cached result" if cached else f"expected {_fmt_s(expected)}"
        self.say(f"[{k}/{len(self.plan)}] {label} ({what}); elapsed {_fmt_s(el)}, about {_fmt_s(self.left())} left")

    def finish(self, expected: float) -> None:
        self.done_expected += expected

    def inner(self, label: str) -> Callable[[str], None]:
        def say(msg: str) -> None:
            self.say(f"  {label}: {msg} (elapsed {_fmt_s(time.perf_counter() - self.t0)})")
        return say


def _kept_files(folder: Path) -> list:
    if not folder.is_dir():
        return []
    return sorted(str(p) for p in folder.rglob("*") if p.is_file() and p.suffix.lower() in KEPT_SUFFIXES)


def _stored(where: Path) -> Optional[dict]:
    """The stored entry's record.json, None when absent or damaged."""
    try:
        stored = json.loads((where / "record.json").read_text())
    except (OSError, ValueError):
        return None
    needed = ("record", "wall_s", "compile_s", "cpu_s")
    return stored if isinstance(stored, dict) and all(k in stored for k in needed) else None


def _reusable(stored: Optional[dict], use_cache: bool, run_id: Optional[str]) -> bool:
    return stored is not None and (use_cache or (run_id is not None and stored.get("run") == run_id))


_TMP = ".tmp-"


def _tmp_name(key: str) -> str:
    return f".{key}{_TMP}{socket.gethostname()}-{os.getpid()}"


def clean_stale(root: Optional[Path] = None) -> None:
    """Remove the temporary folders that processes of this host which no longer run left in
    the cache (an experiment interrupted while it ran)."""
    root = cache_root() if root is None else root
    if not root.is_dir():
        return
    mark = f"{_TMP}{socket.gethostname()}-"
    for p in root.iterdir():
        if p.name.startswith(".") and mark in p.name:
            pid = p.name.rpartition("-")[2]
            if pid.isdigit() and not _alive(int(pid)):
                shutil.rmtree(p, ignore_errors=True)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True


def _key(paper: Paper, exp: Experiment, args: dict) -> str:
    return cache_key(paper.key, exp.name, args, robot_package(exp.run), paper.values)


def run_experiment(paper: Paper, exp: Experiment, quick: bool, progress: Callable[[str], None],
                   use_cache: bool = True, run_id: Optional[str] = None) -> Result:
    """Run one experiment (or take its stored result): the record, times and kept files.
    ``use_cache=False`` reuses only an entry stored by the run ``run_id`` (``resumed``); the
    entry stored here carries ``run_id``."""
    args = exp.args(quick)
    res = Result(paper.key, exp.name, exp.command, args, None, reduction=exp.reduction if quick else "")
    if args is None:
        res.skipped = exp.skip_reason
        return res
    key = _key(paper, exp, args)
    res.key = key
    root = cache_root()
    where = root / key
    stored = _stored(where)  # a damaged entry is recomputed
    if _reusable(stored, use_cache, run_id):
        res.record = stored["record"]
        res.wall_s, res.compile_s, res.cpu_s = stored["wall_s"], stored["compile_s"], stored["cpu_s"]
        res.cached = True
        res.resumed = run_id is not None and stored.get("run") == run_id
        res.files = _kept_files(where / "out")
        return res
    _CompileClock.install()
    tmp = root / _tmp_name(key)
    shutil.rmtree(tmp, ignore_errors=True)
    (tmp / "out").mkdir(parents=True)
    c0, t0, p0 = _CompileClock.total, time.perf_counter(), time.process_time()
    try:
        record = exp.run(args, str(tmp / "out"), progress)
        res.wall_s = time.perf_counter() - t0
        res.cpu_s = time.process_time() - p0
        res.compile_s = _CompileClock.total - c0
        # paths the study wrote into its record name the temporary folder: name the stored one
        res.record = json.loads(dumps_json(record).replace(json.dumps(str(tmp))[1:-1], json.dumps(str(where))[1:-1]))
        for p in (tmp / "out").rglob("*"):  # keep the figures, drop the bulky data files
            if p.is_file() and p.suffix.lower() not in KEPT_SUFFIXES:
                p.unlink()
        text = dumps_json(dict(record=res.record, wall_s=res.wall_s, compile_s=res.compile_s, cpu_s=res.cpu_s,
                               args=args, paper=paper.key, experiment=exp.name, run=run_id))
        write_atomic(tmp / "record.json", lambda fh: fh.write(text.encode()))
        shutil.rmtree(where, ignore_errors=True)
        os.replace(tmp, where)
        fsync_dir(root)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    res.files = _kept_files(where / "out")
    return res


def plan(papers: list, quick: bool) -> list:
    """[(paper, experiment, expected seconds)] in run order."""
    out = []
    for p in papers:
        for e in p.experiments:
            if e.args(quick) is not None:
                out.append((p, e, e.quick_expected_s if quick else e.expected_s))
    return out


def run_all(papers: list, quick: bool, say: Callable[[str], None], use_cache: bool = True,
            only: Optional[set] = None, jobs: int = 1, run_id: Optional[str] = None) -> dict:
    """Run every experiment of ``papers``: {paper key: [Result, ...]} (skipped ones included).
    ``only``: names "paper/experiment" to run (the others are reported as not run). ``jobs`` > 1
    runs the papers side by side in that many worker processes (:mod:`bipedlab.report.workers`;
    the units :func:`work_groups`) when more than one unit has work to do; otherwise everything
    runs in this process.
    ``run_id`` marks the entries this run stores; with ``use_cache=False`` the entries it
    stored before an interruption are still reused (see :func:`run_experiment`)."""
    from bipedlab.report import workers

    clean_stale()
    steps = [(p, e, x) for p, e, x in plan(papers, quick) if only is None or f"{p.key}/{e.name}" in only]
    cached = {(p.key, e.name): root_has(p, e, quick, use_cache, run_id) for p, e, _ in steps}
    steps_expected = [(p, e, 1.0 if cached[(p.key, e.name)] else x) for p, e, x in steps]
    groups = work_groups([(p.key, e.name, x) for p, e, x in steps_expected])
    jobs = max(1, min(int(jobs), sum(1 for key, _, names in groups if not all(cached[(key, n)] for n in names))))
    prog = Progress(steps_expected, say, jobs=jobs, wall_expected=workers.makespan([x for _, x, _ in groups], jobs))
    if not all(cached.values()):
        say(f"reproducing {len(papers)} paper(s), {len(steps)} experiment(s)"
            f"{' (--quick)' if quick else ''}{f' in {jobs} processes' if jobs > 1 else ''}: expected duration "
            f"about {_fmt_s(prog.wall_expected)} from an empty compile cache on a two-core CPU")
    selected = {(p.key, e.name): x for p, e, x in steps_expected}
    done: dict = {}
    counter = [0]

    def started(key: str, name: str) -> None:
        counter[0] += 1
        prog.start(counter[0], f"{key}: {name}", selected[(key, name)], cached[(key, name)])

    def finished(key: str, name: str, r: "Result") -> None:
        prog.finish(selected[(key, name)])
        label = f"{key}: {name}"
        say(f"  {label}: finished before the interruption (a {_fmt_s(r.wall_s)} run)" if r.resumed else
            f"  {label}: stored result of a {_fmt_s(r.wall_s)} run" if r.cached else
            f"  {label}: done in {_fmt_s(r.wall_s)}, compile {_fmt_s(r.compile_s)}")
        done[(key, name)] = r

    if jobs > 1:
        workers.run(groups, quick, use_cache, jobs, on_start=started, run_id=run_id,
                    on_say=lambda label, msg: prog.inner(label)(msg), on_done=finished)
    else:
        for p, e, _ in steps:
            started(p.key, e.name)
            finished(p.key, e.name, run_experiment(p, e, quick, prog.inner(f"{p.key}: {e.name}"), use_cache=use_cache,
                                                   run_id=run_id))
    results: dict = {p.key: [] for p in papers}
    for p in papers:
        for e in p.experiments:
            if (p.key, e.name) in done:
                results[p.key].append(done[(p.key, e.name)])
                continue
            r = Result(p.key, e.name, e.command, e.args(quick), None, reduction=e.reduction if quick else "")
            r.skipped = e.skip_reason if e.args(quick) is None else "not selected in this run"
            results[p.key].append(r)
    return results


def work_groups(todo: list) -> list:
    """The units of work of a run side by side: [(paper key, expected seconds, [experiment
    names])] from ``todo`` [(paper key, experiment name, expected seconds to compute)], one per
    paper (its experiments share a process's compiled programs), except an experiment expected
    to take longer than the rest of its paper together, which is a unit of its own (so that a
    paper with one long experiment runs beside itself)."""
    by: dict = {}
    for key, name, x in todo:
        by.setdefault(key, []).append((name, x))
    out = []
    for key, items in by.items():
        total = sum(x for _, x in items)
        long = [(n, x) for n, x in items if len(items) > 1 and x > total - x]
        for n, x in long:
            out.append((key, x, [n]))
        rest = [(n, x) for n, x in items if (n, x) not in long]
        if rest:
            out.append((key, sum(x for _, x in rest), [n for n, _ in rest]))
    return out


def root_has(paper: Paper, exp: Experiment, quick: bool, use_cache: bool = True, run_id: Optional[str] = None) -> bool:
    """Whether the cache holds an entry :func:`run_experiment` would reuse."""
    args = exp.args(quick)
    return args is not None and _reusable(_stored(cache_root() / _key(paper, exp, args)), use_cache,
                                          run_id)


def stored_by(run_id: str, papers: list, quick: bool, only: Optional[set] = None) -> list:
    """"paper/experiment" of every planned experiment whose stored entry the run ``run_id``
    computed (what an interrupted run had finished)."""
    return [f"{p.key}/{e.name}" for p, e, _ in plan(papers, quick)
            if (only is None or f"{p.key}/{e.name}" in only) and root_has(p, e, quick, False, run_id)]
