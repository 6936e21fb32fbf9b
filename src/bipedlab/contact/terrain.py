"""The one terrain type: flat ground, steps, a constant slope, or a height function sampled
as steps (:func:`from_function`); :func:`height_function` turns a terrain into the callable
``h(x)`` that the penalty and compliant grounds take.

A terrain is a piecewise-constant step profile plus a constant grade:
``ground(x) = heights[floor((x - x0) / step_len)] + grade * x`` (x in m). ``heights[0]`` is the
start, 0. The first ``flat_start`` m are level so every trial starts alike. Terrains of one
batch share the array length so they stack (vmap over the leading axis).

Rough terrain of the running paper (Section IV-B, Figs. 6 and 8), :func:`rough` mode
``"paper"`` (the default). What the paper states, and what follows from it:

* step spacing: "random steps every 3m" -> ``step_len`` = 3 m;
* height distribution: "height changes up to +-25cm" -> the change between neighbouring levels
  never exceeds H = 25 cm; Fig. 8's top row is "ground that is flat on average" (its bottom row
  adds the 1 % slope), so the level has no drift and no trend over the 60 m;
* how the level evolves over 60 m (20 steps): a level that is flat on average and whose changes
  are bounded by H, with nothing else stated, is read as independent levels, each uniform in
  [-H/2, H/2]: every change then lies in [-H, H] (triangular, the full 25 cm reached only
  between opposite extremes), the mean level is 0 at every step and the level s.d. is
  H / (2 sqrt 3) = 7.2 cm at any distance, however long the run.

What this reading implies for the paper's own spring-mass figure: the policy returns the
bounce height above the previous stance's ground in one step and the model conserves energy,
so an apex over a level h has speed v with v^2 = v*^2 - 2 g h: speed s.d. about g / v* = 1.96
(m/s per m) times the level s.d., 14 cm/s for 7.2 cm; the paper's 18.6 cm/s corresponds to a
level s.d. near 9.5 cm. The text alone does not give that: the two literal readings bracket it
("each level within +-H", 14.4 cm, mode ``"level"``; "changes uniform in +-H", an unbounded
walk, mode ``"walk"``). The measured spread of both readings is in the running study's report.

Mode ``"bounded"`` (the former default, the running study's ``--terrain rough-reflected``): changes uniform in [-H, H], a change that would take the level outside [-H, H]
reversed; its level s.d. is 0.117-0.127 m over 60 m, and the spring-mass speed s.d. on it
30-45 % above the paper's.
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
          grade: float = 0.0, flat_start: float = 3.0, mode: str = "paper") -> Terrain:
    """Random steps every step_len m, changes between neighbouring levels up to max_step (H).
    mode "paper" (default, the derivation in the module docstring): independent levels, each
    uniform in [-H/2, H/2]; "bounded": changes uniform in [-H, H], a change that would take the
    level outside [-H, H] is reversed; "level": each level uniform in [-H, H] (changes up to
    2 H); "walk": unbounded random walk of changes uniform in [-H, H]."""
    n = int(np.ceil(length / step_len)) + 8
    if mode == "paper":
        h = rng.uniform(-0.5 * max_step, 0.5 * max_step, size=n)
        h[0] = 0.0
        return Terrain(jnp.asarray(h), float(step_len), float(flat_start), float(grade))
    dh = rng.uniform(-max_step, max_step, size=n)
    if mode == "level":
        h = dh.copy()
    elif mode == "walk":
        h = np.cumsum(dh)
    elif mode == "bounded":  # changes within +-max_step, the level reflected into [-max_step, max_step]
        h = np.zeros(n)
        for j in range(1, n):
            nxt = h[j - 1] + dh[j]
            h[j] = nxt if abs(nxt) <= max_step else h[j - 1] - dh[j]
    else:
        raise ValueError(f"rough terrain mode must be paper, bounded, level or walk, got {mode!r}")
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
