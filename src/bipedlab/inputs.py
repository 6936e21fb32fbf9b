"""Input files: what a path names, found without opening it.

Opening a FIFO waits for a writer and reading a character device (``/dev/zero``) never ends,
so readers of gait files and logs ask :func:`special_kind` first and refuse anything but a
regular file (symbolic links followed) in one line.
"""
from __future__ import annotations

import errno
import os
import stat

_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


def kind_of_mode(mode: int) -> str | None:
    """What a file of this ``st_mode`` is, in words; None for a regular file."""
    if stat.S_ISREG(mode):
        return None
    return next((words for test, words in _KINDS if test(mode)), "not a regular file")


def special_kind(path) -> str | None:
    """What ``path`` names when it is not a regular file (after following symbolic links), in
    words: "a directory", "a FIFO (named pipe)", "a character device", "a loop of symbolic
    links", "a symbolic link to a missing file", ...; None for a regular file, and for a path
    that is missing or cannot be examined (opening it then fails with its own reason).
    Nothing is opened."""
    try:
        st = os.stat(path)
    except OSError as e:
        if e.errno == errno.ELOOP:
            return "a loop of symbolic links"
        if e.errno == errno.ENOENT and os.path.islink(path):
            return "a symbolic link to a missing file"
        return None
    except ValueError:  # a NUL in the name: opening it fails with its own reason
        return None
    return kind_of_mode(st.st_mode)
