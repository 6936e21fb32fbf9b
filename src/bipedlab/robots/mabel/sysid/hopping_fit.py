"""Cable stretch, hard stop and ground from hopping data (Section VIII-C), by nonlinear least
squares on simulated-versus-measured encoders with JAX Jacobians.

Two stages, each ``scipy.optimize.least_squares`` with the exact forward-mode Jacobian of the
simulation:

1. :func:`fit_cable` - per motor, the cable's stiffness K_C and damping Kd_C (eq. 27) from
   the motor's own equation (:func:`bipedlab.robots.mabel.sysid.rigs.rotor_cable`): the rotor driven by its
   command and pulled by the cable, whose far end follows the joint encoders. With K_T, alpha,
   friction and bias from the earlier steps this is the 13-DoF model's equation for q_m,
   exactly, so the fit does not depend on the ground or the hard stop; it compares the
   simulated and measured motor encoder over the whole log.
2. :func:`fit_hopping` - the 13-DoF model replayed open loop under the logged commands from
   the release (at rest), everything identified so far fixed, over the spring damping and hard
   stop of eq. 30 (Kd_B, K_d1, K_vd1, K_vd2) and the ground's normal stiffness and damping and
   its friction (bristle stiffness sigma_0, Coulomb level), starting from the published values
   with a weak log-normal prior towards them. The log starts with the robot held at rest; the
   replay starts at the release from the readings averaged over that rest (encoder noise
   dithers the quantisation away), and the model's torso centre of mass is the one the
   balance experiments give (Section VI). The fit is continued over growing windows (landing
   and stance first, then the whole log: the switches of the hard stop make the cost rough at
   small scales), within a factor ``bound`` of the start. Residuals are joint-side angles in
   encoder counts: motor angles over their gear ratios, hip position over 1 m. An offset of
   the initial hip height can be fitted as a nuisance (``fit_height``).

Identifiability is reported, not assumed: each estimate comes with a 1-sigma relative error
from the data alone, combining the Jacobian's ``sqrt(diag((J^T J)^-1) s^2)`` (s^2 the residual
variance, inflated by the residuals' correlation time) with the spread that the uncertainty of
the initial state causes (each initial coordinate shifted by its standard error and the change
mapped through the fit); a parameter whose relative error exceeds ``IDENTIFIABLE`` is flagged
as not identified by these data.
"""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
from scipy import optimize

from bipedlab.robots.mabel import dynamics as md
from bipedlab.robots.mabel import model as mm
from bipedlab.robots.mabel import tables as tb
from bipedlab.robots.mabel.sysid import params as P
from bipedlab.robots.mabel.sysid import rigs
from bipedlab.robots.mabel.sysid.experiments import HOP_DT, HOP_SUBSTEPS
from bipedlab.robots.mabel.sysid.logs import HOP_ENCODERS, Experiment, motor_encoder

#: Index of each 13-DoF coordinate.
INDEX = {c: i for i, c in enumerate(mm.COORDS_13)}
_H = INDEX
#: A parameter counts as identified when its 1-sigma relative error is below this.
IDENTIFIABLE = 0.1
#: Variables of stage 2: (name, how it is applied), all positive (fitted in log scale).
HOP_VARIABLES = ("spring_d", "kd1", "kvd1", "kvd2", "ground_stiffness", "ground_damping",
                 "ground_bristle_stiffness", "ground_coulomb")
_GEAR = {"mla": abs(tb.GEAR_LA), "mls": tb.GEAR_LS}


def standard_errors(J, r, rows: int | None = None) -> np.ndarray:
    """1-sigma standard errors of least-squares variables from the Jacobian J and residuals
    r: ``sqrt(diag((J^T J)^-1) s^2)``; a direction the data do not see gives infinity."""
    J = np.asarray(J, float)
    rows = len(r) if rows is None else rows
    s2 = float(np.sum(np.asarray(r) ** 2) / max(rows - J.shape[1], 1))
    U, sv, Vt = np.linalg.svd(J, full_matrices=False)
    tol = sv.max() * 1e-12 if sv.size and sv.max() > 0 else 0.0
    var = np.zeros(J.shape[1])
    for k, v in enumerate(sv):
        contrib = Vt[k] ** 2 / v**2 if v > tol else np.where(np.abs(Vt[k]) > 1e-9, np.inf, 0.0)
        var = var + contrib
    return np.sqrt(var * s2)


def _std(sol) -> np.ndarray:
    return standard_errors(sol.jac, sol.fun)


