"""``bipedlab robustness seven-link``: survival of nonkinematic walking against perturbations
of the starting speed and posture.

Each trial starts from the walking study's initial posture (:func:`.study.initial_condition`)
with the hip velocity guess scaled by ``1 + speed_change`` and the body pitched by
``body_offset`` degrees, and walks the closed loop of ``walk seven-link`` (the
:func:`.contact.closed_loop` in chunks of :func:`bipedlab.sim.loop.run_until`, the simulator's
own sample bound) until ``--steps`` touchdowns; it survives when it gets there without a fall.
"""
from __future__ import annotations

from bipedlab.commands import float_in, int_in
from bipedlab.robots.seven_link import catalog
from bipedlab.robustness import options

ROBOT = "seven-link"
CHUNK = 100  # samples per loop chunk between the checks whether the batch has stopped


def study(steps: int = 8, params: str = "tuned", max_speed_change: float = 0.6, max_body_deg: float = 10.0,
          bins: int = 6):
    import jax.numpy as jnp

    from bipedlab import robustness as rb
    from bipedlab.mechanics import coupled as cp
    from bipedlab.robots.seven_link import contact as sc
    from bipedlab.robots.seven_link import controller as ctl
    from bipedlab.robots.seven_link import robot as sl7
    from bipedlab.robots.seven_link import study as ss
    from bipedlab.sim import loop as sl

    r = sl7.model()
    r = r.replace(coupled=cp.batched(r.coupled))   # the trials run batched: the scalar kernel is the faster
    settings = ss.settings_for(steps)
    p = ctl.make_params(r, ss.gains(params), unilateral_check=ss.UNILATERAL_CHECK[params])
    loop = sc.closed_loop(r, ctl.policy, settings, ctl.log_vector)
    x_nom, a0 = ss.initial_condition(r)
    nlog_c = int(ctl.log_vector(ctl.initial_state(x_nom)).shape[0])
    axes = (rb.Axis("speed_change", -max_speed_change, max_speed_change, bins, "", "hip speed guess scale - 1"),
            rb.Axis("body_offset", -max_body_deg, max_body_deg, bins, "deg", "body pitch offset"))

    def trial(q):
        x0, _ = ss.initial_condition(r, ss.START_SPEED * (1.0 + q["speed_change"]))
        x0 = x0.at[2].add(jnp.deg2rad(q["body_offset"]))
        s0 = sl.initial_state(sc.initial_plant(r, x0, a0, nlog_c, settings), None, ctl.initial_state(x0))
        # chunks of the loop until the trial has stopped (steps reached or fallen), as the study's
        # own simulate stops; the bound is the study's sample count
        s = sl.run_until(loop, p, s0, CHUNK, lambda s: sc.running(settings, s.x), settings.n_samples)
        pl = s.x
        reached = (pl.status == sc.OK) & (pl.ntd >= steps)
        status = jnp.where(reached, sl.OK, jnp.where(pl.status == sc.NONFINITE, sl.NONFINITE, sl.FELL))
        return dict(status=status, completed=jnp.minimum(pl.ntd, steps), touchdowns=pl.ntd, hip_x_m=pl.x[0],
                    t_end_s=pl.t)

    def describe(params_, res):
        return dict(robot=ROBOT, params=params, steps=steps, start_speed_mps=ss.START_SPEED,
                    start_body_deg=ss.START_BODY_DEG, max_time_s=settings.max_time)

    return rb.Study(name=f"{ROBOT} start perturbations ({params})", trial=trial,
                    sample=lambda rng, n: rb.uniform(rng, n, axes), horizon=steps, axes=axes, unit="steps",
                    chunk=4, describe=describe)


def _options(p) -> None:
    p.add_argument("--steps", type=int_in(1, 200), default=8, help="touchdowns a trial must reach (default 8)")
    p.add_argument("--params", choices=catalog.PARAMS, default=catalog.DEFAULT_PARAMS,
                   help=f"controller gains (default {catalog.DEFAULT_PARAMS})")
    p.add_argument("--speed-change", type=float_in(0.0, 0.95), default=0.6,
                   help="largest relative change of the starting hip speed (default 0.6)")
    p.add_argument("--max-body", type=float_in(0.0, 45.0), default=10.0,
                   help="largest body pitch offset at the start, deg (default 10)")
    p.add_argument("--bins", type=int_in(2, 100), default=6, help="cells per map axis (default 6)")


def _build(args, progress):
    return study(args.steps, args.params, args.speed_change, args.max_body, args.bins)


COMMAND = options.command(ROBOT, "survival of walking against start speed and posture perturbations",
                          _build, _options, trials=16, chunk=4)
