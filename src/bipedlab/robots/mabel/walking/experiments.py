"""The experiments of the compliant-HZD paper (Sections V-VI) as simulation studies.

The experiments that compare with the robot's walks (Exps. 1, 2, 4, 5, tracking, Table I) walk
:data:`GAIT` (``paper-575``, the paper's design model at the paper's 0.575 m step); each record
names its gait.

- ``nominal`` (Exp. 1): the nominal gait under PD + feedforward, 1 kHz, 14-bit encoders.
- ``push`` (Exp. 2): the forward and backward forces on the hip, over the second half of a step,
  that change the speed by +45 % and -45 % as the paper's pushes did on the robot, found by a
  bracketing search under PD + feedforward, and the recovery under PD + feedforward and the
  decentralised HZD controller at those forces; beside them the paper's estimated forces
  (78 N / -71 N) under PD + FF and smaller pushes under the HZD controller.
- ``efficient`` (Exp. 3): the c_mt-optimal gait; realised versus designed c_mt and the power at
  the stance leg shape (motor and spring).
- ``tracking`` (Exps. 4-5): the nominal gait under PD + feedforward, I/O linearisation with
  corrections, and its decentralised form; tracking errors and torques.
- ``impact-scaling`` (Section VI-B, Table I): steady-state speed for eta = 1.0 ... 0.96.
- ``fast`` (Exp. 5): the nominal constraints with the torso leaned forward step by step (the
  experimenters' procedure) under the compliant-HZD controller, encoders read through the
  model-based velocity observer, 100 steps after the lean.
- ``full-plant`` (Sections V-A, V-C, VI-C): the design-to-robot gap, the gaits under PD +
  feedforward on the 13-DoF plant (cable stretch, compliant ground), realised against designed
  c_mt, and Fig. 20.
- ``sweep``: gaits designed from 0.6 to 1.6 m/s by continuation, with their restricted-map
  eigenvalues computed in one batched (vmapped) call.
- ``pd-gains`` (Section IV-A): the dominant eigenvalue of the full-order Poincaré map (eq. 44)
  under PD + feedforward (eq. 43) of the nominal and the efficient gait, over a grid of common
  factors on the shipped kp and kd; the gains nearest the paper's 0.6921 / 0.8194.
- ``exp4`` (Exp. 4): the nominal gait under the compliant-HZD controller (I/O linearisation with
  corrections), 14-bit encoders at 1 kHz, with the experiment's torque saturation (6 N m leg
  angle, 10 N m leg shape), and the same run at the drivetrain's limits.

``push`` and ``impact-scaling`` also walk :data:`FACTOR_GAITS` beside :data:`GAIT` (the force
searches; the slope dv/deta): the gait as a measured factor of those departures.
"""
from __future__ import annotations

import time

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.robots.mabel import tables as tb
from bipedlab.robots.mabel.walking import catalog
from bipedlab.robots.mabel.walking import controllers as ctl
from bipedlab.robots.mabel.walking import constraints as vcm
from bipedlab.robots.mabel.walking import design as md
from bipedlab.robots.mabel.walking import loop as sw
from bipedlab.robots.mabel.walking.loop import MU as MU_TOE
from bipedlab.robots.mabel.walking import poincare as mp
from bipedlab.robots.mabel.walking import stance as wk
from bipedlab.robots.mabel.walking import study as wm

NAMES = catalog.EXPERIMENTS
#: the gait of Exps. 1, 2, 4, 5, the tracking comparison and Table I (catalog.EXPERIMENT_GAIT)
GAIT = catalog.EXPERIMENT_GAIT
ETAS = (1.0, 0.99, 0.98, 0.97, 0.966, 0.96)
PUSHES = (78.0, -71.0)
#: pushes the decentralised HZD controller survives in this model (N, + forward)
HZD_PUSHES = (30.0, -40.0)
#: the gaits walked beside GAIT as a factor of Exp. 2's forces and Table I's slope: the paper
#: design model's torque optimum (0.457 m steps) and the full design model's (0.656 m); GAIT
#: takes the paper's 0.575 m step between them
FACTOR_GAITS = ("paper-nominal", "nominal")
PUSH_STEP = catalog.PUSH_STEP
SWEEP_SPEEDS = (0.6, 0.7, 0.8, 0.9, 1.0, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6)


def _walk(gait, controller, steps, progress, **kw):
    return wm.walk(gait, controller, steps, progress=progress, **kw)


def mean_speed(r, first: int) -> float:
    """A walk's mean step speed from step ``first`` on (the unpushed reference of a push)."""
    return float(np.mean(r["speed_per_step"][first:]))


def _steady_speed(r, average: int):
    """A walk's steady speed, the mean of its last ``average`` steps; None after a fall or with
    fewer steps."""
    sp = r["speed_per_step"]
    return float(np.mean(sp[-average:])) if not r["fell"] and len(sp) >= average else None


def _recovery(speeds, push_step, reference, tol=0.02):
    """(peak relative change after the push, steps until within tol of reference)."""
    after = np.asarray(speeds[push_step:])
    if after.size == 0:
        return None, None
    rel = after / reference - 1.0
    k = int(np.argmax(np.abs(rel)))
    inside = np.nonzero(np.abs(rel[k:]) <= tol)[0]
    return float(rel[k]), (int(inside[0]) + k if inside.size else None)


#: the speed changes the paper's pushes caused on the robot (Exp. 2)
TARGET_CHANGES = (0.45, -0.45)
#: the search stops when the peak speed change is within this of its target (fraction of the
#: unpushed speed): finer than the paper's two-digit "45 %"
SEARCH_TOL = 0.01
#: walks allowed per search (the push force enters the compiled loop as data, so each walk
#: reuses the compiled program)
SEARCH_WALKS = 10
#: steps after the pushed one that a search walk covers (the peak change comes within two)
SEARCH_AFTER = 3
#: recovery: steps after the pushed one until the step speed is back within 5 % of unpushed
RECOVERY_TOL = 0.05
#: a push's reference: the unpushed walk's mean step speed from this step on
REFERENCE_FROM = 5


def steps_to_settle(speeds, push_step, reference, tol=RECOVERY_TOL):
    """Steps after the pushed one until the step speed stays within ``tol`` (fraction) of
    ``reference`` for the rest of the walk; None if the last step is still outside."""
    rel = np.abs(np.asarray(speeds[push_step:], float) / reference - 1.0)
    if rel.size == 0 or rel[-1] > tol:
        return None
    outside = np.nonzero(rel > tol)[0]
    return int(outside[-1]) + 1 if outside.size else 0


def peak_change(speeds, push_step, reference, direction):
    """The largest relative speed change in the push's direction (+1 forward, -1 backward) over
    the steps from the pushed one on; None before any of them completed."""
    after = np.asarray(speeds[push_step:], float)
    if after.size == 0:
        return None
    rel = after / reference - 1.0
    return float(rel[np.argmax(direction * rel)])


def bracket_force(change_of, target, f0, tol=SEARCH_TOL, max_walks=SEARCH_WALKS, grow=3.0):
    """The force whose peak speed change is within ``tol`` of ``target``, by a bracketing search
    on change(force), with change(0) = 0 (no push).

    ``change_of(force)`` walks once and returns the peak change, or None when the walk fell
    before a step after the push completed (counted as beyond the target). Starting from f0
    (same sign as the target), the secant through the origin extrapolates (by at most ``grow``
    times) until the target is bracketed; then regula falsi with the Illinois modification,
    bisection across a None. Returns (force, change, walks [(force, change)], converged)."""
    walks = []
    lo, g_lo = 0.0, -target  # g = change - target; no push: no change
    hi, g_hi = None, None
    f = f0
    side = 0
    for _ in range(max_walks):
        c = change_of(f)
        walks.append((float(f), c))
        if c is not None and abs(c - target) <= tol:
            return float(f), c, walks, True
        g = None if c is None else c - target
        beyond = g is None or np.sign(g) == np.sign(target)
        if beyond:
            hi, g_hi = f, g
            if side == +1 and g_lo is not None:
                g_lo = 0.5 * g_lo
            side = +1
        else:
            lo, g_lo = f, g
            if side == -1 and g_hi is not None:
                g_hi = 0.5 * g_hi
            side = -1
        if hi is None:  # not yet bracketed: secant through the origin, capped
            f = lo * min(grow, max(1.1, target / c)) if c else lo * grow
        elif g_hi is None:
            f = 0.5 * (lo + hi)
        else:
            f = lo - g_lo * (hi - lo) / (g_hi - g_lo)
    best = min((w for w in walks if w[1] is not None), key=lambda w: abs(w[1] - target), default=(float(f0), None))
    return best[0], best[1], walks, False


def nominal(steps, progress, out, plant_scale=None):
    r = _walk(GAIT, "pdff", steps or 100, progress, out=out, plant_scale=plant_scale)
    r["paper"] = dict(designed_speed_mps=0.8, experimental_speed_mps=1.0, steps=78)
    return r


