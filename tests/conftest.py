"""Shared fixtures for the bipedlab test suite; puts tests/ on sys.path for the helper modules
(helpers.py, oracles.py, trees.py)."""
from __future__ import annotations

import os
import sys

import pytest

sys.path.insert(0, os.path.dirname(__file__))

import bipedlab  # noqa: E402,F401  (enables float64)
import jax  # noqa: E402

assert jax.config.jax_enable_x64, "importing bipedlab must enable float64"


def _shared_compile_cache() -> None:
    """One persistent JAX compilation cache for the whole run: the test processes (pytest-xdist
    workers) and the commands they start as subprocesses (through BIPEDLAB_CACHE_DIR) compile
    each program once. A fresh folder per run, so no result depends on an earlier run; tests
    that need a cold cache of their own set BIPEDLAB_XLA_CACHE_DIR."""
    import tempfile

    path = os.environ.get("BIPEDLAB_TEST_XLA_CACHE")
    if not path:
        path = tempfile.mkdtemp(prefix="bipedlab-test-xla-")
        os.environ["BIPEDLAB_TEST_XLA_CACHE"] = path  # inherited by the xdist workers
        _created.append(path)
    os.environ.setdefault("BIPEDLAB_CACHE_DIR", path)
    # compiled programs are shared even by the tests that keep their results apart (their own
    # BIPEDLAB_CACHE_DIR: reproduce's stored records); a test that needs a cold compilation
    # cache sets BIPEDLAB_XLA_CACHE_DIR too
    os.environ["BIPEDLAB_XLA_CACHE_DIR"] = path
    from bipedlab import compilecache

    compilecache.enable(path)


def _compile_for_tests() -> None:
    """The suite compiles with JAX's ``jax_disable_most_optimizations`` (XLA's backend at
    optimisation level 0, its expensive LLVM passes off): the same programs, computing the same
    arithmetic, compiled in less time and run somewhat slower, which a suite that spends most of
    its time compiling gains from. Inherited by the commands tests start as subprocesses.
    Modules marked ``optimized`` (their time goes to running long simulations, not to compiling)
    compile as a user's run does; BIPEDLAB_TEST_OPTIMIZE=1 compiles everything so."""
    if os.environ.get("BIPEDLAB_TEST_OPTIMIZE") == "1":
        return
    _set_optimized(False)


def _set_optimized(on: bool) -> None:
    os.environ["JAX_DISABLE_MOST_OPTIMIZATIONS"] = "0" if on else "1"
    jax.config.update("jax_disable_most_optimizations", not on)


@pytest.fixture(autouse=True, scope="module")
def _compile_mode(request):
    """A module marked ``optimized`` compiles (and starts its subprocesses) with XLA's
    optimisations; the others as the suite does (:func:`_compile_for_tests`)."""
    if os.environ.get("BIPEDLAB_TEST_OPTIMIZE") == "1" or request.node.get_closest_marker("optimized") is None:
        yield
        return
    _set_optimized(True)
    try:
        yield
    finally:
        _set_optimized(False)


_created: list = []
_compile_for_tests()
_shared_compile_cache()


def _hypothesis_profiles() -> str:
    """The property tests' draws: on CI (CI set) derandomised, every example a function of the
    test's own source, so one commit gets one verdict; locally random, with the example
    database in .hypothesis/ kept between runs, so a failure found once is replayed first
    until it is fixed. Either way a failure prints the blob that replays it. HYPOTHESIS_PROFILE
    picks one by name (``ci`` replays CI's draws on a desk)."""
    from hypothesis import settings

    settings.register_profile("ci", derandomize=True, database=None, print_blob=True)
    settings.register_profile("dev", print_blob=True)
    name = os.environ.get("HYPOTHESIS_PROFILE") or ("ci" if os.environ.get("CI") else "dev")
    settings.load_profile(name)
    return name


_HYPOTHESIS_PROFILE = _hypothesis_profiles()


def pytest_report_header(config):
    if _HYPOTHESIS_PROFILE == "ci":
        how = "derandomised draws (the same examples on every run of this commit)"
    else:
        how = "random draws; failing examples kept in .hypothesis/ and replayed first"
    return [f"property tests: hypothesis profile '{_HYPOTHESIS_PROFILE}', {how}; a failure prints "
            "'@reproduce_failure(...)' to replay it, HYPOTHESIS_PROFILE=ci replays CI's draws"]


def pytest_unconfigure(config):
    import shutil

    for path in _created:  # only the process that made the folder removes it
        shutil.rmtree(path, ignore_errors=True)


