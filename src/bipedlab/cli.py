"""The ``bipedlab`` command: ``bipedlab <verb> <robot> [options]``, collected from the robots.

The core names no robot. Each package under :mod:`bipedlab.robots` may hold a ``cli.py``
whose ``COMMANDS`` is a list of :class:`Command`; the core finds them with
``pkgutil.iter_modules(bipedlab.robots.__path__)`` and gives every (verb, robot) its own
argparse sub-sub-parser, so a robot has exactly its own options. A command with
``robot=None`` (e.g. ``bench``) is ``bipedlab <verb> [options]``.

Third-party packages register commands the same way through the entry-point group
``bipedlab.robots``: each entry point names a module with ``COMMANDS`` (or the list itself),
e.g. in pyproject.toml::

    [project.entry-points."bipedlab.robots"]
    my_walker = "my_walker.cli"

Contract: ``bipedlab <verb> <robot> [options]`` prints the study's summary; ``--json`` (added
to every command by the core unless the command declares it) prints one JSON object and nothing else on stdout, non-finite
floats as null; progress goes to stderr; bad input exits with status 2 and one line
``bipedlab: error: ...`` on stderr. ``bipedlab`` alone lists the studies. A command's ``run``
reports bad input by raising :class:`UsageError`; it imports its study modules itself, so
that building the parser (``bipedlab --help``) stays fast.

Before any work: every numeric option is range-checked by its argparse type (:func:`int_in`,
:func:`float_in`; the range is appended to the option's help), string options are non-empty
(:func:`text`), a command's ``validate(args)`` rejects combinations that cannot mean anything,
and the output options declared with :func:`add_out` / :func:`add_save` are checked and staged
(:mod:`bipedlab.outputs`): the study writes under a temporary name that is renamed into place
only when it has succeeded. While the study runs, SIGINT / SIGTERM end it with status 130 / 143
and one line (:mod:`bipedlab.interrupt`), leaving no partial output.
"""
from __future__ import annotations

import argparse
import importlib
import math
import os
import pkgutil
import sys
from dataclasses import dataclass
from typing import Callable, Optional

from bipedlab import interrupt, outputs

ENTRY_POINT_GROUP = "bipedlab.robots"
CORE_CLI_MODULES = ("bipedlab.report.cli",)
"""The core's own command modules (same ``COMMANDS`` protocol as the robots'): ``reproduce``."""
VERB_ORDER = ("reproduce", "bench", "optimize", "walk", "experiment", "run", "hop", "identify")
"""Listing order of the verbs (others follow alphabetically)."""


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

    @property
    def name(self) -> str:
        """The command line's words: "walk <robot>", or "bench"."""
        return self.verb if self.robot is None else f"{self.verb} {self.robot}"


class UsageError(Exception):
    """Bad input found by a command's run: reported as one ``bipedlab: error:`` line, status 2."""


class _Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line on stderr, status 2, no usage dump; a
    command's parser prefixes its errors with the command ("walk <robot>: ...")."""

    command = ""

    def error(self, message):
        prefix = f"{self.command}: " if self.command else ""
        print(one_line(f"bipedlab: error: {prefix}{message}"), file=sys.stderr)
        raise SystemExit(2)


_LINE_BREAKS = {c: repr(c)[1:-1] for c in "\n\r\v\f\x1c\x1d\x1e\x85\u2028\u2029"}


def one_line(text: str) -> str:
    """``text`` with every character that breaks a line (for str.splitlines too) shown as an
    escape, so an error stays one line whatever the input."""
    return "".join(_LINE_BREAKS.get(c, c) for c in str(text))


