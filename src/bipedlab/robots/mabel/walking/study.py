"""MABEL's compliant-HZD walking studies (compliant-HZD paper, Sections III-VI).

``optimize``: a fixed point designed on the compliant zero dynamics (torque or c_mt cost),
its figures (speed, step length, c_mt, peak torques, the spring's share of the negative work
at the stance leg shape) and its Poincaré eigenvalues under PD + feedforward (eq. 44, full
order) and under the compliant HZD controller (eq. 48, restricted map).

``walk``: the closed loop of the experiments, 1 kHz sampling with 14-bit encoders, under
PD + feedforward, I/O linearisation with hybrid-invariance corrections, or its decentralised
form; optional push (Exp. 2) and impact scaling (Section VI-B).

Gaits are gait files (:mod:`bipedlab.gait.gaitfile`, payload kind :data:`KIND`) holding the decision vector, the constraints, the
fixed point, the u* regression and the design figures; ``nominal``, ``efficient`` and ``fast``
ship with the package.
"""
from __future__ import annotations

import time

from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.robots.mabel.walking import catalog
from bipedlab.robots.mabel.walking import constraints as vcm
from bipedlab.robots.mabel.walking import controllers as ctl
from bipedlab.gait import gaitfile
from bipedlab.outputs import dump_json
from bipedlab.robots.mabel.walking import gait_schema
from bipedlab.robots.mabel.walking import design as md
from bipedlab.robots.mabel.walking import poincare as mp
from bipedlab.robots.mabel.walking.zero_dynamics import robot_mass
from bipedlab.robots.mabel.walking import stance as wk
from bipedlab.robots.mabel.walking import loop as sw

#: payload kind of MABEL gait files, and the format string of their version-1 files
KIND = "mabel-compliant-hzd"
FORMAT_V1 = "bipedlab-mabel-gait/1"
#: shipped gaits, controllers, sensing options and plants (:mod:`.catalog`)
GAITS = catalog.GAITS
CONTROLLERS = catalog.CONTROLLERS
SENSING = catalog.SENSING
PLANTS = catalog.PLANTS
OUTPUT_NAMES = vcm.OUTPUTS
#: The paper's figures, for side-by-side reports.
PAPER = dict(step_length_nominal=0.575, cmt_nominal=0.0452, cmt_efficient=0.0385, eig_pdff_nominal=0.6921,
             eig_pdff_efficient=0.8194, eig_hzd_nominal=0.7258, eig_hzd_efficient=0.7065, fast_speed=1.5,
             impact_scaling={1.0: 0.80, 0.99: 0.86, 0.98: 0.92, 0.97: 0.98, 0.966: 1.00, 0.96: 1.04})


# ----------------------------------------------------------------------------- gait records

def _vc_dict(vc) -> dict:
    return {k: np.asarray(getattr(vc, k)).tolist() for k in vc.__dataclass_fields__}


def _vc_from(d: dict) -> vcm.Constraints:
    return vcm.Constraints(**{k: jnp.asarray(np.asarray(d[k], float)) for k in vcm.Constraints.__dataclass_fields__})


def record(name: str, design: md.Design, gains: ctl.Gains, speed: float, cost: str, poincare: dict | None,
           design_model: str | None = None, clearance: float = 0.0) -> dict:
    return gaitfile.envelope("mabel", KIND, dict(
                name=name, speed=speed, cost=cost, design_model=design_model, clearance=clearance,
                x=np.asarray(design.x).tolist(),
                constraints=_vc_dict(design.vc), z_minus=np.asarray(design.z_minus).tolist(),
                z_plus=np.asarray(design.z_plus).tolist(),
                feedforward=dict(beta=np.asarray(gains.beta).tolist(), bounds=np.asarray(gains.beta_bounds).tolist(),
                                 signs=np.asarray(gains.signs).tolist()),
                design=design.figures, poincare=poincare))


def from_record(d: dict, source: str):
    """(constraints, gains, record), every field checked first (:mod:`.gait_schema`);
    ValueError naming the source and the field."""
    d, pre = gaitfile.open_payload(d, source, KIND, legacy=(FORMAT_V1,), robot="mabel")
    gait_schema.check(d, source, pre)
    vc = _vc_from(d["constraints"])
    ff = d["feedforward"]
    gains = ctl.default_gains(np.asarray(ff["beta"], float), np.asarray(ff["bounds"], float),
                              np.asarray(ff["signs"], float))
    return vc, gains, d


