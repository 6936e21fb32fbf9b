"""The documentation runs: the site builds with ``mkdocs build --strict`` (warnings are errors:
a docstring mkdocstrings cannot render, a page missing from the navigation, a broken link),
and every Python and shell code block of README.md and docs/**/*.md is executed.

* Fenced blocks tagged ``python`` run in this process, page by page, in order, in one
  namespace per page (a page reads like a notebook: a later block uses the names an earlier
  one defined), in a fresh working folder. Tracebacks name the page and its line.
* Blocks tagged ``bash``, ``sh`` or ``shell`` run as one bash script each (``set -euo
  pipefail``, so every ``bipedlab ...`` line must exit with status 0), ``console`` blocks run
  their ``$ `` lines; the working folder is a fresh one that looks like the repository root
  (``src`` links to the checkout's), so paths written "from the repository root" resolve and
  nothing is written into the checkout.
* Untagged blocks are not code (command output, file formats, folder trees) and are not run.
* A block preceded by ``<!-- docs: skip (REASON) -->`` is not run; the list stays short
  (:data:`MAX_SKIPS`) and every skip gives its reason.
* :data:`SUBSTITUTIONS` maps text of a block to what the test runs instead, each with its
  reason. A few are needed by every run (no installs, a free port). The others keep the
  default run short: an example whose cost is compilation, whatever its size (a gait design,
  a Poincaré analysis, MABEL's loops, a whole paper), is checked without being run - a
  command's arguments by ``bipedlab.registry.parse`` (the command's own parser and
  validation: bad input, a missing gait file, a combination that means nothing are refused
  exactly as the command refuses them, and nothing runs), a Python call's arguments against
  the function's signature - and a command whose Python twin on the same page already ran is
  only checked the same way. An edit of such an example no longer matches its entry, so the
  example then runs in full and the table's own test fails until the entry is updated. The
  tests marked ``slow`` run every such block as written
  (``python -m pytest -m slow -p no:xdist -o addopts= tests/test_docs.py``, about 25 min on
  two cores).
"""
from __future__ import annotations

import contextlib
import dataclasses
import inspect
import io
import os
import re
import socket
import subprocess
import sys
import types
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = ["README.md"] + sorted(p.relative_to(ROOT).as_posix() for p in (ROOT / "docs").rglob("*.md"))
PYTHON_TAGS = {"python", "py"}
SHELL_TAGS = {"bash", "sh", "shell", "console"}
SKIP_MARK = re.compile(r"^<!--\s*docs:\s*skip\s*\((?P<reason>[^)]+)\)\s*-->$")
#: at most this many blocks may be skipped (installs, a cluster script)
MAX_SKIPS = 4
#: a shell block may run this long in the default run before it fails, s
SHELL_TIMEOUT = 900


@dataclasses.dataclass(frozen=True)
class Block:
    page: str
    line: int  # line of the block's first line of code, 1-based
    lang: str
    code: str
    skip: str | None  # the skip marker's reason, or None

    @property
    def name(self) -> str:
        return f"{self.page}:{self.line}"


_FENCE = re.compile(r"^(?P<indent>[ \t]*)(?P<fence>`{3,}|~{3,})(?P<info>[^`]*)$")


def blocks(page: str) -> list[Block]:
    """The fenced code blocks of a page (indented ones in lists included, dedented)."""
    lines = (ROOT / page).read_text(encoding="utf-8").splitlines()
    out, i = [], 0
    while i < len(lines):
        m = _FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        indent, fence = m.group("indent"), m.group("fence")
        lang = (m.group("info").strip().split() or [""])[0].lower()
        end = re.compile(rf"^{re.escape(indent)}{re.escape(fence[0])}{{{len(fence)},}}\s*$")
        j = i + 1
        while j < len(lines) and not end.match(lines[j]):
            j += 1
        code = "\n".join(ln[len(indent):] if ln.startswith(indent) else ln.lstrip() for ln in lines[i + 1:j])
        k = i - 1
        while k >= 0 and not lines[k].strip():
            k -= 1
        mark = SKIP_MARK.match(lines[k].strip()) if k >= 0 else None
        out.append(Block(page, i + 2, lang, code + "\n", mark.group("reason").strip() if mark else None))
        i = j + 1
    return out


def _runnable(tags) -> list[Block]:
    return [b for p in PAGES for b in blocks(p) if b.lang in tags]


