"""Study: spring-mass running embedded in the ATRIAS-like biped over unobserved terrain
(running paper, Section IV): flat ground, random steps, slopes, sensor noise, delay and model
errors, beside the pure spring-mass model on the same terrains (Fig. 8).

``simulate`` runs one or many trials batched in one compiled chunk function (time chunks of
1 s re-use it, with a progress bar on stderr; energy options, model errors, noise and delays
share it, see :func:`chunk_function`) and returns the per-trial apex records and
status; ``study`` turns them into the record printed by ``bipedlab run atrias``.
Statistics skip the first two apexes (the start transient) and, for the robot, count only
apexes before a fall; ``apex_height_error_steady_m`` and ``speed_error_steady_mps`` (also as
``last10``) are the mean errors over the last ten apexes of each surviving trial, the paper's
steady-state errors, beside the whole-run means that include the start transient.
On flat ground the record also holds the pure spring-mass model with the exact policy
(``slip_model_exact_policy``) beside the one with the controller's polynomial (``slip_model``,
with the polynomial's fit error ``policy_fit``, :func:`bipedlab.control.slip.fit_error`).
"""
from __future__ import annotations

import functools
import os
import sys
import time
import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.robots.atrias import catalog
from bipedlab.robots.atrias import controller as rc
from bipedlab.robots.atrias import controller_model as rm
from bipedlab.control import slip
from bipedlab.robots.atrias import robot as at
from bipedlab.robots.atrias import loop as ar
from bipedlab.robots.atrias import slip_run
from bipedlab.contact import terrain as tr
from bipedlab.outputs import dump_json

MODEL_ERRORS = catalog.MODEL_ERRORS
#: rough terrains (--terrain) -> bipedlab.contact.terrain.rough mode
ROUGH_MODES = catalog.ROUGH_MODES
SKIP_APEX = 2
STEADY_APEXES = 10  # the steady state: the last ten apexes of a run
_CHUNKS: dict = {}  # compiled chunk functions, re-used across calls in one process


@dataclasses.dataclass(frozen=True)
class Settings:
    terrain: str = "flat"
    step_height: float = 0.25
    slope: float = 1.0
    seconds: float | None = None
    distance: float = 60.0
    noise: bool = False
    delay_ms: float = 0.0
    delay_compensation: bool = False  # the controller knows its delay and bridges it (see controller.py)
    model_error: tuple = ()          # ((name, rel), ...)
    energy: str = "regulation"
    trials: int | None = None
    seed: int = 0
    theta0_offset_deg: float = 0.0  # initial trunk perturbation (flat-ground test of IV-A)
    rough_grade_percent: float = 0.0  # rough terrain with a persistent slope (IV-B), --slope with rough
    controller: str = "paper"         # the paper's controller as published, or "bipedlab" (catalog.ADDITIONS)
    # two values of the controller the paper does not give (None: the controller's own):
    energy_gain: float | None = None  # share of the lift-off energy error a nominal stance removes (eq. 7's c)
    reference_weights: tuple | None = None  # (w_theta, w_phi) of the flight's compensated reference
    per_trial: bool = False  # a batched run's record lists each trial's statistics (``per_trial``)
    # the robot's values scaled, plant and controller alike (a different robot, the controller made
    # for it; :data:`bipedlab.robots.atrias.catalog.SCALABLE`): ((name, factor), ...)
    scale: tuple = ()


def parse_model_errors(items) -> tuple:
    """["mass=0.2", ...] -> (("mass", 0.2), ...); raises ValueError with one line."""
    out = []
    for it in items:
        name, sep, val = str(it).partition("=")
        if not sep or name not in MODEL_ERRORS:
            raise ValueError(f"--model-error expects NAME=REL with NAME one of {', '.join(MODEL_ERRORS)}, got {it!r}")
        try:
            rel = float(val)
        except ValueError:
            raise ValueError(f"--model-error {name}: {val!r} is not a number") from None
        if not np.isfinite(rel) or rel <= -1.0:
            raise ValueError(f"--model-error {name}: relative error must be finite and > -1, got {val}")
        out.append((name, rel))
    return tuple(out)