def load_gait(name_or_path: str):
    if name_or_path in GAITS:
        text, label = gaitfile.shipped_text("bipedlab.robots.mabel", f"mabel_{name_or_path}")
        return from_record(gaitfile.parse(text, label), label)
    d = gaitfile.read_json(name_or_path, f"not a shipped gait ({', '.join(GAITS)}) and cannot be read")
    return from_record(d, str(name_or_path))


def design_from_record(rec: dict) -> md.Design:
    """The design (optimiser vector, virtual constraints, section states) of a gait record."""
    vc = _vc_from(rec["constraints"])
    return md.Design(np.asarray(rec["x"], float), vc, np.asarray(rec["z_minus"], float),
                     np.asarray(rec["z_plus"], float), rec["design"])


# ----------------------------------------------------------------------------- Poincaré

def _eig_summary(J) -> dict:
    """Eigenvalues of the map's Jacobian J at the fixed point found, largest first; all None
    (with the reason) when the fixed-point search left the walking range (J not finite)."""
    if not np.all(np.isfinite(np.asarray(J))):
        return dict(max_abs_eigenvalue=None, poincare_eigenvalues=None, poincare_eigenvalues_complex=None,
                    failed="no fixed point: the Newton search on the return map left the walking range")
    ev = np.asarray(mp.eigenvalues(J))
    return dict(max_abs_eigenvalue=float(np.abs(ev[0])), poincare_eigenvalues=[float(a) for a in np.abs(ev)],
                poincare_eigenvalues_complex=[[float(e.real), float(e.imag)] for e in ev])


def poincare(design: md.Design, gains: ctl.Gains, controllers=("pdff",), fd_check: bool = False,
             design_model: str = "full", model=None) -> dict:
    """Eigenvalues of the restricted map (eq. 48, compliant HZD controller) and of the full
    closed-loop map (eq. 44) under each controller, at their own fixed points; with fd_check,
    the largest relative difference between the autodiff and central-difference Jacobians.

    The full maps run on the walking model (the plant of ``walk mabel``). The restricted map
    runs on the zero dynamics the gait was designed on: for ``design_model="paper"`` those
    have no friction or spring damping (the paper's eq. 48), and the walking model's zero
    dynamics, which lose energy to both, have no periodic orbit near such a gait. ``model``: the
    walking model (default :func:`~bipedlab.robots.mabel.walking.stance.walking_model`'s)."""
    m = wk.walking_model() if model is None else model
    m_zd = m if design_model == "full" else md.design_model(m, design_model)
    vc = jax.tree_util.tree_map(jnp.asarray, design.vc)
    z0, x0 = md.section_state(m_zd, design)
    out = {}
    xs, J, res = mp.fixed_point(mp.restricted_at, x0, args=(m_zd, vc))
    out["hzd"] = dict(**_eig_summary(J), fixed_point_residual=res, map="restricted (eq. 48)",
                      zero_dynamics=f"{design_model} design model" if design_model != "full" else "walking model")
    if fd_check:
        Jfd = mp.central_differences(mp.restricted_at, xs, args=(m_zd, vc))
        out["hzd"]["fd_rel_error"] = float(np.max(np.abs(np.asarray(J) - Jfd)) / np.max(np.abs(Jfd)))
    for kind in controllers:
        P, args = mp.full_map_at(kind), (m, gains, vc)
        zs, J, res = mp.fixed_point(P, z0, args=args)
        out[kind] = dict(**_eig_summary(J), fixed_point_residual=res, map="full order (eq. 44)")
        if fd_check:
            Jfd = mp.central_differences(P, zs, args=args)
            out[kind]["fd_rel_error"] = float(np.max(np.abs(np.asarray(J) - Jfd)) / np.max(np.abs(Jfd)))
    return out


# ----------------------------------------------------------------------------- optimize