def correlation_time(r, rows: int) -> float:
    """Integrated autocorrelation time (samples) of residuals laid out as (rows, channels):
    1 + 2 sum of the autocorrelations up to the first negative one, averaged over the
    channels by their energy. Least-squares errors computed as if residuals were white are
    too small by its square root when the residuals are smooth (model error, not noise)."""
    R = np.asarray(r, float)[: rows * 13].reshape(rows, -1)
    total, weight = 0.0, 0.0
    for c in range(R.shape[1]):
        x = R[:, c] - R[:, c].mean()
        e = float(x @ x)
        if e <= 0.0:
            continue
        f = np.fft.rfft(x, 2 * len(x))
        ac = np.fft.irfft(f * np.conj(f))[: len(x)] / e
        neg = np.flatnonzero(ac < 0.0)
        cut = int(neg[0]) if neg.size else len(ac)
        total += e * (1.0 + 2.0 * float(np.sum(ac[1:cut])))
        weight += e
    return max(total / weight, 1.0) if weight else 1.0


def release_index(exp: Experiment) -> int:
    """Row at which a hopping log's robot is released (rows before it: held at rest)."""
    return int(round(float(exp.meta.get("release_s", 0.0)) / 1e-3))


def initial_sd(exp: Experiment, bits: int = 14) -> np.ndarray:
    """Standard error (13,) of :func:`initial_coordinates`: the spread of the rest readings over
    the square root of their number; where the readings never change (no noise dithers the
    quantisation), a quantisation step (of a ``bits`` encoder) over sqrt(12)."""
    r = release_index(exp)
    q = measured_coordinates(exp)[: r + 1]
    quantum = 2.0 * np.pi / 2**bits * np.where(np.arange(13) < 2, tb.BOOM["radius"], 1.0)
    sd = q.std(axis=0, ddof=1) / np.sqrt(len(q)) if len(q) > 1 else np.zeros(13)
    return np.where(sd > 0, sd, quantum / np.sqrt(12.0))


def initial_coordinates(exp: Experiment) -> np.ndarray:
    """The 13 coordinates at release: the readings averaged over the rest before it."""
    r = release_index(exp)
    return measured_coordinates(exp)[: r + 1].mean(axis=0)


# ----- stage 1: cables ----------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class CableFit:
    """Per actuator: cable stiffness (N m/rad) and damping (N m s/rad) at the motor, their
    1-sigma relative errors, and the rms of the motor-encoder residual (deg, motor side)."""

    actuator: str
    stiffness: float
    damping: float
    stiffness_rel_std: float
    damping_rel_std: float
    rms_deg: float


def cable_inputs(exp: Experiment, actuator: str):
    """(u, r, tor, q_m) of one motor from a hopping log, from its release on: command,
    rigid-cable motor angle from the joint encoders, torso angle, motor encoder."""
    s = actuator[-1]
    k = release_index(exp)
    la, ls, bsp = (np.asarray(exp.enc[f"{c}_{s}"])[k:] for c in ("la", "ls", "bsp"))
    r = rigs.rigid_motor_angle(actuator, la, ls, bsp)
    return (np.asarray(exp.u[actuator])[k:], np.asarray(r), np.asarray(exp.enc["tor"])[k:],
            np.asarray(exp.enc[motor_encoder(actuator)])[k:])


def rotor_cable_params(p: P.MabelParams, actuator: str, K=None, D=None) -> rigs.RotorCable:
    k = P.actuator_index(actuator)
    f = lambda v: jnp.asarray(float(v))  # noqa: E731
    limit = tb.TORQUE_CAPACITY[actuator[:3]]
    return rigs.RotorCable(J=f(p.alpha[k] * P.rotor_inertia_manufacturer(actuator)), kt=f(p.kt[k]), bias=f(p.bias[k]),
                           mu=f(p.friction[k]), K=f(p.cable_k[k] if K is None else K),
                           D=f(p.cable_d[k] if D is None else D), limit=f(limit))


def _cable_residual(logkd, rc, u, r, tor, qm, substeps):
    rc = rc.replace(K=jnp.exp(logkd[0]), D=jnp.exp(logkd[1]))
    return rigs.rotor_cable(rc, u, r, tor, qm[0], substeps)[1:] - qm[1:]


def _cable_both(logkd, rc, u, r, tor, qm, substeps):
    res = _cable_residual(logkd, rc, u, r, tor, qm, substeps)
    return res, res


_cable_jac = jax.jit(jax.jacfwd(_cable_both, has_aux=True), static_argnames=("substeps",))
_rotor_cable = jax.jit(rigs.rotor_cable, static_argnames=("substeps", "h"))


