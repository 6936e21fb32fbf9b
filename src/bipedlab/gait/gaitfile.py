"""Gait files: one versioned JSON schema for every robot, with a per-robot payload.

A file is an envelope ``{"format": "bipedlab-gait/2", "robot": NAME, "kind": KIND, "payload":
{...}}``: ``kind`` names the payload's schema, which the robot package that writes it owns
(:func:`envelope` and :func:`open_envelope`). Version-1 files, which were the payload alone
with a format string of their own, are still read: a robot lists its legacy format strings.

The core's own kind, ``"hzd"`` (gaits designed by :mod:`bipedlab.gait.optimize`), has the
payload ``H0`` (m x n), ``c`` (n), ``alpha`` (m x (M+1)), ``theta_plus`` and ``theta_minus``
(rad), ``z_minus`` (the pre-impact fixed point, stance coordinates and rates), and free-form
``design`` figures (speed, cost, the controller's chosen ``eps``, ``kp``, ``kd``, ...)
(:func:`to_dict`, :func:`from_dict`, :func:`save`, :func:`load`). Every field is checked on
reading, before anything runs (:mod:`.schema`): a problem raises ValueError
``"<file>: payload.<field>: <problem>"``.
"""
from __future__ import annotations

import json
import math
from importlib import resources
from pathlib import Path

import jax.numpy as jnp
import numpy as np

from bipedlab.control.hzd import VirtualConstraints
from bipedlab.gait import schema

SCHEMA = "bipedlab-gait"
VERSION = 2
FORMAT = f"{SCHEMA}/{VERSION}"
#: the payload kind of the core's HZD gaits, and the format string of its version-1 files
HZD = "hzd"
HZD_V1 = "bipedlab-gait/1"


def envelope(robot: str, kind: str, payload: dict) -> dict:
    """A gait file's JSON object: the current format, the robot, the payload's kind."""
    return dict(format=FORMAT, robot=robot, kind=kind, payload=payload)


def open_payload(d, source: str, kind: str, legacy: tuple = (), robot: str | None = None) -> tuple[dict, str]:
    """(the payload of a gait file of ``kind`` with ``robot`` and ``format`` added, the prefix
    naming its fields in messages: ``"payload."``); for a version-1 file whose format is one
    of ``legacy``, (the file itself, ""). With ``robot``, a file that says it is another
    robot's is refused first, naming both (:func:`bipedlab.gait.schema.expect_robot`).
    ValueError naming the source and the field otherwise."""
    if not isinstance(d, dict):
        schema.fail(source, "", f"not a bipedlab gait file (the top level is {schema.describe(d)}, not an object)")
    if robot is not None:
        schema.expect_robot(d, source, robot)
    fmt = d.get("format")
    if fmt in legacy and isinstance(fmt, str):
        robot = schema.text(d, "robot", source, required=False)
        return dict(d, robot=robot), ""
    if fmt != FORMAT:
        got = repr(fmt) if isinstance(fmt, str) else schema.describe(fmt) if "format" in d else "nothing"
        schema.fail(source, "format", f"not a bipedlab gait file (expected {FORMAT!r}, got {got})")
    got_kind = schema.text(d, "kind", source)
    if got_kind != kind:
        schema.fail(source, "kind", f"a {got_kind!r} gait; expected a {kind!r} payload")
    robot = schema.text(d, "robot", source)
    payload = schema.section(d, "payload", source)
    return dict(payload, robot=robot, format=FORMAT), "payload."


def open_envelope(d, source: str, kind: str, legacy: tuple = (), robot: str | None = None) -> dict:
    """The payload of a gait file of ``kind`` (with ``robot`` and ``format`` added), or, for a
    version-1 file whose format is one of ``legacy``, the file itself. ValueError naming the
    source and the field otherwise (and the robots, for another ``robot``'s gait)."""
    return open_payload(d, source, kind, legacy, robot)[0]


def to_dict(robot: str, vc: VirtualConstraints, z_minus, design: dict) -> dict:
    return envelope(robot, HZD, dict(
        H0=np.asarray(vc.H0).tolist(), c=np.asarray(vc.c).tolist(), alpha=np.asarray(vc.alpha).tolist(),
        theta_plus=float(vc.theta_plus), theta_minus=float(vc.theta_minus),
        z_minus=np.asarray(z_minus).tolist(), design=design,
    ))


def save(path, robot: str, vc: VirtualConstraints, z_minus, design: dict) -> None:
    Path(path).write_text(json.dumps(to_dict(robot, vc, z_minus, design), indent=1))


