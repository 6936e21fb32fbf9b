"""Study: MABEL hopping on the 13-DoF model (identification paper, Section VIII, Appendix C).

``run_hops`` simulates the sampled-data closed loop (1 ms control, quantised encoders) on the
13-DoF model with cable stretch, the unilateral springs with hard stops and the compliant
ground, and summarises the hops; ``poincare`` linearises the hop-to-hop return map at its
fixed point, with and without the event-based torso update.

Integration: semi-implicit Euler with implicit hard-stop and ground-friction damping
(:func:`bipedlab.robots.mabel.dynamics.step`) at ``DT`` = 0.05 ms, 20 steps per control
sample. ``accuracy_check`` measures what that costs against finer steps and RK4 on the exact
vector field: over the drop and first landing the hip height differs from RK4 at 5 us by
about 0.01 mm; after the first hop the next touchdown comes about 4 ms late (0.1 ms steps:
6 ms), which is where the largest differences in hip height (9 mm) come from. The scheme is
first order: mean hop periods are 0.577 s at 0.1 ms and 0.590 s at 0.05 ms steps.
"""
from __future__ import annotations

import dataclasses
import time

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.robots.mabel.hopping import controller as hop
from bipedlab.pytree import pytree
from bipedlab.sim import integrators, loop
from bipedlab.robots.mabel import dynamics as md
from bipedlab.robots.mabel import model as mm
from bipedlab.robots.mabel import tables as tb
from bipedlab.robots.mabel import transmission as tr

DT = 5e-5
SUBSTEPS = 20
#: The loop's sample time (s); the controller itself uses its parameter ``period``.
CONTROL_PERIOD = 1e-3
#: The hop counts as a fall when the hip drops below this height (m) or the torso leaves
#: the rotation limiter's range (+30 / -40 deg, identification paper, footnote 7).
MIN_HIP_HEIGHT = 0.5
TORSO_RANGE = (np.deg2rad(-40.0), np.deg2rad(30.0))
#: Index of each 13-DoF coordinate in the state.
INDEX = {c: i for i, c in enumerate(mm.COORDS_13)}
_I = INDEX
H_COORDS = ("la_L", "mls_L", "la_R", "mls_R")


def initial_state(m: mm.Mabel, p: hop.HopParams, clearance: float = 0.02) -> jax.Array:
    """At rest in the air, legs at the flight targets x^d, springs and cables unloaded,
    toes ``clearance`` above the ground."""
    xd = np.asarray(hop.nominal_targets(p, p.h_tor0))
    tor = float(p.h_tor0)
    q = np.zeros(13)
    q[_I["tor"]] = tor
    for k, s in enumerate(tb.SIDES):
        la, mls = xd[2 * k], xd[2 * k + 1]
        ls = float(tr.leg_shape(mls, 0.0))
        q[_I[f"la_{s}"]], q[_I[f"ls_{s}"]], q[_I[f"mls_{s}"]] = la, ls, mls
        q[_I[f"mla_{s}"]] = float(tr.rigid_motor_angles(la, ls, 0.0)[0])
    toes = np.asarray(md.toe_positions(m, jnp.asarray(q)))
    q[_I["y"]] = clearance - toes[:, 1].min()
    return jnp.concatenate([jnp.asarray(q), jnp.zeros(13), jnp.zeros(2)])


def sense(m: mm.Mabel, p: hop.HopParams, x):
    """What the controller reads: h (4,), torso angle, toe heights (2,), horizontal boom angle,
    vertical boom rate (see :func:`bipedlab.robots.mabel.hopping.controller.update`)."""
    n = m.n
    q, qd = x[:n], x[n:2 * n]
    h = jnp.stack([q[_I[c]] for c in H_COORDS])
    toes = md.toe_positions(m, q)[:, 1]
    return h, q[_I["tor"]], toes, q[_I["x"]] / p.boom_radius, qd[_I["y"]] / p.boom_radius


def fell(x):
    """A fall: hip below MIN_HIP_HEIGHT or the torso outside TORSO_RANGE."""
    tor = x[_I["tor"]]
    return (x[_I["y"]] < MIN_HIP_HEIGHT) | (tor < TORSO_RANGE[0]) | (tor > TORSO_RANGE[1])


def _rk4_step(m, x, u, h):
    return integrators.rk4(lambda x, u: md.flow(m, x, u), x, u, h)