def fit_cable(exp: Experiment, p: P.MabelParams, actuator: str, guess=(1.0, 0.05), substeps: int = 4) -> CableFit:
    """Stage 1 for one motor: K_C, Kd_C from the hopping log, starting from ``guess``
    (N m/rad, N m s/rad); K_T, alpha, bias and friction are taken from p."""
    u, r, tor, qm = (jnp.asarray(v) for v in cable_inputs(exp, actuator))
    qm = qm.at[0].set(_rest_mean(exp, motor_encoder(actuator)))
    rc = rotor_cable_params(p, actuator)
    cache = {}

    def evaluate(z):
        key = np.asarray(z).tobytes()
        if key not in cache:
            J, res = _cable_jac(jnp.asarray(z), rc, u, r, tor, qm, substeps)
            cache.clear()
            cache[key] = (np.asarray(res), np.asarray(J))
        return cache[key]

    sol = optimize.least_squares(lambda z: evaluate(z)[0], np.log(np.asarray(guess, float)),
                                 jac=lambda z: evaluate(z)[1], method="lm", xtol=1e-12, ftol=1e-12, gtol=1e-12,
                                 max_nfev=100)
    std = _std(sol)
    K, D = np.exp(sol.x)
    return CableFit(actuator, float(K), float(D), float(std[0]), float(std[1]),
                    float(np.rad2deg(np.sqrt(np.mean(sol.fun**2)))))


def _rest_mean(exp: Experiment, encoder: str) -> float:
    """An encoder's reading at release, averaged over the rest before it."""
    return float(np.mean(np.asarray(exp.enc[encoder])[: release_index(exp) + 1]))


def simulate_cable(exp: Experiment, p: P.MabelParams, actuator: str, substeps: int = 4) -> np.ndarray:
    """Motor angle (N,) the rotor-and-cable model predicts with p's values; with the measured
    joint side it gives the cable stretch the model predicts (Fig. 23)."""
    u, r, tor, qm = cable_inputs(exp, actuator)
    return np.asarray(_rotor_cable(rotor_cable_params(p, actuator), jnp.asarray(u), jnp.asarray(r), jnp.asarray(tor),
                                   _rest_mean(exp, motor_encoder(actuator)), substeps))


def measured_stretch(exp: Experiment, actuator: str) -> np.ndarray:
    """Cable stretch (rad, motor side) read from the encoders: motor minus rigid-cable angle."""
    _, r, _, qm = cable_inputs(exp, actuator)
    return qm - r


# ----- stage 2: hard stop and ground --------------------------------------------------------
def measured_coordinates(exp: Experiment) -> np.ndarray:
    """The 13-DoF coordinates (N, 13) read from a hopping log's encoders."""
    R = float(exp.meta.get("boom_radius", tb.BOOM["radius"]))
    n = len(exp.t)
    q = np.zeros((n, 13))
    for c in HOP_ENCODERS:
        v = np.asarray(exp.enc[c], float)
        if c == "boom_h":
            q[:, _H["x"]] = R * v
        elif c == "boom_v":
            q[:, _H["y"]] = R * v
        else:
            q[:, _H[c]] = v
    return q


def residual_scale() -> np.ndarray:
    """Per coordinate, the divisor that makes residuals joint-side radians."""
    s = np.ones(13)
    for c, i in _H.items():
        if c[:3] in _GEAR:
            s[i] = _GEAR[c[:3]]
    return s


def _apply(m: mm.Mabel, values: dict) -> mm.Mabel:
    d, g = m.drive, m.ground
    d = d.replace(**{k: values[k] for k in ("spring_d", "kd1", "kvd1", "kvd2") if k in values})
    gv = {}
    if "ground_stiffness" in values:
        gv["stiffness"] = values["ground_stiffness"]
    if "ground_damping" in values:
        gv["damping_in"] = gv["damping_out"] = values["ground_damping"]
    if "ground_bristle_stiffness" in values:
        gv["bristle_stiffness"] = values["ground_bristle_stiffness"]
    if "ground_coulomb" in values:
        gv["coulomb"] = values["ground_coulomb"]
    return m.replace(drive=d, ground=g.replace(**gv))


def hop_values(p: P.MabelParams) -> dict:
    """The stage-2 variables' values in a parameter set."""
    return dict(spring_d=p.spring_d, kd1=p.kd1, kvd1=p.kvd1, kvd2=p.kvd2, ground_stiffness=p.ground["stiffness"],
                ground_damping=p.ground["damping_in"], ground_bristle_stiffness=p.ground["bristle_stiffness"],
                ground_coulomb=p.ground["coulomb"])


