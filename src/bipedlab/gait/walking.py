"""Closed-loop walking on the stance model: the step-to-step map, multi-step walks, and the
Poincaré analysis of both the full closed loop and the restricted (zero-dynamics) map.

The Poincaré section is the impact surface (swing toe on the ground): ``P(z-)`` applies the
impact and relabelling, then flows under the controller until the next touchdown, located
exactly (the core's hybrid stage :func:`bipedlab.sim.hybrid.flow_until_event` on the section
before the reset). Its Jacobian comes from forward-mode autodiff through the hybrid flow,
event-time sensitivity included. P maps a neighbourhood of the section into
the section, so the Jacobian has the restricted map's eigenvalues plus one zero. The restricted
map ``rho(thetadot-)`` lives on the zero dynamics (one degree of underactuation: one
eigenvalue).
"""
from __future__ import annotations

import dataclasses
import functools

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.control import hzd
from bipedlab.mechanics.stance import Stance, embed, impact, stance_affine, swing_height, swing_position
from bipedlab.gait.poincare import central_differences
from bipedlab.pytree import pytree
from bipedlab.sim import hybrid
from bipedlab.sim.rollout import FELL, OK


@functools.partial(jax.tree_util.register_dataclass, data_fields=["eps", "kp", "kd"], meta_fields=["kind"])
@dataclasses.dataclass(frozen=True)
class Controller:
    """kind: 'iolin' (eq. 42) or 'pd' (u* feedforward + PD on y); eps, kp, kd as in eq. 42
    for 'iolin'; for 'pd', u = u* - kp y - kd yd with kp N m/rad, kd N m s/rad.

    A pytree whose gains are its leaves and whose kind is static: the compiled programs below
    take the gains as traced inputs, so one program per kind serves every gain (and a batch of
    controllers, the gains stacked, is one ``vmap``)."""

    kind: str = "iolin"
    eps: float = 0.1
    kp: float = 1.0
    kd: float = 2.0


@jax.jit
def _iolin(vc, st, z, eps, kp, kd):
    return hzd.io_linearizing(vc, st, z, eps, kp, kd)


@jax.jit
def _pd(vc, st, z, kp, kd):
    return hzd.pd_control(vc, st, z, kp, kd)


@jax.jit
def _closed_loop(vc, st, z, u):
    a, b, _, _ = stance_affine(st, z)
    return jnp.concatenate([z[st.n:], a + b @ u])


@jax.jit
def _integrand(vc, st, z, u):
    y, _ = hzd.output_state(vc, st, z)
    act = jnp.asarray([i - 2 for i in st.model.actuated])
    return jnp.stack([y @ y, u @ u, jnp.sum(jnp.maximum(u * z[st.n:][act], 0.0))])


_swing_height = jax.jit(swing_height)


def control_law(vc: hzd.VirtualConstraints, st: Stance, ctrl: Controller):
    """u(z) of the chosen controller. The dynamics pieces are module-level jits taking the
    gait and model as arguments: traced once, reused at every call site in the loops."""
    if ctrl.kind == "iolin":
        return lambda z: _iolin(vc, st, z, ctrl.eps, ctrl.kp, ctrl.kd)
    if ctrl.kind == "pd":
        return lambda z: _pd(vc, st, z, ctrl.kp, ctrl.kd)
    raise ValueError(f"unknown controller {ctrl.kind!r}; choose 'iolin' or 'pd'")


@pytree
class Step:
    z_minus: jax.Array       # state at the next touchdown
    z_plus: jax.Array        # state after the impact that started the step
    duration: jax.Array      # s
    step_length: jax.Array   # m
    y_sq: jax.Array          # integral of |y|^2 dt
    u_sq: jax.Array          # integral of |u|^2 dt
    positive_work: jax.Array  # J
    status: jax.Array


MAX_STEP_TIME = 2.0
"""Seconds a step may last before the walk counts as fallen (the default ``max_time``)."""


def arming_phase(vc):
    """The phase (``vc.c @ q``) past which the touchdown is armed: the middle of the step."""
    return vc.theta_plus + 0.5 * (vc.theta_minus - vc.theta_plus)


def armed_at_start(vc, st: Stance, z_plus):
    """Whether a swing starts with the touchdown already armed (its phase past
    :func:`arming_phase`): a touchdown ending such a swing is not one the gait's event logic
    armed (after a large perturbation the foot comes down within milliseconds) and is no step."""
    return vc.c @ z_plus[..., :st.n] > arming_phase(vc)


def transition(vc, st: Stance, ctrl: Controller) -> hybrid.Transition:
    """The touchdown as a :class:`bipedlab.sim.hybrid.Transition`: the stance model in closed
    loop with the controller (the torque is a function of the state: no held input), the swing
    point's height as the guard, armed past the middle of the step in the phase variable, and
    the reset, the impact and relabelling, reporting (impulse (2,) N s, step vector (2,) m,
    velocity of the lifting foot (2,) m/s) of :func:`bipedlab.mechanics.stance.impact`."""
    u_of = control_law(vc, st, ctrl)
    mid = arming_phase(vc)

    def reset(z):
        zp, impulse, vec, lift = impact(st, z)
        return zp, (impulse, vec, lift)

    return hybrid.Transition(flow=lambda z, u: _closed_loop(vc, st, z, u_of(z)),
                             guard=lambda z: _swing_height(st, z), armed=lambda z: vc.c @ z[:st.n] > mid,
                             reset=reset)


