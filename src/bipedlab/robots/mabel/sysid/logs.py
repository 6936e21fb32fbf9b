"""Experiment logs: the in-memory record and the CSV format of ``bipedlab identify mabel --data``.

Format (one file per experiment, any name ending in ``.csv``)::

    # bipedlab sysid log 1
    # experiment: transmission
    # units: time=s torque=N*m angle=rad force=N
    # actuator: mLA_L
    # combination: 2
    time_s,u_mLA_L,enc_mla_L
    0,0,0
    0.001,0.0214,0.000383
    ...

* Leading lines starting with ``#`` hold metadata, ``key: value``; the first may be a title.
  ``experiment`` (one of bias, transmission, leg, spring, balance, hopping) and ``units`` are
  required; units must read ``time=s torque=N*m angle=rad`` (``force=N`` too when a
  ``scale_N`` column is present): angles in radians, torques in newton metres of command.
  ``name`` is optional (default: the file name without ``.csv``).
* Then one header row and one row per sample. Columns: ``time_s`` (seconds, strictly
  increasing); ``u_<actuator>`` the commanded torque of mLA_L, mLS_L, mLA_R or mLS_R (N m, as
  logged: the amplifier's bias is not in it); ``enc_<coordinate>`` encoder angles (rad): the
  motors ``mla_L mls_L mla_R mls_R``, the joints ``la_L ls_L la_R ls_R`` (leg angle and leg
  shape, relative to the torso), the spring pulleys ``bsp_L bsp_R``, the torso ``tor``
  (absolute) and the boom ``boom_h boom_v`` (hip position over boom radius); ``scale_N`` the
  scale's reading (N). Row k: readings at t_k and the command held over [t_k, t_k+1).
* Time series (bias, transmission, leg, hopping) are sampled every 1 ms. Static experiments
  (spring, balance) have one row per posture; their time column only orders the rows.

What each experiment needs:

==============  =====================================  ==========================================
experiment      metadata                               columns
==============  =====================================  ==========================================
bias            actuator                               u_<actuator>, enc_<its motor>
transmission    actuator, combination (1, 2 or 3)      u_<actuator>, enc_<its motor>
leg             side (L/R)                             u_ of the actuated motors of that side,
                                                       enc_mla_<side>, enc_mls_<side>
spring          side (L/R)                             enc_tor, enc_la_<side>, enc_ls_<side>,
                                                       enc_bsp_<side>, scale_N
balance         support (toe_L, toe_R or hip)          enc_tor, enc_la_L, enc_ls_L, enc_la_R,
                                                       enc_ls_R
hopping         release_s (optional; rows before it:   u_ of all four motors, enc_ of boom_h
                robot held at rest; default 0)
                                                       boom_v tor la_L ls_L la_R ls_R bsp_L
                                                       bsp_R mla_L mls_L mla_R mls_R
==============  =====================================  ==========================================

Columns must agree with the experiment: every column is ``time_s``, ``u_`` of an actuator,
``enc_`` of an encoder above or ``scale_N``; a bias or transmission log commands its actuator
only, a leg log only motors of its side (one for ``mode: siso``, both for ``mode: mimo``, the
ones ``actuated`` lists), static logs (spring, balance) command nothing, and only spring logs
read the scale. Values are finite and within :data:`BOUNDS` (|time| 1e7 s, |command| 1000 N m,
|angle| 1e6 rad, |force| 1e5 N). Metadata values are parsed and range-checked: ``release_s``
(s, from 0 to the end of the log), ``boom_radius`` (m, :data:`BOOM_RADIUS`), ``cad_inertia``
(kg m^2, :data:`CAD_INERTIA`; a pulley combination at the motor is of order 1e-4).

Each log must also give its estimator something to fit (rows, postures, a command that varies
and a motor that moves, a full-rank regressor: :mod:`.preconditions`).

A log that breaks these rules raises :class:`LogError`, one line naming the file and the
problem (a missing column, time that does not increase, a NaN, units other than the above).
"""
from __future__ import annotations

import csv
import dataclasses
from pathlib import Path

import numpy as np

from bipedlab.inputs import TextError, decode_text, special_kind
from bipedlab.robots.mabel import tables as tb

KINDS = ("bias", "transmission", "leg", "spring", "balance", "hopping")
TIME_SERIES = ("bias", "transmission", "leg", "hopping")
UNITS = {"time": "s", "torque": "N*m", "angle": "rad", "force": "N"}
_UNIT_ALIASES = {"N*m": {"N*m", "Nm", "N.m", "N m", "N·m"}}
HOP_ENCODERS = ("boom_h", "boom_v", "tor", "la_L", "ls_L", "la_R", "ls_R", "bsp_L", "bsp_R",
                "mla_L", "mls_L", "mla_R", "mls_R")
