"""The command library: what a command module needs to declare the commands of ``bipedlab``.

A command module (a robot package's ``cli.py``, the core's :mod:`bipedlab.report.cli` and
:mod:`bipedlab.benchcmd`, or a third-party module named by an entry point of the group
``bipedlab.robots``) holds ``COMMANDS``, a list of :class:`Command`; :mod:`bipedlab.registry`
collects them and builds the parser, :mod:`bipedlab.cli` runs the chosen one.

This module imports nothing but the standard library, so that a command module can be imported
(and ``bipedlab --help`` built) without JAX: a command's ``run`` imports its study modules itself.

* :class:`Command` and :class:`UsageError` (bad input found late: one ``bipedlab: error:`` line,
  status 2); :class:`Scenario` (a speed scenario of ``bipedlab bench``, in ``SCENARIOS``) and
  the :class:`BenchOptions` it runs with;
* argparse types that check their value before any work: :func:`int_in`, :func:`float_in` (the
  range is appended to the option's help), :data:`SEED`, :func:`text` (non-empty strings),
  :func:`positive_int`, :func:`positive_float`, :func:`nonnegative_float`;
* output options checked and staged by the core: :func:`add_out` (a folder), :func:`add_save`
  (a file);
* :func:`one_line`: a message kept on one line whatever its input.
"""
from __future__ import annotations

import argparse
import math
import os
import re
from dataclasses import dataclass
from typing import Callable, Optional


@dataclass(frozen=True)
class Command:
    """One study of the ``bipedlab`` command.

    verb: the first word ("walk", "optimize", "experiment", "hop", "run", "identify", "bench").
    robot: the second word (a robot package's name for itself, e.g. "my-biped"), or None for a verb without one (bench).
    help: one line for the listings.
    add_arguments(parser): adds the command's options; the core adds ``--json`` after it
        unless it declared one.
    run(args, progress) -> (record, summary): runs the study on the parsed options; progress
        is a one-argument callable printing to stderr; raises UsageError on bad input; the
        record is a JSON-able dict and summary(record) the human-readable text.
    compile_cache: whether to point JAX's persistent compilation cache at the cache directory
        before running.
    before_jax(args): optional hook run first, before JAX touches a device (e.g. to set the
        number of CPU devices).
    validate(args): optional check of the parsed options run before anything else (before
        the outputs are staged, before before_jax and run); raises UsageError on a combination
        that cannot mean anything. It should not import the study modules.
    exit_status(record): optional exit status of a run that completed (e.g. 1 for a check
        that found differences); 0 without it.
    bench: short versions of the command for ``bipedlab bench --studies`` (the first-run
        benchmark, :mod:`bipedlab.studybench`): a tuple of argument tuples appended to the
        command's words, e.g. ``(("--steps", "3"),)``; an argument tuple starting with "long"
        is run only when named.
    """

    verb: str
    robot: Optional[str]
    help: str
    add_arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace, Callable[[str], None]], tuple]
    compile_cache: bool = True
    before_jax: Optional[Callable[[argparse.Namespace], None]] = None
    validate: Optional[Callable[[argparse.Namespace], None]] = None
    bench: tuple = ()
    exit_status: Optional[Callable[[dict], int]] = None

    @property
    def name(self) -> str:
        """The command line's words: "walk <robot>", or "bench"."""
        return self.verb if self.robot is None else f"{self.verb} {self.robot}"


@dataclass(frozen=True)
class BenchOptions:
    """The options of ``bipedlab bench`` as a speed scenario receives them.

    batches: batch sizes of the batched runs; seconds: simulated seconds per rollout; threads:
    CPU cores for the comparison engine's threads and the batch sharding (None: all); mujoco:
    whether to run the MuJoCo comparison."""

    batches: tuple
    seconds: float
    threads: Optional[int]
    mujoco: bool


@dataclass(frozen=True)
class Scenario:
    """A speed scenario of ``bipedlab bench`` (:mod:`bipedlab.bench`), declared in a command
    module's ``SCENARIOS`` beside its ``COMMANDS``.

    name: what ``bench --scenario`` calls it (e.g. "my-biped-standing").
    help: one line for ``bench --help``.
    run(options, progress) -> (record, summary): times the scenario with the parsed
        :class:`BenchOptions`; imports its modules itself, like a command's run.
    """

    name: str
    help: str
    run: Callable[[BenchOptions, Callable[[str], None]], tuple]


class UsageError(Exception):
    """Bad input found by a command's run: reported as one ``bipedlab: error:`` line, status 2."""


_LINE_BREAKS = {c: repr(c)[1:-1] for c in "\n\r\v\f\x1c\x1d\x1e\x85\u2028\u2029"}


def one_line(text: str) -> str:
    """``text`` with every character that breaks a line (for str.splitlines too) shown as an
    escape, so an error stays one line whatever the input."""
    return "".join(_LINE_BREAKS.get(c, c) for c in str(text))


