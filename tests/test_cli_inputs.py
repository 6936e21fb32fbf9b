"""Inputs at the command line's boundary that used to escape its contract (exit status 2 and one
``bipedlab: error:`` line before any work; status 1 and one line when the outputs cannot be
written): output paths too long for the file system, the JAX / XLA / bipedlab environment
variables, stdout full or closed, text inputs in other encodings (a byte-order mark, CRLF,
UTF-16), a model holding a NaN or xacro macros, numerals Python reads but the grammar does not
take, and the ranges the README states.

Most checks run in this process through ``cli.parse`` / ``cli.main``; a few need a process of
their own (stdout closed, variables JAX reads when it starts), each a command that ends before
any study."""
from __future__ import annotations

import dataclasses
import importlib.resources
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import expect_usage_error
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import bipedlab
from bipedlab import cli, environment, inputs, outputs
from bipedlab.commands import parse_float, parse_int

SRC = str(Path(bipedlab.__file__).resolve().parents[1])
RABBIT = str(importlib.resources.files("bipedlab.robots.imported") / "data" / "rabbit.xml")
ROOT = Path(__file__).resolve().parents[1]
LONG = "a" * 300


def _bipedlab(argv, env=None, cwd=None, **kw):
    """``bipedlab argv`` in a process of its own, this checkout's package first on the path."""
    environ = {k: v for k, v in os.environ.items() if k not in ("XLA_FLAGS", "JAX_PLATFORMS")}
    environ.update(PYTHONPATH=SRC, **(env or {}))
    return subprocess.run([sys.executable, "-m", "bipedlab.cli", *argv], capture_output=True, text=True,
                          timeout=120, env=environ, cwd=cwd, **kw)


def _one_error_line(err: str, status_line="bipedlab: error: ") -> str:
    lines = [ln for ln in err.splitlines() if not ln.startswith("[bipedlab]")]
    assert len(lines) == 1 and lines[0].startswith(status_line), err[-3000:]
    return lines[0]


# ----------------------------------------------------------------------------- output paths
@pytest.mark.parametrize("argv,option", [
    (["walk", "five-link", "--steps", "1", "--out", LONG], "--out"),
    (["optimize", "five-link", "--speed", "0.8", "--save", LONG + ".json"], "--save"),
    (["optimize", "model", RABBIT, "--stance", "left_foot", "--swing", "right_foot", "--save", LONG + ".json"],
     "--save"),
    (["walk", "five-link", "--steps", "1", "--out", "x/" * 2100 + "out"], "--out"),
], ids=["walk --out", "optimize --save", "optimize model --save", "walk --out deep"])
def test_an_output_path_the_file_system_cannot_take_is_refused_before_any_work(argv, option, tmp_path, monkeypatch,
                                                                                 capsys):
    monkeypatch.chdir(tmp_path)
    line = expect_usage_error(argv, capsys, needle=option)
    assert "long" in line, line
    assert list(tmp_path.iterdir()) == []  # no staging folder left


_NAME = st.text(st.characters(codec="utf-8", exclude_characters="/\x00"), min_size=1, max_size=300)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(parts=st.lists(_NAME, min_size=1, max_size=3), kind=st.sampled_from(["dir", "file"]))
def test_a_generated_output_path_is_staged_or_refused_in_one_line(parts, kind, tmp_path):
    """Whatever the path, staging it either succeeds (and discarding leaves nothing) or raises
    OutputError in one line; never another error, never a staging folder left behind."""
    work = tmp_path / "w"
    work.mkdir(exist_ok=True)
    path = os.path.join(str(work), *parts)
    staging = outputs.Staging()
    try:
        staged = staging.stage_dir("--out", path) if kind == "dir" else staging.stage_file("--save", path)
    except outputs.OutputError as e:
        assert str(e).startswith(("--out", "--save"))
    else:
        assert staging.owns(staged)
    staging.discard()
    assert not any(n.startswith(outputs.STAGE_PREFIX) for _, ds, fs in os.walk(work) for n in ds + fs)
    for p in sorted(work.rglob("*"), reverse=True):
        p.rmdir() if p.is_dir() else p.unlink()


