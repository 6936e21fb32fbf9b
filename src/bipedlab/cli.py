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
"""
from __future__ import annotations

import argparse
import importlib
import json
import math
import pkgutil
import sys
from dataclasses import dataclass
from typing import Callable, Optional

ENTRY_POINT_GROUP = "bipedlab.robots"
VERB_ORDER = ("bench", "optimize", "walk", "experiment", "run", "hop", "identify")
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
    """

    verb: str
    robot: Optional[str]
    help: str
    add_arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace, Callable[[str], None]], tuple]
    compile_cache: bool = True
    before_jax: Optional[Callable[[argparse.Namespace], None]] = None

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
        print(f"bipedlab: error: {prefix}{message}", file=sys.stderr)
        raise SystemExit(2)


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


def _progress(msg: str) -> None:
    print(f"[bipedlab] {msg}", file=sys.stderr, flush=True)


def _enable_compile_cache() -> None:
    """Keep compiled programs between runs (first runs compile; later ones start fast)."""
    import os

    import jax

    path = os.environ.get("BIPEDLAB_CACHE_DIR") or os.path.join(os.path.expanduser("~"), ".cache", "bipedlab", "xla")
    try:
        os.makedirs(path, exist_ok=True)
        jax.config.update("jax_compilation_cache_dir", path)
    except OSError:
        pass


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
    import os

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
    """Every registered Command: the robot packages' (in package order), then the entry
    points'. Raises ValueError on two commands for one (verb, robot) or a verb both with and
    without a robot."""
    found = []
    for name in robot_cli_modules():
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
    p.set_defaults(_command=cmd)
    return p


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
def _json_safe(x):
    """Non-finite floats (a fallen trial's statistics) -> None, so the JSON stays strict."""
    if isinstance(x, dict):
        return {k: _json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_json_safe(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def _emit(record: dict, as_json: bool, summary) -> None:
    if as_json:
        print(json.dumps(_json_safe(record), allow_nan=False, default=float))
    else:
        print(summary(record))


def main(argv=None) -> int:
    """Parse argv (default sys.argv[1:]), run the chosen command and print its record."""
    parser = build_parser()
    args, extra = parser.parse_known_args(argv)
    cmd = getattr(args, "_command", None)
    if extra:
        where = f"{cmd.name}: " if cmd is not None else ""
        parser.error(f"{where}unrecognized arguments: {' '.join(extra)}")
    if args.verb is None:
        parser.print_help()
        return 0
    if cmd is None:
        parser.error(f"{args.verb}: choose a robot: {', '.join(args._robots)}")
    if cmd.before_jax is not None:
        cmd.before_jax(args)
    if cmd.compile_cache:
        _enable_compile_cache()
    try:
        record, summary = cmd.run(args, _progress)
    except UsageError as e:
        parser.error(str(e))
    _emit(record, args.json, summary)
    return 0


if __name__ == "__main__":
    from bipedlab.cli import main as _main  # the registered module, not a second copy as __main__

    sys.exit(_main())
