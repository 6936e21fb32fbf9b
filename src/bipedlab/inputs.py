"""Input files: what a path names, found without opening it.

Opening a FIFO waits for a writer and reading a character device (``/dev/zero``) never ends,
so readers of gait files and logs ask :func:`special_kind` first and refuse anything but a
regular file (symbolic links followed) in one line.
"""
from __future__ import annotations

import errno
import math
import os
import re
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


_BOMS = ((b"\xef\xbb\xbf", "utf-8"), (b"\xff\xfe\x00\x00", "utf-32-le"), (b"\x00\x00\xfe\xff", "utf-32-be"),
         (b"\xff\xfe", "utf-16-le"), (b"\xfe\xff", "utf-16-be"))


class TextError(ValueError):
    """Bytes that are not a text file (the message says why, without the file's name)."""


def byte_order_mark(data: bytes) -> tuple[bytes, str] | None:
    """(the mark, its encoding) when ``data`` starts with a byte-order mark, else None."""
    return next(((bom, name) for bom, name in _BOMS if data.startswith(bom)), None)


def decode_text(data: bytes) -> str:
    """The text of a file's bytes: UTF-8, or UTF-8 / UTF-16 / UTF-32 after the byte-order mark
    that names it (the mark dropped); line ends are left to ``str.splitlines`` (LF, CRLF, CR).
    TextError: an empty file, bytes that are not text in that encoding, a NUL character."""
    if not data:
        raise TextError("is empty (0 bytes)")
    mark = byte_order_mark(data)
    encoding, start = (mark[1], len(mark[0])) if mark else ("utf-8", 0)
    try:
        text = data[start:].decode(encoding)
    except UnicodeDecodeError as e:
        where = start + e.start
        raise TextError(f"is not {encoding.upper()} text (byte 0x{data[where]:02x} at offset {where})") from None
    if "\0" in text:
        raise TextError("holds a NUL byte: not a text file")
    if not text.strip():
        raise TextError("holds no text (only blanks)")
    return text


#: attributes that name things (a body called "nan" is no number)
_NAMING = frozenset("name class childclass joint joint1 joint2 body body1 body2 site site1 site2 geom geom1 geom2 mesh "
                    "material texture hfield link parent child file filename type tendon actuator target prefix "
                    "content_type key objname objtype refname reftype plugin instance mode".split())
_XACRO = re.compile(r"<\s*/?\s*xacro:|xmlns:xacro\s*=|\$\{[^}]*\}")


def model_text(path: str) -> str:
    """The text of a model file, checked before MuJoCo reads it: a regular file, text
    (:func:`bipedlab.inputs.decode_text`), no xacro macro, no non-finite number; ValueError in
    one line naming the file otherwise."""
    kind = special_kind(path)
    if kind is not None:
        raise ValueError(f"{path}: cannot be read ({kind}, not a regular file)")
    if not os.path.exists(path):
        raise ValueError(f"{path}: no such file")
    try:
        with open(path, "rb") as fh:
            text = decode_text(fh.read())
    except TextError as e:
        raise ValueError(f"{path}: cannot be read as MJCF or URDF: it {e}") from None
    except OSError as e:
        raise ValueError(f"{path}: cannot be read ({e.strerror or e})") from None
    m = _XACRO.search(text)
    if m:
        line = text.count("\n", 0, m.start()) + 1
        raise ValueError(f"{path}: holds xacro macros ({m.group(0).strip()!r} at line {line}); expand them first "
                         "(xacro FILE > expanded.urdf) and read the result")
    problem = nonfinite_attribute(text)
    if problem:
        raise ValueError(f"{path}: {problem}")
    return text


def nonfinite_attribute(text: str) -> str | None:
    """The first attribute of an XML model whose numbers include a NaN or an infinity, in
    words ("<body name='torso'> pos='0 0 nan' holds NaN ..."); None when there is none or the
    text is not XML (MuJoCo then says why)."""
    import xml.etree.ElementTree as ET

    try:
        root = ET.fromstring(text)
    except ET.ParseError:
        return None
    for el in root.iter():
        for attr, value in el.attrib.items():
            if attr in _NAMING or ":" in attr or "}" in attr:
                continue
            words = value.split()
            try:
                numbers = [float(w) for w in words]
            except ValueError:
                continue
            bad = [w for w, x in zip(words, numbers) if not math.isfinite(x)]
            if bad:
                what = "NaN" if any(math.isnan(float(w)) for w in bad) else "an infinity"
                named = f" name={el.get('name')!r}" if el.get("name") else ""
                return f"<{el.tag}{named}> {attr}={value!r} holds {what}; every number of a model must be finite"
    return None


