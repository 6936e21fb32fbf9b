"""The command line's boundary: every option value and combination is accepted or refused with
exit 2 and one line before any work; outputs are complete or absent; SIGINT / SIGTERM end a
study with 130 / 143 and one line; JSON on disk is strict.

Option values are generated (hypothesis) and checked through ``cli.parse`` (parse + validate,
nothing run); the slow set repeats each generator with at least 1000 cases."""
from __future__ import annotations

import argparse
import ast
import contextlib
import importlib.resources
import importlib
import io
import json
import math
import os
import pathlib
import re
import shutil
import signal
import subprocess
import sys
import textwrap
import time
import types

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bipedlab import cli, outputs

PARSER = cli.build_parser()
PARSERS = cli.command_parsers(PARSER)
SRC = pathlib.Path(cli.__file__).parent

#: options an in-range value needs beside it to mean something
CONTEXT = {
    ("run atrias", "--step-height"): ["--terrain", "rough"],
    ("run atrias", "--slope"): ["--terrain", "slope"],
    ("walk mabel", "--lean-steps"): ["--lean", "5"],
    ("walk mabel", "--ground-scale"): ["--plant", "full"],
    ("experiment mabel", "--steps"): [],
}
for _name in PARSERS:  # a multi-process launch names its coordinator and its place
    if _name.startswith("robustness "):
        CONTEXT[(_name, "--num-processes")] = ["--coordinator", "localhost:1", "--process-id", "0"]
        CONTEXT[(_name, "--process-id")] = ["--coordinator", "localhost:1", "--num-processes", "65536"]


#: a valid value of a positional argument without choices, and of a required option
POSITIONAL_VALUES = {"file": "rabbit.xml"}  # a shipped example of the imported-model commands
REQUIRED_VALUES = {
    "--gait": str(importlib.resources.files("bipedlab.robots.imported") / "data" / "rabbit_0.8.json"),
    "--stance": "left_foot",
    "--swing": "right_foot",
}


def _positional_value(a, omit: str | None):
    if a.dest == omit:
        return []
    if a.choices:
        return [a.choices[0]]
    return [] if a.nargs in ("*", "?") else [POSITIONAL_VALUES[a.dest]]


def _base(name: str, option: str | None = None, omit_positional: str | None = None) -> list:
    """The smallest valid argv of a command (its first positional choice or a valid file, the
    required options, the first option of a required group unless ``option`` belongs to that
    group); ``omit_positional`` leaves that positional out (to give it a value of one's own)."""
    p = PARSERS[name]
    argv = name.split()
    for a in p._actions:
        if not a.option_strings and a.dest != "help":
            argv += _positional_value(a, omit_positional)
    for a in p._actions:
        if a.option_strings and a.required and a.option_strings[0] != option:
            argv += [a.option_strings[0], REQUIRED_VALUES[a.option_strings[0]]]
    for g in p._mutually_exclusive_groups:
        if g.required and option not in {s for a in g._group_actions for s in a.option_strings}:
            argv.append(g._group_actions[0].option_strings[0])
    return argv + CONTEXT.get((name, option), [])


def _ranged():
    out = []
    for name, p in sorted(PARSERS.items()):
        for a in p._actions:
            if isinstance(a.type, cli.Range):
                out.append((name, a.option_strings[0], a))
    return out


def _texts():
    """(command, option, action) of every string option; positional strings as (command, None,
    action)."""
    return [(name, a.option_strings[0] if a.option_strings else None, a) for name, p in sorted(PARSERS.items())
            for a in p._actions if a.type is cli.text]


RANGED = _ranged()
TEXTS = _texts()