STEPPERS = {"implicit": md.step, "rk4": _rk4_step}


def control_sample(m: mm.Mabel, p: hop.HopParams, x, c, dt: float, substeps: int, advance=md.step):
    """One 1 ms control sample: the controller reads the state, then ``substeps`` steps of
    length dt under its held torques. Returns (x after the sample, controller state, u)."""
    c_new, u = hop.update(p, c, *sense(m, p, x))
    xn = jax.lax.fori_loop(0, substeps, lambda _, x: advance(m, x, u, dt), x)
    return xn, c_new, u


# ----- the closed loop on bipedlab.sim.loop ----------------------------------------------------
@pytree
class Plant:
    """Plant state of the hopping loop: the robot's state ``x`` (28,) and ``dead``, set when the
    last sample failed (a fall or a non-finite state); a failed sample is not applied."""

    x: jax.Array
    dead: jax.Array


@pytree
class Memory:
    """Controller state of the hopping loop: the controller's memory ``now`` and ``before`` the
    last sample (the memory in force again when that sample failed and was not applied)."""

    now: hop.HopState
    before: hop.HopState


def _tree_where(flag, a, b):
    return jax.tree_util.tree_map(lambda u, v: jnp.where(flag, u, v), a, b)


def _loop_sensor(params, sensor_state, plant: Plant, t):
    m, p = params
    return sensor_state, (plant.dead, sense(m, p, plant.x))


def _loop_controller(params, mem: Memory, y, t):
    m, p = params
    dead, reading = y
    c = _tree_where(dead, mem.before, mem.now)
    c_new, u = hop.update(p, c, *reading)
    return Memory(c_new, c), u


def _plant_step(advance, dt: float, substeps: int):
    def plant_step(params, plant: Plant, u, d, h, t):
        """One control period: ``substeps`` steps of length dt under the held torques u; the
        sample is not applied (and ``dead`` is set) when it ends in a fall or non-finite."""
        m, p = params
        xn = jax.lax.fori_loop(0, substeps, lambda _, x: advance(m, x, u, dt), plant.x)
        dead = ~jnp.all(jnp.isfinite(xn)) | fell(xn)
        return Plant(jnp.where(dead, plant.x, xn), dead)

    return plant_step


def _loop_fell(params, before, y, u, plant: Plant):
    return plant.dead


def _loop_log(params, before, y, u, plant: Plant, mem: Memory):
    m, p = params
    phase = jnp.where(plant.dead, mem.before.phase, mem.now.phase)
    return plant.x, jnp.clip(u, -m.drive.torque_limit, m.drive.torque_limit), phase


def hop_loop(period: float, dt: float = DT, substeps: int = SUBSTEPS, record: bool = True,
             stepper: str = "implicit") -> loop.SampledLoop:
    """The hopping closed loop as a :class:`bipedlab.sim.loop.SampledLoop` over params ``(m, p)``:
    sensor (:func:`sense`), the five-phase controller with its memory (:class:`Memory`), one
    plant step per control sample integrating ``substeps`` steps of ``dt`` (:data:`STEPPERS`),
    the fall check (:func:`fell`), and the log (state, commanded torques, phase) when ``record``."""
    return loop.SampledLoop(plant_step=_plant_step(STEPPERS[stepper], dt, substeps), sensor=_loop_sensor,
                            controller=_loop_controller, fell=_loop_fell, sample_time=period,
                            log=_loop_log if record else None)


def run_samples(m: mm.Mabel, p: hop.HopParams, x0, c0, steps: int, dt: float = DT, substeps: int = SUBSTEPS,
                record: bool = True, stepper: str = "implicit"):
    """Simulate ``steps`` control samples. Returns (x, c, alive, log) where log holds per
    sample the state after it, the commanded torques and the phase (or None).
    stepper: "implicit" (:func:`~bipedlab.robots.mabel.dynamics.step`) or "rk4" on the exact
    vector field (needs dt below about 1e-5 s at the hard stop)."""
    lp = hop_loop(CONTROL_PERIOD, dt, substeps, record, stepper)
    s0 = loop.initial_state(Plant(x0, jnp.asarray(False)), None, Memory(c0, c0))
    s, log = loop.run(lp, (m, p), s0, steps)
    c = _tree_where(s.x.dead, s.ctrl.before, s.ctrl.now)
    return s.x.x, c, s.status == loop.OK, log


