"""The identification's figures: a figure without data is not drawn, and the study says so in
one line per figure (no silent gaps in --out)."""
from __future__ import annotations

import types

from bipedlab.robots.mabel.sysid import plots


def test_figures_without_their_experiments_are_announced_one_line_each(tmp_path):
    said = []
    paths = plots.write_figures(types.SimpleNamespace(fits={}, details={}), tmp_path, say=said.append)
    assert paths == []
    assert len(said) == 6
    assert all(s.startswith("no ") and s.endswith("the logs hold no experiment of that kind") and "\n" not in s
               for s in said)
    assert any("Fig. 13" in s for s in said) and any("Figs. 21, 23" in s for s in said)
