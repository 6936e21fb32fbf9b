"""HZD gait design and closed-loop walking of a biped read from an MJCF or URDF file: the
core's study (:mod:`bipedlab.gait.study`) on the model :mod:`.robot` sets up, with the same
record keys as the shipped robots' studies plus the file, the stance and swing points and the
torque limits. A gait file remembers its stance and swing points, so ``walk`` needs only the
robot's file and the gait."""
from __future__ import annotations

import os
from importlib import resources

import numpy as np

from bipedlab.gait import gaitfile, schema
from bipedlab.gait import study as hzd_study
from bipedlab.robots.imported import robot

#: Robot files shipped with the package (found by name when no such file is in the way).
EXAMPLES = ("rabbit.xml", "rabbit.urdf")


def resolve(path: str) -> str:
    """The file itself, or a shipped example named by its file name (e.g. ``rabbit.xml``)."""
    if os.path.exists(path) or os.path.basename(path) != path or path not in EXAMPLES:
        return path
    return str(resources.files("bipedlab.robots.imported").joinpath("data", path))


def _limits(s: robot.Setup) -> list:
    return [float(v) if np.isfinite(v) else None for v in s.desc.torque_limits]


def _extra(s: robot.Setup, path) -> dict:
    return dict(file=str(path), stance=s.stance_name, swing=s.swing_name,
                actuators=list(s.desc.actuators), torque_limits_nm=_limits(s))


#: The default swing clearance at mid-step, as a fraction of the leg length (the stance hip to its
#: foot point in the file's nominal pose, every joint at zero: straight legs in the usual file).
#: Human walking lifts the toe about 1.3 cm over the ground at mid-swing, its minimum (Winter
#: 1992, The Biomechanics and Motor Control of Human Gait), for a leg of about 0.9 m: 1.5 % of the
#: leg, with an ankle that dorsiflexes the toe up. A point foot has no ankle and its toe is also
#: the contact point, so the default asks twice that, 3 % of the leg: 2.4 cm for RABBIT's 0.8 m
#: legs (whose shipped gait clears 5.4 cm on that parabola, so the bound is inactive there).
CLEARANCE_FRACTION = 0.03


def default_clearance(s: robot.Setup) -> float:
    """The default swing clearance at mid-step, m: :data:`CLEARANCE_FRACTION` of the leg length."""
    return CLEARANCE_FRACTION * float(s.leg)


def _design(s: robot.Setup, speed, cost, controller, progress, max_eigenvalue, clearance):
    prob = hzd_study.problem(s.study, speed, cost, max_eigenvalue, clearance)
    return hzd_study.design(s.study, prob, robot.initial_guess(s, prob), controller, cost, progress)


def optimize(path, stance: str, swing: str, speed: float = 0.8, cost: str = "torque", controller: str = "iolin",
             save=None, plane: str = "xz", progress=None, max_eigenvalue: float | None = None,
             clearance: float | None = None, retry: bool = True) -> dict:
    """The design record (:func:`bipedlab.gait.study.design`); ``max_eigenvalue`` bounds the
    restricted map's |eigenvalue| and ``clearance`` (m) lifts the swing point at mid-step (None:
    :func:`default_clearance`, 3 % of the leg; 0: no bound).

    When the design's closed loop is not stable and the remedy is on an option left to its
    default (``clearance`` None, or ``max_eigenvalue`` None), and ``retry``, the design is made
    once more from the same initial guess with it (:func:`bipedlab.gait.study.design_retrying`;
    the record's ``retried`` says what and why). An explicit option is the caller's: a design
    with it is reported as it is."""
    s = robot.load(resolve(path), stance, swing, plane)
    defaulted = clearance is None
    clearance = default_clearance(s) if defaulted else float(clearance)
    rec, vc, z_minus, met = hzd_study.design_retrying(
        lambda bound, clear: _design(s, speed, cost, controller, progress, bound, clear),
        clearance, max_eigenvalue, defaulted, retry, progress)
    rec.update(_extra(s, path))
    if save:
        hzd_study.save_gait(s.study, save, vc, z_minus, rec)
    return rec


def load_gait(path: str, gait: str, plane: str = "xz"):
    """(setup, virtual constraints, fixed point, gait record) of a gait file designed for the
    robot in ``path``; ValueError naming the file and the field otherwise."""
    rec = gaitfile.read_json(gait)
    schema.expect_robot(rec, gait, robot.ROBOT)
    design = (rec.get("payload") or {}).get("design") if isinstance(rec, dict) else None
    if not isinstance(design, dict) or not isinstance(design.get("stance"), str) \
            or not isinstance(design.get("swing"), str):
        raise ValueError(f"{gait}: payload.design: no stance and swing points (not a gait of optimize model)")
    s = robot.load(resolve(path), design["stance"], design["swing"], plane)
    n, m = s.study.H0.shape[1], s.study.H0.shape[0]
    vc, z, full = gaitfile.from_dict(rec, gait, (n, m))
    if full.get("robot") != robot.ROBOT:
        raise ValueError(f"{gait}: robot: a gait for {full.get('robot')!r}, not {robot.ROBOT!r}")
    return s, vc, z, full


def walk(path, gait, steps: int = 50, perturb: float = 0.0, controller: str = "iolin", seed: int = 0,
         plane: str = "xz", progress=None, walk_anyway: bool = False) -> dict:
    """The walk record (:func:`bipedlab.gait.study.walk`: the gait's own gains; an unstable gait
    raises :class:`bipedlab.gait.study.UnstableGait` naming the gait file and the ``--walk-anyway`` that
    walks it, unless ``walk_anyway``)."""
    s, vc, z_star, meta = load_gait(path, gait, plane)
    try:
        rec, _, _ = hzd_study.walk(s.study, vc, z_star, meta, steps, perturb, controller, seed, progress,
                                   walk_anyway)
    except hzd_study.UnstableGait as e:
        raise hzd_study.UnstableGait(f"{gait}: {e}; --walk-anyway walks it") from None
    rec.update(_extra(s, path))
    return rec


def summary_optimize(r: dict) -> str:
    out = f"{r['file']} (stance {r['stance']}, swing {r['swing']})\n" + hzd_study.summary_optimize(r)
    t = r.get("retried")
    if t:
        what = ", ".join(f"{k} {t[k]:g}" for k in ("clearance", "max_eigenvalue") if k in t)
        out += f"\nretried with {what}, because in the first design {t['because']}"
    return out


def summary_walk(r: dict) -> str:
    return f"{r['file']} (stance {r['stance']}, swing {r['swing']})\n" + hzd_study.summary_walk(r)