run_samples_jit = jax.jit(run_samples, static_argnames=("steps", "dt", "substeps", "record", "stepper"))


_CACHE: dict = {}


def _compiled(m, p, x0, c0, steps: int):
    """Ahead-of-time compiled closed loop, cached per model structure and length."""
    key = (jax.tree_util.tree_structure((m, p)), steps)
    if key not in _CACHE:
        _CACHE[key] = run_samples_jit.lower(m, p, x0, c0, steps=steps).compile()
    return _CACHE[key]


@dataclasses.dataclass
class HopRun:
    """A simulated hopping run: times (s), states (N, 28), torques (N, 4), phases (N,),
    touchdown times (s), whether it fell, and the wall time of the simulation (s)."""

    t: np.ndarray
    x: np.ndarray
    u: np.ndarray
    phase: np.ndarray
    touchdowns: np.ndarray
    fell: bool
    wall_s: float
    compile_s: float


def run_hops(hops: int = 100, torso_update: bool = True, params: hop.HopParams | None = None,
             model: mm.Mabel | None = None, seconds_per_hop: float = 0.7) -> HopRun:
    """Drop MABEL from 2 cm and hop until ``hops`` hops have landed (or it falls)."""
    m = model or mm.hopping_model()
    p = (params or hop.paper_params()).replace(torso_update=jnp.asarray(1.0 if torso_update else 0.0))
    x0 = initial_state(m, p)
    c0 = hop.initial_state(p, sense(m, p, x0)[0])
    steps = int(np.ceil((hops + 1) * seconds_per_hop / float(p.period)))
    t0 = time.perf_counter()
    compiled = _compiled(m, p, x0, c0, steps)
    t1 = time.perf_counter()
    x, c, alive, (xs, us, ph) = jax.block_until_ready(compiled(m, p, x0, c0))
    t2 = time.perf_counter()
    t = (np.arange(steps) + 1) * float(p.period)
    ph = np.asarray(ph)
    td = t[1:][(ph[1:] == hop.TOUCHDOWN) & (ph[:-1] == hop.FLIGHT)]
    if ph[0] == hop.TOUCHDOWN:
        td = np.concatenate([[t[0]], td])
    # keep the run up to the touchdown that completes the requested number of hops
    end = steps if len(td) <= hops else int(np.searchsorted(t, td[hops])) + 1
    return HopRun(t[:end], np.asarray(xs)[:end], np.asarray(us)[:end], ph[:end], td[: hops + 1],
                  not bool(alive) and len(td) <= hops, t2 - t1, t1 - t0)


def cable_stretch(x: np.ndarray) -> np.ndarray:
    """Cable stretch (rad, motor side) per actuator in tables.ACTUATORS order, (N, 4)."""
    out = []
    for s in tb.SIDES:
        la, ls, bsp, mla, mls = (x[:, _I[f"{c}_{s}"]] for c in tr.LOCAL)
        lam_la, lam_ls = tr.cable_stretch(la, ls, bsp, mla, mls)
        out += [np.asarray(lam_la), np.asarray(lam_ls)]
    return np.stack(out, axis=1)


def summarize(run: HopRun) -> dict:
    """The study's record (JSON-ready)."""
    td = run.touchdowns
    periods = np.diff(td)
    stretch = np.rad2deg(np.abs(cable_stretch(run.x)).max(axis=0))
    peak = np.abs(run.u).max(axis=0)
    sim_time = float(run.t[-1]) if len(run.t) else 0.0
    return {
        "fell": bool(run.fell),
        "hops_completed": int(max(len(td) - 1, 0)),
        "mean_hop_period_s": float(periods.mean()) if len(periods) else None,
        "hop_period_sd_s": float(periods.std()) if len(periods) else None,
        "max_cable_stretch_deg": {a: float(v) for a, v in zip(tb.ACTUATORS, stretch)},
        "peak_motor_torque_nm": float(peak.max()),
        "peak_motor_torque_by_actuator_nm": {a: float(v) for a, v in zip(tb.ACTUATORS, peak)},
        "simulated_time_s": sim_time,
        "wall_time_s": run.wall_s,
        "real_time_fraction": run.wall_s / sim_time if sim_time else None,
        "compile_time_s": run.compile_s,
    }


