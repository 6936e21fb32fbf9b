"""The package's structure as a contract: a core that names no robot, robots that use the core
and no other robot, no import cycle between folders, no private name used outside its module,
robot command lines that hold no study data, and one implementation of each shared algorithm
(RK4, event location, the closed loop)."""
from __future__ import annotations

import ast
import itertools
import re
from pathlib import Path

import pytest

import bipedlab

PKG = Path(bipedlab.__file__).parent
CORE = ["mechanics", "contact", "sim", "control", "gait", "viz", "io", "report", "robustness"]
ROBOT_WORDS = re.compile(r"mabel|atrias|seven[_ -]?link|five[_ -]?link|compass|rabbit", re.I)


def _modules():
    for path in sorted(PKG.rglob("*.py")):
        rel = path.relative_to(PKG).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        yield "bipedlab." + ".".join(parts) if parts else "bipedlab", path


def _package_of(path: Path) -> str:
    """The package a module's relative imports start from (the module itself for an __init__)."""
    rel = path.relative_to(PKG)
    return ".".join(["bipedlab", *rel.parts[:-1]])


def _from_module(node: ast.ImportFrom, package: str) -> str:
    """The absolute module of ``from <module> import ...``, relative forms resolved."""
    if not node.level:
        return node.module
    base = package.split(".")
    base = base[:len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _imports(path: Path):
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                yield a.name
        elif isinstance(node, ast.ImportFrom):
            module = _from_module(node, _package_of(path))
            yield module
            for a in node.names:
                yield f"{module}.{a.name}"


def _unit(module: str) -> str | None:
    """The folder a module belongs to: a core folder, 'robots.<name>', or None (top level)."""
    parts = module.split(".")
    if len(parts) < 2 or parts[0] != "bipedlab":
        return None
    if parts[1] == "robots":
        return f"robots.{parts[2]}" if len(parts) > 2 else None
    return parts[1] if parts[1] in CORE else None


def _graph():
    g: dict[str, set[str]] = {}
    for mod, path in _modules():
        u = _unit(mod)
        if u is None:
            continue
        for imp in _imports(path):
            v = _unit(imp)
            if v is not None and v != u:
                g.setdefault(u, set()).add(v)
    return g


def test_core_imports_no_robot():
    offenders = [(mod, imp) for mod, path in _modules() if _unit(mod) in CORE
                 for imp in _imports(path) if imp.startswith("bipedlab.robots")]
    assert not offenders, offenders


def test_robots_import_no_other_robot():
    g = _graph()
    offenders = [(u, v) for u, vs in g.items() if u.startswith("robots.") for v in vs if v.startswith("robots.")]
    assert not offenders, offenders


def test_no_import_cycle_between_folders():
    g = _graph()
    nodes = set(g) | set(itertools.chain.from_iterable(g.values()))
    state: dict[str, int] = {}
    cycle: list[str] = []

    def visit(n, stack):
        state[n] = 1
        for m in g.get(n, ()):
            if state.get(m) == 1:
                cycle.extend(stack[stack.index(m):] + [m] if m in stack else [n, m])
                return True
            if state.get(m) is None and visit(m, stack + [m]):
                return True
        state[n] = 2
        return False

    for n in sorted(nodes):
        if state.get(n) is None and visit(n, [n]):
            break
    assert not cycle, " -> ".join(cycle)


def test_core_source_names_no_robot():
    """No robot's name in the core's code or docstrings (a robot lives in robots/<name>/)."""
    hits = []
    for mod, path in _modules():
        if _unit(mod) in CORE:
            for i, line in enumerate(path.read_text().splitlines(), 1):
                if ROBOT_WORDS.search(line):
                    hits.append(f"{path.relative_to(PKG)}:{i}: {line.strip()}")
    assert not hits, "\n".join(hits)


def _defs(name_pattern: str):
    pat = re.compile(name_pattern)
    out = []
    for mod, path in _modules():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and pat.fullmatch(node.name):
                out.append(f"{mod}.{node.name}")
    return out


RK4_COMBINATION = re.compile(r"k1\s*\+\s*2(\.0)?\s*\*\s*\(?k2")


@pytest.mark.parametrize("what", ["rk4 formula"])
def test_one_rk4(what):
    """The RK4 stage combination appears only in sim/integrators.py."""
    hits = [str(path.relative_to(PKG)) for _, path in _modules()
            if RK4_COMBINATION.search(path.read_text()) and path.name != "integrators.py"]
    assert not hits, hits


def test_one_event_locator():
    """Event-location methods are defined once, in sim/events.py."""
    locators = [d for d in _defs(r"(flow_to_event|regula_falsi|bisection|bisection_step|newton|secant|locate\w*)")
                if not d.startswith("bipedlab.sim.")]
    assert not locators, locators


#: robots whose controllers run at a sample rate: their loops are built on sim.loop
SAMPLED = ["five_link", "mabel", "atrias", "seven_link"]


@pytest.mark.parametrize("robot", SAMPLED)
def test_sampled_loops_are_the_core_loop(robot):
    """A robot with a sampled-data controller builds its closed loops from
    bipedlab.sim.loop (directly or through sim.rollout), and writes no loop driver of its
    own (a chunked runner outside a SampledLoop). Open-loop replays of recorded commands
    inside the identification's output-error fits are model evaluations, not closed loops."""
    users, own = [], []
    for mod, path in _modules():
        if not mod.startswith(f"bipedlab.robots.{robot}"):
            continue
        imps = set(_imports(path))
        if {"bipedlab.sim.loop", "bipedlab.sim.rollout", "bipedlab.sim.loop.SampledLoop"} & imps or any(
                i.startswith("bipedlab.sim.loop") or i.startswith("bipedlab.sim.rollout") for i in imps):
            users.append(mod)
        text = path.read_text()
        if re.search(r"def (make_runner|make_chunk|run_loop)\(", text) and "SampledLoop" not in text:
            own.append(mod)
    assert users, f"no module of robots/{robot} uses bipedlab.sim.loop"
    assert not own, own


def test_one_container_idiom():
    """Parameters and states are frozen dataclasses: no NamedTuple and no hand-written replace."""
    hits = []
    for mod, path in _modules():
        text = path.read_text()
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.ClassDef):
                bases = [ast.unparse(b) for b in node.bases]
                if any("NamedTuple" in b for b in bases):
                    hits.append(f"{mod}.{node.name}: NamedTuple")
                for item in node.body:
                    if isinstance(item, ast.FunctionDef) and item.name == "replace" and mod != "bipedlab.pytree":
                        hits.append(f"{mod}.{node.name}.replace")
    assert not hits, hits


