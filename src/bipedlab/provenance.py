"""What identifies the code that computed a result: the package's version and a hash of its
source and data files, with the JAX version and precision.

Stored results carry it (the reproduction's result cache keys on it, a robustness study's
chunks record it), so that a result is never mixed with one computed by other code.
"""
from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Optional

import bipedlab

_SOURCE_HASHES: dict = {}


def source_hash(skip: tuple = ()) -> str:
    """sha256 of every .py and .json file of the installed package (paths and contents),
    computed once per process and ``skip``.

    skip: paths relative to the package folder, in POSIX form (``"report"``,
    ``"robots/mabel"``, ``"robots/atrias/data/paper_running.json"``): the files and folders
    whose contents a result cannot depend on (see :func:`results_hash`)."""
    skip = tuple(sorted(skip))
    if skip not in _SOURCE_HASHES:
        root = Path(bipedlab.__file__).parent
        h = hashlib.sha256()
        for path in sorted(root.rglob("*")):
            if path.suffix in (".py", ".json") and "__pycache__" not in path.parts and path.is_file():
                rel = path.relative_to(root).as_posix()
                if any(rel == s or rel.startswith(s + "/") for s in skip):
                    continue
                h.update(rel.encode())
                h.update(b"\0")
                h.update(path.read_bytes())
                h.update(b"\0")
        _SOURCE_HASHES[skip] = h.hexdigest()
    return _SOURCE_HASHES[skip]


def results_hash(package: Optional[str] = None, extra_skip: tuple = ()) -> str:
    """:func:`source_hash` of what a robot's study results can depend on: the whole package but
    the report's own modules (``report``: tables, verdicts and pages, computed from the
    results) and the other robots' packages (a robot imports no other robot, which the layout
    test checks). ``package``: the robot's package as ``"robots/<name>"``, or None for a result
    of no robot package (everything but ``report`` counts). ``extra_skip``: further paths (a
    paper's values file)."""
    root = Path(bipedlab.__file__).parent
    others = tuple(f"robots/{p.name}" for p in sorted((root / "robots").iterdir())
                   if p.is_dir() and p.name != "__pycache__" and f"robots/{p.name}" != package) \
        if package is not None else ()
    return source_hash(("report",) + others + tuple(extra_skip))


def code() -> dict:
    """{version, source, jax, x64}: the package version, :func:`source_hash`, the JAX version
    and whether float64 is on (imports JAX)."""
    import jax

    return dict(version=bipedlab.__version__, source=source_hash(), jax=jax.__version__,
                x64=bool(jax.config.jax_enable_x64))


def file_sha256(path) -> str:
    """sha256 of a file's contents."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()
