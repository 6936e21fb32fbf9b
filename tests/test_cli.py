"""The `bipedlab` command: help, one-line errors with status 2, and the bench JSON record."""
from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys

import pytest

from bipedlab.cli import main

BENCH_KEYS = ("bipedlab_substeps_per_s", "mujoco_substeps_per_s", "ratio_vs_mujoco",
              "batched_ratio_vs_mujoco", "compile_s", "device", "dtype", "batched")


def _console_script():
    exe = os.path.join(os.path.dirname(sys.executable), "bipedlab")
    return [exe] if os.path.exists(exe) else [shutil.which("bipedlab") or "bipedlab"]


def _run(args, env=None, timeout=300):
    return subprocess.run(_console_script() + list(args), capture_output=True, text=True, env=env, timeout=timeout)


def test_no_arguments_prints_help_listing_studies():
    r = _run([])
    assert r.returncode == 0, r.stderr
    assert "usage: bipedlab" in r.stdout
    studies = r.stdout.split("studies:", 1)[1]
    assert "bench" in studies


def test_main_without_arguments_returns_zero(capsys):
    assert main([]) == 0
    out = capsys.readouterr().out
    assert "bench" in out and "studies:" in out


@pytest.mark.parametrize("argv", [
    ["bench", "--batch", "0"],
    ["bench", "--batch", "-3"],
    ["bench", "--seconds", "0"],
    ["bench", "--seconds", "nan"],
    ["bench", "--seconds", "abc"],
    ["no-such-study"],
    ["bench", "--no-such-option"],
])
def test_bad_input_is_one_error_line_and_status_2(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("bipedlab: error: "), captured.err


def test_bad_input_exit_status_from_the_console_script():
    for argv in (["bench", "--batch", "0"], ["frobnicate"]):
        r = _run(argv)
        assert r.returncode == 2
        assert r.stdout == ""
        lines = r.stderr.splitlines()
        assert len(lines) == 1 and lines[0].startswith("bipedlab: error: "), r.stderr
    assert "frobnicate" in r.stderr


@pytest.fixture(scope="module")
def bench_records(tmp_path_factory):
    """`bench --json` without and with MuJoCo. The two runs compile the same programs, so a
    shared JAX compilation cache spares the second run its compile time."""
    env = dict(os.environ, JAX_COMPILATION_CACHE_DIR=str(tmp_path_factory.mktemp("jax_cache")))
    out = {}
    for label, extra in (("no_mujoco", ["--no-mujoco"]), ("mujoco", [])):
        r = _run(["bench", "--json", "--seconds", "0.02", "--batch", "2", *extra], env=env)
        assert r.returncode == 0, r.stderr
        lines = r.stdout.strip().splitlines()
        assert len(lines) == 1, r.stdout  # one JSON object and nothing else on stdout
        out[label] = json.loads(lines[0])
    return out


def _positive_number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0


def _check_common(rec):
    for k in BENCH_KEYS:
        assert k in rec, k
    assert _positive_number(rec["bipedlab_substeps_per_s"])
    assert isinstance(rec["compile_s"], float) and math.isfinite(rec["compile_s"])
    assert rec["dtype"] == "float64"
    assert isinstance(rec["device"], str) and rec["device"]
    assert rec["substeps_per_rollout"] == 80  # 0.02 s at 0.25 ms
    batches = [b["batch"] for b in rec["batched"]]
    assert batches == [2, 64]  # the requested size and MuJoCo's batch of 64
    for b in rec["batched"]:
        assert _positive_number(b["substeps_per_s"])
        assert b["all_finite"] is True


def test_bench_json_without_mujoco(bench_records):
    rec = bench_records["no_mujoco"]
    _check_common(rec)
    for k in ("mujoco_substeps_per_s", "ratio_vs_mujoco", "batched_ratio_vs_mujoco",
              "ratio_vs_mujoco_point_feet", "batched_ratio_vs_mujoco_point_feet"):
        assert rec.get(k) is None, k


def test_bench_json_with_mujoco(bench_records):
    pytest.importorskip("mujoco")
    rec = bench_records["mujoco"]
    _check_common(rec)
    for k in ("mujoco_substeps_per_s", "ratio_vs_mujoco", "batched_ratio_vs_mujoco"):
        assert _positive_number(rec[k]), (k, rec[k])
    assert rec["ratio_vs_mujoco"] == pytest.approx(rec["bipedlab_substeps_per_s"] / rec["mujoco_substeps_per_s"])
    b64 = next(b for b in rec["batched"] if b["batch"] == 64)
    assert rec["batched_ratio_vs_mujoco"] == pytest.approx(
        b64["substeps_per_s"] / rec["mujoco_batched_substeps_per_s"])
    assert isinstance(rec["mujoco"]["version"], str)
    # the same figures against the point-feet MuJoCo model
    pf = rec["mujoco_point_feet"]
    for k in ("ratio_vs_mujoco_point_feet", "batched_ratio_vs_mujoco_point_feet"):
        assert _positive_number(rec[k]), (k, rec[k])
    assert rec["ratio_vs_mujoco_point_feet"] == pytest.approx(
        rec["bipedlab_substeps_per_s"] / pf["single_substeps_per_s"])
    assert rec["batched_ratio_vs_mujoco_point_feet"] == pytest.approx(
        b64["substeps_per_s"] / pf["batched_substeps_per_s"])


def test_bench_simulates_the_scenario(bench_records):
    # 20 ms from rest with the joints at their references: no joint torque, feet still
    # 1.6 cm above the ground, so the hip is in free fall: y = 0.78 - g t^2 / 2
    for rec in bench_records.values():
        assert rec["final_hip_height_m"] == pytest.approx(0.78 - 0.5 * 9.81 * 0.02**2, abs=1e-9)


# ---- the registry: commands collected from the robot packages ------------------------------

import importlib  # noqa: E402
import pathlib  # noqa: E402
import re  # noqa: E402
import types  # noqa: E402

from bipedlab import cli  # noqa: E402


def _commands():
    return cli.commands()


def _one_error_line(argv, capsys) -> str:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2, argv
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("bipedlab: error: "), captured.err
    return lines[0]


@pytest.mark.parametrize("name", [c.name for c in cli.commands()])
def test_every_command_parser_builds_and_help_exits_0(name, capsys):
    with pytest.raises(SystemExit) as exc:
        main(name.split() + ["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith(f"usage: bipedlab {name}") and "--json" in out


def _options(p) -> set:
    return {s for a in p._actions for s in a.option_strings if s.startswith("--") and s != "--help"}


def _positionals(p) -> list:
    """A valid value for each positional argument of a command (its first choice, or a shipped
    example file), then each required option with a value (parsing reports a missing required
    option before an unknown one)."""
    out = []
    for a in p._actions:
        if not a.option_strings and a.dest != "help":
            if a.choices:
                out.append(a.choices[0])
            elif a.nargs not in ("*", "?"):
                out.append("rabbit.xml")
    for a in p._actions:
        if a.option_strings and a.required:
            out += [a.option_strings[0], "x"]
    return out


def test_an_option_of_one_robot_is_refused_by_another(capsys, monkeypatch):
    # ~200 refusals, each main() building the whole parser: the registry reads the installed
    # packages' entry points every time (about half of each call), and they cannot change during
    # the test, so they are read once (the modules they name are still loaded by the registry)
    real, seen = importlib.metadata.entry_points, {}

    def entry_points(**kw):
        key = tuple(sorted(kw.items()))
        if key not in seen:
            seen[key] = real(**kw)
        return seen[key]

    monkeypatch.setattr(importlib.metadata, "entry_points", entry_points)
    parsers = cli.command_parsers(cli.build_parser())
    by_verb = {}
    for c in cli.commands():
        if c.robot is not None:
            by_verb.setdefault(c.verb, []).append(c.name)
    checked = 0
    for names in by_verb.values():
        for a in names:
            for b in names:
                for opt in sorted(_options(parsers[a]) - _options(parsers[b])):
                    line = _one_error_line(b.split() + _positionals(parsers[b]) + [opt, "1"], capsys)
                    assert f"{b}: unrecognized arguments: {opt}" in line, line
                    checked += 1
    assert checked > 10
    # the cases that used to be checked by hand
    for argv, needle in ((["optimize", "five-link", "--step-length", "0.575"], "--step-length"),
                         (["walk", "five-link", "--push", "78@3"], "--push"),
                         (["walk", "mabel", "--perturb", "0.1"], "--perturb"),
                         (["walk", "mabel", "--params", "paper"], "--params")):
        assert needle in _one_error_line(argv, capsys)


def test_a_verb_without_the_robot_or_without_a_robot_is_one_line(capsys):
    assert "five-link" in _one_error_line(["hop", "five-link"], capsys)
    line = _one_error_line(["walk"], capsys)
    walkers = [c.robot for c in cli.commands() if c.verb == "walk"]
    assert all(r in line for r in walkers), line


def test_the_registry_finds_every_robot_package_with_a_cli():
    import bipedlab.robots as robots

    on_disk = sorted(f"bipedlab.robots.{d.name}.cli" for p in robots.__path__ for d in pathlib.Path(p).iterdir()
                     if d.is_dir() and (d / "__init__.py").exists() and (d / "cli.py").exists())
    assert cli.robot_cli_modules() == on_disk
    assert {"five_link", "mabel", "atrias", "seven_link", "compass_gait"} <= {n.split(".")[2] for n in on_disk}
    registered = set(cli.commands())
    for name in on_disk:
        mod = importlib.import_module(name)
        assert mod.COMMANDS and set(mod.COMMANDS) <= registered, name
        for c in mod.COMMANDS:
            assert isinstance(c, cli.Command) and c.help


def test_no_arguments_lists_every_verb_and_command(capsys):
    assert main([]) == 0
    studies = capsys.readouterr().out.split("studies:", 1)[1]
    for c in cli.commands():
        assert c.verb in studies and c.name in studies and c.help in studies


HELP_CHECK = """
import contextlib, io, json, sys
from bipedlab.cli import main
out = {}
for argv in ARGVS:
    with contextlib.redirect_stdout(io.StringIO()):
        try:
            code = main(argv)
        except SystemExit as e:
            code = e.code
    out[" ".join(argv)] = code
heavy = sorted(m for m in sys.modules if m.split(".")[0] in ("jax", "jaxlib", "numpy", "scipy", "mujoco"))
print(json.dumps(dict(codes=out, heavy=heavy)))
"""


def test_help_imports_no_jax():
    """The listing and every command's --help (what a command module declares: options,
    vocabularies, refusal reasons) are built without importing JAX, NumPy or any study."""
    argvs = [[]] + [c.name.split() + ["--help"] for c in cli.commands()]
    r = subprocess.run([sys.executable, "-c", f"ARGVS = {argvs!r}\n" + HELP_CHECK], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, r.stderr
    rep = json.loads(r.stdout)
    assert set(rep["codes"].values()) == {0}, rep["codes"]
    assert rep["heavy"] == [], rep["heavy"]


def test_the_core_names_no_robot():
    text = pathlib.Path(cli.__file__).read_text()
    for c in cli.commands():
        if c.robot is not None:  # as a word: a robot may be called by a common word ("model")
            assert not re.search(rf"(?<![\w-]){re.escape(c.robot)}(?![\w-])", text), c.robot


@pytest.fixture
def toy_entry_point(monkeypatch):
    """A third-party package registering `bipedlab greet toy` through the entry-point group."""
    calls = []

    def add_arguments(p):
        p.add_argument("--name", default="world")

    def run(args, progress):
        if args.name == "nobody":
            raise cli.UsageError("toy: --name must name somebody")
        progress("greeting")
        return {"hello": args.name, "ratio": float("nan")}, lambda r: f"hello {r['hello']}"

    toy = types.ModuleType("toy_cli")
    toy.COMMANDS = [cli.Command("greet", "toy", "say hello", add_arguments, run, compile_cache=False,
                                before_jax=lambda args: calls.append(args.name))]
    ep = types.SimpleNamespace(name="toy", load=lambda: toy)

    def entry_points(group=None, **kw):
        return [ep] if group == cli.ENTRY_POINT_GROUP else []

    monkeypatch.setattr(importlib.metadata, "entry_points", entry_points)
    monkeypatch.setattr(cli, "_enable_compile_cache", lambda: calls.append("cache"))
    return calls


def test_entry_point_commands_run_through_the_one_emit(toy_entry_point, capsys):
    assert main(["greet", "toy", "--name", "there", "--json"]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out) == {"hello": "there", "ratio": None}  # non-finite -> null
    assert "[bipedlab] greeting" in captured.err
    assert toy_entry_point == ["there"]  # before_jax ran, the compile cache was left alone
    assert main(["greet", "toy"]) == 0
    assert capsys.readouterr().out.strip() == "hello world"
    assert "toy: --name must name somebody" in _one_error_line(["greet", "toy", "--name", "nobody"], capsys)
    assert "greet toy" in cli.listing()