# ----------------------------------------------------------------------------- environment variables
@pytest.mark.parametrize("env,needle", [
    ({"JAX_PLATFORMS": "tpu9"}, "$JAX_PLATFORMS"), ({"JAX_PLATFORMS": "cpu,,x"}, "$JAX_PLATFORMS"),
    ({"XLA_FLAGS": "bogus"}, "$XLA_FLAGS"), ({"XLA_FLAGS": "--xla_a=1 -- x"}, "$XLA_FLAGS"),
], ids=lambda v: ",".join(f"{k}={x}" for k, x in v.items()) if isinstance(v, dict) else "")
def test_a_bad_jax_variable_is_one_line_before_any_work(env, needle, monkeypatch, capsys):
    for k, v in env.items():
        monkeypatch.setenv(k, v)
    expect_usage_error(["walk", "compass-gait", "--steps", "1"], capsys, needle=needle)


@pytest.mark.parametrize("variable", ["BIPEDLAB_CACHE_DIR", "BIPEDLAB_XLA_CACHE_DIR"])
@pytest.mark.parametrize("what", ["a file", "under a file", "unwritable"])
def test_a_cache_folder_that_cannot_be_used_is_one_line(what, variable, tmp_path, monkeypatch, capsys):
    f = tmp_path / "f"
    f.write_text("x")
    if what == "unwritable":
        if os.geteuid() == 0:
            target = "/proc/bipedlab-cache"  # not even root creates a folder there
        else:
            ro = tmp_path / "ro"
            ro.mkdir(mode=0o500)
            target = str(ro / "cache")
    else:
        target = str(f) if what == "a file" else str(f / "cache")
    monkeypatch.setenv(variable, target)
    expect_usage_error(["walk", "compass-gait", "--steps", "1"], capsys, needle=f"${variable}")


def test_local_device_ids_are_checked_in_a_single_process_run(monkeypatch, capsys):
    for k in ("JAX_NUM_PROCESSES", "JAX_PROCESS_ID", "JAX_COORDINATOR_ADDRESS", "SLURM_NTASKS"):
        monkeypatch.delenv(k, raising=False)
    monkeypatch.setenv("JAX_LOCAL_DEVICE_IDS", "a,b")
    expect_usage_error(["robustness", "five-link", "--trials", "1", "--steps", "1", "--devices", "1"], capsys,
                       needle="$JAX_LOCAL_DEVICE_IDS")


def test_a_platform_that_does_not_start_is_one_line_naming_it(monkeypatch):
    import jax

    def no_backend(*a, **k):
        raise AssertionError()

    monkeypatch.setattr(jax, "devices", no_backend)
    monkeypatch.setenv("JAX_PLATFORMS", "cuda")
    problem = environment.devices_problem()
    assert problem.startswith("$JAX_PLATFORMS: ") and "'cuda'" in problem and "\n" not in problem


@pytest.mark.parametrize("env,needle", [
    ({"JAX_PLATFORMS": "cuda"}, "$JAX_PLATFORMS"),  # no GPU plugin here: JAX fails with a bare AssertionError
    ({"XLA_FLAGS": "--xla_bogus_flag=1"}, "$XLA_FLAGS"),  # XLA's fatal log line ends the process
], ids=["JAX_PLATFORMS=cuda", "XLA_FLAGS=--xla_bogus_flag=1"])
def test_what_jax_reads_at_start_is_one_line(env, needle, tmp_path):
    if env.get("JAX_PLATFORMS") == "cuda":
        import jax

        if any(d.platform == "gpu" for d in jax.devices()):
            pytest.skip("this machine has a GPU")
    r = _bipedlab(["walk", "compass-gait", "--steps", "1", "--out", "o"], env=env, cwd=tmp_path)
    assert r.returncode == 2 and r.stdout == "", r.stderr[-3000:]
    line = _one_error_line(r.stderr)
    assert needle in line and "Traceback" not in r.stderr, line
    assert list(tmp_path.iterdir()) == []


