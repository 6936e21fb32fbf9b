"""The robustness engine: sample the trials, run them in sharded chunks, gather, summarise,
write the NPZ and figures (see the package docstring for the contract)."""
from __future__ import annotations

import contextlib
import dataclasses
import math
import os
import sys
import time
from typing import Callable

import jax
import numpy as np

from bipedlab.robustness import distributed as dist
from bipedlab.sim.loop import FELL, NONFINITE, OK, STATUS_NAMES


@dataclasses.dataclass(frozen=True)
class Axis:
    """One axis of the survival map: the sampled parameter ``name`` over [lo, hi] in ``bins``
    cells, in ``unit``; ``label`` for the figures (default: name)."""

    name: str
    lo: float
    hi: float
    bins: int = 10
    unit: str = ""
    label: str = ""

    def edges(self) -> np.ndarray:
        return np.linspace(self.lo, self.hi, self.bins + 1)

    def centers(self) -> np.ndarray:
        e = self.edges()
        return 0.5 * (e[1:] + e[:-1])

    def title(self) -> str:
        return (self.label or self.name) + (f" ({self.unit})" if self.unit else "")


@dataclasses.dataclass(frozen=True)
class Study:
    """A robustness study.

    name: shown in the progress bar, the summary and the figures' titles.
    trial(params) -> dict: one trial, pure JAX (vmapped and sharded by the engine); returns
        ``status`` (int code), ``completed`` (int) and any further per-trial values.
    sample(rng, n) -> {name: (n, ...) array}: the trials' parameters (host, deterministic in the
        generator's seed).
    horizon: units a surviving trial completes (steps, hops, strides); ``unit`` names them.
    axes: the survival map's axes (one or two :class:`Axis` over entries of the sample).
    chunk: trials per device per compiled call.
    describe(params, outcomes) -> dict: optional study-specific entries of the record.
    figures(out_dir, params, outcomes) -> [paths]: optional extra figures.
    """

    name: str
    trial: Callable
    sample: Callable
    horizon: int
    axes: tuple = ()
    unit: str = "steps"
    chunk: int = 16
    describe: Callable | None = None
    figures: Callable | None = None


def uniform(rng: np.random.Generator, n: int, axes) -> dict:
    """Independent uniform draws of every axis over its range: {name: (n,) float64}."""
    return {a.name: rng.uniform(a.lo, a.hi, n) for a in axes}


def grid(n: int, axes) -> dict:
    """``n`` trials on the cell centres of the axes' lattice, visited in order and repeated
    (so any n covers the map as evenly as it can): {name: (n,) float64}."""
    mesh = np.meshgrid(*[a.centers() for a in axes], indexing="ij")
    flat = [m.ravel() for m in mesh]
    idx = np.arange(n) % flat[0].size
    return {a.name: f[idx] for a, f in zip(axes, flat)}


def outcome_arrays(out: dict, horizon: int) -> dict:
    """The engine's per-trial outcome arrays from a trial batch's raw outputs: ``status``,
    ``survived`` (status OK), ``nonfinite``, ``completed`` and ``fell_at`` (the unit at which a
    failed trial failed, -1 when it survived)."""
    status = np.asarray(out["status"]).astype(np.int32)
    completed = np.asarray(out["completed"]).astype(np.int32)
    survived = status == OK
    res = dict(out)
    res.update(status=status, survived=survived, nonfinite=status == NONFINITE, completed=completed,
               fell_at=np.where(survived, -1, completed).astype(np.int32))
    return res


def _bar(name: str, done: int, n: int, rate: float) -> None:
    w = 30
    k = int(w * done / max(n, 1))
    print(f"\r[bipedlab] {name} [{'#' * k}{'.' * (w - k)}] {done}/{n} trials, {rate:.3g} trials/s",
          end="" if done < n else "\n", file=sys.stderr, flush=True)


def _pad(params: dict, total: int) -> dict:
    n = len(next(iter(params.values())))
    idx = np.concatenate([np.arange(n), np.zeros(total - n, dtype=int)])
    return {k: np.asarray(v)[idx] for k, v in params.items()}


