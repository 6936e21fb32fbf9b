"""Ready-made closed-loop scenarios built from a model, a ground and a controller.

``standing`` is the speed anchors' scenario: the five-link biped under joint PD control
(kp 400 N m/rad, kd 20 N m s/rad) on the penalty ground, RK4 at 0.25 ms, 1 kHz control, 2 s.
"""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from bipedlab.contact.penalty import PenaltyGround, anchor_ground
from bipedlab.mechanics import Model
from bipedlab.contact.penalty import contact_dynamics
from bipedlab.robots.five_link import robot as five_link
from bipedlab.sim.rollout import RolloutSpec


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class JointPDParams:
    """A model on a penalty ground under joint PD: u = kp (q_ref - q) - kd qd on the
    actuated coordinates. kp N m/rad, kd N m s/rad, q_ref rad (one per actuator);
    contacts: indices of the points that touch the ground (static);
    min_height: the run counts as fallen when the base y drops below it (m)."""

    model: Model
    ground: PenaltyGround
    kp: jax.Array
    kd: jax.Array
    q_ref: jax.Array
    min_height: jax.Array
    contacts: tuple[int, ...] = dataclasses.field(metadata=dict(static=True))


def flow(p: JointPDParams, x, u):
    """xdot = [qd, qdd] of the model on the ground under input u."""
    n = p.model.nq
    q, qd = x[:n], x[n:]
    return jnp.concatenate([qd, contact_dynamics(p.model, p.ground, p.contacts, q, qd, u)])


def pd_policy(p: JointPDParams, x, k):
    n = p.model.nq
    idx = jnp.asarray(p.model.actuated)
    return p.kp * (p.q_ref - x[idx]) - p.kd * x[n + idx]


def fell(p: JointPDParams, x):
    return x[1] < p.min_height


def standing(seconds: float = 2.0, dt: float = 2.5e-4, substeps: int = 4, integrator: str = "rk4"):
    """(params, x0, spec) of the anchor scenario: five-link standing under PD."""
    m = five_link.model()
    f = lambda v: jnp.asarray(v, dtype=jnp.float64)  # noqa: E731
    params = JointPDParams(
        model=m,
        ground=anchor_ground(),
        kp=f(400.0),
        kd=f(20.0),
        q_ref=f(five_link.STANDING_REFERENCE),
        min_height=f(0.2),
        contacts=(m.point_index("foot_1"), m.point_index("foot_2")),
    )
    steps = int(round(seconds / (dt * substeps)))
    spec = RolloutSpec(dt=dt, substeps=substeps, steps=steps, integrator=integrator)
    return params, five_link.standing_state(), spec