# ----- longest modules first ----------------------------------------------------------------
#: The test modules that take longest (seconds of setup + calls + teardown summed per module
#: from ``--junitxml``, one default-tier run on an idle two-core Intel Xeon at commit 284ef60;
#: 1,124 s in all, these 45 modules 1,002 s of it).
#: The workers take modules in collection order (--dist loadfile with --no-loadscope-reorder:
#: without it pytest-xdist >= 3.8 orders the modules by their number of tests, and the longest
#: module could start last while the other worker idled, 75 s at 284ef60), so these go first
#: and the short ones fill the end.
LONGEST_FIRST = (
    "robots/imported/test_stable_by_design.py",           # 70 s
    "robots/mabel/sysid/test_sysid_cli.py",               # 62 s
    "test_docs.py",                                       # 55 s
    "robots/seven_link/test_walk_seven_link.py",          # 45 s
    "core/sim/test_gradients.py",                         # 38 s
    "test_robustness_resume.py",                          # 37 s
    "robots/atrias/test_atrias_controller.py",            # 36 s
    "robots/five_link/test_five_link_gait.py",            # 33 s
    "robots/mabel/test_mabel_model.py",                   # 31 s
    "robots/mabel/test_mabel_full_plant.py",              # 30 s
    "robots/seven_link/test_seven_link_boom.py",          # 28 s
    "robots/five_link/test_five_link_cli.py",             # 27 s
    "test_reproduce_resume.py",                           # 27 s
    "robots/mabel/test_hop_mabel.py",                     # 25 s
    "test_cli.py",                                        # 25 s
    "robots/atrias/test_atrias_shared_program.py",        # 20 s
    "robots/mabel/test_mabel_walking_controllers.py",     # 20 s
    "test_reproduce_browser.py",                          # 19 s
    "robots/mabel/test_mabel_vc_and_zd.py",               # 19 s
    "core/contact/test_rigid.py",                         # 16 s
    "core/mechanics/test_stance.py",                      # 16 s
    "robots/mabel/sysid/test_sysid_legs.py",              # 15 s
    "golden/test_golden_loops.py",                        # 15 s
    "core/control/test_hzd.py",                           # 15 s
    "core/robustness/test_chunks.py",                     # 15 s
    "robots/atrias/test_run_atrias_fidelity.py",          # 15 s
    "golden/test_golden_cli.py",                          # 15 s
    "core/mechanics/test_kinematics.py",                  # 14 s
    "robots/mabel/test_mabel_fidelity.py",                # 14 s
    "test_studybench.py",                                 # 14 s
    "robots/mabel/test_mabel_paper_design.py",            # 13 s
    "core/mechanics/test_tree_dynamics.py",               # 13 s
    "robots/mabel/test_walk_mabel_cli.py",                # 11 s
    "core/sim/test_hybrid.py",                            # 11 s
    "core/mechanics/test_coupled.py",                     # 10 s
    "robots/atrias/test_run_atrias.py",                   # 10 s
    "core/control/test_bezier.py",                        # 10 s
    "core/sim/test_integrators.py",                       # 10 s
    "core/mechanics/test_array_kernel.py",                # 10 s
    "robots/imported/test_rabbit_gait.py",                # 10 s
    "robots/seven_link/test_seven_link_controller.py",    # 9 s
    "core/gait/test_one_program_per_loop.py",             # 9 s
    "robots/mabel/test_mabel_walk_one_program.py",        # 9 s
    "robots/mabel/test_mabel_walking.py",                 # 9 s
    "test_cli_reliability.py",                            # 8 s
)


def _module_rank(item) -> int:
    rel = os.path.relpath(str(item.fspath), os.path.dirname(__file__)).replace(os.sep, "/")
    return LONGEST_FIRST.index(rel) if rel in LONGEST_FIRST else len(LONGEST_FIRST)


def pytest_collection_modifyitems(session, config, items):
    """The modules of LONGEST_FIRST first, in its order; every other one after them in
    collection order (a stable sort: the tests inside a module keep their order)."""
    here = os.path.dirname(__file__)
    gone = [m for m in LONGEST_FIRST if not os.path.exists(os.path.join(here, m))]
    if gone:
        raise pytest.UsageError(f"tests/conftest.py LONGEST_FIRST names modules that do not exist: {gone}")
    items.sort(key=_module_rank)


@pytest.fixture(scope="session")
def mujoco():
    return pytest.importorskip("mujoco")


@pytest.fixture(scope="session")
def five():
    from bipedlab.robots.five_link import robot as five_link

    return five_link.model()