def build(st: Settings):
    """Robot, controller parameters (with the model-error scaling) and the nominal policy
    (cached per model error and energy option)."""
    if st.controller not in catalog.CONTROLLERS:
        raise ValueError(f"controller must be one of {', '.join(catalog.CONTROLLERS)}, got {st.controller!r}")
    rp, cp, gait, samples = _build(tuple(st.model_error), st.energy, tuple(st.scale))
    if st.energy_gain is not None:  # c is proportional to the gain
        cp = cp.replace(c_energy=cp.c_energy * float(st.energy_gain) / rc.ENERGY_GAIN)
    if st.reference_weights is not None:
        cp = cp.replace(w_theta=float(st.reference_weights[0]), w_phi=float(st.reference_weights[1]))
    return rp, (rc.paper_controller(cp) if st.controller == "paper" else cp), gait, samples


def robot(scale=()):
    """(the robot's :class:`~bipedlab.robots.atrias.robot.AtriasParams`, its spring-mass model's
    :class:`~bipedlab.control.slip.SlipParams`) with the values of ``scale`` ((name, factor), ...;
    names of :data:`~bipedlab.robots.atrias.catalog.SCALABLE`) scaled."""
    sc = dict(scale)
    bad = sorted(set(sc) - set(catalog.SCALABLE))
    if bad:
        raise ValueError(f"scale: unknown value {bad[0]!r}; choose from {', '.join(catalog.SCALABLE)}")
    rp, smm = at.AtriasParams(), slip.SlipParams()
    rp = rp.replace(**{k: getattr(rp, k) * f for k, f in sc.items() if hasattr(rp, k)})
    smm = smm.replace(m=rp.m, **{k: getattr(smm, k) * f for k, f in sc.items() if k in ("k0", "l0")})
    return rp, smm


@functools.lru_cache(maxsize=16)
def _build(model_error, energy, scale=()):
    rp, smm = robot(scale)
    err = dict(model_error)
    s_m, s_i, s_f, s_k = (1 + err.get(k, 0.0) for k in MODEL_ERRORS)
    mp = rm.ModelParams(rp.m * s_m, rp.I_t * s_i, rp.I_m * s_i, rp.d, rp.mu_slide * s_f, m_f=rp.m_f * s_m)
    gait = slip.Gait(rc.APEX_HEIGHT, rc.SPEED)
    # A model error is one of the controller's model wherever the controller uses it, the plant
    # keeping its true values (Sec. IV-C: mass and stiffness errors "produce errors in foot placement
    # policy"). Mass: the swing-leg policy's spring-mass model, the stance inverse dynamics, the
    # lift-off energy and its target, the energy-modulation gain. Stiffness: the spring-mass model
    # of the policy and of the energy-modulation gain; the leg's stiffness in stance is the robot's
    # true one (ATRIAS's legs are springs: here the virtual spring the stance realises, k0). Scaling
    # that realised spring too would leave the policy consistent with it (no foot-placement error):
    # measured on 8 terrains of 30 m, +-20 % then moved the errors by less than 1 cm and 1.5 cm/s.
    smm_model, pol, samples = _policy(smm.m * s_m, smm.k0 * s_k, gait, smm.l0)
    cp = rc.make_params(mp, smm_model, pol, regulation=(energy == "regulation"),
                        tau_max=rp.tau_max, stiffness_scale=1.0 / s_k)
    return rp, cp, gait, samples


@functools.lru_cache(maxsize=16)
def _policy(m: float, k0: float, gait, l0: float = slip.SlipParams().l0):
    """The spring-mass model of mass m, stiffness k0 and rest length l0 and its swing policy for
    gait (cached: the energy options and the inertia and friction errors share the nominal one)."""
    smm_model = slip.SlipParams(m=m, k0=k0, l0=l0)
    pol, samples = slip.swing_policy(smm_model, gait)
    return smm_model, pol, samples


_FIT: dict = {}


def _fit_error(smm, gait, pol, samples) -> dict:
    """:func:`bipedlab.control.slip.fit_error` of the policy, once per process and model."""
    key = (float(smm.m), float(smm.k0), float(smm.l0), float(gait.y_apex), float(gait.speed))
    if key not in _FIT:
        _FIT[key] = slip.fit_error(smm, gait, pol, samples)
    return dict(_FIT[key])


