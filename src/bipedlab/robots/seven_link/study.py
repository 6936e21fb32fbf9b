"""Studies of the seven-link biped (Braun, Mitchell, Goldfarb, IEEE/ASME T-Mech 2012).

* :func:`walk`: nonkinematic walking on flat ground (Section VI): eq. 4 generalised forces,
  S1-S4 switching, the eq. 7 torque map, on the active-set contact simulation of
  :mod:`bipedlab.robots.seven_link.contact`; gait figures (speed, step length, step frequency),
  the mechanical cost of transport, constraint drift, impact energy check, Fig. 8/9 figures.
* :func:`free_swing`: Fig. 6, hip and knee released from rest, with Table I's gearing
  (21:1 hip, 12:1 knee) and the highly geared alternative (105:1, 60:1).
* :func:`low_gain_pd`: Fig. 7, the low-gain PD experiment with the stated gains and
  references on a leg hanging from a fixed body.

Mechanical cost of transport (the paper's ``c_mt = |mechanical energy| / (weight x distance)``,
after Gabrielli and von Karman): the mechanical energy is the actuators' absolute work
``sum_i int |u_i phi_dot_i| dt`` over whole steps, after the first ``TRANSIENT_STEPS``
steps, divided by the robot's weight and the hip's distance travelled over the same steps.
The positive-work variant of Collins et al. (``int max(u_i phi_dot_i, 0) dt``) is reported
beside it as ``cmt_positive``.
"""
from __future__ import annotations

import functools
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.robots.seven_link import controller as ctl
from bipedlab.robots.seven_link import robot as sl
from bipedlab.robots.seven_link import contact as sc
from bipedlab.robots.seven_link import setup as su
from bipedlab.sim.integrators import rk4
from bipedlab.sim.loop import SampledLoop
from bipedlab.sim.loop import initial_state as loop_initial_state
from bipedlab.sim.loop import run as loop_run

#: Steps ignored by the gait averages (the start from a guessed posture).
TRANSIENT_STEPS = 6
#: Mechanical cost of transport quoted in the paper and the reference values.
CMT_COMPARISON = {"Cornell biped": 0.055, "MABEL": 0.14, "seven-link (paper, hardware)": 0.31, "RABBIT": 0.38,
                  "ASIMO": 1.6}
PAPER_GAIT = {"speed_mps": 0.5, "step_length_m": 0.5, "step_frequency_hz": 1.0, "cmt": 0.31}
#: The initial posture: body angle, joint angles (deg) and hip velocity (m/s); leg 1 stands
#: flat-footed with the knee on its stop, leg 2 swings behind.
START_BODY_DEG = 87.5
START_PHI_DEG = (7.5, 0.0, 0.0, -7.5, -30.0, 10.0)
START_SPEED = 0.5


# ----------------------------------------------------------------------------- walking
#: the constraint projection compiled once (called eagerly, its Newton loop compiled anew per call)
_project = jax.jit(sc.project, static_argnames=("newton",))


def initial_condition(r: sl.SevenLink | None = None, speed: float = START_SPEED):
    """(x0 (18,), active0 (6,)): leg 1 flat on the ground at x = 0 with its knee locked, leg 2
    in swing; the hip velocity guess ``speed`` is projected onto the constraints by the
    simulator."""
    r = r or sl.model()
    q = sl.configuration(np.deg2rad(START_BODY_DEG), np.deg2rad(START_PHI_DEG), anchor="heel_1", r=r)
    qd = jnp.zeros(9).at[0].set(speed)
    active = jnp.array([True, True, False, False, True, False])
    x = jnp.concatenate([q, qd])
    # the posture's foot is tilted 5 deg: lay it flat (M-weighted Newton projection onto
    # the stance constraints, to convergence) and make the velocity consistent
    anchors = jnp.stack([sl.point_position(r, q, n) for n in sl.CONTACTS])[:, 0]
    for _ in range(5):
        x, _ = _project(r, x, active, anchors)
    return x, active


#: The controller variant of each parameter set: both use the unilateral check of
#: :func:`bipedlab.robots.seven_link.controller.policy` (no element asked to pull): Section II-B
#: keeps in A the constraints "active when they restrict the motion", and a toe, heel or knee
#: stop that eq. 7 would ask to pull restricts nothing. Without it (every touching element in
#: A) the contacts chatter: Table II on the boom setup made 24.5 contact events per step and
#: fell after 2 touchdowns (with the stance-knee latch of
#: :data:`bipedlab.robots.seven_link.controller.STANCE_KNEE_LATCH_DEG`, still 100.6 events per step
#: and a fall after 10); with it, 10.8 events per step over 30 steps. The planar model with
#: Table II and the check falls after 5 touchdowns (it walked, too fast, only through the
#: chatter's losses).
UNILATERAL_CHECK = {"paper": True, "tuned": True}


def gains(name: str) -> ctl.Gains:
    """"paper" (Table II) or "tuned" (:data:`bipedlab.robots.seven_link.controller.TABLE_TUNED`)."""
    if name == "paper":
        return ctl.paper_gains()
    if name == "tuned":
        return ctl.tuned_gains()
    raise ValueError(f"seven-link: params must be 'paper' or 'tuned', got {name!r}")


def settings_for(steps: int) -> sc.Settings:
    return sc.Settings(max_time=float(max(10.0, 2.5 * steps + 5.0)), steps=int(steps))