def positive_int(text: str) -> int:
    """argparse type: an integer > 0."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if v <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return v


def _number(text: str, strict: bool) -> float:
    kind = "positive" if strict else "non-negative"
    try:
        v = float(text)
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


_positive_int, _positive_float, _nonnegative_float = positive_int, positive_float, nonnegative_float


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
            v = int(text) if self.integer else float(text)
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


def _progress(msg: str) -> None:
    print(f"[bipedlab] {msg}", file=sys.stderr, flush=True)


def _enable_compile_cache() -> None:
    """Keep every compiled program between runs (first runs compile; later ones load them)."""
    from bipedlab import compilecache

    compilecache.enable()


# ----------------------------------------------------------------------------- registry
def _module_commands(obj) -> list:
    """The Commands of a module (its COMMANDS) or of a list given directly."""
    cmds = list(getattr(obj, "COMMANDS", obj))
    for c in cmds:
        if not isinstance(c, Command):
            raise TypeError(f"{getattr(obj, '__name__', obj)!r}: COMMANDS must hold bipedlab.cli.Command, got {c!r}")
    return cmds


def robot_cli_modules() -> list[str]:
    """Names of the robot packages' CLI modules, sorted: ``bipedlab.robots.<pkg>.cli`` for
    every package under bipedlab.robots (found by pkgutil.iter_modules) that has a ``cli``
    module. Nothing is imported here."""
    import bipedlab.robots as robots

    names = []
    for info in sorted(pkgutil.iter_modules(robots.__path__), key=lambda m: m.name):
        where = getattr(info.module_finder, "path", None)
        if info.ispkg and where and any(m.name == "cli" for m in pkgutil.iter_modules([os.path.join(where, info.name)])):
            names.append(f"{robots.__name__}.{info.name}.cli")
    return names


def _entry_point_commands() -> list:
    from importlib.metadata import entry_points

    try:
        eps = entry_points(group=ENTRY_POINT_GROUP)
    except TypeError:  # Python < 3.10 style API
        eps = entry_points().get(ENTRY_POINT_GROUP, [])
    out = []
    for ep in sorted(eps, key=lambda e: e.name):
        out += _module_commands(ep.load())
    return out


def commands() -> list[Command]:
    """Every registered Command: the core's (CORE_CLI_MODULES), the robot packages' (in package
    order), then the entry points'. Raises ValueError on two commands for one (verb, robot) or a verb both with and
    without a robot."""
    found = []
    for name in CORE_CLI_MODULES + tuple(robot_cli_modules()):
        found += _module_commands(importlib.import_module(name))
    found += _entry_point_commands()
    seen: dict = {}
    for c in found:
        if (c.verb, c.robot) in seen:
            raise ValueError(f"two commands for '{c.name}'")
        seen[(c.verb, c.robot)] = c
    for verb in {c.verb for c in found}:
        kinds = {c.robot is None for c in found if c.verb == verb}
        if len(kinds) > 1:
            raise ValueError(f"'{verb}' is registered both with and without a robot")
    return found


def _verbs(cmds) -> dict:
    """{verb: [Command, ...]} in listing order."""
    by = {}
    for c in cmds:
        by.setdefault(c.verb, []).append(c)
    rank = {v: i for i, v in enumerate(VERB_ORDER)}
    return {v: by[v] for v in sorted(by, key=lambda v: (rank.get(v, len(rank)), v))}


def listing(cmds=None) -> str:
    """The studies, one line per command: verb, robot, help."""
    by = _verbs(commands() if cmds is None else cmds)
    rows = [(c.name, c.help) for cs in by.values() for c in cs]
    w = max((len(n) for n, _ in rows), default=0)
    return "studies:\n" + "\n".join(f"  {n:<{w}}  {h}" for n, h in rows)


def _leaf(sub, name: str, cmd: Command, help_text: str):
    p = sub.add_parser(name, help=help_text, description=cmd.help)
    p.command = cmd.name
    cmd.add_arguments(p)
    if "--json" not in p._option_string_actions:  # a command may declare it itself, with the same meaning
        p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    for a in p._actions:  # every range is stated in its option's help
        if isinstance(a.type, Range) and a.help is not argparse.SUPPRESS and a.type.text not in (a.help or ""):
            a.help = f"{a.help or ''}; in {a.type.text}".lstrip("; ")
    p.set_defaults(_command=cmd, _parser=p)
    return p


def _check_values_given(p, args) -> None:
    """argparse hands an option written ``--opt=--`` an empty list without calling its type:
    refuse it like a missing value."""
    for a in p._actions:
        if a.option_strings and a.nargs not in (0, "*") and a.default != [] and getattr(args, a.dest, None) == []:
            p.error(f"argument {'/'.join(a.option_strings)}: expected a value, got '--'")


def build_parser(cmds=None) -> argparse.ArgumentParser:
    """The argparse parser of every command: ``bipedlab <verb> [<robot>] [options]``."""
    by = _verbs(commands() if cmds is None else cmds)
    p = _Parser(prog="bipedlab", description="Planar bipedal robots: models, controllers, batched simulation.",
                epilog=listing([c for cs in by.values() for c in cs]),
                formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="verb", metavar="<study>", parser_class=_Parser)
    for verb, cs in by.items():
        if cs[0].robot is None:
            _leaf(sub, verb, cs[0], cs[0].help)
            continue
        robots = [c.robot for c in cs]
        v = sub.add_parser(verb, help=f"robots: {', '.join(robots)}",
                           description=f"bipedlab {verb} <robot> [options]; bipedlab {verb} <robot> --help lists "
                                       "the robot's options.")
        v.command = verb
        v.set_defaults(_robots=robots)
        vs = v.add_subparsers(dest="robot", metavar="<robot>", parser_class=_Parser)
        for c in cs:
            _leaf(vs, c.robot, c, c.help)
    return p


def command_parsers(parser) -> dict:
    """{command name ("walk <robot>", "bench"): its argparse parser} of a built parser."""
    def subs(p):
        acts = [a for a in p._actions if isinstance(a, argparse._SubParsersAction)]
        return acts[0].choices if acts else {}

    out = {}
    for verb, vp in subs(parser).items():
        robots = subs(vp)
        if not robots:
            out[verb] = vp
        for robot, rp in robots.items():
            out[f"{verb} {robot}"] = rp
    return out


# ----------------------------------------------------------------------------- running
_json_safe = outputs.json_safe  # non-finite floats (a fallen trial's statistics) -> None


def _emit(record: dict, as_json: bool, summary) -> None:
    if as_json:
        print(outputs.dumps_json(record))
    else:
        print(summary(record))


def parse(argv=None, parser=None):
    """Parse and validate argv without running anything: returns (parser, args) of a command
    ready to run (args._command set), or (parser, None) for the bare listing. Bad input exits
    with status 2 and one line (SystemExit). Output targets are not touched here."""
    parser = parser or build_parser()
    args, extra = parser.parse_known_args(argv)
    cmd = getattr(args, "_command", None)
    if extra:
        where = f"{cmd.name}: " if cmd is not None else ""
        parser.error(f"{where}unrecognized arguments: {' '.join(extra)}")
    if args.verb is None:
        return parser, None
    if cmd is None:
        parser.error(f"{args.verb}: choose a robot: {', '.join(args._robots)}")
    _check_values_given(args._parser, args)
    if cmd.validate is not None:
        try:
            cmd.validate(args)
        except UsageError as e:
            parser.error(f"{cmd.name}: {e}")
    return parser, args


def _stage_outputs(parser, args, staging: outputs.Staging) -> None:
    """Check every declared output target and point its option at the staged path."""
    for dest, kind, option in getattr(args, "_outputs", None) or []:
        value = getattr(args, dest, None)
        if value is None:
            continue
        try:
            staged = staging.stage_dir(option, value) if kind == "dir" else staging.stage_file(option, value)
        except outputs.OutputError as e:
            staging.discard()
            parser.error(f"{args._command.name}: {e}")
        setattr(args, dest, staged)


def _fail(line: str, code: int) -> int:
    print(one_line(f"bipedlab: error: {line}"), file=sys.stderr)
    return code


def main(argv=None) -> int:
    """Parse argv (default sys.argv[1:]), run the chosen command and print its record.

    Exit status: 0 done; 2 bad input (one ``bipedlab: error:`` line, nothing run); 1 the
    outputs could not be written (one line; nothing left half-written); 130 / 143 interrupted
    by SIGINT / SIGTERM (one line; no partial output)."""
    try:
        return _main(argv)
    except KeyboardInterrupt:  # before the handlers are in place (parsing, imports)
        print(interrupt.LINES[interrupt.signal.SIGINT], file=sys.stderr)
        return interrupt.EXIT_CODES[interrupt.signal.SIGINT]


def _main(argv) -> int:
    parser, args = parse(argv)
    if args is None:
        parser.print_help()
        return 0
    cmd = args._command
    staging = outputs.Staging()
    with interrupt.guard(cleanup=staging.discard):
        _stage_outputs(parser, args, staging)
        try:
            if cmd.before_jax is not None:
                cmd.before_jax(args)
            if cmd.compile_cache:
                _enable_compile_cache()
            record, summary = cmd.run(args, _progress)
        except UsageError as e:
            staging.discard()
            parser.error(str(e))
        except OSError as e:  # a full disk or a folder made read-only meanwhile: one line, not a traceback
            ours = staging.owns(e.filename) or staging.owns(e.filename2)
            staging.discard()
            if not ours:
                raise
            return _fail(f"{cmd.name}: could not write the outputs: {e.strerror or e}", 1)
        except BaseException:
            staging.discard()
            raise
        try:
            with interrupt.critical():
                staging.commit()
        except OSError as e:
            staging.discard()
            return _fail(f"{cmd.name}: could not move the outputs into place: {e}", 1)
    _emit(staging.rename_paths(record), args.json, summary)
    return 0


if __name__ == "__main__":
    from bipedlab.cli import main as _main  # the registered module, not a second copy as __main__

    sys.exit(_main())