def make_terrains(st: Settings, n: int, length: float):
    rng = np.random.default_rng(st.seed)
    if st.terrain == "flat":
        ts = [tr.flat(length) for _ in range(n)]
    elif st.terrain == "slope":
        ts = [tr.slope(st.slope, length) for _ in range(n)]
    else:  # "rough": the paper's terrain as derived in bipedlab.contact.terrain; "rough-reflected": the former one
        mode = ROUGH_MODES[st.terrain]
        ts = [tr.rough(rng, st.step_height, length, grade=st.rough_grade_percent / 100.0, mode=mode) for _ in range(n)]
    return tr.stack(ts)


def duration(st: Settings) -> float:
    return float(st.seconds) if st.seconds else st.distance / 5.0 * 1.25 + 1.0


def loop_config(st: Settings, cp, log: bool = False, dt: float = ar.DT):
    """The loop's settings (its static program and traced sensing, see
    :func:`bipedlab.robots.atrias.loop.program`) and the controller parameters for st. The
    delay (Sec. IV-C) holds back every measurement the controller receives by whole 1 ms
    samples (state and contact switches alike), so every force it commands acts that much late: the controller is
    a causal function of its measurement sequence, hence delaying all its inputs by N samples
    delays all its outputs by N samples, the paper's "delay of force generation". The
    controller knows nothing of it (cp.delay = 0) unless st.delay_compensation."""
    cfg = ar.RunConfig(noise=st.noise, delay=int(round(st.delay_ms / (ar.CONTROL_DT * 1e3))), log=log,
                       dt=dt, substeps=int(round(ar.CONTROL_DT / dt)))
    if st.delay_compensation:  # the controller knows its delay and bridges it
        cp = cp.replace(delay=cfg.delay * ar.CONTROL_DT)
    return cfg, cp


def chunk_function(rp, prog, n_chunk: int):
    """The compiled batched chunk of ``n_chunk`` samples for the robot ``rp`` and the static
    program ``prog`` (:func:`bipedlab.robots.atrias.loop.program`), made once per process: the
    controller parameters (energy option, model errors, known delay) and the sensing (noise,
    delay) are its traced arguments, so every variant of a trial count and terrain length
    runs on one compiled program."""
    robot = tuple(np.asarray(a).tobytes() for a in jax.tree_util.tree_leaves(rp))
    key = (robot, prog, n_chunk)
    if key not in _CHUNKS:
        _CHUNKS[key] = ar.make_chunk(rp, prog, n_chunk, batched=True)
    return _CHUNKS[key]


def simulate(st: Settings, n: int, log: bool = False, progress=None, chunk_s: float = 1.0,
             theta0_offsets_deg=None, dt: float = ar.DT):
    """Run n trials; returns (dict of numpy arrays with a leading trial axis, plus the logs
    when asked, and (robot, controller params, gait, terrains)). theta0_offsets_deg: initial
    trunk perturbation per trial (deg); dt: integration step (s), a divisor of the 1 ms sample."""
    rp, cp, gait, _ = build(st)
    T = duration(st)
    length = (st.distance if not st.seconds else 6.0 * T) + 12.0
    terr = make_terrains(st, n, length)
    cfg, cp = loop_config(st, cp, log, dt)
    c0 = ar.initial_state(rp, cp, cfg)
    c = jax.tree_util.tree_map(lambda a: jnp.broadcast_to(a, (n,) + jnp.shape(a)), c0)
    if theta0_offsets_deg is not None or st.theta0_offset_deg:
        off = np.deg2rad(np.broadcast_to(theta0_offsets_deg if theta0_offsets_deg is not None
                                         else st.theta0_offset_deg, (n,)))
        s = c.x.s
        c = c.replace(x=c.x.replace(s=s.replace(q=s.q.at[:, at.ITH].add(jnp.asarray(off)))))
    trials = ar.Trial(terr, jax.random.split(jax.random.PRNGKey(st.seed), n))
    params = ar.params(trials, cp, cfg)
    n_chunk = int(round(chunk_s / ar.CONTROL_DT))
    n_chunks = int(np.ceil(T / chunk_s))
    f = chunk_function(rp, ar.program(cfg), n_chunk)
    logs = []
    for j in range(n_chunks):
        c, lg = f(c, params)
        if log:
            logs.append(jax.tree_util.tree_map(np.asarray, lg))
        if progress:
            progress(j + 1, n_chunks)
        done = np.asarray(c.status != ar.OK) | (np.asarray(c.x.s.q[:, 0]) >= (st.distance if not st.seconds else np.inf))
        if done.all():
            break
    x = c.x
    out = dict(status=np.asarray(c.status), x=np.asarray(x.s.q[:, 0]), n_apex=np.asarray(x.n_apex),
               bounce=np.asarray(x.apex_bounce), speed=np.asarray(x.apex_speed), apex_y=np.asarray(x.apex_y),
               apex_x=np.asarray(x.apex_x), pitch_rms=np.sqrt(np.asarray(x.pitch_sq) / np.maximum(np.asarray(x.pitch_n), 1)),
               heights=np.asarray(terr.heights))
    if log:
        out["log"] = {k: np.concatenate([lg[k] for lg in logs], axis=1) for k in logs[0]}
    return out, (rp, cp, gait, terr)


