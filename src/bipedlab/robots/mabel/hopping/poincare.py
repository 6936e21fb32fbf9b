"""Poincaré analysis of MABEL's hopping (identification paper, Section VIII-D).

The section is touchdown: the control sample at which the controller passes from phase I
(flight) to phase II. The return map P takes the closed-loop state there (robot state and
controller memory) to the state at the next touchdown. Its coordinates are the robot's
coordinates and velocities without the horizontal hip position (nothing depends on it) and,
with the torso update (44), the desired torso angle it has just set; the controller's previous
encoder sample and velocity estimate are those of exact encoders tracking the state.
Encoder quantisation is switched off here: it makes P piecewise constant along some
directions.

The updated controller does not settle on an exactly periodic hop: touchdown states keep
varying by a few per cent (speed sd ~0.02 m/s, torso ~1 deg), the phase switches fall on
whole 1 ms samples, and damped Newton iterations for a period-1 fixed point started from
the observed hops do not converge. The linear part of P is therefore fitted by least squares
over a cloud of perturbed touchdown states (data-driven Floquet analysis); its eigenvalues
are the multipliers reported, with the share of the variance the linear fit leaves
unexplained.
"""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.robots.mabel.hopping import controller as hop
from bipedlab.robots.mabel import model as mm
from bipedlab.robots.mabel.hopping import study as hm

HORIZON_S = 1.0


def _section_search(m, p, x, c, samples: int, substeps: int = hm.SUBSTEPS):
    """Simulate up to ``samples`` control samples; return the state at the first touchdown
    (the sample at which the controller passes from phase I to phase II)."""

    def body(carry, _):
        x, c, found, xs, cs = carry
        xn, c_new, _ = hm.control_sample(m, p, x, c, hm.DT, substeps)
        hit = (~found) & (c_new.phase == hop.TOUCHDOWN) & (c.phase == hop.FLIGHT)
        xs = jnp.where(hit, xn, xs)
        cs = jax.tree_util.tree_map(lambda a, b: jnp.where(hit, a, b), c_new, cs)
        return (xn, c_new, found | hit, xs, cs), None

    (_, _, found, xs, cs), _ = jax.lax.scan(body, (x, c, jnp.asarray(False), x, c), None, length=samples)
    return xs, cs, found


def _free(m):
    """State indices on the section: all but the hip's x (the map ignores it)."""
    n = m.n
    return np.array([i for i in range(2 * n) if i != hm.INDEX["x"]])


def _pack(m, p, x, c, update: bool):
    parts = [x[_free(m)]]
    if update:
        parts += [jnp.atleast_1d(c.h_tor)]
    return jnp.concatenate(parts)


def _unpack(m, p, v, x_ref, c_ref, update: bool):
    """Section coordinates -> (x, c). The controller's previous sample and velocity estimate
    are those of exact encoders that have tracked the state (so they are not independent
    directions of the map)."""
    free = _free(m)
    k = len(free)
    x = x_ref.at[free].set(v[:k])
    n = m.n
    idx = jnp.asarray([hm.INDEX[c] for c in hm.H_COORDS])
    h, hdot = x[idx], x[n + idx]
    fields = dict(h_prev=h - p.period * hdot, hdot=hdot)
    if update:
        fields.update(h_tor=v[k])
    c = dataclasses.replace(c_ref, **fields)
    return x, c


def _sampling(p):
    period = float(p.period)
    return int(round(HORIZON_S / period)), max(int(round(period / hm.DT)), 1)


def return_map(m, p, x_ref, c_ref, update: bool):
    """v -> P(v) as a (batchable) function of the reduced section coordinates."""
    samples, substeps = _sampling(p)

    def P(v):
        x, c = _unpack(m, p, v, x_ref, c_ref, update)
        xs, cs, found = _section_search(m, p, x, c, samples, substeps)
        out = _pack(m, p, xs, cs, update)
        return jnp.where(found, out, jnp.nan)

    return P


def sections(m, p, x, c, count: int):
    """The next ``count`` section states (x, c) from (x, c), hop by hop."""
    samples, substeps = _sampling(p)
    search = jax.jit(_section_search, static_argnums=(4, 5))
    out = []
    for _ in range(count):
        x, c, found = search(m, p, x, c, samples, substeps)
        if not bool(found):
            break
        out.append((x, c))
    return out