TITLE = "bipedlab sysid log 1"
#: largest |value| of each column family (time s, command N m, encoder rad, scale N)
BOUNDS = {"time_s": 1e7, "u_": 1e3, "enc_": 1e6, "scale_N": 1e5}
#: ranges of numeric metadata: the boom's radius (m), a pulley combination's CAD inertia at the
#: motor (kg m^2); release_s must lie within the log
BOOM_RADIUS = (0.5, 10.0)
CAD_INERTIA = (1e-7, 1e-2)
STATIC = ("spring", "balance")


class LogError(ValueError):
    """A malformed experiment log; the message names the file and the problem."""


@dataclasses.dataclass
class Experiment:
    """One log. t (N,) s; u: {actuator: (N,)} commanded torque (N m); enc: {encoder: (N,)}
    readings (rad); scale: (N,) toe force read by the scale (N) or None; meta: metadata."""

    name: str
    kind: str
    t: np.ndarray
    u: dict
    enc: dict
    scale: np.ndarray | None = None
    meta: dict = dataclasses.field(default_factory=dict)
    #: the file it was read from ("" when built in memory)
    source: str = dataclasses.field(default="", compare=False, repr=False)

    def U(self, actuators) -> np.ndarray:
        """Commands (N, len(actuators)) in the given order."""
        return np.stack([self.u[a] for a in actuators], axis=1)


def motor_encoder(actuator: str) -> str:
    """Encoder name of an actuator's motor angle ("mLA_L" -> "mla_L")."""
    return actuator[:3].lower() + actuator[3:]


# ----- writing -----------------------------------------------------------------------------
def write_log(exp: Experiment, path) -> Path:
    """Write one experiment in the CSV format above."""
    path = Path(path)
    cols = {"time_s": exp.t}
    cols.update({f"u_{a}": v for a, v in exp.u.items()})
    cols.update({f"enc_{c}": v for c, v in exp.enc.items()})
    if exp.scale is not None:
        cols["scale_N"] = exp.scale
    units = "time=s torque=N*m angle=rad" + (" force=N" if exp.scale is not None else "")
    lines = [f"# {TITLE}", f"# experiment: {exp.kind}", f"# name: {exp.name}", f"# units: {units}"]
    lines += [f"# {k}: {v}" for k, v in exp.meta.items() if k not in ("experiment", "name", "units")]
    data = np.stack([np.asarray(v, float) for v in cols.values()], axis=1)
    with open(path, "w", newline="") as fh:
        fh.write("\n".join(lines) + "\n")
        fh.write(",".join(cols) + "\n")
        np.savetxt(fh, data, delimiter=",", fmt="%.12g")
    return path


def write_logs(experiments, directory) -> list[str]:
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    return [str(write_log(e, directory / f"{e.name}.csv")) for e in experiments]


# ----- reading -----------------------------------------------------------------------------
def _fail(path, problem: str):
    raise LogError(f"{path}: {problem}")


def _parse_units(path, text: str, need_force: bool):
    found = {}
    for item in text.replace(",", " ").split():
        if "=" not in item:
            _fail(path, f"units metadata {text!r} is not of the form 'time=s torque=N*m angle=rad'")
        k, v = item.split("=", 1)
        found[k.strip()] = v.strip()
    for key in ("time", "torque", "angle") + (("force",) if need_force else ()):
        want = UNITS[key]
        got = found.get(key)
        if got is None:
            _fail(path, f"units metadata gives no unit for {key} (expected {key}={want})")
        if got != want and got not in _UNIT_ALIASES.get(want, ()):
            _fail(path, f"units metadata says {key}={got}; expected {key}={want}")


def _required(kind: str, meta: dict, path) -> list[str]:
    """Columns a log of this kind must have (after checking the metadata it needs)."""

    def need(key, allowed=None):
        if key not in meta:
            _fail(path, f"metadata '{key}' is missing (a {kind} log needs it)")
        if allowed is not None and meta[key] not in allowed:
            _fail(path, f"metadata {key}={meta[key]!r}; expected one of {', '.join(allowed)}")
        return meta[key]

    if kind in ("bias", "transmission"):
        a = need("actuator", tb.ACTUATORS)
        if kind == "transmission":
            need("combination", ("1", "2", "3"))
        return ["time_s", f"u_{a}", f"enc_{motor_encoder(a)}"]
    if kind == "leg":
        s = need("side", tb.SIDES)
        return ["time_s", f"enc_mla_{s}", f"enc_mls_{s}"]
    if kind == "spring":
        s = need("side", tb.SIDES)
        return ["time_s", "enc_tor", f"enc_la_{s}", f"enc_ls_{s}", f"enc_bsp_{s}", "scale_N"]
    if kind == "balance":
        need("support", ("toe_L", "toe_R", "hip"))
        return ["time_s", "enc_tor", "enc_la_L", "enc_ls_L", "enc_la_R", "enc_ls_R"]
    return ["time_s"] + [f"u_{a}" for a in tb.ACTUATORS] + [f"enc_{c}" for c in HOP_ENCODERS]