def _apex_arrays(out, i):
    k = min(int(out["n_apex"][i]), ar.MAX_APEX)
    return out["bounce"][i, SKIP_APEX:k], out["speed"][i, SKIP_APEX:k]


def _stats(bounce, speed, gait):
    if bounce.size == 0:
        return dict(apex_height_error_mean_m=float("nan"), apex_height_sd_m=float("nan"),
                    speed_error_mean_mps=float("nan"), speed_sd_mps=float("nan"))
    return dict(apex_height_error_mean_m=float(np.mean(bounce) - gait.y_apex), apex_height_sd_m=float(np.std(bounce)),
                speed_error_mean_mps=float(np.mean(speed) - gait.speed), speed_sd_mps=float(np.std(speed)))


def per_trial(arrays, ok, gait) -> dict:
    """Each trial's own statistics (lists over the trials, None for a trial that fell): its
    apexes past the start transient, mean bounce-height and speed errors and bounce-height s.d.
    (one terrain draw's, as the paper's single run; pooled means over any subset of the trials
    follow from the counts and the means). ``arrays``: per trial (bounce heights, speeds)."""
    out = dict(apexes=[], apex_height_error_mean_m=[], speed_error_mean_mps=[], apex_height_sd_m=[])
    for (b, v), good in zip(arrays, ok):
        good = bool(good) and b.size > 0
        out["apexes"].append(int(b.size) if good else None)
        out["apex_height_error_mean_m"].append(float(np.mean(b) - gait.y_apex) if good else None)
        out["speed_error_mean_mps"].append(float(np.mean(v) - gait.speed) if good else None)
        out["apex_height_sd_m"].append(float(np.std(b)) if good else None)
    return out


def level_stats(heights, terr, distance: float) -> dict:
    """Statistics of the step levels under the run (m): the levels from the start to
    ``distance``, pooled over the trials: their s.d., the mean of each trial's own s.d. (that of
    one run, as the paper's single run), and the largest change between neighbouring levels."""
    n = int(np.ceil((distance - float(terr.x0)) / float(terr.step_len))) + 1
    h = np.asarray(heights)[:, :max(n, 2)]
    return dict(level_sd_m=float(np.std(h)), level_sd_per_run_m=float(np.mean(np.std(h, axis=1))),
                level_change_max_m=float(np.max(np.abs(np.diff(h, axis=1)))), levels_per_run=int(h.shape[1]))


def steady_errors(out, survivors, gait, last: int = STEADY_APEXES) -> dict:
    """The paper's steady-state errors (Sec. IV-A: "steady state errors of 1.8cm and 0.8cm/s"):
    the mean apex-height and apex-speed errors over the last ``last`` apexes of each surviving
    trial (pooled over trials), never reaching into the first SKIP_APEX apexes of the start
    transient. The whole-run means (``apex_height_error_mean_m``, ``speed_error_mean_mps``)
    include the transient from the start state. A run too short for an apex past the transient
    has no steady state: NaN (null in JSON)."""
    tail = [(out["bounce"][i, max(SKIP_APEX, k - last):k], out["speed"][i, max(SKIP_APEX, k - last):k])
            for i in survivors for k in [min(int(out["n_apex"][i]), ar.MAX_APEX)]]
    tb = np.concatenate([a for a, _ in tail] or [np.zeros(0)])
    ts = np.concatenate([b for _, b in tail] or [np.zeros(0)])
    return dict(apex_height_error_steady_m=float(tb.mean() - gait.y_apex) if tb.size else float("nan"),
                speed_error_steady_mps=float(ts.mean() - gait.speed) if ts.size else float("nan"))


