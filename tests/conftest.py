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


@pytest.fixture(scope="session")
def mujoco():
    return pytest.importorskip("mujoco")


@pytest.fixture(scope="session")
def five():
    from bipedlab.robots.five_link import robot as five_link

    return five_link.model()
