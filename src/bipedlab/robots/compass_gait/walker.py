"""One passive step of the compass gait, its Poincaré return map and the period-one gait.

Section: the post-impact state (just after the leg swap), ``x = [theta, psi, thetadot,
psidot]`` in the stance coordinates of :mod:`.model` (rad, rad/s). One step is the core's hybrid
stage :func:`bipedlab.sim.hybrid.flow_until_event` on :func:`transition`: the stance dynamics
flowed by RK4 with step ``H`` to the heel strike, located by secant iterations
(forward-mode differentiable including the event time), and the reset, the plastic impact
and the swap. Images of the map lie on the guard
(a 3-dimensional surface), so one eigenvalue of the 4x4 Jacobian is zero at the fixed point.
"""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.gait import poincare
from bipedlab.sim import OK, hybrid
from bipedlab.pytree import pytree

from bipedlab.robots.compass_gait import model as cg

#: RK4 step of the stance flow, s (global error ~1e-10 rad on a 0.7 s step).
H = 2e-3
#: A step that has not ended after this long counts as a fall, s.
MAX_TIME = 4.0

#: Post-impact guess of the 3-degree gait (near the fixed point; Newton converges from it).
GUESS = np.array([0.22, -0.54, -1.09, 0.71])


@pytree
class Step:
    """One step: post-impact state after the swap (4,), the pre-impact state (4,), step period
    (s), step vector between the feet (2,) m, impact impulse (2,) N s, kinetic energy before
    and after the impact (J), and the status code of the event location (``bipedlab.sim.OK``)."""

    z: jax.Array
    z_minus: jax.Array
    period: jax.Array
    step: jax.Array
    impulse: jax.Array
    ke_minus: jax.Array
    ke_plus: jax.Array
    status: jax.Array


# The hybrid pieces, jitted once with the parameters as an argument: inside the event loop
# every call is then one cached sub-computation (tracing the step drops from ~10 s to ~2 s).
_flow, _guard, _armed, _fell, _reset, _energy = (
    jax.jit(f) for f in (cg.flow, cg.guard, cg.armed, cg.fell, cg.reset, cg.energy))


def _impact(p, z):
    z_plus, impulse, vec, _ = _reset(p, z)
    return z_plus, (impulse, vec)


def transition(p: cg.CompassGaitParams) -> hybrid.Transition:
    """The heel strike as a :class:`bipedlab.sim.hybrid.Transition`: the passive stance flow
    (no input), the swing foot's height above the slope as the guard, armed once the swing
    foot is ahead, and the reset (impact and swap) reporting (impulse (2,) N s, step vector
    (2,) m)."""
    return hybrid.Transition(flow=lambda z, u: _flow(p, z), guard=lambda z: _guard(p, z),
                             armed=lambda z: _armed(p, z), reset=lambda z: _impact(p, z))


def step(p: cg.CompassGaitParams, z0, h: float = H) -> Step:
    """Flow from the post-impact state z0 to the next heel strike and reset it (where the step
    falls, the state stays the pre-impact one and the impulse and step vector are zeros)."""
    r, z_plus, (impulse, vec) = hybrid.flow_until_event(transition(p), z0, None, h, MAX_TIME,
                                                        fell=lambda z: _fell(p, z))
    ke_minus = _energy(p, r.z)[0]
    ke_plus = _energy(p, z_plus)[0]  # the new stance foot is pinned after the swap
    return Step(z_plus, r.z, r.t, vec, impulse, ke_minus, ke_plus, r.status)


def return_map(p: cg.CompassGaitParams, h: float = H):
    """The Poincaré map x -> P(x) on the post-impact section (a pure function)."""
    return lambda x: step(p, x, h).z


@dataclasses.dataclass(frozen=True)
class Gait:
    """A period-one passive gait. fixed_point: post-impact state (4,) [rad, rad, rad/s, rad/s];
    absolute: [stance angle, swing angle, rates] from the vertical; period: s; step_length:
    distance between the feet at impact (along the slope), m; speed: step_length / period, m/s;
    jacobian: exact (forward-mode) Jacobian of the return map (4, 4); fd_jacobian: its central
    differences; eigenvalues: of ``jacobian``, largest magnitude first; residual: max |P(x)-x|."""

    slope: float
    fixed_point: np.ndarray
    absolute: np.ndarray
    period: float
    step_length: float
    speed: float
    jacobian: np.ndarray
    fd_jacobian: np.ndarray
    eigenvalues: np.ndarray
    residual: float
    status: int

    @property
    def max_abs_eigenvalue(self) -> float:
        return float(np.max(np.abs(self.eigenvalues)))

    @property
    def stable(self) -> bool:
        return self.status == OK and self.max_abs_eigenvalue < 1.0

    @property
    def jacobian_error(self) -> float:
        """max |exact - central-difference Jacobian|."""
        return float(np.max(np.abs(self.jacobian - self.fd_jacobian)))


@jax.jit
def step_jit(p, z0):
    """:func:`step`, compiled once for every slope and start (the parameters are traced)."""
    return step(p, z0)


def period_one_gait(gamma: float = 3.0 * np.pi / 180.0, guess=None, iterations: int = 12,
                    fd_step: float = 1e-6, p: cg.CompassGaitParams | None = None) -> Gait:
    """Period-one gait on a slope gamma (rad): Newton (:func:`bipedlab.gait.poincare.fixed_point`,
    exact forward-mode Jacobian through the event) from ``guess`` (default :data:`GUESS`, which
    converges for slopes of 1 to 5 degrees), then the central-difference Jacobian
    (step ``fd_step``; 0 skips it) as a check. ``status`` is not OK if the step at the fixed
    point fell; check ``residual`` too before trusting the gait."""
    p = p if p is not None else cg.CompassGaitParams(slope=jnp.asarray(gamma, dtype=jnp.float64))
    P = return_map(p)
    x0 = GUESS if guess is None else np.asarray(guess, float)
    x, J, res = poincare.fixed_point(P, jnp.asarray(x0), iterations=iterations)
    s = step_jit(p, x)
    J = np.asarray(J)
    Jfd = poincare.central_differences(P, x, fd_step) if fd_step > 0 else np.full_like(J, np.nan)
    length = float(jnp.linalg.norm(s.step))
    period = float(s.period)
    return Gait(float(gamma), np.asarray(x), np.asarray(cg.absolute_angles(x)), period, length,
                length / period, J, Jfd, poincare.eigenvalues(J), res, int(s.status))