def _push_row(r, controller, force, push_step, ref, direction):
    """One pushed walk's record: the peak change in the push's direction (over the steps
    completed), the recovery ``steps_to_recover_5pct`` (:func:`steps_to_settle` within
    RECOVERY_TOL; None after a fall) and the toe's contact record (friction cone, pulling)."""
    sp = r["speed_per_step"]
    peak = peak_change(sp, push_step, ref, direction)
    back = steps_to_settle(sp, push_step, ref)
    return dict(controller=controller, force_n=float(force), step=push_step, fell=r["fell"],
                steps_completed=r["steps_completed"], unpushed_speed_mps=ref, speed_per_step=sp,
                speed_change=peak, steps_to_recover_5pct=None if r["fell"] else back, **_contact(r),
                friction_cone_exceeded_step=r["friction_cone_exceeded_step"], toe_pulled_step=r["toe_pulled_step"])


def push_at(gait, controller, force, ref, steps, push_step=PUSH_STEP, progress=None, plant="stance", plant_scale=None,
            direction=None) -> dict:
    """One walk of ``steps`` pushed with ``force`` (N) over the second half of ``push_step``:
    its push record (the peak change in ``direction``, default the force's sign, against the
    unpushed speed ``ref``; the recovery within RECOVERY_TOL; the toe's contact record) with
    ``steps_to_recover``, the steps until first back within 2 % (None after a fall)."""
    direction = np.sign(force) if direction is None else direction
    r = _walk(gait, controller, steps, progress, push=(force, push_step), plant=plant, plant_scale=plant_scale)
    row = _push_row(r, controller, force, push_step, ref, direction)
    row["steps_to_recover"] = None if r["fell"] else _recovery(r["speed_per_step"], push_step, ref)[1]
    return row


def search_push(controller, target, f0, ref, steps, push_step=PUSH_STEP, progress=None, tol=SEARCH_TOL,
                max_walks=SEARCH_WALKS, plant="stance", gait=GAIT, plant_scale=None):
    """The force (N, + forward) over the second half of step ``push_step`` whose peak speed
    change is ``target`` (fraction of ``ref``) under ``controller`` on ``plant``, by
    :func:`bracket_force` on walks of the pushed step and SEARCH_AFTER more (a walk that falls
    counts as beyond the target unless the steps it completed already reached it); then one
    walk of ``steps`` at that force for the recovery (``steps_to_recover_5pct``, and
    ``steps_to_recover``: first back within 2 %, as the rows at the paper's forces). Returns the
    search record. ``gait``: the gait walked (default :data:`GAIT`); ``plant_scale``: the plant's
    values (:func:`~bipedlab.robots.mabel.walking.study.run_walk`)."""
    direction = np.sign(target)
    seen = {}

    def change_of(force):
        r = _walk(gait, controller, push_step + 1 + SEARCH_AFTER, None, push=(force, push_step), plant=plant,
                  plant_scale=plant_scale)
        c = peak_change(r["speed_per_step"], push_step, ref, direction)
        seen[float(force)] = (c, r["fell"], r["steps_completed"])
        # a walk that falls short of the target before its fall tells nothing of the change the
        # push would have made: beyond the target (the steps a fall cuts short mislead)
        return None if r["fell"] and (c is None or abs(c - target) > tol) else c

    force, change, walks, ok = bracket_force(change_of, target, f0, tol, max_walks)
    row = push_at(gait, controller, force, ref, steps, push_step, progress, plant, plant_scale, direction)
    return dict(target_change=target, converged=ok, tolerance=tol, walks=[
        dict(force_n=f, speed_change=seen[f][0], fell=seen[f][1], steps_completed=seen[f][2]) for f, _ in walks],
        **row)


def push(steps, progress, out, push_step=PUSH_STEP, controllers=("pdff", "decentralized"), search=True,
         reference_from=REFERENCE_FROM, full_plant=True, gait_factor=FACTOR_GAITS, plant_scale=None):
    """Exp. 2. The forces that change the speed by TARGET_CHANGES (+45 % / -45 %, as the paper's
    pushes did on the robot) over the second half of step PUSH_STEP, searched from the paper's
    estimates under PD + feedforward, the experiment's controller (``force_for_plus_45pct_n``,
    ``force_for_minus_45pct_n``), and from HZD_PUSHES under the decentralised HZD controller;
    each search's record has the change reached, the recovery over ``steps`` and the toe's
    contact record; ``at_pdff_forces`` walks the HZD controller at PD + FF's forces. Then the
    paper's estimated forces (PUSHES) under PD + FF, and HZD_PUSHES under the HZD controller.
    The reference is each controller's unpushed speed (mean over steps 5 on).

    The stance model pins the toe: a push can ask the ground for more friction than MU times
    the normal force, or pull on it, which the record reports (``friction_cone_exceeded``,
    ``max_friction_ratio``, ``toe_pulled``) but does not count as a fall; a fall is the hip or
    torso leaving the walking range, or the robot rolling back over its stance toe
    (:func:`~bipedlab.robots.mabel.walking.loop.fell`). Making the foot slip is outside this
    model. A run that falls keeps the speed change of the steps it completed.

    With ``search`` and ``full_plant``, the same two searches under PD + feedforward on the
    13-DoF plant (:mod:`.full_plant`: cable stretch, the compliant ground on which the toe can
    slip or lift), the robot's analog (``full_plant``: its unpushed speed, the forces, each
    search's record).

    Reductions: ``push_step``, the pushed step; ``controllers``, a subset of PD + FF and the
    decentralised controller; ``search`` False leaves out the force searches (the record then
    has no ``force_for_*`` keys); ``reference_from``, the first step of the unpushed speed's
    mean; ``full_plant`` False leaves out the 13-DoF searches. The searches need both
    controllers.

    With ``search``, the PD + feedforward searches again on each of ``gait_factor`` (default
    :data:`FACTOR_GAITS`; record ``gait_factor``, :func:`push_on_gait`): the gait as a factor of
    the forces and the recovery. ``plant_scale``: the stance and 13-DoF plants' values
    (:func:`~bipedlab.robots.mabel.walking.study.run_walk`; the factor gaits' searches keep the
    published ones)."""
    if search and set(controllers) != {"pdff", "decentralized"}:
        raise ValueError("push: the force searches walk both PD + feedforward and the decentralised controller")
    steps = steps or 30
    refs = {}
    for controller in controllers:
        base = _walk(GAIT, controller, steps, progress, plant_scale=plant_scale)
        refs[controller] = mean_speed(base, reference_from)
    paper = dict(controller="pdff", forward=dict(force_n=78, speed_change=0.45, steps_to_recover=10),
                 backward=dict(force_n=-71, speed_change=-0.45, steps_to_recover=3))
    runs = []
    for controller, pushes in (("pdff", PUSHES), ("decentralized", HZD_PUSHES)):
        if controller not in refs:
            continue
        ref = refs[controller]
        for force in pushes:
            r = _walk(GAIT, controller, steps, progress, push=(force, push_step),
                      out=f"{out}/{controller}_{force:+.0f}N" if out else None, plant_scale=plant_scale)
            row = _push_row(r, controller, force, push_step, ref, np.sign(force))
            peak, back = _recovery(r["speed_per_step"], push_step, ref)
            # and as before: the largest change either way, the steps until first back within 2 %
            row.update(peak_speed_change=peak, steps_to_recover=back)
            runs.append(row)
    rec = dict(experiment="push", gait=GAIT, push_step=push_step, recovery_tolerance=RECOVERY_TOL, unpushed_speed_mps=refs,
               runs=runs, paper=paper)
    if not search:
        return rec
    say = progress or (lambda msg: None)
    searches = []
    for controller, starts in (("pdff", PUSHES), ("decentralized", HZD_PUSHES)):
        for target, f0 in zip(TARGET_CHANGES, starts):
            say(f"push: searching the force for {100 * target:+.0f} % under {controller}")
            searches.append(search_push(controller, target, f0, refs[controller], steps, push_step, progress,
                                        plant_scale=plant_scale))
    plus, minus = searches[:2]
    at_pdff = []
    for x in (plus, minus):
        r = _walk(GAIT, "decentralized", steps, progress, push=(x["force_n"], push_step), plant_scale=plant_scale)
        at_pdff.append(dict(_push_row(r, "decentralized", x["force_n"], push_step, refs["decentralized"],
                                      np.sign(x["target_change"])), target_change=x["target_change"]))
    rec.update(force_for_plus_45pct_n=plus["force_n"], force_for_minus_45pct_n=minus["force_n"],
               speed_change_at_plus_force=plus["speed_change"], speed_change_at_minus_force=minus["speed_change"],
               searches=searches, at_pdff_forces=at_pdff)
    if full_plant:
        rec["full_plant"] = push_full_plant(steps, push_step, reference_from, progress, plant_scale=plant_scale)
    rec["gait_factor"] = [push_on_gait(g, steps, push_step, reference_from, progress) for g in gait_factor]
    return rec


