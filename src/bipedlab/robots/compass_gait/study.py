"""The ``walk`` study of the compass gait: the period-one gait on a slope, its Poincaré
eigenvalues, and a walk of N steps from a (perturbed) fixed point.
Its command line, ``bipedlab walk compass-gait``, is registered in
:mod:`bipedlab.robots.compass_gait.cli`.
"""
from __future__ import annotations

import os

import jax.numpy as jnp
import numpy as np

from bipedlab.sim import OK

from . import model as cg
from . import walker


def walk(slope_deg: float = 3.0, steps: int = 20, perturb: float = 0.0, seed: int = 0, out: str | None = None,
         progress=None):
    """Find the period-one gait on a ``slope_deg`` (degrees) slope, then walk ``steps`` steps
    from the fixed point displaced by ``perturb`` (Euclidean norm of the displacement in
    [rad, rad, rad/s, rad/s], random direction from ``seed``).

    Returns (record, summary): a JSON-able dict and :func:`summary`. Record keys: slope_deg;
    fixed_point (post-impact [theta, psi, thetadot, psidot], stance coordinates), fixed_point_absolute
    ([stance, swing angle, rates] from the vertical); step_period_s; step_length_m (between
    the feet at impact, along the slope); speed_mps (step length / period, along the slope);
    poincare_eigenvalues (list of [re, im], largest magnitude first); eigenvalue_magnitudes;
    max_abs_eigenvalue; stable (fixed point found and all |eigenvalues| < 1);
    jacobian_fd_error (max |exact - central-difference| Jacobian entry); residual;
    steps_completed; fell; distance_to_fixed_point (after each completed step, norm of the
    section state minus the fixed point); step_periods_s; png (path or None). ``progress(msg)``
    hears when the walk starts."""
    g = walker.period_one_gait(np.radians(slope_deg))
    if progress is not None:
        progress(f"walking {steps} steps from the fixed point")
    p = cg.params(slope_deg)
    rng = np.random.default_rng(seed)
    d = rng.normal(size=4)
    x = g.fixed_point + perturb * d / np.linalg.norm(d)
    dist, periods, traj, fell = [], [], [np.asarray(x)], False
    for _ in range(steps):
        s = walker.step_jit(p, jnp.asarray(x))
        if int(s.status) != OK or not np.all(np.isfinite(np.asarray(s.z))):
            fell = True
            break
        x = np.asarray(s.z)
        traj.append(x)
        periods.append(float(s.period))
        dist.append(float(np.linalg.norm(x - g.fixed_point)))
    record = dict(
        robot="compass_gait", slope_deg=float(slope_deg), perturb=float(perturb), seed=int(seed),
        fixed_point=[float(v) for v in g.fixed_point],
        fixed_point_absolute=[float(v) for v in g.absolute],
        step_period_s=g.period, step_length_m=g.step_length, speed_mps=g.speed,
        poincare_eigenvalues=[[float(e.real), float(e.imag)] for e in g.eigenvalues],
        eigenvalue_magnitudes=[float(abs(e)) for e in g.eigenvalues],
        max_abs_eigenvalue=g.max_abs_eigenvalue, stable=bool(g.stable),
        jacobian_fd_error=g.jacobian_error, residual=g.residual,
        steps_requested=int(steps), steps_completed=len(dist), fell=bool(fell),
        distance_to_fixed_point=dist, step_periods_s=periods, png=None,
    )
    if out:
        record["png"] = _plot(p, g, out)
    return record, summary


def summary(record: dict) -> str:
    """Short human-readable text of a walk record."""
    mags = ", ".join(f"{m:.3f}" for m in record["eigenvalue_magnitudes"])
    last = record["distance_to_fixed_point"][-1] if record["distance_to_fixed_point"] else float("nan")
    lines = [
        f"compass gait on a {record['slope_deg']:g} deg slope: "
        f"{'stable' if record['stable'] else 'unstable'} period-one gait",
        f"  step period {record['step_period_s']:.4f} s, step length {record['step_length_m']:.4f} m, "
        f"speed {record['speed_mps']:.4f} m/s",
        f"  |Poincare eigenvalues| {mags} (autodiff vs central differences {record['jacobian_fd_error']:.1e})",
        f"  walked {record['steps_completed']}/{record['steps_requested']} steps"
        f"{' and fell' if record['fell'] else ''}; distance to the fixed point {last:.2e}",
    ]
    if record.get("png"):
        lines.append(f"  figure: {record['png']}")
    return "\n".join(lines)


def _plot(p, g, out: str) -> str:
    """Stick figures along the period-one step (Agg backend); returns the PNG path."""
    import jax
    import matplotlib

    from bipedlab.sim.integrators import rk4
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    os.makedirs(out, exist_ok=True)
    f = jax.jit(lambda z: walker.cg.flow(p, z))
    z, dt = jnp.asarray(g.fixed_point), g.period / 8
    n = 40
    fig, ax = plt.subplots(figsize=(7, 3))
    for k in range(9):
        pts = np.asarray(cg.points(p, z))
        ax.plot(pts[:, 0], pts[:, 1], "-o", color=plt.cm.viridis(k / 8), ms=3)
        for _ in range(n if k < 8 else 0):  # RK4 substeps to the next frame
            h = dt / n
            z = rk4(lambda x, _: f(x), z, None, h)
    x = np.array([-0.6, 0.9])
    ax.plot(x, -np.tan(float(p.slope)) * x, "k-", lw=1)
    ax.set_aspect("equal")
    ax.set_title(f"compass gait, {np.degrees(float(p.slope)):g} deg: period {g.period:.3f} s, "
                 f"step {g.step_length:.3f} m")
    path = os.path.join(out, f"compass_gait_{np.degrees(float(p.slope)):g}deg.png")
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
