"""Planar vector arithmetic on pairs of scalars, for the recursions of kinematics and dynamics.

A vector is a tuple ``(x, y)`` of scalars (Python floats or JAX scalars, batched under
``vmap``), so that an unrolled recursion stays a handful of fused elementwise kernels.
"""
from __future__ import annotations

Vec = tuple  # a planar vector as a pair of scalars (x, y)


def sub(a: Vec, b: Vec) -> Vec:
    """a - b."""
    return (a[0] - b[0], a[1] - b[1])


def add(a: Vec, b: Vec) -> Vec:
    """a + b."""
    return (a[0] + b[0], a[1] + b[1])


def scale(k, a: Vec) -> Vec:
    """k a."""
    return (k * a[0], k * a[1])


def perp(a: Vec) -> Vec:
    """z x a: the velocity of a point at offset a on a body turning at unit rate."""
    return (-a[1], a[0])


def dot(a: Vec, b: Vec):
    """a . b."""
    return a[0] * b[0] + a[1] * b[1]


def cross(a: Vec, b: Vec):
    """z-component of a x b (moment of force b applied at lever a)."""
    return a[0] * b[1] - a[1] * b[0]


def rot(c, s, v: Vec) -> Vec:
    """v turned by the angle whose cosine and sine are c and s."""
    return (c * v[0] - s * v[1], s * v[0] + c * v[1])