def push_on_gait(gait, steps, push_step=PUSH_STEP, reference_from=REFERENCE_FROM, progress=None) -> dict:
    """Exp. 2's two PD + feedforward force searches (stance model, encoders) on ``gait``: its
    unpushed speed and mean step (steps ``reference_from`` on), the forces for +45 % and -45 %,
    the changes reached and the steps until back within 2 % (``steps_to_recover``) and within
    RECOVERY_TOL for good (``steps_to_recover_5pct``)."""
    say = progress or (lambda msg: None)
    base = _walk(gait, "pdff", steps, progress)
    ref = mean_speed(base, reference_from)
    out = dict(gait=gait, unpushed_speed_mps=ref, step_length_m=float(np.mean(base["step_lengths_m"][reference_from:])))
    for target, f0, sign in zip(TARGET_CHANGES, PUSHES, ("plus", "minus")):
        say(f"push: searching the force for {100 * target:+.0f} % under pdff on {gait}")
        x = search_push("pdff", target, f0, ref, steps, push_step, progress, gait=gait)
        out.update({f"force_for_{sign}_45pct_n": x["force_n"], f"speed_change_at_{sign}_force": x["speed_change"],
                    f"steps_to_recover_{sign}": x["steps_to_recover"],
                    f"steps_to_recover_5pct_{sign}": x["steps_to_recover_5pct"], f"converged_{sign}": x["converged"]})
    return out


def push_full_plant(steps, push_step=PUSH_STEP, reference_from=REFERENCE_FROM, progress=None, plant_scale=None) -> dict:
    """Exp. 2 on the 13-DoF plant under PD + feedforward: the unpushed speed (mean over steps
    ``reference_from`` on of a ``steps`` walk), and the forces that change it by TARGET_CHANGES,
    searched from the paper's forces PUSHES (its estimates for its own model), each with its
    recovery. ``plant_scale``: the plant's values (:func:`~bipedlab.robots.mabel.walking.study.run_walk`)."""
    base = _walk(GAIT, "pdff", steps, progress, plant="full", plant_scale=plant_scale)
    ref = mean_speed(base, reference_from)
    say = progress or (lambda msg: None)
    searches = []
    for target, f0 in zip(TARGET_CHANGES, PUSHES):
        say(f"push: searching the force for {100 * target:+.0f} % under pdff on the 13-DoF plant")
        searches.append(search_push("pdff", target, f0, ref, steps, push_step, progress, plant="full",
                                    plant_scale=plant_scale))
    plus, minus = searches
    return dict(controller="pdff", unpushed_speed_mps=ref, unpushed_fell=base["fell"],
                force_for_plus_45pct_n=plus["force_n"], force_for_minus_45pct_n=minus["force_n"], searches=searches)


#: Exp. 3's gait: the c_mt gait of the paper's design model with catalog.EFFICIENT_CLEARANCE of
#: swing-toe clearance at mid-step (paper-efficient-clear). Without it (paper-efficient, the
#: design rows' gait) the swing toe grazes the ground at mid-step and every controller falls on
#: the 13-DoF plant; the full-model ``efficient`` gait clears the ground by at most 1.9 cm, and
#: under every controller its swing toe strikes the ground behind the stance toe in the first
#: step (catalog.GAIT_FALLS)
EXP3_GAIT, EXP3_NOMINAL = "paper-efficient-clear", "paper-nominal"


def efficient(steps, progress, out, plant_scale=None):
    r = _walk(EXP3_GAIT, "pdff", steps or 100, progress, out=out, plant_scale=plant_scale)
    _, _, rec = wm.load_gait(EXP3_GAIT)
    _, _, nom = wm.load_gait(EXP3_NOMINAL)
    r.update(experiment="efficient", designed_cmt=rec["design"]["cmt"], nominal_designed_cmt=nom["design"]["cmt"],
             negative_work_fraction_spring=rec["design"]["negative_work_fraction_spring"],
             paper=dict(designed_cmt=0.0385, nominal_designed_cmt=0.0452, realised_cmt=0.14))
    if out:
        from bipedlab.robots.mabel.walking import plots as wp

        m = md.design_model(kind=rec.get("design_model", "full"))
        r.setdefault("figures", []).extend(wp.gait_figures(out, m, wm.design_from_record(rec), prefix="efficient_"))
    return r


def _tracking_row(r) -> dict:
    return dict(fell=r["fell"], steps_completed=r["steps_completed"], fell_in_step=r["steps_completed"] + 1
                if r["fell"] else None, speed_mps=r["speed_mps"], tracking_rms_deg=r["tracking_rms_deg"],
                tracking_peak_deg=r["tracking_peak_deg"], peak_torques_nm=r["peak_torques_nm"], cmt=r["cmt"])


def tracking(steps, progress, out, controllers=("pdff", "iolin", "decentralized"), causes=True, plant_scale=None):
    """Exps. 1, 4-5 tracking: the nominal gait (:data:`GAIT`) under each controller on the stance model with
    14-bit encoders at 1 kHz (the rows). ``causes``: the same walks with exact encoders
    (``ideal_sensing``: no quantisation, exact rates) and on the 13-DoF plant (``full_plant``:
    cable stretch, free swing spring, compliant ground; encoders), which separate what the
    sensing and what the model mismatch do to each controller's tracking."""
    rows = {}
    n = steps or 30
    for c in controllers:
        r = _walk(GAIT, c, n, progress, out=(f"{out}/{c}" if out else None), plant_scale=plant_scale)
        rows[c] = _tracking_row(r)
        if causes:
            rows[c]["ideal_sensing"] = _tracking_row(_walk(GAIT, c, n, progress, sensing="ideal"))
            rows[c]["full_plant"] = _tracking_row(_walk(GAIT, c, n, progress, plant="full"))
    return dict(experiment="tracking", gait=GAIT, controllers=rows,
                paper=dict(torso_rms_deg=dict(pdff=1.44, iolin=0.89), mLS_st_rms_deg=dict(pdff=29.82, iolin=0.28),
                           torso_peak_deg=dict(pdff=3.1, iolin=2.4), mLS_st_peak_deg=dict(pdff=59.1, iolin=39.5)))


def speed_sensitivity(etas, speeds):
    """dv/deta (m/s per unit eta): the slope of the least-squares line v = a + b eta through the
    (eta, speed) pairs whose speed is not None (a fallen run has none); None with fewer than two
    such pairs or a single eta."""
    pts = [(float(e), float(v)) for e, v in zip(etas, speeds) if v is not None]
    if len(pts) < 2:
        return None
    e, v = np.asarray(pts).T
    de = e - e.mean()
    if not np.any(de):
        return None
    return float(np.sum(de * (v - v.mean())) / np.sum(de**2))


def paper_speed_sensitivity() -> float:
    """dv/deta of the paper's Table I (the same least-squares line through its six rows)."""
    table = wm.PAPER["impact_scaling"]
    return speed_sensitivity(list(table), list(table.values()))


def impact_scaling(steps, progress, out, etas=ETAS, average=catalog.STEADY_STEPS, pdff_column=True,
                   gait_factor=FACTOR_GAITS, plant_scale=None):
    """Table I is a simulation of the nominal fixed point (:data:`GAIT`): here under the compliant-HZD
    controller with exact sensing (the model's own closed loop), and beside it (``pdff_column``)
    PD + feedforward with encoders (the experiment's controller). The steady speed is the mean
    over the last ``average`` steps. ``dv_deta``: the speed's sensitivity to eta (m/s per unit
    eta, :func:`speed_sensitivity` through the etas run), beside the paper's
    (``dv_deta_paper``, the same fit through Table I's six rows). ``gait_factor``: gaits on which
    the compliant-HZD column is walked again (default :data:`FACTOR_GAITS`; record
    ``gait_factor``: per gait its steady speeds and dv_deta), the gait as a factor of the slope."""
    steps = steps or 40
    columns = (("", "iolin", "ideal"), ("pdff_", "pdff", "encoders"))[: 2 if pdff_column else 1]
    rows = []
    for eta in etas:
        row = dict(eta=eta, paper_speed_mps=wm.PAPER["impact_scaling"][eta])
        for key, c, sensing in columns:
            r = _walk(GAIT, c, steps, progress, eta=eta, sensing=sensing, plant_scale=plant_scale)
            row.update({f"{key}fell": r["fell"], f"{key}steps_completed": r["steps_completed"],
                        f"{key}steady_speed_mps": _steady_speed(r, average)})
        rows.append(row)
    ok = [x["steady_speed_mps"] for x in rows if x["steady_speed_mps"] is not None]
    e = [x["eta"] for x in rows]
    rec = dict(experiment="impact-scaling", gait=GAIT, controller="iolin", sensing="ideal", rows=rows,
               speed_rises_as_eta_falls=bool(len(ok) == len(rows) and all(np.diff(ok) > 0)),
               dv_deta=speed_sensitivity(e, [x["steady_speed_mps"] for x in rows]),
               dv_deta_paper=paper_speed_sensitivity(),
               dv_deta_paper_same_etas=speed_sensitivity(e, [x["paper_speed_mps"] for x in rows]))
    if pdff_column:
        rec["pdff_dv_deta"] = speed_sensitivity(e, [x["pdff_steady_speed_mps"] for x in rows])
    factor = []
    for gait in gait_factor:
        speeds = [_steady_speed(_walk(gait, "iolin", steps, progress, eta=eta, sensing="ideal"), average)
                  for eta in etas]
        factor.append(dict(gait=gait, steady_speed_mps=speeds, dv_deta=speed_sensitivity(e, speeds)))
    rec["gait_factor"] = factor
    return rec


