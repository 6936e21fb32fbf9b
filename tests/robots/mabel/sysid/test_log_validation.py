"""Experiment logs are checked completely when read: every damaged CSV log gives one LogError line
starting with the file's name, or reads as an experiment its estimator can fit (property-based,
hypothesis); each estimator's preconditions (rows, postures, excitation, rank), the metadata's
values and the columns' agreement with the experiment are checked before any fit; the summary
prints null estimates; `identify mabel --data BAD` exits 2 with one line before compiling."""
from __future__ import annotations

import time

import jax
import numpy as np
import pytest
from helpers import expect_usage_error
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mutations import csv_bytes

from bipedlab import cli
from bipedlab.robots.mabel import sysid
from bipedlab.robots.mabel.sysid import preconditions
from bipedlab.robots.mabel.sysid import study as im
from bipedlab.robots.mabel.sysid.logs import HOP_ENCODERS, Experiment, LogError, read_log, read_logs, write_log

SETTINGS = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
H = 1e-3


def _rotor(u, J=3e-4, mu=2e-3, bias=0.01):
    """Angles of a first-order rotor J w' + mu w = u + bias (explicit Euler at 1 kHz)."""
    w, th, out = 0.0, 0.0, []
    for v in u:
        out.append(th)
        th += H * w
        w += H * (v + bias - mu * w) / J
    return np.array(out)


def _t(n):
    return np.arange(n) * H


def valid_experiments() -> dict:
    """One small valid experiment of each kind (and both leg modes), built directly."""
    out = {}
    t = _t(400)
    u = 0.02 * np.sin(2 * np.pi * 3 * t) + 0.01 * np.sin(2 * np.pi * 11 * t)
    out["bias"] = Experiment("bias_mLA_L", "bias", t, {"mLA_L": u}, {"mla_L": _rotor(u)}, meta=dict(actuator="mLA_L"))
    out["transmission"] = Experiment("transmission_mLS_R_2", "transmission", t[:200], {"mLS_R": u[:200]},
                                     {"mls_R": _rotor(u[:200], J=6e-4)},
                                     meta=dict(actuator="mLS_R", combination=2, cad_inertia=2.4e-4))
    t = _t(120)
    ua, us = 0.5 * np.sin(2 * np.pi * 4 * t), 0.3 * np.cos(2 * np.pi * 5 * t)
    enc = {"mla_L": 0.1 * np.sin(2 * np.pi * 4 * t + 0.3) + 1.0, "mls_L": 0.05 * np.cos(2 * np.pi * 5 * t) + 0.4}
    out["leg_siso"] = Experiment("leg_siso_mLA_L", "leg", t, {"mLA_L": ua}, dict(enc, mls_L=np.full(len(t), 0.4)),
                                 meta=dict(side="L", mode="siso", actuated="mLA_L"))
    out["leg_mimo"] = Experiment("leg_mimo_L", "leg", t, {"mLA_L": ua, "mLS_L": us}, enc,
                                 meta=dict(side="L", mode="mimo", actuated="mLA_L mLS_L"))
    n = 5
    ls = np.deg2rad(np.linspace(10, 30, n))
    out["spring"] = Experiment("spring_L", "spring", np.arange(n, dtype=float), {},
                               dict(tor=0.1 + 0.01 * np.arange(n), la_L=np.full(n, np.pi), ls_L=ls,
                                    bsp_L=0.01 * np.arange(n), la_R=np.full(n, 2.7), ls_R=np.full(n, 0.9)),
                               scale=np.full(n, 640.0), meta=dict(side="L"))
    out["balance"] = Experiment("balance_stance", "balance", np.arange(n, dtype=float), {},
                                dict(tor=np.linspace(-0.1, 0.1, n), la_L=np.full(n, 3.0), ls_L=np.full(n, 0.3),
                                     la_R=np.full(n, 3.2), ls_R=np.full(n, 0.2)), meta=dict(support="toe_R"))
    t = _t(150)
    rng = np.random.default_rng(0)
    out["hopping"] = Experiment("hopping", "hopping", t,
                                {a: 0.1 * np.sin(2 * np.pi * (k + 1) * t) for k, a in enumerate(sysid.params.ACTUATORS)},
                                {c: 0.01 * np.cumsum(rng.standard_normal(len(t))) for c in HOP_ENCODERS},
                                meta=dict(release_s=0.05, boom_radius=2.25))
    return out


