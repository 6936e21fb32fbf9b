"""batched_rollout split across several devices (CPU cores exposed as JAX devices with
use_cpu_cores) gives the same results as the plain vmap. Runs in a fresh interpreter, since
the device count must be set before JAX first touches a device."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent('''
    import dataclasses, json
    import jax, jax.numpy as jnp, numpy as np
    import bipedlab
    from bipedlab.sim import RolloutSpec, batched_rollout, use_cpu_cores

    n = use_cpu_cores(2)
    assert n == 2 and len(jax.devices()) == 2, (n, jax.devices())

    @jax.tree_util.register_dataclass
    @dataclasses.dataclass(frozen=True)
    class P:
        acc: jax.Array
        nan_above: jax.Array

    flow = lambda p, x, u: jnp.where(x[0] > p.nan_above, jnp.nan, jnp.stack([x[1], u]))
    policy = lambda p, x, k: p.acc
    fell = lambda p, x: x[0] < 0.0
    out = {}
    for record in (False, True):
        spec = RolloutSpec(dt=0.01, substeps=10, steps=30, integrator="rk4", record=record)
        x0 = jnp.array([[1.0, 0.25], [1.0, -0.95], [1.0, 0.45], [0.5, -0.45]])
        p = P(jnp.asarray(0.0), jnp.asarray(2.0))
        ps = P(jnp.array([0.0, 0.1, -0.2, 0.3]), jnp.array([10.0, 2.0, 1.2, 3.0]))
        for name, params, axis in (("shared", p, None), ("batched", ps, 0)):
            a = batched_rollout(flow, policy, fell, spec, params, x0, params_axis=axis, shard=True)
            b = batched_rollout(flow, policy, fell, spec, params, x0, params_axis=axis, shard=False)
            key = f"{name}_record{int(record)}"
            out[key] = dict(
                sharded=len(a.final.sharding.device_set),
                status=np.asarray(a.status).tolist(), status_ref=np.asarray(b.status).tolist(),
                failed_at=np.asarray(a.failed_at).tolist(), failed_at_ref=np.asarray(b.failed_at).tolist(),
                final_diff=float(np.abs(np.asarray(a.final) - np.asarray(b.final)).max()),
                states_diff=None if not record else float(np.abs(np.asarray(a.states) - np.asarray(b.states)).max()),
            )
    # a batch that does not divide evenly falls back to one device
    spec = RolloutSpec(dt=0.01, substeps=10, steps=30, integrator="rk4", record=False)
    r = batched_rollout(flow, policy, fell, spec, P(jnp.asarray(0.0), jnp.asarray(2.0)),
                        jnp.array([[1.0, 0.25], [1.0, -0.95], [1.0, 0.45]]))
    out["odd"] = dict(status=np.asarray(r.status).tolist(), failed_at=np.asarray(r.failed_at).tolist(),
                      devices=len(r.final.sharding.device_set))
    print(json.dumps(out))
''')


def test_sharded_batched_rollout_matches_vmap():
    env = dict(os.environ, JAX_PLATFORMS="cpu")  # CPU cores as devices, also on a GPU machine
    r = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=300, env=env)
    assert r.returncode == 0, r.stderr[-3000:]
    out = json.loads(r.stdout.strip().splitlines()[-1])
    odd = out.pop("odd")
    assert odd == dict(status=[0, 1, 2], failed_at=[30, 10, 22], devices=1)
    # shared parameters: OK, FELL at 10, NONFINITE at 22, FELL at 11 (x = 0.5 - 0.45 t)
    assert out["shared_record0"]["status_ref"] == [0, 1, 2, 1]
    assert out["shared_record0"]["failed_at_ref"] == [30, 10, 22, 11]
    assert len(set(out["batched_record0"]["status_ref"])) > 1
    for key, v in out.items():
        assert v["sharded"] == 2, key
        assert v["status"] == v["status_ref"], key
        assert v["failed_at"] == v["failed_at_ref"], key
        assert v["final_diff"] == 0.0, key
        assert v["states_diff"] in (None, 0.0), key