def slip_model(st: Settings, terr, n: int, gait, policy: str = "polynomial"):
    """The pure spring-mass model on the same terrains with the swing policy of the robot's
    controller (Sec. IV-A: "the same polynomial used for the articulated robot controller"; the
    very polynomial :func:`build` gives the controller), or with ``policy="table"`` the exact
    policy, the solved pairs (t, a*) themselves (:class:`~bipedlab.control.slip.PolicyTable`).
    Over the robot's distance, as the robot: its apexes up to there, a trial failed only if it
    failed before. Counting the failures of the longer scan, on the 1 % slope all 32 draws
    "fell" at 70 to 80 m after losing speed over the 60 m (the paper's "eventually fails by
    losing forward velocity"), and the spreads took in apexes past the robot's distance."""
    p = robot(st.scale)[1]
    _, pol, samples = _policy(p.m, p.k0, gait, p.l0)
    if policy == "table":
        pol = slip.policy_table(samples)
    elif policy != "polynomial":
        raise ValueError(f"policy must be 'polynomial' or 'table', got {policy!r}")
    n_steps = int(np.ceil(st.distance / 1.2)) + 4 if not st.seconds else int(np.ceil(st.seconds / 0.4)) + 2
    run = jax.jit(jax.vmap(lambda h: slip_run.run(p, gait, pol, tr.Terrain(h, terr.step_len, terr.x0, terr.grade),
                                                    n_steps)))
    r = jax.tree_util.tree_map(np.asarray, run(terr.heights))
    if st.seconds:
        fell, n_in = r.fell, r.steps_done
    else:
        # the model runs the robot's distance: its apexes up to there, and a failure only if it came
        # before (the scan runs past the distance, where a model losing speed on a slope fails later)
        fell = r.x[np.arange(n), np.maximum(r.steps_done - 1, 0)] < st.distance - 3.0
        n_in = np.array([int(np.sum(r.x[i, :r.steps_done[i]] <= st.distance)) for i in range(n)])
    arrays = [(r.bounce[i, SKIP_APEX:n_in[i]], r.speed[i, SKIP_APEX:n_in[i]]) for i in range(n)]
    b = np.concatenate([a[0] for a, f in zip(arrays, fell) if not f] or [np.zeros(0)])
    s = np.concatenate([a[1] for a, f in zip(arrays, fell) if not f] or [np.zeros(0)])
    rec = dict(success_rate=float(1 - np.mean(fell)), **_stats(b, s, gait))
    if st.per_trial and st.trials is not None:
        rec["per_trial"] = per_trial(arrays, ~np.asarray(fell), gait)
    return rec, r


SETTLE_BAND_DEG = 2.0  # a trunk perturbation has settled once the pitch error stays within this band


def settle_steps(t, theta, mode, theta_star: float, band_deg: float = SETTLE_BAND_DEG):
    """Steps a trunk perturbation takes to settle (running paper, Sec. IV-A: 10 deg "in about
    two steps"): the touchdowns up to the last sample at which the pitch error |theta -
    theta*| exceeds ``band_deg`` (the error stays within it afterwards), from one run's log (time,
    trunk pitch in rad, controller mode). None if the error is still outside the band in the
    last second of the log (the run too short to tell)."""
    err = np.abs(np.rad2deg(np.asarray(theta) - theta_star))
    out = np.nonzero(err > band_deg)[0]
    if out.size == 0:
        return 0
    last = int(out[-1])
    if t[last] > t[-1] - 1.0:
        return None
    mode = np.asarray(mode)
    touchdowns = np.nonzero((mode[1:] != rc.FLIGHT) & (mode[:-1] == rc.FLIGHT))[0] + 1
    return int(np.sum(touchdowns <= last))


