"""``bipedlab robustness model FILE --gait GAIT``: the push-robustness map of a walking gait of a
biped read from a file.

Each trial pushes the robot at the hip with an impulse (P_x, P_y) (N s, forward and up) at
the end of a step, just before touchdown, on the Poincaré section: the stance foot stays on
the ground, so the push changes the velocities by ``dqd = (M^-1 - M^-1 J^T (J M^-1 J^T)^-1
J M^-1) J_hip^T P`` (J: the stance foot's Jacobian), the configuration not at all. The robot
then walks ``--steps`` steps of the closed loop of ``walk model``
(:func:`bipedlab.gait.walking.walk`); a trial survives when every step ends in a touchdown.
"""
from __future__ import annotations

import os

from bipedlab.inputs import model_text
from bipedlab.commands import UsageError, float_in, int_in, text
from bipedlab.robustness import options

ROBOT = "model"


def push(st, hip_body: int, z, impulse):
    """Stance state after an impulse (2,) N s at the hip with the stance foot held (jnp)."""
    import jax
    import jax.numpy as jnp

    from bipedlab.mechanics.dynamics import mass_matrix
    from bipedlab.mechanics.kinematics import frames, point_jacobian
    from bipedlab.mechanics.stance import embed, reduce

    q, qd = embed(st, z)
    M = mass_matrix(st.model, q)
    Js = point_jacobian(st.model, q, st.stance)
    Jh = jax.jacfwd(lambda x: jnp.stack(frames(st.model, x).origin[hip_body]))(q)
    a = jnp.linalg.solve(M, Jh.T @ impulse)
    MiJs = jnp.linalg.solve(M, Js.T)
    lam = jnp.linalg.solve(Js @ MiJs, Js @ a)
    return reduce(q, qd + a - MiJs @ lam)


def study(path, gait, steps: int = 10, controller: str = "iolin", push_max: float = 40.0, bins: int = 8,
          grid: bool = False, plane: str = "xz"):
    """The push-robustness :class:`bipedlab.robustness.Study` of a gait of ``optimize model``."""
    import jax.numpy as jnp
    import numpy as np

    from bipedlab import robustness as rb
    from bipedlab.gait import walking as gw
    from bipedlab.robots.imported import study as imported_study

    from bipedlab.gait import study as hzd_study

    s, vc, z_star, meta = imported_study.load_gait(path, gait, plane)
    st = s.study.stance
    ctrl = hzd_study.controller_of(s.study, meta, controller)  # the gait's own gains
    hip = s.legs.stance_path[0]
    ax = (rb.Axis("push_x", -push_max, push_max, bins, "N s", "forward impulse at the hip"),
          rb.Axis("push_y", -push_max, push_max, bins, "N s", "upward impulse at the hip"))
    zs = jnp.asarray(z_star)

    def trial(p):
        z0 = push(st, hip, zs, jnp.stack([p["push_x"], p["push_y"]]))
        return gw.outcome(gw.walk(vc, st, ctrl, z0, steps), zs)

    def sample(rng, k):
        return rb.grid(k, ax) if grid else rb.uniform(rng, k, ax)

    def describe(params, res):
        alive = res["survived"]
        dev = res["final_deviation"][alive]
        return dict(robot=ROBOT, file=str(path), gait=str(gait), controller=controller, steps=steps,
                    median_final_deviation=float(np.median(dev)) if dev.size else None,
                    sampling="grid" if grid else "uniform")

    return rb.Study(name=f"{os.path.basename(str(path))} hip pushes ({controller})", trial=trial, sample=sample,
                    horizon=steps, axes=ax, unit="steps", chunk=16, describe=describe)


def _options(p) -> None:
    p.add_argument("file", type=text, metavar="FILE", help="the robot: an MJCF (.xml) or URDF (.urdf) file")
    p.add_argument("--gait", type=text, required=True, metavar="GAIT", help="a gait file from optimize model --save")
    p.add_argument("--plane", choices=["xz", "yz", "zx", "zy", "xy", "yx"], default="xz",
                   help="the sagittal plane as (forward axis, up axis) of the file's world (default xz)")
    p.add_argument("--steps", type=int_in(1, 1000), default=10, help="steps a trial must walk (default 10)")
    p.add_argument("--controller", choices=["iolin", "pd"], default="iolin", help="iolin | pd (default iolin)")
    p.add_argument("--push", type=float_in(0.1, 1000.0), default=40.0,
                   help="largest impulse of each axis, N s (default 40)")
    p.add_argument("--bins", type=int_in(2, 100), default=8, help="cells per axis of the survival map (default 8)")
    p.add_argument("--grid", action="store_true", help="trials on the map's cell centres instead of uniform draws")


def _check(args) -> None:
    from bipedlab.robots.imported.study import EXAMPLES

    if not (args.file in EXAMPLES and not os.path.lexists(args.file)):  # not a shipped example
        try:
            model_text(args.file)  # a regular text file, no xacro macro, every number finite
        except ValueError as e:
            raise UsageError(str(e)) from None
    if not os.path.isfile(args.gait):
        raise UsageError(f"--gait: {args.gait!r} is not a file")


def _build(args, progress):
    try:
        return study(args.file, args.gait, args.steps, args.controller, args.push, args.bins, args.grid,
                     args.plane)
    except (ValueError, ImportError) as e:
        raise UsageError(str(e)) from None


COMMAND = options.command(ROBOT, "push-robustness map of a walking gait of a biped in an MJCF or URDF file",
                          _build, _options, trials=64, chunk=16, check=_check)