def fit_linear_map(P, base, sigma, per_base: int, spread: float, rng):
    """Least-squares linear part J of P over perturbed copies of the base states.

    Each base state is perturbed ``per_base`` times by ``spread * sigma * N(0, 1)``; the fit
    ``P(v) - mean = J (v - mean)`` is done in coordinates scaled by sigma (J's eigenvalues do
    not depend on the scaling). Returns (J, fraction of the output variance the fit leaves
    unexplained, samples used)."""
    U = np.concatenate([b + spread * sigma * rng.standard_normal((per_base, b.shape[0])) for b in base])
    Y = np.asarray(jax.jit(jax.vmap(P))(jnp.asarray(U)))
    ok = np.all(np.isfinite(Y), axis=1)
    U, Y = U[ok] / sigma, Y[ok] / sigma
    Uc, Yc = U - U.mean(0), Y - Y.mean(0)
    Jt, *_ = np.linalg.lstsq(Uc, Yc, rcond=None)
    unexplained = float(np.sum((Yc - Uc @ Jt) ** 2) / max(np.sum(Yc**2), 1e-300))
    return Jt.T, unexplained, int(ok.sum())


def analyse(warmup_hops: int = 40, observe_hops: int = 16, per_base: int = 50, spread: float = 1.0,
            seed: int = 0, model=None, params=None) -> dict:
    """Linearised hop-to-hop map with and without the torso update (44).

    The updated controller settles into hopping that is bounded but not exactly periodic
    (touchdown states keep varying by a few per cent from hop to hop), so there is no smooth
    fixed point to differentiate at. The map's linear part is fitted instead, as in
    data-driven Floquet analysis: by least squares over perturbed copies of
    ``observe_hops`` consecutive touchdown states, perturbations ``spread`` times each
    coordinate's observed hop-to-hop spread. The nominal controller is fitted over the same
    states with its desired torso angle frozen at their mean."""
    m = model or mm.hopping_model()
    p = (params or hop.paper_params()).replace(encoder_counts=jnp.asarray(0.0), torso_update=jnp.asarray(1.0))
    x0 = hm.initial_state(m, p)
    c0 = hop.initial_state(p, hm.sense(m, p, x0)[0])
    samples, substeps = _sampling(p)
    steps = int(warmup_hops * 0.6 / float(p.period))
    x, c, alive, _ = hm.run_samples_jit(m, p, x0, c0, steps=steps, substeps=substeps, record=False)
    secs = sections(m, p, x, c, observe_hops + 1) if bool(alive) else []
    if len(secs) < observe_hops + 1:
        return {"converged": False, "hops_observed": len(secs)}
    rng = np.random.default_rng(seed)
    V = np.stack([np.asarray(_pack(m, p, a, b, True)) for a, b in secs])
    sigma = np.maximum(V.std(axis=0), 1e-9 + 1e-6 * np.abs(V).mean(axis=0))
    x_ref, c_ref = secs[0]
    J_u, un_u, k_u = fit_linear_map(return_map(m, p, x_ref, c_ref, True), V[:-1], sigma, per_base, spread, rng)
    h_tor = float(V[:, -1].mean())
    pn = p.replace(torso_update=jnp.asarray(0.0), h_tor0=jnp.asarray(h_tor))
    cn = dataclasses.replace(c_ref, h_tor=jnp.asarray(h_tor))
    J_n, un_n, k_n = fit_linear_map(return_map(m, pn, x_ref, cn, False), V[:-1, :-1], sigma[:-1], per_base, spread,
                                    rng)
    eig_u, eig_n = np.linalg.eigvals(J_u), np.linalg.eigvals(J_n)
    top = lambda e: sorted(e, key=abs, reverse=True)[:6]  # noqa: E731
    n = m.n
    free = list(_free(m))
    col = lambda i: V[:, free.index(i)]  # noqa: E731
    spread_of = lambda v: [float(v.mean()), float(v.std())]  # noqa: E731
    return dict(
        converged=True,
        method="least-squares fit of the touchdown-to-touchdown map over perturbed touchdown states",
        section="touchdown (first control sample of phase II)",
        hops_observed=observe_hops,
        touchdown_speed_mps=spread_of(col(n + hm.INDEX["x"])),
        touchdown_torso_deg=spread_of(np.rad2deg(col(hm.INDEX["tor"]))),
        desired_torso_deg=spread_of(np.rad2deg(V[:, -1])),
        with_torso_update=dict(max_abs_eigenvalue=float(np.abs(eig_u).max()), eigenvalues=_complex_list(top(eig_u)),
                               unexplained_variance=un_u, samples=k_u),
        without_torso_update=dict(max_abs_eigenvalue=float(np.abs(eig_n).max()),
                                  eigenvalues=_complex_list(top(eig_n)), unexplained_variance=un_n, samples=k_n),
    )


def _complex_list(vals):
    return [[float(np.real(z)), float(np.imag(z))] for z in vals]
