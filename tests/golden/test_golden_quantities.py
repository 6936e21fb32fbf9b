"""Golden values of the library-level quantities (adapter.py functions) against data/."""
from __future__ import annotations

import pytest

import adapter
import golden_cases
from _check import check


def _params(cases):
    return [pytest.param(n, marks=[pytest.mark.slow] if c.slow else [], id=n) for n, c in cases.items()]


@pytest.mark.parametrize("name", _params(golden_cases.QUANTITIES))
def test_golden_quantity(name):
    case = golden_cases.QUANTITIES[name]
    check(name, getattr(adapter, case.func)(*case.args))
