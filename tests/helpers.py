"""Numerical helpers shared by the tests (importable: tests/ is on sys.path via conftest)."""
from __future__ import annotations

import numpy as np


def mj_full_inertia(mujoco, m, d) -> np.ndarray:
    """Dense joint-space inertia from MuJoCo: MuJoCo >= 4 takes (m, d, dst); older versions
    take (m, dst, d.qM)."""
    dst = np.zeros((m.nv, m.nv))
    try:
        mujoco.mj_fullM(m, d, dst)
    except TypeError:
        mujoco.mj_fullM(m, dst, d.qM)
    return dst


def rel_err(a, b) -> float:
    """||a - b|| / ||b|| (Frobenius for matrices), guarded against a zero reference."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.linalg.norm(a - b) / max(np.linalg.norm(b), 1e-300))


def random_states(rng: np.random.Generator, n: int, nq: int, qd_scale: float = 2.0):
    """n random (q, qd) with base position ~ U(-1, 1) m, angles ~ U(-pi, pi)."""
    q = rng.uniform(-np.pi, np.pi, size=(n, nq))
    q[:, :2] = rng.uniform(-1.0, 1.0, size=(n, 2))
    qd = qd_scale * rng.standard_normal(size=(n, nq))
    return q, qd


def expect_usage_error(argv, capsys, needle=None) -> str:
    """Run ``bipedlab`` with argv and check the bad-input contract: exit status 2, nothing on
    stdout, one ``bipedlab: error: ...`` line on stderr (containing needle if given). Returns
    that line."""
    import pytest

    from bipedlab import cli

    with pytest.raises(SystemExit) as exc:
        cli.main(argv)
    assert exc.value.code == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("bipedlab: error: "), captured.err
    if needle is not None:
        assert needle in lines[0], lines[0]
    return lines[0]


_COMPILE_EVENTS = {"/jax/core/compile/jaxpr_trace_duration": "traced",
                   "/jax/core/compile/jaxpr_to_mlir_module_duration": "lowered",
                   "/jax/core/compile/backend_compile_duration": "compiled"}
_compile_counts = {v: 0 for v in _COMPILE_EVENTS.values()}
_listening: list = []


def compile_counts() -> dict:
    """Running totals, in this process, of the functions JAX traced, the programs it lowered to
    XLA and the programs XLA compiled (or loaded from the persistent cache): take the
    difference around a call to see whether the call built a new program."""
    if not _listening:
        from jax import monitoring

        def on_duration(event, secs, **_):
            kind = _COMPILE_EVENTS.get(event)
            if kind:
                _compile_counts[kind] += 1

        monitoring.register_event_duration_secs_listener(on_duration)
        _listening.append(True)
    return dict(_compile_counts)


def new_programs(fn, *args, **kwargs):
    """(fn's result, the number of programs lowered to XLA while it ran)."""
    before = compile_counts()["lowered"]
    out = fn(*args, **kwargs)
    return out, compile_counts()["lowered"] - before