# ----------------------------------------------------------------------------- pd-gains
#: common factors on the shipped PD gains (every output's kp; every output's kd) of pd-gains
PD_SCALES = (0.5, 0.75, 1.0, 1.5, 2.0)
#: the gaits of pd-gains: the designs of the paper's design model whose eigenvalues the design
#: rows compare with Sec. IV-A's
PD_GAITS = ("paper-nominal", "paper-efficient")
#: the paper's dominant eigenvalue of the full map under PD + feedforward (Sec. IV-A)
PD_PAPER = {"paper-nominal": wm.PAPER["eig_pdff_nominal"], "paper-efficient": wm.PAPER["eig_pdff_efficient"]}
#: a fixed point counts as found when |P(z) - z| is below this (Newton with the
#: central-difference Jacobian of :func:`~bipedlab.robots.mabel.walking.poincare.pd_fixed_points`)
PD_RESIDUAL = 1e-6


def _eig(ev) -> dict:
    e = complex(ev)
    return dict(re=e.real, im=e.imag, complex=[e.real, e.imag], abs=abs(e))


def _eig_distance(e: dict, paper: float) -> float:
    """Distance in the complex plane from an eigenvalue record to the paper's dominant eigenvalue,
    which is real and positive (Sec. IV-A): a negative eigenvalue of the same magnitude (a
    deviation alternating step to step) is far from it."""
    return abs(complex(e["re"], e["im"]) - paper)


def pd_gains(steps, progress, out, kp_scales=PD_SCALES, kd_scales=PD_SCALES, gaits=PD_GAITS):
    """Section IV-A: the dominant eigenvalue of the full-order Poincaré map (eq. 44) under PD +
    feedforward (eq. 43) as a function of the PD gains: every output's kp times a common factor
    (``kp_scales``) and every output's kd times another (``kd_scales``), on each gait of
    ``gaits`` (its own u* regression and constraints). All fixed points are found together
    (:func:`~bipedlab.robots.mabel.walking.poincare.pd_fixed_points`: the gains and the gait are
    data of one compiled map). A grid point whose map is not finite (the walk leaves the model's
    range within a step) or whose Newton iteration does not reach PD_RESIDUAL has no eigenvalue.
    The shipped gains (factor 1, 1) are always evaluated (``studies_gains``)."""
    if steps is not None:
        raise ValueError("pd-gains: --steps does not apply (the experiment linearises return maps, it does not walk)")
    say = progress or (lambda msg: None)
    m = wk.walking_model()
    pts = [(a, b) for a in kp_scales for b in kd_scales]
    if (1.0, 1.0) not in pts:
        pts.append((1.0, 1.0))
    G, V, Z, where = [], [], [], []
    base = {}
    for gait in gaits:
        vc, g, rec = wm.load_gait(gait)
        z0, _ = md.section_state(m, wm.design_from_record(rec))
        base[gait] = g
        for a, b in pts:
            G.append(g.replace(kp=g.kp * a, kd=g.kd * b))
            V.append(vc)
            Z.append(np.asarray(z0))
            where.append((gait, a, b))
    say(f"pd-gains: fixed points of the PD + feedforward map at {len(G)} (gait, gains) pairs")
    t0 = time.perf_counter()
    z, J, res, its = mp.pd_fixed_points(m, G, V, np.asarray(Z))
    solve_s = time.perf_counter() - t0
    grid = {gait: [] for gait in gaits}
    for (gait, a, b), Jk, r in zip(where, J, res):
        ok = bool(np.isfinite(r) and r < PD_RESIDUAL and np.all(np.isfinite(Jk)))
        ev = mp.eigenvalues(Jk) if ok else None
        g = base[gait]
        grid[gait].append(dict(kp_scale=a, kd_scale=b, kp=[float(v) for v in np.asarray(g.kp) * a],
                               kd=[float(v) for v in np.asarray(g.kd) * b], fixed_point_found=ok,
                               fixed_point_residual=float(r) if np.isfinite(r) else None,
                               dominant_eigenvalue=_eig(ev[0]) if ok else None,
                               stable=bool(ok and abs(ev[0]) < 1.0)))
    closest, studies, dominant = {}, {}, {}
    for gait in gaits:
        rows = grid[gait]
        found = [x for x in rows if x["dominant_eigenvalue"] is not None]
        best = min(found, key=lambda x: _eig_distance(x["dominant_eigenvalue"], PD_PAPER[gait]), default=None)
        closest[gait] = None if best is None else dict(
            kp_scale=best["kp_scale"], kd_scale=best["kd_scale"], kp=best["kp"], kd=best["kd"],
            dominant_eigenvalue=best["dominant_eigenvalue"], paper_abs=PD_PAPER[gait],
            difference=_eig_distance(best["dominant_eigenvalue"], PD_PAPER[gait]))
        own = next(x for x in rows if (x["kp_scale"], x["kd_scale"]) == (1.0, 1.0))
        studies[gait] = dict(kp=own["kp"], kd=own["kd"], dominant_eigenvalue=own["dominant_eigenvalue"],
                             stored_in_gait_file=wm.load_gait(gait)[2].get("poincare", {}).get("pdff", {}).get(
                                 "poincare_eigenvalues_complex", [None])[0])
        dominant[gait] = [[x["kp_scale"], x["kd_scale"], x["dominant_eigenvalue"]] for x in rows
                          if (x["kp_scale"], x["kd_scale"]) in [(a, b) for a in kp_scales for b in kd_scales]]
    rec = dict(experiment="pd-gains", controller="pdff", map="full order (eq. 44)",
               gains_grid=dict(kp_scales=list(kp_scales), kd_scales=list(kd_scales),
                               shipped_kp={k: [float(v) for v in np.asarray(g.kp)] for k, g in base.items()},
                               shipped_kd={k: [float(v) for v in np.asarray(g.kd)] for k, g in base.items()},
                               points=grid),
               dominant_eigenvalue=dominant, closest_to_paper=closest, studies_gains=studies,
               paper=dict(PD_PAPER), map_passes=its, fixed_point_tolerance=PD_RESIDUAL, solve_s=solve_s)
    if out:
        from bipedlab.robots.mabel.walking import plots as wp

        rec["figures"] = [wp.pd_gain_figure(out, rec)]
    return rec


# ----------------------------------------------------------------------------- exp4
#: Exp. 4's torque saturation (N m) in actuator order (mLA_st, mLS_st, mLA_sw, mLS_sw): 6 on
#: the leg-angle motors, 10 on the leg-shape motors (Fig. 13 caption)
EXP4_LIMITS = (6.0, 10.0, 6.0, 10.0)
#: the drivetrain's limits (N m), the other runs' saturation
DRIVE_LIMITS = (30.0, 55.0, 30.0, 55.0)
EXP4_PAPER = dict(speed_mps=0.9, cmt=0.18, torso_rms_deg=0.89, torso_peak_deg=2.4, mLS_st_rms_deg=0.28,
                  mLS_st_peak_deg=39.5)


def limited_walk(gait, controller, steps, limits, sensing="encoders", progress=None, plant_scale=None) -> dict:
    """A walk of ``gait`` under ``controller`` with the gait's gains saturated at ``limits``
    (N m, actuator order; :func:`~bipedlab.robots.mabel.walking.study.run_walk`, the limits
    data of the compiled loop); :func:`~bipedlab.robots.mabel.walking.study.metrics` plus the
    fraction of samples in saturation per motor and the peak torques, both over the samples up
    to the last touchdown (or the fall)."""
    s, log, rec = wm.run_walk(gait, controller, steps, sensing=sensing, progress=progress, torque_limits=limits,
                              plant_scale=plant_scale)
    r = wm.metrics(s, log, limits, mass=wm.plant_mass(plant_scale))
    n = sw.record_samples(s, log)
    u = np.asarray(log["u"][:n])
    lim = np.asarray(limits, float)
    r.update(gait=gait, controller=controller, sensing=sensing, torque_limits_nm=[float(v) for v in lim],
             samples=int(n),
             peak_torques_nm=[float(v) for v in np.max(np.abs(u), 0)],
             designed_speed_mps=float(rec["design"]["speed"]))
    return r