def test_a_list_of_platforms_and_flags_is_read():
    assert environment.platforms_problem("cpu") is None and environment.platforms_problem("cuda,cpu") is None
    assert environment.xla_flags_problem("--xla_force_host_platform_device_count=4 --xla_cpu_enable_fast_math=false") is None


# ----------------------------------------------------------------------------- stdout
def _quick(monkeypatch, record=None):
    """Commands run as a stand-in that returns a record at once (the printing is what is tested)."""
    real = cli.parse

    def parse(argv=None, parser=None):
        p, args = real(argv, parser)
        args._command = dataclasses.replace(args._command, run=lambda a, progress: (record or {"x": 1.0}, str),
                                            compile_cache=False, before_jax=None)
        return p, args

    monkeypatch.setattr(cli, "parse", parse)


def test_a_full_stdout_is_status_1_and_one_line(monkeypatch, capfd):
    _quick(monkeypatch)
    full = open("/dev/full", "w")
    monkeypatch.setattr(sys, "stdout", full)
    try:
        assert cli.main(["walk", "compass-gait", "--json"]) == 1
    finally:
        monkeypatch.undo()
        try:
            full.close()  # what the failed write left in its buffer fails again
        except OSError:
            pass
    line = _one_error_line(capfd.readouterr().err)
    assert "No space left on device" in line, line


def test_a_closed_stdout_is_status_1_before_any_work(monkeypatch, capsys):
    _quick(monkeypatch)
    monkeypatch.setattr(sys, "stdout", None)
    assert cli.main(["walk", "compass-gait", "--json"]) == 1
    assert "standard output is closed" in _one_error_line(capsys.readouterr().err)


def test_a_closed_stdout_descriptor_is_status_1(tmp_path):
    """``bipedlab ... >&-``: the interpreter starts without stdout."""
    env = {k: v for k, v in os.environ.items() if k not in ("XLA_FLAGS", "JAX_PLATFORMS")}
    r = subprocess.run(["sh", "-c", 'exec "$0" -m bipedlab.cli walk compass-gait --steps 1 --json >&-', sys.executable],
                       stderr=subprocess.PIPE, text=True, timeout=120, cwd=tmp_path, env=dict(env, PYTHONPATH=SRC))
    assert r.returncode == 1, r.stderr[-3000:]
    assert "standard output" in _one_error_line(r.stderr)


# ----------------------------------------------------------------------------- numerals
@pytest.mark.parametrize("value", ["1_0", "\u0661\u0660", "\uff11", " 3", "3 ", "+", "0x10", "1e3", "٣"])
def test_an_integer_option_takes_ascii_digits_only(value, capsys):
    expect_usage_error(["walk", "five-link", "--steps", value], capsys, needle="--steps")


@pytest.mark.parametrize("value", ["1_0", "\u0660.5", "0.5\u2009", "inf", "nan", "1e", ".", "0x1p-2", "½"])
def test_a_number_option_takes_the_numeral_grammar_only(value, capsys):
    expect_usage_error(["walk", "five-link", "--steps", "1", f"--perturb={value}"], capsys, needle="--perturb")


@given(st.text(max_size=12))
@settings(max_examples=200, deadline=None)
def test_the_numeral_grammar(text):
    """parse_int / parse_float take exactly sign, ASCII digits, point, exponent."""
    if re.fullmatch(r"[+-]?[0-9]+", text, re.ASCII):
        assert parse_int(text) == int(text)
    else:
        with pytest.raises(ValueError):
            parse_int(text)
    if re.fullmatch(r"[+-]?([0-9]+(\.[0-9]*)?|\.[0-9]+)([eE][+-]?[0-9]+)?", text, re.ASCII):
        assert parse_float(text) == float(text)
    else:
        with pytest.raises(ValueError):
            parse_float(text)