@functools.lru_cache(maxsize=8)
def _setup_simulator(settings: sc.Settings):
    """The closed loop with the plant's robot in the parameters (``(policy params, plant)``),
    so every :class:`~bipedlab.robots.seven_link.robot.Setup`, the planar model's all-zero one
    included, shares one compiled program."""
    def policy(pp, c, t, x, a):
        return ctl.policy(pp[0], c, t, x, a)

    loop = sc.closed_loop(su.plant(), policy, settings, ctl.log_vector, robot_of=lambda pp: pp[1])

    def run(x0, active0, p, c0, plant):
        return sc.simulate(plant, policy, (p, plant), c0, x0, active0, settings, ctl.log_vector, loop=loop)

    return run


def setup_parts(without=()) -> dict:
    """Which parts of the boom setup are on (:data:`bipedlab.robots.seven_link.setup.PARTS`),
    all but those named in ``without``."""
    bad = [w for w in without if w not in su.PARTS]
    if bad:
        raise ValueError(f"seven-link: unknown setup parts {bad}, expected some of {list(su.PARTS)}")
    return {k: k not in without for k in su.PARTS}


def boom_setup(without=(), **boom_options):
    """(parts on, :class:`~bipedlab.robots.seven_link.robot.Setup`): the boom setup less the
    parts named in ``without``; ``boom_options``: keyword arguments of
    :func:`bipedlab.robots.seven_link.setup.boom`."""
    on = setup_parts(without)
    return on, su.boom(boom_inertia=on["boom_inertia"], foot_turning=on["foot_turning"],
                       drive_friction=on["drive_friction"], **boom_options)


def run_walk(steps: int = 30, params: str = "tuned", sensing: bool = False, x0=None, active0=None,
             speed: float = START_SPEED, setup: str = "planar", without=(), boom_options: dict | None = None,
             knee_lock_torque: float = su.KNEE_LOCK_TORQUE, scale: dict | None = None):
    """Simulate the closed loop; returns the raw :class:`~bipedlab.robots.seven_link.contact.SimResult`.
    setup: "planar" (the planar model: the boom setup with every part off) or "boom" (the plant of
    :mod:`bipedlab.robots.seven_link.setup`, less the parts named in ``without``; the
    controller keeps the planar model, the knee lock torque is the controller's);
    boom_options: keyword arguments of :func:`bipedlab.robots.seven_link.setup.boom` (the
    sensitivity to its assumed sizes); scale: Table I's values scaled in the plant only
    (:func:`bipedlab.robots.seven_link.robot.model`; the controller keeps Table I)."""
    r = sl.model()
    if x0 is None:
        x0, active0 = initial_condition(r, speed)
    if setup not in su.SETUPS:
        raise ValueError(f"seven-link: setup must be one of {list(su.SETUPS)}, got {setup!r}")
    # the planar model is the boom setup with every part off (its additions exactly zero), so
    # both run on one compiled program
    on, s = boom_setup(su.PARTS) if setup == "planar" else boom_setup(without, **(boom_options or {}))
    g = gains(params).replace(knee_lock_torque=jnp.asarray(knee_lock_torque * on["knee_lock"], jnp.float64))
    # the lock torque and its threshold are one mechanism (Fig. 8 caption): the latch with the torque
    p = ctl.make_params(r, g, sensing=sensing, unilateral_check=UNILATERAL_CHECK[params],
                        stance_knee_latch_deg=ctl.STANCE_KNEE_LATCH_DEG * float(on["knee_lock"]))
    plant = su.plant(s, sl.model(scale=scale) if scale else None)
    return _setup_simulator(settings_for(steps))(x0, active0, p, ctl.initial_state(x0), plant)


#: the fewest whole steps a gait window must hold to measure a gait over it
MIN_WINDOW_STEPS = 2


def gait_window_start(n: int, transient: int = TRANSIENT_STEPS) -> int:
    """The first touchdown of the gait window of a walk with ``n`` touchdowns: after
    ``transient`` of them, moved earlier on a short walk so that the window keeps what steps
    there are (it holds n - 1 - start whole steps)."""
    return min(transient, max(n - 3, 0))


def gait_metrics(res, weight: float, transient: int = TRANSIENT_STEPS) -> dict:
    """Speed, step length, step frequency and c_mt over the touchdowns after ``transient``."""
    n = int(res.n_touchdowns)
    t = np.asarray(res.td_time[:n])
    hx = np.asarray(res.td_hip_x[:n])
    wk = np.asarray(res.td_work[:n])
    a = gait_window_start(n, transient)
    out = dict(speed_mps=None, step_length_m=None, step_frequency_hz=None, cmt=None, cmt_positive=None,
               gait_window_steps=max(n - 1 - a, 0))
    if n - 1 - a >= MIN_WINDOW_STEPS:
        dist = hx[-1] - hx[a]
        dur = t[-1] - t[a]
        out.update(speed_mps=dist / dur, step_length_m=dist / (n - 1 - a), step_frequency_hz=(n - 1 - a) / dur)
        if dist > 0:
            out.update(cmt=(wk[-1, 0] - wk[a, 0]) / (weight * dist), cmt_positive=(wk[-1, 1] - wk[a, 1]) / (weight * dist))
    return out


#: A knee flexed less than this (deg) counts as extended (on its stop) in :func:`gait_phases`:
#: it shortens the hip-ankle distance by under 0.05 mm.
KNEE_EXTENDED_DEG = 1.0


