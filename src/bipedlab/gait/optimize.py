"""Fixed-point gait optimisation on the hybrid zero dynamics (Appendix B of the compliant-HZD
paper, for a robot with one degree of underactuation).

Decision variables: the pre-impact stance state ``(q-, qd-)`` and the free Bézier coefficients
``alpha[:, 2:M-1]``. The remaining coefficients follow from the state, which makes the zero
dynamics manifold invariant through the impact (hybrid invariance):

    alpha_M = H0 q-,   alpha_{M-1} = alpha_M - (dtheta / M) H0 qd- / thetadot-,
    (q+, qd+) = impact(q-, qd-),   alpha_0 = H0 q+,   alpha_1 = alpha_0 + (dtheta / M) H0 qd+ / thetadot+.

On Z the state is fixed by (theta, thetadot). The zero dynamics are integrated in the phase,
from theta+ to theta- with fixed RK4 steps on zeta = thetadot^2 / 2, together with time and the
cost integrands; the step then ends exactly on the guard (the swing toe is on the ground at
q-, an equality constraint), so no event location is needed, and periodicity is the single
equation thetadot(theta-) = thetadot-.

Costs: ``torque`` = integral of |u|^2 dt per step length (eq. 39); ``cmt`` = positive actuator
work per weight and distance (eqs. 40-41). Constraints: periodicity, swing toe on the ground at
the end and above it in between, positive normal force, |F_T / F_N| <= mu along the step and at
the impact, the lifting foot leaves the ground, walking speed; optionally a clearance of the
swing point over the step and a bound on the restricted Poincaré map's eigenvalue.
Derivatives are exact (JAX forward mode) and the NLP is solved by SciPy's SLSQP.

The restricted map's eigenvalue (``max_eigenvalue``). With one degree of underactuation the
restricted map rho(thetadot-) is scalar and its slope is its eigenvalue. On Z the decision
state is the lift of (theta-, thetadot-) (the end coefficients are derived from it), the
impact is linear in the rates (thetadot+ = delta thetadot-, delta = thetadot+ / thetadot- of
the candidate) and the design's own integration is the restricted map's, so

    d rho / d thetadot- = delta (d zeta- / d thetadot+) / sqrt(2 zeta-),

with d zeta- / d thetadot+ by forward mode (a ``jvp``) through the zero-dynamics integration;
the constraint's Jacobian is forward mode through that (the design's Jacobian program holds
both). At a periodic solution it is :func:`bipedlab.gait.walking.restricted_eigenvalue`.
"""
from __future__ import annotations

import collections
import dataclasses
import time

import jax
import jax.numpy as jnp
import numpy as np
import scipy.optimize

from bipedlab.control import hzd
from bipedlab.mechanics.dynamics import total_mass
from bipedlab.sim.integrators import rk4_t, rk4_t_scan
from bipedlab.mechanics.stance import Stance, impact, swing_height, swing_position


@dataclasses.dataclass(frozen=True)
class GaitProblem:
    """Static description of a gait design problem.

    stance: the stance model; H0 (m, n) and c (n,) define outputs and phase; order: Bézier
    order M; nodes: RK4 steps in the phase; speed: m/s; cost: 'torque' | 'cmt'; mu: friction
    ratio bound; clearance_window: fraction of the step at each end where the swing-toe
    height constraint is not imposed (the toe leaves and reaches the ground there);
    torque_limits: (m,) largest |u| per input at every node, N m (inf: none), or None;
    max_eigenvalue: bound R on |d rho / d thetadot-| of the restricted Poincaré map, or None
    (no constraint, and none of its computation in the programs); clearance: m, the swing
    point at least ``clearance * 4 s (1 - s)`` above the ground at every interior node
    (s the step's phase fraction: the bound is the clearance at mid-step and falls to zero at
    both ends), or 0 (only the windowed height >= 0 constraint)."""

    stance: Stance
    H0: np.ndarray
    c: np.ndarray
    order: int = 5
    nodes: int = 60
    speed: float = 0.8
    cost: str = "torque"
    mu: float = 0.6
    clearance_window: float = 0.1
    torque_limits: tuple | None = None
    max_eigenvalue: float | None = None
    clearance: float = 0.0

    def __hash__(self):
        return id(self)

    def __eq__(self, other):
        return self is other

    @property
    def n(self) -> int:
        return self.stance.n

    @property
    def m(self) -> int:
        return self.H0.shape[0]

    @property
    def n_free(self) -> int:
        return self.m * (self.order - 3)

    @property
    def size(self) -> int:
        return 2 * self.n + self.n_free