# ----- compile profile ---------------------------------------------------------------------
# BIPEDLAB_TEST_COMPILE_PROFILE=DIR: every test process records, per test, the seconds JAX spent
# tracing, lowering and compiling (its monitoring events) and the persistent-cache hits, into
# DIR/compile-<process>.json; the run ends with the modules that compile longest.
_PROFILE_DIR = os.environ.get("BIPEDLAB_TEST_COMPILE_PROFILE")
_profile: dict = {}
_current = {"test": "(collection)"}
#: XLA compilations shorter than this are counted apart ("small" in the summary): nearly all are
#: the one-operation programs JAX compiles for operations run outside jit (a model's function
#: called on concrete arrays), 0.02-0.05 s each, thousands per run
SMALL_PROGRAM_S = 0.1
_COMPILE_EVENTS = {"/jax/core/compile/jaxpr_trace_duration": "trace_s",
                   "/jax/core/compile/jaxpr_to_mlir_module_duration": "lower_s",
                   "/jax/core/compile/backend_compile_duration": "compile_s"}


def _on_duration(event, duration, **kwargs):
    key = _COMPILE_EVENTS.get(event)
    if key:
        row = _profile.setdefault(_current["test"], {})
        row[key] = row.get(key, 0.0) + duration
        if key == "compile_s":
            row["programs"] = row.get("programs", 0) + 1
            if duration < SMALL_PROGRAM_S:  # mostly eager operations, each its own program
                row["small"] = row.get("small", 0) + 1
                row["small_s"] = row.get("small_s", 0.0) + duration


def _on_event(event, **kwargs):
    if event == "/jax/compilation_cache/cache_hits":
        row = _profile.setdefault(_current["test"], {})
        row["cache_hits"] = row.get("cache_hits", 0) + 1


if _PROFILE_DIR:
    jax.monitoring.register_event_duration_secs_listener(_on_duration)
    jax.monitoring.register_event_listener(_on_event)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    _current["test"] = item.nodeid
    yield
    _current["test"] = "(between tests)"


def pytest_sessionfinish(session, exitstatus):
    if not _PROFILE_DIR:
        return
    import json
    import time

    os.makedirs(_PROFILE_DIR, exist_ok=True)
    name = os.environ.get("PYTEST_XDIST_WORKER", "main")
    _profile["(process ended)"] = {"unix_time": time.time()}
    with open(os.path.join(_PROFILE_DIR, f"compile-{name}.json"), "w") as f:
        json.dump(_profile, f, indent=0)


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    if not _PROFILE_DIR or os.environ.get("PYTEST_XDIST_WORKER"):
        return
    import glob
    import json

    modules: dict = {}
    ended: dict = {}
    for path in glob.glob(os.path.join(_PROFILE_DIR, "compile-*.json")):
        with open(path) as f:
            rows = json.load(f)
        end = rows.pop("(process ended)", {}).get("unix_time")
        worker = os.path.basename(path)[len("compile-"):-len(".json")]
        if end is not None and worker != "main":
            ended[worker] = end
        for test, row in rows.items():
            m = modules.setdefault(test.split("::")[0], {})
            for k, v in row.items():
                m[k] = m.get(k, 0) + v
    total = lambda r: r.get("trace_s", 0) + r.get("lower_s", 0) + r.get("compile_s", 0)  # noqa: E731
    terminalreporter.write_sep("=", "compile seconds per module (trace + lower + XLA compile, programs, cache hits, "
                                    f"programs compiled in under {SMALL_PROGRAM_S} s and their seconds)")
    for mod, r in sorted(modules.items(), key=lambda kv: -total(kv[1]))[:40]:
        terminalreporter.write_line(f"{total(r):8.1f} s  ({r.get('trace_s', 0):6.1f} + {r.get('lower_s', 0):6.1f} + "
                                    f"{r.get('compile_s', 0):6.1f})  {r.get('programs', 0):5d} programs  "
                                    f"{r.get('cache_hits', 0):5d} hits  {r.get('small', 0):5d} small "
                                    f"{r.get('small_s', 0.0):6.1f} s  {mod}")
    terminalreporter.write_line(f"{sum(total(r) for r in modules.values()):8.1f} s  in all; "
                                f"{sum(r.get('small', 0) for r in modules.values())} small programs, "
                                f"{sum(r.get('small_s', 0.0) for r in modules.values()):.1f} s")
    if len(ended) > 1:  # the idle tail: the first worker to finish waited this long for the last
        last, first = max(ended.values()), min(ended.values())
        terminalreporter.write_line(f"workers ended {last - first:.1f} s apart ({', '.join(sorted(ended))})")
