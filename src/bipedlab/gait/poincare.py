"""Poincaré analysis of any return map: fixed point by Newton's method with the exact
(forward-mode) Jacobian, that Jacobian, a central-difference check, and eigenvalues sorted by
magnitude. ``fun`` is a pure function x -> P(x) on a section's coordinates; it may contain
``lax.while_loop`` event location (forward mode differentiates through it)."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np


def value_and_jacobian(fun):
    """One compiled function x -> (fun(x), dfun/dx) (forward mode)."""
    def twice(x):
        y = fun(x)
        return y, y

    return jax.jit(jax.jacfwd(twice, has_aux=True))


def fixed_point(fun, x0, iterations: int = 8, fix=None):
    """Newton's method on x = fun(x) with the exact Jacobian; ``fix`` (index) keeps one
    coordinate at its value. Returns (x, J at x, residual)."""
    vj = value_and_jacobian(fun)
    x = jnp.asarray(x0)
    J, fx = vj(x)
    for _ in range(iterations):
        r = fx - x
        if float(jnp.max(jnp.abs(r))) < 1e-11:
            break
        A = J - jnp.eye(x.size)
        if fix is not None:
            A = A.at[:, fix].set(0.0)
        x = x + jnp.linalg.lstsq(A, -r)[0]
        J, fx = vj(x)
    return x, J, float(jnp.max(jnp.abs(fx - x)))


def eigenvalues(J):
    """Eigenvalues sorted by magnitude (largest first)."""
    ev = np.linalg.eigvals(np.asarray(J))
    return ev[np.argsort(-np.abs(ev))]


def central_differences(fun, x, step=1e-6, relative: bool = True):
    """Jacobian of ``fun`` at ``x`` by central differences (the check on the autodiff one);
    the step of coordinate i is ``step * max(1, |x_i|)`` when ``relative``, else ``step``."""
    fun = jax.jit(fun)
    x = np.asarray(x, float)
    cols = []
    for i in range(x.size):
        e = np.zeros_like(x)
        e[i] = step * max(1.0, abs(x[i])) if relative else step
        cols.append((np.asarray(fun(jnp.asarray(x + e))) - np.asarray(fun(jnp.asarray(x - e)))) / (2 * e[i]))
    return np.stack(cols, 1)
