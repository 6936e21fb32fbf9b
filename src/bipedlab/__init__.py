"""bipedlab: planar bipedal robots in JAX — models, controllers, batched simulation.

Importing bipedlab makes float64 JAX's default without importing JAX (so that the command
line's parser and ``--help`` stay light): JAX reads ``JAX_ENABLE_X64`` when it is first
imported, and a JAX imported before bipedlab is switched over directly."""
import os as _os
import sys as _sys

if "jax" in _sys.modules:
    _sys.modules["jax"].config.update("jax_enable_x64", True)
else:
    _os.environ["JAX_ENABLE_X64"] = "1"

__version__ = "0.1.0"