def _exp4_row(r) -> dict:
    keys = ("fell", "fell_at_s", "steps_completed", "speed_mps", "cmt", "torque_limits_nm", "saturation_fraction",
            "peak_torques_nm", "tracking_rms_deg", "tracking_peak_deg", "speed_per_step", "samples")
    return dict({k: r[k] for k in keys}, fell_in_step=r["steps_completed"] + 1 if r["fell"] else None)


def exp4(steps, progress, out, compare=True, plant_scale=None):
    """Exp. 4: the nominal (Exp. 1) gait :data:`GAIT` under the compliant-HZD controller (I/O linearisation
    with the hybrid-invariance corrections, ``iolin``), 14-bit encoders at 1 kHz, with the
    experiment's saturation EXP4_LIMITS; ``steps`` (default 30). A fallen run has no speed
    (``speed_mps`` None) and gives the step and time of the fall. ``without_limits``: the same
    run at the drivetrain's limits (30 / 55 N m); ``compare`` False leaves it out."""
    n = steps or 30
    r = _exp4_row(limited_walk(GAIT, "iolin", n, EXP4_LIMITS, progress=progress, plant_scale=plant_scale))
    rec = dict(experiment="exp4", gait=GAIT, controller="iolin", sensing="encoders", steps=n, **r,
               paper=dict(EXP4_PAPER, torque_limits_nm=list(EXP4_LIMITS)))
    if compare:
        rec["without_limits"] = _exp4_row(limited_walk(GAIT, "iolin", n, DRIVE_LIMITS, progress=progress))
    return rec


FAST_LEAN_DEG = float(np.degrees(0.7))
FAST_LEAN_STEPS = 30
FAST_TARGET_MPS = 1.5
#: velocity estimation of the fast run: encoders with the model-based observer
FAST_SENSING = "observer"
#: the controller of Exp. 5 (Sec. V-E): the decentralised zero-dynamics controller
FAST_CONTROLLER = "decentralized"
#: steps whose mean speed is the walk's start speed (the paper: "started walking at around 1.15 m/s")
FAST_START_STEPS = 3


def _after_ramp(r, ramp):
    sp = np.asarray(r["speed_per_step"][ramp:])
    return dict(steps_after_lean=int(sp.size), speed_after_lean_mps=float(np.mean(sp)) if sp.size else None,
                min_step_speed_after_lean_mps=float(np.min(sp)) if sp.size else None)


def _contact(r):
    """The pinned toe's contact record of a walk (not part of the fall test)."""
    return {k: r[k] for k in ("friction_cone_exceeded", "max_friction_ratio", "toe_pulled", "min_normal_force_n")}


def fast(steps, progress, out, lean_steps=FAST_LEAN_STEPS, comparisons=True, plant_scale=None):
    """Exp. 5 as the experimenters did it: the nominal (Exp. 1) constraints (:data:`GAIT`), the torso leaned
    forward step by step (:func:`~bipedlab.robots.mabel.walking.constraints.lean`, FAST_LEAN_STEPS increments)
    under the decentralised zero-dynamics controller (:data:`FAST_CONTROLLER`, Sec. V-E), then
    ``steps`` (default 100) more steps, with the 14-bit encoders read through the model-based
    velocity observer; ``start_speed_mps`` is the mean of the first FAST_START_STEPS steps,
    beside the paper's 1.15 m/s. Alongside: the same run with the plain filtered difference
    (whose quantisation chatter can unload the stance toe at this speed: see its ``toe_pulled``
    and ``min_normal_force_n``), the full I/O-linearising controller, and the optimised ``fast``
    gait (which falls within a few steps); ``comparisons`` False leaves those out.
    ``lean_steps``: the increments of the lean."""
    n = steps or 100
    total = lean_steps + n
    lean = dict(lean_deg=FAST_LEAN_DEG, lean_steps=lean_steps)
    r = _walk(GAIT, FAST_CONTROLLER, total, progress, out=out, sensing=FAST_SENSING, plant_scale=plant_scale, **lean)
    r.update(_after_ramp(r, lean_steps))
    first = r["speed_per_step"][:FAST_START_STEPS]
    r["start_speed_mps"] = float(np.mean(first)) if len(first) == FAST_START_STEPS else None
    r.update(experiment="fast", within_torque_limits=bool(all(
        t <= c + 1e-9 for t, c in zip(r["peak_torques_nm"], [30.0, 55.0, 30.0, 55.0]))),
        target_met=bool(not r["fell"] and r["steps_after_lean"] >= n and r["speed_after_lean_mps"] >= FAST_TARGET_MPS),
        paper=dict(sustained_speed_mps=1.5, top_speed_mps=1.52, start_speed_mps=1.15))
    if not comparisons:
        return r
    comp = {}
    for key, controller, sensing in (("decentralized_filtered_difference", FAST_CONTROLLER, "encoders"),
                                     ("iolin_observer", "iolin", FAST_SENSING)):
        d = _walk(GAIT, controller, total, progress, sensing=sensing, **lean)
        comp[key] = dict(fell=d["fell"], steps_completed=d["steps_completed"], **_after_ramp(d, lean_steps),
                         **_contact(d))
    g = _walk("fast", FAST_CONTROLLER, 10, progress, sensing=FAST_SENSING)
    comp["optimised_fast_gait"] = dict(designed_speed_mps=g["designed_speed_mps"], fell=g["fell"],
                                       fell_at_s=g["fell_at_s"], steps_completed=g["steps_completed"], **_contact(g))
    r["comparison"] = comp
    return r


def sweep(steps, progress, out):
    """Continuation from the nominal gait to each speed; eigenvalues of all gaits' restricted
    maps in one vmapped call."""
    say = progress or (lambda msg: None)
    _, _, nom = wm.load_gait("nominal")
    x_nom = np.asarray(nom["x"], float)
    designs, infos = {}, {}
    t0 = time.perf_counter()
    for direction in (sorted([v for v in SWEEP_SPEEDS if v >= 0.8]), sorted([v for v in SWEEP_SPEEDS if v < 0.8], reverse=True)):
        x = x_nom
        for v in direction:
            say(f"sweep: designing {v:.1f} m/s")
            d, info = md.optimize(v, "torque", x0=x)
            designs[v], infos[v] = d, info
            if info["success"]:
                x = d.x
    design_s = time.perf_counter() - t0
    m = wk.walking_model()
    speeds = sorted(designs)
    secs = [md.section_state(m, designs[v]) for v in speeds]
    vcs = jax.tree_util.tree_map(lambda *a: jnp.stack([jnp.asarray(x) for x in a]), *[designs[v].vc for v in speeds])
    xs = jnp.stack([jnp.asarray(s[1]) for s in secs])
    t1 = time.perf_counter()
    J = jax.jit(jax.vmap(jax.jacfwd(lambda vc, x: mp.restricted_map(m, vc, x), argnums=1)))(vcs, xs)
    eig_s = time.perf_counter() - t1
    rows = []
    for v, Jv in zip(speeds, np.asarray(J)):
        ev = mp.eigenvalues(Jv)
        f = designs[v].figures
        ok = bool(infos[v]["success"])  # a failed solve's last iterate is no gait: no figures
        rows.append(dict(target_speed_mps=v, converged=ok, speed_mps=f["speed"] if ok else None,
                         step_length_m=f["step_length"] if ok else None, cmt=f["cmt"] if ok else None,
                         peak_torques_nm=f["peak_torques"] if ok else None,
                         max_abs_eigenvalue=float(np.abs(ev[0])) if ok else None))
    return dict(experiment="sweep", rows=rows, design_s=design_s, eigen_batched_s=eig_s)


#: the gaits walked on the 13-DoF plant: designed on the paper's design model (Exps. 1 and 3's
#: torque and c_mt gaits) and on the full one (the experiments' gaits)
GAP_GAITS = ("paper-nominal", "paper-efficient", EXP3_GAIT, "nominal", "efficient")
#: Exps. 1 and 3 on the robot: realised c_mt against designed (Section V-C, Table II)
GAP_PAPER = {"paper-nominal": dict(designed=0.0452, realised=0.15), "paper-efficient": dict(designed=0.0385, realised=0.14),
             EXP3_GAIT: dict(designed=0.0385, realised=0.14)}