def gait_phases(t, x, u, active, td_time, td_foot, transient: int = TRANSIENT_STEPS) -> dict | None:
    """The gait's phases and ranges over the gait window of :func:`gait_metrics` (touchdowns
    ``a`` .. n-1), from the walk's log (t, x (n, 18), u (n, 6), active (n, 6): the contacts of
    :data:`bipedlab.robots.seven_link.robot.CONTACTS`, then the knee stops):

    * ``ranges``: per joint (both legs pooled) the joint angle's and the torque's min and max
      (deg, N m), cf. Fig. 8;
    * ``max_heel_on_knee_flexion_deg``: the largest knee flexion (-phi_knee) of a leg while its
      heel is on the ground (heel strike to heel lift: the stance before the push-off),
      ``heel_on_knee_extended_fraction``: the share of those samples with the knee within
      :data:`KNEE_EXTENDED_DEG` of full extension (on its stop), and ``single_support_fraction``:
      the share of the window's samples with one foot on the ground;
    * per step (each touchdown k > a; the landing foot f, the trailing foot g): ``heel_strike``
      (the landing foot's first contact is its heel alone), ``toe_only_before_strike`` (g stood
      on its toe alone, heel lifted, in the last logged sample before the strike: a pre-emptive
      push-off, Fig. 9), ``heel_off_lead_s`` (from g's heel lift to the strike; negative: it lifts after),
      ``double_support_s`` (from the strike until g leaves the ground), ``rolling_double_support``
      (a double support with g on its toe alone throughout and f landing heel first: both feet
      rolling), ``push_off_ankle_work_j`` (g's ankle work int u dphi/dt dt from its heel lift to
      its toe-off). None when the window holds fewer than two steps."""
    t, x, u, act = np.asarray(t), np.asarray(x), np.asarray(u), np.asarray(active, bool)
    td_time, td_foot = np.asarray(td_time), np.asarray(td_foot).astype(int)
    n = len(td_time)
    a = gait_window_start(n, transient)
    if n - 1 - a < MIN_WINDOW_STEPS or len(t) < 2:
        return None
    phi = x[:, :9] @ sl.JOINT_MAP.T + sl.JOINT_OFFSET
    phid = x[:, 9:18] @ sl.JOINT_MAP.T
    w = (t >= td_time[a]) & (t <= td_time[-1])
    ranges = {}
    for k, nm in enumerate(("hip", "knee", "ankle")):
        ang, tq = np.rad2deg(phi[w][:, [k, 3 + k]]), u[w][:, [k, 3 + k]]
        ranges[nm] = dict(angle_min_deg=float(ang.min()), angle_max_deg=float(ang.max()),
                          torque_min_nm=float(tq.min()), torque_max_nm=float(tq.max()))
    on = np.stack([act[:, 0] | act[:, 1], act[:, 2] | act[:, 3]], axis=1)  # foot touching
    single = w & (on.sum(axis=1) == 1)
    heel_on = w[:, None] & act[:, [1, 3]]
    flex = -np.rad2deg(phi[:, [1, 4]])[heel_on]
    steps = []
    for k in range(a + 1, n):
        f = int(td_foot[k])
        g = 1 - f
        toe_g, heel_g = act[:, 2 * g], act[:, 2 * g + 1]
        i0 = int(np.searchsorted(t, td_time[k]))  # first logged sample at / after the strike
        if i0 >= len(t) or i0 < 1:
            continue
        off = np.flatnonzero(~on[i0:, g])
        i_to = i0 + off[0] if len(off) else len(t) - 1
        heel = np.flatnonzero((t >= td_time[k - 1]) & (np.arange(len(t)) < i_to) & heel_g)
        i_ho = heel[-1] + 1 if len(heel) else int(np.searchsorted(t, td_time[k - 1]))
        ds = slice(i0, i_to)
        seg = slice(i_ho, i_to + 1)
        pw = u[seg, 3 * g + 2] * phid[seg, 3 * g + 2]
        steps.append(dict(
            touchdown=k, foot=f + 1,
            heel_strike=bool(act[i0, 2 * f + 1] and not act[i0, 2 * f]),
            toe_only_before_strike=bool(toe_g[i0 - 1] and not heel_g[i0 - 1]),
            heel_off_lead_s=float(td_time[k] - t[i_ho]),
            double_support_s=float(t[i_to] - td_time[k]),
            rolling_double_support=bool(i_to > i0 and np.all(toe_g[ds] & ~heel_g[ds])
                                        and act[i0, 2 * f + 1] and not act[i0, 2 * f]),
            push_off_ankle_work_j=float(np.sum(0.5 * (pw[1:] + pw[:-1]) * np.diff(t[seg])))))
    if len(steps) < 2:
        return None
    return dict(window_touchdowns=[int(a), int(n - 1)], log_sample_s=float(np.median(np.diff(t))), ranges=ranges,
                max_heel_on_knee_flexion_deg=float(flex.max()) if flex.size else None,
                heel_on_knee_extended_fraction=float(np.mean(flex <= KNEE_EXTENDED_DEG)) if flex.size else None,
                single_support_fraction=float(single.sum() / max(w.sum(), 1)), steps=steps)


#: Names of the logged active-set elements (:data:`bipedlab.robots.seven_link.robot.CONTACTS`, then
#: the knee stops) in :func:`contact_sequence`.
ELEMENT_NAMES = ("toe_1", "heel_1", "toe_2", "heel_2", "knee_1", "knee_2")
#: What a change of each element is called (made, broken): strikes and lifts of toes and heels,
#: locks and unlocks of the knees.
_ELEMENT_CHANGES = {"toe": ("toe strike", "toe lift"), "heel": ("heel strike", "heel lift"),
                    "knee": ("knee lock", "knee unlock")}