_INTEGER = re.compile(r"[+-]?[0-9]+", re.ASCII)
_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?", re.ASCII)
NUMERALS = "ASCII digits with an optional sign (numbers also a decimal point and an exponent, e.g. -1.5e-3)"
"""The one numeral grammar of every numeric option."""


def parse_int(text) -> int:
    """An integer numeral (an optional sign and ASCII digits) as an int; ValueError on anything
    else (Python's int() also takes '1_0', blanks and other scripts' digits)."""
    if not isinstance(text, str) or _INTEGER.fullmatch(text) is None:
        raise ValueError(f"not an integer numeral: {text!r}")
    return int(text)


def parse_float(text) -> float:
    """A number numeral (an optional sign, ASCII digits, a decimal point, an exponent) as a
    float; ValueError on anything else ('1_0', 'inf', 'nan', blanks, other scripts' digits)."""
    if not isinstance(text, str) or _NUMBER.fullmatch(text) is None:
        raise ValueError(f"not a numeral: {text!r}")
    return float(text)


def positive_int(text: str) -> int:
    """argparse type: an integer > 0."""
    try:
        v = parse_int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if v <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return v


def _number(text: str, strict: bool) -> float:
    kind = "positive" if strict else "non-negative"
    try:
        v = parse_float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a {kind} number, got {text!r}") from None
    if not (math.isfinite(v) and (v > 0 if strict else v >= 0)):
        raise argparse.ArgumentTypeError(f"expected a {kind} number, got {text!r}")
    return v


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0."""
    return _number(text, strict=True)


def nonnegative_float(text: str) -> float:
    """argparse type: a finite number >= 0."""
    return _number(text, strict=False)


def _fmt(v) -> str:
    return str(v) if isinstance(v, int) else f"{v:g}"


class Range:
    """argparse type: a number in the closed interval [lo, hi]; ``text`` is "[lo, hi]"."""

    def __init__(self, lo, hi, integer: bool):
        self.lo, self.hi, self.integer = lo, hi, integer
        self.text = f"[{_fmt(lo)}, {_fmt(hi)}]"
        self.__name__ = f"{'integer' if integer else 'number'} in {self.text}"

    def __call__(self, text: str):
        kind = "an integer" if self.integer else "a number"
        bad = argparse.ArgumentTypeError(f"expected {kind} in {self.text}, got {text!r}")
        try:
            v = parse_int(text) if self.integer else parse_float(text)
        except (ValueError, TypeError):
            raise bad from None
        if not (math.isfinite(v) and self.lo <= v <= self.hi):
            raise bad
        return v

    def __repr__(self):
        return f"{'int_in' if self.integer else 'float_in'}({self.lo!r}, {self.hi!r})"


def int_in(lo: int, hi: int) -> Range:
    """argparse type: an integer in [lo, hi] (error: "expected an integer in [lo, hi], got 'x'")."""
    return Range(int(lo), int(hi), integer=True)


def float_in(lo: float, hi: float) -> Range:
    """argparse type: a finite number in [lo, hi] (error: "expected a number in [lo, hi], got 'x'")."""
    return Range(float(lo), float(hi), integer=False)


SEED = int_in(0, 2**32 - 1)
"""argparse type of every seed: what NumPy's and JAX's generators take."""


def text(value: str) -> str:
    """argparse type: a non-empty string (not only blanks, no NUL) that the OS can take as a
    path or a name."""
    if not value.strip():
        raise argparse.ArgumentTypeError(f"expected a non-empty value, got {value!r}")
    if "\x00" in value:
        raise argparse.ArgumentTypeError(f"expected no NUL character, got {value!r}")
    try:
        os.fsencode(value)
    except UnicodeError:
        raise argparse.ArgumentTypeError(f"expected text the system can encode, got {value!r}") from None
    return value


def add_out(p, what: str = "figures (PNG) and data (NPZ)", flag: str = "--out") -> None:
    """Add the output-folder option (DIR): checked and staged by the core before the study runs;
    the study receives a temporary folder, renamed to DIR when it succeeds."""
    _declare_output(p, p.add_argument(flag, type=text, metavar="DIR", help=f"write {what} to DIR"), "dir")


def add_save(p, what: str = "the gait", flag: str = "--save") -> None:
    """Add an output-file option (FILE): checked and staged like :func:`add_out`, renamed onto
    FILE (os.replace) when the study succeeds."""
    _declare_output(p, p.add_argument(flag, type=text, metavar="FILE", help=f"write {what} to FILE"), "file")


def _declare_output(p, action, kind: str) -> None:
    declared = list(p.get_default("_outputs") or [])
    p.set_defaults(_outputs=declared + [(action.dest, kind, action.option_strings[0])])