#: the headline comparison on the 13-DoF plant (Sec. V-D, Exps. 1, 4, 5): these gaits under the
#: eq. 42 controllers, beside their PD + feedforward runs of :func:`full_plant` (paper-575: the
#: paper's design model at the paper's step, the gait closest to the paper's; Exp. 3's gait; the
#: paper model's torque optimum). The full-model ``nominal`` gait under eq. 42 is CABLE_GAIT's
#: variant (``cable_runs``)
HEADLINE_GAITS = ("paper-nominal", "paper-575", EXP3_GAIT)
#: the headline gait whose ratios the report judges: the one closest to the paper's gait
HEADLINE_JUDGED = "paper-575"
HEADLINE_CONTROLLERS = ("iolin", "decentralized")
#: what a headline run keeps of its walk record
HEADLINE_KEYS = ("controller", "fell", "fell_at_s", "steps_completed", "speed_mps", "designed_speed_mps", "cmt",
                 "tracking_rms_deg", "tracking_peak_deg", "peak_torques_nm", "toe_pulled", "min_normal_force_n",
                 "saturation_fraction", "first_saturation_s", "rate_estimate_error_rms", "cable_stretch_rms_deg",
                 "cable_stretch_peak_deg", "speed_left_stance_mps", "speed_right_stance_mps", "torque_noise_rms_nm")


#: the headline's labelled variants on the 13-DoF plant, neither the paper's setup: they trace
#: what holds the compliant controller's stance leg-shape tracking. The rates from the
#: model-based velocity observer (bipedlab's, ``sensing="observer"``) instead of the filtered
#: difference, on the headline gaits under the three controllers; and on FACTOR_GAIT under PD +
#: feedforward and eq. 42, a grid of grounds (the identified ground's stiffness and damping times
#: each of GROUND_SCALES; the identified ground takes 2-3 mm of penetration and dissipates nearly
#: all of the impact) by rate estimates (FACTOR_SENSING: the filtered difference, the observer,
#: the exact rates)
VARIANT_SENSING = "observer"
GROUND_SCALES = (1.0, 10.0)
#: the cable variant: CABLE_GAIT under the three controllers on the encoders with the 13-DoF
#: plant's cables CABLE_SCALE times stiffer and more damped than the identified ones (the
#: controllers' stance model has rigid cables; measured, 30 steps on the encoders: with the
#: identified cables eq. 42 falls on nominal in step 2, its stance leg-shape cable stretched 87
#: deg on the motor side; ten times stiffer, it walks, 17 deg)
CABLE_GAIT = "nominal"
CABLE_SCALE = 10.0
#: Sec. VI-C: "both friction and cable stretch contribute significantly to increase" c_mt. Exp.
#: 1's walk (HEADLINE_JUDGED, PD + feedforward, encoders) again with the cables CABLE_SCALE times
#: stiffer (nearly the stance model's rigid cables) and with the motors' viscous friction
#: FRICTION_SCALE times Table V's, beside the identified plant's headline run
FRICTION_SCALE = 2.0
FACTOR_SENSING = ("encoders", "observer", "ideal")
FACTOR_GAIT = HEADLINE_JUDGED


def _joint_side(x: dict) -> dict:
    """The stance leg-shape errors on the joint side: the motor-side figures over the leg-shape
    gear ratio (the paper's conversion, Sec. V-D)."""
    return dict(mLS_st_rms_joint_deg=x["tracking_rms_deg"]["mLS_st"] / tb.GEAR_LS,
                mLS_st_peak_joint_deg=x["tracking_peak_deg"]["mLS_st"] / tb.GEAR_LS)


def _headline_run(x: dict) -> dict:
    """What a headline run keeps of its walk record (HEADLINE_KEYS), with the stance leg-shape
    errors on the joint side."""
    return dict({k: x[k] for k in HEADLINE_KEYS}, **_joint_side(x))


#: walk length of :func:`eps_selection` (steps after the gait's fixed point)
EPS_STEPS = 30


def eps_selection(gait=HEADLINE_JUDGED, steps=EPS_STEPS, controllers=HEADLINE_CONTROLLERS, progress=None) -> dict:
    """How eq. 42's eps per output (:data:`~.controllers.EPS_OUTPUTS`) is chosen: on the 13-DoF
    plant, encoders at 1 kHz, ``gait``, each controller of ``controllers`` first walks with
    every output at ``EPS``; then each output in turn takes the next stiffer value of
    ``EPS_GRID`` (the others at EPS) until the walk falls or its c_mt rises more than
    ``EPS_CMT_RISE`` over the walk at EPS. An output's choice is the stiffest value that met the
    bound with ``EPS_MARGIN`` stiffer values also meeting it (EPS where none did), the softer of
    the controllers' choices. The record keeps every walk (eps, c_mt and its rise, fall, the
    tracking rms of the four outputs, the largest saturated fraction), PD + feedforward's walk
    of the same length (``pdff``), each controller's choice (``chosen_index``), the chosen eps
    (``eps``) and whether it is the shipped one (``shipped``)."""
    vc, gains, rec = wm.load_gait(gait)
    grid, base_eps = ctl.EPS_GRID, ctl.EPS

    def walk(c, eps):
        if progress:
            progress(f"eps selection: {gait} under {c}, eps {', '.join(f'{e:.4f}' for e in eps)}")
        r = wm.walk(gait, c, steps, plant="full", loaded=(vc, gains.replace(eps=jnp.asarray(eps, float)), rec))
        return dict(fell=r["fell"], steps_completed=r["steps_completed"], cmt=r["cmt"],
                    tracking_rms_deg=r["tracking_rms_deg"],
                    saturation_max=max(r["saturation_fraction"].values()))

    out = dict(gait=gait, steps=steps, grid=list(grid), cmt_rise=ctl.EPS_CMT_RISE, margin=ctl.EPS_MARGIN,
               outputs=list(vcm.OUTPUTS), pdff=walk("pdff", [base_eps] * 4), base={}, trials={}, chosen_index={})
    for c in controllers:
        base = out["base"][c] = walk(c, [base_eps] * 4)
        out["trials"][c], out["chosen_index"][c] = [], []
        for i in range(4):
            rows, met = [], 0
            for k in range(1, len(grid)):
                eps = [base_eps] * 4
                eps[i] = grid[k]
                x = walk(c, eps)
                rise = None if x["fell"] or base["cmt"] is None else x["cmt"] / base["cmt"] - 1.0
                ok = rise is not None and rise <= ctl.EPS_CMT_RISE
                rows.append(dict(x, index=k, eps=grid[k], cmt_rise=rise, met=ok))
                if not ok:
                    break
                met = k
            out["trials"][c].append(rows)
            out["chosen_index"][c].append(max(met - ctl.EPS_MARGIN, 0))
    chosen = [min(out["chosen_index"][c][i] for c in controllers) for i in range(4)]
    out["eps"] = [grid[k] for k in chosen]
    out["shipped"] = bool(np.allclose(out["eps"], ctl.EPS_OUTPUTS, rtol=1e-12, atol=0.0))
    return out


