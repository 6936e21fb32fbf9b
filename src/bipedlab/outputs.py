"""Output paths of a command: checked before any work, written under a temporary name, renamed
into place when the work has succeeded.

A command's ``--out DIR`` and ``--save FILE`` are *staged*: before the study starts,
:func:`stage_dir` / :func:`stage_file` check the target (an ``--out`` folder must not be an
existing file, the folder that will hold it must be writable; a ``--save`` file must not be a
folder and its folder must exist and be writable) and create a private staging folder
``.bipedlab-tmp-<pid>`` beside the target. The study is handed ``<parent>/.bipedlab-tmp-<pid>/<name>``
(same base name as the target, so a study that names things after the file keeps doing so)
and writes there. :meth:`Staging.commit` then moves the result into place:

- ``--out DIR`` that did not exist: the staged folder is renamed to DIR (one atomic rename).
- ``--out DIR`` that exists: every staged file replaces its namesake in DIR by ``os.replace``
  (each file atomic; files of DIR the study did not write are kept).
- ``--save FILE``: ``os.replace`` onto FILE (atomic).

:meth:`Staging.discard` removes the staging folders (and any parent folders created for
``--out``), so a failed or interrupted run leaves the file system as it found it.

A long command may also keep state *in place*, under the final ``--out`` folder
(:func:`final_path` finds it from the staged one), so that an interrupted run can resume: a
robustness study's chunks, a reproduction's progress. Such files are written with
:func:`write_atomic` (a temporary name in the same folder, fsync, ``os.replace``, fsync of the
folder), so a reader finds either the whole file or none of it; :meth:`Staging.discard` leaves
them.

Problems with a target raise :class:`OutputError` with one line naming the option and the
path. JSON written to disk goes through :func:`json_safe` / :func:`dump_json`: strict JSON,
non-finite floats as null.
"""
from __future__ import annotations

import json
import math
import os
import shutil
from dataclasses import dataclass, field

STAGE_PREFIX = ".bipedlab-tmp-"


class OutputError(ValueError):
    """An output target that cannot be written (one line, naming the option and the path)."""