def _column_problem(h: str) -> str | None:
    if h in ("time_s", "scale_N"):
        return None
    if h.startswith("u_"):
        if h[2:] in tb.ACTUATORS:
            return None
        return f"column '{h}' names no actuator (expected u_ followed by one of {', '.join(tb.ACTUATORS)})"
    if h.startswith("enc_"):
        if h[4:] in HOP_ENCODERS:
            return None
        return f"column '{h}' names no encoder (expected enc_ followed by one of {', '.join(HOP_ENCODERS)})"
    return f"column '{h}' is not a log column (time_s, u_<actuator>, enc_<encoder>, scale_N)"


def _contradiction(kind: str, meta: dict, header: list) -> str | None:
    """Why the columns contradict the experiment kind, or None."""
    u = [h[2:] for h in header if h.startswith("u_")]
    if "scale_N" in header and kind != "spring":
        return f"column 'scale_N' in a {kind} log (only spring logs read the scale)"
    if kind in ("bias", "transmission"):
        extra = [a for a in u if a != meta["actuator"]]
        if extra:
            return f"column 'u_{extra[0]}' in a {kind} log of actuator {meta['actuator']} (it commands that one only)"
    if kind in STATIC and u:
        return f"column 'u_{u[0]}' in a static {kind} log (the robot is posed, not commanded)"
    if kind == "leg":
        side = meta["side"]
        other = [a for a in u if not a.endswith(f"_{side}")]
        if other:
            return f"column 'u_{other[0]}' in a leg log of side {side} (only mLA_{side}, mLS_{side} belong to it)"
        mode = meta.get("mode")
        if mode is not None:
            if mode not in ("siso", "mimo"):
                return f"metadata mode={mode!r}; expected siso or mimo"
            want = 1 if mode == "siso" else 2
            if len(u) != want:
                return (f"a {mode} leg log with {len(u)} command column{'s' * (len(u) != 1)} "
                        f"({', '.join('u_' + a for a in u)}); {mode} means {want}")
        if "actuated" in meta and sorted(meta["actuated"].split()) != sorted(u):
            return (f"metadata actuated={meta['actuated']!r} but the commands logged are "
                    f"{', '.join('u_' + a for a in u)}")
    return None


def _metadata_number(path, meta: dict, key: str, low: float, high: float, unit: str) -> None:
    if key not in meta:
        return
    try:
        x = float(meta[key])
    except ValueError:
        _fail(path, f"metadata {key}={meta[key]!r} is not a number ({unit})")
    if not (np.isfinite(x) and low <= x <= high):
        _fail(path, f"metadata {key}={meta[key]} is outside [{low:g}, {high:g}] {unit}")


def _csv_rows(path, lines):
    try:
        return list(csv.reader(lines))
    except csv.Error as e:
        _fail(path, f"is not CSV ({e})")


