"""Comparison helpers of the golden tests (no bipedlab import).

``strip_timing`` removes what differs between runs of the same code: wall-clock durations,
compile times, throughput / real-time ratios, device and version strings. Keys removed
(recursively, in any nested dict):

* explicitly: TIMING_KEYS below;
* by pattern TIMING_PATTERN: any key containing ``wall``, ``compile``, ``elapsed``,
  ``real_time``, ``realtime``, ``speedup``, ``_warm_s`` / ``_cold_s``, ending in ``_per_s``,
  or starting with ``device`` / ``version`` / ending in ``_version``.

Simulated times (``duration_s``, ``sim_time_s``, ``simulated_time_s``, ``period_s``,
``settling_time_s``, ...) are results and are NOT removed.
"""
from __future__ import annotations

import json
import math
import re

import numpy as np

TIMING_KEYS = frozenset({
    "wall_s", "wall_time_s", "compile_s", "compile_time_s", "run_s", "real_time_fraction",
    "optimize_warm_s", "optimize_cold_s", "warm_s", "cold_s", "solve_s", "solve_time_s",
    "time_s", "seconds", "substeps_per_s", "device", "devices", "platform", "version",
    "jax_version", "numpy_version", "mujoco_version", "bipedlab_version", "python_version",
})
TIMING_PATTERN = re.compile(
    r"wall|compile|elapsed|real_?time|speedup|_warm_s$|_cold_s$|_per_s$|^device|^version|_version$")


def is_timing_key(key) -> bool:
    return isinstance(key, str) and (key in TIMING_KEYS or bool(TIMING_PATTERN.search(key)))


def strip_timing(obj):
    """A copy of obj without the timing / environment keys (recursively)."""
    if isinstance(obj, dict):
        return {k: strip_timing(v) for k, v in obj.items() if not is_timing_key(k)}
    if isinstance(obj, (list, tuple)):
        return [strip_timing(v) for v in obj]
    return obj


def to_jsonable(obj):
    """numpy arrays / scalars -> lists / Python numbers (NaN kept; json writes NaN)."""
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating):
        return float(obj)
    return obj


def dump(obj, path) -> None:
    with open(path, "w") as fh:
        json.dump(to_jsonable(obj), fh, indent=None, separators=(",", ":"), allow_nan=True)
        fh.write("\n")


def load(path):
    with open(path) as fh:
        return json.load(fh)


def _tol(path: str, rtol: float, atol: float, special) -> tuple[float, float]:
    for prefix, r, a in special:
        if prefix.startswith("*"):  # "*name": any path containing name (e.g. every rel_error)
            if prefix[1:] in path:
                return r, a
        elif path == prefix or path.startswith(prefix + ".") or path.startswith(prefix + "["):
            return r, a
    return rtol, atol


def differences(new, ref, rtol=1e-9, atol=1e-12, special=(), path="") -> list[str]:
    """Human-readable list of mismatches between a fresh result and the recorded one:
    numbers to |new - ref| <= atol + rtol |ref| (NaN == NaN), bools / strings / None exactly,
    dict keys and list lengths exactly."""
    out: list[str] = []
    where = path or "<root>"
    if isinstance(ref, dict):
        if not isinstance(new, dict):
            return [f"{where}: expected a dict, got {type(new).__name__}"]
        if set(new) != set(ref):
            out.append(f"{where}: keys differ: missing {sorted(set(ref) - set(new))}, "
                       f"extra {sorted(set(new) - set(ref))}")
        for k in ref:
            if k in new:
                out += differences(new[k], ref[k], rtol, atol, special, f"{path}.{k}" if path else k)
        return out
    if isinstance(ref, list):
        if not isinstance(new, list) or len(new) != len(ref):
            return [f"{where}: expected a list of {len(ref)}, got {type(new).__name__} "
                    f"of {len(new) if isinstance(new, list) else '-'}"]
        for i, (a, b) in enumerate(zip(new, ref)):
            out += differences(a, b, rtol, atol, special, f"{path}[{i}]")
        return out
    if isinstance(ref, bool) or ref is None or isinstance(ref, str):
        if type(new) is not type(ref) or new != ref:
            out.append(f"{where}: {new!r} != recorded {ref!r}")
        return out
    if isinstance(ref, (int, float)):
        if isinstance(new, bool) or not isinstance(new, (int, float)):
            return [f"{where}: expected a number, got {new!r}"]
        if isinstance(ref, int) and isinstance(new, int):
            if new != ref:
                out.append(f"{where}: {new} != recorded {ref}")
            return out
        if math.isnan(ref) or math.isnan(new):
            if not (math.isnan(ref) and math.isnan(new)):
                out.append(f"{where}: {new!r} != recorded {ref!r}")
            return out
        r, a = _tol(path, rtol, atol, special)
        if not abs(new - ref) <= a + r * abs(ref):
            out.append(f"{where}: {new!r} != recorded {ref!r} (rel {abs(new - ref) / max(abs(ref), 1e-300):.2e},"
                       f" tol rel {r:g} abs {a:g})")
        return out
    return [f"{where}: unsupported recorded type {type(ref).__name__}"]
