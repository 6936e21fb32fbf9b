"""Where the studies keep their compiled programs.

A study's first run pays for every program it compiles; :func:`enable` makes every later run
load them instead:

* the persistent compilation cache lives in ``$BIPEDLAB_CACHE_DIR`` (default
  ``~/.cache/bipedlab/xla``), or in ``$BIPEDLAB_XLA_CACHE_DIR`` when that is set;
* every program is kept, however short its compilation (JAX's default keeps only those that
  took at least 1 s, so a study's many small programs compiled again on every run);
* a cache entry is written inside :func:`bipedlab.interrupt.critical`, so an interruption
  cannot leave half an entry behind.

XLA's CPU compile options were measured on the studies and left at XLA's defaults: LLVM
optimisation level 0 or 1, or no expensive LLVM passes, shorten compilation by 10-30 % but make
the compiled loops 1.5-4 times slower (README, "Compilation").
"""
from __future__ import annotations

import os

from bipedlab import interrupt


def cache_dir() -> str:
    """The folder of the persistent compilation cache: ``$BIPEDLAB_XLA_CACHE_DIR`` when set (the
    compiled programs apart from the stored results, e.g. several result folders sharing one
    set of programs), else ``$BIPEDLAB_CACHE_DIR``, else ``~/.cache/bipedlab/xla``."""
    return (os.environ.get("BIPEDLAB_XLA_CACHE_DIR") or os.environ.get("BIPEDLAB_CACHE_DIR")
            or os.path.join(os.path.expanduser("~"), ".cache", "bipedlab", "xla"))


def enable(path: str | None = None) -> str | None:
    """Keep every compiled program in the persistent cache at ``path`` (default
    :func:`cache_dir`). Returns the folder, or None when it cannot be created (the studies then
    run without a cache)."""
    import jax

    path = path or cache_dir()
    try:
        os.makedirs(path, exist_ok=True)
    except OSError:
        return None
    jax.config.update("jax_compilation_cache_dir", path)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", -1)
    _cache_writes_are_critical()
    return path


def _cache_writes_are_critical() -> None:
    """An interruption must not cut a compilation-cache entry in half (JAX writes the entry in
    place, and a truncated one is reported on every later run): JAX's file cache writes an
    entry inside interrupt.critical(), which the exit waits for. Leaves JAX alone if its cache
    class is not where this JAX version keeps it."""
    try:
        from jax._src import lru_cache
    except ImportError:
        return
    cls = getattr(lru_cache, "LRUCache", None)
    put = getattr(cls, "put", None)
    if put is None or getattr(put, "_bipedlab_critical", False):
        return

    def critical_put(self, key, value):
        with interrupt.critical():
            return put(self, key, value)

    critical_put._bipedlab_critical = True
    cls.put = critical_put