def read_log(path) -> Experiment:
    """Read and check one CSV log; raise :class:`LogError` naming the file and the problem."""
    from bipedlab.robots.mabel.sysid import preconditions

    path = Path(path)
    kind = special_kind(path)  # a FIFO or a device would block or never end: refused unopened
    if kind is not None:
        _fail(path, f"cannot be read ({kind}, not a regular file)")
    try:
        text = decode_text(path.read_bytes())
    except TextError as e:
        _fail(path, f"cannot be read: it {e}")
    except OSError as e:
        _fail(path, f"cannot be read ({e.strerror or e.__class__.__name__})")
    lines = text.splitlines()
    meta, i = {}, 0
    while i < len(lines) and lines[i].startswith("#"):
        body = lines[i][1:].strip()
        if ":" in body:
            k, v = body.split(":", 1)
            meta[k.strip()] = v.strip()
        i += 1
    kind = meta.get("experiment")
    if kind is None:
        _fail(path, "metadata 'experiment' is missing (one of " + ", ".join(KINDS) + ")")
    if kind not in KINDS:
        _fail(path, f"unknown experiment {kind!r}; expected one of {', '.join(KINDS)}")
    if i >= len(lines) or not lines[i].strip():
        _fail(path, "no header row after the metadata")
    header = [h.strip() for h in _csv_rows(path, [lines[i]])[0]]
    if len(set(header)) != len(header):
        _fail(path, "a column name appears twice in the header")
    if "units" not in meta:
        _fail(path, "metadata 'units' is missing (expected 'time=s torque=N*m angle=rad')")
    _parse_units(path, meta["units"], need_force="scale_N" in header)
    for col in _required(kind, meta, path):
        if col not in header:
            _fail(path, f"missing column '{col}' (a {kind} log needs {', '.join(_required(kind, meta, path))})")
    for h in header:
        bad = _column_problem(h)
        if bad:
            _fail(path, bad)
    if kind == "leg" and not any(f"u_{a}" in header for a in (f"mLA_{meta['side']}", f"mLS_{meta['side']}")):
        _fail(path, f"missing column 'u_mLA_{meta['side']}' or 'u_mLS_{meta['side']}' (a leg log needs the "
                    "command of at least one motor of its side)")
    bad = _contradiction(kind, meta, header)
    if bad:
        _fail(path, bad)
    if "name" in meta and not meta["name"]:
        _fail(path, "metadata name is empty")
    _metadata_number(path, meta, "cad_inertia", *CAD_INERTIA, "kg m^2")
    _metadata_number(path, meta, "boom_radius", *BOOM_RADIUS, "m")
    _metadata_number(path, meta, "release_s", 0.0, BOUNDS["time_s"], "s")
    rows = [r for r in _csv_rows(path, lines[i + 1:]) if r and any(c.strip() for c in r)]
    if not rows:
        _fail(path, "has no data rows")
    for j, r in enumerate(rows):
        if len(r) != len(header):
            _fail(path, f"row {j + 1} has {len(r)} values for {len(header)} columns")
    try:
        data = np.array(rows, dtype=float)
    except ValueError:
        for j, r in enumerate(rows):
            for c, v in zip(header, r):
                try:
                    float(v)
                except ValueError:
                    _fail(path, f"row {j + 1}, column '{c}': {v.strip()!r} is not a number")
        raise
    bad = ~np.isfinite(data)
    if bad.any():
        j, c = np.argwhere(bad)[0]
        _fail(path, f"column '{header[c]}' has a non-finite value ({rows[j][c].strip()}) at row {j + 1}")
    for c, h in enumerate(header):
        bound = BOUNDS[next(k for k in BOUNDS if h.startswith(k))]
        big = np.abs(data[:, c]) > bound
        if big.any():
            j = int(np.argmax(big))
            _fail(path, f"column '{h}' has {rows[j][c].strip()} at row {j + 1}, outside +-{bound:g}")
    cols = {h: data[:, k] for k, h in enumerate(header)}
    t = cols["time_s"]
    dt = np.diff(t)
    if np.any(dt <= 0):
        j = int(np.argmax(dt <= 0)) + 1
        _fail(path, f"time_s is not strictly increasing (row {j + 1}: {t[j]:g} s after {t[j - 1]:g} s)")
    if kind in TIME_SERIES:
        if len(t) < 20:
            _fail(path, f"has {len(t)} samples; a {kind} log needs at least 20")
        if np.max(np.abs(dt - 1e-3)) > 1e-6:
            _fail(path, f"time_s must advance by 1 ms per row (found steps from {dt.min():g} to {dt.max():g} s)")
    if "release_s" in meta and float(meta["release_s"]) > t[-1] - t[0]:
        _fail(path, f"metadata release_s={meta['release_s']} is after the log's end "
                    f"({t[-1] - t[0]:g} s after its start)")
    u = {h[2:]: v for h, v in cols.items() if h.startswith("u_")}
    enc = {h[4:]: v for h, v in cols.items() if h.startswith("enc_")}
    name = meta.pop("name", path.stem)
    meta.pop("experiment")
    meta.pop("units")
    meta = {k: v for k, v in meta.items() if not k.startswith("bipedlab")}
    exp = Experiment(name, kind, t, u, enc, cols.get("scale_N"), meta, source=str(path))
    why = preconditions.problem(exp)
    if why:
        _fail(path, why)
    return exp


def read_logs(directory) -> list[Experiment]:
    """Every ``*.csv`` log of a directory (sorted by name), each checked."""
    directory = Path(directory)
    if not directory.is_dir():
        raise LogError(f"{directory}: not a directory")
    files = sorted(directory.glob("*.csv"))
    if not files:
        raise LogError(f"{directory}: no .csv logs found")
    out = [read_log(f) for f in files]
    first = {}
    for e in out:
        if e.name in first:
            raise LogError(f"{e.source}: its name {e.name!r} is also that of {first[e.name]}")
        first[e.name] = e.source
    from bipedlab.robots.mabel.sysid import preconditions

    preconditions.check(out)
    return out