#: the low-level event locators of bipedlab.sim.events, for the core's stages to call
LOW_LEVEL_LOCATORS = re.compile(r"regula_falsi\w*|bisection\w*|newton|first_on_grid|linear_crossing")
#: robot modules that still integrate, locate and reset by hand (not yet on bipedlab.sim.hybrid)
#: or loop with lax.while_loop for another reason; each entry is checked to still need it
HYBRID_EXEMPT: dict[str, str] = {}
#: drivers moved onto the core's hybrid step
HYBRID_PORTED = ["bipedlab.robots.mabel.walking.loop", "bipedlab.robots.atrias.slip_run",
                 "bipedlab.robots.mabel.walking.poincare", "bipedlab.robots.compass_gait.walker",
                 "bipedlab.robots.seven_link.contact"]


def _event_loop_uses(source: str) -> list[str]:
    """Calls (and imports) in ``source`` of the low-level locators of bipedlab.sim.events and of
    lax.while_loop, resolved through the module's import aliases (by AST, whatever the names)."""
    tree = ast.parse(source)
    alias: dict[str, str] = {}  # local name -> dotted name it stands for
    hits = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                alias[a.asname or a.name.split(".")[0]] = a.name if a.asname else a.name.split(".")[0]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            for a in node.names:
                full = f"{node.module}.{a.name}"
                alias[a.asname or a.name] = full
                if node.module == "bipedlab.sim.events" and LOW_LEVEL_LOCATORS.fullmatch(a.name):
                    hits.append(f"imports {full}")

    def dotted(f):
        parts = []
        while isinstance(f, ast.Attribute):
            parts.append(f.attr)
            f = f.value
        if not isinstance(f, ast.Name):
            return None
        return ".".join([alias.get(f.id, f.id)] + parts[::-1])

    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            name = dotted(node.func)
            if name is None:
                continue
            mod, _, fn = name.rpartition(".")
            if mod == "bipedlab.sim.events" and LOW_LEVEL_LOCATORS.fullmatch(fn):
                hits.append(f"calls {name}")
            elif name == "jax.lax.while_loop":
                hits.append(f"calls {name}")
    return hits