def _parse(argv):
    """(args or None, exit code or None, stdout, stderr) of parse + validate, in-process."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            _, args = cli.parse(argv, PARSER)
            code = None
        except SystemExit as e:
            args, code = None, e.code
    return args, code, out.getvalue(), err.getvalue()


def _refused(argv) -> str:
    args, code, out, err = _parse(argv)
    assert code == 2 and args is None, (argv, code, err)
    assert out == ""
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("bipedlab: error: "), (argv, err)
    return lines[0]


def _accepted(argv):
    args, code, out, err = _parse(argv)
    assert code is None and args is not None, (argv, err)
    assert out == "" and err == ""
    return args


_INTEGER = re.compile(r"[+-]?[0-9]+", re.ASCII)
_NUMBER = re.compile(r"[+-]?([0-9]+(\.[0-9]*)?|\.[0-9]+)([eE][+-]?[0-9]+)?", re.ASCII)


def _in_range(r: cli.Range, value: str) -> bool:
    """Whether value is a numeral of the grammar (sign, ASCII digits, for numbers a point and
    an exponent) inside the range."""
    if not isinstance(value, str) or (_INTEGER if r.integer else _NUMBER).fullmatch(value) is None:
        return False
    v = int(value) if r.integer else float(value)
    return math.isfinite(v) and r.lo <= v <= r.hi


# ----------------------------------------------------------------------------- every option's range
def test_every_numeric_option_has_a_range_stated_in_its_help():
    checked = 0
    for name, p in PARSERS.items():
        for a in p._actions:
            if a.option_strings and a.type not in (None, cli.text) and a.help is not argparse.SUPPRESS:
                assert isinstance(a.type, cli.Range) or callable(a.type), (name, a.dest)
                if isinstance(a.type, cli.Range):
                    assert a.type.text in a.help, (name, a.option_strings, a.help)
                    checked += 1
            if a.option_strings and a.type in (int, float):
                pytest.fail(f"{name} {a.option_strings[0]}: a bare {a.type.__name__} has no range")
    assert checked >= 25


def test_every_string_option_refuses_the_empty_string():
    assert len(TEXTS) >= 10
    for name, opt, action in TEXTS:
        for value in ("", "   "):
            if opt is None:  # a positional: its own value in its place
                argv = _base(name, omit_positional=action.dest)
                line = _refused(argv[:len(name.split())] + [value] + argv[len(name.split()):])
                assert f"argument {action.metavar or action.dest}" in line and "non-empty" in line, line
                continue
            line = _refused(_base(name, opt) + [f"{opt}={value}"])
            assert f"argument {opt}" in line and "non-empty" in line, line


@pytest.mark.parametrize("name,opt,action", RANGED, ids=[f"{n}{o}" for n, o, _ in RANGED])
def test_the_ends_of_every_range(name, opt, action):
    r = action.type
    for v in (r.lo, r.hi):
        args = _accepted(_base(name, opt) + [f"{opt}={v}"])
        got = getattr(args, action.dest)
        assert (got[0] if isinstance(got, list) else got) == v
    step = 1 if r.integer else max(1e-9, 1e-6 * (r.hi - r.lo))
    for v in (r.lo - step, r.hi + step, "nan", "inf", "x", ""):
        line = _refused(_base(name, opt) + [f"{opt}={v}"])
        assert f"{name}: argument {opt}: expected " in line and r.text in line, line


def _number_text(r: cli.Range):
    span = max(abs(r.lo), abs(r.hi), 1.0)
    return st.one_of(
        st.integers(min_value=-(2 ** 80), max_value=2 ** 80).map(str),
        st.integers(min_value=int(r.lo) - 3, max_value=int(r.hi) + 3).map(str),
        st.floats(min_value=r.lo - span, max_value=r.hi + span).map(repr),
        st.floats(allow_nan=True, allow_infinity=True).map(str),
        st.sampled_from(["", " ", "nan", "-inf", "1e309", "0x10", "1_0", "+3", " 7 ", "1e3", "٣", "--", "1,5"]),
        st.text(max_size=12),
    )


def _numeric_property(n: int):
    @settings(max_examples=n, deadline=None, suppress_health_check=list(HealthCheck))
    @given(data=st.data())
    def check(data):
        name, opt, action = data.draw(st.sampled_from(RANGED), label="option")
        value = data.draw(_number_text(action.type), label="value")
        argv = _base(name, opt) + [f"{opt}={value}"]
        if "\x00" in value:
            return  # a command line cannot carry NUL
        if value == "--":  # argparse drops it: the option gets no value
            line = _refused(argv)
            assert opt in line, line
        elif _in_range(action.type, value):
            _accepted(argv)
        else:
            line = _refused(argv)
            assert f"argument {opt}" in line and action.type.text in line, line
    return check


test_generated_numbers = _numeric_property(250)
test_generated_numbers_slow = pytest.mark.slow(_numeric_property(2000))


def _text_property(n: int):
    @settings(max_examples=n, deadline=None, suppress_health_check=list(HealthCheck))
    @given(data=st.data())
    def check(data):
        name, opt, _ = data.draw(st.sampled_from([t for t in TEXTS if t[1] is not None]), label="option")
        value = data.draw(st.one_of(st.text(max_size=20), st.sampled_from(["", " ", "\t", ".", "/", "nominal"])),
                          label="value")
        argv = _base(name, opt) + [f"{opt}={value}"]
        args, code, out, err = _parse(argv)
        assert out == ""
        if code is None:
            assert value.strip() and "\x00" not in value
        else:
            assert code == 2 and len(err.splitlines()) == 1 and err.startswith("bipedlab: error: "), err
            if not value.strip():
                assert f"argument {opt}" in err
    return check


test_generated_strings = _text_property(100)
test_generated_strings_slow = pytest.mark.slow(_text_property(1000))


def _push_property(n: int):
    force = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr), st.integers(-2000, 2000).map(str),
                      st.text(max_size=5))
    step = st.one_of(st.integers(-5, 200).map(str), st.integers(-(2 ** 70), 2 ** 70).map(str), st.text(max_size=5))

    @settings(max_examples=n, deadline=None, suppress_health_check=list(HealthCheck))
    @given(f=force, k=step, sep=st.sampled_from(["@", "@", "@", "", "@@", " @"]),
           steps=st.one_of(st.none(), st.integers(1, 150)))
    def check(f, k, sep, steps):
        value = f"{f}{sep}{k}"
        if "\x00" in value:
            return
        argv = ["walk", "mabel", f"--push={value}"] + ([] if steps is None else ["--steps", str(steps)])
        args, code, out, err = _parse(argv)
        head, at, tail = value.partition("@")
        try:
            if not (_NUMBER.fullmatch(head) and _INTEGER.fullmatch(tail)):  # the numeral grammar
                raise ValueError(value)
            ok_f, ok_k = float(head), int(tail)
            well_formed = at == "@" and math.isfinite(ok_f) and abs(ok_f) <= 1000 and 0 <= ok_k <= 9999
        except ValueError:
            well_formed = False
        if well_formed and ok_k < (steps or 100):
            assert code is None and args.push == (ok_f, ok_k), err
        else:
            assert code == 2 and len(err.splitlines()) == 1 and "--push" in err, (value, err)
    return check


test_generated_pushes = _push_property(150)
test_generated_pushes_slow = pytest.mark.slow(_push_property(1500))


def _model_error_property(n: int):
    item = st.builds(lambda name, sep, rel: f"{name}{sep}{rel}",
                     st.sampled_from(["mass", "inertia", "friction", "stiffness", "", "Mass", "length"]),
                     st.sampled_from(["=", "=", "", "=="]),
                     st.one_of(st.floats(-3, 5).map(repr), st.floats(allow_nan=True).map(repr), st.text(max_size=4)))

    @settings(max_examples=n, deadline=None, suppress_health_check=list(HealthCheck))
    @given(items=st.lists(item, min_size=1, max_size=4))
    def check(items):
        if any("\x00" in i for i in items):
            return
        argv = ["run", "atrias", "--model-error", *items]
        args, code, out, err = _parse(argv)
        if code is None:
            names = [nm for nm, _ in args.model_error]
            assert len(names) == len(set(names)) == len(items)
            assert all(-0.9 <= r <= 2.0 for _, r in args.model_error)
        else:
            assert code == 2 and len(err.splitlines()) == 1 and err.startswith("bipedlab: error: "), err
    return check


test_generated_model_errors = _model_error_property(100)
test_generated_model_errors_slow = pytest.mark.slow(_model_error_property(1000))


def _value(action):
    if action.choices:
        return st.one_of(st.sampled_from(list(action.choices)), st.text(max_size=6))
    if isinstance(action.type, cli.Range):
        return _number_text(action.type)
    return st.one_of(st.text(max_size=8), st.sampled_from(["1", "0", "-1", "78@3", "mass=0.1", "nominal"]))


def _argv_property(n: int):
    names = sorted(PARSERS)

    @st.composite
    def argv(draw):
        name = draw(st.sampled_from(names))
        p = PARSERS[name]
        opts = [a for a in p._actions if a.option_strings and a.dest != "help"]
        words = list(_base(name)) if draw(st.booleans()) else name.split()
        for a in draw(st.lists(st.sampled_from(opts), max_size=5)):
            flag = a.option_strings[0]
            if a.nargs == 0:
                words.append(flag)
            else:
                words.append(f"{flag}={draw(_value(a))}")
        if draw(st.booleans()):
            words.append(draw(st.text(max_size=6)))
        return words

    @settings(max_examples=n, deadline=None, suppress_health_check=list(HealthCheck))
    @given(words=argv())
    def check(words):
        if any("\x00" in w or w.startswith(("-h", "--h")) for w in words):
            return  # a command line cannot carry NUL; -h / --help (or a prefix of it) prints the help
        args, code, out, err = _parse(words)
        assert out == ""
        if code is not None:
            assert code == 2 and len(err.splitlines()) == 1 and err.startswith("bipedlab: error: "), (words, err)
        else:
            assert err == "" and (args is None or args._command is not None)
    return check


test_generated_command_lines = _argv_property(120)
test_generated_command_lines_slow = pytest.mark.slow(_argv_property(2000))


# ----------------------------------------------------------------------------- launch variables
LAUNCH = ["robustness five-link", "robustness mabel", "robustness model", "robustness atrias"]
_MULTI = {"JAX_NUM_PROCESSES": "2", "JAX_PROCESS_ID": "0", "JAX_COORDINATOR_ADDRESS": "localhost:1"}
#: variable: (the other variables that make it read, [lo, hi] of an integer, or None for HOST:PORT)
LAUNCH_VARIABLES = {
    "SLURM_NTASKS": ({}, (1, 65536)), "SLURM_PROCID": ({}, (0, 65535)),
    "JAX_NUM_PROCESSES": ({}, (1, 65536)), "JAX_PROCESS_ID": ({}, (0, 65535)),
    "JAX_COORDINATOR_ADDRESS": ({}, None), "JAX_LOCAL_DEVICE_IDS": (_MULTI, (0, 65535)),
}
_ENV_TEXT = st.text(alphabet=st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"), max_size=12)


@contextlib.contextmanager
def _environment(values: dict):
    """os.environ with the launch variables cleared and ``values`` set, restored afterwards."""
    names = set(LAUNCH_VARIABLES) | set(values) | {"SLURM_JOB_ID", "SLURM_STEP_NODELIST", "SLURM_LOCALID"}
    saved = {k: os.environ.get(k) for k in names}
    try:
        for k in names:
            os.environ.pop(k, None)
        os.environ.update(values)
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _integer_verdict(value: str, lo: int, hi: int, many: bool = False):
    """True: a valid integer, or with ``many`` integers separated by commas (or blank:
    unset); False: refused."""
    if not value.strip():
        return True
    items = value.split(",") if many else [value]
    return all(re.fullmatch(r"\s*[0-9]+\s*", x) is not None and lo <= int(x) <= hi for x in items)


def _address_verdict(value: str):
    """True: certainly HOST:PORT; False: certainly not; None: either (the grammar's fine print)."""
    if not value.strip():
        return True
    host, colon, port = value.rpartition(":")
    if not colon or not host or re.fullmatch(r"[0-9]{1,5}", port) is None or not 1 <= int(port) <= 65535:
        return False
    return True if re.fullmatch(r"[A-Za-z0-9]+", host) else None


def _launch_property(n: int):
    @settings(max_examples=n, deadline=None, suppress_health_check=list(HealthCheck))
    @given(data=st.data())
    def check(data):
        name = data.draw(st.sampled_from(LAUNCH), label="command")
        var = data.draw(st.sampled_from(sorted(LAUNCH_VARIABLES)), label="variable")
        context, bounds = LAUNCH_VARIABLES[var]
        value = data.draw(st.one_of(_ENV_TEXT, st.sampled_from(
            ["", " ", "0", "1", "2", " 3 ", "-1", "+2", "two", "1.5", "1e3", "\u0663", "65537", "0,1", "a,b", ",",
             "localhost:1", "h:0", ":80", "[::1]:5", "h:65536", "notahost", "a b:1"])), label="value")
        with _environment(dict(context, **{var: value})):
            args, code, out, err = _parse(_base(name))
        assert out == ""
        if code is not None:
            assert code == 2 and len(err.splitlines()) == 1 and err.startswith("bipedlab: error: "), (var, value, err)
        if var == "JAX_LOCAL_DEVICE_IDS" and not value.strip():
            return
        verdict = (_address_verdict(value) if bounds is None
                   else _integer_verdict(value, *bounds, many=var == "JAX_LOCAL_DEVICE_IDS"))
        if verdict is False:
            assert code == 2 and f"${var}" in err, (var, value, err)
        elif verdict and (var in ("SLURM_PROCID", "JAX_COORDINATOR_ADDRESS", "JAX_LOCAL_DEVICE_IDS")
                          or (var == "JAX_PROCESS_ID" and not value.strip().strip("0"))):
            assert code is None, (var, value, err)  # read, valid, and nothing else asks for more
    return check


test_generated_launch_variables = _launch_property(150)
test_generated_launch_variables_slow = pytest.mark.slow(_launch_property(1500))


# ----------------------------------------------------------------------------- files that are not regular
@pytest.fixture(scope="module")
def special_files(tmp_path_factory):
    """{kind: a path of that kind}, and {kind: a folder whose a.csv is of that kind}."""
    d = tmp_path_factory.mktemp("special")
    paths = {"fifo": d / "fifo.json", "directory": d / "folder.json", "/dev/null": d / "null.json",
             "symlink loop": d / "loop.json", "dangling symlink": d / "dangling.json", "/dev/zero": d / "zero.json"}
    os.mkfifo(paths["fifo"])
    paths["directory"].mkdir()
    os.symlink("/dev/null", paths["/dev/null"])
    os.symlink("/dev/zero", paths["/dev/zero"])
    os.symlink(d / "loop2.json", paths["symlink loop"])
    os.symlink(paths["symlink loop"], d / "loop2.json")
    os.symlink(d / "nowhere.json", paths["dangling symlink"])
    folders = {}
    for kind, path in paths.items():
        folders[kind] = d / f"logs-{kind.strip('/').replace('/', '-').replace(' ', '-')}"
        folders[kind].mkdir()
        os.symlink(path, folders[kind] / "a.csv") if kind != "directory" else (folders[kind] / "a.csv").mkdir()
    os.mkfifo(folders["fifo"] / "b.csv")
    return {k: str(v) for k, v in paths.items()}, {k: str(v) for k, v in folders.items()}


#: command lines taking a file (X): as a gait, a model or a log folder
FILE_TARGETS = [
    ["walk", "five-link", "--gait", "X"], ["walk", "mabel", "--gait", "X"], ["robustness", "mabel", "--gait", "X"],
    ["walk", "model", "X", "--gait", REQUIRED_VALUES["--gait"]], ["robustness", "model", "X", "--gait",
                                                                  REQUIRED_VALUES["--gait"]],
    ["optimize", "model", "X", "--stance", "left_foot", "--swing", "right_foot"],
    ["walk", "model", "rabbit.xml", "--gait", "X"], ["robustness", "model", "rabbit.xml", "--gait", "X"],
    ["identify", "mabel", "--data", "X"], ["identify", "mabel", "--data", "LOGS"],
]


def _file_property(n: int):
    @settings(max_examples=n, deadline=None, suppress_health_check=list(HealthCheck))
    @given(target=st.sampled_from(FILE_TARGETS), kind=st.sampled_from(
        ["fifo", "directory", "/dev/null", "symlink loop", "dangling symlink", "/dev/zero"]))
    def check(special_files, target, kind):
        paths, folders = special_files
        if target[-1] == "X" and target[-2] == "--data" and kind == "directory":
            return  # a folder is what --data takes
        argv = [paths[kind] if w == "X" else folders[kind] if w == "LOGS" else w for w in target]
        t0 = time.perf_counter()
        line = _refused(argv)
        assert time.perf_counter() - t0 < 1.0 and "Traceback" not in line
        assert (paths[kind] if "X" in target else folders[kind]) in line, line
    return check


test_generated_special_files = _file_property(60)
test_generated_special_files_slow = pytest.mark.slow(_file_property(600))


# ----------------------------------------------------------------------------- the cases
@pytest.mark.parametrize("argv,needle", [
    (["walk", "five-link", "--seed", "-1"], "--seed: expected an integer in [0, 4294967295]"),
    (["walk", "compass-gait", "--seed", str(2 ** 64)], "--seed"),
    (["walk", "mabel", "--steps", "0"], "walk mabel: argument --steps: expected an integer in [1, 10000], got '0'"),
    (["walk", "mabel", "--steps", "10" * 20], "[1, 10000]"),
    (["hop", "mabel", "--hops", "99999999999"], "--hops"),
    (["run", "atrias", "--trials", "100000000"], "--trials"),
    (["walk", "mabel", "--push", "78@99999999999999999999"], "--push"),
    (["walk", "mabel", "--lean", "5", "--lean-steps", "1e9"], "--lean-steps"),
    (["run", "atrias", "--seconds", "1e12"], "--seconds"),
    (["run", "atrias", "--delay-ms", "1e300"], "--delay-ms"),
    (["run", "atrias", "--terrain", "rough", "--step-height", "1e6"], "--step-height"),
    (["optimize", "mabel", "--step-length", "100"], "--step-length: expected a number in [0.2, 1]"),
    (["bench", "--seconds", "0.0001"], "--seconds: expected a number in [0.01, 60]"),
    (["identify", "mabel", "--synthetic", "--noise", "-1"], "--noise"),
    (["experiment", "mabel", "push", "--steps", "2"], "push: --steps must be at least 11"),
    (["experiment", "mabel", "sweep", "--steps", "20"], "sweep: --steps does not apply"),
    (["experiment", "mabel", "impact-scaling", "--steps", "5"], "impact-scaling"),
    (["walk", "mabel", "--push", "78@30", "--steps", "20"], "step 30 is never reached in 20 steps"),
    (["walk", "mabel", "--push", "78@"], "--push"),
    (["walk", "mabel", "--lean-steps", "5"], "--lean-steps applies with a non-zero --lean"),
    (["run", "atrias", "--step-height", "0.1"], "--step-height applies to --terrain rough"),
    (["run", "atrias", "--model-error", "mass=0.1", "mass=0.2"], "mass given more than once"),
    (["run", "atrias", "--model-error", "mass=-1"], "[-0.9, 2]"),
    (["run", "atrias", "--model-error", "volume=0.1"], "NAME one of mass, inertia, friction, stiffness"),
    (["walk", "five-link", "--gait", ""], "--gait: expected a non-empty value"),
    (["walk", "mabel", "--gait", "no-such-gait"], "neither a shipped gait"),
    (["identify", "mabel", "--data", ""], "--data: expected a non-empty value"),
    (["identify", "mabel", "--data", "/no/such/folder"], "is not a folder"),
    (["identify", "mabel", "--data", ".", "--seed", "3"], "apply to --synthetic only"),
    (["walk", "compass-gait", "--out", ""], "--out: expected a non-empty value"),
    (["optimize", "five-link", "--save", " "], "--save: expected a non-empty value"),
    (["walk", "mabel", "--steps", "3\n4"], "\\n"),
    (["bench", "\x1e\u2028"], "\\x1e\\u2028"),
])
def test_bad_values_and_combinations(argv, needle):
    line = _refused(argv)
    assert needle in line, line


def test_rejections_come_before_any_compilation_and_within_5_s(tmp_path):
    """A fresh interpreter refuses a batch of bad command lines: no JAX compilation, no study
    module imported, each refusal well under 5 s."""
    bad = [["walk", "mabel", "--steps", "0"], ["experiment", "mabel", "push", "--steps", "2"],
           ["run", "atrias", "--seconds", "1e9"], ["walk", "five-link", "--seed", "-3"],
           ["bench", "--seconds", "0.0001"], ["walk", "mabel", "--push", "5@500"],
           ["walk", "compass-gait", "--out", str(tmp_path / "f.txt")], ["identify", "mabel", "--data", ""],
           ["optimize", "mabel", "--save", str(tmp_path / "missing" / "g.json")]]
    (tmp_path / "f.txt").write_text("a file")
    script = textwrap.dedent(f"""
        import io, contextlib, json, sys, time
        import jax.monitoring
        events = []
        jax.monitoring.register_event_duration_secs_listener(lambda name, *a, **k: events.append(name))
        from bipedlab import cli
        times = []
        for argv in {bad!r}:
            t = time.perf_counter()
            err = io.StringIO()
            with contextlib.redirect_stderr(err):
                try:
                    cli.main(argv)
                    code = 0
                except SystemExit as e:
                    code = e.code
            times.append((code, time.perf_counter() - t, err.getvalue()))
        studies = sorted(m for m in sys.modules if m.startswith("bipedlab.robots.")
                         and m.rsplit(".", 1)[1] in ("study", "experiments", "bench", "loop", "walker"))
        print(json.dumps(dict(times=times, compiles=[e for e in events if "compil" in e], studies=studies)))
    """)
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    rep = json.loads(r.stdout)
    assert rep["compiles"] == [], rep["compiles"]
    assert rep["studies"] == [], rep["studies"]
    for code, secs, err in rep["times"]:
        assert code == 2 and len(err.splitlines()) == 1, err
        assert secs < 5.0, (secs, err)


# ----------------------------------------------------------------------------- output targets
def _main(argv):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = cli.main(argv)
        except SystemExit as e:
            code = e.code
    return code, out.getvalue(), err.getvalue()


def _no_staging_left(root: pathlib.Path):
    left = [str(p) for p in root.rglob(f"{outputs.STAGE_PREFIX}*")]
    assert not left, left


def test_output_targets_are_checked_before_the_study(tmp_path):
    f = tmp_path / "a-file"
    f.write_text("x")
    cases = [
        (["walk", "compass-gait", "--out", str(f)], "exists and is not a folder"),
        (["walk", "compass-gait", "--out", str(f / "sub")], "is not a folder"),
        (["optimize", "five-link", "--save", str(tmp_path / "nowhere" / "g.json")], "does not exist"),
        (["optimize", "mabel", "--save", str(tmp_path)], "is a folder, not a file"),
        (["optimize", "mabel", "--save", str(tmp_path) + "/"], "is a folder"),
        (["walk", "compass-gait", "--out", "/"], "--out"),
    ]
    for argv, needle in cases:
        t = time.perf_counter()
        code, out, err = _main(argv)
        assert code == 2 and out == "" and len(err.splitlines()) == 1 and needle in err, (argv, err)
        assert time.perf_counter() - t < 5.0
    assert f.read_text() == "x"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a-file"]


@pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0, reason="root writes anywhere")
def test_an_unwritable_folder_is_refused_before_the_study(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        code, _, err = _main(["walk", "compass-gait", "--out", str(ro / "out")])
        assert code == 2 and "cannot write" in err
        code, _, err = _main(["optimize", "mabel", "--save", str(ro / "g.json")])
        assert code == 2 and "cannot write" in err
    finally:
        ro.chmod(0o755)


@pytest.fixture
def toy(monkeypatch):
    """`bipedlab write toy`: writes figures into --out and a file to --save, then fails or not."""
    seen = {}

    def add_arguments(p):
        cli.add_out(p)
        cli.add_save(p)
        p.add_argument("--fail", choices=["none", "error", "usage", "disk"], default="none")

    def run(args, progress):
        seen.update(out=args.out, save=args.save)
        files = []
        if args.out:
            os.makedirs(os.path.join(args.out, "sub"), exist_ok=True)
            for name in ("a.png", "sub/b.npz"):
                path = os.path.join(args.out, name)
                with open(path, "w") as fh:
                    fh.write("new")
                files.append(path)
        if args.save:
            with open(args.save, "w") as fh:
                outputs.dump_json({"name": pathlib.Path(args.save).stem, "x": float("nan")}, fh)
        if args.fail == "error":
            raise RuntimeError("the study broke")
        if args.fail == "usage":
            raise cli.UsageError("toy: a bad combination found late")
        if args.fail == "disk":
            raise OSError(28, "No space left on device", os.path.join(args.out, "c.png"))
        return {"files": files, "saved": args.save}, lambda r: " ".join(r["files"])

    mod = types.ModuleType("toy_cli")
    mod.COMMANDS = [cli.Command("write", "toy", "write outputs", add_arguments, run, compile_cache=False)]
    ep = types.SimpleNamespace(name="toy", load=lambda: mod)
    monkeypatch.setattr(importlib.metadata, "entry_points",
                        lambda group=None, **kw: [ep] if group == cli.ENTRY_POINT_GROUP else [])
    return seen


def test_outputs_appear_complete_after_success(toy, tmp_path):
    out, save = tmp_path / "deep" / "er" / "res", tmp_path / "gait.json"
    code, stdout, err = _main(["write", "toy", "--out", str(out), "--save", str(save), "--json"])
    assert code == 0, err
    rec = json.loads(stdout)
    assert rec["files"] == [str(out / "a.png"), str(out / "sub" / "b.npz")]  # the final paths, not the staged ones
    assert rec["saved"] == str(save)
    assert (out / "a.png").read_text() == "new" and (out / "sub" / "b.npz").read_text() == "new"
    assert json.loads(save.read_text()) == {"name": "gait", "x": None}  # same stem; strict JSON
    assert toy["out"] != str(out) and outputs.STAGE_PREFIX in toy["out"]
    _no_staging_left(tmp_path)


def test_an_existing_folder_keeps_its_other_files(toy, tmp_path):
    out = tmp_path / "res"
    (out / "sub").mkdir(parents=True)
    (out / "a.png").write_text("old")
    (out / "keep.txt").write_text("mine")
    (out / "sub" / "keep2.txt").write_text("mine")
    assert _main(["write", "toy", "--out", str(out)])[0] == 0
    assert (out / "a.png").read_text() == "new" and (out / "sub" / "b.npz").read_text() == "new"
    assert (out / "keep.txt").read_text() == "mine" and (out / "sub" / "keep2.txt").read_text() == "mine"
    _no_staging_left(tmp_path)


@pytest.mark.parametrize("fail,code,needle", [("usage", 2, "a bad combination found late"),
                                              ("disk", 1, "could not write the outputs: No space left")])
def test_a_failed_run_leaves_no_output(toy, tmp_path, fail, code, needle):
    out, save = tmp_path / "new" / "res", tmp_path / "g.json"
    got, stdout, err = _main(["write", "toy", "--out", str(out), "--save", str(save), "--fail", fail])
    assert got == code and stdout == "" and len(err.splitlines()) == 1 and needle in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # not even the parent made for --out
    existing = tmp_path / "old"
    existing.mkdir()
    (existing / "a.png").write_text("old")
    assert _main(["write", "toy", "--out", str(existing), "--fail", fail])[0] == code
    assert [p.name for p in existing.iterdir()] == ["a.png"] and (existing / "a.png").read_text() == "old"
    _no_staging_left(tmp_path)


def test_an_unexpected_error_still_removes_the_staged_outputs(toy, tmp_path):
    with pytest.raises(RuntimeError):
        cli.main(["write", "toy", "--out", str(tmp_path / "res"), "--fail", "error"])
    assert list(tmp_path.iterdir()) == []


# ----------------------------------------------------------------------------- strict JSON on disk
def test_json_written_to_disk_is_strict(tmp_path):
    rec = {"a": float("nan"), "b": [np.float64("inf"), np.float32("nan"), 1.5, np.float32(2.0)],
           "c": {"d": (float("-inf"), 3)}}
    path = tmp_path / "r.json"
    with open(path, "w") as fh:
        outputs.dump_json(rec, fh, indent=1)

    def refuse(token):
        raise AssertionError(f"non-strict JSON token {token}")

    assert json.loads(path.read_text(), parse_constant=refuse) == {"a": None, "b": [None, None, 1.5, 2.0],
                                                                   "c": {"d": [None, 3]}}


def test_no_module_writes_lenient_json():
    """JSON reaches disk through bipedlab.outputs (strict) only: no json.dump to a file elsewhere,
    no allow_nan=True anywhere."""
    offenders = []
    for path in SRC.rglob("*.py"):
        if path.name == "outputs.py":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
                f = node.func
                if isinstance(f.value, ast.Name) and f.value.id == "json" and f.attr == "dump":
                    offenders.append(f"{path}:{node.lineno}: json.dump")
                for kw in node.keywords:
                    if kw.arg == "allow_nan" and isinstance(kw.value, ast.Constant) and kw.value.value is True:
                        offenders.append(f"{path}:{node.lineno}: allow_nan=True")
    assert not offenders, offenders


# ----------------------------------------------------------------------------- interruption
def _console():
    exe = os.path.join(os.path.dirname(sys.executable), "bipedlab")
    return [exe] if os.path.exists(exe) else [shutil.which("bipedlab") or "bipedlab"]


def _interrupt(cmd, env, sig, wait_for: str, delay: float, timeout=240):
    """Start cmd, wait for a stderr line containing ``wait_for``, wait ``delay`` s, send sig.
    Returns (exit code, stdout, stderr lines other than progress, seconds from signal to exit)."""
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    seen = []
    try:
        t0 = time.monotonic()
        while True:
            line = p.stderr.readline()
            assert line, f"ended before {wait_for!r}: {''.join(seen)}"
            seen.append(line)
            if wait_for in line:
                break
            assert time.monotonic() - t0 < timeout
        time.sleep(delay)
        t = time.monotonic()
        p.send_signal(sig)
        out, err = p.communicate(timeout=60)
        dt = time.monotonic() - t
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    lines = [ln for ln in "".join(seen + [err]).splitlines() if not ln.startswith("[bipedlab]")]
    return p.returncode, out, lines, dt


def _cache_ok(cache: pathlib.Path):
    """No partial entry: nothing but whole files JAX names itself (no stray temporaries)."""
    if cache.exists():
        assert not [p for p in cache.rglob("*") if outputs.STAGE_PREFIX in p.name]


@pytest.mark.parametrize("sig,code,line", [(signal.SIGINT, 130, "bipedlab: interrupted"),
                                           pytest.param(signal.SIGTERM, 143, "bipedlab: terminated",
                                                        marks=pytest.mark.slow)])
def test_a_signal_during_compilation_ends_with_one_line_and_no_output(tmp_path, sig, code, line):
    cache, out = tmp_path / "cache", tmp_path / "res"
    env = dict(os.environ, BIPEDLAB_CACHE_DIR=str(cache), BIPEDLAB_XLA_CACHE_DIR=str(cache))
    got, stdout, lines, dt = _interrupt(_console() + ["walk", "compass-gait", "--steps", "200", "--out", str(out)],
                                        env, sig, "compass gait:", 1.5)
    assert (got, stdout, lines) == (code, "", [line])
    assert dt < 10.0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cache"]  # no res, no staging folder
    _cache_ok(cache)


TOY_RUNNER = '''
import importlib.metadata, os, sys, types
import jax, jax.numpy as jnp
from bipedlab import cli

def add_arguments(p):
    cli.add_out(p)

def run(args, progress):
    f = jax.jit(lambda x: jnp.sin(x) @ jnp.cos(x).T)
    x = jnp.ones((200, 200))
    with open(os.path.join(args.out, "part.npz"), "w") as fh:
        fh.write("half")
    progress("running")
    while True:
        x = f(x) / 200.0
        x.block_until_ready()

mod = types.ModuleType("toy_cli")
mod.COMMANDS = [cli.Command("spin", "toy", "spin", add_arguments, run, compile_cache=False)]
ep = types.SimpleNamespace(name="toy", load=lambda: mod)
importlib.metadata.entry_points = lambda group=None, **kw: [ep] if group == cli.ENTRY_POINT_GROUP else []
sys.exit(cli.main(sys.argv[1:]))
'''


@pytest.mark.parametrize("sig,code,line", [pytest.param(signal.SIGINT, 130, "bipedlab: interrupted",
                                                        marks=pytest.mark.slow),
                                           (signal.SIGTERM, 143, "bipedlab: terminated")])
def test_a_signal_during_the_run_leaves_no_partial_output(tmp_path, sig, code, line):
    script = tmp_path / "runner.py"
    script.write_text(TOY_RUNNER)
    out = tmp_path / "res"
    got, stdout, lines, dt = _interrupt([sys.executable, str(script), "spin", "toy", "--out", str(out)],
                                        dict(os.environ), sig, "running", 1.0)
    assert (got, stdout, lines) == (code, "", [line])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["runner.py"]


@pytest.mark.slow
def test_a_signal_while_a_study_walks_then_the_cache_still_serves(tmp_path):
    """The compass-gait study interrupted after compiling, while walking: 130, one line, no
    output; the next run from the same cache compiles nothing broken and prints no warning."""
    cache, out = tmp_path / "cache", tmp_path / "res"
    env = dict(os.environ, BIPEDLAB_CACHE_DIR=str(cache), BIPEDLAB_XLA_CACHE_DIR=str(cache))
    got, stdout, lines, _ = _interrupt(_console() + ["walk", "compass-gait", "--steps", "10000", "--out", str(out)],
                                       env, signal.SIGINT, "walking 10000 steps", 2.0, timeout=600)
    assert (got, stdout, lines) == (130, "", ["bipedlab: interrupted"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cache"]
    _cache_ok(cache)
    r = subprocess.run(_console() + ["walk", "compass-gait", "--steps", "2", "--out", str(out)], capture_output=True,
                       text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stderr
    assert [ln for ln in r.stderr.splitlines() if not ln.startswith("[bipedlab]")] == []
    assert [p.name for p in out.iterdir()] == ["compass_gait_3deg.png"]


def test_a_keyboard_interrupt_before_the_handlers_is_one_line(monkeypatch):
    def boom(argv=None, parser=None):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "parse", boom)
    code, out, err = _main(["walk", "mabel"])
    assert (code, out, err) == (130, "", "bipedlab: interrupted\n")
