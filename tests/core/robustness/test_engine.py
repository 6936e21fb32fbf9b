"""The robustness engine on a study with a closed-form oracle (an undamped pendulum, whose
energy decides whether a swing passes the limit), and its bookkeeping: padding and chunking do
not change a trial's outcome, the seed fixes the draws, the survival map is the per-cell mean."""
from __future__ import annotations

import json

import numpy as np
import pytest

from bipedlab import robustness as rb
from bipedlab.robustness import engine

from .pendulum_study import W2, LIMIT, energy_falls, study

KEYS = {"trials", "survival_rate", "trials_per_s", "device", "devices", "processes", "seed", "axes",
        "survival_map", "cell_trials", "fell_at_histogram"}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    out = {}
    for name, trials, chunk in (("a", 37, 16), ("b", 37, 3)):
        d = tmp_path_factory.mktemp(name)
        rec = engine.run(study(), trials, seed=11, chunk=chunk, out=str(d), progress=False)
        out[name] = (rec, dict(np.load(d / "outcomes.npz")), d)
    return out


def test_survival_is_the_energy_criterion(runs):
    rec, o, _ = runs["a"]
    th, om = o["param_theta0"], o["param_omega0"]
    margin = np.abs(0.5 * om ** 2 - W2 * np.cos(th) + W2 * np.cos(LIMIT))
    clear = margin > 0.05 * W2  # away from the separatrix, where the 2.4 s horizon decides
    falls = energy_falls(th, om)
    assert clear.sum() > 25
    assert np.array_equal(o["survived"][clear], ~falls[clear])
    assert not o["nonfinite"].any()
    # a fallen trial stops at the first sample past the limit: within one sample's swing of it
    fallen = ~o["survived"]
    assert np.all(o["fell_at"][fallen] == o["completed"][fallen]) and np.all(o["fell_at"][~fallen] == -1)
    assert np.all(np.abs(o["final_theta"][fallen]) > LIMIT)
    assert np.all(np.abs(o["final_theta"][fallen]) < LIMIT + 0.02 * 8.0)  # T = 20 ms, |omega| < 8 rad/s


def test_record(runs):
    rec, o, d = runs["a"]
    assert KEYS <= set(rec)
    json.dumps(rec, allow_nan=False)
    assert rec["trials"] == 37 and rec["processes"] == 1 and rec["devices"] >= 1
    assert rec["survival_rate"] == pytest.approx(o["survived"].mean())
    assert rec["trials_per_s"] > 0
    assert sum(rec["fell_at_histogram"]) == rec["fell"] + rec["nonfinite"] == int((~o["survived"]).sum())
    frac, count = rb.survival_map({"theta0": o["param_theta0"], "omega0": o["param_omega0"]}, o["survived"],
                                  study().axes)
    assert np.asarray(rec["cell_trials"]).sum() == 37
    ax = study().axes
    i = np.clip(((o["param_theta0"] - ax[0].lo) / (ax[0].hi - ax[0].lo) * ax[0].bins).astype(int), 0, 5)
    j = np.clip(((o["param_omega0"] - ax[1].lo) / (ax[1].hi - ax[1].lo) * ax[1].bins).astype(int), 0, 5)
    for a in range(6):
        for b in range(6):
            sel = (i == a) & (j == b)
            v = rec["survival_map"][a][b]
            assert (v is None) == (not sel.any())
            if sel.any():
                assert v == pytest.approx(o["survived"][sel].mean())
    for f in ("survival_map.png", "survival_by_axis.png", "fell_at.png"):
        assert (d / f).stat().st_size > 1000


def test_chunks_and_padding_do_not_change_outcomes(runs):
    (ra, a, _), (rb_, b, _) = runs["a"], runs["b"]
    assert ra["padded_to"] != rb_["padded_to"] or ra["chunk_per_device"] != rb_["chunk_per_device"]
    for k in ("status", "completed", "final_theta", "param_theta0", "param_omega0"):
        assert np.array_equal(a[k], b[k]), k


def test_seed_fixes_the_draws():
    s = study()
    a = s.sample(np.random.default_rng(4), 10)
    b = s.sample(np.random.default_rng(4), 10)
    c = s.sample(np.random.default_rng(5), 10)
    assert all(np.array_equal(a[k], b[k]) for k in a)
    assert not np.array_equal(a["theta0"], c["theta0"])


def test_grid_visits_every_cell_centre():
    axes = (rb.Axis("x", 0.0, 1.0, 4), rb.Axis("y", -2.0, 2.0, 2))
    g = rb.grid(8, axes)
    pts = sorted(zip(g["x"], g["y"]))
    want = sorted((x, y) for x in (0.125, 0.375, 0.625, 0.875) for y in (-1.0, 1.0))
    assert np.allclose(pts, want)
