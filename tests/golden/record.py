"""Re-record the golden data: ``python tests/golden/record.py [CASE ...]`` (all cases by
default; the names are those of golden_cases.ALL). Prints each case's wall time."""
from __future__ import annotations

import os
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [HERE, os.path.join(os.path.dirname(HERE))]
os.environ["BIPEDLAB_CACHE_DIR"] = tempfile.mkdtemp(prefix="bipedlab-golden-xla-")

import adapter  # noqa: E402
import compare  # noqa: E402
import golden_cases  # noqa: E402


def compute(name: str):
    case = golden_cases.ALL[name]
    if case.func == "cli":
        return compare.strip_timing(adapter.cli_record(case.args))
    return getattr(adapter, case.func)(*case.args)


def main(names) -> None:
    os.makedirs(os.path.join(HERE, "data"), exist_ok=True)
    for name in names or list(golden_cases.ALL):
        t0 = time.perf_counter()
        value = compute(name)
        if name == "cli_identify_mabel_quick":  # the per-parameter estimates, on their own too
            compare.dump(adapter.sysid_quick(value), os.path.join(HERE, "data", "sysid_quick.json"))
        compare.dump(value, os.path.join(HERE, "data", f"{name}.json"))
        print(f"{time.perf_counter() - t0:8.1f} s  {name}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