@pytest.mark.parametrize("value", ["78@1_0", "7_8@10", "78@\u0661"])
def test_a_push_takes_the_numeral_grammar(value, capsys):
    expect_usage_error(["walk", "mabel", f"--push={value}"], capsys, needle="--push")


# ----------------------------------------------------------------------------- ranges
def test_trials_above_the_documented_range_are_refused(capsys):
    expect_usage_error(["robustness", "five-link", "--trials", "100001"], capsys, needle="--trials")


_README_RANGE = re.compile(r"(steps and hops|`--[a-z-]+`|seeds) (-?[0-9.]+) to ([0-9.]+)")


def test_the_readme_states_the_ranges_help_states():
    """Every "X to Y" range of the README's paragraph on numeric options is what the parsers
    check (one source: the parsers' ranges)."""
    from bipedlab.commands import Range

    text = (ROOT / "README.md").read_text()
    para = text[text.index("Every numeric option has a range"):]
    para = para[:para.index("\n\n")]
    stated = _README_RANGE.findall(para)
    assert len(stated) >= 5, para
    ranges = {}
    for name, p in cli.command_parsers(cli.build_parser()).items():
        for a in p._actions:
            if isinstance(a.type, Range):
                for o in a.option_strings:
                    ranges.setdefault(o, set()).add((float(a.type.lo), float(a.type.hi)))
    for what, lo, hi in stated:
        options = ["--steps", "--hops"] if what == "steps and hops" else ["--seed"] if what == "seeds" else [what.strip("`")]
        for o in options:
            assert o in ranges, o
            if what == "seeds":
                continue  # 0 to 2^32-1, written with a superscript
            assert (float(lo), float(hi)) in ranges[o], (o, lo, hi, ranges[o])
    # every --trials 1 to 100000, but the sensitivity's, whose standard errors need two draws
    assert ranges["--trials"] == {(1.0, 100_000.0), (2.0, 100_000.0)}


# ----------------------------------------------------------------------------- encodings
def _bias_log_bytes(tmp_path) -> bytes:
    from bipedlab.robots.mabel.sysid.logs import Experiment, write_log

    t = np.arange(400) * 1e-3
    u = 0.02 * np.sin(2 * np.pi * 3 * t) + 0.01 * np.sin(2 * np.pi * 11 * t)
    w, th, rotor = 0.0, 0.0, []
    for v in u:  # a rotor: inertia 3e-4, viscous friction 2e-3, a bias of 0.01
        rotor.append(th)
        th += 1e-3 * w
        w += 1e-3 * (v + 0.01 - 2e-3 * w) / 3e-4
    write_log(Experiment("bias_mLA_L", "bias", t, {"mLA_L": u}, {"mla_L": np.array(rotor)},
                         meta=dict(actuator="mLA_L")), tmp_path / "src.csv")
    data = (tmp_path / "src.csv").read_bytes()
    (tmp_path / "src.csv").unlink()
    return data.replace(b"\r\n", b"\n")


ENCODINGS = {
    "utf-8": lambda b: b,
    "BOM": lambda b: b"\xef\xbb\xbf" + b,
    "CRLF": lambda b: b.replace(b"\n", b"\r\n"),
    "BOM+CRLF": lambda b: b"\xef\xbb\xbf" + b.replace(b"\n", b"\r\n"),
    "UTF-16": lambda b: b.decode().encode("utf-16"),
    "UTF-16-BE": lambda b: b"\xfe\xff" + b.decode().encode("utf-16-be"),
}


@pytest.mark.parametrize("encoding", ENCODINGS)
def test_a_log_reads_the_same_in_every_encoding(encoding, tmp_path):
    from bipedlab.robots.mabel.sysid.logs import read_log

    raw = _bias_log_bytes(tmp_path)
    (tmp_path / "a.csv").write_bytes(raw)
    (tmp_path / "b.csv").write_bytes(ENCODINGS[encoding](raw))
    a, b = read_log(tmp_path / "a.csv"), read_log(tmp_path / "b.csv")
    assert a.name == b.name and a.meta == b.meta
    np.testing.assert_array_equal(a.t, b.t)


