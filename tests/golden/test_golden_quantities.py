"""Golden values of the library-level quantities (adapter.py functions) against data/: gait
files, Poincaré maps and the gait design. The closed loops are in test_golden_loops.py and
test_golden_mabel_walk.py, so that pytest-xdist (one file per worker at a time) spreads them."""
from __future__ import annotations

import pytest

import adapter
import golden_cases
from _check import check


def params(prefixes, exclude=()):
    """The QUANTITIES cases whose names start with one of ``prefixes`` (slow ones marked)."""
    names = [n for n in golden_cases.QUANTITIES if n.startswith(prefixes) and not n.startswith(tuple(exclude) or "\0")]
    return [pytest.param(n, marks=[pytest.mark.slow] if golden_cases.QUANTITIES[n].slow else [], id=n) for n in names]


def run_case(name):
    case = golden_cases.QUANTITIES[name]
    check(name, getattr(adapter, case.func)(*case.args))


@pytest.mark.parametrize("name", params(("gait_", "poincare_", "optimize_")))
def test_golden_quantity(name):
    run_case(name)


def test_every_case_belongs_to_one_file():
    groups = [params(("gait_", "poincare_", "optimize_")), params(("walk_mabel_",)),
              params(("walk_", "run_", "hop_", "bench_"), exclude=("walk_mabel_",))]
    names = [p.values[0] for g in groups for p in g]
    assert sorted(names) == sorted(golden_cases.QUANTITIES)
