"""Golden tests: the golden helpers importable. The compiled programs come from the test run's
shared compilation cache (fresh for each run, so nothing is reused from an earlier run; the
records exclude timings, and a program loaded from the cache computes the same values as one
compiled anew)."""
from __future__ import annotations

import os
import sys

sys.path.insert(0, os.path.dirname(__file__))