def test_an_identification_reads_a_log_with_a_bom(tmp_path, capsys):
    """The row of the issue: a BOM before '# experiment: ...' hid the metadata."""
    data = tmp_path / "logs"
    data.mkdir()
    (data / "a.csv").write_bytes(b"\xef\xbb\xbf" + _bias_log_bytes(tmp_path))
    assert cli.main(["identify", "mabel", "--data", str(data), "--json"]) == 0
    assert '"bias_mLA_L"' in capsys.readouterr().out


@pytest.mark.parametrize("content,needle", [(b"", "empty"), (b"  \n", "no text"), (b"\xff\xfe\x00", "UTF-16"),
                                            (b"a\x00b", "NUL")], ids=["0 bytes", "blanks", "odd UTF-16", "NUL"])
def test_a_log_that_is_no_text_says_why(content, needle, tmp_path, capsys):
    data = tmp_path / "logs"
    data.mkdir()
    (data / "a.csv").write_bytes(content)
    line = expect_usage_error(["identify", "mabel", "--data", str(data)], capsys, needle="a.csv")
    assert needle in line and "metadata" not in line, line


@given(st.binary(max_size=64))
@settings(max_examples=100, deadline=None)
def test_decode_text_is_text_or_one_reason(data):
    try:
        text = inputs.decode_text(data)
    except inputs.TextError as e:
        assert "\n" not in str(e)
    else:
        assert text.strip() and "\0" not in text and not text.startswith("\ufeff")


@pytest.mark.parametrize("encoding", ["BOM", "CRLF", "UTF-16"])
def test_a_model_reads_in_every_encoding(encoding, tmp_path):
    raw = Path(RABBIT).read_bytes()
    f = tmp_path / "r.xml"
    f.write_bytes(ENCODINGS[encoding](raw))
    assert inputs.model_text(str(f)).replace("\r\n", "\n") == raw.decode().replace("\r\n", "\n")


# ----------------------------------------------------------------------------- model files
def _rabbit_with(old: str, new: str, tmp_path) -> str:
    text = Path(RABBIT).read_text()
    assert old in text
    f = tmp_path / "m.xml"
    f.write_text(text.replace(old, new, 1))
    return str(f)


def test_a_nan_position_is_blamed_on_the_position(tmp_path, capsys):
    text = Path(RABBIT).read_text()
    m = re.search(r'<body name="torso"[^>]*pos="([^"]*)"', text)
    f = _rabbit_with(m.group(0), m.group(0).replace(m.group(1), "0 0 nan"), tmp_path)
    line = expect_usage_error(["optimize", "model", f, "--stance", "left_foot", "--swing", "right_foot"], capsys,
                              needle="pos=")
    assert "NaN" in line and "mass" not in line, line


@pytest.mark.parametrize("value", ["inf", "-Infinity", "1 nan 2"])
def test_every_nonfinite_number_of_a_model_is_refused(value):
    problem = inputs.nonfinite_attribute(f'<mujoco><body name="b" pos="{value}"/></mujoco>')
    assert problem and "pos" in problem


def test_a_body_named_nan_is_a_name():
    assert inputs.nonfinite_attribute('<mujoco><body name="nan" pos="0 0 1"/></mujoco>') is None


def test_a_urdf_with_xacro_macros_is_refused(tmp_path, capsys):
    """MuJoCo reads a URDF with xacro elements, ignoring them: the robot it builds is not the
    one the file describes."""
    text = (Path(RABBIT).parent / "rabbit.urdf").read_text()
    i = text.index(">", text.index("<robot")) + 1
    f = tmp_path / "r.urdf"
    f.write_text(text[:i - 1] + ' xmlns:xacro="http://www.ros.org/wiki/xacro">\n  <xacro:property name="l" value="0.4"/>'
                 + text[i:])
    line = expect_usage_error(["optimize", "model", str(f), "--stance", "a", "--swing", "b"], capsys, needle="xacro")
    assert "r.urdf" in line


