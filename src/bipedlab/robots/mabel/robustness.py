"""``bipedlab robustness mabel-hopping`` and ``bipedlab robustness mabel``.

Hopping: MABEL dropped from a height above the ground with a forward hip speed, hopping on
the closed loop of ``hop mabel`` (:func:`bipedlab.robots.mabel.hopping.study.run_samples`, the
batched drops of its Poincaré check); a trial survives when it does not fall within the time
of ``--hops`` hops; ``completed`` counts the hops landed.

Walking: the compliant-HZD walking loop of ``experiment mabel`` (:mod:`.walking.loop`) with a
horizontal push on the hip of a given force over a window of a given phase of one step,
initial-state perturbations of the joint rates and encoder noise (:func:`walking_study`).
"""
from __future__ import annotations

from bipedlab.commands import float_in, int_in
from bipedlab.robots.mabel.walking import catalog
from bipedlab.robustness import options

HOP_PERIOD_S = 0.7  # s per hop allowed, as the hopping study's runs


def hopping_study(hops: int = 10, max_drop: float = 0.10, max_speed: float = 0.4, torso_update: bool = True,
                  bins: int = 6):
    import dataclasses

    import jax.numpy as jnp
    import numpy as np

    from bipedlab import robustness as rb
    from bipedlab.robots.mabel import model as mm
    from bipedlab.robots.mabel.hopping import controller as hop
    from bipedlab.robots.mabel.hopping import study as hs

    m = mm.hopping_model()
    p = hop.paper_params().replace(torso_update=jnp.asarray(1.0 if torso_update else 0.0))
    x_nom = jnp.asarray(hs.initial_state(m, p, clearance=0.0))
    c_nom = hop.initial_state(p, hs.sense(m, p, x_nom)[0])
    steps = int(np.ceil((hops + 1) * HOP_PERIOD_S / float(p.period)))
    iy, ivx = hs.INDEX["y"], m.n + hs.INDEX["x"]
    axes = (rb.Axis("drop_height", 0.0, max_drop, bins, "m", "drop height (toe clearance)"),
            rb.Axis("forward_speed", -max_speed, max_speed, bins, "m/s", "initial forward speed"))

    def trial(q):
        x0 = x_nom.at[iy].add(q["drop_height"]).at[ivx].add(q["forward_speed"])
        c0 = dataclasses.replace(c_nom, h_prev=hop.quantise(p, hs.sense(m, p, x0)[0]))
        x, c, alive, _ = hs.run_samples(m, p, x0, c0, steps, record=False)
        landed = jnp.maximum(c.touchdowns - 1, 0)
        status = jnp.where(alive, 0, jnp.where(jnp.all(jnp.isfinite(x)), 1, 2))
        return dict(status=status, completed=jnp.where(alive, hops, jnp.minimum(landed, hops)),
                    hops_landed=landed, hip_height_end_m=x[iy])

    def describe(params, res):
        return dict(robot="mabel", gait="hopping", hops=hops, torso_update=torso_update,
                    simulated_s=steps * float(p.period))

    return rb.Study(name="mabel hopping drops", trial=trial, sample=lambda rng, n: rb.uniform(rng, n, axes),
                    horizon=hops, axes=axes, unit="hops", chunk=8, describe=describe)


def _hop_options(p) -> None:
    p.add_argument("--hops", type=int_in(1, 500), default=10, help="hops a trial must last (default 10)")
    p.add_argument("--max-drop", type=float_in(0.0, 0.5), default=0.10, help="largest drop height, m (default 0.10)")
    p.add_argument("--max-speed", type=float_in(0.0, 2.0), default=0.4,
                   help="largest initial forward speed, m/s (default 0.4)")
    p.add_argument("--no-torso-update", action="store_true", help="without the event-based torso update")
    p.add_argument("--bins", type=int_in(2, 100), default=6, help="cells per map axis (default 6)")


def _hop_build(args, progress):
    return hopping_study(args.hops, args.max_drop, args.max_speed, not args.no_torso_update, args.bins)


HOPPING = options.command("mabel-hopping", "MABEL hopping: survival against drop height and forward speed",
                          _hop_build, _hop_options, trials=32, chunk=8)


# ----------------------------------------------------------------------------- walking
PUSH_STEP = 2


#: trials per device per compiled call of the walking study: the batched scalar kernel runs wider
#: batches faster (64 trials of 6 steps on a two-core Xeon, programs cached: 1.97 trials/s in calls of
#: 8 per device, 2.69 in one call of 32; outcomes bit for bit the same); a run of fewer trials uses
#: calls of its own size (:func:`bipedlab.robustness.engine.run`)
WALK_CHUNK = 32