def full_plant(steps, progress, out, gaits=GAP_GAITS, headline=HEADLINE_GAITS, variants=True, plant_scale=None):
    """The design-to-robot gap (Sections V-A, V-C, VI-C): each gait under PD + feedforward on
    encoders at 1 kHz on the 13-DoF plant (:mod:`.full_plant`), beside its designed c_mt; Fig.
    20 for the first gait when ``out`` is given. The headline comparison (Sec. V-D): each gait
    of ``headline`` also under the compliant zero-dynamics controller (eq. 42) and its
    decentralised form, on the same plant and encoders (``hzd_runs[gait][controller]``; the
    stance leg-shape errors also on the joint side). With ``variants``, the labelled variants
    that trace the headline's figures: the same runs with the velocity observer
    (``hzd_runs_observer``), and FACTOR_GAIT under PD + feedforward and eq. 42 on each ground
    of GROUND_SCALES with each rate estimate of FACTOR_SENSING
    (``factor_runs[scale][sensing][controller]``; the runs above are not walked again), CABLE_GAIT
    under the three controllers with the cables CABLE_SCALE times stiffer (``cable_runs``) and
    under the eq. 42 controllers with the identified cables (``cable_runs_identified``), Exp.
    1's walk with those cables and with FRICTION_SCALE times the motor friction
    (``cmt_factor_runs``: ``cables``, ``friction``), and
    :func:`eps_selection` (``eps_selection``), whose walks at one eps on every output are the
    headline's figures before eq. 42's eps was chosen per output. ``plant_scale``: the plant's
    values (:func:`~bipedlab.robots.mabel.walking.study.run_walk`) for every walk but the eps
    selection's."""
    runs, hzd = {}, {}
    n = steps or 100

    def walk(g, c, **kw):
        if progress:
            progress(f"{g} under {c} on the 13-DoF plant" + "".join(f", {k} {v}" for k, v in kw.items()))
        return wm.walk(g, c, n, plant="full", plant_scale=plant_scale, **kw)

    for k, g in enumerate(gaits):
        if progress:
            progress(f"{g} on the 13-DoF plant")
        runs[g] = wm.walk(g, "pdff", n, plant="full", out=f"{out}/{g}" if out and k == 0 else None,
                          plant_scale=plant_scale)
    for g in headline:
        hzd[g] = {c: _headline_run(runs.get(g) if c == "pdff" and g in runs else walk(g, c))
                  for c in ("pdff",) + HEADLINE_CONTROLLERS}
    r = dict(experiment="full-plant", controller="pdff", sensing="encoders", steps=n, runs=runs,
             hzd_runs=hzd, judged_gait=HEADLINE_JUDGED, paper=GAP_PAPER)
    if variants:
        obs = r["hzd_runs_observer"] = {g: {c: _headline_run(walk(g, c, sensing=VARIANT_SENSING))
                                            for c in ("pdff",) + HEADLINE_CONTROLLERS} for g in headline}
        done = {("encoders", 1.0): hzd.get(FACTOR_GAIT), (VARIANT_SENSING, 1.0): obs.get(FACTOR_GAIT)}

        def cell(sensing, k, c):
            x = (done.get((sensing, k)) or {}).get(c)
            return x if x is not None else _headline_run(walk(FACTOR_GAIT, c, sensing=sensing, ground=k))

        r["cable_gait"], r["cable_scale"] = CABLE_GAIT, CABLE_SCALE
        r["cable_runs"] = {c: _headline_run(walk(CABLE_GAIT, c, cable=CABLE_SCALE))
                           for c in ("pdff",) + HEADLINE_CONTROLLERS}
        r["cable_runs_identified"] = {c: (hzd.get(CABLE_GAIT) or {}).get(c) or _headline_run(walk(CABLE_GAIT, c))
                                      for c in HEADLINE_CONTROLLERS}
        r["cmt_factor_gait"], r["friction_scale"] = HEADLINE_JUDGED, FRICTION_SCALE
        r["cmt_factor_runs"] = dict(cables=_headline_run(walk(HEADLINE_JUDGED, "pdff", cable=CABLE_SCALE)),
                                    friction=_headline_run(walk(HEADLINE_JUDGED, "pdff", friction=FRICTION_SCALE)))
        r["eps_selection"] = eps_selection(progress=progress)
        r["factor_gait"] = FACTOR_GAIT
        r["factor_runs"] = {f"{k:g}": {sn: {c: cell(sn, k, c) for c in ("pdff", "iolin")} for sn in FACTOR_SENSING}
                            for k in GROUND_SCALES}
    return r


def sensitivity(steps, progress, out, parameters=None, step: float = 0.01, plant=True):
    """The designed gaits' rows as functions of MABEL's published values
    (:func:`bipedlab.robots.mabel.walking.sensitivity.sensitivity`) and, with ``plant``, the
    walking experiments' rows as functions of the plant's
    (:func:`~bipedlab.robots.mabel.walking.sensitivity.plant_sensitivity`, record key ``plant``)."""
    from bipedlab.robots.mabel.walking import sensitivity as ws

    if steps is not None:
        raise ValueError(f"sensitivity: --steps does not apply ({catalog.NO_STEPS['sensitivity']})")
    rec = ws.sensitivity(step=step, parameters=parameters, progress=progress)
    if plant:
        rec["plant"] = ws.plant_sensitivity(parameters=ws.PLANT_PARAMETERS if parameters is None else parameters,
                                            progress=progress)
    return rec


_RUN = {"nominal": nominal, "push": push, "efficient": efficient, "tracking": tracking,
        "impact-scaling": impact_scaling, "fast": fast, "sweep": sweep, "pd-gains": pd_gains, "exp4": exp4,
        "full-plant": full_plant, "sensitivity": sensitivity}


def run(name: str, steps=None, out=None, progress=None, **options) -> dict:
    """Run experiment ``name``; ``options``: the experiment's own keyword arguments (the
    reductions of ``bipedlab reproduce --quick``)."""
    t0 = time.perf_counter()
    r = _RUN[name](steps, progress, out, **options)
    r.setdefault("experiment", name)
    r["wall_s"] = time.perf_counter() - t0
    return r


def _drive_line(x: dict) -> str:
    """A walk's saturation, rate-estimate error and cable stretch in one line."""
    sat = ", ".join(f"{k} {100 * v:.1f} %" for k, v in x["saturation_fraction"].items() if v) or "none"
    err, cab = x["rate_estimate_error_rms"], x.get("cable_stretch_rms_deg") or {}
    return (f"saturated: {sat}; rate estimate error rms mLS_st {err['mLS_st']:.2f}, mLS_sw {err['mLS_sw']:.2f} rad/s"
            + ("; cable stretch rms (motor side, deg) " + ", ".join(f"{k} {v:.0f}" for k, v in cab.items()) if cab else ""))


def _headline_lines(title: str, by: dict) -> list:
    """A headline block of the summary: per controller, the stance leg-shape and torso errors,
    peak torques and the drive line."""
    lines = [f"  {title}, stance leg-shape motor rms / peak (deg), torso rms (deg), per controller:"]
    for c, x in by.items():
        state = f"FELL in step {x['steps_completed'] + 1}; " if x["fell"] else ""
        lines.append(f"    {c:>13}: {state}{x['tracking_rms_deg']['mLS_st']:.2f} / {x['tracking_peak_deg']['mLS_st']:.1f}"
                     f" (joint side {x['mLS_st_rms_joint_deg']:.3f} / {x['mLS_st_peak_joint_deg']:.2f}), torso "
                     f"{x['tracking_rms_deg']['Tor']:.2f}, peak torques {[round(t, 1) for t in x['peak_torques_nm']]}")
        lines.append(f"{'':>19}{_drive_line(x)}")
    return lines


def summary_full_plant(r: dict) -> str:
    lines = [f"13-DoF plant, PD + feedforward on encoders, {r['steps']} steps per gait:"]
    for g, by in (r.get("hzd_runs") or {}).items():
        lines += _headline_lines(g, by)
    for g, by in (r.get("hzd_runs_observer") or {}).items():
        lines += _headline_lines(f"{g} with the velocity observer (bipedlab's) instead of the filtered difference", by)
    if r.get("factor_runs"):
        lines.append(f"  {r['factor_gait']}, stance leg-shape motor rms (deg) under PD + feedforward / eq. 42, by ground "
                     "(stiffness and damping x K) and rate estimate:")

        def one(x):
            return f"{x['tracking_rms_deg']['mLS_st']:.2f}" + (f" (FELL in step {x['steps_completed'] + 1})"
                                                                  if x["fell"] else "")

        for k, grid in r["factor_runs"].items():
            for sn, by in grid.items():
                lines.append(f"    K {k:>4}, {sn:>8}: {one(by['pdff'])} / {one(by['iolin'])}")
    for g, x in r["runs"].items():
        paper = r["paper"].get(g)
        state = (f"FELL in step {x['steps_completed'] + 1}" if x["fell"] else
                 f"{x['speed_mps']:.3f} m/s, c_mt {x['cmt']:.4f} = {x['cmt_ratio']:.2f} x designed {x['cmt_designed']:.4f}"
                 f" ({x['cmt_ratio_paper_model']:.2f} x its c_mt on the paper's design model)")
        lines.append(f"  {g:>15}: {state}; stance leg-shape motor tracking rms {x['tracking_rms_deg']['mLS_st']:.1f} deg"
                     + (f"; paper: designed {paper['designed']}, realised {paper['realised']}" if paper else ""))
    return "\n".join(lines)


