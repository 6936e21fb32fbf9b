"""The running paper (Wu & Geyer) in ``bipedlab reproduce``: flat ground (Sec. IV-A, Fig. 7),
rough terrain under both energy controllers and with a 1 % slope (Sec. IV-B, Fig. 8), sensor
noise, delay and model errors (Sec. IV-C), through :mod:`bipedlab.robots.atrias.study` (the
rough cases batched over random terrains). ``--quick`` runs every experiment, the batched ones
on 4 terrains of 30 m each: one compiled program serves them all (the controller parameters,
noise and delay are traced arguments of the study's chunk), the flat run with its log another.
The judged rows run the paper's controller as published (``--controller paper``);
bipedlab's controller, with its two additions (:data:`~bipedlab.robots.atrias.catalog.ADDITIONS`),
runs flat ground and the mass and stiffness errors beside them (experiments ``*-bipedlab``), in
rows labelled "bipedlab's controller" that are shown, not judged. The pure spring-mass model's
judged flat rows run the polynomial a*(t) of the robot's controller, as the paper's model (Sec.
IV-A), with the polynomial's fit error in their facts; the exact policy (the solved landing pairs)
runs beside it in the rows ``flat_slip_exact_*``, shown, not judged (experiment flat, records
``slip_model`` and ``slip_model_exact_policy``).
Paper values: ``data/paper_running.json``."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from bipedlab.report import Experiment, Failed, Figure, Measured, Paper, Skip, dig
from bipedlab.report.spec import with_sensitivity

DATA = Path(__file__).parent / "data" / "paper_running.json"
TRIALS, QUICK_TRIALS = 32, 4
ERR_TRIALS = 16
DISTANCE, QUICK_DISTANCE = 60.0, 30.0
ANIMATION_S = 3.0


def study_settings(args):
    from bipedlab.robots.atrias import study

    keys = ("terrain", "step_height", "distance", "noise", "delay_ms", "energy", "trials", "seed", "rough_grade_percent",
            "controller", "theta0_offset_deg", "per_trial")
    # "figures": write the apex figure of a batched run too
    kw = {k: args[k] for k in keys if k in args}
    kw["model_error"] = tuple((k, float(v)) for k, v in sorted(args.get("model_error", {}).items()))
    return study.Settings(**kw)


def _run(args, out, progress):
    from bipedlab.robots.atrias import study

    st = study_settings(args)
    single = st.trials is None
    figures = args.get("figures", single)
    rec = study.study(st, out_dir=out if figures else None, progress=None)
    if single and out and figures:
        rec["animation"] = animate(Path(out) / "run_atrias.npz", Path(out) / "running.html")
    rec.update(_sweeps(args, st))
    return rec


#: values of the controller the paper does not give, varied beside a judged run so that its row
#: can say what moves it: the compensated flight reference's weights (w_theta, w_phi; the
#: controller's own are 4 and 1) and the share of a lift-off energy error the nominal stance's
#: stiffness modulation removes (eq. 7's gain c; the controller's own share is 0.5)
WEIGHT_SWEEP = ((1.0, 1.0), (1.0, 4.0), (1.0, 16.0))
GAIN_SWEEP = (0.25, 1.0)


def _sweeps(args, st) -> dict:
    """The runs of ``args["weight_sweep"]`` (reference weights, the trunk perturbation's settle
    steps) and ``args["gain_sweep"]`` (energy gains, a batched run's statistics), each a record
    list (``reference_weight_sweep``, ``energy_gain_sweep``); none asked, none run."""
    import dataclasses

    from bipedlab.robots.atrias import study

    out = {}
    for w in args.get("weight_sweep", ()):
        rec = study.study(dataclasses.replace(st, reference_weights=tuple(w)))
        steps = rec.get("trunk_settle_steps")
        out.setdefault("reference_weight_sweep", []).append(
            dict(w_theta=w[0], w_phi=w[1], fell=rec["fell"],
                 settle_steps=steps if steps is not None else "no count (not settled by the run's last second)"))
    for g in args.get("gain_sweep", ()):
        rec = study.study(dataclasses.replace(st, energy_gain=g))
        out.setdefault("energy_gain_sweep", []).append(
            dict(energy_gain=g, **{k: rec[k] for k in ("success_rate", "apex_height_error_mean_m", "speed_error_mean_mps",
                                                       "apex_height_sd_m", "speed_sd_mps")}))
    return out


def animate(npz, path, seconds: float = ANIMATION_S, fps: float = 40.0) -> str:
    """Stick figure (trunk through its centre of mass, the two legs hip to foot) of the first
    ``seconds`` of a logged run, over the terrain, as an offline HTML animation."""
    from bipedlab.robots.atrias import robot as at
    from bipedlab.viz import animation

    d = np.load(npz)
    t, q = d["log_t"], d["log_q"]
    keep = np.nonzero(t <= seconds)[0][:: max(1, int(round(1.0 / (fps * float(t[1] - t[0])))))]
    p = at.AtriasParams()
    frames = []
    for k in keep:
        h = np.asarray(at.hip(p, q[k]))
        com = q[k, :2]
        up = (com - h) / max(float(np.linalg.norm(com - h)), 1e-9)
        f1, f2 = np.asarray(at.foot(p, q[k], 0)), np.asarray(at.foot(p, q[k], 1))
        frames.append([[h, h + 0.6 * up], [h, f1], [h, f2]])
    ground = None
    if "log_ground" in d.files:
        x = np.asarray([fr[0][0][0] for fr in frames])
        ground = np.stack([np.linspace(x.min() - 1.0, x.max() + 1.0, 2), np.zeros(2)], axis=1)
    return animation.write(path, np.asarray(frames), t[keep] - t[keep][0], ground=ground,
                           colors=["#444444", "#1f77b4", "#d62728"], widths=[4.0, 2.5, 2.5], follow=True,
                           title="ATRIAS-like biped running")[0]


def _rough(**kw):
    base = dict(terrain="rough", step_height=0.25, distance=DISTANCE, trials=TRIALS, seed=0, energy="regulation",
                controller="paper", per_trial=True)
    base.update(kw)
    return base


def _quick(args, **kw):
    q = dict(args, distance=QUICK_DISTANCE, trials=QUICK_TRIALS)
    q.update(kw)
    return q


_R = f"{QUICK_TRIALS} terrains of {QUICK_DISTANCE:g} m instead of {TRIALS} of {DISTANCE:g} m"
_R_ERR = f"{QUICK_TRIALS} terrains of {QUICK_DISTANCE:g} m instead of {ERR_TRIALS} of {DISTANCE:g} m"
_SD = f" (the s.d. rows from the apexes of {QUICK_TRIALS} short runs)"

FLAT = dict(terrain="flat", distance=DISTANCE, seed=0, energy="regulation", controller="paper")
TRUNK = dict(FLAT, distance=20.0, theta0_offset_deg=10.0, figures=False, weight_sweep=[list(w) for w in WEIGHT_SWEEP])
ROUGH_REG = _rough(figures=True, gain_sweep=list(GAIN_SWEEP))
ROUGH_CONS = _rough(energy="conservation")
SLOPE = _rough(rough_grade_percent=1.0, figures=True)
SLOPE_CONS = _rough(rough_grade_percent=1.0, energy="conservation")
NOISE = _rough(energy="conservation", noise=True)
DELAY = _rough(energy="conservation", delay_ms=10.0, gain_sweep=list(GAIN_SWEEP))


def _err(name, rel):
    return _rough(energy="conservation", trials=ERR_TRIALS, model_error={name: rel})


#: the model errors of Sec. IV-C, each an experiment named by :func:`error_name`
ERRORS = (("mass", 0.2), ("mass", -0.2), ("stiffness", 0.2), ("stiffness", -0.2),
          ("inertia", 0.5), ("inertia", -0.5), ("friction", 0.5), ("friction", -0.5))


def error_name(name, rel) -> str:
    return f"{name}{rel:+.0%}".replace("%", "pct")


# --quick: every batched experiment runs the same number of terrains of the same length, so all of
# them (energy options, slope, noise, delay, model errors) run on one compiled program
EXPERIMENTS = (
    Experiment("flat", "bipedlab run atrias --distance 60", _run, FLAT, dict(FLAT, distance=20.0),
               reduction="20 m instead of 60 m", expected_s=40, quick_expected_s=20),
    Experiment("trunk-10deg", "bipedlab run atrias --distance 20 --trunk-offset 10", _run, TRUNK, TRUNK, reduction="as in the full run",
               expected_s=20, quick_expected_s=5),
    Experiment("rough", f"bipedlab run atrias --terrain rough --trials {TRIALS}", _run, ROUGH_REG, _quick(ROUGH_REG),
               reduction=_R + _SD, expected_s=40, quick_expected_s=15),
    Experiment("rough-conservation", f"bipedlab run atrias --terrain rough --energy conservation --trials {TRIALS}", _run,
               ROUGH_CONS, _quick(ROUGH_CONS), reduction=_R + _SD, expected_s=40, quick_expected_s=4),
    Experiment("slope", f"bipedlab run atrias --terrain rough --slope 1 --trials {TRIALS}", _run, SLOPE,
               _quick(SLOPE), reduction=_R + _SD, expected_s=40, quick_expected_s=15),
    Experiment("slope-conservation",
               f"bipedlab run atrias --terrain rough --slope 1 --energy conservation --trials {TRIALS}", _run,
               SLOPE_CONS, _quick(SLOPE_CONS), reduction=_R + _SD, expected_s=40, quick_expected_s=4),
    Experiment("noise", f"bipedlab run atrias --terrain rough --energy conservation --noise --trials {TRIALS}", _run,
               NOISE, _quick(NOISE), reduction=_R + _SD, expected_s=40, quick_expected_s=4),
    Experiment("delay", f"bipedlab run atrias --terrain rough --energy conservation --delay-ms 10 --trials {TRIALS}",
               _run, DELAY, _quick(DELAY), reduction=_R + _SD, expected_s=40, quick_expected_s=4),
) + tuple(
    Experiment(error_name(name, rel),
               f"bipedlab run atrias --terrain rough --energy conservation --model-error {name}={rel:g} "
               f"--trials {ERR_TRIALS}", _run, _err(name, rel), _quick(_err(name, rel)),
               reduction=_R_ERR + _SD, expected_s=30, quick_expected_s=4)
    for name, rel in ERRORS)

#: bipedlab's controller beside the paper's: flat ground and the two model errors whose
#: foot-placement errors its additions change most (experiment name -> the paper-controller one)
VARIANTS = {"flat-bipedlab": "flat", "mass+20pct-bipedlab": "mass+20pct", "stiffness+20pct-bipedlab": "stiffness+20pct"}


def _variant(name: str, of: str) -> Experiment:
    e = next(x for x in EXPERIMENTS if x.name == of)
    full, quick = (dict(a, controller="bipedlab", figures=False) for a in (e.full_args, e.quick_args))
    return Experiment(name, e.command + " --controller bipedlab", _run, full, quick, reduction=e.reduction,
                      expected_s=e.expected_s, quick_expected_s=4)


EXPERIMENTS = EXPERIMENTS + tuple(_variant(n, of) for n, of in VARIANTS.items())


def _sensitivity(args, out, progress):
    from bipedlab.robots.atrias import sensitivity

    return sensitivity.sensitivity(args["step"], progress=progress)


EXPERIMENTS = EXPERIMENTS + (
    Experiment("sensitivity", "bipedlab experiment atrias sensitivity", _sensitivity, dict(step=-0.1), None,
               skip_reason="not run in --quick (9 experiments for each of 14 robots)", expected_s=1800),)


#: the batched experiments' rows: experiment -> the prefix of its rows' ids (:func:`_stats`)
BATCHED_PREFIXES = (("rough", "rough"), ("rough-conservation", "cons"), ("slope", "slope"),
                    ("slope-conservation", "slope_cons"), ("noise", "noise"), ("delay", "delay"))
_STATS = ("apex_sd_m", "speed_sd_mps", "apex_error_m", "speed_error_mps", "success")


def _stats(rec, prefix: str, missing: Skip) -> dict:
    if rec is None:
        return {f"{prefix}_{k}": missing for k in _STATS}
    return {f"{prefix}_apex_sd_m": dig(rec, "apex_height_sd_m"), f"{prefix}_speed_sd_mps": dig(rec, "speed_sd_mps"),
            f"{prefix}_apex_error_m": dig(rec, "apex_height_error_mean_m"),
            f"{prefix}_speed_error_mps": dig(rec, "speed_error_mean_mps"),
            f"{prefix}_success": dig(rec, "success_rate", default=None if dig(rec, "fell") is None
                                     else float(not rec["fell"]))}


def measure(records: dict, quick: bool) -> dict:
    from bipedlab.report import values

    rows = {r["id"]: r for r in values.load(DATA)["rows"]}
    missing = Skip("not run in --quick" if quick else "not run")
    out = {k: missing for k in ("trunk_settle_steps", "flat_apex_error_m", "flat_speed_error_mps", "flat_success", "flat_slip_apex_error_m",
                                "flat_slip_speed_error_mps", "flat_slip_exact_apex_error_m", "flat_slip_exact_speed_error_mps",
                                "rough_slip_apex_sd_m", "rough_slip_speed_sd_mps")}
    flat = records.get("flat")
    if flat is not None:
        h, v = dig(flat, "last10", "apex_height_error_mean_m"), dig(flat, "last10", "speed_error_mean_mps")
        out["flat_apex_error_m"] = None if h is None else abs(h)  # the paper states the errors' sizes
        out["flat_speed_error_mps"] = None if v is None else abs(v)
        out["flat_success"] = _stabilised(flat, out["flat_apex_error_m"], out["flat_speed_error_mps"], rows)
        out.update(_slip_flat(flat))
    trunk = records.get("trunk-10deg")
    if trunk is not None and trunk.get("fell"):
        out["trunk_settle_steps"] = Failed("the run with the trunk perturbation fell")
    elif trunk is not None and trunk.get("trunk_settle_steps") is None:
        out["trunk_settle_steps"] = Failed("the 10 deg trunk perturbation had not settled within "
                                           f"{trunk['trunk_settle_band_deg']:g} deg by the run's last second")
    elif trunk is not None:
        out["trunk_settle_steps"] = trunk["trunk_settle_steps"]
    for name, prefix in BATCHED_PREFIXES:
        out.update(_stats(records.get(name), prefix, missing))
    out.update(_slope_losses(records, missing))
    out.update(_sd_ratios(records, missing))
    rough = records.get("rough")
    if rough is not None:
        out["rough_apex_sd_m"] = _with_draws(out["rough_apex_sd_m"], rough.get("per_trial"))
        out["rough_slip_apex_sd_m"] = _with_draws(dig(rough, "slip_model", "apex_height_sd_m"),
                                                  dig(rough, "slip_model", "per_trial", default=None))
        out["rough_slip_speed_sd_mps"] = dig(rough, "slip_model", "speed_sd_mps")
    for name in (error_name(n, rel) for n, rel in ERRORS):
        out.update(_stats(records.get(name), name, missing))
    out.update(_model_error_shifts(records, missing, rows))
    out.update(_variants(records, missing))
    out.update(_with_sensitivity(out, records.get("sensitivity")))
    return {k: v for k, v in out.items() if k in rows}


def _with_sensitivity(out: dict, rec) -> dict:
    """The rows the sensitivity experiment measured, each with its
    :class:`~bipedlab.report.spec.Sensitivity` (only where the experiment's unscaled value is the
    row's own: the same run); the values named in the row's text by what they are ("trunk mass
    (59 kg)" -> "trunk mass")."""
    if not rec:
        return {}
    view = dict(rec, method="experiment sensitivity: " + rec["method"],
                parameters={r["what"].split(" (")[0]: r for r in rec["parameters"].values()})
    return with_sensitivity(out, view, rel=1e-9)


def _with_draws(value, per_trial):
    """A pooled bounce-height s.d. with the single draws' own (each one run, as the paper's):
    ``draw_min``, ``draw_median``, ``draw_max`` (m)."""
    sds = [x for x in (per_trial or {}).get("apex_height_sd_m", []) if x is not None]
    if value is None or not sds or isinstance(value, Skip):
        return value
    return Measured(value, dict(draw_min=min(sds), draw_median=float(np.median(sds)), draw_max=max(sds)))


def _pooled(rec, n: int, key: str):
    """The mean of ``key`` pooled over the apexes of the first ``n`` trials of a batched record
    (from its per-trial counts and means; fallen trials left out), or None."""
    pt = rec.get("per_trial") if rec else None
    if not pt:
        return None
    pairs = [(a, m) for a, m in zip(pt["apexes"][:n], pt[key][:n]) if a]
    return sum(a * m for a, m in pairs) / sum(a for a, _ in pairs) if pairs else None


def _model_error_shifts(records: dict, missing: Skip, rows: dict) -> dict:
    """The mass and stiffness errors' mean bounce-height and speed errors with the error-free
    run's on the same terrain draws beside them (``reference``: experiment rough-conservation's
    first ``ERR_TRIALS`` draws, the same seed and terrain settings, hence the same draws), the
    model error's own share (``shift``, the row's value minus the reference) and what the two
    shifts together do to the apex energy, M (g dh + v* dv) to first order with M the robot's
    mass (``energy_shift_j``), beside what the paper's pair of errors means
    (``paper_energy_j``; ``rows``: the paper's rows by id)."""
    from bipedlab.robots.atrias import controller as rc
    from bipedlab.robots.atrias import robot as at

    rp = at.AtriasParams()
    mass, speed = rp.m + 2 * rp.m_f, rc.SPEED
    energy = lambda dh, dv: mass * (rp.g * dh + speed * dv)  # noqa: E731
    free = records.get("rough-conservation")
    out = {}
    keys = (("apex_error_m", "apex_height_error_mean_m"), ("speed_error_mps", "speed_error_mean_mps"))
    for name in (error_name(n, rel) for n, rel in ERRORS if n in ("mass", "stiffness")):
        rec = records.get(name)
        if rec is None or free is None:
            out.update({f"{name}_{q}": missing for q, _ in keys})
            continue
        vals = [dig(rec, key) for _, key in keys]
        refs = [_pooled(free, int(rec["trials"]), key) for _, key in keys]
        if any(x is None for x in vals + refs):
            out.update({f"{name}_{q}": v for (q, _), v in zip(keys, vals)})
            continue
        shifts = [v - r for v, r in zip(vals, refs)]
        facts = dict(energy_shift_j=energy(*shifts),
                     paper_energy_j=energy(*(rows[f"{name}_{q}"]["paper"] for q, _ in keys)))
        out.update({f"{name}_{q}": Measured(v, dict(reference=r, shift=d, **facts))
                    for (q, _), v, r, d in zip(keys, vals, refs, shifts)})
    return out


def _stabilised(flat, apex, speed, rows: dict) -> Measured:
    """The claim that the controller "stabilises the gait" on flat ground (Sec. IV-A), tested as:
    the run does not fall and settles with steady apex-height and speed errors each within the
    band of its own row (``flat_apex_error_m``, ``flat_speed_error_mps``; ``rows``: the paper's
    rows by id); 1.0 or 0.0, with the reason in words (``reason``)."""
    from bipedlab.report import values

    if flat["fell"]:
        return Measured(0.0, dict(reason="the run fell"))
    outside = [f"{what} {x * 100:.1f} {unit} (the paper's {rows[rid]['paper'] * 100:g} {unit}; "
               f"{values.tolerance_text(rows[rid]['tolerance'], unit)})"
               for rid, what, x, unit in (("flat_apex_error_m", "apex-height error", apex, "cm"),
                                          ("flat_speed_error_mps", "apex-speed error", speed, "cm/s"))
               if x is None or not values.agrees(x, rows[rid]["tolerance"], rows[rid]["paper"])]
    if outside:
        return Measured(0.0, dict(reason="the run does not fall, but it settles with a steady " + " and ".join(outside)))
    return Measured(1.0, dict(reason="the run does not fall and settles within both bands"))


def _slip_flat(flat) -> dict:
    """The pure spring-mass model on flat ground (experiment flat): the judged rows run the
    robot controller's polynomial a*(t), as the paper's model (Sec. IV-A), with its fit error
    (``fit_max_rad``, ``fit_rms_rad``, ``fit_gait_rad``, over ``fit_t_min_s`` to ``fit_t_max_s``)
    and the exact policy's error (``exact``) beside them; the rows ``flat_slip_exact_*`` run the
    exact policy (shown, not judged), with the polynomial's (``polynomial``) and the difference
    (``change``, the polynomial's minus the exact policy's)."""
    out = {}
    fit = dig(flat, "slip_model", "policy_fit", default=None) or {}
    for q, key in (("apex_error_m", "apex_height_error_mean_m"), ("speed_error_mps", "speed_error_mean_mps")):
        poly, exact = dig(flat, "slip_model", key), dig(flat, "slip_model_exact_policy", key, default=None)
        if poly is None or exact is None or not fit:
            out[f"flat_slip_{q}"], out[f"flat_slip_exact_{q}"] = poly, exact
            continue
        out[f"flat_slip_{q}"] = Measured(poly, dict(exact=exact, **{f"fit_{k}": v for k, v in fit.items()}))
        out[f"flat_slip_exact_{q}"] = Measured(exact, dict(polynomial=poly, change=poly - exact))
    return out


def _difference(a, b, **facts):
    """a - b as a Measured with both beside it (``this``, ``reference``); None where either
    record lacks its number."""
    return None if a is None or b is None else Measured(a - b, dict(this=a, reference=b, **facts))


def _slope_losses(records: dict, missing: Skip) -> dict:
    """The 1 % slope's loss of apex speed (Sec. IV-B: the pure spring-mass model and the energy
    conservation control "eventually fail by losing forward velocity"): the mean apex-speed
    error on the sloped rough terrain minus that on the flat-on-average one, for the same
    model and controller (so the loss is the slope's, not a steady error either has without it)."""
    slope, rough = records.get("slope"), records.get("rough")
    cons_s, cons = records.get("slope-conservation"), records.get("rough-conservation")
    slip = (_difference(dig(slope, "slip_model", "speed_error_mean_mps"), dig(rough, "slip_model", "speed_error_mean_mps"),
                        success=dig(slope, "slip_model", "success_rate"))
            if slope is not None and rough is not None else missing)
    robot = (_difference(dig(cons_s, "speed_error_mean_mps"), dig(cons, "speed_error_mean_mps"),
                         success=dig(cons_s, "success_rate"))
             if cons_s is not None and cons is not None else missing)
    return {"slope_slip_speed_loss_mps": slip, "slope_cons_speed_loss_mps": robot}


def _sd_ratios(records: dict, missing: Skip) -> dict:
    """Bounce-height s.d. under a ±50 % inertia or friction error over the error-free run's on
    the same kind of terrain (experiment rough-conservation): "very little effect" (Sec. IV-C)."""
    free = dig(records.get("rough-conservation"), "apex_height_sd_m") if records.get("rough-conservation") else None
    out = {}
    for name in (error_name(n, rel) for n, rel in ERRORS if n in ("inertia", "friction")):
        rec = records.get(name)
        sd = dig(rec, "apex_height_sd_m") if rec is not None else None
        out[f"{name}_apex_sd_ratio"] = (missing if rec is None or records.get("rough-conservation") is None
                                        else None if sd is None or not free
                                        else Measured(sd / free, dict(this=sd, reference=free)))
    return out


def _errors(rec) -> tuple:
    """(apex-height error m, speed error m/s) of a record: the last ten apexes' of a single
    run, the mean over the surviving trials' apexes of a batched one (as the judged rows)."""
    if rec is None:
        return None, None
    if "trials" in rec:
        return dig(rec, "apex_height_error_mean_m"), dig(rec, "speed_error_mean_mps")
    return dig(rec, "last10", "apex_height_error_mean_m"), dig(rec, "last10", "speed_error_mean_mps")


def _variants(records: dict, missing: Skip) -> dict:
    """Rows ``bipedlab_<experiment>_{apex_error_m, speed_error_mps}``: bipedlab's controller's
    errors, with the paper's controller's on the same terrains (``paper_controller``) and the
    difference (``change``) for the texts."""
    out = {}
    for name, of in VARIANTS.items():
        mine, theirs = _errors(records.get(name)), _errors(records.get(of))
        for i, q in enumerate(("apex_error_m", "speed_error_mps")):
            key = f"bipedlab_{of}_{q}"
            if mine[i] is None or theirs[i] is None:
                out[key] = missing if records.get(name) is None or records.get(of) is None else None
            else:
                out[key] = Measured(mine[i], dict(paper_controller=theirs[i], change=mine[i] - theirs[i]))
    return out


PAPERS = [Paper(
    key="running", title="Spring-mass running embedded in an articulated biped (ATRIAS-like)", values=str(DATA),
    experiments=EXPERIMENTS, measure=measure, order=30,
    figures=(Figure("flat", "gait_time_series.png",
                    "Flat ground, the paper's controller (energy regulation), first 2 s of the 60 m run (20 m with --quick): "
                    "trunk height, speed, pitch, landing angle, angular momentum, hip torques (cf. paper Fig. 7)"),
             Figure("flat", "grf_first_stance.png", "Ground reaction forces of the first stance on flat ground, the paper's controller (cf. paper Fig. 5)"),
             Figure("rough", "apex.png", "Rough terrain (steps up to 25 cm), the paper's controller with energy regulation, "
                    "terrain draw 0: bounce heights and apex speeds of the robot and of the pure spring-mass model on "
                    "the same terrain, the target dashed, the paper's s.d. about it shaded (cf. paper Fig. 8, top row)"),
             Figure("slope", "apex.png", "Rough terrain on a 1 % slope, the paper's controller with energy regulation, terrain "
                    "draw 0, the paper's s.d. shaded (cf. paper Fig. 8, bottom row)"),),
    animations=(Figure("flat", "running.html", "The ATRIAS-like biped running on flat ground, the paper's controller (first 3 s of the log)",
                       kind="animation"),),
    notes=("The rough-terrain rows pool the apexes of every terrain draw that did not fall (random steps every 3 m, "
           "changes up to ±25 cm: independent levels uniform within ±12.5 cm, flat on average, the reading of the "
           "paper's text documented in bipedlab.contact.terrain); the paper's numbers are from one run each.",
           "Every judged row runs the paper's controller as published (--controller paper). bipedlab's controller "
           "adds an integral action on the lift-off energy error and a landing-angle trim from the apex-height error "
           "(each kept because it improves a figure: without the integral the flat-ground steady speed error is "
           "about -1 cm/s, without the trim about -6 cm/s, against 0.0 with both); its rows, labelled \"bipedlab's "
           "controller\", are shown beside the paper's and not judged.",
           "Where the paper gives no value the controller uses its own (the compensated flight reference's weights, "
           "the stiffness modulation's gain c); the rows whose numbers move with one of them say by how much, from "
           "runs with other values beside the judged one (records reference_weight_sweep, energy_gain_sweep).",
           "The delay and model-error experiments run as the paper's: the controller does not know its 10 ms delay "
           "(--delay-compensation not given), and a mass or stiffness error is one of the controller's model, in the "
           "swing-leg policy and the stance control alike, the robot keeping its true values.",),
)]