def _start_point(speed: float, cost: str, shipped_only: bool = False, design_model: str = "paper"):
    """The hand-set guess near 0.8 m/s; otherwise (or with ``shipped_only``) the shipped gait
    nearest in speed (continuation), among those designed on ``design_model`` if any is.
    Returns (x0, description, its step length or None)."""
    if abs(speed - 0.8) < 0.15 and not shipped_only:
        return md.initial_guess(speed), "hand-set initial guess", None
    best = None
    for g in GAITS:
        try:
            _, _, rec = load_gait(g)
        except (OSError, ValueError):
            continue
        key = lambda r: (r.get("design_model", "full") != design_model, abs(r["speed"] - speed))  # noqa: E731
        if best is None or key(rec) < key(best):
            best = rec
    if best is None:
        return md.initial_guess(speed), "hand-set initial guess", None
    return (np.asarray(best["x"], float), f"shipped gait '{best['name']}' ({best['speed']:.2f} m/s)",
            float(best["design"]["step_length"]))


#: largest change of a prescribed step length per continuation solve (m)
STEP_CONTINUATION = 0.03


def design_gait(speed: float, cost: str, x0=None, progress=None, step_length=None, design_model: str = "paper",
                clearance: float = 0.0, model=None):
    """Optimise (torque cost first; for c_mt, continue from the torque optimum) on the design
    model ``design_model`` (:data:`~bipedlab.robots.mabel.walking.design.DESIGN_MODELS`). With
    ``step_length`` (m) the step is prescribed, reached from the nearest shipped gait by
    continuation in increments of at most STEP_CONTINUATION; ``clearance`` (m): the swing toe's
    least mid-step height (:func:`~bipedlab.robots.mabel.walking.design.evaluate`); ``model``: the walking model
    the design model is made from (default the published one). Returns (design, info with warm and cold times)."""
    say = progress or (lambda msg: None)
    start, L0 = "given start", None
    if x0 is None:
        x0, start, L0 = _start_point(speed, cost, shipped_only=step_length is not None, design_model=design_model)
    lengths = [None] if step_length is None else [step_length]
    if step_length is not None and L0 is not None:
        n = max(1, int(np.ceil(abs(step_length - L0) / STEP_CONTINUATION)))
        lengths = list(np.linspace(L0, step_length, n + 1)[1:])
    t0 = time.perf_counter()
    say(f"compiling the gait-design problem (speed {speed} m/s); start: {start}")
    md.compile_problem(speed, "torque", model=model, kind=design_model)
    if cost == "cmt":
        md.compile_problem(speed, "cmt", model=model, kind=design_model)
    cold_compile = time.perf_counter() - t0
    its, wall = 0, 0.0
    d = None
    for L in lengths:
        window = {} if L is None else dict(min_step=float(L), max_step=float(L))
        if L is not None:
            say(f"step length {L:.3f} m")
        d, info = md.optimize(speed, "torque", x0=x0 if d is None else d.x, kind=design_model, clearance=clearance,
                              model=model, **window)
        its, wall = its + info["iterations"], wall + info["wall_s"]
    if cost == "cmt":
        say("continuing from the torque optimum with the c_mt cost")
        d, info = md.optimize(speed, "cmt", x0=d.x, kind=design_model, clearance=clearance, model=model, **window)
        its, wall = its + info["iterations"], wall + info["wall_s"]
    info.update(iterations=its, warm_s=wall, cold_s=cold_compile + wall, start=start)
    return d, info