def walking_study(steps: int = 6, controller: str = "decentralized", gait: str = "nominal", max_force: float = 80.0,
                  perturb: float = 0.0, noise_counts: float = 0.0, sensing: str = "encoders", bins: int = 6,
                  push_step: int = PUSH_STEP, loaded=None):
    """Pushes on MABEL's walking loop: each trial pushes the hip horizontally with a force in
    [-max_force, max_force] N (positive forward) from a phase in [0.1, 0.9] of step
    ``push_step`` (in nominal periods) until that step's touchdown, starts from the gait's
    post-impact state with its rates scaled by (1 + perturb N(0, 1)) per component, and reads
    encoders with Gaussian noise of ``noise_counts`` counts added per sample. The loop is the
    one of ``walk mabel`` (the stages of :mod:`.walking.loop` in a
    :class:`bipedlab.sim.loop.SampledLoop`, the sensor stage wrapped for the noise), run for
    ``steps`` nominal periods plus 20 %; a trial survives when it does not fall in that time.
    ``loaded``: what :func:`~bipedlab.robots.mabel.walking.study.load_gait` returned for
    ``gait``, if the caller has loaded it already."""
    import dataclasses
    import math

    import jax
    import jax.numpy as jnp
    import numpy as np

    from bipedlab import robustness as rb
    from bipedlab.robots.mabel.walking import loop as sw
    from bipedlab.robots.mabel.walking import stance as wk
    from bipedlab.robots.mabel.walking import study as ws
    from bipedlab.sim import loop as sl

    vc, gains, rec = ws.load_gait(gait) if loaded is None else loaded
    m = wk.walking_model(kernel="scalar")   # the trials run batched: the scalar kernel is the faster
    period = float(rec["design"]["period"])
    z_plus = jnp.asarray(rec["z_plus"], float)
    base = ws.setup_for(vc, gains, period, sensing=sensing)
    n_samples = int(math.ceil(1.2 * steps * period / sw.SAMPLE))
    count = 2 * math.pi / sw.COUNTS
    axes = (rb.Axis("push_force", -max_force, max_force, bins, "N", "push force (+ forward)"),
            rb.Axis("push_phase", 0.1, 0.9, bins, "", f"push start (periods into step {push_step})"))
    template = sw.closed_loop(m, controller)

    def trial(p):
        setup = base.replace(push_force=p["push_force"], push_step=jnp.asarray(push_step),
                             push_start=p["push_phase"])

        def sensor(q, st, x, t):
            st, r = sw.sensor(q, st, x, t)
            k = jnp.round(t / sw.SAMPLE).astype(jnp.int32)
            e = noise_counts * count * jax.random.normal(jax.random.fold_in(p["key"], k), (6,))
            return st, r.replace(q=r.q + e)

        lp = dataclasses.replace(template, sensor=sensor, log=None)
        z0 = z_plus.at[6:].multiply(1.0 + perturb * p["rate_noise"])
        s, _ = sl.run(lp, setup, sw.initial_state(setup, z0), n_samples)
        return dict(status=s.status, completed=jnp.minimum(s.x.step, steps), touchdowns=s.x.step,
                    distance_m=s.x.distance, failed_at_s=jnp.where(s.failed_at >= 0, s.failed_at * sw.SAMPLE, jnp.nan))

    def sample(rng, n):
        p = rb.uniform(rng, n, axes)
        p["rate_noise"] = rng.standard_normal((n, 6))
        p["key"] = rng.integers(0, 2**32, (n, 2), dtype=np.uint32)
        return p

    def describe(params, res):
        return dict(robot="mabel", gait=gait, controller=controller, sensing=sensing, steps=steps,
                    push_step=push_step, perturb=perturb, noise_counts=noise_counts, simulated_s=n_samples * sw.SAMPLE,
                    nominal_period_s=period)

    return rb.Study(name=f"mabel walking pushes ({controller})", trial=trial, sample=sample, horizon=steps,
                    axes=axes, unit="steps", chunk=WALK_CHUNK, describe=describe)


def _walk_options(p) -> None:
    from bipedlab.commands import text

    p.add_argument("--steps", type=int_in(PUSH_STEP + 1, 200), default=6,
                   help=f"nominal step periods a trial walks (default 6; the push is in step {PUSH_STEP})")
    p.add_argument("--controller", choices=catalog.CONTROLLERS, default="decentralized",
                   help="default decentralized (the compliant-HZD controller)")
    p.add_argument("--gait", type=text, default=catalog.DEFAULT_GAIT, help=f"{' | '.join(catalog.GAITS)} | a gait file")
    p.add_argument("--max-force", type=float_in(0.0, 500.0), default=80.0, help="largest push, N (default 80)")
    p.add_argument("--perturb", type=float_in(0.0, 1.0), default=0.0,
                   help="relative s.d. of the initial rates' perturbation (default 0)")
    p.add_argument("--noise", type=float_in(0.0, 1000.0), default=0.0,
                   help="encoder noise s.d. in counts of the 14-bit encoders (default 0)")
    p.add_argument("--sensing", choices=catalog.SENSING, default="encoders",
                   help="rate estimation, as walk mabel (default encoders)")
    p.add_argument("--bins", type=int_in(2, 100), default=6, help="cells per map axis (default 6)")


def _walk_check(args) -> None:
    import os

    from bipedlab.commands import UsageError

    if args.gait not in catalog.GAITS and not os.path.isfile(args.gait):
        raise UsageError(f"--gait: {args.gait!r} is neither a shipped gait ({', '.join(catalog.GAITS)}) nor a file")


def _walk_build(args, progress):
    from bipedlab.commands import UsageError
    from bipedlab.robots.mabel.walking import study as ws

    try:  # every field of the gait, before anything compiles; the study takes it as loaded
        loaded = ws.load_gait(args.gait)
    except ValueError as e:
        raise UsageError(str(e)) from None
    return walking_study(args.steps, args.controller, args.gait, args.max_force, args.perturb, args.noise,
                         args.sensing, args.bins, loaded=loaded)


WALKING = options.command("mabel", "MABEL walking: push force x push timing map, initial-state perturbations, "
                          "encoder noise", _walk_build, _walk_options, trials=16, chunk=WALK_CHUNK, check=_walk_check)
