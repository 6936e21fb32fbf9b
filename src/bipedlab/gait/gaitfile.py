"""Gait files: one versioned JSON schema for every robot, with a per-robot payload.

A file is an envelope ``{"format": "bipedlab-gait/2", "robot": NAME, "kind": KIND, "payload":
{...}}``: ``kind`` names the payload's schema, which the robot package that writes it owns
(:func:`envelope` and :func:`open_envelope`). Version-1 files, which were the payload alone
with a format string of their own, are still read: a robot lists its legacy format strings.

The core's own kind, ``"hzd"`` (gaits designed by :mod:`bipedlab.gait.optimize`), has the
payload ``H0`` (m x n), ``c`` (n), ``alpha`` (m x (M+1)), ``theta_plus`` and ``theta_minus``
(rad), ``z_minus`` (the pre-impact fixed point, stance coordinates and rates), and free-form
``design`` figures (speed, cost, ...) (:func:`to_dict`, :func:`from_dict`, :func:`save`,
:func:`load`).
"""
from __future__ import annotations

import json
from importlib import resources
from pathlib import Path

import jax.numpy as jnp
import numpy as np

from bipedlab.control.hzd import VirtualConstraints

SCHEMA = "bipedlab-gait"
VERSION = 2
FORMAT = f"{SCHEMA}/{VERSION}"
#: the payload kind of the core's HZD gaits, and the format string of its version-1 files
HZD = "hzd"
HZD_V1 = "bipedlab-gait/1"


def envelope(robot: str, kind: str, payload: dict) -> dict:
    """A gait file's JSON object: the current format, the robot, the payload's kind."""
    return dict(format=FORMAT, robot=robot, kind=kind, payload=payload)


def open_envelope(d, source: str, kind: str, legacy: tuple = ()) -> dict:
    """The payload of a gait file of ``kind`` (with ``robot`` and ``format`` added), or, for a
    version-1 file whose format is one of ``legacy``, the file itself. ValueError naming the
    source otherwise."""
    if isinstance(d, dict) and d.get("format") in legacy:
        return d
    if not (isinstance(d, dict) and d.get("format") == FORMAT and d.get("kind") == kind
            and isinstance(d.get("payload"), dict)):
        raise ValueError(f"{source}: not a bipedlab gait file (expected format {FORMAT!r} with a {kind!r} payload)")
    return dict(d["payload"], robot=d.get("robot"), format=FORMAT)


def to_dict(robot: str, vc: VirtualConstraints, z_minus, design: dict) -> dict:
    return envelope(robot, HZD, dict(
        H0=np.asarray(vc.H0).tolist(), c=np.asarray(vc.c).tolist(), alpha=np.asarray(vc.alpha).tolist(),
        theta_plus=float(vc.theta_plus), theta_minus=float(vc.theta_minus),
        z_minus=np.asarray(z_minus).tolist(), design=design,
    ))


def save(path, robot: str, vc: VirtualConstraints, z_minus, design: dict) -> None:
    Path(path).write_text(json.dumps(to_dict(robot, vc, z_minus, design), indent=1))


def from_dict(d: dict, source: str = "gait") -> tuple[VirtualConstraints, jnp.ndarray, dict]:
    """(virtual constraints, pre-impact fixed point, the whole record); ValueError names the
    source and the problem."""
    d = open_envelope(d, source, HZD, legacy=(HZD_V1,))
    try:
        H0 = np.asarray(d["H0"], float)
        c = np.asarray(d["c"], float)
        alpha = np.asarray(d["alpha"], float)
        z = np.asarray(d["z_minus"], float)
        tp, tm = float(d["theta_plus"]), float(d["theta_minus"])
    except (KeyError, TypeError, ValueError) as e:
        raise ValueError(f"{source}: missing or malformed field ({e})") from None
    n = c.size
    if H0.ndim != 2 or H0.shape[1] != n or alpha.ndim != 2 or alpha.shape[0] != H0.shape[0] or z.size != 2 * n:
        raise ValueError(f"{source}: inconsistent sizes (H0 {H0.shape}, c {c.shape}, alpha {alpha.shape}, z_minus {z.shape})")
    if not all(np.all(np.isfinite(a)) for a in (H0, c, alpha, z, tp, tm)):
        raise ValueError(f"{source}: non-finite values (NaN or Infinity)")
    if not tm > tp:
        raise ValueError(f"{source}: theta_minus <= theta_plus (the phase must grow over a step)")
    vc = VirtualConstraints(jnp.asarray(H0), jnp.asarray(c), jnp.asarray(alpha), jnp.asarray(tp), jnp.asarray(tm))
    return vc, jnp.asarray(z), d


def check_sizes(vc: VirtualConstraints, z_minus, n: int, m: int, source: str) -> None:
    """ValueError unless the gait has m outputs on n stance coordinates (the robot's)."""
    if vc.H0.shape != (m, n) or z_minus.shape != (2 * n,):
        raise ValueError(f"{source}: gait sized for {vc.H0.shape[1]} stance coordinates and "
                         f"{vc.H0.shape[0]} outputs; this robot has {n} and {m}")


def read_json(path, unreadable: str = "cannot read") -> dict:
    """The JSON object in a file; ValueError naming the path and the problem."""
    try:
        return json.loads(Path(path).read_text())
    except OSError as e:
        raise ValueError(f"{path}: {unreadable} ({e.strerror})") from None
    except json.JSONDecodeError as e:
        raise ValueError(f"{path}: not valid JSON ({e.msg} at line {e.lineno})") from None


def load(path) -> tuple[VirtualConstraints, jnp.ndarray, dict]:
    return from_dict(read_json(path), str(path))


def shipped_text(package: str, name: str) -> tuple[str, str]:
    """The text of ``data/NAME.json`` shipped inside a robot package, and a label naming it."""
    return (resources.files(package).joinpath("data", f"{name}.json").read_text(),
            f"{package.replace('.', '/')}/data/{name}.json")


def shipped(package: str, name: str):
    """A gait shipped with a robot package, ``data/NAME.json`` inside ``package``."""
    text, label = shipped_text(package, name)
    return from_dict(json.loads(text), label)