def contact_sequence(t, active, states, t_end: float | None = None) -> list:
    """The walk's event sequence from its log (t (n,), active (n, 6) of :data:`ELEMENT_NAMES`,
    leg states (n, 2) as 0-3 for S1-S4): one dict per change between successive samples, in
    time order, ``dict(t, kind, leg, element)`` with kind one of "toe strike", "toe lift",
    "heel strike", "heel lift", "knee lock", "knee unlock" or "S1->S2" (a leg's state change,
    element None); up to t_end (s) when given. An element made and broken within one logged
    interval leaves no entry (log every sample to see them all)."""
    t, act, st = np.asarray(t), np.asarray(active, bool), np.asarray(states).astype(int)
    if act.ndim != 2 or act.shape[1] != len(ELEMENT_NAMES) or len(act) != len(t) or st.shape != (len(t), 2):
        raise ValueError(f"seven-link: contact_sequence needs t (n,), active (n, 6), states (n, 2); got "
                         f"{t.shape}, {act.shape}, {st.shape}")
    out = []
    for i in range(1, len(t)):
        if t_end is not None and t[i] > t_end:
            break
        for j, name in enumerate(ELEMENT_NAMES):
            if act[i, j] != act[i - 1, j]:
                part, leg = name.split("_")
                out.append(dict(t=float(t[i]), kind=_ELEMENT_CHANGES[part][0 if act[i, j] else 1], leg=int(leg),
                                element=name))
        for leg in range(2):
            if st[i, leg] != st[i - 1, leg]:
                out.append(dict(t=float(t[i]), kind=f"S{st[i - 1, leg] + 1}->S{st[i, leg] + 1}", leg=leg + 1,
                                element=None))
    return out


def stance_knee_unlocks(sequence: list, initial=(0, 2)) -> list:
    """The knee unlocks of a leg in S1 (stance) in a :func:`contact_sequence` whose legs start
    in the states ``initial`` (0-3; the default start: leg 1 in S1, leg 2 in S3): the stance
    leg's knee leaving its stop, which the paper's extended-knee stance never shows (Fig. 8)."""
    state = {1: int(initial[0]), 2: int(initial[1])}
    out = []
    for e in sequence:
        if e["element"] is None:
            state[e["leg"]] = int(e["kind"][-1]) - 1
        elif e["kind"] == "knee unlock" and state[e["leg"]] == 0:
            out.append(e)
    return out


def _finite(v):
    if v is None:
        return None
    v = float(v)
    return v if np.isfinite(v) else None


def walk_fell(res, steps: int) -> bool:
    """Whether a walk of :func:`run_walk` fell: a failure status, or fewer touchdowns than the
    ``steps`` asked for."""
    return bool(int(res.status) != sc.OK or int(res.n_touchdowns) < steps)


def walk(steps: int = 30, params: str = "tuned", out: str | None = None, progress=None, sensing: bool = False,
         setup: str = "planar", without=()) -> dict:
    """The walking study: a result record (JSON-ready) and, with ``out``, figures and an NPZ.
    sensing: the controller sees the Section V-A estimates (quantised encoders, body angle
    from the contact kinematics or the integrated gyro) instead of the exact state.
    setup: "planar" or "boom" (:mod:`bipedlab.robots.seven_link.setup`; ``without`` switches
    parts of it off); the boom record adds the setup's numbers (:func:`setup_record`)."""
    progress = progress or (lambda m: None)
    r = sl.model()
    where = "" if setup == "planar" else f" on the {setup} setup"
    progress(f"seven-link: simulating {steps} steps with the {params} parameters{where} (first run compiles, ~30 s)")
    # the record is kept from host copies: slices and reads of device arrays by a walk's own
    # counts each compiled a program of their own
    res = jax.device_get(run_walk(steps, params, sensing=sensing, setup=setup, without=without))
    status = int(res.status)
    n = int(res.n_touchdowns)
    weight = float(sl.total_mass(r)) * sl.GRAVITY
    nl = int(res.n_log_used)
    lt, lx, lu = np.asarray(res.log_t[:nl]), np.asarray(res.log_x[:nl]), np.asarray(res.log_u[:nl])
    rec = dict(robot="seven-link", params=params, sensing="section V-A" if sensing else "ideal", steps_requested=steps, steps_completed=n,
               fell=walk_fell(res, steps), status=sc.STATUS_NAMES.get(status, str(status)),
               sim_time_s=float(res.t_end))
    rec.update({k: _finite(v) if k != "gait_window_steps" else v for k, v in gait_metrics(res, weight).items()})
    rec["cmt_definition"] = ("sum_i int |u_i dphi_i/dt| dt / (m g distance), over whole steps after the first "
                             f"{TRANSIENT_STEPS}; cmt_positive counts positive work only")
    rec["cmt_comparison"] = CMT_COMPARISON
    rec["paper"] = PAPER_GAIT
    rec["max_constraint_drift"] = dict(
        position_before_projection_m=float(res.drift_before[0]), velocity_before_projection_mps=float(res.drift_before[1]),
        position_after_projection_m=float(res.drift_after[0]), velocity_after_projection_mps=float(res.drift_after[1]))
    rec["max_impact_energy_change_j"] = _finite(res.impact_energy_gain)
    rec["max_friction_ratio"] = float(res.friction_ratio)
    rec["events"] = int(res.n_events)
    rec["releases"] = int(res.n_releases)
    rec["events_per_step"] = int(res.n_events) / max(n, 1)
    rec["unilateral_check"] = UNILATERAL_CHECK[params]
    tail = lt >= (lt[-1] - 5.0) if nl else np.zeros(0, bool)
    rec["peak_torques_nm"] = dict(zip(sl.JOINT_NAMES, np.abs(lu).max(axis=0).round(3).tolist())) if nl else {}
    rec["body_angle_deg_mean"] = float(np.rad2deg(lx[tail, 2]).mean()) if nl else None
    rec["gait_phases"] = gait_phases(lt, lx, lu, np.asarray(res.log_active[:nl]), np.asarray(res.td_time[:n]),
                                     np.asarray(res.td_foot[:n])) if nl else None
    rec["gains"] = {k: np.asarray(v).round(6).tolist() for k, v in
                    dict(k=gains(params).k, b=gains(params).b, ref_deg=np.rad2deg(np.asarray(gains(params).ref))).items()}
    if setup != "planar":
        rec.update(setup_record(res, rec, without))
    if out:
        rec["files"] = _walk_files(res, out, params)
    return rec


