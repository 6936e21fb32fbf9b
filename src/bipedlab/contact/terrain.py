"""Unobserved terrains of the running study: flat, random steps, constant slope.

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

from typing import NamedTuple

import jax.numpy as jnp
import numpy as np


class Terrain(NamedTuple):
    """heights: (n,) level of each step (m); step_len (m); x0: where step 0 ends (m);
    grade: slope (rise / run)."""

    heights: jnp.ndarray
    step_len: float
    x0: float
    grade: float


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
    return t._replace(grade=grade_percent / 100.0)


def stack(terrains) -> Terrain:
    """Batch terrains of equal array length (a leading trial axis on heights)."""
    t0 = terrains[0]
    return Terrain(jnp.stack([t.heights for t in terrains]), t0.step_len, t0.x0, t0.grade)
