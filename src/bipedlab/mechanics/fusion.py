"""Trace-time hints that steer XLA's kernel fusion. They never change results.

The dynamics are written on scalars, unrolled over the tree. XLA then fuses them into
kernels, and where a scalar feeds several kernels it may recompute it in each. Under ``vmap``
(every scalar a batch vector) that recomputation costs more than materialising each stage's
outputs once, so batched rollouts trace inside :func:`stage_barriers`; a single rollout on a
CPU is dominated by per-kernel overhead instead and runs about twice as fast without them.
The setting is read while tracing, so it belongs around the code being traced.
"""
from __future__ import annotations

import contextlib
import contextvars

import jax
import jax.numpy as jnp

_STAGE_BARRIERS = contextvars.ContextVar("bipedlab_stage_barriers", default=False)


@contextlib.contextmanager
def stage_barriers(enabled: bool = True):
    """Materialise the outputs of each dynamics stage once (best for batched evaluation)."""
    token = _STAGE_BARRIERS.set(enabled)
    try:
        yield
    finally:
        _STAGE_BARRIERS.reset(token)


def materialize(tree):
    """Inside :func:`stage_barriers`, compute every traced scalar leaf of tree once, as one
    array behind an optimisation barrier; otherwise return tree unchanged."""
    if not _STAGE_BARRIERS.get():
        return tree
    leaves, treedef = jax.tree_util.tree_flatten(tree, is_leaf=lambda v: v is None)
    idx = [i for i, v in enumerate(leaves) if isinstance(v, jax.Array) and v.ndim == 0]
    if not idx:
        return tree
    packed = jax.lax.optimization_barrier(jnp.stack([leaves[i] for i in idx]))
    for k, i in enumerate(idx):
        leaves[i] = packed[k]
    return jax.tree_util.tree_unflatten(treedef, leaves)