def accuracy_check(seconds: float = 1.2, params: hop.HopParams | None = None) -> dict:
    """What the semi-implicit step costs: the drop, first landing and first hop simulated
    with it at 0.1, 0.05 (the study's) and 0.025 ms, and with RK4 on the exact vector field at 5 us,
    all under the same 1 ms controller (exact encoder readings, so all three see the same
    signals). Reports the largest differences in hip height and torso angle and the times
    of the first phase switches."""
    m = mm.hopping_model()
    p = (params or hop.paper_params()).replace(encoder_counts=jnp.asarray(0.0))
    x0 = initial_state(m, p)
    c0 = hop.initial_state(p, sense(m, p, x0)[0])
    steps = int(round(seconds / float(p.period)))
    runs = {}
    for name, dt, sub, stepper in (("implicit_0.1ms", 1e-4, 10, "implicit"),
                                   ("implicit_0.05ms", 5e-5, 20, "implicit"),
                                   ("implicit_0.025ms", 2.5e-5, 40, "implicit"),
                                   ("rk4_5us", 5e-6, 200, "rk4")):
        t0 = time.perf_counter()
        _, _, _, (xs, _, ph) = run_samples_jit(m, p, x0, c0, steps=steps, dt=dt, substeps=sub, stepper=stepper)
        xs, ph = np.asarray(xs), np.asarray(ph)
        runs[name] = (xs, ph, time.perf_counter() - t0)
    ref_x, ref_ph, _ = runs["rk4_5us"]

    def switches(ph):
        return [int(i) + 1 for i in np.flatnonzero(np.diff(ph))][:6]

    out = {"seconds": seconds, "reference": "rk4_5us", "reference_phase_switch_ms": switches(ref_ph)}
    for name, (xs, ph, wall) in runs.items():
        if name == "rk4_5us":
            continue
        out[name] = {
            "max_hip_height_error_mm": float(1e3 * np.abs(xs[:, _I["y"]] - ref_x[:, _I["y"]]).max()),
            "max_torso_error_deg": float(np.rad2deg(np.abs(xs[:, _I["tor"]] - ref_x[:, _I["tor"]]).max())),
            "phase_switch_ms": switches(ph),
            "wall_s": wall,
        }
    return out


def study(hops: int = 100, torso_update: bool = True, poincare: bool = True, accuracy: bool = False,
          robustness_samples: int | None = None, out: str | None = None, progress=None) -> dict:
    """The hopping experiment of Section VIII-D: simulate, summarise, linearise, plot."""
    say = progress or (lambda msg: None)
    say(f"simulating {hops} hops on the 13-DoF model ({'with' if torso_update else 'without'} the torso update)")
    run = run_hops(hops, torso_update=torso_update)
    p = hop.paper_params()
    rec = {"robot": "mabel", "model": "13-DoF hopping model (cable stretch, unilateral springs, compliant ground)",
           "torso_update": torso_update, "hops_requested": hops}
    rec.update(summarize(run))
    rec.update(integrator="semi-implicit Euler, implicit spring and ground-friction damping", dt_s=DT,
               control_period_s=float(p.period), encoder_counts_per_rev=int(p.encoder_counts))
    rec["poincare_max_abs_eigenvalue"] = None
    if poincare:
        from bipedlab.robots.mabel.hopping import poincare as hop_poincare

        say("Poincaré analysis of the hop-to-hop map (with and without the torso update)")
        pa = hop_poincare.analyse()
        rec["poincare"] = pa
        if pa.get("converged"):
            key = "with_torso_update" if torso_update else "without_torso_update"
            rec["poincare_max_abs_eigenvalue"] = pa[key]["max_abs_eigenvalue"]
    if accuracy:
        say("integrator accuracy check (first hop: 0.1, 0.05, 0.025 ms vs RK4 at 5 us)")
        rec["accuracy"] = accuracy_check()
    if robustness_samples:
        say(f"robustness: {robustness_samples} perturbed drops per controller, 50 hops")
        rec["robustness"] = robustness(robustness_samples)
    if out:
        from bipedlab.robots.mabel.hopping import plots as hop_plots

        stretch = cable_stretch(run.x)
        rec["figures"] = hop_plots.write_figures(run, stretch, out)
        if not any(str(f).endswith("hop_periods.png") for f in rec["figures"]):
            say(f"no hop-period figure: it needs at least 3 touchdowns, the run had {len(run.touchdowns)}")
        path = f"{out}/hop_mabel.npz"
        np.savez(path, t=run.t, x=run.x, u=run.u, phase=run.phase, touchdowns=run.touchdowns,
                 cable_stretch=stretch, coordinates=np.array(mm.COORDS_13 + ("z_L", "z_R")))
        rec["data"] = path
    return rec