@dataclasses.dataclass(frozen=True)
class Sub:
    """In ``page``, the text ``old`` (exactly once in the page's code blocks) runs as ``new``.
    ``full``: also in the slow, full run (a substitution every run needs, not a shortening)."""

    page: str
    old: str
    new: str
    why: str
    full: bool = False


#: shell: a command replaced by its argument check (bipedlab.registry.parse: the command's own
#: parser and validation, nothing run)
PARSE_ONLY = "bipedlab_parse_only"
_SHIPPED_FIVE_LINK = "src/bipedlab/robots/five_link/data/five_link_0.8.json"
_SHIPPED_RABBIT = "src/bipedlab/robots/imported/data/rabbit_0.8.json"

SUBSTITUTIONS = [
    # ----- README.md -----------------------------------------------------------------------
    Sub("README.md",
        'logs = sysid.generate(truth, sysid.Sensors(noise=1.0))\n'
        'ident = sysid.identify(logs)                         # ident.params: a MabelParams of estimates\n'
        'table = sysid.compare(truth, ident)                  # true / estimate / rel_error per parameter\n'
        'sysid.write_logs(logs, "logs/"); again = sysid.identify(sysid.read_logs("logs/"))\n',
        '_bind(sysid.generate, truth, sysid.Sensors(noise=1.0))\n'
        '_bind(sysid.identify, [])\n'
        '_bind(sysid.compare, truth, None)\n'
        '_bind(sysid.write_logs, [], "logs/"); _bind(sysid.read_logs, "logs/")\n',
        "the identification compiles and fits for minutes, even on the reduced design of "
        "`identify mabel --synthetic --quick`"),
    Sub("README.md", "u = hzd.io_linearizing(vc, st, z_star, eps=0.1)", "_bind(hzd.io_linearizing, vc, st, z_star, eps=0.1)",
        "evaluated op by op it takes several seconds; docs/guides/design-a-gait.md walks the same "
        "gait under this controller, compiled"),
    Sub("README.md", "J = walking.poincare_jacobian(vc, st, ctrl, z_star)",
        "_bind(walking.poincare_jacobian, vc, st, ctrl, z_star)",
        "the Jacobian through the hybrid flow compiles for about 40 s"),
    Sub("README.md", "steps = walking.walk(vc, st, ctrl, z_star, 20)",
        "_bind(walking.walk, vc, st, ctrl, z_star, 20)",
        "the walk compiles for over 10 s whatever the number of steps; "
        "docs/guides/design-a-gait.md walks the same gait"),
    Sub("README.md", "run = hop.run_hops(100)", "_bind(hop.run_hops, 100)",
        "the 13-DoF hopping loop compiles for about 10 s whatever the number of hops"),
    Sub("README.md", 'design, info = md.optimize(0.8, "torque")', '_bind(md.optimize, 0.8, "torque")',
        "MABEL's compliant-HZD design compiles for minutes"),
    Sub("README.md", 'r = wm.walk("nominal", "pdff", steps=20)', '_bind(wm.walk, "nominal", "pdff", steps=20)',
        "MABEL's 1 kHz walking loop compiles for minutes"),
    Sub("README.md", "  JAX_PLATFORMS=cpu bipedlab robustness five-link --trials 256 --devices 1 \\",
        "  JAX_PLATFORMS=cpu bipedlab_parse_only robustness five-link --trials 256 --devices 1 \\",
        "two processes that each compile the walk take about 20 s; tests/test_robustness_five_link.py "
        "runs two processes against one"),
    Sub("README.md", "--coordinator 127.0.0.1:12345", "--coordinator 127.0.0.1:{port}",
        "a free port: other tests may be running on this machine", full=True),
    Sub("README.md", "done; wait", 'done; for p in $(jobs -p); do wait "$p"; done',
        "a bare `wait` returns 0 whatever the processes ended with; the test waits on each", full=True),
    Sub("README.md", "pip install '.[mujoco]'    # once: MuJoCo reads the file", ":",
        "the environment under test is installed already (the test extra has MuJoCo); "
        "installing again would reach the network", full=True),
    Sub("README.md", "bipedlab optimize model $F --stance left_foot --swing right_foot --speed 0.8 --save rabbit.json",
        "bipedlab_parse_only optimize model $F --stance left_foot --swing right_foot --speed 0.8 --save rabbit.json"
        f" && cp {_SHIPPED_RABBIT} rabbit.json",
        "the design compiles for over a minute; the shipped rabbit_0.8.json is what this command "
        "writes (tests/robots/imported checks the design against it)"),
    Sub("README.md", "bipedlab walk model $F --gait rabbit.json --steps 50",
        "bipedlab_parse_only walk model $F --gait rabbit.json --steps 50",
        "the walk's Poincaré analysis compiles for about a minute whatever the number of steps"),
    Sub("README.md", "bipedlab robustness model $F --gait rabbit.json --trials 64 --out rabbit-pushes",
        "bipedlab_parse_only robustness model $F --gait rabbit.json --trials 64 --out rabbit-pushes",
        "the push trial compiles for about 20 s whatever the number of trials"),
    # ----- docs/guides ---------------------------------------------------------------------
    Sub("docs/guides/design-a-gait.md",
        "res = go.solve(prob, study.initial_guess(prob))\n"
        "assert res.success and res.max_eq_violation < 1e-8\n"
        "cost, eq, ineq, gait = go.evaluator(prob)(jnp.asarray(res.x))    # the solution's metrics\n"
        'print(gait["speed"], gait["step_length"], gait["cmt"])              # m/s, m, -\n'
        'gaitfile.save("gait.json", "five_link", gait["vc"], gait["z_minus"], dict(speed_mps=0.8, cost="torque"))\n',
        "_bind(go.solve, prob, study.initial_guess(prob))\n"
        f'import shutil; shutil.copy(_DOCS_ROOT / "{_SHIPPED_FIVE_LINK}", "gait.json")\n',
        "the design compiles for about a minute; the shipped five_link_0.8.json is this design "
        "(the same solver from the same guess, to 1e-13)"),
    Sub("docs/guides/design-a-gait.md", "rho = walking.restricted_eigenvalue(vc, st, vc.c @ z_star[st.n:])",
        "_bind(walking.restricted_eigenvalue, vc, st, vc.c @ z_star[st.n:])\n"
        'import json; rho = json.load(open("gait.json"))["payload"]["design"]["restricted_eigenvalue"]',
        "the restricted map's derivative compiles for over 10 s; the shipped gait file records "
        "its value (computed the same way by `optimize five-link`)"),
    Sub("docs/guides/design-a-gait.md", "bipedlab optimize five-link --speed 0.8 --save gait.json",
        f"bipedlab_parse_only optimize five-link --speed 0.8 --save gait.json && cp {_SHIPPED_FIVE_LINK} gait.json",
        "the design and its Poincaré analysis compile for over a minute; the shipped gait is what "
        "it writes"),
    Sub("docs/guides/design-a-gait.md", "bipedlab walk five-link --gait gait.json --steps 10 --perturb 0.01",
        "bipedlab_parse_only walk five-link --gait gait.json --steps 10 --perturb 0.01",
        "the walk's Poincaré analysis compiles for about a minute whatever the number of steps"),
    Sub("docs/guides/design-a-gait.md", "bipedlab walk compass-gait --slope 3 --steps 10 --perturb 0.02",
        "bipedlab_parse_only walk compass-gait --slope 3 --steps 10 --perturb 0.02",
        "each run starts an interpreter and loads the compiled walk (about 5 s); the Python above "
        "finds the same gait and README.md runs this command"),
    Sub("docs/guides/model-a-robot.md", "bipedlab walk compass-gait --slope 3 --steps 5",
        "bipedlab_parse_only walk compass-gait --slope 3 --steps 5",
        "each run starts an interpreter and loads the compiled walk (about 5 s); README.md runs "
        "this command"),
    Sub("docs/guides/import-a-file.md",
        "bipedlab optimize model rabbit.xml --stance left_foot --swing right_foot --speed 0.8 --save rabbit.json",
        "bipedlab_parse_only optimize model rabbit.xml --stance left_foot --swing right_foot --speed 0.8 "
        f"--save rabbit.json && cp {_SHIPPED_RABBIT} rabbit.json",
        "the design compiles for over a minute; the shipped rabbit_0.8.json is what it writes"),
    Sub("docs/guides/import-a-file.md", "bipedlab walk model rabbit.xml --gait rabbit.json --steps 20",
        "bipedlab_parse_only walk model rabbit.xml --gait rabbit.json --steps 20",
        "the walk's Poincaré analysis compiles for about a minute whatever the number of steps"),
    Sub("docs/guides/closed-loop.md", "bipedlab hop mabel --hops 3 --no-poincare",
        "bipedlab_parse_only hop mabel --hops 3 --no-poincare",
        "the 13-DoF hopping loop compiles for about 10 s whatever the number of hops"),
    Sub("docs/guides/robustness.md", "bipedlab robustness five-link --trials 16 --steps 2 --json --out five-link-atlas",
        "bipedlab_parse_only robustness five-link --trials 16 --steps 2 --json --out five-link-atlas",
        "the five-link trial compiles for about 15 s whatever the number of trials; the guide's "
        "Python runs the same engine, and tests/test_robustness_five_link.py this command"),
    Sub("docs/guides/reproduce-a-paper.md", "bipedlab experiment seven-link free-swing --json",
        "bipedlab_parse_only experiment seven-link free-swing --json",
        "the Python above runs the same experiment in-process; starting the command costs about 5 s"),
    Sub("docs/guides/reproduce-a-paper.md", "bipedlab reproduce seven-link --quick --out report",
        "bipedlab_parse_only reproduce seven-link --quick --out report",
        "the paper's three walks compile for several minutes even in --quick"),
]


