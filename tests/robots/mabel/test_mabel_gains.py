"""The PD + feedforward full-order Poincaré map (eq. 44, Section IV-A) as a function of the PD
gains (``experiment mabel pd-gains``).

The paper reports a dominant eigenvalue of 0.6921 for its nominal gait and 0.8194 for its c_mt
gait under PD + feedforward, without publishing the PD gains. The studies here use the gains
shipped with the gaits (``controllers.default_gains``); the sweep scales every output's kp by
one factor and every kd by another and measures the dominant eigenvalue.
"""
from __future__ import annotations

import numpy as np
import pytest

from bipedlab.robots.mabel.walking import controllers as ctl
from bipedlab.robots.mabel.walking import experiments as wx
from bipedlab.robots.mabel.walking import poincare as mp
from bipedlab.robots.mabel.walking import study as wm


def test_paper_eigenvalues_and_the_studies_gains():
    """The experiment compares with the paper's Section IV-A values (0.6921 nominal, 0.8194
    c_mt gait, exact: they are the published numbers), and the gains it calls the studies'
    are those every walk loads with a shipped gait: controllers.default_gains, kp = (3.5, 45,
    3.5, 60) and kd = (0.05, 1.2, 0.05, 3.0) per output (mLS_st, LA_sw, mLS_sw, Tor), the same
    for both gaits (exact equality: the same constants)."""
    assert wx.PD_PAPER == {"paper-nominal": 0.6921, "paper-efficient": 0.8194} and tuple(wx.PD_PAPER) == wx.PD_GAITS
    d = ctl.default_gains(np.zeros((4, 4, 6)), np.zeros((4, 2)), np.ones(4))
    for gait in wx.PD_GAITS:
        _, g, _ = wm.load_gait(gait)
        assert np.asarray(g.kp).tolist() == np.asarray(d.kp).tolist() == [3.5, 45.0, 3.5, 60.0]
        assert np.asarray(g.kd).tolist() == np.asarray(d.kd).tolist() == [0.05, 1.2, 0.05, 3.0]


def test_closest_gains_are_chosen_by_the_distance_to_the_paper(monkeypatch):
    """The bookkeeping of the sweep on a stand-in map whose Jacobian at every gain pair is
    known: diag(lambda, 0.1, ...) with lambda = 0.9 / (kp_scale * kd_scale) (a stand-in, so
    the check runs without compiling eq. 44, about two minutes). The absolute gains are the
    shipped ones times the factors; the dominant eigenvalue is lambda; the closest point to
    the paper's 0.6921 is the one with |lambda - 0.6921| least (kp x 1, kd x 1.5: 0.6 is
    nearer than 0.9 or 0.45), for the efficient gait's 0.8194 it is (1, 1) with 0.9; a point
    whose map is not finite (kp x 0.5, kd x 0.5 here) has no eigenvalue and is not chosen."""
    def fake(m, gains, vcs, z0s, iterations=10, tol=1e-10):
        n = len(gains)
        J = np.zeros((n, 12, 12))
        res = np.zeros(n)
        for i, g in enumerate(gains):
            a = float(np.asarray(g.kp)[0] / 3.5)
            b = float(np.asarray(g.kd)[0] / 0.05)
            J[i] = np.diag([0.9 / (a * b)] + [0.1] * 11)
            if a == 0.5 and b == 0.5:
                J[i] = np.nan
                res[i] = np.nan
        return np.asarray(z0s), J, res, 1

    monkeypatch.setattr(mp, "pd_fixed_points", fake)
    r = wx.pd_gains(None, None, None, kp_scales=(0.5, 1.0, 2.0), kd_scales=(0.5, 1.0, 1.5))
    pts = r["gains_grid"]["points"]["paper-nominal"]
    p = next(x for x in pts if (x["kp_scale"], x["kd_scale"]) == (2.0, 1.5))
    assert p["kp"] == pytest.approx([7.0, 90.0, 7.0, 120.0]) and p["kd"] == pytest.approx([0.075, 1.8, 0.075, 4.5])
    assert p["dominant_eigenvalue"]["abs"] == pytest.approx(0.3)
    assert next(x for x in pts if (x["kp_scale"], x["kd_scale"]) == (0.5, 0.5))["dominant_eigenvalue"] is None
    c = r["closest_to_paper"]
    assert (c["paper-nominal"]["kp_scale"], c["paper-nominal"]["kd_scale"]) == (1.0, 1.5)
    assert c["paper-nominal"]["dominant_eigenvalue"]["abs"] == pytest.approx(0.6)
    assert (c["paper-efficient"]["kp_scale"], c["paper-efficient"]["kd_scale"]) == (1.0, 1.0)
    assert r["studies_gains"]["paper-nominal"]["dominant_eigenvalue"]["abs"] == pytest.approx(0.9)


