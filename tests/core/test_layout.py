"""The package's structure as a contract: a core that names no robot, robots that use the core
and no other robot, no import cycle between folders, and one implementation of each shared
algorithm (RK4, event location, the closed loop)."""
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


def _imports(path: Path):
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                yield a.name
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            yield node.module
            for a in node.names:
                yield f"{node.module}.{a.name}"


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