def phase_summary(phases: dict | None) -> dict:
    """The share of steps with a rolling double support and the mean push-off ankle work (J) of
    a walk's :func:`gait_phases` (None without a gait window)."""
    if not phases:
        return dict(rolling_double_support_share=None, push_off_ankle_work_j=None)
    st = phases["steps"]
    return dict(rolling_double_support_share=float(np.mean([s["rolling_double_support"] for s in st])),
                push_off_ankle_work_j=float(np.mean([s["push_off_ankle_work_j"] for s in st])))


#: The rows of :func:`parts_table`: the planar model, each part of the boom setup alone, all.
PARTS_ROWS = (("planar", None), *((f"+ {p.replace('_', ' ')}", p) for p in su.PARTS), ("boom (all)", "all"))


def parts_table(steps: int = 30, params: str = "paper", progress=None) -> list:
    """Table II (or ``params``) walked on the planar model, on it plus one part of the boom
    setup at a time (:data:`bipedlab.robots.seven_link.setup.PARTS`), and on the whole boom
    setup: one dict per row of :data:`PARTS_ROWS` with the steps walked, whether it fell, speed,
    step length, frequency, c_mt, the rolling double support share and the push-off work."""
    progress = progress or (lambda m: None)
    weight = float(sl.total_mass(sl.model())) * sl.GRAVITY
    rows = []
    for label, part in PARTS_ROWS:
        progress(f"seven-link parts table: {label}")
        if part is None:
            res = run_walk(steps, params)
        else:
            without = () if part == "all" else tuple(p for p in su.PARTS if p != part)
            res = run_walk(steps, params, setup="boom", without=without)
        n = int(res.n_touchdowns)
        nl = int(res.n_log_used)
        ph = gait_phases(np.asarray(res.log_t[:nl]), np.asarray(res.log_x[:nl]), np.asarray(res.log_u[:nl]),
                         np.asarray(res.log_active[:nl]), np.asarray(res.td_time[:n]), np.asarray(res.td_foot[:n]))
        m = gait_metrics(res, weight)
        rows.append(dict(row=label, steps=n, fell=walk_fell(res, steps),
                         events_per_step=int(res.n_events) / max(n, 1),
                         **{k: _finite(m[k]) for k in PAPER_GAIT}, **phase_summary(ph)))
    return rows


def setup_record(res, rec: dict, without=()) -> dict:
    """The boom walk's added record: the setup, its parts, the gait beside the paper's, the
    friction coefficient against the peak no-slip ratio, the identified drive friction and the
    setup's numbers (:func:`bipedlab.robots.seven_link.setup.describe`)."""
    on, s = boom_setup(without)
    details = su.describe(s, su.KNEE_LOCK_TORQUE * on["knee_lock"])
    gait = {k: rec[k] for k in PAPER_GAIT}
    return dict(
        setup="boom", setup_parts=on, contact_events_per_step=rec["events_per_step"],
        friction_coefficient=su.FRICTION_COEFFICIENT,
        friction_cone_exceeded=bool(rec["max_friction_ratio"] > su.FRICTION_COEFFICIENT),
        drive_friction_nm=details["drive_coulomb_nm"],
        drive_friction_identification=dict(
            fig6_decay_read_deg_per_cycle=details["fig6_decay_read_deg_per_cycle"],
            swing_stiffness_nm_per_rad=details["fig6_swing_stiffness_nm_per_rad"],
            rule="F_c = (amplitude lost per cycle) k / 4; ankle = hip (same drive)"),
        **phase_summary(rec.get("gait_phases")),
        versus_paper={k: dict(model=gait[k], paper=PAPER_GAIT[k],
                              relative_departure=None if gait[k] is None else gait[k] / PAPER_GAIT[k] - 1.0)
                      for k in PAPER_GAIT},
        setup_details=details)


def _walk_files(res, out, params) -> list:
    from bipedlab.robots.seven_link import plots as vp

    d = Path(out)
    d.mkdir(parents=True, exist_ok=True)
    nl = int(res.n_log_used)
    lt, lx, lu = np.asarray(res.log_t[:nl]), np.asarray(res.log_x[:nl]), np.asarray(res.log_u[:nl])
    states = np.asarray(res.log_ctrl[:nl, :2])
    files = [vp.angles_and_torques(lt, lx, lu, states, d), vp.stick_figure(lt, lx, d)]
    files += vp.animate(d / "walk.html", lt, lx)  # the whole walk, playable offline in a browser
    npz = d / f"walk_seven_link_{params}.npz"
    np.savez(npz, t=lt, x=lx, u=lu, states=states, active=np.asarray(res.log_active[:nl]),
             forces=np.asarray(res.log_force[:nl]), td_time=np.asarray(res.td_time), td_hip_x=np.asarray(res.td_hip_x))
    files.append(str(npz))
    return files