def json_safe(x):
    """Non-finite floats -> None, recursively through dicts, lists and tuples."""
    if isinstance(x, dict):
        return {k: json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [json_safe(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def _number_or_null(v):
    f = float(v)  # NumPy scalars; anything else raises TypeError as json would
    return f if math.isfinite(f) else None


def dumps_json(obj, **kw) -> str:
    """json.dumps as strict JSON: non-finite floats (also NumPy scalars) as null."""
    return json.dumps(json_safe(obj), allow_nan=False, default=_number_or_null, **kw)


def dump_json(obj, fh, **kw) -> None:
    """json.dump as strict JSON: non-finite floats (also NumPy scalars) as null."""
    fh.write(dumps_json(obj, **kw))


def _stage_name() -> str:
    return f"{STAGE_PREFIX}{os.getpid()}"


def _clean(option: str, path: str) -> str:
    if not isinstance(path, str) or not path.strip():
        raise OutputError(f"{option}: expected a path, got {path!r}")
    if "\x00" in path:
        raise OutputError(f"{option}: a path cannot hold a NUL character, got {path!r}")
    try:
        os.fsencode(path)
    except UnicodeError:
        raise OutputError(f"{option}: not a valid path: {path!r}") from None
    trimmed = path.rstrip(os.sep) or path
    if os.path.basename(trimmed) in ("", ".", ".."):
        raise OutputError(f"{option}: expected a path ending in a name, got {path!r}")
    problem = length_problem(trimmed)
    if problem:
        raise OutputError(f"{option}: {problem}")
    return trimmed


def _limit(path: str, name: str, default: int) -> int:
    """The file system's limit ``name`` (PC_NAME_MAX, PC_PATH_MAX) at the nearest existing
    folder above ``path``; ``default`` where it cannot be asked."""
    folder = os.path.dirname(os.path.abspath(path))
    while folder and not os.path.isdir(folder) and os.path.dirname(folder) != folder:
        folder = os.path.dirname(folder)
    try:
        return int(os.pathconf(folder or os.sep, name))
    except (OSError, ValueError, AttributeError):
        return default


def length_problem(path: str) -> str | None:
    """Why the file system cannot take ``path`` for its length (a name over PC_NAME_MAX bytes,
    or the path, with the staging folder a run adds, over PC_PATH_MAX); None if it can."""
    name_max = _limit(path, "PC_NAME_MAX", 255)
    for part in path.split(os.sep):
        n = len(os.fsencode(part))
        if n > name_max:
            shown = part if len(part) <= 40 else part[:20] + "..." + part[-12:]
            return f"the name {shown!r} is {n} bytes long, more than the {name_max} the file system takes"
    total = len(os.fsencode(os.path.join(os.path.abspath(path), _stage_name(), "x")))
    path_max = _limit(path, "PC_PATH_MAX", 4096)
    if total >= path_max:
        return f"the path is too long ({total} bytes with the staging folder, the file system takes {path_max - 1})"
    return None


def _why(e: OSError) -> str:
    return e.strerror or str(e)


@dataclass
class _Target:
    option: str
    final: str       # as the user spelled it (trailing separators dropped)
    staged: str      # <parent>/.bipedlab-tmp-<pid>/<name>
    kind: str        # "dir" | "file"


@dataclass
class Staging:
    """The staged outputs of one run; commit() or discard() exactly once."""

    targets: list = field(default_factory=list)
    folders: list = field(default_factory=list)   # staging folders created, in order
    created: list = field(default_factory=list)   # parent folders created for --out, outermost first
    done: bool = False

    # ------------------------------------------------------------------------- staging
    def _folder_for(self, option: str, parent: str) -> str:
        folder = os.path.join(parent, _stage_name())
        if folder in self.folders:
            return folder
        try:
            if os.path.lexists(folder):  # left by an earlier process with our pid: not ours to keep
                shutil.rmtree(folder) if os.path.isdir(folder) and not os.path.islink(folder) else os.remove(folder)
            os.mkdir(folder)
        except OSError as e:
            raise OutputError(f"{option}: cannot write in {parent or '.'!r}: {_why(e)}") from None
        self.folders.append(folder)
        return folder

    def stage_dir(self, option: str, path: str) -> str:
        """Check ``--out DIR`` and return the staged folder the study should write into."""
        final = _clean(option, path)
        if os.path.lexists(final) and not os.path.isdir(final):
            raise OutputError(f"{option}: {path!r} exists and is not a folder")
        if os.path.isdir(final):
            _probe(option, final)
        parent = os.path.dirname(final)
        missing = []
        p = parent
        while p and not os.path.lexists(p):
            missing.append(p)
            p = os.path.dirname(p)
        if p and not os.path.isdir(p):
            raise OutputError(f"{option}: {p!r} is not a folder")
        for d in reversed(missing):
            try:
                os.mkdir(d)
            except OSError as e:
                self.discard()
                raise OutputError(f"{option}: cannot create {d!r}: {_why(e)}") from None
            self.created.append(d)
        try:
            folder = self._folder_for(option, parent)
        except OutputError:
            self.discard()
            raise
        staged = os.path.join(folder, os.path.basename(final))
        try:
            os.mkdir(staged)
        except OSError as e:
            self.discard()
            raise OutputError(f"{option}: cannot create {path!r}: {_why(e)}") from None
        self.targets.append(_Target(option, final, staged, "dir"))
        return staged

    def stage_file(self, option: str, path: str) -> str:
        """Check ``--save FILE`` and return the staged path the study should write."""
        final = _clean(option, path)
        if path.endswith(os.sep) or os.path.isdir(final):
            raise OutputError(f"{option}: {path!r} is a folder, not a file")
        parent = os.path.dirname(final)
        if parent and not os.path.isdir(parent):
            raise OutputError(f"{option}: folder {parent!r} does not exist")
        if os.path.lexists(final) and not os.access(final, os.W_OK):
            raise OutputError(f"{option}: {path!r} is not writable")
        staged = os.path.join(self._folder_for(option, parent), os.path.basename(final))
        try:  # the name itself must be one the file system takes: create it and take it back
            with open(staged, "x"):
                pass
            os.remove(staged)
        except OSError as e:
            self.discard()
            raise OutputError(f"{option}: cannot write {path!r}: {_why(e)}") from None
        self.targets.append(_Target(option, final, staged, "file"))
        return staged

    # ------------------------------------------------------------------------- ending
    def owns(self, path) -> bool:
        """Whether ``path`` lies in one of the staging folders."""
        if not isinstance(path, (str, bytes, os.PathLike)):
            return False
        p = os.path.abspath(os.fsdecode(path))
        return any(p == os.path.abspath(f) or p.startswith(os.path.abspath(f) + os.sep) for f in self.folders)

    def commit(self) -> None:
        """Move every staged output into place, then remove the staging folders."""
        for t in self.targets:
            if t.kind == "file":
                if not os.path.exists(t.staged):
                    continue  # the study chose not to write it
                os.replace(t.staged, t.final)
            elif os.path.isdir(t.final):
                _merge(t.staged, t.final)
            else:
                os.rename(t.staged, t.final)
        self.created = []  # they hold the outputs now
        self.discard()

    def discard(self) -> None:
        """Remove the staging folders and the parents created for them (if still empty)."""
        for f in self.folders:
            shutil.rmtree(f, ignore_errors=True)
        for d in reversed(self.created):
            try:
                os.rmdir(d)
            except OSError:
                pass
        self.folders, self.created, self.done = [], [], True

    def rename_paths(self, x):
        """``x`` (a record) with every staged path in its strings replaced by the final one."""
        if isinstance(x, str):
            for t in self.targets:
                if t.staged in x:
                    x = x.replace(t.staged, t.final)
            return x
        if isinstance(x, dict):
            return {k: self.rename_paths(v) for k, v in x.items()}
        if isinstance(x, (list, tuple)):
            return type(x)(self.rename_paths(v) for v in x)
        return x


def final_path(path: str) -> str:
    """The target a staged path stands for (``<parent>/<name>`` for
    ``<parent>/.bipedlab-tmp-<pid>/<name>``); any other path unchanged."""
    folder, name = os.path.split(os.fspath(path))
    parent, stage = os.path.split(folder)
    return os.path.join(parent, name) if stage.startswith(STAGE_PREFIX) else os.fspath(path)


def fsync_dir(folder) -> None:
    """Make the entries of ``folder`` (a rename into it) durable; a no-op where folders cannot
    be opened."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


TEMP_MARK = ".tmp-"
"""What the temporary names of :func:`write_atomic` hold (``.<name>.tmp-<pid>``)."""


def write_atomic(path, write) -> None:
    """Write the file ``path`` whole or not at all: ``write(fh)`` fills a binary file named
    ``.<name>.tmp-<pid>`` in the same folder, which is flushed, fsynced and renamed onto
    ``path`` (``os.replace``), the folder fsynced after. On any failure (a full disk) the
    temporary file is removed and the error raised (an OSError naming ``path``); ``path`` is
    untouched."""
    path = os.fspath(path)
    folder, name = os.path.split(path)
    tmp = os.path.join(folder, f".{name}{TEMP_MARK}{os.getpid()}")
    try:
        with open(tmp, "wb") as fh:
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException as e:
        try:
            os.remove(tmp)
        except OSError:
            pass
        if isinstance(e, OSError) and e.filename is None:  # a failed close names no file: name it
            raise OSError(e.errno, e.strerror or str(e), path) from None
        raise
    fsync_dir(folder or ".")


def _probe(option: str, folder: str) -> None:
    """Create and remove a file in an existing folder: is it writable (also for root, to whom
    os.access says yes on a read-only mount)?"""
    probe = os.path.join(folder, f"{_stage_name()}.probe")
    try:
        with open(probe, "w"):
            pass
        os.remove(probe)
    except OSError as e:
        raise OutputError(f"{option}: cannot write in {folder!r}: {_why(e)}") from None


def _merge(src: str, dst: str) -> None:
    """Move the tree src into the existing folder dst, each file by os.replace."""
    for name in sorted(os.listdir(src)):
        s, d = os.path.join(src, name), os.path.join(dst, name)
        if os.path.isdir(s) and not os.path.islink(s):
            if os.path.isdir(d) and not os.path.islink(d):
                _merge(s, d)
                continue
            if os.path.lexists(d):
                os.remove(d)
            os.rename(s, d)
        else:
            if os.path.isdir(d) and not os.path.islink(d):
                shutil.rmtree(d)
            os.replace(s, d)
