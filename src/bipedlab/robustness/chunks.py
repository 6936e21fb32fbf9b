"""A robustness run's outcomes on disk, chunk by chunk, so that an interrupted run resumes.

The folder (``<out>/chunks`` by default) holds ``manifest.json`` — what the run is: its trials,
seed, chunk layout, devices, study, arguments, the code that computes it
(:func:`bipedlab.provenance.code`) and a digest of every trial's sampled parameters — and one
``chunk-<index>.npz`` per compiled call: the call's trial range, its trials' parameters and
their raw outcomes. Every file is written whole or not at all
(:func:`bipedlab.outputs.write_atomic`), so a chunk under its final name is complete; what a
killed writer leaves is a temporary ``.chunk-*.tmp-<pid>`` file, removed at the next start and
never read. A chunk that cannot be read back (a damaged file: its zip checksums fail) or whose
range or parameters are not the run's is computed again.

A folder whose manifest is not this run's is refused (:class:`ResumeError`, one line naming
the first difference) unless ``restart``, which deletes its chunks first. One run at a time
holds a folder (an exclusive ``flock`` on ``lock``, released when the process ends however it
ends).
"""
from __future__ import annotations

import errno
import fcntl
import hashlib
import json
import os
import re
import zipfile
from pathlib import Path
from typing import Callable, Optional

import numpy as np

from bipedlab.outputs import TEMP_MARK, dumps_json, fsync_dir, write_atomic

FORMAT = 1
MANIFEST = "manifest.json"
LOCK = "lock"
ORDER = ("format", "study", "trials", "seed", "arguments", "command", "options", "files", "chunk_per_device",
         "devices", "processes", "block", "device", "horizon", "unit", "axes", "code", "params_sha256")
"""The order in which two manifests are compared (the first difference is named)."""
_CHUNK = re.compile(r"chunk-(\d{6,})\.npz")


class ResumeError(ValueError):
    """A folder of chunks this run cannot use (one line)."""


def chunk_name(index: int) -> str:
    return f"chunk-{index:06d}.npz"