@pytest.fixture(scope="module")
def texts(tmp_path_factory) -> dict:
    d = tmp_path_factory.mktemp("valid_logs")
    return {k: write_log(e, d / f"{e.name}.csv").read_text() for k, e in valid_experiments().items()}


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("damaged_logs")


def _read_or_error(path):
    """The experiment read, or the LogError's message (asserted one line naming the file)."""
    try:
        e = read_log(path)
    except LogError as err:
        msg = str(err)
        assert msg.startswith(f"{path}: "), msg
        assert "\n" not in msg and "\r" not in msg, msg
        return msg
    assert preconditions.problem(e) is None
    for v in [e.t, *e.u.values(), *e.enc.values()] + ([e.scale] if e.scale is not None else []):
        assert np.all(np.isfinite(v))
    return None


def test_the_valid_logs_read(texts, tmp_path):
    for kind, text in texts.items():
        path = tmp_path / f"{kind}.csv"
        path.write_text(text)
        assert _read_or_error(path) is None, kind


def _check(folder, drawn):
    _, raw = drawn
    path = folder / "log.csv"
    path.write_bytes(raw)
    _read_or_error(path)


@settings(max_examples=300, **SETTINGS)
@given(data=st.data())
def test_damaged_logs_read_or_fail_on_one_line(texts, folder, data):
    _check(folder, data.draw(csv_bytes(texts)))


@pytest.mark.slow
@settings(max_examples=3000, **SETTINGS)
@given(data=st.data())
def test_damaged_logs_read_or_fail_on_one_line_many(texts, folder, data):
    _check(folder, data.draw(csv_bytes(texts)))


# ----- each category, by example ---------------------------------------------------------------
def _with(e: Experiment, **changes) -> Experiment:
    import dataclasses

    return dataclasses.replace(e, **changes)