def summary_walk(rec: dict) -> str:
    f = lambda v, fmt: "n/a" if v is None else format(v, fmt)  # noqa: E731
    lines = [f"seven-link walk ({rec['params']} parameters): {rec['steps_completed']}/{rec['steps_requested']} steps, "
             f"{'FELL' if rec['fell'] else 'no fall'} (status {rec['status']}, {rec['sim_time_s']:.1f} s simulated)",
             f"  speed {f(rec['speed_mps'], '.3f')} m/s (paper ~0.5), step {f(rec['step_length_m'], '.3f')} m (~0.5), "
             f"frequency {f(rec['step_frequency_hz'], '.3f')} Hz (~1)",
             f"  c_mt {f(rec['cmt'], '.3f')} (paper robot 0.31; Cornell 0.055, MABEL 0.14, RABBIT 0.38, ASIMO 1.6), "
             f"positive-work c_mt {f(rec['cmt_positive'], '.3f')}",
             "  max constraint drift before/after projection: "
             f"{rec['max_constraint_drift']['position_before_projection_m']:.1e} / "
             f"{rec['max_constraint_drift']['position_after_projection_m']:.1e} m",
             f"  contact/knee-stop events {rec['events_per_step']:.1f} per step, {rec['releases']} releases "
             f"(unilateral check {'on' if rec['unilateral_check'] else 'off'})"]
    if rec.get("setup"):
        fc = rec["drive_friction_nm"]
        off = [k for k, v in rec["setup_parts"].items() if not v]
        lines.append(f"  setup {rec['setup']}{' without ' + ', '.join(off) if off else ''}: drive Coulomb friction "
                     f"hip {fc['hip']:.3f}, knee {fc['knee']:.3f}, ankle {fc['ankle']:.3f} N m (from Fig. 6); "
                     f"friction coefficient {rec['friction_coefficient']:.2f}, peak no-slip ratio "
                     f"{rec['max_friction_ratio']:.2f}")
    if rec.get("files"):
        lines.append("  wrote " + ", ".join(rec["files"]))
    return "\n".join(lines)


# ----------------------------------------------------------------------------- Fig. 6
def _reduced_acc(r: sl.SevenLink, q0, e, s, sd, u=None):
    """Acceleration of the one-degree-of-freedom motion q = q0 + e s (the other coordinates
    held): (e^T (damping - bias + E u)) / (e^T M e); u (6,) joint torques, none by default."""
    q = q0 + e * s
    qd = e * sd
    m = e @ sl.mass_matrix(r, q) @ e
    f = sl.damping_force(r, qd) - sl.bias(r, q, qd)
    if u is not None:
        f = f + sl.actuation(u)
    return e @ f / m


def _swing_loop(dt: float) -> SampledLoop:
    """The free swing as a sampled loop: a zero-torque controller on the one-degree-of-freedom
    plant q = q0 + e s (state [s, s_dot]), one RK4 step of :func:`_reduced_acc` per sample."""
    def flow(p, z, u):
        r, q0, e = p
        return jnp.stack([z[1], _reduced_acc(r, q0, e, z[0], z[1], u)])

    return SampledLoop(plant_step=lambda p, z, u, d, h, t: rk4(lambda z, u: flow(p, z, u), z, u, h),
                       sensor=lambda p, s, z, t: (s, z), controller=lambda p, c, y, t: (c, jnp.zeros(6)),
                       fell=lambda p, z0, y, u, z: jnp.asarray(False), sample_time=dt,
                       log=lambda p, z0, y, u, z, c: z[0])


@functools.partial(jax.jit, static_argnames=("n", "dt"))
def _swing(r: sl.SevenLink, q0, e, s0, n: int, dt: float):
    """RK4 (step dt, n steps) of :func:`_reduced_acc` from rest at s0; returns s (n,)."""
    _, s = loop_run(_swing_loop(dt), (r, q0, e), loop_initial_state(jnp.stack([s0, jnp.zeros_like(s0)])), n)
    return s


def _rk4_1dof(r, q0, e, s0, duration, dt=1e-3):
    n = int(round(duration / dt))
    s = _swing(r, jnp.asarray(q0, jnp.float64), jnp.asarray(e, jnp.float64), jnp.asarray(s0, jnp.float64), n, dt)
    return np.arange(n + 1) * dt, np.concatenate([[s0], np.asarray(s)])


def swing_metrics(t, y) -> dict:
    """Period (mean time between successive same-direction zero crossings of y about its
    final value), logarithmic decrement of successive peaks, and settling time (|y| within 5 %
    of the release amplitude). Overdamped responses report no period."""
    y = np.asarray(y) - y[-1]
    cross = np.flatnonzero(np.sign(y[1:]) != np.sign(y[:-1]))
    tc = t[cross]
    period = float(np.mean(np.diff(tc[::2]))) if len(tc) >= 3 else None
    peaks = []
    for a, b in zip(cross[:-1], cross[1:]):
        peaks.append(np.max(np.abs(y[a:b + 1])))
    dec = float(np.mean(np.log(np.asarray(peaks[:-1]) / np.asarray(peaks[1:])) * 2)) if len(peaks) >= 3 else None
    big = np.flatnonzero(np.abs(y) > 0.05 * abs(y[0]))
    settle = float(t[big[-1]]) if len(big) else 0.0
    return dict(period_s=period, log_decrement_per_cycle=dec, half_cycles=int(len(cross)), settling_time_s=settle,
                amplitude_after_1s_deg=float(np.rad2deg(abs(y[np.searchsorted(t, 1.0)]))))