#: traced once, shared by every call site (RK4 stages, node samples, derivatives)
_zero_dynamics = jax.jit(hzd.zero_dynamics)


def unpack(prob: GaitProblem, x):
    n = prob.n
    return x[: 2 * n], x[2 * n:].reshape(prob.m, prob.order - 3)


def pack(z_minus, alpha_free) -> np.ndarray:
    return np.concatenate([np.asarray(z_minus), np.asarray(alpha_free).ravel()])


def constraints_from_state(prob: GaitProblem, z_minus, alpha_free):
    """(VirtualConstraints, z_plus, impact data) implied by the decision variables."""
    n, M = prob.n, prob.order
    H0, c = jnp.asarray(prob.H0), jnp.asarray(prob.c)
    qm, qdm = z_minus[:n], z_minus[n:]
    zp, impulse, step, lift = impact(prob.stance, z_minus)
    qp, qdp = zp[:n], zp[n:]
    th_m, th_p = c @ qm, c @ qp
    thd_m, thd_p = c @ qdm, c @ qdp
    w = th_m - th_p
    aM = H0 @ qm
    aM1 = aM - (w / M) * (H0 @ qdm) / thd_m
    a0 = H0 @ qp
    a1 = a0 + (w / M) * (H0 @ qdp) / thd_p
    alpha = jnp.concatenate([a0[:, None], a1[:, None], alpha_free, aM1[:, None], aM[:, None]], 1)
    vc = hzd.VirtualConstraints(H0, c, alpha, th_p, th_m)
    return vc, zp, dict(impulse=impulse, step=step, lift_velocity=lift)


def integrate_zero_dynamics(prob: GaitProblem, vc, theta_dot_plus, scan_stages: bool = False):
    """RK4 in theta from theta+ to theta- of [zeta, t, int |u|^2 dt, int positive power dt].

    Returns (final augmented state, nodes (N+1, 4), thetas (N+1,), samples) where samples =
    (u*, ground reaction, stance state) at the N+1 nodes, taken from the RK4 first stages.
    ``scan_stages``: the four RK4 stages as one scan over a single traced zero dynamics
    (:func:`bipedlab.sim.integrators.rk4_t_scan`): a program half the size that compiles in
    about two thirds of the time, for an evaluation made once (a restricted map); the design's
    evaluation and Jacobian, run at every solver iteration, keep the stages written out, which
    run twice as fast. The two agree to rounding (1e-15 relative)."""
    N = prob.nodes
    act = jnp.asarray([i - 2 for i in prob.stance.model.actuated])
    thetas = vc.theta_plus + (vc.theta_minus - vc.theta_plus) * jnp.arange(N + 1) / N
    hstep = (vc.theta_minus - vc.theta_plus) / N

    def g(theta, w):
        thd = jnp.sqrt(jnp.maximum(2.0 * w[0], 1e-12))
        thdd, u, grf, z = _zero_dynamics(vc, prob.stance, theta, thd)
        power = u * z[prob.n:][act]
        d = jnp.stack([thdd, 1.0 / thd, (u @ u) / thd, jnp.sum(jnp.maximum(power, 0.0)) / thd])
        return d, (u, grf, z)

    def body(w, theta):
        wn, sample = (rk4_t_scan if scan_stages else rk4_t)(g, theta, w, hstep)
        return wn, (wn, sample)

    w0 = jnp.stack([0.5 * theta_dot_plus**2, 0.0, 0.0, 0.0])
    wf, (ws, samples) = jax.lax.scan(body, w0, thetas[:-1])
    last = g(thetas[-1], wf)[1]
    samples = jax.tree_util.tree_map(lambda a, b: jnp.concatenate([a, b[None]], 0), samples, last)
    return wf, jnp.concatenate([w0[None], ws], 0), thetas, samples


