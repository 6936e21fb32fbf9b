"""``bipedlab robustness atrias``: survival of spring-mass running against the terrain's step
height (and optionally an initial trunk offset).

Each trial draws a maximum step height H and a rough terrain of the running study's kind
(``bipedlab.contact.terrain.rough``, mode "paper": levels every 3 m, each uniform in
[-H/2, H/2], flat start), then runs the ATRIAS closed loop of ``run atrias`` (the same
:func:`bipedlab.robots.atrias.loop.make_loop` on :func:`bipedlab.sim.loop.run`) for the time
the running study gives the distance. A trial survives when it reaches ``--distance`` m
without a fall; ``completed`` is the metres run before the fall.
"""
from __future__ import annotations

from bipedlab.commands import float_in, int_in
from bipedlab.robustness import options

ROBOT = "atrias"


def study(distance: float = 15.0, max_step: float = 0.3, trunk_offset_deg: float = 0.0, noise: bool = False,
          bins: int = 6):
    import jax.numpy as jnp
    import numpy as np

    from bipedlab import robustness as rb
    from bipedlab.contact import terrain as tr
    from bipedlab.robots.atrias import loop as ar
    from bipedlab.robots.atrias import robot as at
    from bipedlab.robots.atrias import study as rs
    from bipedlab.sim import loop as sl

    st = rs.Settings(terrain="rough", step_height=max_step, distance=distance, noise=noise)
    rp, cp, gait, _ = rs.build(st)
    T = rs.duration(st)
    length = distance + 12.0
    template = tr.rough(np.random.default_rng(0), max_step, length)
    n_levels = int(template.heights.shape[0])
    cfg = ar.RunConfig(noise=noise)
    loop = ar.make_loop(rp, ar.program(cfg))
    c0 = ar.initial_state(rp, cp, cfg)
    n_samples = int(round(T / ar.CONTROL_DT))
    axes = [rb.Axis("step_height", 0.0, max_step, bins, "m", "max step height H")]
    if trunk_offset_deg > 0:
        axes.append(rb.Axis("trunk_offset", -trunk_offset_deg, trunk_offset_deg, bins, "deg", "initial trunk offset"))
    axes = tuple(axes)

    def trial(p):
        terr = tr.Terrain(p["levels"], template.step_len, template.x0, template.grade)
        c = c0
        if trunk_offset_deg > 0:
            s = c.x.s
            c = c.replace(x=c.x.replace(s=s.replace(q=s.q.at[at.ITH].add(jnp.deg2rad(p["trunk_offset"])))))
        trial = ar.Trial(terr, p["key"])  # key: raw uint32 pair, as run atrias
        s, _ = sl.run(loop, ar.params(trial, cp, cfg), c, n_samples)
        x = s.x.s.q[0]
        reached = x >= distance
        status = jnp.where(reached, sl.OK, s.status)
        done = jnp.where(reached, distance, jnp.clip(jnp.floor(x), 0.0, distance)).astype(jnp.int32)
        return dict(status=status, completed=done, x_m=x, apexes=s.x.n_apex,
                    pitch_rms_rad=jnp.sqrt(s.x.pitch_sq / jnp.maximum(s.x.pitch_n, 1)))

    def sample(rng, n):
        p = rb.uniform(rng, n, axes)
        h = p["step_height"][:, None] * rng.uniform(-0.5, 0.5, (n, n_levels))
        h[:, 0] = 0.0  # the flat start
        p["levels"] = h
        p["key"] = rng.integers(0, 2**32, (n, 2), dtype=np.uint32)
        return p

    def describe(params, res):
        return dict(robot=ROBOT, distance_m=distance, simulated_s=T, noise=noise, terrain="rough (paper)",
                    level_step_m=float(template.step_len))

    return rb.Study(name=f"{ROBOT} rough terrain", trial=trial, sample=sample, horizon=int(distance), axes=axes,
                    unit="m", chunk=8, describe=describe)


def _options(p) -> None:
    p.add_argument("--distance", type=float_in(3.0, 200.0), default=15.0, help="metres a trial must run (default 15)")
    p.add_argument("--max-step", type=float_in(0.0, 1.0), default=0.3,
                   help="largest step height H of the map, m (default 0.3)")
    p.add_argument("--trunk-offset", type=float_in(0.0, 45.0), default=0.0,
                   help="also perturb the initial trunk angle uniformly within +-DEG (a second map axis)")
    p.add_argument("--noise", action="store_true", help="sensor noise as in run atrias --noise")
    p.add_argument("--bins", type=int_in(2, 100), default=6, help="cells per map axis (default 6)")


def _build(args, progress):
    return study(args.distance, args.max_step, args.trunk_offset, args.noise, args.bins)


COMMAND = options.command(ROBOT, "survival of running against terrain step height (batched rough terrains)",
                          _build, _options, trials=32, chunk=8)
