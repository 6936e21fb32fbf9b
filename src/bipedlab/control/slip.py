"""Spring-mass model (SMM / SLIP) of running and its time-based deadbeat swing-leg policy.

Running paper (Wu & Geyer), Section II-A. A point mass m bounces on a massless spring leg
(stiffness k0, rest length l0). The leg angle alpha is measured from the horizontal, in front
of the body: at touchdown the foot lies at (x + l0 cos a, y - l0 sin a). Stance GRF is
k0 (l0 - l) (-cos a, sin a) with a stationary foot; flight is ballistic.

With the total energy E held fixed, running is the 1-D return map y_{i+1} = f(y_i, a_TD)
(:func:`apex_map`). The deadbeat landing angle a*(y_i) solves f(y_i, a) = y* (eq. 1,
:func:`deadbeat_angle`, Brent's method on the compiled map); each solution lands at the time
t = sqrt(2 (y_i - l0 sin a*) / g) after apex. Sequencing the pairs (t, a*) over all apex
heights gives the swing-leg profile a*(t) (:func:`swing_policy`), fitted by a polynomial.
Unobserved ground steps act as perturbations of the previous apex height: a step down by h is
an apex h higher (the energetic difference is what makes the embedding inexact).

Choices (the paper does not give them): apex perturbations are sampled with the energy E*
fixed (so the speed at apex follows from the height), the branch of f^-1 is the one
continuous with the periodic gait's landing angle, the fit is a degree-5 polynomial in t
over the sampled range and is held constant outside it. The controller of the articulated
robot and the pure spring-mass model run the same polynomial (Sec. IV-A); the solved pairs
themselves (:class:`PolicyTable`) are the exact policy at its nodes. Measured (m = 59 kg,
k0 = 32 kN/m, y* = 1.05 m, 5 m/s; :func:`fit_error`): the fit follows the solved policy to
8.2e-6 rad at most, 2.0e-6 rad rms, over landing times 0.005 to 0.273 s (29 samples and the
28 heights between them), 1.9e-6 rad at the periodic gait's own landing time.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.pytree import pytree
from bipedlab.sim import hybrid
from bipedlab.sim.integrators import rk4
from bipedlab.sim.rollout import OK

G = 9.81


@pytree
class SlipParams:
    """m: mass (kg); k0: leg stiffness (N/m); l0: leg rest length (m); g (m/s^2)."""

    m: float = 60.0
    k0: float = 32000.0
    l0: float = 1.0
    g: float = G


@pytree
class Gait:
    """Target apex height (m, above the ground of the next stance) and forward speed (m/s)."""

    y_apex: float = 1.05
    speed: float = 5.0


def energy(p: SlipParams, pos, vel, foot=None):
    """Total energy (J): kinetic + gravitational (+ spring when ``foot`` is given, in stance)."""
    e = 0.5 * p.m * jnp.sum(jnp.square(vel), axis=-1) + p.m * p.g * pos[..., 1]
    if foot is not None:
        l = jnp.linalg.norm(pos - foot, axis=-1)
        e = e + 0.5 * p.k0 * jnp.square(jnp.minimum(l - p.l0, 0.0))
    return e


def gait_energy(p: SlipParams, gait: Gait) -> float:
    return p.m * p.g * gait.y_apex + 0.5 * p.m * gait.speed ** 2


def stance_flow(p: SlipParams, s):
    """s = (x, y, vx, vy) relative to the foot; the leg spring pushes along the leg."""
    r = s[:2]
    l = jnp.linalg.norm(r)
    acc = p.k0 / p.m * (p.l0 / l - 1.0) * r - jnp.array([0.0, p.g])
    return jnp.concatenate([s[2:], acc])


def lift_off(p: SlipParams) -> hybrid.Transition:
    """Stance's end as a hybrid transition: the stance flow on the stationary foot, the guard
    l0 - |r| (m, the leg's compression), armed while the leg extends (r . v > 0), no reset (the
    flight that follows starts from the lift-off state)."""
    return hybrid.Transition(flow=lambda s, _: stance_flow(p, s), guard=lambda s: p.l0 - jnp.linalg.norm(s[:2]),
                             armed=lambda s: jnp.dot(s[:2], s[2:]) > 0, reset=lambda s: (s, None), integrator=rk4)


def stance(p: SlipParams, s_td, dt: float = 1e-4, max_steps: int = 20000):
    """Integrate stance from touchdown state s_td (relative to the foot) until the leg is
    back at rest length while extending (:func:`lift_off` through the core's
    :func:`~bipedlab.sim.hybrid.flow_until_event`: RK4 steps of ``dt`` s, the crossing linearly
    interpolated inside the last step). Returns (lift-off state, stance time in s, ok) where ok
    is False when the mass hit the ground or the stance did not end within ``max_steps``."""
    r, _, _ = hybrid.flow_until_event(lift_off(p), s_td, None, dt, max_steps * dt, fell=lambda s: s[1] <= 0.0,
                                      locate="linear")
    return r.z, r.t, r.status == OK


def touchdown_state(p: SlipParams, y_apex, vx, alpha):
    """State relative to the foot at touchdown after falling from apex (y_apex, vx) with the
    leg at alpha, and the fall time; nan when the leg cannot reach the ground."""
    drop = y_apex - p.l0 * jnp.sin(alpha)
    t = jnp.sqrt(2.0 * drop / p.g)
    s = jnp.stack([-p.l0 * jnp.cos(alpha), p.l0 * jnp.sin(alpha), vx, -p.g * t])
    return s, t


def apex_map(p: SlipParams, e_total, y_apex, alpha):
    """One step of the return map at fixed total energy e_total: apex height y_i -> y_{i+1}
    (nan where the step fails: no fall to touchdown, no lift-off or no upward lift-off)."""
    vx = jnp.sqrt(jnp.maximum(2.0 * (e_total / p.m - p.g * y_apex), 0.0))
    s_td, _ = touchdown_state(p, y_apex, vx, alpha)
    s_lo, _, ok = stance(p, s_td)
    y_next = s_lo[1] + jnp.square(jnp.maximum(s_lo[3], 0.0)) / (2.0 * p.g)
    good = ok & (s_lo[3] > 0) & (s_lo[2] > 0) & jnp.isfinite(s_td[3])
    return jnp.where(good, y_next, jnp.nan)


_apex_map_jit = jax.jit(apex_map)


def periodic_angle(p: SlipParams, gait: Gait, lo=np.deg2rad(50.0), hi=np.deg2rad(85.0)) -> float:
    """Landing angle of the periodic gait (f(y*, a) = y*), on the steep branch."""
    return deadbeat_angle(p, gait, gait.y_apex, lo, hi)


def deadbeat_angle(p: SlipParams, gait: Gait, y_i: float, lo=np.deg2rad(40.0), hi=np.deg2rad(88.0),
                   n_grid: int = 60) -> float:
    """Eq. (1): the landing angle returning the model from apex y_i to y* in one step (nan
    when none exists). Scans a grid for the sign change of f - y* nearest the steep end
    (the branch through the periodic gait) and refines it with Brent's method."""
    from scipy.optimize import brentq

    e = gait_energy(p, gait)
    hi = min(hi, float(np.arcsin(min(y_i / p.l0, 1.0))) - 1e-9)
    if hi <= lo:
        return float("nan")
    grid = np.linspace(lo, hi, n_grid)
    r = np.array([float(_apex_map_jit(p, e, y_i, a)) for a in grid]) - gait.y_apex
    for j in range(n_grid - 1, 0, -1):
        if np.isfinite(r[j]) and np.isfinite(r[j - 1]) and r[j] * r[j - 1] <= 0:
            return float(brentq(lambda a: float(_apex_map_jit(p, e, y_i, a)) - gait.y_apex,
                                grid[j - 1], grid[j], xtol=1e-12))
    return float("nan")


