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
