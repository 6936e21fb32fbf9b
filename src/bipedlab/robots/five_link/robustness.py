"""``bipedlab robustness five-link``: a 2-D slice of the basin of attraction of the walking
gait's fixed point, on the Poincaré section.

Each trial starts at the pre-impact state z* of the gait with its joint rates perturbed in two
directions — all rates scaled by ``1 + rate_scale`` (faster or slower along the gait) and
``torso_rate`` rad/s added to the torso's rate — so the configuration stays on the impact
surface; it then walks ``--steps`` steps of the closed loop (:func:`bipedlab.gait.walking.walk`,
the loop of ``walk five-link``). A trial survives when every step ends in a touchdown.
"""
from __future__ import annotations

from bipedlab.commands import int_in
from bipedlab.robustness import options

ROBOT = "five-link"
RATE_SCALE = (-0.5, 0.5)
TORSO_RATE = (-2.0, 2.0)  # rad/s


def axes(bins: int = 8):
    from bipedlab.robustness import Axis

    return (Axis("rate_scale", *RATE_SCALE, bins, "", "rate scale - 1"),
            Axis("torso_rate", *TORSO_RATE, bins, "rad/s", "torso rate offset"))


def initial_state(z_star, n: int, rate_scale, torso_rate):
    """The perturbed pre-impact state of one trial (jnp)."""
    import jax.numpy as jnp

    z = jnp.asarray(z_star)
    qd = z[n:] * (1.0 + rate_scale)
    return jnp.concatenate([z[:n], qd.at[0].add(torso_rate)])


def study(steps: int = 20, controller: str = "iolin", gait=None, bins: int = 8, grid: bool = False):
    """The basin-slice :class:`bipedlab.robustness.Study` (trials drawn uniformly over the
    slice, or on the lattice of cell centres with ``grid``)."""
    import jax.numpy as jnp
    import numpy as np

    from bipedlab import robustness as rb
    from bipedlab.gait import walking as gw
    from bipedlab.robots.five_link import robot as five_link
    from bipedlab.robots.five_link import study as hz

    vc, z_star, _ = hz.load_gait(gait)
    st = five_link.stance()
    ctrl = hz.CONTROLLERS[controller]
    n = st.n
    ax = axes(bins)
    zs = jnp.asarray(z_star)

    def trial(p):
        z0 = initial_state(zs, n, p["rate_scale"], p["torso_rate"])
        return gw.outcome(gw.walk(vc, st, ctrl, z0, steps), zs)

    def sample(rng, k):
        return rb.grid(k, ax) if grid else rb.uniform(rng, k, ax)

    def describe(params, res):
        alive = res["survived"]
        dev = res["final_deviation"][alive]
        return dict(robot=ROBOT, controller=controller, steps=steps,
                    median_final_deviation=float(np.median(dev)) if dev.size else None,
                    sampling="grid" if grid else "uniform")

    return rb.Study(name=f"{ROBOT} basin slice ({controller})", trial=trial, sample=sample, horizon=steps,
                    axes=ax, unit="steps", chunk=16, describe=describe)


def _options(p) -> None:
    p.add_argument("--steps", type=int_in(1, 1000), default=20, help="steps a trial must walk (default 20)")
    p.add_argument("--controller", choices=["iolin", "pd"], default="iolin", help="iolin | pd (default iolin)")
    p.add_argument("--bins", type=int_in(2, 100), default=8, help="cells per axis of the survival map (default 8)")
    p.add_argument("--grid", action="store_true", help="trials on the map's cell centres instead of uniform draws")


def _build(args, progress):
    return study(args.steps, args.controller, None, args.bins, args.grid)


COMMAND = options.command(ROBOT, "basin of attraction of the walking gait: a 2-D slice of joint-rate perturbations",
                          _build, _options, trials=64, chunk=16)