def _cases():
    v = valid_experiments()
    b, tr, leg, sp, bal, hop = (v[k] for k in ("bias", "transmission", "leg_siso", "spring", "balance", "hopping"))
    n = len(b.t)
    return {
        "bias too short": (_with(b, t=b.t[:100], u={"mLA_L": b.u["mLA_L"][:100]}, enc={"mla_L": b.enc["mla_L"][:100]}),
                           "has 100 samples; the bias fit (ARX on 10 ms blocks) needs at least 161"),
        "bias all-zero command": (_with(b, u={"mLA_L": np.zeros(n)}),
                                  "the command u_mLA_L never changes (no excitation"),
        "bias rotor still": (_with(b, enc={"mla_L": np.zeros(n)}), "the motor encoder enc_mla_L never changes"),
        "bias rank-deficient": (_with(b, u={"mLA_L": np.where(np.arange(n) < 10, 1.0, 0.0)},
                                      enc={"mla_L": np.cumsum(np.arange(n) < 10) * 1e-3}),
                                "the ARX regressor (speed, command, lagged command, constant) is rank-deficient"),
        "transmission unexcited": (_with(tr, u={"mLS_R": np.full(len(tr.t), 0.3)}), "the command u_mLS_R never changes"),
        "leg motor still": (_with(leg, enc=dict(leg.enc, mla_L=np.full(len(leg.t), 1.0))),
                            "the motor encoder enc_mla_L never changes"),
        "spring too few postures": (_with(sp, t=sp.t[:2], enc={k: x[:2] for k, x in sp.enc.items()}, scale=sp.scale[:2]),
                                    "has 2 postures; the spring fit needs at least 3"),
        "spring one deflection": (_with(sp, enc=dict(sp.enc, bsp_L=np.zeros(5))),
                                  "enc_bsp_L has one value over all postures"),
        "balance one posture": (_with(bal, t=bal.t[:1], enc={k: x[:1] for k, x in bal.enc.items()}),
                                "has 1 posture; the COM check needs at least 2"),
        "balance one torso angle": (_with(bal, enc=dict(bal.enc, tor=np.zeros(5))), "enc_tor has one value"),
        "hopping release too late": (_with(hop, meta=dict(hop.meta, release_s=0.14)),
                                     "has 10 samples from the release (release_s 0.14) on; the hopping fits need at "
                                     "least 20"),
        "hopping release after the end": (_with(hop, meta=dict(hop.meta, release_s=0.5)),
                                          "metadata release_s=0.5 is after the log's end"),
        "hopping release unparsable": (_with(hop, meta=dict(hop.meta, release_s="soon")),
                                       "metadata release_s='soon' is not a number (s)"),
        "hopping release negative": (_with(hop, meta=dict(hop.meta, release_s=-1)),
                                     "metadata release_s=-1 is outside [0, 1e+07] s"),
        "hopping boom radius": (_with(hop, meta=dict(hop.meta, boom_radius=0)),
                                "metadata boom_radius=0 is outside [0.5, 10] m"),
        "hopping motor still": (_with(hop, enc=dict(hop.enc, mls_R=np.zeros(150))),
                                "the motor encoder enc_mls_R never changes (the rotor does not move under u_mLS_R) "
                                "after the release"),
        "cad_inertia unparsable": (_with(tr, meta=dict(tr.meta, cad_inertia="big")),
                                   "metadata cad_inertia='big' is not a number (kg m^2)"),
        "cad_inertia out of range": (_with(tr, meta=dict(tr.meta, cad_inertia=5.0)),
                                     "metadata cad_inertia=5.0 is outside [1e-07, 0.01] kg m^2"),
        "SISO log with an extra actuator": (_with(leg, u=dict(leg.u, mLS_L=leg.u["mLA_L"])),
                                            "a siso leg log with 2 command columns (u_mLA_L, u_mLS_L); siso means 1"),
        "MIMO log with one actuator": (_with(v["leg_mimo"], u={"mLA_L": leg.u["mLA_L"]}),
                                       "a mimo leg log with 1 command column (u_mLA_L); mimo means 2"),
        "actuated disagrees": (_with(leg, meta=dict(leg.meta, mode="siso", actuated="mLS_L")),
                               "metadata actuated='mLS_L' but the commands logged are u_mLA_L"),
        "leg log of the other side": (_with(leg, u=dict(leg.u, mLA_R=leg.u["mLA_L"]), meta=dict(side="L")),
                                      "column 'u_mLA_R' in a leg log of side L"),
        "bias log with a second actuator": (_with(b, u=dict(b.u, mLS_L=b.u["mLA_L"])),
                                            "column 'u_mLS_L' in a bias log of actuator mLA_L"),
        "static log with a command": (_with(bal, u={"mLA_L": np.arange(5.0)}),
                                      "column 'u_mLA_L' in a static balance log"),
        "scale outside a spring log": (_with(bal, scale=np.ones(5)), "column 'scale_N' in a balance log"),
        "unknown encoder": (_with(bal, enc=dict(bal.enc, knee_L=np.arange(5.0))), "column 'enc_knee_L' names no encoder"),
        "huge command": (_with(tr, u={"mLS_R": tr.u["mLS_R"] * 1e9}), "column 'u_mLS_R' has"),
    }


CASES = _cases()


@pytest.mark.parametrize("case", list(CASES))
def test_each_precondition_is_one_line_naming_the_file(tmp_path, case):
    exp, needle = CASES[case]
    path = write_log(exp, tmp_path / f"{exp.name}.csv")
    msg = _read_or_error(path)
    assert msg is not None and needle in msg, msg


def test_identify_checks_in_memory_experiments_before_any_fit():
    exp, needle = CASES["bias all-zero command"]
    with pytest.raises(LogError) as err:
        sysid.identify([exp])
    assert str(err.value).startswith("bias_mLA_L: ") and needle in str(err.value)