def study(st: Settings, out_dir=None, progress=None) -> dict:
    n = st.trials or 1
    t0 = time.time()
    perturbed = st.trials is None and bool(st.theta0_offset_deg)
    out, (rp, cp, gait, terr) = simulate(st, n, log=(bool(out_dir) or perturbed) and st.trials is None,
                                         progress=progress)
    wall = time.time() - t0
    target = st.distance if not st.seconds else -np.inf
    fell = out["status"] != ar.OK
    reached = out["x"] >= target
    ok = ~fell
    survivors = [i for i in range(n) if ok[i]]
    b = np.concatenate([_apex_arrays(out, i)[0] for i in survivors] or [np.zeros(0)])
    s = np.concatenate([_apex_arrays(out, i)[1] for i in survivors] or [np.zeros(0)])
    rec = dict(robot="atrias", controller=st.controller, terrain=st.terrain, energy=st.energy, noise=st.noise, delay_ms=st.delay_ms,
               delay_compensation=bool(st.delay_compensation),
               model_error=dict(st.model_error), seed=st.seed)
    if st.terrain in ROUGH_MODES:
        rec["step_height_m"] = st.step_height
        rec["terrain_levels"] = level_stats(out["heights"], terr, st.distance if not st.seconds
                                            else float(np.max(out["x"])))
        if st.rough_grade_percent:
            rec["slope_percent"] = st.rough_grade_percent
    if st.terrain == "slope":
        rec["slope_percent"] = st.slope
    single = st.trials is None
    rec.update(fell=bool(fell[0]) if single else int(fell.sum()),
               distance_m=float(out["x"][0]) if single else float(np.mean(out["x"])),
               reached_target=bool(reached.all()), **_stats(b, s, gait),
               trunk_pitch_rms_deg=float(np.rad2deg(np.mean(out["pitch_rms"][ok]))) if ok.any() else float("nan"),
               apexes=int(b.size), wall_s=wall)
    steady = steady_errors(out, survivors, gait)
    rec.update(steady)
    if survivors:
        rec["last10"] = dict(apex_height_error_mean_m=steady["apex_height_error_steady_m"],
                             speed_error_mean_mps=steady["speed_error_steady_mps"])
    if single:
        rec["status"] = ar.STATUS_NAMES[int(out["status"][0])]
    else:
        rec.update(success_rate=float(np.mean(ok)), trials=n)
        if st.per_trial:
            rec["per_trial"] = per_trial([_apex_arrays(out, i) for i in range(n)], ok, gait)
    if perturbed:
        lg = out["log"]
        rec["theta0_offset_deg"] = st.theta0_offset_deg
        rec["trunk_settle_steps"] = settle_steps(lg["t"][0], lg["q"][0][:, 2], lg["mode"][0], float(cp.theta_star))
        rec["trunk_settle_band_deg"] = SETTLE_BAND_DEG
    srec, sr = slip_model(st, terr, n, gait)
    rec["slip_model"] = srec
    if st.terrain == "flat":
        # the paper's pure spring-mass model runs the controller's polynomial (above); beside it the
        # exact policy, and the polynomial's fit error (Sec. IV-A attributes the model's error to it)
        p = robot(st.scale)[1]
        smm, pol, samples = _policy(float(p.m), float(p.k0), gait, float(p.l0))
        srec["policy_fit"] = _fit_error(smm, gait, pol, samples)
        rec["slip_model_exact_policy"] = slip_model(st, terr, n, gait, policy="table")[0]
    if out_dir:
        _write_outputs(out_dir, st, out, sr, cp, gait, rec)
    return rec


def paper_rough_sd(st: Settings):
    """The paper's (bounce-height, apex-speed) s.d. for these settings' case, robot and
    spring-mass model ((robot pair, model pair)), or None where the paper gives none (other
    terrains or step heights, delays, model errors)."""
    if st.terrain != "rough" or st.step_height != 0.25 or st.delay_ms or st.model_error:
        return None
    case = (st.energy + ("-slope" if st.rough_grade_percent == 1.0 else "") + ("-noise" if st.noise else ""))
    robot = catalog.PAPER_ROUGH_SD.get(case)
    smm = catalog.PAPER_ROUGH_SD["spring-mass"] if not st.rough_grade_percent else None
    return None if robot is None else (robot, smm)


def _write_outputs(out_dir, st, out, sr, cp, gait, rec):
    os.makedirs(out_dir, exist_ok=True)
    data = {k: v for k, v in out.items() if k != "log"}
    if "log" in out:
        for k, v in out["log"].items():
            data["log_" + k] = v[0]
    data.update(slip_bounce=sr.bounce, slip_speed=sr.speed, slip_apex_y=sr.apex_y, slip_x=sr.x)
    np.savez(os.path.join(out_dir, "run_atrias.npz"), **data)
    with open(os.path.join(out_dir, "run_atrias.json"), "w") as fh:
        dump_json(rec, fh, indent=1)  # strict JSON: a fallen trial's NaN statistics as null
    from bipedlab.robots.atrias import plots as run_plots

    run_plots.write_all(out_dir, out, sr, cp, gait, paper_sd=paper_rough_sd(st))
    if "log" not in out:
        print("[bipedlab] no time-series or GRF figure: --trials runs keep no per-sample log "
              "(run without --trials for them)", file=sys.stderr, flush=True)