def test_batched_newton_finds_a_known_fixed_point_and_jacobian(monkeypatch):
    """pd_fixed_points on an affine stand-in map P(z) = A z + b (per pair its own A, b; entries
    of z far from 1 so that the central-difference steps differ by column): the Jacobian
    returned is A to 1e-6 (central differences are exact on an affine map up to rounding: outputs
    near 100 over steps of 1e-6 to 1.5e-5 leave about 1e-8; a transposed or misscaled Jacobian
    would be off by order one) and the fixed point is (I - A)^-1 b to 1e-10 within three Newton steps; a
    pair whose map is not finite keeps NaN. Guards the orientation of the Jacobian (row: output,
    column: perturbed coordinate), which eigenvalues alone would not (a diagonal rescaling
    keeps them)."""
    rng = np.random.default_rng(0)
    A = [0.4 * rng.standard_normal((12, 12)) for _ in range(3)]
    b = [rng.standard_normal(12) * np.linspace(1.0, 20.0, 12) for _ in range(3)]

    def affine(m, gains, vcs, zs):
        out = np.stack([A[g] @ z + b[g] for g, z in zip(gains, zs)])
        return np.where(np.asarray(gains)[:, None] == 2, np.nan, out)

    monkeypatch.setattr(mp, "_pd_eval", affine)
    z0 = np.tile(np.linspace(-15.0, 15.0, 12), (3, 1))
    z, J, res, its = mp.pd_fixed_points(None, [0, 1, 2], [None] * 3, z0)
    for i in (0, 1):
        assert np.max(np.abs(J[i] - A[i])) < 1e-6
        assert np.max(np.abs(z[i] - np.linalg.solve(np.eye(12) - A[i], b[i]))) < 1e-10
        assert res[i] < 1e-10
    assert np.isnan(res[2]) and np.all(np.isnan(J[2]))
    assert its <= 3


@pytest.fixture(scope="module")
def sweep():
    """The reduced sweep of ``reproduce --quick``: factors 0.75, 1, 1.5 on kp and on kd, both
    gaits (one compilation of the batched map, one to three minutes on two cores)."""
    return wx.run("pd-gains", kp_scales=(0.75, 1.0, 1.5), kd_scales=(0.75, 1.0, 1.5))


@pytest.mark.slow
def test_shipped_gains_eigenvalue_equals_study_poincare(sweep):
    """At the shipped gains the sweep's dominant eigenvalue (Newton with a central-difference
    Jacobian on the batched map) equals study.poincare's (Newton with the exact forward-mode
    Jacobian, its own compiled map) within 1e-6: the central differences (step 1e-6) agree with
    the exact Jacobian to about 1e-7 relative, and both fixed points are converged to 1e-10.
    The paper-nominal gait's eigenvalue is real and positive, 0.7219, as the paper's 0.6921."""
    _, g, rec = wm.load_gait("paper-nominal")
    pc = wm.poincare(wm.design_from_record(rec), g, ("pdff",))
    exact = complex(*pc["pdff"]["poincare_eigenvalues_complex"][0])
    ours = sweep["studies_gains"]["paper-nominal"]["dominant_eigenvalue"]
    assert pc["pdff"]["fixed_point_residual"] < 1e-10
    assert abs(complex(ours["re"], ours["im"]) - exact) < 1e-6
    assert ours["re"] == pytest.approx(0.7219, abs=1e-4) and ours["im"] == 0.0


@pytest.mark.slow
def test_dominant_eigenvalue_changes_with_the_gains_as_measured(sweep):
    """Measured on this model (the paper gives neither its gains nor a sweep): on both gaits of
    the paper's design model the dominant eigenvalue is real and positive at every point of the
    3 x 3 grid, as the paper's, and moves little with the gains: paper-nominal 0.686 (kp and kd
    x 0.75) to 0.747 (x 1.5), nearest the paper's 0.6921 at kp x 0.75, kd x 1 (0.6891);
    paper-efficient 0.767 (x 1.5) to 0.829 (kp x 1.5, kd x 0.75), nearest 0.8194 at kp and kd
    x 0.75 (0.8194). Tolerances 1e-3 on the eigenvalues: the fixed points converge to 1e-10,
    the central-difference Jacobian is good to about 1e-7; 1e-3 keeps the assertion to the
    digits quoted."""
    pts = {g: {(x["kp_scale"], x["kd_scale"]): x["dominant_eigenvalue"] for x in rows}
           for g, rows in sweep["gains_grid"]["points"].items()}
    nom = pts["paper-nominal"]
    assert all(e is not None and 0.6 < e["re"] < 0.8 and e["im"] == 0.0 for e in nom.values())
    assert nom[(1.0, 1.0)]["re"] == pytest.approx(0.7219, abs=1e-3)
    assert nom[(0.75, 0.75)]["re"] == pytest.approx(0.6861, abs=1e-3)
    assert nom[(1.5, 1.5)]["re"] == pytest.approx(0.7471, abs=1e-3)
    c = sweep["closest_to_paper"]["paper-nominal"]
    assert (c["kp_scale"], c["kd_scale"]) == (0.75, 1.0)
    assert c["dominant_eigenvalue"]["re"] == pytest.approx(0.6891, abs=1e-3)
    eff = pts["paper-efficient"]
    assert all(e is not None and 0.7 < e["re"] < 0.9 and e["im"] == 0.0 for e in eff.values())
    assert eff[(1.0, 1.0)]["re"] == pytest.approx(0.8190, abs=1e-3)
    assert eff[(1.5, 1.5)]["re"] == pytest.approx(0.7670, abs=1e-3)
    c = sweep["closest_to_paper"]["paper-efficient"]
    assert (c["kp_scale"], c["kd_scale"]) == (0.75, 0.75)
    assert c["dominant_eigenvalue"]["abs"] == pytest.approx(0.8194, abs=1e-3)
