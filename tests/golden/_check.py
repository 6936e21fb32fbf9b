"""Shared assertion of the golden tests (no bipedlab import)."""
from __future__ import annotations

import json
import os

import compare
import golden_cases

DATA = os.path.join(os.path.dirname(__file__), "data")


def check(name: str, value) -> None:
    case = golden_cases.CHECKED[name]
    path = os.path.join(DATA, f"{name}.json")
    if not os.path.exists(path):
        import pytest

        pytest.fail(f"no golden data for {name}: record it with `python tests/golden/record.py {name}`")
    # durations and the environment differ between runs of the same code (a design's
    # optimize_cold_s / optimize_warm_s are wall-clock seconds): neither side's count
    ref = compare.strip_timing(compare.load(path))
    new = compare.strip_timing(json.loads(json.dumps(compare.to_jsonable(value), allow_nan=True)))
    diffs = compare.differences(new, ref, case.rtol, case.atol, case.special)
    assert not diffs, f"{name}: {len(diffs)} difference(s) from the recorded golden data:\n" + "\n".join(diffs[:30])
