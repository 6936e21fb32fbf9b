"""The registered commands of ``bipedlab`` and the parser built from them.

The core names no robot. Each package under :mod:`bipedlab.robots` may hold a ``cli.py``
whose ``COMMANDS`` is a list of :class:`bipedlab.commands.Command`; :func:`commands` finds them
with ``pkgutil.iter_modules(bipedlab.robots.__path__)``, after the core's own command modules
(:data:`CORE_CLI_MODULES`), and :func:`build_parser` gives every (verb, robot) its own argparse
sub-sub-parser, so a robot has exactly its own options. A command with ``robot=None`` (e.g.
``bench``) is ``bipedlab <verb> [options]``. A command module may also declare the speed
scenarios of ``bipedlab bench`` (``SCENARIOS``, :func:`scenarios`).

Third-party packages register commands the same way through the entry-point group
``bipedlab.robots``: each entry point names a module with ``COMMANDS`` (or the list itself),
e.g. in pyproject.toml::

    [project.entry-points."bipedlab.robots"]
    my_walker = "my_walker.cli"

:func:`parse` parses and validates a command line without running anything: every numeric
option is range-checked by its argparse type, a command's ``validate(args)`` rejects
combinations that cannot mean anything, and bad input exits with status 2 and one line
``bipedlab: error: ...`` on stderr. Building the parser imports the command modules only, none
of their study modules (and no JAX).
"""
from __future__ import annotations

import argparse
import importlib
import os
import pkgutil
import sys

from bipedlab.commands import Command, Range, Scenario, UsageError, one_line

ENTRY_POINT_GROUP = "bipedlab.robots"
CORE_CLI_MODULES = ("bipedlab.report.cli", "bipedlab.bench")
"""The core's own command modules (same ``COMMANDS`` protocol as the robots'): ``reproduce``
and ``bench``."""
VERB_ORDER = ("reproduce", "bench", "optimize", "walk", "experiment", "run", "hop", "identify")
"""Listing order of the verbs (others follow alphabetically)."""


class _Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line on stderr, status 2, no usage dump; a
    command's parser prefixes its errors with the command ("walk <robot>: ...")."""

    command = ""

    def error(self, message):
        prefix = f"{self.command}: " if self.command else ""
        print(one_line(f"bipedlab: error: {prefix}{message}"), file=sys.stderr)
        raise SystemExit(2)



def _module_commands(obj) -> list:
    """The Commands of a module (its COMMANDS) or of a list given directly."""
    cmds = list(getattr(obj, "COMMANDS", obj))
    for c in cmds:
        if not isinstance(c, Command):
            raise TypeError(f"{getattr(obj, '__name__', obj)!r}: COMMANDS must hold bipedlab.commands.Command, got {c!r}")
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


def _entry_points() -> list:
    """What the entry points of the group name (a module, or a list of Commands), by name."""
    from importlib.metadata import entry_points

    try:
        eps = entry_points(group=ENTRY_POINT_GROUP)
    except TypeError:  # Python < 3.10 style API
        eps = entry_points().get(ENTRY_POINT_GROUP, [])
    return [ep.load() for ep in sorted(eps, key=lambda e: e.name)]


def _sources() -> list:
    """The command modules in registry order: the core's, the robot packages' (in package
    order), then what the entry points name."""
    return [importlib.import_module(n) for n in CORE_CLI_MODULES + tuple(robot_cli_modules())] + _entry_points()


def commands() -> list[Command]:
    """Every registered Command: the core's (CORE_CLI_MODULES), the robot packages' (in package
    order), then the entry points'. Raises ValueError on two commands for one (verb, robot) or a verb both with and
    without a robot."""
    found = []
    for obj in _sources():
        found += _module_commands(obj)
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


def scenarios() -> list[Scenario]:
    """Every registered speed scenario of ``bipedlab bench`` (the ``SCENARIOS`` of the command
    modules, in the order of :func:`commands`). Raises ValueError on two scenarios of one name."""
    found = []
    for obj in _sources():
        for s in getattr(obj, "SCENARIOS", ()):
            if not isinstance(s, Scenario):
                raise TypeError(f"{getattr(obj, '__name__', obj)!r}: SCENARIOS must hold bipedlab.commands.Scenario, "
                                f"got {s!r}")
            if any(s.name == f.name for f in found):
                raise ValueError(f"two scenarios named '{s.name}'")
            found.append(s)
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


# ----------------------------------------------------------------------------- parsing
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