def _substituted(block: Block, full: bool) -> str:
    code = block.code
    for s in SUBSTITUTIONS:
        if s.page == block.page and s.old in code and (s.full or not full):
            code = code.replace(s.old, s.new)
    return code


def _has_default_only_subs(block: Block) -> bool:
    return any(s.page == block.page and s.old in block.code and not s.full for s in SUBSTITUTIONS)


def _bind(f, *args, **kwargs):
    """A call checked and not made: ``f`` exists and takes these arguments."""
    assert callable(f), f
    inspect.signature(f).bind(*args, **kwargs)


# ----- the tests of the tests' own bookkeeping ----------------------------------------------

def test_every_substitution_matches_exactly_one_place():
    code = {p: [b.code for b in blocks(p) if b.lang in PYTHON_TAGS | SHELL_TAGS] for p in PAGES}
    for s in SUBSTITUTIONS:
        assert s.page in code, f"{s.page}: no such page"
        hits = sum(c.count(s.old) for c in code[s.page])
        assert hits == 1, f"{s.page}: {s.old!r} is in its code blocks {hits} times, not once (a stale entry?)"
        assert s.why, s


def test_skips_are_few_and_explained():
    skipped = [b for p in PAGES for b in blocks(p) if b.skip is not None]
    assert len(skipped) <= MAX_SKIPS, [b.name for b in skipped]
    for b in skipped:
        assert b.lang in PYTHON_TAGS | SHELL_TAGS, f"{b.name}: a skip marker before a block that would not run"
        assert len(b.skip) >= 8, f"{b.name}: say why the block is skipped"