def test_event_loop_check_sees_aliases():
    """The structural check below finds the calls however they are imported."""
    src = ("import jax\nfrom jax import lax as L\nfrom jax.lax import while_loop as wl\n"
           "from bipedlab.sim import events as ev\nimport bipedlab.sim.events\n"
           "from bipedlab.sim.events import first_on_grid as fog\n"
           "def f():\n    jax.lax.while_loop(c, b, x); L.while_loop(c, b, x); wl(c, b, x)\n"
           "    ev.regula_falsi_with(g, 0, 1, 1, -1, 6); bipedlab.sim.events.bisection(p, 0, 1, 4); fog(v, t)\n"
           "    ev.flow_to_event(f, g, a, z, 0.1, 1.0); jax.lax.scan(b, x, None, length=3)\n")
    hits = _event_loop_uses(src)
    assert sorted(hits) == sorted(["imports bipedlab.sim.events.first_on_grid"] + ["calls jax.lax.while_loop"] * 3 + [
        "calls bipedlab.sim.events.regula_falsi_with", "calls bipedlab.sim.events.bisection",
        "calls bipedlab.sim.events.first_on_grid"]), hits


def test_robots_use_the_core_hybrid_step():
    """Robot packages locate events through the core's stages (bipedlab.sim.hybrid, or
    flow_to_event): no call of the low-level locators of sim.events and no event loop of their
    own (lax.while_loop), except the modules listed in HYBRID_EXEMPT - the work still to do,
    each of which must still need its exemption; the ported drivers use sim.hybrid."""
    found = {mod: _event_loop_uses(path.read_text()) for mod, path in _modules() if mod.startswith("bipedlab.robots.")}
    offenders = {m: h for m, h in found.items() if h and m not in HYBRID_EXEMPT}
    assert not offenders, offenders
    stale = [m for m in HYBRID_EXEMPT if not found.get(m)]
    assert not stale, f"no longer needs its exemption (remove it from HYBRID_EXEMPT): {stale}"
    paths = dict(_modules())
    unported = [m for m in HYBRID_PORTED if "bipedlab.sim.hybrid" not in set(_imports(paths[m]))]
    assert not unported, unported


def _private(name: str) -> bool:
    """A module's own name: one leading underscore, not a dunder."""
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _private_uses(source: str, module: str, package: str, modules) -> list[str]:
    """The private names of other bipedlab modules that ``source`` (the module ``module``, whose
    relative imports start at ``package``) imports or uses, by AST: ``from m import _x``
    (relative forms resolved), an import of a private module, and ``m._x`` / ``getattr(m, "_x")``
    where ``m`` is a bipedlab module reached through the module's imports, whatever their
    aliases (``import bipedlab.a.b``, ``from bipedlab.a import b as B``, ``from . import b``).
    ``modules`` holds the names of bipedlab's modules. A module's own names are its own; a
    package's ``__init__`` is a module like the others (it re-exports public names only)."""
    tree = ast.parse(source)
    alias: dict[str, str] = {}  # local name -> dotted name it stands for
    hits = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                alias[a.asname or a.name.split(".")[0]] = a.name if a.asname else a.name.split(".")[0]
                parts = a.name.split(".")
                if parts[0] == "bipedlab" and any(_private(p) for p in parts):
                    hits.append(f"imports {a.name}")
        elif isinstance(node, ast.ImportFrom):
            src = _from_module(node, package)
            for a in node.names:
                if a.name == "*":
                    continue
                alias[a.asname or a.name] = f"{src}.{a.name}"
                if src in modules and src != module and _private(a.name):
                    hits.append(f"imports {src}.{a.name}")

    def dotted(f):
        parts = []
        while isinstance(f, ast.Attribute):
            parts.append(f.attr)
            f = f.value
        if not isinstance(f, ast.Name) or f.id not in alias:
            return None
        return ".".join([alias[f.id]] + parts[::-1])

    def foreign(owner) -> bool:
        return owner in modules and owner != module

    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and _private(node.attr) and foreign(dotted(node.value)):
            hits.append(f"uses {dotted(node.value)}.{node.attr}")
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "getattr"
              and len(node.args) >= 2 and isinstance(node.args[1], ast.Constant)
              and isinstance(node.args[1].value, str) and _private(node.args[1].value)
              and foreign(dotted(node.args[0]))):
            hits.append(f"uses {dotted(node.args[0])}.{node.args[1].value}")
    return hits


