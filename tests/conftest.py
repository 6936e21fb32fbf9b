"""Shared fixtures for the bipedlab test suite; puts tests/ on sys.path for the helper modules
(helpers.py, oracles.py, trees.py)."""
from __future__ import annotations

import os
import sys

import pytest

sys.path.insert(0, os.path.dirname(__file__))

import bipedlab  # noqa: E402,F401  (enables float64)
import jax  # noqa: E402

assert jax.config.jax_enable_x64, "importing bipedlab must enable float64"


def _shared_compile_cache() -> None:
    """One persistent JAX compilation cache for the whole run: the test processes (pytest-xdist
    workers) and the commands they start as subprocesses (through BIPEDLAB_CACHE_DIR) compile
    each program once. A fresh folder per run, so no result depends on an earlier run; tests
    that need a cold cache of their own set BIPEDLAB_XLA_CACHE_DIR."""
    import tempfile

    path = os.environ.get("BIPEDLAB_TEST_XLA_CACHE")
    if not path:
        path = tempfile.mkdtemp(prefix="bipedlab-test-xla-")
        os.environ["BIPEDLAB_TEST_XLA_CACHE"] = path  # inherited by the xdist workers
        _created.append(path)
    os.environ.setdefault("BIPEDLAB_CACHE_DIR", path)
    # compiled programs are shared even by the tests that keep their results apart (their own
    # BIPEDLAB_CACHE_DIR: reproduce's stored records); a test that needs a cold compilation
    # cache sets BIPEDLAB_XLA_CACHE_DIR too
    os.environ["BIPEDLAB_XLA_CACHE_DIR"] = path
    from bipedlab import compilecache

    compilecache.enable(path)


_created: list = []
_shared_compile_cache()


def _hypothesis_profiles() -> str:
    """The property tests' draws: on CI (CI set) derandomised, every example a function of the
    test's own source, so one commit gets one verdict; locally random, with the example
    database in .hypothesis/ kept between runs, so a failure found once is replayed first
    until it is fixed. Either way a failure prints the blob that replays it. HYPOTHESIS_PROFILE
    picks one by name (``ci`` replays CI's draws on a desk)."""
    from hypothesis import settings

    settings.register_profile("ci", derandomize=True, database=None, print_blob=True)
    settings.register_profile("dev", print_blob=True)
    name = os.environ.get("HYPOTHESIS_PROFILE") or ("ci" if os.environ.get("CI") else "dev")
    settings.load_profile(name)
    return name


_HYPOTHESIS_PROFILE = _hypothesis_profiles()


def pytest_report_header(config):
    if _HYPOTHESIS_PROFILE == "ci":
        how = "derandomised draws (the same examples on every run of this commit)"
    else:
        how = "random draws; failing examples kept in .hypothesis/ and replayed first"
    return [f"property tests: hypothesis profile '{_HYPOTHESIS_PROFILE}', {how}; a failure prints "
            "'@reproduce_failure(...)' to replay it, HYPOTHESIS_PROFILE=ci replays CI's draws"]


def pytest_unconfigure(config):
    import shutil

    for path in _created:  # only the process that made the folder removes it
        shutil.rmtree(path, ignore_errors=True)


@pytest.fixture(scope="session")
def mujoco():
    return pytest.importorskip("mujoco")


@pytest.fixture(scope="session")
def five():
    from bipedlab.robots.five_link import robot as five_link

    return five_link.model()