def optimize(speed: float, cost: str, save=None, out=None, poincare_check: bool = True, progress=None,
             step_length=None, design_model: str = "paper", x0=None, clearance: float = 0.0, model=None) -> dict:
    """Design a gait (:func:`design_gait`) on ``design_model`` and report it; the u* regression
    of PD + feedforward follows the design model's orbit, the Poincaré analysis runs on the
    walking model (the plant of ``walk mabel``; ``model``, default the published one)."""
    say = progress or (lambda msg: None)
    d, info = design_gait(speed, cost, x0=x0, progress=progress, step_length=step_length, design_model=design_model,
                          clearance=clearance, model=model)
    m = wk.walking_model() if model is None else model
    m_design = m if design_model == "full" else md.design_model(m, design_model)
    gains = md.controller_gains(m_design, d)
    pc = None
    if poincare_check:
        say("Poincaré analysis: restricted map (HZD) and full map under PD + feedforward")
        pc = poincare(d, gains, controllers=("pdff",), design_model=design_model, model=m)
    f = d.figures
    rec = dict(
        robot="mabel", speed_mps=float(f["speed"]), cost=cost, step_length_m=float(f["step_length"]),
        period_s=float(f["period"]), cmt=float(f["cmt"]), torque_cost=float(f["torque_cost"]),
        peak_torques_nm=[float(v) for v in f["peak_torques"]],
        torque_capacity_nm=[float(v) for v in np.asarray(m_design.drive.torque_limit)],
        negative_work_fraction_spring=float(f["negative_work_fraction_spring"]),
        negative_work_spring_j=float(f["neg_work_spring"]), negative_work_motor_j=float(f["neg_work_motor"]),
        optimize_warm_s=float(info["warm_s"]), optimize_cold_s=float(info["cold_s"]),
        iterations=int(info["iterations"]), converged=bool(info["success"]), solver_message=info["message"],
        equality_residual=float(info["eq_residual"]), start=info["start"],
        prescribed_step_length_m=step_length, design_model=design_model, clearance_m=clearance,
        torso_travel_deg=float(np.degrees(md.torso_travel(m_design, d))))
    if pc is not None:
        rec.update(max_abs_eigenvalue=pc["hzd"]["max_abs_eigenvalue"], poincare_eigenvalues=pc["hzd"]["poincare_eigenvalues"],
                   poincare_eigenvalues_complex=pc["hzd"]["poincare_eigenvalues_complex"],
                   max_abs_eigenvalue_pdff=pc["pdff"]["max_abs_eigenvalue"],
                   poincare_eigenvalues_pdff=(pc["pdff"]["poincare_eigenvalues"] or [])[:6] or None, poincare=pc)
    else:
        rec.update(max_abs_eigenvalue=None, poincare_eigenvalues=None)
    if save:
        name = Path(save).stem
        with open(save, "w") as fh:  # strict JSON: a failed analysis' NaN as null
            dump_json(record(name, d, gains, speed, cost, pc, design_model, clearance), fh, indent=1)
        rec["saved"] = str(save)
    if out:
        from bipedlab.robots.mabel.walking import plots as wp

        rec["figures"] = wp.gait_figures(out, m, d)
    return rec


def summary_optimize(r: dict) -> str:
    lines = [
        f"MABEL gait ({r['cost']} cost): speed {r['speed_mps']:.3f} m/s, step {r['step_length_m']:.3f} m, "
        f"period {r['period_s']:.3f} s, c_mt {r['cmt']:.4f}, torso travel {r['torso_travel_deg']:.1f} deg "
        f"({r['design_model']} design model)",
        "peak torques (N m): " + ", ".join(f"{v:.1f}" for v in r["peak_torques_nm"]) + "  (capacity 30 / 55)",
        f"negative work at the stance leg shape done by the spring: {100 * r['negative_work_fraction_spring']:.1f} %",
    ]
    if "poincare" in r:
        eig = lambda v: "no fixed point found" if v is None else f"{v:.4f}"  # noqa: E731
        lines.append(f"Poincaré: max |eig| {eig(r['max_abs_eigenvalue'])} (HZD, restricted map), "
                     f"{eig(r['max_abs_eigenvalue_pdff'])} (PD + feedforward, full map)")
    lines.append(f"solve: {r['iterations']} SLSQP iterations, warm {r['optimize_warm_s']:.1f} s, "
                 f"cold {r['optimize_cold_s']:.1f} s (from {r['start']})")
    return "\n".join(lines)


# ----------------------------------------------------------------------------- walk

def parse_push(text: str | None):
    """'FORCE@STEP' -> (force N, step index); None -> (0, -1)."""
    if not text:
        return 0.0, -1
    try:
        f, s = text.split("@")
        force, step = float(f), int(s)
    except ValueError:
        raise ValueError(f"--push expects FORCE@STEP (e.g. 78@10 or -71@30), got {text!r}") from None
    if not np.isfinite(force) or step < 0:
        raise ValueError(f"--push expects a finite force and a step >= 0, got {text!r}")
    return force, step