def survival_map(params: dict, survived: np.ndarray, axes) -> tuple[np.ndarray, np.ndarray]:
    """(survival fraction, trial count) per cell of the axes' lattice; NaN where a cell holds
    no trial. Values outside an axis's range fall in its end cells."""
    if not axes:
        return np.asarray(np.mean(survived) if survived.size else np.nan), np.asarray(survived.size)
    shape = tuple(a.bins for a in axes)
    idx = tuple(np.clip(np.floor((np.asarray(params[a.name]) - a.lo) / (a.hi - a.lo) * a.bins).astype(int), 0,
                        a.bins - 1) for a in axes)
    count = np.zeros(shape)
    alive = np.zeros(shape)
    np.add.at(count, idx, 1.0)
    np.add.at(alive, idx, survived.astype(float))
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = np.where(count > 0, alive / np.maximum(count, 1), np.nan)
    return frac, count.astype(int)


def _nested(a: np.ndarray):
    return [None if not math.isfinite(v) else float(v) for v in a] if a.ndim == 1 else [_nested(r) for r in a]


def _manifest(study: Study, trials: int, seed: int, per_dev: int, mesh, block: int, params: dict, key) -> dict:
    from bipedlab import provenance
    from bipedlab.robustness import chunks

    return dict(format=chunks.FORMAT, study=study.name, trials=int(trials), seed=int(seed), horizon=int(study.horizon),
                unit=study.unit, chunk_per_device=int(per_dev), devices=int(mesh.size), block=int(block),
                processes=int(jax.process_count()), device=dist.device_label(mesh),
                axes=[[a.name, a.lo, a.hi, a.bins] for a in study.axes], arguments=key or {},
                code=provenance.code(), params_sha256=chunks.params_digest(params))


def _share(found: dict, done: list, study: Study, padded: dict, block: int) -> dict:
    """Every process's copy of the chunks process 0 read back (a multi-process run): the
    outcomes of the ``done`` chunks, padded to whole blocks, as one byte buffer broadcast from
    process 0; the layout comes from the trial's output shapes (traced, not compiled)."""
    from jax.experimental import multihost_utils

    spec = {k: jax.ShapeDtypeStruct((block,) + v.shape[1:], v.dtype) for k, v in padded.items()}
    shapes = jax.eval_shape(jax.vmap(study.trial), spec)
    keys = sorted(shapes)
    sizes = [int(np.prod(shapes[k].shape)) * np.dtype(shapes[k].dtype).itemsize for k in keys]
    per_block = sum(sizes)
    buf = np.zeros(per_block * len(done), np.uint8)
    if jax.process_index() == 0:
        at = 0
        for i in done:
            for k, size in zip(keys, sizes):
                a = np.zeros(shapes[k].shape, shapes[k].dtype)
                got = np.asarray(found[i][k], shapes[k].dtype)
                a[:got.shape[0]] = got
                buf[at:at + size] = np.frombuffer(a.tobytes(), np.uint8)
                at += size
    buf = np.asarray(multihost_utils.broadcast_one_to_all(buf))
    out, at = {}, 0
    for i in done:
        out[i] = {}
        for k, size in zip(keys, sizes):
            out[i][k] = np.frombuffer(buf[at:at + size].tobytes(), shapes[k].dtype).reshape(shapes[k].shape)
            at += size
    return out


