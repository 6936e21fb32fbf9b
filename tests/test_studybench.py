"""The first-run benchmark of the studies (``bipedlab bench --studies``): which studies it
selects, and that its child process measures compilation from JAX's own events (a cold run
compiles programs, a warm run loads them from the compilation cache the cold one filled)."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

from bipedlab import studybench as sb


def test_every_shipped_study_family_declares_a_short_version():
    names = [s.name for s in sb.studies()]
    for words in ("walk five-link", "optimize five-link", "walk mabel", "hop mabel", "identify mabel",
                  "run atrias", "walk seven-link", "walk compass-gait"):
        assert any(n.startswith(words) for n in names), words
    # the long study runs only when named
    long = [s for s in sb.studies() if s.long]
    assert [s.name for s in long] == ["experiment mabel sweep"]
    assert not any(s.long for s in sb.select([], sb.studies()))
    assert [s.name for s in sb.select(["experiment mabel"], sb.studies())] == ["experiment mabel sweep"]


def test_selection_by_leading_words_and_one_line_for_an_unknown_name():
    chosen = sb.select(["walk five", "walk"], sb.studies())
    assert chosen[0].name == "walk five-link --steps 10"
    assert all(s.name.startswith("walk") for s in chosen)
    assert len({s.name for s in chosen}) == len(chosen)  # no study twice
    with pytest.raises(ValueError, match="'fly' names no study"):
        sb.select(["fly"], sb.studies())
    r = subprocess.run([sys.executable, "-m", "bipedlab.cli", "bench", "--studies", "fly"], capture_output=True, text=True)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1


def test_a_failing_study_is_reported_with_its_error_line(tmp_path):
    rec = sb._one(("walk", "compass-gait", "--steps", "0"), str(tmp_path), timeout=120)
    assert rec["exit_status"] == 2
    assert "--steps" in rec["error"]
    assert "failed" in sb.summary(dict(cpu="x", cores=1, jax_version="0", wall_s=0.0,
                                       studies=[dict(study="walk compass-gait --steps 0", cold=rec)]))


def test_cold_run_compiles_and_warm_run_loads_every_program_from_the_cache():
    study = sb.Study(("walk", "compass-gait", "--steps", "2"))
    r = sb.run([study])
    row = r["studies"][0]
    cold, warm = row["cold"], row["warm"]
    assert cold["exit_status"] == 0 and warm["exit_status"] == 0
    assert cold["programs_compiled"] > 0 and cold["programs_from_cache"] == 0
    # every program is kept, however small: the warm run compiles none and loads each one the
    # cold run compiled (JAX's default threshold of 1 s of compilation kept only a few)
    assert warm["programs_compiled"] == 0
    assert warm["programs_from_cache"] == cold["programs_compiled"]
    # the sizes: the largest program is named and counted, the slowest compilations listed
    assert cold["largest_program_eqns"] >= max(p["eqns"] or 0 for p in cold["slowest_programs"]) > 0
    assert cold["programs_lowered"] >= cold["programs_compiled"]
    assert cold["slowest_programs"][0]["seconds"] >= cold["slowest_programs"][-1]["seconds"]
    assert warm["backend_compile_s"] < cold["backend_compile_s"]
    assert 0.0 < cold["compile_s"] < cold["wall_s"]
    assert 50.0 < cold["peak_rss_mb"] < 3000.0
    json.dumps(r)