def with_hop_values(p: P.MabelParams, values: dict) -> P.MabelParams:
    g = dict(p.ground)
    g.update(stiffness=values["ground_stiffness"], damping_in=values["ground_damping"],
             damping_out=values["ground_damping"], bristle_stiffness=values["ground_bristle_stiffness"],
             coulomb=values["ground_coulomb"])
    return p.replace(spring_d=values["spring_d"], kd1=values["kd1"], kvd1=values["kvd1"], kvd2=values["kvd2"], ground=g)


def replay(m: mm.Mabel, x0, U) -> jax.Array:
    """Coordinates (N, 13) at t_0..t_N-1 of the model from x0 under held commands U (N, 4)."""

    def sample(x, u):
        xn = jax.lax.fori_loop(0, HOP_SUBSTEPS, lambda _, x: md.step(m, x, u, HOP_DT), x)
        return xn, x[:13]

    return jax.lax.scan(sample, x0, U)[1]


def initial_state(q0, dy0: float = 0.0) -> jax.Array:
    """At rest at the first readings (hip height shifted by dy0), bristles relaxed."""
    q = jnp.asarray(q0).at[_H["y"]].add(dy0)
    return jnp.concatenate([q, jnp.zeros(13), jnp.zeros(2)])


def _hop_residual(z, dq0, names, base, q_meas, U, weights, scale):
    """Weighted joint-side residuals (N-1, 13) for log-values z of names and dy0 = z[-1] mm,
    the initial coordinates shifted by dq0 (13,)."""
    values = {n: jnp.exp(z[i]) for i, n in enumerate(names)}
    m = _apply(base, values)
    q = replay(m, initial_state(q_meas[0] + dq0, 1e-3 * z[-1]), U)
    return (((q[1:] - q_meas[1:]) / scale) * weights[1:, None]).ravel()


def _hop_both(z, dq0, names, base, q_meas, U, weights, scale):
    r = _hop_residual(z, dq0, names, base, q_meas, U, weights, scale)
    return r, r


_hop_jac = jax.jit(jax.jacfwd(_hop_both, has_aux=True), static_argnames=("names",))
_hop_res = jax.jit(_hop_residual, static_argnames=("names",))


@dataclasses.dataclass(frozen=True)
class HopFit:
    """Stage 2: fitted values and their 1-sigma relative errors from the data alone (the
    prior left out), the prior (the starting values), the fitted initial hip-height offset
    (mm), the rms joint-side residual (deg) and the function evaluations per window."""

    values: dict
    rel_std: dict
    prior: dict
    dy0_mm: float
    rms_deg: float
    nfev: list

    def identified(self, name: str) -> bool:
        return bool(self.rel_std[name] < IDENTIFIABLE)