#: most coefficients of a Bézier virtual constraint (degree 1 to 20)
MAX_COEFFICIENTS = 21
#: bounds of the controller gains a design records (eps, kp, kd), checked on reading
GAIN_BOUND = 1e6
MIN_GAIN = 1e-9


def from_dict(d: dict, source: str = "gait", sizes: tuple | None = None, robot: str | None = None
              ) -> tuple[VirtualConstraints, jnp.ndarray, dict]:
    """(virtual constraints, pre-impact fixed point, the whole record). Every field is
    checked (type, shape, finiteness, the bounds of :mod:`bipedlab.gait.schema`); with
    ``sizes = (n, m)`` the gait must have m outputs on n stance coordinates; with ``robot``,
    it must not be another robot's. ValueError naming the source and the field."""
    d, pre = open_payload(d, source, HZD, legacy=(HZD_V1,), robot=robot)
    n, m = sizes if sizes is not None else (None, None)
    H0 = schema.array(d, "H0", source, pre, (m, n), schema.COEFFICIENT, "")
    m, n = H0.shape
    c = schema.array(d, "c", source, pre, (n,), schema.COEFFICIENT, "")
    alpha = schema.array(d, "alpha", source, pre, (m, None))
    if not 2 <= alpha.shape[1] <= MAX_COEFFICIENTS:
        schema.fail(source, pre + "alpha", f"expected {m} rows of 2 to {MAX_COEFFICIENTS} Bézier coefficients, "
                                           f"got {alpha.shape[1]}")
    z = schema.array(d, "z_minus", source, pre, (2 * n,), bound=math.inf)
    schema.within(z[:n], source, pre + "z_minus", schema.ANGLE, "rad")
    schema.within(z[n:], source, pre + "z_minus", schema.RATE, "rad/s", offset=n)
    tp = schema.number(d, "theta_plus", source, pre)
    tm = schema.number(d, "theta_minus", source, pre)
    if not tm > tp:
        schema.fail(source, pre + "theta_minus", "theta_minus <= theta_plus (the phase must grow over a step)")
    design = schema.section(d, "design", source, pre, required=False)
    if design is not None:
        schema.optional_number(design, "speed_mps", source, pre + "design.", 100.0, "m/s")
        for key in ("eps", "kp", "kd"):  # the controller's gains chosen by the design
            if design.get(key) is not None:
                schema.number(design, key, source, pre + "design.", GAIN_BOUND, "", low=MIN_GAIN)
        schema.record_arrays(design, source, pre + "design.")
    vc = VirtualConstraints(jnp.asarray(H0), jnp.asarray(c), jnp.asarray(alpha), jnp.asarray(tp), jnp.asarray(tm))
    return vc, jnp.asarray(z), d


def check_sizes(vc: VirtualConstraints, z_minus, n: int, m: int, source: str) -> None:
    """ValueError unless the gait has m outputs on n stance coordinates (the robot's)."""
    if vc.H0.shape != (m, n) or z_minus.shape != (2 * n,):
        raise ValueError(f"{source}: gait sized for {vc.H0.shape[1]} stance coordinates and "
                         f"{vc.H0.shape[0]} outputs; this robot has {n} and {m}")


def read_json(path, unreadable: str = "cannot read"):
    """The JSON value in a file; ValueError naming the path and the problem (see
    :func:`bipedlab.gait.schema.read_json`)."""
    return schema.read_json(path, unreadable)


def parse(text: str, source: str):
    """The JSON value of a gait file's text; ValueError naming ``source`` (see
    :func:`bipedlab.gait.schema.parse`)."""
    return schema.parse(text, source)


def load(path, sizes: tuple | None = None, robot: str | None = None) -> tuple[VirtualConstraints, jnp.ndarray, dict]:
    return from_dict(read_json(path), str(path), sizes, robot)


def shipped_text(package: str, name: str) -> tuple[str, str]:
    """The text of ``data/NAME.json`` shipped inside a robot package, and a label naming it."""
    return (resources.files(package).joinpath("data", f"{name}.json").read_text(),
            f"{package.replace('.', '/')}/data/{name}.json")


def shipped(package: str, name: str, sizes: tuple | None = None, robot: str | None = None):
    """A gait shipped with a robot package, ``data/NAME.json`` inside ``package``."""
    text, label = shipped_text(package, name)
    return from_dict(schema.parse(text, label), label, sizes, robot)
