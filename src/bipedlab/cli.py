"""The ``bipedlab`` program: ``bipedlab <verb> [<robot>] [options]``, run by :func:`main`.

The commands are those :mod:`bipedlab.registry` collects (the core's and the robot packages'
``COMMANDS``, declared with :mod:`bipedlab.commands`); ``bipedlab`` alone lists them.

Contract: ``bipedlab <verb> <robot> [options]`` prints the study's summary; ``--json`` (added
to every command by the core unless the command declares it) prints one JSON object and nothing
else on stdout, non-finite floats as null; progress goes to stderr; bad input exits with status
2 and one line ``bipedlab: error: ...`` on stderr.

Before any work the command line is parsed and validated (:func:`bipedlab.registry.parse`) and
the output options declared with ``add_out`` / ``add_save`` are checked and staged
(:mod:`bipedlab.outputs`): the study writes under a temporary name that is renamed into place
only when it has succeeded. While the study runs, SIGINT / SIGTERM end it with status 130 / 143
and one line (:mod:`bipedlab.interrupt`), leaving no partial output.
"""
from __future__ import annotations

import io
import os
import sys

from bipedlab import environment, interrupt, outputs
from bipedlab.commands import UsageError, one_line
from bipedlab.registry import parse

# the command library and the registry under their former home, for modules not yet moved
from bipedlab.commands import (SEED, Command, Range, add_out, add_save, float_in, int_in,  # noqa: F401
                               nonnegative_float, positive_float, positive_int, text)
from bipedlab.registry import (CORE_CLI_MODULES, ENTRY_POINT_GROUP, VERB_ORDER, build_parser,  # noqa: F401
                               command_parsers, commands, listing, robot_cli_modules)


def _progress(msg: str) -> None:
    print(f"[bipedlab] {msg}", file=sys.stderr, flush=True)


def _enable_compile_cache() -> None:
    """Keep every compiled program between runs (first runs compile; later ones load them)."""
    from bipedlab import compilecache

    compilecache.enable()


def _emit(record: dict, as_json: bool, summary) -> None:
    """Print the record (or its summary) and flush it; OSError when stdout cannot take it."""
    out = sys.stdout
    if out is None:
        raise OSError(9, "standard output is closed")
    out.write((outputs.dumps_json(record) if as_json else summary(record)) + "\n")
    out.flush()


def stdout_problem(stream=None) -> str | None:
    """Why the record could not be printed (standard output closed), found before any work;
    None when it is open."""
    stream = sys.stdout if stream is None else stream
    if stream is None:
        return "standard output is closed"
    try:
        fd = stream.fileno()
    except (AttributeError, ValueError, io.UnsupportedOperation):  # a stream without a descriptor (captured)
        return None
    try:
        os.fstat(fd)
    except OSError as e:
        return f"standard output cannot be written: {e.strerror or e}"
    return None


def _drop_stdout() -> None:
    """After a failed write, point stdout at the null device so that the interpreter's exit
    does not try (and fail, with a traceback) to flush it again."""
    try:
        sys.stdout = open(os.devnull, "w")
    except OSError:
        sys.stdout = None


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


def _warning_line(message, category, filename, lineno, line=None) -> str:
    """A Python warning as the command line prints it: one line ``bipedlab: warning: ...``
    (not the source line the default format adds)."""
    return one_line(f"bipedlab: warning: {message}") + "\n"


def _fail(line: str, code: int) -> int:
    print(one_line(f"bipedlab: error: {line}"), file=sys.stderr)
    return code


def main(argv=None) -> int:
    """Parse argv (default sys.argv[1:]), run the chosen command and print its record.

    Exit status: 0 done (or the command's own status of a completed run, e.g. 1 for
    ``reproduce --check`` finding differences); 2 bad input (one ``bipedlab: error:`` line, nothing run); 1 the
    outputs could not be written (one line; nothing left half-written); 130 / 143 interrupted
    by SIGINT / SIGTERM (one line; no partial output)."""
    try:
        return _main(argv)
    except KeyboardInterrupt:  # before the handlers are in place (parsing, imports)
        print(interrupt.LINES[interrupt.signal.SIGINT], file=sys.stderr)
        return interrupt.EXIT_CODES[interrupt.signal.SIGINT]


def _main(argv) -> int:
    import warnings

    warnings.formatwarning = _warning_line
    parser, args = parse(argv)
    if args is None:
        parser.print_help()
        return 0
    cmd = args._command
    try:
        environment.check()
    except UsageError as e:
        parser.error(f"{cmd.name}: {e}")
    closed = stdout_problem()
    if closed:
        return _fail(f"{cmd.name}: {closed}: the record would be lost", 1)
    staging = outputs.Staging()
    with interrupt.guard(cleanup=staging.discard):
        _stage_outputs(parser, args, staging)
        try:
            if cmd.before_jax is not None:
                cmd.before_jax(args)
            problem = environment.devices_problem()  # after before_jax, which may configure the devices
            if problem:
                raise UsageError(f"{cmd.name}: {problem}")
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
    try:
        _emit(staging.rename_paths(record), args.json, summary)
    except OSError as e:  # a full disk or a closed pipe behind stdout
        _drop_stdout()
        return _fail(f"{cmd.name}: could not print the record: {e.strerror or e}", 1)
    return int(cmd.exit_status(record)) if cmd.exit_status is not None else 0


if __name__ == "__main__":
    from bipedlab.cli import main as _main  # the registered module, not a second copy as __main__

    sys.exit(_main())