def evaluate(prob: GaitProblem, x):
    """All quantities of a candidate gait: cost, constraint vectors and metrics (a dict)."""
    z_minus, alpha_free = unpack(prob, x)
    vc, zp, imp = constraints_from_state(prob, z_minus, alpha_free)
    n = prob.n
    thd_p = vc.c @ zp[n:]
    thd_m = vc.c @ z_minus[n:]
    if prob.max_eigenvalue is None:
        wf, ws, thetas, (u, grf, zs) = integrate_zero_dynamics(prob, vc, thd_p)
        slope = None
    else:
        def final_zeta(t):
            out = integrate_zero_dynamics(prob, vc, t)
            return out[0][0], out

        _, dzeta, (wf, ws, thetas, (u, grf, zs)) = jax.jvp(final_zeta, (thd_p,), (jnp.ones_like(thd_p),),
                                                           has_aux=True)
        slope = (thd_p / thd_m) * dzeta / jnp.sqrt(jnp.maximum(2.0 * wf[0], 1e-12))
    zeta = ws[:, 0]
    thd = jnp.sqrt(jnp.maximum(2.0 * zeta, 1e-12))
    heights = jax.vmap(lambda z: swing_height(prob.stance, z))(zs)
    step_length = swing_position(prob.stance, z_minus)[0]
    T = wf[1]
    mg = total_mass(prob.stance.model) * prob.stance.model.gravity
    torque_cost = wf[2] / step_length
    cmt = wf[3] / (mg * step_length)
    cost = torque_cost if prob.cost == "torque" else cmt
    N = prob.nodes
    k0 = int(np.ceil(prob.clearance_window * N))
    mu = prob.mu
    eq = jnp.stack([
        10.0 * swing_height(prob.stance, z_minus),
        wf[0] - 0.5 * thd_m**2,
        step_length / T - prob.speed,
    ])
    ineq = jnp.concatenate([
        grf[:, 1] / mg,                                    # normal force positive
        (mu * grf[:, 1] - jnp.abs(grf[:, 0])) / mg,        # inside the friction cone
        10.0 * heights[k0: N + 1 - k0],                    # swing toe above the ground
        zeta - 0.02,                                       # the phase keeps increasing
        jnp.stack([
            imp["lift_velocity"][1],                       # old stance foot lifts off
            imp["impulse"][1],                             # ground pushes at impact
            mu * imp["impulse"][1] - jnp.abs(imp["impulse"][0]),
            vc.theta_minus - vc.theta_plus - 0.05,
            step_length - 0.1,
            thd_m,
        ]),
    ])
    if prob.torque_limits is not None:
        lim = np.asarray(prob.torque_limits, float)
        bounded = np.flatnonzero(np.isfinite(lim))
        if bounded.size:                                   # |u| within the actuators' limits
            r = u[:, bounded] / lim[bounded]
            ineq = jnp.concatenate([ineq, (1.0 - r).ravel(), (1.0 + r).ravel()])
    if prob.clearance > 0.0:                               # the swing point clears the ground
        s = np.arange(1, N) / N
        ineq = jnp.concatenate([ineq, 10.0 * (heights[1:N] - prob.clearance * 4.0 * s * (1.0 - s))])
    if slope is not None:                                  # |restricted eigenvalue| <= R
        R = prob.max_eigenvalue
        ineq = jnp.concatenate([ineq, jnp.stack([R - slope, R + slope])])
    metrics = dict(
        vc=vc, z_plus=zp, z_minus=z_minus, step_length=step_length, period=T,
        speed=step_length / T, torque_cost=torque_cost, cmt=cmt, thetas=thetas,
        theta_dot=thd, u=u, grf=grf, swing_heights=heights, states=zs, impulse=imp["impulse"],
    )
    if slope is not None:
        metrics["restricted_slope"] = slope
    return cost, eq, ineq, metrics


#: compiled functions of the most recent problems (a sweep builds many; each holds a program)
_COMPILED: "collections.OrderedDict" = collections.OrderedDict()
_COMPILED_KEEP = 8


def _compiled(prob: GaitProblem, kind: str, make):
    key = (id(prob), kind)
    hit = _COMPILED.get(key)
    if hit is None or hit[0] is not prob:
        hit = _COMPILED[key] = (prob, make())
        while len(_COMPILED) > _COMPILED_KEEP * 2:
            _COMPILED.popitem(last=False)
    _COMPILED.move_to_end(key)
    return hit[1]


