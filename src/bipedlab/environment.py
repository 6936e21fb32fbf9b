"""The environment variables a run reads, checked before any work.

JAX and XLA read ``JAX_PLATFORMS`` and ``XLA_FLAGS`` when they start a backend; a wrong value
ends a run late, in a traceback (an unknown platform, a GPU platform on a machine without a
GPU) or in XLA's fatal log line, which ends the process from inside the library. bipedlab reads
``BIPEDLAB_CACHE_DIR`` (and ``BIPEDLAB_XLA_CACHE_DIR``) for its compiled programs. :func:`check`
finds these problems first and raises :class:`bipedlab.commands.UsageError` with one line
naming the variable:

* ``JAX_PLATFORMS``: a comma-separated list of platform names JAX knows (:data:`PLATFORMS`);
* ``XLA_FLAGS``: blank-separated ``--name`` or ``--name=value`` words; when it is set, a forked
  child starts XLA's CPU backend with it (:func:`flags_problem`, about a second), so that a flag
  XLA does not know is reported in one line instead of ending the process;
* ``BIPEDLAB_CACHE_DIR``, ``BIPEDLAB_XLA_CACHE_DIR``: a folder that is, or can be created, and
  is writable.

A platform that is known but cannot start here (``cuda`` without a GPU) is found when the
command starts the backend, before its first compilation (:func:`devices_problem`).

Nothing here imports JAX at module import.
"""
from __future__ import annotations

import os
import re
import sys

from bipedlab.commands import UsageError

PLATFORMS = ("cpu", "cuda", "gpu", "rocm", "tpu", "metal", "METAL", "interpreter")
"""The platform names ``JAX_PLATFORMS`` may list."""
_FLAG = re.compile(r"--?[A-Za-z_][A-Za-z0-9_]*(=\S*)?", re.ASCII)


def platforms_problem(value: str) -> str | None:
    """Why ``value`` is not a list of JAX platforms (None if it is one, or blank)."""
    names = [n.strip() for n in value.split(",")]
    if not value.strip():
        return None
    bad = [n for n in names if n not in PLATFORMS]
    if bad:
        return (f"expected platforms among {', '.join(p for p in PLATFORMS if p.islower())} separated by commas, "
                f"got {value!r}")
    return None


def xla_flags_problem(value: str) -> str | None:
    """Why ``value`` is not a list of XLA flags (``--name`` or ``--name=value`` words separated
    by blanks); None if it is one. Whether XLA knows each name is found by :func:`backend_problem`."""
    bad = [w for w in value.split() if _FLAG.fullmatch(w) is None]
    if bad:
        return f"expected words --name or --name=value separated by blanks, got {bad[0]!r}"
    return None


def cache_dir_problem(path: str) -> str | None:
    """Why ``path`` cannot hold the compiled programs (not a folder, or a folder that cannot be
    created or written); None if it can. Creates the folder when it is missing."""
    if os.path.lexists(path) and not os.path.isdir(path):
        return f"{path!r} exists and is not a folder"
    try:
        os.makedirs(path, exist_ok=True)
        probe = os.path.join(path, f".bipedlab-probe-{os.getpid()}")
        with open(probe, "w"):
            pass
        os.remove(probe)
    except OSError as e:
        return f"cannot write in {path!r}: {e.strerror or e}"
    return None


_XLA_FATAL = re.compile(r"\] (Unknown flags? in XLA_FLAGS: .*)")


def _fatal_line(text: str) -> str:
    """The sentence of XLA's fatal log line (or the last line) of a child's stderr."""
    m = _XLA_FATAL.search(text)
    if m:
        return m.group(1).strip()
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    return lines[-1] if lines else "the backend did not start"


def flags_problem() -> str | None:
    """Start JAX's CPU backend in a forked child with this environment's ``XLA_FLAGS``; why it
    could not (XLA's fatal line, JAX's error), or None. XLA parses every flag, a GPU's too, when
    any backend starts, so the child starts the CPU one (no device is touched). The parent's JAX
    is left unstarted; None where fork is not available."""
    if not hasattr(os, "fork"):
        return None
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: its stderr goes to the pipe; nothing of the parent's is flushed
        code = 3
        try:
            os.dup2(w, 2)
            os.environ["JAX_PLATFORMS"] = "cpu"
            import jax

            jax.devices()
            code = 0
        except BaseException as e:  # noqa: BLE001 - any failure is the answer
            try:
                os.write(2, f"\n{type(e).__name__}: {e}\n".encode(errors="replace"))
            except OSError:
                pass
        finally:
            os._exit(code)
    os.close(w)
    chunks = []
    while True:
        b = os.read(r, 65536)
        if not b:
            break
        chunks.append(b)
    os.close(r)
    _, status = os.waitpid(pid, 0)
    if os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0:
        return None
    return _fatal_line(b"".join(chunks).decode(errors="replace"))


def devices_problem() -> str | None:
    """Start JAX's backend (in this process, as the study would); why it could not, in one
    line naming ``JAX_PLATFORMS``, or None."""
    import jax

    try:
        jax.devices()
    except Exception as e:  # noqa: BLE001 - RuntimeError, or a bare AssertionError when no platform started
        why = str(e).strip().splitlines()[0] if str(e).strip() else ""
        if not why or isinstance(e, AssertionError):
            why = "no backend of the platforms asked for could start (no such device here?)"
        return f"$JAX_PLATFORMS: {why} (JAX_PLATFORMS={os.environ.get('JAX_PLATFORMS', '')!r})"
    return None


def backend_started() -> bool:
    """Whether this process has started a JAX backend (importing JAX starts none)."""
    bridge = sys.modules.get("jax._src.xla_bridge")
    return bool(getattr(bridge, "_backends", None))


def check(environ=None, probe: bool = True) -> None:
    """Check the variables above (see the module docstring); UsageError naming the variable.
    ``probe``: when ``XLA_FLAGS`` is set and no backend started yet, start one with it in a
    child (:func:`flags_problem`)."""
    env = os.environ if environ is None else environ
    problem = platforms_problem(env.get("JAX_PLATFORMS", ""))
    if problem:
        raise UsageError(f"$JAX_PLATFORMS: {problem}")
    flags = env.get("XLA_FLAGS", "")
    problem = xla_flags_problem(flags)
    if problem:
        raise UsageError(f"$XLA_FLAGS: {problem}")
    for name in ("BIPEDLAB_CACHE_DIR", "BIPEDLAB_XLA_CACHE_DIR"):
        cache = env.get(name)
        if cache is not None and cache.strip():
            problem = cache_dir_problem(cache)
            if problem:
                raise UsageError(f"${name}: {problem}")
    if probe and flags.strip() and not backend_started():
        problem = flags_problem()
        if problem:
            raise UsageError(f"$XLA_FLAGS: {problem}")