def test_the_parser_finds_the_blocks(tmp_path, monkeypatch):
    page = tmp_path / "page.md"
    page.write_text("text\n\n```python\nx = 1\n```\n\n<!-- docs: skip (installs) -->\n```bash\npip install x\n```\n"
                    "\n1. item\n\n   ```sh\n   bipedlab walk\n   ```\n\n```\nplain\n```\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    got = [(b.line, b.lang, b.code, b.skip) for b in blocks("page.md")]
    assert got == [(4, "python", "x = 1\n", None), (9, "bash", "pip install x\n", "installs"),
                   (15, "sh", "bipedlab walk\n", None), (19, "", "plain\n", None)]


def test_every_page_has_code_that_runs():
    for p in PAGES:
        if p.startswith("docs/guides/"):
            langs = {b.lang for b in blocks(p) if b.skip is None}
            assert langs & PYTHON_TAGS and langs & SHELL_TAGS, f"{p}: a guide needs Python and shell examples"


# ----- the site --------------------------------------------------------------------------

def test_mkdocs_build_strict(tmp_path):
    pytest.importorskip("mkdocs")
    pytest.importorskip("mkdocstrings_handlers.python")
    # not --quiet: it hides the warnings from --strict, which then lets them pass
    r = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(ROOT / "mkdocs.yml"),
                        "-d", str(tmp_path / "site")], capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert r.returncode == 0 and "WARNING" not in r.stderr, r.stdout + r.stderr
    site = tmp_path / "site"
    api = (site / "reference" / "mechanics" / "index.html").read_text(encoding="utf-8")
    assert 'id="bipedlab.mechanics.dynamics.mass_matrix"' in api  # rendered from the docstrings
    for guide in (ROOT / "docs" / "guides").glob("*.md"):
        assert (site / "guides" / guide.stem / "index.html").is_file(), guide.name


# ----- the code blocks -------------------------------------------------------------------

