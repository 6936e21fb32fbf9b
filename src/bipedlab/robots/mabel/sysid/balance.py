"""The static check of the torso's CAD parameters (Section VI, Fig. 17).

The torso cannot be identified dynamically (it is too heavy and its workspace too small), so
its CAD mass, centre of mass and inertia are checked statically. In the first set of
experiments the robot is balanced by hand on its right toe in several postures; in the second
the hip is fixed, the legs hang, and the torso is balanced upright. From the logged joint and
torso angles the CAD model gives the centre of mass, which should lie over the toe (robot and
boom) or over the hip (robot without boom); :func:`com_check` reports the horizontal
distances (the paper finds at most 6 mm).

The boom enters the first set through its weight at the hip: its moment ``m_boom g r_com``
over its radius R acts as a mass ``m_boom r_com / R`` (4.8 kg) at the hip.
"""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
from scipy import optimize

from bipedlab.robots.mabel import dynamics as md
from bipedlab.robots.mabel import model as mm
from bipedlab.robots.mabel import tables as tb

_H = {c: i for i, c in enumerate(mm.COORDS_13)}


def boom_mass() -> float:
    """Mass (kg) the boom's weight adds at the hip."""
    return tb.BOOM["mass"] * tb.BOOM["com"] / tb.BOOM["radius"]


@jax.jit
def _com_and_toes(m: mm.Mabel, q):
    return jnp.sum(m.body.tree.mass), md.com_position(m, q), md.toe_positions(m, q)


def com_gap(m: mm.Mabel, q, support: str) -> float:
    """Horizontal distance (m) from the support point to the centre of mass: the toe
    ("toe_L"/"toe_R", centre of mass of robot and boom) or the hip ("hip", robot alone)."""
    q = jnp.asarray(q, dtype=jnp.float64)
    M, com, toes = _com_and_toes(m, q)
    M, c = float(M), float(com[0])
    hip = float(q[_H["x"]])
    if support == "hip":
        return c - hip
    mb = boom_mass()
    toe = float(toes[mm.TOES.index(support), 0])
    return (M * c + mb * hip) / (M + mb) - toe


def balance_torso(m: mm.Mabel, q, support: str) -> float:
    """Torso angle (rad) at which the centre of mass lies over the support (see com_gap)."""
    q = jnp.asarray(q, dtype=jnp.float64)
    return optimize.brentq(lambda tor: com_gap(m, q.at[_H["tor"]].set(tor), support), -0.7, 0.7, xtol=1e-14)


@dataclasses.dataclass(frozen=True)
class ComCheck:
    """Per experiment: support point and horizontal distances (mm) COM - support per posture."""

    support: dict
    distance_mm: dict

    @property
    def max_abs_mm(self) -> float:
        return float(max(np.max(np.abs(d)) for d in self.distance_mm.values())) if self.distance_mm else float("nan")


def com_check(m: mm.Mabel, experiments) -> ComCheck:
    """Distances COM - toe / hip of every logged posture on the CAD model m (Fig. 17)."""
    support, dist = {}, {}
    for e in experiments:
        s = e.meta["support"]
        rows = []
        for i in range(len(e.t)):
            q = np.zeros(13)
            for c, v in e.enc.items():
                if c in _H:
                    q[_H[c]] = v[i]
            rows.append(1e3 * com_gap(m, q, s))
        support[e.name] = s
        dist[e.name] = np.array(rows)
    return ComCheck(support, dist)


def estimate_torso_com(m: mm.Mabel, experiments, step: float = 1e-3) -> np.ndarray:
    """The shift (m, torso frame) of the torso's centre of mass that best zeroes the logged
    postures' COM distances (least squares; the distances are linear in the shift)."""
    from bipedlab.robots.mabel.sysid.params import with_torso_com

    def gaps(offset):
        mo = m.replace(body=with_torso_com(m.body, offset))
        return np.concatenate([com_check(mo, experiments).distance_mm[e.name] for e in experiments]) * 1e-3

    g0 = gaps(np.zeros(2))
    A = np.stack([(gaps(np.eye(2)[k] * step) - g0) / step for k in range(2)], axis=1)
    shift, *_ = np.linalg.lstsq(A, -g0, rcond=None)
    return shift
