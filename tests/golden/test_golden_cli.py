"""Golden CLI records: ``bipedlab ... --json`` in-process, timing keys stripped, against data/."""
from __future__ import annotations

import pytest

import adapter
import compare
import golden_cases
from _check import check


def _params(cases):
    return [pytest.param(n, marks=[pytest.mark.slow] if c.slow else [], id=n) for n, c in cases.items()]


@pytest.mark.parametrize("name", _params(golden_cases.CLI))
def test_golden_cli_record(name):
    rec = adapter.cli_record(golden_cases.CLI[name].args)
    check(name, compare.strip_timing(rec))
    if name == "cli_identify_mabel_quick":
        check("sysid_quick", adapter.sysid_quick(rec))


def test_strip_timing_removes_durations_only():
    rec = {"wall_s": 1.0, "compile_time_s": 2.0, "optimize_warm_s": 3.0, "real_time_fraction": 0.1, "device": "cpu",
           "jax_version": "x", "duration_s": 0.5, "sim_time_s": 1.0, "period_s": 0.6,
           "nested": [{"wall_time_s": 1.0, "settling_time_s": 2.0}]}
    assert compare.strip_timing(rec) == {"duration_s": 0.5, "sim_time_s": 1.0, "period_s": 0.6,
                                         "nested": [{"settling_time_s": 2.0}]}


def test_differences_detects_a_perturbation():
    ref = {"a": [1.0, 2.0], "b": "x", "c": True, "d": 0.0}
    assert compare.differences({"a": [1.0, 2.0 * (1 + 1e-10)], "b": "x", "c": True, "d": 1e-13}, ref) == []
    assert compare.differences({"a": [1.0, 2.0 * (1 + 1e-8)], "b": "x", "c": True, "d": 0.0}, ref)
    assert compare.differences({"a": [1.0, 2.0], "b": "y", "c": True, "d": 0.0}, ref)
    assert compare.differences({"a": [1.0, 2.0], "b": "x", "c": 1, "d": 0.0}, ref)


def test_wildcard_tolerance_applies_to_every_matching_key():
    special = (("*rel_error", 0.0, 1e-8),)
    ref = {"parameters": [{"rel_error": 1e-3, "estimate": 1.0}]}
    near = {"parameters": [{"rel_error": 1e-3 + 5e-9, "estimate": 1.0}]}
    far = {"parameters": [{"rel_error": 1e-3 + 5e-8, "estimate": 1.0}]}
    assert compare.differences(near, ref, 1e-9, 1e-12, special) == []
    assert compare.differences(far, ref, 1e-9, 1e-12, special)
    assert compare.differences({"parameters": [{"rel_error": 1e-3, "estimate": 1.0 + 1e-8}]}, ref, 1e-9, 1e-12, special)
