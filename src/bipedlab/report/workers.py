"""Running a report's experiments in several processes.

Compiling dominates a first run, and XLA compiles one program on one core, so a two-core CPU
finishes two papers side by side in about the time of the longer one. The unit of work is a
paper: its experiments run in one worker process, in order, sharing that process's compiled
programs (a paper's walks reuse one compiled loop) and the persistent compilation cache; an
experiment expected to take longer than the rest of its paper together is a unit of its own
(:func:`bipedlab.report.runner.work_groups`). The units are dealt to the workers longest first (by their expected times), each worker takes the
next paper when it is free, and every message goes back to the parent, which keeps the one
progress display.

Workers are started with ``spawn`` (a fresh interpreter: no JAX state is inherited) and report
through a queue; a worker that dies is reported as a failed experiment, not a hang. A worker
stores each experiment's result in the cache itself, before it starts the next, and ends as
soon as the parent is gone (interrupted, killed): an interrupted run leaves no worker behind.
"""
from __future__ import annotations

import multiprocessing as mp
import os
import queue as queue_module
import time
from typing import Callable, Optional

START, SAY, DONE, FAIL, IDLE = "start", "say", "done", "fail", "idle"


def default_jobs() -> int:
    """One worker per core, at least one."""
    return max(1, os.cpu_count() or 1)


def _end_with_parent(parent: int, poll_s: float = 0.5) -> None:
    """End this process (no teardown) once its parent process is gone."""
    import threading

    def watch():
        while os.getppid() == parent:
            time.sleep(poll_s)
        os._exit(1)

    threading.Thread(target=watch, name="bipedlab-parent-watch", daemon=True).start()


def _worker(tasks, quick: bool, use_cache: bool, messages, run_id: Optional[str] = None,
            parent: Optional[int] = None) -> None:
    """Run papers from ``tasks`` ([paper key, [experiment names]] or None to stop)."""
    from bipedlab import compilecache
    from bipedlab.report import registry, runner

    if parent is not None:
        _end_with_parent(parent)
    compilecache.enable()
    known = registry.papers()
    while True:
        task = tasks.get()
        if task is None:
            messages.put((IDLE, os.getpid()))
            return
        key, names = task
        paper = known[key]
        for name in names:
            exp = paper.experiment(name)
            messages.put((START, key, name))
            label = f"{key}: {name}"
            try:
                res = runner.run_experiment(paper, exp, quick, lambda msg, label=label: messages.put((SAY, label, msg)),
                                            use_cache=use_cache, run_id=run_id)
            except BaseException as e:  # noqa: BLE001  (reported to the parent, which raises it)
                messages.put((FAIL, key, name, f"{type(e).__name__}: {e}"))
                return
            messages.put((DONE, key, name, res))


def deal(groups: list) -> list:
    """Groups [(key, expected seconds, payload)] in the order a pool of workers should take
    them: longest first (the longest-processing-time rule)."""
    return sorted(groups, key=lambda g: -g[1])


def makespan(expected: list, jobs: int) -> float:
    """Expected wall time of ``expected`` group times on ``jobs`` workers that each take the
    next group, longest first, when free."""
    loads = [0.0] * max(1, jobs)
    for x in sorted(expected, reverse=True):
        loads[loads.index(min(loads))] += x
    return max(loads)


def run(groups: list, quick: bool, use_cache: bool, jobs: int, on_start: Callable[[str, str], None],
        on_say: Callable[[str, str], None], on_done: Callable[[str, str, object], None],
        poll_s: float = 1.0, run_id: Optional[str] = None) -> None:
    """Run ``groups`` — [(paper key, expected seconds, [experiment names])] — on ``jobs``
    worker processes, calling back in the parent as experiments start, talk and finish.
    Raises RuntimeError if an experiment fails or a worker dies."""
    ctx = mp.get_context("spawn")
    tasks, messages = ctx.Queue(), ctx.Queue()
    order = deal(groups)
    for key, _, names in order:
        tasks.put((key, list(names)))
    n = min(jobs, len(order))
    for _ in range(n):
        tasks.put(None)
    procs = [ctx.Process(target=_worker, args=(tasks, quick, use_cache, messages, run_id, os.getpid()), daemon=True)
             for _ in range(n)]
    for p in procs:
        p.start()
    remaining = sum(len(names) for _, _, names in order)
    idle = 0
    error: Optional[str] = None
    try:
        while (remaining and error is None) or idle < n:
            try:
                msg = messages.get(timeout=poll_s)
            except queue_module.Empty:
                if any(not p.is_alive() and p.exitcode not in (0, None) for p in procs):
                    error = error or "a reproduce worker process died (exit codes " + \
                        ", ".join(str(p.exitcode) for p in procs) + ")"
                    break
                if error is None and remaining == 0 and all(not p.is_alive() for p in procs):
                    break
                continue
            kind = msg[0]
            if kind == START:
                on_start(msg[1], msg[2])
            elif kind == SAY:
                on_say(msg[1], msg[2])
            elif kind == DONE:
                remaining -= 1
                on_done(msg[1], msg[2], msg[3])
            elif kind == FAIL:
                error = f"{msg[1]}: {msg[2]} failed: {msg[3]}"
                break
            elif kind == IDLE:
                idle += 1
    finally:
        for p in procs:
            if p.is_alive() and error is not None:
                p.terminate()
        deadline = time.monotonic() + 10.0
        for p in procs:
            p.join(timeout=max(0.1, deadline - time.monotonic()))
            if p.is_alive():
                p.terminate()
    if error is not None:
        raise RuntimeError(error)