def params_digest(params: dict) -> str:
    """sha256 over every sampled parameter array (name, dtype, shape and bytes)."""
    h = hashlib.sha256()
    for k in sorted(params):
        a = np.ascontiguousarray(params[k])
        h.update(f"{k}\0{a.dtype.str}\0{a.shape}\0".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    a, b = np.ascontiguousarray(a), np.ascontiguousarray(b)
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def _short(v) -> str:
    text = json.dumps(v, sort_keys=True)
    return text if len(text) <= 40 else text[:37] + "..."


def difference(stored, now, where: str = "") -> Optional[str]:
    """The first entry in which two manifests differ, in words (None if they are equal)."""
    if isinstance(stored, dict) and isinstance(now, dict):
        rank = {k: i for i, k in enumerate(ORDER)}
        for k in sorted(set(stored) | set(now), key=lambda k: (rank.get(k, len(rank)), k)):
            name = f"{where}.{k}" if where else k
            if k not in stored or k not in now:
                return f"{name}: {'absent' if k not in stored else _short(stored[k])} in the stored run, " \
                       f"{'absent' if k not in now else _short(now[k])} now"
            d = difference(stored[k], now[k], name)
            if d:
                return d
        return None
    if stored != now:
        if where == "code.source":
            return "the package's source files changed since its chunks were written"
        if where == "params_sha256":
            return "the trials' sampled parameters differ"
        return f"{where}: {_short(stored)} in the stored run, {_short(now)} now"
    return None


class Store:
    """An open folder of chunks (see the module docstring); :meth:`close` releases it."""

    def __init__(self, folder, manifest: dict, restart: bool = False):
        self.folder = Path(folder)
        self.manifest = json.loads(dumps_json(manifest))
        self._lock = None
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            self._lock = os.open(self.folder / LOCK, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as e:
            raise ResumeError(f"cannot write in {str(self.folder)!r}: {e.strerror or e}") from None
        try:
            fcntl.flock(self._lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as e:
            self.close()
            if e.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise ResumeError(f"{str(self.folder)!r} is in use by another run") from None
            raise
        try:
            self._open(restart)
        except BaseException:
            self.close()
            raise

    # ------------------------------------------------------------------ manifest
    def _open(self, restart: bool) -> None:
        for p in self.folder.iterdir():  # what killed writers left: never read
            if p.name.startswith(".") and TEMP_MARK in p.name:
                p.unlink(missing_ok=True)
        path = self.folder / MANIFEST
        stored = None
        if path.exists():
            try:
                stored = json.loads(path.read_text())
            except (OSError, ValueError):
                stored = {"unreadable": True}
        chunks = self.chunk_files()
        if stored is None and chunks:
            stored = {"unreadable": True}
        if stored is not None and not restart:
            if stored.get("unreadable"):
                raise ResumeError(f"{str(self.folder)!r} holds chunks without a readable {MANIFEST}")
            d = difference(stored, self.manifest)
            if d:
                raise ResumeError(f"{str(self.folder)!r} holds the chunks of another run ({d})")
            return
        for p in chunks:
            p.unlink()
        write_atomic(path, lambda fh: fh.write(dumps_json(self.manifest, indent=1, sort_keys=True).encode()))
        self.restarted = stored is not None

    restarted = False

    def chunk_files(self) -> list:
        return sorted(p for p in self.folder.iterdir() if _CHUNK.fullmatch(p.name))

    # ------------------------------------------------------------------ chunks
    def load(self, index: int, start: int, stop: int, params: dict) -> Optional[dict]:
        """The raw outcomes of chunk ``index`` (trials [start, stop)) if its file is there,
        whole and this run's (its range and parameters); None otherwise."""
        path = self.folder / chunk_name(index)
        if not path.exists():
            return None
        try:
            with np.load(path, allow_pickle=False) as z:
                data = {k: z[k] for k in z.files}  # reads every member: the zip checksums are checked
        except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError):
            return None
        try:
            if (int(data.pop("index")), int(data.pop("start")), int(data.pop("stop"))) != (index, start, stop):
                return None
        except (KeyError, TypeError, ValueError):
            return None
        got = {k[len("param_"):]: v for k, v in data.items() if k.startswith("param_")}
        if set(got) != set(params) or not all(_same(got[k], np.asarray(params[k])[start:stop]) for k in params):
            return None
        out = {k[len("out_"):]: v for k, v in data.items() if k.startswith("out_")}
        if not out or any(v.shape[:1] != (stop - start,) for v in out.values()):
            return None
        return out

    def save(self, index: int, start: int, stop: int, params: dict, outcomes: dict) -> None:
        """Write chunk ``index`` atomically: trials [start, stop), their parameters and raw
        outcomes (the first ``stop - start`` rows of each array)."""
        arrays = dict(index=np.asarray(index), start=np.asarray(start), stop=np.asarray(stop))
        arrays.update({f"param_{k}": np.asarray(v)[start:stop] for k, v in params.items()})
        arrays.update({f"out_{k}": np.asarray(v)[:stop - start] for k, v in outcomes.items()})
        write_atomic(self.folder / chunk_name(index), lambda fh: np.savez(fh, **arrays))

    def close(self) -> None:
        if self._lock is not None:
            os.close(self._lock)  # releases the flock
            self._lock = None
        fsync_dir(self.folder)


def load_all(store: Store, ranges: list, params: dict, say: Optional[Callable[[str], None]] = None) -> dict:
    """{index: raw outcomes} of every chunk of ``ranges`` ([(start, stop)] by index) that
    :meth:`Store.load` reads back, all of one structure (the keys, dtypes and trailing shapes
    of the first); a chunk file that is there but not usable is reported through ``say`` and
    left to be computed again."""
    found: dict = {}
    shape = None
    for i, (a, b) in enumerate(ranges):
        present = (store.folder / chunk_name(i)).exists()
        out = store.load(i, a, b, params) if present else None
        if out is not None:
            s = {k: (v.dtype.str, v.shape[1:]) for k, v in out.items()}
            if shape is None:
                shape = s
            if s != shape:
                out = None
        if out is None:
            if present and say is not None:
                say(f"{chunk_name(i)} is damaged or not this run's: computing it again")
            continue
        found[i] = out
    return found