def run(study: Study, trials: int, seed: int = 0, chunk: int | None = None, out=None, progress: bool = True,
        mesh=None, store=None, restart: bool = False, key: dict | None = None) -> dict:
    """Run ``trials`` trials of ``study`` drawn with ``seed`` over the global mesh (every device
    of every process), ``chunk`` trials per device per compiled call (default ``study.chunk``).
    Writes ``outcomes.npz`` and figures under ``out`` (process 0 only) and returns the record.

    Resuming: each compiled call's outcomes are stored as one chunk file in ``store``
    (default ``<out>/chunks``; ``False``: none) as soon as the call returns; a run with the same
    trials, seed, chunk layout, devices, study, ``key`` (a JSON-able dict of whatever else
    defines the study, e.g. its command-line arguments) and code reads back the chunks an
    interrupted run left and computes only the others, so it ends with the same outcomes, bit
    for bit, as an uninterrupted run (see :mod:`bipedlab.robustness.chunks`). A folder holding
    another run's chunks raises :class:`bipedlab.robustness.chunks.ResumeError` unless
    ``restart``, which discards them. In a multi-process run, process 0 reads and writes the
    chunks and tells the others which to skip (no shared file system is needed)."""
    from bipedlab import interrupt
    from bipedlab.robustness import chunks

    if trials < 1:
        raise ValueError("trials must be at least 1")
    mesh = dist.global_mesh() if mesh is None else mesh
    ndev = mesh.size
    lead = jax.process_index() == 0
    multi = jax.process_count() > 1
    params = {k: np.asarray(v) for k, v in study.sample(np.random.default_rng(seed), trials).items()}
    per_dev = max(1, min(chunk or study.chunk, math.ceil(trials / ndev)))
    block = per_dev * ndev
    total = math.ceil(trials / block) * block
    ranges = [(a, min(a + block, trials)) for a in range(0, total, block)]
    padded = _pad(params, total)
    folder = None if store is False else (store if store is not None else (os.path.join(out, "chunks") if out else None))
    say = (lambda m: print(f"[bipedlab] {m}", file=sys.stderr, flush=True)) if progress and lead else None
    held, found, refused = None, {}, None
    # several processes: the collectives library announces its peers on fd 1 at the first gather
    with dist.stdout_to_stderr() if multi else contextlib.nullcontext():
        try:
            if lead and folder:
                try:
                    held = chunks.Store(folder, _manifest(study, trials, seed, per_dev, mesh, block, params, key),
                                        restart=restart)
                    if held.restarted and say:
                        say(f"--restart: discarded the chunks of an earlier run in {folder}")
                    found = chunks.load_all(held, ranges, params, say)
                except Exception as e:  # noqa: BLE001 - the others learn of it first (they would wait)
                    if not multi:
                        raise
                    refused = e
            if multi:  # process 0 says which chunks it holds (or that it refused the folder)
                from jax.experimental import multihost_utils

                mask = np.zeros(len(ranges) + 1, np.int32)
                mask[0] = refused is not None
                mask[[1 + i for i in found]] = 1
                mask = np.asarray(multihost_utils.broadcast_one_to_all(mask))
                if mask[0]:
                    raise refused or chunks.ResumeError("process 0 could not resume the run (see its message)")
                done = [int(i) for i in np.flatnonzero(mask[1:])]
                if done:
                    found = _share(found, done, study, padded, block)
            if say and found:
                say(f"resuming: {sum(b - a for i, (a, b) in enumerate(ranges) if i in found)} of {trials} trials "
                    f"({len(found)} of {len(ranges)} chunks) read back from {folder}")
            todo = [i for i in range(len(ranges)) if i not in found]
            pieces, t_run, compile_s, computed = dict(found), 0.0, 0.0, 0
            if todo:
                mapped = dist.sharded_map(study.trial, mesh)
                compile_s = mapped.compile({k: v[:block] for k, v in padded.items()})
            for i in todo:
                a = i * block
                piece = {k: v[a:a + block] for k, v in padded.items()}
                t0 = time.perf_counter()
                res_i = mapped(piece)
                t_run += time.perf_counter() - t0
                pieces[i] = res_i
                computed += ranges[i][1] - ranges[i][0]
                if held is not None:
                    with interrupt.critical():  # an interruption waits for the chunk to be written
                        held.save(i, ranges[i][0], ranges[i][1], params, res_i)
                if progress and lead:
                    done_n = trials - sum(ranges[j][1] - ranges[j][0] for j in todo if j not in pieces)
                    _bar(study.name, done_n, trials, computed / max(t_run, 1e-9))
        finally:
            if held is not None:
                held.close()
    raw = {k: np.concatenate([np.asarray(pieces[i][k])[:ranges[i][1] - ranges[i][0]] for i in range(len(ranges))])
           for k in pieces[0]}
    res = outcome_arrays(raw, study.horizon)
    rate = computed / t_run if computed and t_run > 0 else float("nan")
    frac, count = survival_map(params, res["survived"], study.axes)
    fell_at = np.bincount(res["completed"][~res["survived"]], minlength=study.horizon + 1)[:study.horizon + 1]
    rec = dict(
        study=study.name, trials=int(trials), seed=int(seed), horizon=int(study.horizon), unit=study.unit,
        survival_rate=float(np.mean(res["survived"])), survived=int(np.sum(res["survived"])),
        fell=int(np.sum(res["status"] == FELL)), nonfinite=int(np.sum(res["nonfinite"])),
        mean_completed=float(np.mean(res["completed"])),
        trials_per_s=float(rate), compile_s=float(compile_s), run_s=float(t_run),
        chunk_per_device=int(per_dev), padded_to=int(total),
        computed_trials=int(computed), resumed_trials=int(trials - computed),
        chunks=str(folder) if folder and lead else None, chunk_files=len(ranges),
        device=dist.device_label(mesh), devices=int(ndev), local_devices=int(len(jax.local_devices())),
        processes=int(jax.process_count()),
        axes=[dict(name=a.name, lo=a.lo, hi=a.hi, bins=a.bins, unit=a.unit, centers=[float(c) for c in a.centers()])
              for a in study.axes],
        survival_map=_nested(np.atleast_1d(frac)) if study.axes else float(frac),
        cell_trials=np.asarray(count).tolist(),
        fell_at_histogram=[int(v) for v in fell_at],
        status_names={str(k): v for k, v in STATUS_NAMES.items()},
    )
    if study.describe is not None:
        rec.update(study.describe(params, res))
    if out and lead:
        from bipedlab.robustness import figures

        rec["files"] = figures.write(out, study, params, res, frac, count, rec)
    return rec