def step(vc, st: Stance, ctrl: Controller, z_minus, h: float = 1e-3, max_time: float = MAX_STEP_TIME,
         min_height: float = 0.0) -> Step:
    """One step from a pre-impact state: impact, relabel, closed-loop flow to the next
    touchdown (:func:`bipedlab.sim.hybrid.flow_until_event` on :func:`transition`, the map of
    the pre-impact section). A swing that starts armed (:func:`armed_at_start`) ends as FELL:
    its touchdown is no step."""
    u_of = control_law(vc, st, ctrl)
    n = st.n

    def integrand(z):
        return _integrand(vc, st, z, u_of(z))

    def fell(z):
        q, _ = embed(st, z)
        return (q[1] < min_height) | (vc.c @ z[n:] <= 0.0)

    r, zp, _ = hybrid.flow_until_event(transition(vc, st, ctrl), z_minus, None, h, max_time, integrand, fell,
                                       section="pre")
    # a touchdown counts only if the swing crossed the arming phase: one armed from the start is spurious
    status = jnp.where((r.status == OK) & armed_at_start(vc, st, zp), FELL, r.status)
    return Step(r.z, zp, r.t, swing_position(st, r.z)[0], r.integrals[0], r.integrals[1],
                r.integrals[2], status)


def walk(vc, st: Stance, ctrl: Controller, z_minus, steps: int, h: float = 1e-3,
         max_time: float = MAX_STEP_TIME, min_height: float = 0.0) -> Step:
    """``steps`` consecutive steps (a Step of stacked arrays); after a failure the state is
    frozen and later steps carry the failing status."""

    def body(carry, _):
        z, status = carry
        s = step(vc, st, ctrl, z, h, max_time, min_height)
        status = jnp.where(status == OK, s.status, status)
        z = jnp.where(status == OK, s.z_minus, z)
        return (z, status), s.replace(status=status)

    _, out = jax.lax.scan(body, (jnp.asarray(z_minus), jnp.asarray(OK)), None, length=steps)
    return out


def outcome(w: Step, z_star) -> dict:
    """A walk's outcome for a robustness trial: the last step's status, the steps completed,
    the distance from the fixed point z_star at the last completed touchdown (NaN when none
    completed) and the distance walked, m."""
    ok = w.status == OK
    done = jnp.sum(ok)
    last = jnp.where(done > 0, done - 1, 0)
    return dict(status=w.status[-1], completed=done,
                final_deviation=jnp.where(done > 0, jnp.linalg.norm(w.z_minus[last] - z_star), jnp.nan),
                distance_m=jnp.sum(jnp.where(ok, w.step_length, 0.0)))


def poincare_jacobian(vc, st: Stance, ctrl: Controller, z_minus, h: float = 1e-3) -> jax.Array:
    """d P / d z- at z- by forward-mode autodiff through the hybrid flow."""
    return jax.jacfwd(lambda z: step(vc, st, ctrl, z, h).z_minus)(z_minus)


def poincare_step_and_jacobian(vc, st: Stance, ctrl: Controller, z_minus, h: float = 1e-3):
    """(the step P from z-, d P / d z- there): the map's value with its Jacobian, one
    forward-mode pass. A fixed point of the design is one of the closed loop only when the
    step returns to it (status OK, ``z_minus`` equal to z-, the duration the design's period):
    on Z the controller's gains do not act, so a step that ends elsewhere from the fixed point
    (a swing point grazing the ground mid-step touches down early) does so for every gain."""
    def value(z):
        s = step(vc, st, ctrl, z, h)
        return s.z_minus, s

    J, s = jax.jacfwd(value, has_aux=True)(z_minus)
    return s, J


#: compiled forms with the gait (virtual constraints), the model, the controller's gains and
#: the state traced: one program per controller kind, step count and time step serves every
#: gait and every gain of a robot
walk_program = jax.jit(walk, static_argnames=("steps", "h", "max_time", "min_height"))
poincare_program = jax.jit(poincare_jacobian, static_argnames=("h",))
poincare_step_program = jax.jit(poincare_step_and_jacobian, static_argnames=("h",))


def poincare_jacobian_fd(vc, st: Stance, ctrl: Controller, z_minus, h: float = 1e-3,
                         delta: float = 1e-6) -> np.ndarray:
    """Central finite differences of the same map (the check on the autodiff Jacobian)."""
    return central_differences(lambda z: step(vc, st, ctrl, z, h).z_minus, z_minus, delta, relative=False)


def restricted_map(vc, st: Stance, theta_dot_minus, nodes: int = 60):
    """rho: pre-impact phase rate -> next pre-impact phase rate, on the zero dynamics."""
    from bipedlab.gait.optimize import GaitProblem, integrate_zero_dynamics

    q, qd = hzd.lift(vc, vc.theta_minus, theta_dot_minus)
    zp, _, _, _ = impact(st, jnp.concatenate([q, qd]))
    prob = GaitProblem(st, vc.H0, vc.c, order=vc.order, nodes=nodes)  # H0, c may be traced
    wf = integrate_zero_dynamics(prob, vc, vc.c @ zp[st.n:], scan_stages=True)[0]
    return jnp.sqrt(jnp.maximum(2.0 * wf[0], 0.0))


@functools.partial(jax.jit, static_argnames=("nodes",))
def _restricted_slope(vc, st: Stance, theta_dot_minus, nodes: int):
    return jax.jacfwd(lambda t: restricted_map(vc, st, t, nodes))(theta_dot_minus)


def restricted_eigenvalue(vc, st: Stance, theta_dot_minus, nodes: int = 60) -> float:
    """d rho / d thetadot- at thetadot-: one compiled program per model and node count, the
    gait a traced argument."""
    return float(_restricted_slope(vc, st, jnp.asarray(theta_dot_minus, float), nodes))
