"""Claim rows of the HZD paper that can fail for the reason the paper states, from stand-in
records: Exp. 4 closer to the designed speed than Exp. 1 (Sec. V-D), a pushed walk whose pinned
toe pulled on the ground has no speed change or recovery to report, and the PD + feedforward
map's dominant eigenvalue compared with its sign (Sec. IV-A: 0.6921, real and positive)."""
from __future__ import annotations

import pytest

from bipedlab.report import Failed, Measured, Skip, values
from bipedlab.robots.mabel import reproduce as R


def _rows():
    return {r["id"]: r for r in values.load(R.DATA / "paper_hzd.json")["rows"]}


def test_exp4_must_walk_closer_to_the_designed_speed_than_exp1():
    tol = _rows()["exp4_closer_to_design_than_exp1"]["tolerance"]
    nom = dict(fell=False, speed_mps=1.0, designed_speed_mps=0.8)
    m = R._closer_to_design(nom, dict(speed_mps=0.9), 0.9, Skip("x"))
    assert isinstance(m, Measured) and m.value == pytest.approx(-0.1)  # the robot's: 0.9 against 1.0
    assert values.agrees(m.value, tol) is True
    m = R._closer_to_design(dict(nom, speed_mps=0.80), dict(speed_mps=0.86), 0.86, Skip("x"))
    assert m.value == pytest.approx(0.06) and values.agrees(m.value, tol) is False
    fallen = Failed("fell")
    assert R._closer_to_design(nom, dict(speed_mps=None), fallen, Skip("x")) is fallen
    assert isinstance(R._closer_to_design(None, dict(speed_mps=0.9), 0.9, Skip("x")), Skip)


def test_a_push_whose_toe_pulled_reports_no_speed_change():
    ok = dict(fell=False, toe_pulled=False)
    assert R._pushed(ok) is None
    pulled = R._pushed(dict(fell=False, toe_pulled=True, min_normal_force_n=-162.0, toe_pulled_step=11))
    assert isinstance(pulled, Failed) and "-162 N in step 11" in pulled.reason
    assert R._pushed(dict(fell=True)).reason == "fell after the push"


def _pdg(re, im, kp=1.0, kd=1.0, paper=0.6921):
    return {"closest_to_paper": {"nominal": dict(kp_scale=kp, kd_scale=kd, paper_abs=paper,
                                                 dominant_eigenvalue=dict(re=re, im=im),
                                                 difference=abs(complex(re, im) - paper))}}


def test_the_pd_eigenvalue_row_compares_the_signed_eigenvalue():
    row = _rows()["nominal_eig_pdff_closest_gains"]
    neg = R._nearest_eigenvalue(_pdg(-0.663, 0.0), "nominal")  # |.| within 0.03, opposite sign
    assert isinstance(neg, Measured) and neg.value == -0.663
    assert values.agrees(neg.value, row["tolerance"], row["paper"]) is False
    near = R._nearest_eigenvalue(_pdg(0.70, 0.01), "nominal")
    assert values.agrees(near.value, row["tolerance"], row["paper"]) is True
    assert isinstance(R._nearest_eigenvalue(_pdg(0.69, 0.2), "nominal"), Failed)  # complex: no real stands for it
    assert isinstance(R._nearest_eigenvalue({"closest_to_paper": {"nominal": None}}, "nominal"), Failed)
