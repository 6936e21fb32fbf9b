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


def _captured(monkeypatch):
    figs = {}

    def save(fig, path, paths=None, **_):
        figs[str(path).rsplit("/", 1)[-1]] = fig
        return str(path)

    monkeypatch.setattr(plots.figures, "save", save)
    return figs


def test_spring_and_com_figures_mark_the_papers_values(monkeypatch, tmp_path):
    """Fig. 19's two fitted lines (115.1 q + 2.214, 111.7 q + 5.377 N m) are drawn beside the
    study's fits, and Fig. 17's 6 mm bound beside the centre-of-mass distances."""
    import numpy as np

    figs = _captured(monkeypatch)
    fit = lambda k, t0: types.SimpleNamespace(deflection=np.linspace(0.01, 0.3, 5), torque=k * np.linspace(0.01, 0.3, 5) + t0,  # noqa: E731
                                              stiffness=k, preload=t0)
    ident = types.SimpleNamespace(fits=dict(springs={"L": fit(100.0, 1.0), "R": fit(120.0, 4.0)},
                                            com_check=types.SimpleNamespace(distance_mm={"a": np.array([1.0, -2.0])},
                                                                            support={"a": "toe"})), details={})
    plots._springs(ident, tmp_path, [])
    plots._com(ident, tmp_path, [])
    lines = figs["identify_springs.png"].axes[0].get_lines()
    slopes = {}
    for ln in lines:
        x, y = ln.get_data()
        if len(x) > 1 and ln.get_linestyle() == "--":
            k = (y[-1] - y[0]) / (x[-1] - x[0])
            slopes[round(k, 6)] = round(y[0] - k * x[0], 6)
    assert slopes == {115.1: 2.214, 111.7: 5.377}
    levels = sorted(ln.get_ydata()[0] for ln in figs["identify_com.png"].axes[0].get_lines() if ln.get_linestyle() == "--")
    assert levels == [-6.0, 6.0]