@pytree
class SwingPolicy:
    """a*(t) as a polynomial in time since apex, valid on [t_min, t_max] and held outside.
    coeffs: highest power first (numpy.polyval order)."""

    coeffs: jax.Array
    t_min: float
    t_max: float


def swing_policy(p: SlipParams, gait: Gait, dy: float = 0.3, n: int = 41, degree: int = 5):
    """Solve eq. (1) for apex heights y* + [-dy, dy] and fit a*(t). Returns (policy, samples)
    where samples = (y_i, t, a*) of the solvable heights."""
    ys = np.linspace(gait.y_apex - dy, gait.y_apex + dy, n)
    out = []
    for y in ys:
        a = deadbeat_angle(p, gait, float(y))
        if np.isfinite(a):
            t = np.sqrt(2.0 * max(y - p.l0 * np.sin(a), 0.0) / p.g)
            out.append((y, t, a))
    s = np.array(out)
    order = np.argsort(s[:, 1])
    s = s[order]
    coeffs = np.polyfit(s[:, 1], s[:, 2], degree)
    return SwingPolicy(jnp.asarray(coeffs), float(s[0, 1]), float(s[-1, 1])), s


@pytree
class PolicyTable:
    """a*(t) as the solved pairs themselves (t ascending): linear between them, held at the
    ends. Exact at its nodes, so on flat ground a run from the target apex lands on the
    periodic gait's own pair (:func:`policy_table`)."""

    t: jax.Array
    a: jax.Array


