"""First-run benchmark of the studies: what a researcher meets the first time a command runs.

Every command may declare short versions of itself (``Command.bench``: argument lists). For
each, :func:`run` starts the command twice in a fresh Python process: first with an empty
compilation cache (cold), then again with the cache the first run filled (warm). The child
(:func:`child`) listens to JAX's own monitoring events and reports

* ``compile_s``: seconds spent tracing, lowering and compiling (or loading compiled programs
  from the cache): the sum of JAX's ``jaxpr_trace``, ``jaxpr_to_mlir_module`` and
  ``backend_compile`` durations;
* ``run_s``: the rest of the wall time (imports, running, writing);
* ``programs_compiled`` / ``programs_from_cache``: XLA programs compiled by XLA in the process,
  and programs loaded from the persistent cache instead (the studies keep every program there,
  see :mod:`bipedlab.compilecache`, so a warm run compiles none);
* ``programs_lowered``, ``largest_program`` and ``largest_program_eqns``: the programs lowered
  to XLA, and the one with the most jaxpr equations (counted through every sub-jaxpr: loop
  bodies, branches, inner jits) with its count: the size of what XLA has to compile;
* ``slowest_programs``: the five programs that took longest to compile or load, with their
  seconds and equations;
* ``peak_rss_mb``: the study process's own peak resident memory (``VmHWM``).

Nothing here names a robot: the studies are whatever the registered commands declare.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass

_TRACE = "/jax/core/compile/jaxpr_trace_duration"
_LOWER = "/jax/core/compile/jaxpr_to_mlir_module_duration"
_BACKEND = "/jax/core/compile/backend_compile_duration"
_CACHE_HIT = "/jax/compilation_cache/cache_hits"


def count_eqns(jaxpr) -> int:
    """Equations of a jaxpr (or closed jaxpr) counted through every sub-jaxpr it holds (loop
    bodies and conditions, branches, inner jits, custom derivative rules)."""
    from jax.extend import core as jcore

    jaxpr = getattr(jaxpr, "jaxpr", jaxpr)
    n = 0
    for eqn in jaxpr.eqns:
        n += 1
        for v in eqn.params.values():
            for sub in (v if isinstance(v, (tuple, list)) else (v,)):
                if isinstance(sub, (jcore.Jaxpr, jcore.ClosedJaxpr)):
                    n += count_eqns(sub)
    return n


def _watch_lowering(sizes: list) -> None:
    """Record (name, equations) of every program JAX lowers to XLA; silently does nothing on a
    JAX version that lowers elsewhere."""
    try:
        from jax._src.interpreters import pxla
    except ImportError:
        return
    lower = getattr(pxla, "lower_sharding_computation", None)
    if lower is None:
        return

    def watched(closed_jaxpr, api_name, fun_name, *args, **kwargs):
        try:
            sizes.append((str(fun_name), count_eqns(closed_jaxpr)))
        except Exception:  # noqa: BLE001 - a count is informative, never worth a failed study
            sizes.append((str(fun_name), None))
        return lower(closed_jaxpr, api_name, fun_name, *args, **kwargs)

    pxla.lower_sharding_computation = watched


@dataclass(frozen=True)
class Study:
    """One short study: its command line words (e.g. ``("walk", "mabel", "--steps", "3")``) and
    whether it is long (run only when named)."""

    argv: tuple
    long: bool = False

    @property
    def name(self) -> str:
        return " ".join(self.argv)


def studies(commands=None) -> list[Study]:
    """The short studies declared by the registered commands, in listing order."""
    from bipedlab import registry

    out = []
    for c in commands if commands is not None else registry.commands():
        words = [c.verb] + ([c.robot] if c.robot else [])
        for extra in c.bench:
            long = bool(extra) and extra[0] == "long"
            out.append(Study(tuple(words) + tuple(extra[1:] if long else extra), long))
    return out


def select(names, available: list[Study]) -> list[Study]:
    """The studies to run: every short (not long) study when ``names`` is empty; otherwise those
    whose name starts with one of ``names`` (``walk`` selects every walk, ``walk five`` the
    five-link biped's).
    ValueError naming the first name that selects nothing."""
    if not names:
        return [s for s in available if not s.long]
    chosen = []
    for n in names:
        hit = [s for s in available if s.name.startswith(n.strip())]
        if not hit:
            raise ValueError(f"--studies: {n!r} names no study; studies: " + "; ".join(s.name for s in available))
        chosen += [s for s in hit if s not in chosen]
    return chosen


# ----------------------------------------------------------------------------- child process
def child(stats_path: str, argv: list[str]) -> int:
    """Run ``bipedlab argv`` in this process with JAX's monitoring listeners installed; write
    the figures of the module docstring to ``stats_path`` (JSON). Returns the command's exit
    status."""
    t0 = time.perf_counter()

    import jax
    from jax import monitoring

    durations = {_TRACE: 0.0, _LOWER: 0.0, _BACKEND: 0.0}
    counts = {_BACKEND: 0, _CACHE_HIT: 0}
    compiles: list = []  # (name, seconds) per backend compile or cache load
    sizes: list = []  # (name, equations) per lowered program

    def on_duration(event: str, secs: float, fun_name=None, **_):
        if event in durations:
            durations[event] += secs
        if event in counts:
            counts[event] += 1
        if event == _BACKEND:
            compiles.append((str(fun_name), secs))

    def on_event(event: str, **_):
        if event in counts:
            counts[event] += 1

    monitoring.register_event_duration_secs_listener(on_duration)
    monitoring.register_event_listener(on_event)
    _watch_lowering(sizes)
    from bipedlab import cli, outputs

    t_import = time.perf_counter() - t0
    with open(os.devnull, "w") as sink:
        saved, sys.stdout = sys.stdout, sink
        try:
            code = cli.main(list(argv))
        except SystemExit as e:  # bad input: argparse exits
            code = int(e.code or 0)
        finally:
            sys.stdout = saved
    wall = time.perf_counter() - t0
    compile_s = durations[_TRACE] + durations[_LOWER] + durations[_BACKEND]
    rec = dict(
        exit_status=code, wall_s=wall, import_s=t_import, compile_s=compile_s, run_s=wall - compile_s,
        trace_s=durations[_TRACE], lower_s=durations[_LOWER], backend_compile_s=durations[_BACKEND],
        programs_compiled=counts[_BACKEND] - counts[_CACHE_HIT], programs_from_cache=counts[_CACHE_HIT],
        peak_rss_mb=_peak_rss_mb(),
        jax_version=jax.__version__,
        **_program_figures(compiles, sizes),
    )
    with open(stats_path, "w") as f:
        outputs.dump_json(rec, f)
    return code


def _peak_rss_mb() -> float:
    """This process's own peak resident memory (MB): the high-water mark of its address space
    (``VmHWM``). ``getrusage``'s ``ru_maxrss`` survives fork and exec, so a study launched from a
    large process (a test worker) would report the launcher's memory instead of its own."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return float(line.split()[1]) / 1024.0
    except OSError:
        pass
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _program_figures(compiles: list, sizes: list) -> dict:
    """The per-program figures of the record from the (name, seconds) compiles and the
    (name, equations) lowerings, matched by name in order (JAX lowers a program, then compiles it)."""
    counted = [n for _, n in sizes if n is not None]
    largest = max((s for s in sizes if s[1] is not None), key=lambda s: s[1], default=(None, None))
    pending: dict = {}
    for name, n in sizes:
        pending.setdefault(name, []).append(n)
    def lowered_name(name: str) -> str:  # the compile event says jit(f) where the lowering says f
        return name[4:-1] if name.startswith("jit(") and name.endswith(")") else name

    rows = [dict(name=name, seconds=secs, eqns=(pending.get(lowered_name(name)) or [None]).pop(0))
            for name, secs in compiles]
    rows.sort(key=lambda r: -r["seconds"])
    return dict(programs_lowered=len(sizes), largest_program=largest[0], largest_program_eqns=largest[1],
                total_eqns=sum(counted), slowest_programs=rows[:5])


def _one(argv: tuple, cache: str, timeout: float | None) -> dict:
    fd, stats = tempfile.mkstemp(suffix=".json", prefix="bipedlab-studybench-")
    os.close(fd)
    env = dict(os.environ, BIPEDLAB_CACHE_DIR=cache, BIPEDLAB_XLA_CACHE_DIR=cache)  # its own programs too
    cmd = [sys.executable, "-m", "bipedlab.studybench", "--child", stats, "--", *argv]
    try:
        p = subprocess.run(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                           timeout=timeout)
        err = p.stderr.strip().splitlines()
        try:
            with open(stats) as f:
                rec = json.load(f)
        except (OSError, ValueError):
            rec = dict(exit_status=p.returncode)
        if rec.get("exit_status"):
            rec["error"] = err[-1] if err else f"exit status {p.returncode}"
        return rec
    except subprocess.TimeoutExpired:
        return dict(exit_status=None, error=f"did not finish within {timeout:g} s")
    finally:
        os.unlink(stats)


def run(chosen: list[Study], warm: bool = True, timeout: float | None = None, progress=None) -> dict:
    """Run each study cold (empty cache) and, with ``warm``, again warm; returns the record."""
    import platform

    import jax

    say = progress or (lambda m: None)
    rows = []
    t0 = time.perf_counter()
    for i, s in enumerate(chosen):
        cache = tempfile.mkdtemp(prefix="bipedlab-studybench-cache-")
        try:
            say(f"[{i + 1}/{len(chosen)}] {s.name}: cold (empty compilation cache)")
            row = dict(study=s.name, argv=list(s.argv), cold=_one(s.argv, cache, timeout))
            if warm and not row["cold"].get("exit_status"):
                say(f"[{i + 1}/{len(chosen)}] {s.name}: warm")
                row["warm"] = _one(s.argv, cache, timeout)
            rows.append(row)
            c = row["cold"]
            if "compile_s" in c:
                say(f"    cold: compile {c['compile_s']:.1f} s, run {c['run_s']:.1f} s, "
                    f"{c['programs_compiled']} programs, peak {c['peak_rss_mb']:.0f} MB")
        finally:
            shutil.rmtree(cache, ignore_errors=True)
    return dict(kind="studies", studies=rows, cpu=_cpu_name(), cores=os.cpu_count(), platform=platform.platform(),
                jax_version=jax.__version__, wall_s=time.perf_counter() - t0)


def _cpu_name() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    import platform

    return platform.processor() or platform.machine()


def summary(r: dict) -> str:
    lines = [f"first-run benchmark of the studies on {r['cpu']} ({r['cores']} cores), JAX {r['jax_version']}",
             f"{'study':<44} {'':>5} {'compile s':>9} {'run s':>7} {'programs':>8} {'cached':>6} {'peak MB':>8} "
             f"{'largest eqns':>12}"]
    for row in r["studies"]:
        for kind in ("cold", "warm"):
            c = row.get(kind)
            if c is None:
                continue
            name = row["study"] if kind == "cold" else ""
            if "compile_s" not in c or c.get("exit_status"):
                lines.append(f"{name:<44} {kind:>5} failed: {c.get('error', '')}")
                continue
            lines.append(f"{name:<44} {kind:>5} {c['compile_s']:9.1f} {c['run_s']:7.1f} {c['programs_compiled']:8d} "
                         f"{c['programs_from_cache']:6d} {c['peak_rss_mb']:8.0f} {c.get('largest_program_eqns') or 0:12d}")
    lines.append(f"total {r['wall_s']:.0f} s")
    return "\n".join(lines)


def _main(argv: list[str]) -> int:
    if len(argv) >= 3 and argv[0] == "--child" and argv[2] == "--":
        return child(argv[1], argv[3:])
    print("usage: python -m bipedlab.studybench --child STATS.json -- <bipedlab arguments>", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(_main(sys.argv[1:]))
