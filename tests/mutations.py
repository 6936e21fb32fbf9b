"""Hypothesis strategies that damage valid inputs: JSON documents (gait files) and CSV logs.

Each strategy draws from a valid input and applies one to three mutations, so that most
examples are *nearly* valid (the checks deep inside a loader are reached) and some are
wrecked (the checks at the door). Importable from the tests (tests/ is on sys.path).
"""
from __future__ import annotations

import copy
import json
import math

from hypothesis import strategies as st

# ----- values ------------------------------------------------------------------------------
FLOATS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, 1.0, -1.0, 1e-300, 1e300, -1e300, 1e20, 123456.0, math.nan, math.inf, -math.inf]),
)
INTEGERS = st.one_of(st.integers(-10, 10), st.sampled_from([2**63, -(2**63), 10**400]))
SCALARS = st.one_of(FLOATS, INTEGERS, st.booleans(), st.none(), st.text(max_size=8))
JSON_VALUES = st.recursive(SCALARS, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                            st.dictionaries(st.text(max_size=5), inner, max_size=3)),
                           max_leaves=12)


def paths(doc, prefix=()):
    """Every path (tuple of keys and indices) to a node of a JSON document, the root first."""
    out = [prefix]
    if isinstance(doc, dict):
        for k, v in doc.items():
            out += paths(v, prefix + (k,))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            out += paths(v, prefix + (i,))
    return out


def _get(doc, path):
    for k in path:
        doc = doc[k]
    return doc


def _set(doc, path, value):
    if not path:
        return value
    _get(doc, path[:-1])[path[-1]] = value
    return doc


@st.composite
def json_mutation(draw, doc):
    """One mutation of a JSON document (a copy is returned)."""
    doc = copy.deepcopy(doc)
    path = draw(st.sampled_from(paths(doc)))
    node = _get(doc, path)
    op = draw(st.sampled_from(["drop", "replace", "number", "scale", "reshape", "wrap", "rename"]))
    if op == "drop" and path:
        parent = _get(doc, path[:-1])
        del parent[path[-1]]
        return doc
    if op == "number" and isinstance(node, (int, float)) and not isinstance(node, bool):
        return _set(doc, path, draw(FLOATS))
    if op == "scale" and isinstance(node, (int, float)) and not isinstance(node, bool):
        factor = draw(st.sampled_from([1e3, 1e6, 1e200, -1.0, 0.0]))
        try:
            value = node * factor if node else 1e250
        except OverflowError:
            value = math.inf
        return _set(doc, path, value)
    if op == "reshape" and isinstance(node, list):
        how = draw(st.sampled_from(["empty", "truncate", "extend", "transpose_like"]))
        if how == "empty":
            return _set(doc, path, [])
        if how == "truncate":
            return _set(doc, path, node[: draw(st.integers(0, max(len(node) - 1, 0)))])
        if how == "extend":
            return _set(doc, path, node + [copy.deepcopy(node[-1]) if node else 0.0])
        return _set(doc, path, [node])
    if op == "wrap":
        depth = draw(st.sampled_from([1, 2, 40, 200]))
        for _ in range(depth):
            node = [node]
        return _set(doc, path, node)
    if op == "rename" and path and isinstance(_get(doc, path[:-1]), dict):
        parent = _get(doc, path[:-1])
        parent[str(path[-1]) + draw(st.sampled_from(["_", "X", " "]))] = parent.pop(path[-1])
        return doc
    return _set(doc, path, draw(JSON_VALUES))


@st.composite
def spoiled(draw, raw: bytes, bad=(b"\xff", b"\xc3", b"\x00", b"\xe9", b"\x80\x80"), kinds=("cut", "byte", "bom"),
            plain: int = 6):
    """A file's bytes, sometimes damaged as bytes: ``kinds`` among cut short, one of the ``bad``
    bytes inserted, a UTF-8 byte-order mark, emptied, nested in 33 to 100,000 JSON brackets;
    left whole ``plain`` times in ``plain + len(kinds)``."""
    how = draw(st.sampled_from(["none"] * plain + list(kinds)))
    if how == "cut":
        return raw[: draw(st.integers(0, len(raw)))]
    if how == "byte":
        k = draw(st.integers(0, len(raw)))
        return raw[:k] + draw(st.sampled_from(list(bad))) + raw[k:]
    if how == "bom":
        return b"\xef\xbb\xbf" + raw
    if how == "empty":
        return b""
    if how == "nest":
        n = draw(st.sampled_from([33, 1000, 100_000]))
        return b"[" * n + raw + b"]" * n
    return raw


@st.composite
def json_bytes(draw, doc):
    """The bytes of a damaged gait file: 0-3 structural mutations, serialised, and sometimes
    damaged as bytes (cut short, an invalid UTF-8 byte, a NUL, deep nesting around it, Latin-1)."""
    for _ in range(draw(st.integers(0, 3))):
        doc = draw(json_mutation(doc))
    if draw(st.integers(0, 11)) == 0:  # the text in Latin-1, a non-ASCII character in it
        return json.dumps(doc, ensure_ascii=False).replace('"', '"\u00e9', 1).encode("latin-1", "replace")
    return draw(spoiled(json.dumps(doc).encode(), kinds=("cut", "byte", "nest", "bom")))


