"""A robustness study small enough to compile in seconds: an uncontrolled, undamped pendulum
(theta'' = -(g/l) sin theta) released from (theta0, omega0) on the core closed loop
(:func:`bipedlab.sim.rollout.rollout`); a trial "falls" when |theta| passes LIMIT. Energy is
conserved, so the oracle is closed-form: the swing passes LIMIT exactly when
0.5 omega0^2 - W2 cos theta0 > -W2 cos LIMIT (W2 = g/l).

Run as a script it is one process of a (possibly multi-process) run, writing its outcomes:
``python pendulum_study.py OUT.npz TRIALS SEED [COORDINATOR NUM_PROCESSES PROCESS_ID]``.
"""
from __future__ import annotations

import sys

W2 = 9.81  # g / l, 1/s^2
LIMIT = 2.0  # rad
STEPS = 120  # control samples of 4 x 5 ms: 2.4 s, longer than one swing at these amplitudes


def study(steps: int = STEPS):
    import jax.numpy as jnp

    from bipedlab import robustness as rb
    from bipedlab.sim.rollout import RolloutSpec, rollout

    spec = RolloutSpec(dt=5e-3, substeps=4, steps=steps)
    axes = (rb.Axis("theta0", -1.5, 1.5, 6, "rad"), rb.Axis("omega0", -6.0, 6.0, 6, "rad/s"))

    def flow(p, x, u):
        return jnp.stack([x[1], -W2 * jnp.sin(x[0])])

    def trial(p):
        r = rollout(flow, lambda q, x, k: 0.0, lambda q, x: jnp.abs(x[0]) > LIMIT, spec, None,
                    jnp.stack([p["theta0"], p["omega0"]]))
        return dict(status=r.status, completed=r.failed_at, final_theta=r.final[0])

    return rb.Study(name="pendulum", trial=trial, sample=lambda rng, n: rb.uniform(rng, n, axes),
                    horizon=steps, axes=axes, unit="samples", chunk=8)


def energy_falls(theta0, omega0):
    """The closed-form oracle: does the swing from (theta0, omega0) pass LIMIT?"""
    import numpy as np

    return 0.5 * np.asarray(omega0) ** 2 - W2 * np.cos(theta0) > -W2 * np.cos(LIMIT)


def main(argv):
    """One process of a run: ``OUT_DIR TRIALS SEED [COORDINATOR NUM_PROCESSES PROCESS_ID]``;
    two CPU devices in one process, or one per process in a distributed run. Process 0 writes
    ``OUT_DIR/outcomes.npz`` and ``OUT_DIR/record.json``."""
    import json
    import os

    out, trials, seed = argv[0], int(argv[1]), int(argv[2])
    from bipedlab.robustness import distributed

    if len(argv) > 3:
        distributed.initialize(argv[3], int(argv[4]), int(argv[5]), cpu_devices=1)
    else:
        distributed.initialize(cpu_devices=2)
    from bipedlab.robustness import engine

    rec = engine.run(study(), trials, seed, progress=False, out=out)
    if distributed.process_index() == 0:
        with open(os.path.join(out, "record.json"), "w") as fh:
            json.dump(rec, fh)


if __name__ == "__main__":
    sys.path.insert(0, __import__("os").path.join(__import__("os").path.dirname(__file__), "..", "..", ".."))
    main(sys.argv[1:])