@pytest.mark.parametrize("kind", ["directory", "/dev/zero"])
def test_a_model_that_is_not_a_regular_file_says_what_it_is(kind, tmp_path, capsys):
    target = str(tmp_path) if kind == "directory" else kind
    line = expect_usage_error(["optimize", "model", target, "--stance", "a", "--swing", "b"], capsys)
    assert "no such file" not in line and ("directory" in line or "character device" in line), line


# ----------------------------------------------------------------------------- generated environments
_VALUE = st.one_of(st.text(max_size=30), st.sampled_from(["cpu", "cuda", "gpu,cpu", "tpu9", "--xla_x=1", "-x",
                                                          "0,1", "a,b", " 1 , 2 ", "\u0661", "/dev/null", ""]))


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(platforms=_VALUE, flags=_VALUE, ids=_VALUE)
def test_generated_jax_variables_pass_or_are_one_line_naming_them(platforms, flags, ids):
    """Any JAX_PLATFORMS, XLA_FLAGS, JAX_LOCAL_DEVICE_IDS: accepted, or UsageError in one line
    naming the variable (the XLA probe left out: a child process per example)."""
    from bipedlab.commands import UsageError
    from bipedlab.robustness import options

    env = {"JAX_PLATFORMS": platforms, "XLA_FLAGS": flags}
    try:
        environment.check(env, probe=False)
    except UsageError as e:
        name = str(e).split(":")[0]
        assert name in ("$JAX_PLATFORMS", "$XLA_FLAGS") and env[name[1:]] is not None, e
    try:
        options._check_device_ids({"JAX_LOCAL_DEVICE_IDS": ids})
    except UsageError as e:
        assert str(e).startswith("$JAX_LOCAL_DEVICE_IDS: "), e
    else:
        assert not ids.strip() or all(x.strip().isascii() and x.strip().isdigit() for x in ids.split(","))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(name=_NAME, under=st.sampled_from(["", "file", "missing/deeper"]))
def test_generated_cache_folders_are_used_or_one_line(name, under, tmp_path):
    from bipedlab.commands import UsageError

    (tmp_path / "file").write_text("x")
    path = os.path.join(str(tmp_path), under, name) if under else os.path.join(str(tmp_path), name)
    try:
        environment.check({"BIPEDLAB_CACHE_DIR": path}, probe=False)
    except UsageError as e:
        assert str(e).startswith("$BIPEDLAB_CACHE_DIR: ")
    else:
        assert os.path.isdir(path) and os.access(path, os.W_OK)


@pytest.mark.parametrize("encoding", ["BOM", "CRLF", "UTF-16"])
def test_a_published_report_reads_in_every_encoding(encoding, tmp_path):
    from bipedlab.report import check

    src = ROOT / "docs" / "report" / check.QUICK_FILE
    (tmp_path / check.QUICK_FILE).write_bytes(ENCODINGS[encoding](src.read_bytes()))
    assert check.load(tmp_path) == check.load(src.parent)


def test_the_flags_are_probed_after_the_command_modules_imported_jax(tmp_path):
    """``walk model`` imports JAX while its options are checked: XLA_FLAGS is still probed
    before a backend starts (a fresh process: this one has started its backend)."""
    gait = str(importlib.resources.files("bipedlab.robots.imported") / "data" / "rabbit_0.8.json")
    r = _bipedlab(["walk", "model", "rabbit.xml", "--gait", gait, "--steps", "1"],
                  env={"XLA_FLAGS": "--xla_bogus_flag=1"}, cwd=tmp_path)
    assert r.returncode == 2 and "$XLA_FLAGS" in _one_error_line(r.stderr), r.stderr[-3000:]