def free_swing(out: str | None = None, release_deg: float = 45.0, duration: float = 6.0, progress=None) -> dict:
    """Fig. 6: the hip (whole leg, knee on its stop and ankle locked, body fixed upright)
    and the knee (shank and foot, thigh held horizontal, ankle locked) released from rest
    ``release_deg`` away from hanging, unactuated, with the Table I gearing and with 105:1
    hip / 60:1 knee gearing (reflected inertia n^2 J_m and viscous damping scaled by
    (n / n_Table I)^2, see :func:`bipedlab.robots.seven_link.robot.model`)."""
    progress = progress or (lambda m: None)
    a = np.deg2rad(release_deg)
    # hanging posture (absolute angles, body upright): the hip case swings theta_1..theta_3
    # together about a fixed hip; the knee case swings theta_2, theta_3 with the thigh
    # held horizontal and forward (theta_1 = pi, the shank hanging at phi_2 = -90 deg)
    cases = {"hip": (*su.swing_case("hip"), 21.0, 105.0), "knee": (*su.swing_case("knee"), 12.0, 60.0)}
    rec = dict(robot="seven-link", experiment="free-swing", release_deg=release_deg, duration_s=duration, joints={})
    curves = {}
    for joint, (pose, e, n_lo, n_hi) in cases.items():
        curves[joint] = {}
        rec["joints"][joint] = {}
        for label, gear in ((f"{int(n_lo)}:1 (Table I)", "table"), (f"{int(n_hi)}:1", "high")):
            ratios = (21.0, 12.0, 21.0) if gear == "table" else ((105.0, 12.0, 21.0) if joint == "hip" else (21.0, 60.0, 21.0))
            r = sl.model(gear_ratios=ratios)
            q0 = jnp.asarray(pose)
            progress(f"seven-link free swing: {joint} {label}")
            t, s = _rk4_1dof(r, q0, e, a, duration)
            m = swing_metrics(t, s)
            m.update(gear_ratio=ratios[0 if joint == "hip" else 1],
                     reflected_inertia_kgm2=float(r.coupled.rotor_inertia[0 if joint == "hip" else 1]),
                     damping_nms=float(r.damping[0 if joint == "hip" else 1]))
            rec["joints"][joint][label] = m
            curves[joint][label] = (t, np.rad2deg(s))
    if out:
        from bipedlab.robots.seven_link import plots as vp

        Path(out).mkdir(parents=True, exist_ok=True)
        rec["files"] = [vp.free_swing(curves, out)]
        npz = Path(out) / "free_swing.npz"
        np.savez(npz, **{f"{j}_{k.split()[0].replace(':', '_')}": np.stack(v) for j, c in curves.items()
                         for k, v in c.items()})
        rec["files"].append(str(npz))
    return rec


# ----------------------------------------------------------------------------- Fig. 7
PD_K = (2.0, 1.5, 1.0)
PD_B = (0.2, 0.2, 0.1)


def pd_reference(t):
    """phi_d(t) of Fig. 7 (rad): hip, knee, ankle."""
    t = jnp.asarray(t)
    return jnp.stack([jnp.pi / 3 * jnp.sin(1.5 * jnp.pi * t) + jnp.pi / 20,
                      jnp.pi / 6 * jnp.sin(3 * jnp.pi * t - jnp.pi / 2) - jnp.pi / 2,
                      jnp.pi / 6 * jnp.sin(6 * jnp.pi * t) + jnp.pi / 6], axis=-1)


PD_FREQ_HZ = (0.75, 1.5, 3.0)


_PD_FREE = (3, 4, 5)


def _pd_fixed_pose(r: sl.SevenLink):
    return sl.configuration(np.pi / 2, np.deg2rad([9.0, -90.0, 30.0, 0.0, 0.0, 0.0]), r=r)


def _pd_torque(t, q, qd):
    """u = -K (phi - phi_d(t)) - B phi_dot on leg 1's joints (3,)."""
    phi = sl.joint_angles(q)[:3]
    phid = sl.joint_rates(qd)[:3]
    return -jnp.asarray(PD_K) * (phi - pd_reference(t)) - jnp.asarray(PD_B) * phid


def _pd_coordinates(q_fix, z):
    free = jnp.asarray(_PD_FREE)
    return q_fix.at[free].set(z[:3]), jnp.zeros(9).at[free].set(z[3:])


def _pd_flow(p, x, u):
    """[z_dot, 1] of the hanging leg (z = [theta_1..3, rates], x = [z, t]) under the PD servo,
    evaluated at every RK4 stage (a continuous servo), plus the held joint torques u (3,)."""
    r, q_fix = p
    z, t = x[:6], x[6]
    free = jnp.asarray(_PD_FREE)
    q, qd = _pd_coordinates(q_fix, z)
    tau = _pd_torque(t, q, qd) + u
    f = jnp.asarray(sl.E)[:, :3] @ tau + sl.damping_force(r, qd) - sl.bias(r, q, qd)
    M = sl.mass_matrix(r, q)
    return jnp.concatenate([z[3:], jnp.linalg.solve(M[free][:, free], f[free]), jnp.ones(1)])


def _pd_loop(dt: float) -> SampledLoop:
    """Fig. 7 as a sampled loop: plant state (z (6,), sample index); the PD acts inside the
    flow, the sampled controller adds no torque (u = 0) and the log records (z after the
    sample, the PD torque at the sample's start)."""
    def plant_step(p, xs, u, d, h, t):
        z, k = xs
        x1 = rk4(lambda x, u: _pd_flow(p, x, u), jnp.concatenate([z, (k * h)[None]]), u, h)
        return x1[:6], k + 1

    def sensor(p, s, xs, t):
        z, k = xs
        return s, (z, k * dt)

    def log(p, xs0, y, u, xs, c):
        q, qd = _pd_coordinates(p[1], y[0])
        return xs[0], _pd_torque(y[1], q, qd) + u

    return SampledLoop(plant_step=plant_step, sensor=sensor, controller=lambda p, c, y, t: (c, jnp.zeros(3)),
                       fell=lambda p, x0, y, u, x: jnp.asarray(False), sample_time=dt, log=log)