# ----- CSV logs ----------------------------------------------------------------------------
CELL_TOKENS = st.one_of(st.sampled_from(["nan", "inf", "-inf", "", "abc", "1e400", "1e300", "-1e9", "0", "0x10",
                                         "1,5", '"', "1e-320", "  3  "]),
                        st.floats(allow_nan=False, allow_infinity=False).map(repr))
COLUMNS = st.sampled_from(["u_mLA_L", "u_mLS_L", "u_mLA_R", "u_mLS_R", "enc_mla_L", "enc_tor", "enc_bsp_R",
                           "enc_foo", "scale_N", "u_bogus", "time_s", "temperature", ""])
META_KEYS = st.sampled_from(["experiment", "units", "actuator", "combination", "side", "support", "mode", "actuated",
                             "release_s", "boom_radius", "cad_inertia", "name"])
META_VALUES = st.one_of(st.sampled_from(["", "abc", "nan", "-1", "0", "1e9", "1e-12", "2", "4", "L", "X", "siso",
                                         "mimo", "mLA_L", "mLS_R", "mLA_L mLS_L", "hip", "transmission", "hopping",
                                         "time=s torque=N*m angle=rad", "time=ms", "0.05", "100"]),
                        st.floats(allow_nan=True).map(repr), st.text(max_size=6).filter(lambda s: "\n" not in s))


def _split(text: str):
    lines = text.splitlines()
    h = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    return lines[:h], lines[h].split(","), [r.split(",") for r in lines[h + 1:]]


def _join(meta, header, rows) -> str:
    return "\n".join(meta + [",".join(header)] + [",".join(r) for r in rows]) + "\n"


@st.composite
def csv_mutation(draw, text: str) -> str:
    """One mutation of a CSV log's text (rows, columns, cells, metadata)."""
    meta, header, rows = _split(text)
    op = draw(st.sampled_from(["cell", "meta_value", "add_column", "constant_column", "truncate", "drop_column",
                               "meta_add", "meta_drop", "swap_rows", "duplicate_row", "drop_value"]))
    if op == "truncate":
        rows = rows[: draw(st.sampled_from([len(rows) - 1, 161, 160, 100, 21, 20, 19, 3, 2, 1, 0]))]
    elif op == "drop_column" and len(header) > 1:
        j = draw(st.integers(0, len(header) - 1))
        header = header[:j] + header[j + 1:]
        rows = [r[:j] + r[j + 1:] for r in rows]
    elif op == "add_column":
        header = header + [draw(COLUMNS)]
        value = draw(st.sampled_from(["0", "1.5", "varying"]))
        rows = [r + [str(0.001 * i) if value == "varying" else value] for i, r in enumerate(rows)]
    elif op == "constant_column" and header:
        j = draw(st.integers(0, len(header) - 1))
        value = draw(st.sampled_from(["0", "1", "3.25"]))
        rows = [r[:j] + [value] + r[j + 1:] for r in rows]
    elif op == "cell" and rows and header:
        i, j = draw(st.integers(0, len(rows) - 1)), draw(st.integers(0, len(header) - 1))
        rows = [list(r) for r in rows]
        if j < len(rows[i]):
            rows[i][j] = draw(CELL_TOKENS)
    elif op == "meta_value" and meta:
        k = draw(st.integers(0, len(meta) - 1))
        key = meta[k][1:].split(":", 1)[0].strip()
        meta = meta[:k] + [f"# {key}: {draw(META_VALUES)}"] + meta[k + 1:]
    elif op == "meta_drop" and meta:
        k = draw(st.integers(0, len(meta) - 1))
        meta = meta[:k] + meta[k + 1:]
    elif op == "meta_add":
        meta = meta + [f"# {draw(META_KEYS)}: {draw(META_VALUES)}"]
    elif op == "swap_rows" and len(rows) > 1:
        i = draw(st.integers(0, len(rows) - 2))
        rows = rows[:i] + [rows[i + 1], rows[i]] + rows[i + 2:]
    elif op == "duplicate_row" and rows:
        i = draw(st.integers(0, len(rows) - 1))
        rows = rows[: i + 1] + [rows[i]] + rows[i + 1:]
    elif op == "drop_value" and rows:
        i = draw(st.integers(0, len(rows) - 1))
        rows = rows[:i] + [rows[i][:-1]] + rows[i + 1:]
    return _join(meta, header, rows)


@st.composite
def csv_bytes(draw, texts: dict) -> tuple[str, bytes]:
    """(the kind drawn, the bytes of a damaged log): a valid log of some kind, 1-3 mutations,
    and sometimes damage as bytes."""
    kind = draw(st.sampled_from(sorted(texts)))
    text = texts[kind]
    for _ in range(draw(st.integers(1, 3))):
        text = draw(csv_mutation(text))
    raw = text.encode()
    how = draw(st.sampled_from(["none"] * 8 + ["cut", "byte", "empty"]))
    if how == "cut":
        raw = raw[: draw(st.integers(0, len(raw)))]
    elif how == "byte":
        k = draw(st.integers(0, len(raw)))
        raw = raw[:k] + draw(st.sampled_from([b"\xff", b"\x00", b"\xe9", b"\r", b"\x0b"])) + raw[k:]
    elif how == "empty":
        raw = b""
    return kind, raw