def fit_hopping(exp: Experiment, p: P.MabelParams, prior: dict | None = None, variables=HOP_VARIABLES,
                windows=(0.6, 1.0), prior_sd=float(np.log(3.0)), sigma: float = 2.0 * np.pi / 2**14,
                bound: float = 10.0, max_nfev: int = 8, fit_height: bool = False, free=None,
                progress=None) -> HopFit:
    """Stage 2: the variables of eq. 30 and the ground by replaying the hopping log on the
    13-DoF model built from p (its other values fixed).

    The fit starts from, and is gently pulled towards, ``prior`` (default: p's values): a
    log-normal prior of ``prior_sd`` (a factor 3) per variable, weighed against residuals
    counted in units of ``sigma`` (rad, an encoder count). Data that determine a variable
    override it; for one they do not, the estimate stays near the prior, and the reported
    relative error (from the data alone) says so. prior_sd may also be a dict per variable
    (a tiny value pins a variable at its prior). windows: fractions of the log fitted in
    turn; bound: the estimates stay within this factor of the prior; fit_height: also fit an
    offset of the initial hip height (within +-5 mm); free: the variables to fit (default all),
    the others held at their prior values (their errors are still reported)."""
    say = progress or (lambda msg: None)
    names = tuple(variables)
    base = P.model(p)
    start = dict(hop_values(p))
    start.update(prior or {})
    k0 = release_index(exp)
    q_meas = np.asarray(measured_coordinates(exp))[k0:]
    q_meas[0] = initial_coordinates(exp)
    q_meas = jnp.asarray(q_meas)
    U = jnp.asarray(exp.U(P.ACTUATORS)[k0:])
    scale = jnp.asarray(residual_scale() * sigma)
    n = len(q_meas)
    zp = np.log([start[k] for k in names])
    z = np.concatenate([zp, [0.0]])
    dy = 5.0 if fit_height else 1e-9
    lo = np.concatenate([zp - np.log(bound), [-dy]])
    hi = np.concatenate([zp + np.log(bound), [dy]])
    nv = len(names)
    psd = np.array([prior_sd[k] for k in names], float) if isinstance(prior_sd, dict) else np.full(nv, float(prior_sd))
    fit = [i for i, k in enumerate(names) if free is None or k in free] + ([nv] if fit_height else [])
    fit = np.array(fit, int)
    prior_fit = [j for j, i in enumerate(fit) if i < nv]
    nfevs = []
    zero13 = jnp.zeros(13)
    for frac in windows:
        weights = jnp.asarray((np.arange(n) < frac * n).astype(float))
        cache = {}

        def evaluate(zf, weights=weights, cache=cache):
            key = np.asarray(zf).tobytes()
            if key not in cache:
                zz = z.copy()
                zz[fit] = zf
                J, res = _hop_jac(jnp.asarray(zz), zero13, names, base, q_meas, U, weights, scale)
                J = np.asarray(J)
                prior_r = (zz[fit[prior_fit]] - zp[fit[prior_fit]]) / psd[fit[prior_fit]]
                prior_J = np.zeros((len(prior_fit), len(fit)))
                prior_J[np.arange(len(prior_fit)), prior_fit] = 1.0 / psd[fit[prior_fit]]
                cache.clear()
                cache[key] = (np.concatenate([np.asarray(res), prior_r]), np.concatenate([J[:, fit], prior_J]),
                              J, np.asarray(res))
            return cache[key]

        say(f"hopping fit (hard stop, ground) over the first {frac * n * 1e-3:.2f} s of the log")
        sol = optimize.least_squares(lambda zf: evaluate(zf)[0], np.clip(z[fit], lo[fit] + 1e-9, hi[fit] - 1e-9),
                                     jac=lambda zf: evaluate(zf)[1], method="trf", bounds=(lo[fit], hi[fit]),
                                     max_nfev=max_nfev, xtol=1e-10, ftol=1e-10)
        z[fit] = sol.x
        nfevs.append(int(sol.nfev))
    _, _, J_all, rd = evaluate(sol.x)
    Jd = J_all
    rows = int(np.sum(np.asarray(weights) > 0) - 1) * 13
    cols = list(range(nv)) + ([nv] if fit_height else [])
    std_noise = standard_errors(Jd[:, cols], rd, rows)[:nv] * np.sqrt(correlation_time(rd, n - 1))
    # what the uncertainty of the initial state does to the estimates: shift each initial
    # coordinate by its standard error, re-evaluate, and map the change through the fit
    sd0 = initial_sd(exp)
    pinv = np.linalg.pinv(Jd[:, cols])
    shifts = []
    for i in range(13):
        dq = jnp.zeros(13).at[i].set(sd0[i])
        dr = np.asarray(_hop_res(jnp.asarray(z), dq, names, base, q_meas, U, weights, scale)) - rd
        shifts.append((pinv @ dr)[:nv])
    std_init = np.sqrt(np.sum(np.square(shifts), axis=0))
    std = np.sqrt(std_noise**2 + std_init**2)
    values = {k: float(np.exp(z[i])) for i, k in enumerate(names)}
    rel_std = {k: float(std[i]) for i, k in enumerate(names)}   # log-scale std = relative std
    rms = float(np.rad2deg(sigma * np.sqrt(np.sum(rd**2) / max(rows, 1))))
    return HopFit(values, rel_std, {k: float(start[k]) for k in names}, float(z[-1]), rms, nfevs)


def replay_log(exp: Experiment, p: P.MabelParams, dy0_mm: float = 0.0) -> np.ndarray:
    """Coordinates (N - release, 13) the 13-DoF model of p predicts for a hopping log, open
    loop from its release (at rest at the averaged readings, hip height shifted by dy0)."""
    base = P.model(p)
    k0 = release_index(exp)
    q_meas = np.asarray(measured_coordinates(exp))[k0:]
    q_meas[0] = initial_coordinates(exp)
    values = hop_values(p)
    z = jnp.asarray(np.concatenate([np.log([values[k] for k in HOP_VARIABLES]), [dy0_mm]]))
    n = len(q_meas)
    r = _hop_res(z, jnp.zeros(13), HOP_VARIABLES, base, jnp.asarray(q_meas), jnp.asarray(exp.U(P.ACTUATORS)[k0:]),
                 jnp.ones(n), jnp.ones(13))
    out = q_meas.copy()
    out[1:] += np.asarray(r).reshape(n - 1, 13)
    return out