def summary(rec: dict) -> str:
    """The record as a few lines of text."""
    rate = rec.get("trials_per_s")
    speed = f"{rate:.3g} trials/s" if rate is not None and math.isfinite(rate) else "no trial computed"
    lines = [
        f"robustness {rec['study']}: {rec['survived']}/{rec['trials']} trials survived {rec['horizon']} {rec['unit']}"
        f" ({100 * rec['survival_rate']:.1f} %); fell {rec['fell']}, non-finite {rec['nonfinite']} (seed {rec['seed']})",
        f"{speed} on {rec['devices']} device(s) [{rec['device']}] in {rec['processes']} "
        f"process(es); compile {rec['compile_s']:.1f} s, run {rec['run_s']:.2f} s",
    ]
    if rec.get("resumed_trials"):
        lines.append(f"resumed: {rec['resumed_trials']} trials read back from {rec.get('chunks') or 'the chunks'}, "
                     f"{rec['computed_trials']} computed")
    axes = rec.get("axes") or []
    if 1 <= len(axes) <= 2:
        m = np.asarray([[np.nan if v is None else v for v in (row if isinstance(row, list) else [row])]
                        for row in rec["survival_map"]], float)
        a0 = axes[0]
        head = f"survival map: rows {a0['name']} ({a0['unit'] or '-'})"
        if len(axes) == 2:
            a1 = axes[1]
            head += f", columns {a1['name']} " + " ".join(f"{c:.3g}" for c in a1["centers"])
        lines.append(head)
        for c, row in zip(a0["centers"], m):
            lines.append(f"  {c:>9.3g} | " + " ".join("   -" if not np.isfinite(v) else f"{v:4.2f}" for v in row))
    for k in rec.get("summary_keys", []):
        lines.append(f"{k}: {rec[k]}")
    if rec.get("files"):
        lines.append("wrote " + ", ".join(rec["files"]))
    return "\n".join(lines)
