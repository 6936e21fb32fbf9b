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

_SOURCE_HASH: Optional[str] = None


def source_hash() -> str:
    """sha256 of every .py and .json file of the installed package (paths and contents),
    computed once per process."""
    global _SOURCE_HASH
    if _SOURCE_HASH is None:
        root = Path(bipedlab.__file__).parent
        h = hashlib.sha256()
        for path in sorted(root.rglob("*")):
            if path.suffix in (".py", ".json") and "__pycache__" not in path.parts and path.is_file():
                h.update(str(path.relative_to(root)).encode())
                h.update(b"\0")
                h.update(path.read_bytes())
                h.update(b"\0")
        _SOURCE_HASH = h.hexdigest()
    return _SOURCE_HASH


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
