"""Golden tests: a private, empty JAX compile cache (timings honest, nothing reused from
earlier runs) and the golden helpers importable."""
from __future__ import annotations

import os
import sys

import pytest

sys.path.insert(0, os.path.dirname(__file__))


@pytest.fixture(scope="session", autouse=True)
def _private_compile_cache(tmp_path_factory):
    old = os.environ.get("BIPEDLAB_CACHE_DIR")
    os.environ["BIPEDLAB_CACHE_DIR"] = str(tmp_path_factory.mktemp("xla"))
    yield
    if old is None:
        os.environ.pop("BIPEDLAB_CACHE_DIR", None)
    else:
        os.environ["BIPEDLAB_CACHE_DIR"] = old
