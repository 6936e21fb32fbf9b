"""Scan carries that trace once under ``jax.jvp`` and ``jax.vmap``.

``lax.scan``'s forward-mode and batching rules find which carried values have tangents (or a
batch axis) by a fixed-point iteration: a carry that starts without one (a zero initial
guess, a nominal parameter set that an impact later replaces by a state-dependent one) but
acquires one inside the body makes the rule trace the whole body again. Scans nested inside
scans multiply those re-traces: a step-to-step map written as scans over sub-phases, RK4
nodes, RK4 stages and Newton iterations can spend most of its trace time in them.
:func:`joint` gives every leaf of a carry the tangents and batch axes of all of them up
front, at the cost of one multiply-add per leaf.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp


def joint(tree, *others):
    """``tree`` with ``0 * s`` added to every floating leaf, where ``s`` sums one element of
    every floating leaf of ``tree`` and ``others``: the values are unchanged (for finite
    leaves), but each leaf now depends on all of them, so a scan whose initial carry is
    ``joint(...)`` is traced once by ``jvp``/``vmap`` however its tangents spread."""
    leaves = [a for a in jax.tree_util.tree_leaves((tree, others))
              if jnp.issubdtype(jnp.result_type(a), jnp.floating)]
    if not leaves:
        return tree
    s = 0.0 * sum(jnp.ravel(jnp.asarray(a))[0] for a in leaves if jnp.size(a))

    def tie(a):
        return a + s.astype(jnp.result_type(a)) if jnp.issubdtype(jnp.result_type(a), jnp.floating) else a

    return jax.tree_util.tree_map(tie, tree)


__all__ = ["joint"]
