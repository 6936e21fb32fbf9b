"""SIGINT and SIGTERM during a command: one line on stderr, the staged outputs removed, exit
status 130 / 143, and nothing else (no traceback, no interpreter teardown).

While a study runs, the main thread may sit for a long time inside XLA (compiling or
executing) where Python signal handlers cannot run. So :func:`guard` installs handlers for
both signals *and* points Python's signal wake-up file descriptor at a pipe read by a small
watcher thread: whichever sees the signal first (the handler, between two bytecodes of the
main thread, or the watcher, at once) calls the cleanup, writes the line and ends the process
with ``os._exit``. Ending without interpreter teardown is deliberate: tearing down while XLA
threads still compile is what used to crash.

Work that must not be cut in half (renaming the outputs into place, writing an entry of the
compilation cache) runs inside :func:`critical`; an exit requested meanwhile waits for it.
"""
from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading

EXIT_CODES = {signal.SIGINT: 130, signal.SIGTERM: 143}
LINES = {signal.SIGINT: "bipedlab: interrupted", signal.SIGTERM: "bipedlab: terminated"}

_lock = threading.Lock()
_state = {"cleanup": None, "stderr": None}


@contextlib.contextmanager
def critical():
    """A block an interruption waits for (the exit takes the same lock)."""
    with _lock:
        yield


def _write_line(text: str) -> None:
    err = _state["stderr"] or sys.stderr
    mid_line = bool(getattr(err, "mid_line", False))
    data = ("\n" if mid_line else "") + text + "\n"
    try:
        os.write(2, data.encode("utf-8", "backslashreplace"))
    except OSError:
        pass


def _exit(signum: int, wait: bool) -> None:
    """Clean up, print the line and end the process; returns only if ``wait`` is False and
    the lock is taken (then the holder finishes and the watcher ends the process)."""
    if not _lock.acquire(blocking=wait):
        return
    _finish(LINES.get(signum, "bipedlab: interrupted"), EXIT_CODES.get(signum, 128 + int(signum)))


def end(line: str, code: int) -> None:
    """End the process now as an interruption does: the guard's cleanup (the staged outputs
    removed), ``line`` on stderr, exit status ``code``, no interpreter teardown. For a failure
    that leaves a native thread blocked (a join that JAX would later abort). Waits for a
    :func:`critical` block in progress."""
    _lock.acquire()
    _finish(line, code)


def _finish(line: str, code: int) -> None:
    try:
        cleanup = _state["cleanup"]
        if cleanup is not None:
            cleanup()
    except BaseException:  # noqa: BLE001 - nothing may stop the exit
        pass
    try:
        if _state["stderr"] is not None:
            _state["stderr"].flush()
    except BaseException:  # noqa: BLE001
        pass
    _write_line(line)
    os._exit(code)


def _handler(signum, frame):
    _exit(signum, wait=False)


def _watch(fd: int) -> None:
    try:
        while True:
            data = os.read(fd, 64)
            if not data:
                return
            for b in data:
                if b in EXIT_CODES:
                    _exit(b, wait=True)
    except OSError:
        return
    finally:
        os.close(fd)


class _TrackingStream:
    """stderr as seen by the study, remembering whether its last write ended a line (a
    progress bar redrawn with '\\r' does not), so the interruption line starts on its own."""

    def __init__(self, stream):
        self._stream = stream
        self.mid_line = False

    def write(self, s):
        if s:
            self.mid_line = not s.endswith("\n")
        return self._stream.write(s)

    def __getattr__(self, name):
        return getattr(self._stream, name)


@contextlib.contextmanager
def guard(cleanup=None):
    """Within the block, SIGINT / SIGTERM end the process as described above, calling
    ``cleanup()`` first. Outside the main thread (where handlers cannot be set) it does
    nothing. Restores the previous handlers and stderr on leaving."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    r, w = os.pipe()
    os.set_blocking(w, False)
    old = {s: signal.getsignal(s) for s in EXIT_CODES}
    old_fd = None
    old_stderr = sys.stderr
    tracked = _TrackingStream(old_stderr)
    _state.update(cleanup=cleanup, stderr=tracked)
    try:
        for s in EXIT_CODES:
            signal.signal(s, _handler)
        old_fd = signal.set_wakeup_fd(w, warn_on_full_buffer=False)
        threading.Thread(target=_watch, args=(r,), name="bipedlab-signals", daemon=True).start()
        sys.stderr = tracked
        yield
    finally:
        sys.stderr = old_stderr
        try:
            signal.set_wakeup_fd(old_fd if old_fd is not None else -1)
        except (ValueError, OSError):
            pass
        for s, h in old.items():
            signal.signal(s, h if h is not None else signal.SIG_DFL)
        _state.update(cleanup=None, stderr=None)
        os.close(w)  # the watcher reads EOF and ends
