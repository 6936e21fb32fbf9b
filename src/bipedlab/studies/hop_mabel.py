"""Study: MABEL hopping on the 13-DoF model (identification paper, Section VIII, Appendix C).

``run_hops`` simulates the sampled-data closed loop (1 ms control, quantised encoders) on the
13-DoF model with cable stretch, the unilateral springs with hard stops and the compliant
ground, and summarises the hops; ``poincare`` linearises the hop-to-hop return map at its
fixed point, with and without the event-based torso update.

Integration: semi-implicit Euler with implicit hard-stop and ground-friction damping
(:func:`bipedlab.robots.mabel.dynamics.step`) at ``DT`` = 0.1 ms, 10 steps per control
sample. ``accuracy_check`` measures what that step costs in accuracy against 4x finer steps.
"""
from __future__ import annotations

import dataclasses
import time

import jax
import jax.numpy as jnp
import numpy as np

from ..control import hopping as hop
from ..robots.mabel import dynamics as md
from ..robots.mabel import model as mm
from ..robots.mabel import tables as tb
from ..robots.mabel import transmission as tr

DT = 1e-4
SUBSTEPS = 10
#: The hop counts as a fall when the hip drops below this height (m) or the torso leaves
#: the rotation limiter's range (+30 / -40 deg, identification paper, footnote 7).
MIN_HIP_HEIGHT = 0.5
TORSO_RANGE = (np.deg2rad(-40.0), np.deg2rad(30.0))
_I = {c: i for i, c in enumerate(mm.COORDS_13)}
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


def _sense(m: mm.Mabel, p: hop.HopParams, x):
    n = m.n
    q, qd = x[:n], x[n:2 * n]
    h = jnp.stack([q[_I[c]] for c in H_COORDS])
    toes = md.toe_positions(m, q)[:, 1]
    return h, q[_I["tor"]], toes, q[_I["x"]] / p.boom_radius, qd[_I["y"]] / p.boom_radius


def _fell(x):
    tor = x[_I["tor"]]
    return (x[_I["y"]] < MIN_HIP_HEIGHT) | (tor < TORSO_RANGE[0]) | (tor > TORSO_RANGE[1])


def closed_loop(m: mm.Mabel, p: hop.HopParams, x0, c0, steps: int, dt: float = DT, substeps: int = SUBSTEPS,
                record: bool = True):
    """Simulate ``steps`` control samples. Returns (x, c, alive, log) where log holds per
    sample the state after it, the commanded torques and the phase (or None)."""

    def sample(carry, _):
        x, c, alive = carry
        c_new, u = hop.update(p, c, *_sense(m, p, x))
        xn = jax.lax.fori_loop(0, substeps, lambda _, x: md.step(m, x, u, dt), x)
        ok = alive & jnp.all(jnp.isfinite(xn)) & ~_fell(xn)
        x = jnp.where(ok, xn, x)
        c = jax.tree_util.tree_map(lambda a, b: jnp.where(ok, a, b), c_new, c)
        out = (x, jnp.clip(u, -m.drive.torque_limit, m.drive.torque_limit), c.phase) if record else None
        return (x, c, ok), out

    (x, c, alive), log = jax.lax.scan(sample, (x0, c0, jnp.asarray(True)), None, length=steps)
    return x, c, alive, log


_closed_loop = jax.jit(closed_loop, static_argnames=("steps", "dt", "substeps", "record"))


_CACHE: dict = {}


def _compiled(m, p, x0, c0, steps: int):
    """Ahead-of-time compiled closed loop, cached per model structure and length."""
    key = (jax.tree_util.tree_structure((m, p)), steps)
    if key not in _CACHE:
        _CACHE[key] = _closed_loop.lower(m, p, x0, c0, steps=steps).compile()
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
    c0 = hop.initial_state(p, _sense(m, p, x0)[0])
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
