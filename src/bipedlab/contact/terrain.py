"""The one terrain type: flat ground, steps, a constant slope, or a height function sampled
as steps (:func:`from_function`); :func:`height_function` turns a terrain into the callable
``h(x)`` that the penalty and compliant grounds take.

A terrain is a piecewise-constant step profile plus a constant grade:
``ground(x) = heights[floor((x - x0) / step_len)] + grade * x`` (x in m). ``heights[0]`` is the
start, 0. Rough terrain (running paper, Section IV-B): a step every ``step_len`` = 3 m whose
height change is uniform in [-H, H] (the paper's "height changes up to +-25 cm"), with the
level kept within [-H, H] by reversing a change that would leave it (choice: the paper's
Fig. 8 shows ground "flat on average"; a free random walk drifts by about H sqrt(n / 3) and
changes the running energy without bound). The first ``flat_start`` m are level so every
trial starts alike. Terrains of one batch share the array length so they stack (vmap over the leading axis).
"""
from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from bipedlab.pytree import pytree


@pytree
class Terrain:
    """heights: (n,) level of each step (m); step_len (m); x0: where step 0 ends (m);
    grade: slope (rise / run)."""

    heights: jnp.ndarray
    step_len: float
    x0: float
    grade: float

    def __call__(self, x):
        """Ground height (m) below x (m): a terrain is a height function."""
        return ground(self, x)


def ground(terr: Terrain, x):
    """Ground height (m) below horizontal position x (m)."""
    n = terr.heights.shape[-1]
    idx = jnp.clip(jnp.floor((x - terr.x0) / terr.step_len).astype(jnp.int32) + 1, 0, n - 1)
    return jnp.take(terr.heights, idx) + terr.grade * x


def flat(length: float = 60.0, step_len: float = 3.0) -> Terrain:
    n = int(np.ceil(length / step_len)) + 8
    return Terrain(jnp.zeros(n), float(step_len), 3.0, 0.0)


def rough(rng: np.random.Generator, max_step: float, length: float = 60.0, step_len: float = 3.0,
          grade: float = 0.0, flat_start: float = 3.0, mode: str = "bounded") -> Terrain:
    """Random steps every step_len m. mode "bounded" (default): height changes uniform in
    [-max_step, max_step], a change that would take the level outside [-max_step, max_step]
    is reversed; "level": each level uniform in [-max_step, max_step] (changes up to twice
    max_step); "walk": unbounded random walk of the changes."""
    n = int(np.ceil(length / step_len)) + 8
    dh = rng.uniform(-max_step, max_step, size=n)
    if mode == "level":
        h = dh.copy()
    elif mode == "walk":
        h = np.cumsum(dh)
    else:  # "bounded": changes within +-max_step, the level reflected into [-max_step, max_step]
        h = np.zeros(n)
        for j in range(1, n):
            nxt = h[j - 1] + dh[j]
            h[j] = nxt if abs(nxt) <= max_step else h[j - 1] - dh[j]
    h[0] = 0.0
    return Terrain(jnp.asarray(h), float(step_len), float(flat_start), float(grade))


def slope(grade_percent: float, length: float = 60.0, step_len: float = 3.0) -> Terrain:
    t = flat(length, step_len)
    return t.replace(grade=grade_percent / 100.0)


def stack(terrains) -> Terrain:
    """Batch terrains of equal array length (a leading trial axis on heights)."""
    t0 = terrains[0]
    return Terrain(jnp.stack([t.heights for t in terrains]), t0.step_len, t0.x0, t0.grade)


def steps(heights, step_len: float = 3.0, x0: float = 3.0, grade: float = 0.0) -> Terrain:
    """Given step levels (m): level heights[0] up to x0, then heights[k] on
    [x0 + (k - 1) step_len, x0 + k step_len), plus the grade."""
    return Terrain(jnp.asarray(heights, dtype=float), float(step_len), float(x0), float(grade))


def from_function(h, length: float = 60.0, step_len: float = 0.05, x0: float = 0.0) -> Terrain:
    """Any height function h(x) (m), sampled as steps of ``step_len`` (at each step's centre)."""
    n = int(np.ceil(length / step_len)) + 2
    xs = x0 + (np.arange(n) - 0.5) * step_len
    return steps(np.asarray([h(x) for x in xs], dtype=float), step_len, x0)


def height_function(terr: Terrain):
    """The terrain as a traceable callable x -> height (m), e.g. for
    :mod:`bipedlab.contact.penalty` and :mod:`bipedlab.contact.compliant`."""
    return lambda x: ground(terr, x)