def summary(r: dict) -> str:
    name = r["experiment"]
    if name == "full-plant":
        return summary_full_plant(r)
    if name == "sensitivity":
        from bipedlab.robots.mabel.walking import sensitivity as ws

        return ws.summary(r)
    if name in ("nominal", "efficient", "fast"):
        text = wm.summary_walk(r)
        if name == "fast":
            text += (f"\nafter the {FAST_LEAN_DEG:.1f} deg lean ({FAST_LEAN_STEPS} steps): {r['steps_after_lean']} steps at "
                     f"{r['speed_after_lean_mps']:.3f} m/s (slowest step {r['min_step_speed_after_lean_mps']:.3f}); "
                     f"paper: sustained 1.5 m/s, top 1.52")
            if r.get("start_speed_mps") is not None:
                text += f"\nstart speed (first {FAST_START_STEPS} steps) {r['start_speed_mps']:.3f} m/s; paper: about 1.15"
            for k, x in r["comparison"].items():
                text += f"\n{k}: {x}"
        if name == "efficient":
            text += (f"\ndesigned c_mt {r['designed_cmt']:.4f} (nominal gait {r['nominal_designed_cmt']:.4f}); "
                     f"paper 0.0385 / 0.0452, realised on the robot 0.14")
        return text
    if name == "push":
        def pct(v):
            return "n/a" if v is None else f"{100 * v:+.1f} %"

        def end(x):
            if x["fell"]:
                return f"FELL in step {x['steps_completed']}"
            back = x["steps_to_recover_5pct"]
            text = "not settled within 5 %" if back is None else f"within 5 % from {back} steps on"
            if x["friction_cone_exceeded"]:
                text += (f"; friction ratio {x['max_friction_ratio']:.2f} > {MU_TOE} "
                         f"(step {x['friction_cone_exceeded_step']})")
            if x["toe_pulled"]:
                text += f"; toe pulled on the ground (step {x['toe_pulled_step']})"
            return text

        lines = []
        for x in r["searches"]:
            lines.append(f"{x['controller']:>13}: force for {pct(x['target_change'])}: {x['force_n']:+.1f} N "
                         f"({len(x['walks'])} walks{'' if x['converged'] else ', NOT converged'}), speed change "
                         f"{pct(x['speed_change'])}, {end(x)}")
        for x in r["at_pdff_forces"]:
            lines.append(f"{x['controller']:>13} push {x['force_n']:+.1f} N at step {x['step']}: speed change "
                         f"{pct(x['speed_change'])}, {end(x)}")
        for x in r["runs"]:
            lines.append(f"{x['controller']:>13} push {x['force_n']:+.0f} N at step {x['step']} (unpushed "
                         f"{x['unpushed_speed_mps']:.3f} m/s): speed change {pct(x['speed_change'])}, {end(x)}")
        for x in r.get("gait_factor", []):
            lines.append(f"{'pdff':>13} on {x['gait']} ({x['step_length_m']:.3f} m steps, {x['unpushed_speed_mps']:.3f} m/s):"
                         f" {x['force_for_plus_45pct_n']:+.1f} N / {x['force_for_minus_45pct_n']:+.1f} N, back within 2 % "
                         f"after {x['steps_to_recover_plus']} / {x['steps_to_recover_minus']} steps")
        lines.append("paper: +45 % recovering over ~10 steps (78 N), -45 % over ~3 (71 N)")
        return "\n".join(lines)
    if name == "tracking":
        lines = []
        for c, x in r["controllers"].items():
            lines.append(f"{c:>13}: " + ", ".join(f"{k} {v:.2f}" for k, v in x["tracking_rms_deg"].items())
                         + (" deg rms; FELL" if x["fell"] else f" deg rms; speed {x['speed_mps']:.3f} m/s"))
            for key, label in (("ideal_sensing", "exact encoders"), ("full_plant", "13-DoF plant")):
                if key in x:
                    y = x[key]
                    lines.append(f"{'':>15}{label}: mLS_st {y['tracking_rms_deg']['mLS_st']:.2f}, Tor "
                                 f"{y['tracking_rms_deg']['Tor']:.3f} deg rms"
                                 + (f"; FELL in step {y['fell_in_step']}" if y["fell"] else ""))
        lines.append("paper (experiment): torso 1.44 -> 0.89 deg, mLS_st 29.82 -> 0.28 deg rms (PD+FF -> HZD)")
        return "\n".join(lines)
    if name == "impact-scaling":
        lines = ["eta    HZD (m/s)   PD+FF (m/s)   paper"]
        for x in r["rows"]:
            s = "fell" if x["steady_speed_mps"] is None else f"{x['steady_speed_mps']:.3f}"
            p = ("not run" if "pdff_steady_speed_mps" not in x else "fell" if x["pdff_steady_speed_mps"] is None
                 else f"{x['pdff_steady_speed_mps']:.3f}")
            lines.append(f"{x['eta']:<6} {s:>9}   {p:>11}   {x['paper_speed_mps']:.2f}")
        if "dv_deta_paper" in r:
            def slope(v):
                return "n/a" if v is None else f"{v:+.2f}"

            lines.append(f"dv/deta (least-squares line, m/s per unit eta): HZD {slope(r['dv_deta'])}"
                         + (f", PD+FF {slope(r['pdff_dv_deta'])}" if "pdff_dv_deta" in r else "")
                         + f"; paper (Table I) {slope(r['dv_deta_paper'])}")
            for x in r.get("gait_factor", []):
                lines.append(f"  HZD on {x['gait']}: {slope(x['dv_deta'])} (speeds "
                             + ", ".join("fell" if v is None else f"{v:.3f}" for v in x["steady_speed_mps"]) + ")")
        return "\n".join(lines)
    if name == "pd-gains":
        return summary_pd_gains(r)
    if name == "exp4":
        return summary_exp4(r)
    if name == "sweep":
        lines = ["speed   step (m)  c_mt    max|eig|"]
        for x in r["rows"]:
            if not x["converged"]:
                lines.append(f"{x['target_speed_mps']:.2f}   not converged")
                continue
            lines.append(f"{x['speed_mps']:.2f}   {x['step_length_m']:.3f}    {x['cmt']:.4f}  {x['max_abs_eigenvalue']:.4f}")
        lines.append(f"design {r['design_s']:.1f} s; eigenvalues of all gaits in one batched call {r['eigen_batched_s']:.1f} s")
        return "\n".join(lines)
    return str(r)


def _ev_text(e) -> str:
    if e is None:
        return "no fixed point"
    return f"{e['re']:+.4f}{e['im']:+.4f}j (|.| {e['abs']:.4f})"


def summary_pd_gains(r: dict) -> str:
    g = r["gains_grid"]
    lines = [f"PD + feedforward, full-order map (eq. 44): dominant eigenvalue |.| over kp x {g['kp_scales']} "
             f"(rows) and kd x {g['kd_scales']} (columns) of the shipped gains"]
    for gait, rows in g["points"].items():
        lines.append(f"{gait}: paper {r['paper'][gait]:.4f}")
        for a in g["kp_scales"]:
            cells = []
            for b in g["kd_scales"]:
                x = next(x for x in rows if (x["kp_scale"], x["kd_scale"]) == (a, b))
                e = x["dominant_eigenvalue"]
                cells.append("   --  " if e is None else f"{e['abs']:7.4f}")
            lines.append(f"  kp x {a:<5g}" + " ".join(cells))
        c = r["closest_to_paper"][gait]
        if c is not None:
            lines.append(f"  closest to the paper: kp x {c['kp_scale']:g}, kd x {c['kd_scale']:g} "
                         f"(kp {c['kp']}, kd {c['kd']}): {_ev_text(c['dominant_eigenvalue'])}")
        s = r["studies_gains"][gait]
        lines.append(f"  the studies' gains (kp {s['kp']}, kd {s['kd']}): {_ev_text(s['dominant_eigenvalue'])}")
        ev = [x["dominant_eigenvalue"] for x in rows if x["dominant_eigenvalue"] is not None]
        if ev:
            mags = [e["abs"] for e in ev]
            neg = sum(e["re"] < 0 and abs(e["im"]) < 1e-12 for e in ev)
            lines.append(f"  stable at {sum(m < 1 for m in mags)} of {len(rows)} grid points; |.| from {min(mags):.3f} "
                         f"to {max(mags):.3f}; real and negative (alternating) at {neg}")
    lines.append("The walking studies use the PD gains shipped with the gaits (controllers.default_gains, the same for "
                 "every gait, tuned on the nominal gait for a stable map and small tracking errors): the gains every "
                 "walk loads. The paper does not publish its PD gains, so its eigenvalues fix no gains here; the sweep "
                 "shows the dominant eigenvalue moving widely with the gains (above), so a difference from the paper's "
                 "value at the shipped gains says little about the model; the point closest to the paper's (real, "
                 "positive) eigenvalue is chosen by the distance in the complex plane.")
    return "\n".join(lines)


def summary_exp4(r: dict) -> str:
    def one(x, label):
        head = (f"{label}: FELL in step {x['steps_completed'] + 1} at {x['fell_at_s']:.3f} s (no speed)" if x["fell"]
                else f"{label}: {x['steps_completed']} steps at {x['speed_mps']:.3f} m/s, c_mt "
                     + ("n/a" if x["cmt"] is None else f"{x['cmt']:.3f}"))
        sat = ", ".join(f"{k} {100 * v:.2f} %" for k, v in x["saturation_fraction"].items())
        lim = "/".join(f"{v:g}" for v in x["torque_limits_nm"])
        return [head, f"  limits {lim} N m; samples in saturation: {sat}; peak torques "
                + ", ".join(f"{v:.1f}" for v in x["peak_torques_nm"]) + " N m",
                "  tracking rms / peak (deg): " + ", ".join(
                    f"{k} {x['tracking_rms_deg'][k]:.2f} / {x['tracking_peak_deg'][k]:.2f}" for k in x["tracking_rms_deg"])]
    lines = one(r, "Exp. 4, compliant-HZD controller (iolin), encoders, 1 kHz")
    if "without_limits" in r:
        lines += one(r["without_limits"], "same without the 6/10 N m limits (30/55 N m)")
    lines.append("paper (robot): 0.9 m/s, c_mt 0.18; torso rms 0.89 deg (peak 2.4), q_mLS_st rms 0.28 deg (peak 39.5)")
    return "\n".join(lines)