def test_private_check_sees_aliases():
    """The check below finds private names however the module is reached, and leaves public
    names, dunders, a module's own names and other libraries' names alone."""
    modules = {"bipedlab", "bipedlab.cli", "bipedlab.gait", "bipedlab.gait.study", "bipedlab.gait.walking",
               "bipedlab.robots.r", "bipedlab.robots.r.a", "bipedlab.robots.r.b"}
    src = ("import os\nimport bipedlab.gait.study\nimport bipedlab.gait.walking as gw\n"
           "from bipedlab import cli\nfrom bipedlab.gait import study as st\n"
           "from bipedlab.gait.study import _design, design\nfrom . import b\nfrom .b import _helper as h\n"
           "from . import _secret\nfrom bipedlab.robots.r.a import _mine\n"
           "def f():\n    from bipedlab.gait import walking\n"
           "    cli._enable_compile_cache(); st._design_from_record(r); gw._step(x); walking._step(x)\n"
           "    bipedlab.gait.study._grid; b._table[0]; getattr(st, '_hidden')\n"
           "    os._exit(0); st.__name__; st.design(); b.public(); _own(); getattr(st, 'design')\n")
    hits = _private_uses(src, "bipedlab.robots.r.a", "bipedlab.robots.r", modules)
    assert sorted(hits) == sorted([
        "imports bipedlab.gait.study._design", "imports bipedlab.robots.r.b._helper",
        "imports bipedlab.robots.r._secret",
        "uses bipedlab.cli._enable_compile_cache", "uses bipedlab.gait.study._design_from_record",
        "uses bipedlab.gait.walking._step", "uses bipedlab.gait.walking._step",
        "uses bipedlab.gait.study._grid", "uses bipedlab.robots.r.b._table",
        "uses bipedlab.gait.study._hidden"]), hits
    init = "from bipedlab.gait.walking import _step, step\nfrom .study import _design\n"
    assert sorted(_private_uses(init, "bipedlab.gait", "bipedlab.gait", modules)) == [
        "imports bipedlab.gait.study._design", "imports bipedlab.gait.walking._step"]


def test_no_private_name_crosses_modules():
    """No module of bipedlab - core, robots and the top-level modules (cli, commands, registry,
    bench, ...) alike - imports or uses another module's private name (one leading underscore):
    what two modules share is public in its home."""
    mods = dict(_modules())
    hits = [f"{mod}: {h}" for mod, path in mods.items()
            for h in _private_uses(path.read_text(), mod, _package_of(path), set(mods))]
    assert not hits, "\n".join(sorted(set(hits)))


def test_private_check_covers_every_module():
    """The check above reads every module under src/bipedlab, the top-level ones included."""
    mods = dict(_modules())
    assert len(mods) == len(list(PKG.rglob("*.py")))
    top = {m for m in mods if m.count(".") == 1}
    assert {"bipedlab.cli", "bipedlab.commands", "bipedlab.registry", "bipedlab.bench"} <= top, top


def _data_literals(source: str) -> list[str]:
    """Module-level assignments in ``source`` whose value is a literal container (list, tuple,
    set or dict display, nested or not) holding a number: data, not command-line plumbing."""
    def numbers(node) -> bool:
        return any(isinstance(n, ast.Constant) and isinstance(n.value, (int, float, complex))
                   and not isinstance(n.value, bool) for n in ast.walk(node))

    hits = []
    for node in ast.parse(source).body:
        if isinstance(node, (ast.Assign, ast.AnnAssign)) and node.value is not None:
            value = node.value
            if isinstance(value, (ast.List, ast.Tuple, ast.Set, ast.Dict)) and numbers(value):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                hits.append(f"{node.lineno}: {', '.join(ast.unparse(t) for t in targets)}")
    return hits


def test_data_literal_check():
    src = ("X = float_in(0.0, 1.0)\nNAMES = ['a', 'b']\nFALLS = {'push': (0.2, 0.9)}\n"
           "T: tuple = (1, 2)\nFLAGS = (True, False)\nCOMMANDS = [Command('w', 'r', 'h', f, g, bench=((),))]\n"
           "def f():\n    return {'x': 1.0}\n")
    assert _data_literals(src) == ["3: FALLS", "4: T"]


def test_robot_command_lines_hold_no_study_data():
    """A robot's command line parses, calls its studies and prints: measured or declared study
    data (module-level literals of numbers: falls, pushes, tables) live in the robot's study or
    catalog modules, which the command line imports."""
    hits = [f"{mod}:{h}" for mod, path in _modules()
            if mod.startswith("bipedlab.robots.") and path.name == "cli.py" for h in _data_literals(path.read_text())]
    assert not hits, hits
