"""Golden values of MABEL's walking closed loop (the largest program of the golden set)."""
from __future__ import annotations

import pytest

from test_golden_quantities import params, run_case


@pytest.mark.parametrize("name", params(("walk_mabel_",)))
def test_golden_mabel_walk(name):
    run_case(name)
