"""Every array field of every gait schema (five-link, MABEL, imported models) refuses a value
that is not a rectangular array of numbers in one line naming the entry: rows of equal length
holding empty arrays, entries of mixed depth, shapes that differ further in. The cases are built
from the shipped files, so a field added to a schema is covered without listing it here."""
from __future__ import annotations

import copy
import json

import pytest

from bipedlab.gait import gaitfile
from bipedlab.robots.imported import robot as imported_robot
from bipedlab.robots.imported import study as imported_study
from bipedlab.robots.mabel.walking import study as mabel_study



def _five_link(path):
    return gaitfile.load(path, (5, 4))


def _mabel(path):
    return mabel_study.load_gait(str(path))


def _imported(path):
    return imported_study.load_gait("rabbit.xml", str(path))


SCHEMAS = {
    "five-link": ("bipedlab.robots.five_link", "five_link_0.8", _five_link),
    "mabel": ("bipedlab.robots.mabel", "mabel_nominal", _mabel),
    "imported": ("bipedlab.robots.imported", "rabbit_0.8", _imported),
}


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _array_fields(doc, path=()):
    """Paths (of object keys) to every list of numbers or of lists in the document."""
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield from _array_fields(v, path + (k,))
    elif isinstance(doc, list) and doc and all(_is_number(x) or isinstance(x, list) for x in doc):
        yield path


def _damages(value):
    """(name, damaged value, index of the entry the message must name) for an array value."""
    first = value[0]
    if isinstance(first, list):
        yield "row of empty arrays", [[[] for _ in first]] + value[1:], 0
        yield "row one level deeper", [[first]] + value[1:], 0
        if len(value) > 1:
            yield "last row of empty arrays", value[:-1] + [[[] for _ in value[-1]]], len(value) - 1
    else:
        yield "number replaced by an empty array", [[]] + value[1:], 0
        yield "number replaced by an array", [[first, first]] + value[1:], 0


def _cases():
    out = []
    for schema_name, (package, name, _) in SCHEMAS.items():
        doc = json.loads(gaitfile.shipped_text(package, name)[0])
        for path in _array_fields(doc):
            value = doc
            for k in path:
                value = value[k]
            if len(value) < 2:
                continue
            for damage, _, _ in _damages(value):
                out.append(pytest.param(schema_name, path, damage, id=f"{schema_name}:{'.'.join(path)}:{damage}"))
    return out


CASES = _cases()


def test_every_schema_has_array_fields():
    found = {c.values[0] for c in CASES}
    assert found == set(SCHEMAS), found
    assert len(CASES) >= 30, len(CASES)


@pytest.mark.parametrize("schema_name, path, damage", CASES)
def test_a_non_rectangular_array_fails_on_one_line_naming_the_entry(tmp_path, schema_name, path, damage):
    package, name, load = SCHEMAS[schema_name]
    doc = json.loads(gaitfile.shipped_text(package, name)[0])
    parent = doc
    for k in path[:-1]:
        parent = parent[k]
    _, bad, k = next(d for d in _damages(parent[path[-1]]) if d[0] == damage)
    parent[path[-1]] = copy.deepcopy(bad)
    file = tmp_path / "gait.json"
    file.write_text(json.dumps(doc))
    with pytest.raises(ValueError) as err:
        load(file)
    msg = str(err.value)
    assert msg.startswith(f"{file}: ") and "\n" not in msg, msg
    assert ".".join(path) in msg, msg
    # a field the schema does not read as an array (a design record's free list) may be named
    # whole; an array field is named down to the entry
    assert f"{'.'.join(path)}[{k}]" in msg or f"{'.'.join(path)}: expected" in msg, msg
