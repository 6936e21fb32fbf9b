"""Golden values of the closed loops: five-link and seven-link walks, ATRIAS and spring-mass
running, MABEL hopping, the bench scenario."""
from __future__ import annotations

import pytest

from test_golden_quantities import params, run_case


@pytest.mark.parametrize("name", params(("walk_", "run_", "hop_", "bench_"), exclude=("walk_mabel_",)))
def test_golden_loop(name):
    run_case(name)