def summary(rec: dict) -> str:
    lines = [f"ATRIAS-like biped running, terrain {rec['terrain']}, energy {rec['energy']}, "
             f"{'the paper' if rec.get('controller', 'paper') == 'paper' else 'bipedlab'}'s controller"]
    if rec.get("delay_ms"):
        lines.append(f"  delay {rec['delay_ms']:g} ms, " + ("known to the controller (--delay-compensation)"
                                                           if rec["delay_compensation"] else "unknown to the controller"))
    if "trials" in rec:
        lines.append(f"  trials {rec['trials']}: success {100 * rec['success_rate']:.1f} %, wall {rec['wall_s']:.1f} s")
    else:
        lines.append(f"  fell: {rec['fell']}  distance {rec['distance_m']:.1f} m")
    if "trunk_settle_steps" in rec:
        n = rec["trunk_settle_steps"]
        lines.append(f"  trunk pitched {rec['theta0_offset_deg']:+g} deg at the start: "
                     + (f"within {rec['trunk_settle_band_deg']:g} deg for good after {n} touchdowns" if n is not None
                        else f"not yet within {rec['trunk_settle_band_deg']:g} deg in the last second"))
    lines.append(f"  apex height error {100 * rec['apex_height_error_mean_m']:+.1f} cm (s.d. {100 * rec['apex_height_sd_m']:.1f} cm),"
                 f" speed error {100 * rec['speed_error_mean_mps']:+.1f} cm/s (s.d. {100 * rec['speed_sd_mps']:.1f} cm/s)")
    if "apex_height_error_steady_m" in rec:
        lines.append(f"  steady state (last 10 apexes): apex height error {100 * rec['apex_height_error_steady_m']:+.1f} cm,"
                     f" speed error {100 * rec['speed_error_steady_mps']:+.1f} cm/s")
    lines.append(f"  trunk pitch rms error {rec['trunk_pitch_rms_deg']:.2f} deg over {rec['apexes']} apexes")
    if "terrain_levels" in rec:
        lv = rec["terrain_levels"]
        lines.append(f"  terrain levels: s.d. {100 * lv['level_sd_m']:.1f} cm, largest change {100 * lv['level_change_max_m']:.1f} cm"
                     f" ({lv['levels_per_run']} levels a run)")
    s = rec["slip_model"]
    lines.append(f"  spring-mass model: success {100 * s['success_rate']:.0f} %, apex s.d. {100 * s['apex_height_sd_m']:.1f} cm,"
                 f" speed s.d. {100 * s['speed_sd_mps']:.1f} cm/s")
    if "slip_model_exact_policy" in rec:
        f, x = s["policy_fit"], rec["slip_model_exact_policy"]
        lines.append(f"  spring-mass model, the controller's polynomial a*(t): apex height error {100 * s['apex_height_error_mean_m']:+.1e} cm,"
                     f" speed error {100 * s['speed_error_mean_mps']:+.1e} cm/s (fit error {f['max_rad']:.1e} rad at most,"
                     f" {f['rms_rad']:.1e} rad rms over landing times {f['t_min_s']:.3f}-{f['t_max_s']:.3f} s,"
                     f" {f['gait_rad']:+.1e} rad at the gait's)")
        lines.append(f"  spring-mass model, the exact policy: apex height error {100 * x['apex_height_error_mean_m']:+.1e} cm,"
                     f" speed error {100 * x['speed_error_mean_mps']:+.1e} cm/s")
    return "\n".join(lines)


def progress_bar(i, n):
    """Progress of a run on stderr: simulated seconds i of n."""
    w = 30
    k = int(w * i / n)
    print(f"\r[bipedlab] running [{'#' * k}{'.' * (w - k)}] {i}/{n} s", end="" if i < n else "\n",
          file=sys.stderr, flush=True)