def summary(rec: dict) -> str:
    """Human-readable summary of :func:`study`."""
    lines = [f"MABEL hopping, {rec['model']}",
             f"  torso update (44): {'on' if rec['torso_update'] else 'off'}",
             f"  hops completed: {rec['hops_completed']} of {rec['hops_requested']}"
             + ("  (fell)" if rec["fell"] else "")]
    if rec["mean_hop_period_s"] is not None:
        lines.append(f"  hop period: {rec['mean_hop_period_s']:.3f} s +- {rec['hop_period_sd_s']:.3f} s")
    lines.append("  max cable stretch (deg, motor side): "
                 + ", ".join(f"{k} {v:.1f}" for k, v in rec["max_cable_stretch_deg"].items()))
    lines.append(f"  peak motor torque: {rec['peak_motor_torque_nm']:.1f} N m")
    lines.append(f"  simulated {rec['simulated_time_s']:.1f} s in {rec['wall_time_s']:.2f} s "
                 f"({rec['real_time_fraction']:.3f} of real time; compile {rec['compile_time_s']:.1f} s)")
    pa = rec.get("poincare")
    if pa and pa.get("converged"):
        for key, label in (("with_torso_update", "with update"), ("without_torso_update", "nominal")):
            lines.append(f"  Poincaré, {label}: max |eigenvalue| {pa[key]['max_abs_eigenvalue']:.3f}")
    if "accuracy" in rec:
        for k, v in rec["accuracy"].items():
            if isinstance(v, dict):
                lines.append(f"  accuracy {k} vs RK4 5 us: hip height {v['max_hip_height_error_mm']:.2f} mm, "
                             f"torso {v['max_torso_error_deg']:.3f} deg")
    rb = rec.get("robustness")
    if rb:
        for key, label in (("with_torso_update", "with update"), ("without_torso_update", "nominal")):
            lines.append(f"  perturbed drops, {label}: {rb[key]['completed_fraction']:.0%} complete {rb['hops']} hops "
                         f"(median {rb[key]['median_hops']:.0f})")
    for f in rec.get("figures", []):
        lines.append(f"  figure: {f}")
    return "\n".join(lines)


def robustness(samples: int = 32, hops: int = 50, seed: int = 0) -> dict:
    """Nonlinear check of the Poincaré result: drop MABEL from randomly perturbed states
    (height 1-5 cm, torso +-3 deg, hip speed +-0.2 m/s forward and down to -0.3 m/s
    vertical) and count the hops each controller completes, all rollouts of a controller in
    one batched call. Returns per controller the fraction that completes ``hops`` hops and
    the median hop count."""
    m = mm.hopping_model()
    rng = np.random.default_rng(seed)
    out = {"samples": samples, "hops": hops}
    base = hop.paper_params()
    x_nom = np.asarray(initial_state(m, base, clearance=0.0))
    X = np.repeat(x_nom[None], samples, axis=0)
    X[:, _I["y"]] += rng.uniform(0.01, 0.05, samples)
    X[:, _I["tor"]] += np.deg2rad(rng.uniform(-3.0, 3.0, samples))
    X[:, m.n + _I["x"]] += rng.uniform(-0.2, 0.2, samples)
    X[:, m.n + _I["y"]] += rng.uniform(-0.3, 0.0, samples)
    steps = int((hops + 1) * 0.7 / float(base.period))

    def one(x0, p, c0):
        c0 = dataclasses.replace(c0, h_prev=hop.quantise(p, sense(m, p, x0)[0]))
        return run_samples(m, p, x0, c0, steps, record=False)[1].touchdowns

    batch = jax.jit(jax.vmap(one, in_axes=(0, None, None)))  # the controller traced: one program for both
    for name, flag in (("with_torso_update", 1.0), ("without_torso_update", 0.0)):
        p = base.replace(torso_update=jnp.asarray(flag))
        c0 = hop.initial_state(p, sense(m, p, jnp.asarray(x_nom))[0])
        td = np.asarray(batch(jnp.asarray(X), p, c0))
        done = np.maximum(td - 1, 0)
        out[name] = {"completed_fraction": float(np.mean(done >= hops)), "median_hops": float(np.median(done))}
    return out