def setup_for(vc, gains, period, eta=1.0, push=(0.0, -1), sensing="encoders", lean=0.0, lean_steps=1,
              ground=1.0, cable=1.0, friction=1.0) -> sw.Setup:
    if sensing not in SENSING:
        raise ValueError(f"sensing must be one of {', '.join(SENSING)}, got {sensing!r}")
    f = lambda v: jnp.asarray(v, float)  # noqa: E731
    return sw.Setup(vc=vc, gains=gains, eta=f(eta), push_force=f(push[0]), push_step=jnp.asarray(push[1]),
                    period=f(period), quantised=f(0.0 if sensing == "ideal" else 1.0), lean=f(lean),
                    lean_steps=jnp.asarray(int(lean_steps)), observer=f(1.0 if sensing == "observer" else 0.0),
                    ground=f(ground), cable=f(cable), friction=f(friction))


def run_walk(gait: str, controller: str, steps: int, push=(0.0, -1), eta: float = 1.0, sensing: str = "encoders",
             progress=None, lean_deg: float = 0.0, lean_steps: int = 20, plant: str = "stance", torque_limits=None,
             loaded=None, ground: float = 1.0, cable: float = 1.0, friction: float = 1.0, plant_scale=None):
    """Simulate; returns (final loop state, logs, gait record). ``push``: (force N, step index),
    step -1 for none. On the ``full`` plant there is no impact map to scale (the ground's
    compliance makes the impact). ``torque_limits`` (N m, actuator order): the controller's
    saturation instead of the gait's (data of the compiled loop, so any limits share one
    program). ``loaded``: what :func:`load_gait` returned for ``gait``, for a caller that has
    loaded it already (it is then not read again). ``ground``: the 13-DoF plant's ground stiffness
    and damping over the identified ground's (``tables.GROUND``); ``cable``: its cables' stiffness
    and damping over the identified cables' (``tables.CABLE_K``, ``tables.CABLE_D``); ``friction``:
    its motors' viscous friction over Table V's. ``plant_scale``: None, the plant is the
    controller's model (a constant of the compiled loop); else pairs (name, factor) of published
    values (:data:`bipedlab.robots.mabel.model.SCALABLE`; () for none) the plant is built with,
    data of the loop (one program for every such plant), the controller knowing the published
    ones: a robot whose values differ from its model's."""
    if plant not in PLANTS:
        raise ValueError(f"plant must be one of {', '.join(PLANTS)}, got {plant!r}")
    if plant == "full" and eta != 1.0:
        raise ValueError("the full plant takes no impact scaling (its impact is the compliant ground's)")
    if plant != "full" and ground != 1.0:
        raise ValueError("only the full plant has a compliant ground to scale (the stance plant pins its toe)")
    if plant != "full" and cable != 1.0:
        raise ValueError("only the full plant has cables to scale (the stance plant's are rigid)")
    if plant != "full" and friction != 1.0:
        raise ValueError("only the full plant's motor friction can be scaled")
    for what, k in (("ground", ground), ("cable", cable), ("friction", friction)):
        if not (np.isfinite(k) and k > 0):
            raise ValueError(f"the {what} scale must be a positive number, got {k!r}")
    vc, gains, rec = load_gait(gait) if loaded is None else loaded
    if torque_limits is not None:
        gains = gains.replace(limit=jnp.asarray(torque_limits, float))
    m = wk.walking_model()
    setup = setup_for(vc, gains, rec["design"]["period"], eta, push, sensing, np.radians(lean_deg), lean_steps, ground,
                      cable, friction)
    cb = None
    if progress is not None:
        last = [-1]

        def cb(k, n):
            if k // 10 != last[0]:
                last[0] = k // 10
                progress(f"step {k}/{n}")
    if plant == "full":
        from bipedlab.robots.mabel.walking import full_plant as fp

        if plant_scale is not None:
            setup = setup.replace(plant=fp.plant_model(tuple(plant_scale)))
        s, log = fp.simulate(controller, setup, jnp.asarray(rec["z_plus"]), steps, progress=cb)
    else:
        if plant_scale is not None:
            setup = setup.replace(plant=wk.walking_model(scale=tuple(plant_scale)))
        s, log = sw.simulate(m, controller, setup, jnp.asarray(rec["z_plus"]), steps, progress=cb)
    return s, log, rec