def test_logs_that_cannot_be_fitted_together(tmp_path):
    tr = valid_experiments()["transmission"]
    write_log(tr, tmp_path / "a.csv")
    write_log(_with(tr, name="other"), tmp_path / "b.csv")
    with pytest.raises(LogError, match=r"b\.csv: a second transmission log of mLS_R for combination 2 \(the first: "):
        read_logs(tmp_path)
    write_log(_with(tr, name="other", meta=dict(tr.meta, combination=3)), tmp_path / "b.csv")
    with pytest.raises(LogError, match=r"b\.csv: cad_inertia 0.00024 kg m\^2 equals that of .*a\.csv"):
        read_logs(tmp_path)
    write_log(_with(tr, name=tr.name, meta=dict(tr.meta, combination=3, cad_inertia=1e-4)), tmp_path / "b.csv")
    with pytest.raises(LogError, match=r"b\.csv: its name 'transmission_mLS_R_2' is also that of .*a\.csv"):
        read_logs(tmp_path)


def test_a_fit_that_fails_is_one_log_error_naming_the_files():
    """Logs that meet every precondition but that the rotor model cannot explain (the angle
    runs against the command): K_T comes out negative, and identify says so in one line."""
    tr = valid_experiments()["transmission"]
    a = _with(tr, enc={"mls_R": -tr.enc["mls_R"]}, source="a.csv")
    b = _with(a, name="t3", meta=dict(tr.meta, combination=3, cad_inertia=2.7e-4), source="b.csv")
    with pytest.raises(LogError) as err:
        sysid.identify([a, b])
    msg = str(err.value)
    assert msg.startswith("a.csv, b.csv: ") and "not both positive" in msg and "\n" not in msg


def test_summary_prints_null_estimates():
    rec = dict(mode="data", logs=1, data="d", wall_time_s=None,
               parameters=[dict(name="kt_mLA_L", estimate=None, unit="N m/N m"),
                           dict(name="spring_k_L", estimate=1.5, unit="N m/rad")],
               com_check=dict(max_abs_mm=None, distance_mm={"b": [1.0]}, torso_com_shift_mm=[None, 1.0]),
               validation_rms_deg=0.5, validation_cable_stretch_rms_deg=None)
    text = im.summary(rec)
    assert "kt_mLA_L                   - N m/N m" in text and "largest distance - mm" in text
    synthetic = dict(rec, mode="synthetic", seed=0, noise_level=1.0, design="quick",
                     max_rel_error={"friction": None, "motor_constant": 0.01}, max_rel_error_identified={},
                     targets={"friction": 0.1}, targets_met={}, max_abs_bias_error_nm=None,
                     max_abs_bias_error_arx_nm=None,
                     noise_study=dict(rows=[dict(noise=0.0, max_rel_error={"friction": None},
                                                 max_abs_bias_error_nm=None)]))
    text = im.summary(synthetic)
    assert "largest bias error: - mN m" in text


@pytest.fixture
def nothing_compiles(monkeypatch):
    monkeypatch.setattr(cli, "_enable_compile_cache", lambda: None, raising=False)
    compiled = []
    listener = lambda event, duration, **kw: compiled.append(event) if "backend_compile" in event else None  # noqa: E731
    jax.monitoring.register_event_duration_secs_listener(listener)
    yield compiled
    jax.monitoring.unregister_event_duration_listener(listener)


@pytest.mark.parametrize("case", ["bias all-zero command", "SISO log with an extra actuator", "hopping release unparsable",
                                  "spring too few postures"])
def test_cli_refuses_bad_logs_before_compiling(tmp_path, capsys, nothing_compiles, case):
    exp, needle = CASES[case]
    good = valid_experiments()["transmission"]
    write_log(good, tmp_path / f"{good.name}.csv")
    path = write_log(exp, tmp_path / f"{exp.name}.csv")
    t0 = time.perf_counter()
    line = expect_usage_error(["identify", "mabel", "--data", str(tmp_path)], capsys, needle=needle)
    assert time.perf_counter() - t0 < 5.0
    assert line.startswith(f"bipedlab: error: {path}: ")
    assert not nothing_compiles, nothing_compiles