def _run_python_page(page: str, full: bool, workdir: Path) -> None:
    todo = [b for b in blocks(page) if b.lang in PYTHON_TAGS and b.skip is None]
    assert todo, f"{page}: no Python blocks"
    # the page's namespace is a module's, so that classes defined on the page (dataclasses,
    # pytrees) find their module
    name = "docs_page_" + re.sub(r"\W", "_", page)
    module = types.ModuleType(name)
    module.__dict__.update(_bind=_bind, _DOCS_ROOT=ROOT)  # what the substitutions use, nothing else
    ns = module.__dict__
    sys.modules[name] = module
    cwd = os.getcwd()
    os.chdir(workdir)
    try:
        for b in todo:
            code = _substituted(b, full)
            # pad with blank lines so a traceback names the line of the page
            program = compile("\n" * (b.line - 1) + code, str(ROOT / page), "exec")
            with contextlib.redirect_stdout(io.StringIO()):
                exec(program, ns)
    finally:
        os.chdir(cwd)
        sys.modules.pop(name, None)


def _shell_workdir(tmp_path: Path) -> Path:
    work = tmp_path / "root"
    work.mkdir()
    (work / "src").symlink_to(ROOT / "src", target_is_directory=True)
    return work


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _check_arguments(argv: list[str]) -> None:
    """What ``bipedlab ARGV`` does before any work: parse and validate (the command line's own
    :func:`bipedlab.registry.parse`, which runs nothing)."""
    from bipedlab.registry import parse

    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            parse(argv)
    except SystemExit as e:
        raise AssertionError(f"bipedlab {' '.join(argv)}: refused (status {e.code}): {err.getvalue().strip()}")


def _run_shell(block: Block, full: bool, workdir: Path) -> None:
    code = _substituted(block, full)
    if block.lang == "console":
        code = "\n".join(ln[2:] for ln in code.splitlines() if ln.startswith("$ ")) + "\n"
    code = code.replace("{port}", str(_free_port()))
    # a command checked without being run leaves its arguments (NUL-separated, one file per
    # call) for bipedlab.registry.parse in this process (no interpreter to start per call)
    calls = workdir.parent / "parse-only"
    calls.mkdir()
    script = ("set -euo pipefail\n"
              f'{PARSE_ONLY}() {{ printf "%s\\0" "$@" > "$(mktemp "$DOCS_PARSE_ONLY/XXXXXX")"; }}\n'
              + code)
    env = dict(os.environ, DOCS_PARSE_ONLY=str(calls), MPLBACKEND="Agg",
               PATH=os.path.dirname(sys.executable) + os.pathsep + os.environ.get("PATH", ""))
    r = subprocess.run(["bash", "-c", script], cwd=workdir, env=env, capture_output=True, text=True,
                       timeout=SHELL_TIMEOUT)
    assert r.returncode == 0, (f"{block.name}: exit status {r.returncode}\n--- ran:\n{code}\n--- stdout:\n"
                               f"{r.stdout[-3000:]}\n--- stderr:\n{r.stderr[-3000:]}")
    recorded = sorted(calls.iterdir())
    assert len(recorded) >= code.count(PARSE_ONLY), f"{block.name}: a checked command was not reached"
    cwd = os.getcwd()
    os.chdir(workdir)  # the files the block made (a gait) are checked where it made them
    try:
        for f in recorded:
            _check_arguments(f.read_text().split("\0")[:-1])
    finally:
        os.chdir(cwd)


PYTHON_PAGES = [p for p in PAGES if any(b.lang in PYTHON_TAGS and b.skip is None for b in blocks(p))]
SHELL_BLOCKS = [b for b in _runnable(SHELL_TAGS) if b.skip is None]


@pytest.mark.parametrize("page", PYTHON_PAGES)
def test_python_blocks(page, tmp_path):
    _run_python_page(page, False, tmp_path)


@pytest.mark.parametrize("block", SHELL_BLOCKS, ids=lambda b: b.name)
def test_shell_block(block, tmp_path):
    _run_shell(block, False, _shell_workdir(tmp_path))


@pytest.mark.slow
@pytest.mark.parametrize("page", [p for p in PYTHON_PAGES if any(
    _has_default_only_subs(b) for b in blocks(p) if b.lang in PYTHON_TAGS)])
def test_python_blocks_full(page, tmp_path):
    _run_python_page(page, True, tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("block", [b for b in SHELL_BLOCKS if _has_default_only_subs(b)], ids=lambda b: b.name)
def test_shell_block_full(block, tmp_path):
    _run_shell(block, True, _shell_workdir(tmp_path))