def policy_table(samples) -> PolicyTable:
    """The table of :func:`swing_policy`'s samples (y_i, t, a*), sorted by t."""
    s = np.asarray(samples)
    return PolicyTable(jnp.asarray(s[:, 1]), jnp.asarray(s[:, 2]))


def policy_angle(pol, t):
    """a*(t), t the time since apex (s); held at the ends of the fitted range (a
    :class:`SwingPolicy` polynomial, or a :class:`PolicyTable`)."""
    if isinstance(pol, PolicyTable):
        return jnp.interp(t, pol.t, pol.a)
    tc = jnp.clip(t, pol.t_min, pol.t_max)
    return jnp.polyval(pol.coeffs, tc)


def fit_error(p: SlipParams, gait: Gait, pol: SwingPolicy, samples) -> dict:
    """The polynomial's fit error a_poly(t) - a*(t) (rad) over the landing times it covers: at
    the solved samples and at the landing times of the apex heights halfway between neighbouring
    samples (eq. 1 solved there too): its largest size (``max_rad``), rms (``rms_rad``) and
    value at the periodic gait's own landing time (``gait_rad``, the sample nearest y*), with
    the range of landing times (``t_min_s``, ``t_max_s``) and the number of points."""
    s = np.asarray(samples)
    mid = []
    for y in 0.5 * (s[1:, 0] + s[:-1, 0]):
        a = deadbeat_angle(p, gait, float(y))
        if np.isfinite(a):
            mid.append((y, np.sqrt(2.0 * max(y - p.l0 * np.sin(a), 0.0) / p.g), a))
    pts = np.concatenate([s, np.asarray(mid).reshape(-1, 3)])
    err = np.polyval(np.asarray(pol.coeffs), np.clip(pts[:, 1], pol.t_min, pol.t_max)) - pts[:, 2]
    k = int(np.argmin(np.abs(s[:, 0] - gait.y_apex)))
    return dict(max_rad=float(np.max(np.abs(err))), rms_rad=float(np.sqrt(np.mean(err ** 2))),
                gait_rad=float(np.polyval(np.asarray(pol.coeffs), s[k, 1]) - s[k, 2]),
                t_min_s=float(np.min(pts[:, 1])), t_max_s=float(np.max(pts[:, 1])), points=int(len(pts)))


def policy_rate(pol: SwingPolicy, t):
    """d a*/dt (zero outside the fitted range)."""
    inside = (t > pol.t_min) & (t < pol.t_max)
    d = jnp.polyval(jnp.polyder(pol.coeffs), jnp.clip(t, pol.t_min, pol.t_max))
    return jnp.where(inside, d, 0.0)