def _pd_sim(duration: float, dt: float = 5e-4):
    """Leg 1 hanging from the fixed, upright body (x, y, theta and leg 2 held), three free
    absolute angles theta_1..theta_3, u = -K (phi - phi_d) - B phi_dot on leg 1's joints."""
    r = sl.model()
    free = jnp.asarray(_PD_FREE)
    q_fix = _pd_fixed_pose(r)
    # start on the reference at t = 0 (at rest)
    phi0 = np.asarray(pd_reference(0.0))
    q0 = sl.configuration(np.pi / 2, np.concatenate([phi0, [0.0, 0.0, 0.0]]), r=r)
    z0 = jnp.concatenate([q0[free], jnp.zeros(3)])
    n = int(round(duration / dt))
    ts = np.arange(n) * dt
    loop = _pd_loop(dt)
    _, (zs, us) = jax.jit(lambda p, z0: loop_run(loop, p, loop_initial_state((z0, jnp.asarray(0))), n))((r, q_fix), z0)
    t = ts + dt
    th = np.asarray(zs[:, :3])
    phi = np.stack([th[:, 0] - np.pi / 2, th[:, 1] - th[:, 0], th[:, 2] - th[:, 1] + np.pi / 2], axis=1)
    return t, phi, np.asarray(pd_reference(t)), np.asarray(us)


def _fit_harmonic(t, y, f):
    """Amplitude and phase (rad) of y's component at frequency f (least squares with offset)."""
    w = 2 * np.pi * f
    X = np.stack([np.sin(w * t), np.cos(w * t), np.ones_like(t)], axis=1)
    c, *_ = np.linalg.lstsq(X, y, rcond=None)
    return float(np.hypot(c[0], c[1])), float(np.arctan2(c[1], c[0])), float(c[2])


def low_gain_pd(out: str | None = None, duration: float = 8.0, progress=None) -> dict:
    """Fig. 7: tracking of the low-gain PD experiment after the first ``duration / 2`` s:
    RMS and peak error, and per joint the response's amplitude and phase at the reference's
    frequency against the reference's."""
    progress = progress or (lambda m: None)
    progress("seven-link low-gain PD experiment")
    t, phi, ref, u = _pd_sim(duration)
    w = t >= duration / 2
    rec = dict(robot="seven-link", experiment="low-gain-pd", duration_s=duration, gains=dict(K=PD_K, B=PD_B),
               analysis_window_s=[duration / 2, duration], joints={})
    for k, nm in enumerate(("hip", "knee", "ankle")):
        a_r, p_r, o_r = _fit_harmonic(t[w], ref[w, k], PD_FREQ_HZ[k])
        a_y, p_y, o_y = _fit_harmonic(t[w], phi[w, k], PD_FREQ_HZ[k])
        err = phi[w, k] - ref[w, k]
        rec["joints"][nm] = dict(
            frequency_hz=PD_FREQ_HZ[k], reference_amplitude_deg=float(np.rad2deg(a_r)),
            response_amplitude_deg=float(np.rad2deg(a_y)), amplitude_ratio=a_y / a_r,
            phase_lag_deg=float(np.rad2deg((p_r - p_y + np.pi) % (2 * np.pi) - np.pi)),
            reference_mean_deg=float(np.rad2deg(o_r)), response_mean_deg=float(np.rad2deg(o_y)),
            rms_error_deg=float(np.rad2deg(np.sqrt(np.mean(err**2)))), max_error_deg=float(np.rad2deg(np.abs(err).max())),
            peak_torque_nm=float(np.abs(u[w, k]).max()))
    rec["knee_stop_reached"] = bool(np.max(phi[:, 1]) > 0.0)
    if out:
        from bipedlab.robots.seven_link import plots as vp

        Path(out).mkdir(parents=True, exist_ok=True)
        rec["files"] = [vp.pd_experiment(t, phi, ref, out)]
        npz = Path(out) / "low_gain_pd.npz"
        np.savez(npz, t=t, phi=phi, phi_d=ref, u=u)
        rec["files"].append(str(npz))
    return rec


def summary_experiment(rec: dict) -> str:
    lines = [f"seven-link experiment {rec['experiment']}"]
    if rec["experiment"] == "free-swing":
        for j, cases in rec["joints"].items():
            for label, m in cases.items():
                per = "overdamped" if m["period_s"] is None else f"period {m['period_s']:.3f} s"
                dec = "" if m["log_decrement_per_cycle"] is None else f", log decrement {m['log_decrement_per_cycle']:.2f}/cycle"
                lines.append(f"  {j} {label}: {per}{dec}, {m['half_cycles']} half-cycles, settles (5 %) in "
                             f"{m['settling_time_s']:.2f} s")
    else:
        for j, m in rec["joints"].items():
            lines.append(f"  {j}: amplitude {m['response_amplitude_deg']:.1f} of {m['reference_amplitude_deg']:.1f} deg "
                         f"(ratio {m['amplitude_ratio']:.2f}), lag {m['phase_lag_deg']:.1f} deg, "
                         f"RMS error {m['rms_error_deg']:.1f} deg")
    if rec.get("files"):
        lines.append("  wrote " + ", ".join(rec["files"]))
    return "\n".join(lines)