def evaluator(prob: GaitProblem):
    """``jit(evaluate(prob, .))``, compiled once per problem: the solver's values, its scale
    and the final metrics all come from this one program (each separate ``jit`` of the same
    evaluation would compile the whole zero-dynamics integration again)."""
    return _compiled(prob, "evaluate", lambda: jax.jit(lambda x: evaluate(prob, x)))


def _scalar_problem(prob: GaitProblem, cost_scale: float):
    """(values, Jacobian) of [cost / cost_scale, eq, ineq]: the values from :func:`evaluator`,
    the Jacobian by forward mode (``cost_scale`` a traced argument, so a new scale does not
    compile again)."""
    ev = evaluator(prob)

    def f(x):
        cost, eq, ineq = jax.device_get(ev(x)[:3])  # one transfer
        return np.concatenate([[float(cost) / cost_scale], eq, ineq])

    def vec(x, scale):
        cost, eq, ineq, _ = evaluate(prob, x)
        return jnp.concatenate([(cost / scale)[None], eq, ineq])

    jac = _compiled(prob, "jacobian", lambda: jax.jit(jax.jacfwd(vec)))
    return f, lambda x: jac(x, np.float64(cost_scale))


@dataclasses.dataclass
class OptimizeResult:
    x: np.ndarray
    success: bool
    message: str
    iterations: int
    warm_s: float
    cold_s: float
    cost: float
    max_eq_violation: float
    min_ineq: float


def solve(prob: GaitProblem, x0, tol: float = 1e-10, maxiter: int = 300, warm_start_runs: int = 1) -> OptimizeResult:
    """Solve with SLSQP. ``cold_s`` includes compilation; ``warm_s`` re-solves from x0 with
    the compiled functions (what a sweep or a re-design costs)."""
    x0 = np.asarray(x0, float)
    t0 = time.perf_counter()
    cost0 = float(evaluator(prob)(jnp.asarray(x0))[0])
    f, jf = _scalar_problem(prob, max(abs(cost0), 1e-9))
    ne = 3

    def run():
        cache: dict = {}

        def vals(x):  # values only: line-search trial points need no derivatives
            key = ("f", x.tobytes())
            if key not in cache:
                cache[key] = f(x)  # a NumPy argument goes to the program without an eager copy
            return cache[key]

        def jac(x):
            key = ("j", x.tobytes())
            if key not in cache:
                cache[key] = np.asarray(jf(x))
            return cache[key]

        cons = [
            dict(type="eq", fun=lambda x: vals(x)[1:1 + ne], jac=lambda x: jac(x)[1:1 + ne]),
            dict(type="ineq", fun=lambda x: vals(x)[1 + ne:], jac=lambda x: jac(x)[1 + ne:]),
        ]
        return scipy.optimize.minimize(
            lambda x: vals(x)[0], x0, jac=lambda x: jac(x)[0], method="SLSQP",
            constraints=cons, options=dict(maxiter=maxiter, ftol=tol),
        )

    res = run()
    cold = time.perf_counter() - t0
    warm = float("inf")
    for _ in range(warm_start_runs):
        t1 = time.perf_counter()
        res = run()
        warm = min(warm, time.perf_counter() - t1)
    v = np.asarray(f(jnp.asarray(res.x)))
    return OptimizeResult(
        x=res.x, success=bool(res.success), message=str(res.message), iterations=int(res.nit),
        warm_s=warm, cold_s=cold, cost=float(v[0] * max(abs(cost0), 1e-9)),
        max_eq_violation=float(np.max(np.abs(v[1:1 + ne]))), min_ineq=float(np.min(v[1 + ne:])),
    )


def initial_guess(prob: GaitProblem, z_minus) -> np.ndarray:
    """Decision vector from a pre-impact state, with the free Bézier coefficients placed on
    the straight line between the derived end coefficients."""
    z_minus = jnp.asarray(z_minus)
    M = prob.order
    dummy = jnp.zeros((prob.m, M - 3))
    vc, _, _ = constraints_from_state(prob, z_minus, dummy)
    a1, aM1 = vc.alpha[:, 1], vc.alpha[:, M - 1]
    free = a1[:, None] + (aM1 - a1)[:, None] * ((jnp.arange(2, M - 1) - 1) / (M - 2.0))[None, :]
    return pack(z_minus, free)


__all__ = ["GaitProblem", "evaluate", "solve", "initial_guess", "pack", "unpack",
           "constraints_from_state", "integrate_zero_dynamics", "OptimizeResult"]