def metrics(s, log, limit, mass=None) -> dict:
    """A walk's figures from its final loop state and logs; ``limit``: the torque limits the
    controller saturated at (N m, actuator order), for the saturation figures
    (:func:`~bipedlab.robots.mabel.walking.loop.drive_record`); ``mass``: the robot's mass for
    c_mt (kg; default the published links', :func:`robot_mass`)."""
    touched = np.nonzero(log["touched"])[0]
    n = int(s.x.step)
    t_imp = (touched + 1) * sw.SAMPLE
    durations = np.diff(np.concatenate([[0.0], t_imp]))
    lengths = np.diff(np.concatenate([[0.0], log["distance"][touched]]))
    dist, t = float(s.x.distance), float(t_imp[-1]) if n else float(s.t)
    speed_steps = (lengths / durations).tolist()
    y = log["y"][: touched[-1] + 1] if n else log["y"]
    mass = robot_mass() if mass is None else float(mass)
    work = float(log["work"][touched[-1]]) if n else 0.0
    cmt = work / (mass * 9.81 * dist) if dist > 0 else None
    fell = sw.fell_flag(s)
    # a fallen run has no walking speed (speed_per_step keeps the steps it completed)
    speed = None if fell else (dist / t if t > 0 and n else 0.0)
    end = int(s.failed_at) + 1 if fell and int(s.failed_at) >= 0 else None
    return dict(fell=fell, fell_at_s=(end - 1) * sw.SAMPLE if end else None, steps_completed=n, distance_m=dist,
                duration_s=t, speed_mps=speed, cmt=cmt,
                tracking_rms_deg={k: float(v) for k, v in zip(OUTPUT_NAMES, np.degrees(np.sqrt(np.mean(y**2, 0))))},
                tracking_peak_deg={k: float(v) for k, v in zip(OUTPUT_NAMES, np.degrees(np.max(np.abs(y), 0)))},
                peak_torques_nm=[float(v) for v in np.max(np.abs(log["u"]), 0)],
                speed_per_step=speed_steps, step_lengths_m=lengths.tolist(), step_durations_s=durations.tolist(),
                **sw.contact_record(log, end), **sw.drive_record(log, limit, sw.record_samples(s, log)))


def plant_mass(plant_scale=None):
    """The robot's mass (kg) for c_mt when its plant is built with ``plant_scale`` (None: the
    published robot's, :func:`metrics`' default)."""
    return None if plant_scale is None else float(robot_mass(wk.walking_model(scale=tuple(plant_scale))))


