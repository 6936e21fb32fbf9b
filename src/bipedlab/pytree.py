"""The one container idiom for parameters and states: frozen dataclasses registered as JAX
pytrees, with ``replace`` provided once here.

    @pytree
    class Params:
        mass: jax.Array                     # kg
        n_links: int = static_field(5)      # structural: part of the compiled program

``static_field`` marks fields that are not traced (integers that fix shapes, mode names); every
other field is a pytree leaf (or a nested pytree). Instances are immutable; ``p.replace(mass=2.0)``
returns a copy with the given fields changed.
"""
from __future__ import annotations

import dataclasses

import jax


def static_field(default=dataclasses.MISSING, **kwargs):
    """A dataclass field that is static metadata of the pytree (not a leaf)."""
    return dataclasses.field(default=default, metadata={"static": True}, **kwargs)


def replace(self, **changes):
    """A copy of the frozen dataclass ``self`` with ``changes`` (the ``replace`` method of
    every :func:`pytree` class; a class registered by hand may bind it as ``replace = replace``)."""
    return dataclasses.replace(self, **changes)


def pytree(cls=None):
    """Make ``cls`` a frozen dataclass, registered as a pytree, with a ``replace`` method."""
    def wrap(c):
        c = dataclasses.dataclass(frozen=True)(c)
        c.replace = replace
        return jax.tree_util.register_dataclass(c)

    return wrap if cls is None else wrap(cls)


__all__ = ["pytree", "replace", "static_field"]
