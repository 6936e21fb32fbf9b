"""The pure spring-mass model running blind over a terrain with the swing policy a*(t)
(the comparison of the running paper's Fig. 8).

Each step: from lift-off, the ballistic flight with the leg at a*(t) (t = time since the
flight's apex) until the foot meets the ground after the flight's apex (the core's
:func:`bipedlab.sim.hybrid.first_event_time`: a 2 ms grid, refined by bisection),
then stance on the stationary foot (:func:`bipedlab.control.slip.stance`). Eq. (1) gives
landing angles for landings after the apex, the policy's whole domain; before it a*(t) is
held at its first angle, and a step up just ahead of a lift-off can hold that foot inside the
terrain from the start. Taking that as a touchdown (any foot at or below the ground once the
first 20 ms had passed, as this model did) landed 16 % of the steps on 32 rough terrains
of 60 m (steps up to 25 cm) a few centimetres past the last stance, strides under 1 m, and
spread the bounce heights 3.6 cm (the paper's model: 1.8 cm); after the apex only, no stride
is under 1 m and they spread 2.5 cm, the apex speeds 15 cm/s as before. Records, per step,
the bounce height (apex above the ground of the stance before it, the quantity the policy
targets) and the forward speed at apex. Vmappable over terrains. The policy is the fitted
polynomial (:class:`~bipedlab.control.slip.SwingPolicy`, the one the robot's controller runs) or
the solved pairs themselves (:class:`~bipedlab.control.slip.PolicyTable`, the exact policy).
"""
from __future__ import annotations

import jax
import jax.numpy as jnp

from bipedlab.control import slip
from bipedlab.contact import terrain as tr
from bipedlab.pytree import pytree
from bipedlab.sim import hybrid


@pytree
class SlipRun:
    """bounce (n,), speed (n,), apex_y (n,) global apex height, x (n,) apex position;
    steps_done: valid entries; fell: bool."""

    bounce: jax.Array
    speed: jax.Array
    apex_y: jax.Array
    x: jax.Array
    steps_done: jax.Array
    fell: jax.Array


def _touchdown_time(p, pol, terr, s, t_max=2.0, n=1000):
    """First time after the flight's apex, from state s = (x, y, vx, vy), at which the foot at
    a*(t) is at or below the ground."""
    t_apex = s[3] / p.g

    def gap(t):
        a = slip.policy_angle(pol, t - t_apex)
        fx = s[0] + s[2] * t + p.l0 * jnp.cos(a)
        fy = s[1] + s[3] * t - 0.5 * p.g * t * t - p.l0 * jnp.sin(a)
        return jnp.where(t > t_apex, fy - tr.ground(terr, fx), 1.0)  # no landing before the apex

    # ignore the very start (the foot is at the ground at lift-off)
    return hybrid.first_event_time(gap, t_max, n, t_min=0.02, iterations=40)


def run(p: slip.SlipParams, gait: slip.Gait, pol: slip.SwingPolicy, terr: tr.Terrain, n_steps: int):
    """n_steps bounces from the target apex at x = 0 (ground level 0 there)."""
    s0 = jnp.array([0.0, gait.y_apex + tr.ground(terr, 0.0), gait.speed, 0.0])
    g0 = tr.ground(terr, 0.0)

    def step(c, _):
        s, fell = c
        t, found = _touchdown_time(p, pol, terr, s)
        a = slip.policy_angle(pol, t - s[3] / p.g)
        pos = s[:2] + s[2:] * t + jnp.array([0.0, -0.5 * p.g * t * t])
        vel = s[2:] + jnp.array([0.0, -p.g * t])
        foot = pos + p.l0 * jnp.array([jnp.cos(a), -jnp.sin(a)])
        s_lo, _, ok = slip.stance(p, jnp.concatenate([pos - foot, vel]))
        s_new = jnp.concatenate([s_lo[:2] + foot, s_lo[2:]])
        bad = fell | ~found | ~ok | (s_new[3] <= 0) | (s_new[2] <= 0) | ~jnp.all(jnp.isfinite(s_new))
        apex_y = s_new[1] + jnp.square(s_new[3]) / (2 * p.g)
        x_apex = s_new[0] + s_new[2] * s_new[3] / p.g
        gf = tr.ground(terr, foot[0])
        rec = (apex_y - gf, s_new[2], apex_y, x_apex, ~bad)
        s_out = jnp.where(bad, s, s_new)
        return (s_out, bad), rec

    (_, fell), (bounce, speed, ay, xa, ok) = jax.lax.scan(step, (s0, jnp.asarray(False)), None, length=n_steps)
    del g0
    return SlipRun(bounce, speed, ay, xa, jnp.sum(ok), fell)