def walk(gait: str, controller: str, steps: int, push=None, eta: float = 1.0, sensing: str = "encoders",
         out=None, progress=None, lean_deg: float = 0.0, lean_steps: int = 20, plant: str = "stance",
         loaded=None, ground: float = 1.0, cable: float = 1.0, friction: float = 1.0, plant_scale=None) -> dict:
    """Closed-loop walk; ``push``: (force N, step index) of a horizontal push on the hip over the
    second half of that step (:func:`parse_push` reads 'FORCE@STEP'), or None; ``lean_deg`` leans
    the torso forward (swing leg's absolute angle kept) in ``lean_steps`` equal increments, one
    per step, as the experimenters did to walk faster. ``plant``: the stance model or the 13-DoF
    model (:data:`PLANTS`); the record gives the realised ``cmt`` beside the gait's designed
    ``cmt_designed``. ``loaded``: what :func:`load_gait` returned for ``gait``, if the caller has
    loaded it already. ``ground``: on the 13-DoF plant, its ground's stiffness and damping over
    the identified ground's (record key ``ground_scale``); ``cable``: its cables' stiffness and
    damping over the identified cables' (record key ``cable_scale``); ``friction``: its motors'
    viscous friction over Table V's (record key ``friction_scale``); ``plant_scale``: as
    :func:`run_walk`'s (record key ``plant_scale``, its c_mt over the scaled robot's mass)."""
    force, step = (0.0, -1) if push is None else (float(push[0]), int(push[1]))
    loaded = load_gait(gait) if loaded is None else loaded
    s, log, rec = run_walk(gait, controller, steps, (force, step), eta, sensing, progress, lean_deg, lean_steps, plant,
                           loaded=loaded, ground=ground, cable=cable, friction=friction, plant_scale=plant_scale)
    r = dict(robot="mabel", gait=gait, plant=plant, controller=controller, sensing=sensing, impact_scale=eta,
             torso_lean_deg=lean_deg, lean_steps=lean_steps if lean_deg else None,
             push_force_n=force if step >= 0 else None, push_step=step if step >= 0 else None,
             **metrics(s, log, loaded[1].limit, mass=plant_mass(plant_scale)))
    if plant_scale is not None:
        r["plant_scale"] = [list(x) for x in plant_scale]
    pc = rec.get("poincare") or {}
    key = "hzd" if controller != "pdff" else "pdff"
    r["max_abs_eigenvalue"] = pc.get(key, {}).get("max_abs_eigenvalue")
    r["designed_speed_mps"] = float(rec["design"]["speed"])
    r["cmt_designed"] = float(rec["design"]["cmt"])
    r["cmt_ratio"] = None if r["cmt"] is None or r["fell"] else r["cmt"] / r["cmt_designed"]
    if plant == "full":
        from bipedlab.robots.mabel.walking import full_plant as fp

        # the compliant ground cannot pull: F_N = 0 there is the stance toe off the ground,
        # which stance_toe_airborne_fraction reports
        r.update(fp.gap_record(log, r["speed_per_step"]), toe_pulled=False, toe_pulled_step=None, ground_scale=ground,
                 cable_scale=cable, friction_scale=friction)
        # the gait's decision vector evaluated on the HZD paper's design model (no friction, no
        # spring damping, rigid cables): the designed c_mt the paper's ~3x gap is measured from
        paper = md.make_design(md.design_model(kind="paper"), np.asarray(rec["x"], float), rec["speed"])
        r["cmt_designed_paper_model"] = float(paper.figures["cmt"])
        r["cmt_ratio_paper_model"] = None if r["cmt_ratio"] is None else r["cmt"] / r["cmt_designed_paper_model"]
    if out:
        from bipedlab.robots.mabel.walking import plots as wp

        r["figures"] = wp.walk_figures(out, log, r)
        if plant == "full":
            from bipedlab.robots.mabel.walking import gap_plots

            _, ref_log, _ = run_walk(gait, controller, 12, eta=gap_plots.FIG20_ETA, sensing="ideal", loaded=loaded)
            r["figures"] += gap_plots.fig20(out, log, ref_log)
    return r


def summary_walk(r: dict) -> str:
    lines = [f"MABEL walking, gait {r['gait']}, controller {r['controller']} ({r['sensing']}, 1 kHz), "
             f"{r['plant']} plant: "
             f"{'FELL after' if r['fell'] else 'no fall,'} {r['steps_completed']} steps",
             ("speed n/a (fell)" if r["speed_mps"] is None else f"speed {r['speed_mps']:.3f} m/s")
             + f" (designed {r['designed_speed_mps']:.3f}), c_mt "
             + (f"{r['cmt']:.4f}" if r["cmt"] is not None else "n/a") + f" (designed {r['cmt_designed']:.4f})",
             "tracking rms (deg): " + ", ".join(f"{k} {v:.3f}" for k, v in r["tracking_rms_deg"].items())]
    if r.get("cmt_designed_paper_model") is not None:
        lines.append(f"13-DoF plant: the same gait on the paper's design model has c_mt "
                     f"{r['cmt_designed_paper_model']:.4f}; stance spring peak {r['stance_spring_peak_deg']:.1f} deg, "
                     f"swing spring peak {r['swing_spring_peak_deg']:.1f} deg, stance toe drift up to "
                     f"{100 * r['max_toe_drift_m']:.1f} cm, stance toe off the ground "
                     f"{100 * r['stance_toe_airborne_fraction']:.1f} % of the time")
    if r.get("max_abs_eigenvalue") is not None:
        lines.append(f"Poincaré max |eig| of the gait under this controller: {r['max_abs_eigenvalue']:.4f}")
    return "\n".join(lines)
