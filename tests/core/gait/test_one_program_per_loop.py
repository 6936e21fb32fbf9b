"""Variants of a study run on the program its first run compiled: another gait, another
initial perturbation or seed, or other gains of the controller, lowers no new program (a gait and
the gains are traced arguments of the walk, of its Poincaré Jacobian and of the restricted map,
not constants baked into them)."""
from __future__ import annotations

import dataclasses

import jax.numpy as jnp
import numpy as np
from helpers import new_programs

from bipedlab.robots.five_link import study as fs


def _other_gait(vc):
    """The shipped gait with its free Bézier coefficients moved slightly: a different gait of
    the same shape."""
    alpha = np.asarray(vc.alpha).copy()
    alpha[:, 2:-2] *= 1.01
    return dataclasses.replace(vc, alpha=jnp.asarray(alpha))


def test_a_second_gait_and_perturbation_walk_on_the_first_walks_programs():
    vc, z_star, meta = fs.load_gait()
    s = fs.study()
    first, built = new_programs(fs.hzd_study.walk, s, vc, z_star, meta, steps=2, perturb=0.0)
    assert built > 0  # the first walk compiles its programs
    assert not first[0]["fell"] and first[0]["steps_completed"] == 2
    # another gait, perturbation and seed, and other gains of the controller (eps, kp, kd: traced);
    # the moved gait's fixed point is no longer z_star, so it is walked anyway
    gains = dict(meta, design=dict(meta["design"], controller="iolin", eps=0.05, kp=1.5, kd=2.5))
    second, built = new_programs(fs.hzd_study.walk, s, _other_gait(vc), z_star, gains, steps=2, perturb=1e-3,
                                 seed=7, walk_anyway=True)
    assert built == 0, f"the second variant lowered {built} new programs"
    # and the variant is a different walk, not the first one again
    assert second[0]["speed_mps"] != first[0]["speed_mps"]
    assert second[0]["max_abs_eigenvalue"] != first[0]["max_abs_eigenvalue"]
    assert (second[0]["eps"], second[0]["kp"], second[0]["kd"]) == (0.05, 1.5, 2.5)
