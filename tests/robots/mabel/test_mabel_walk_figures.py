"""MABEL's walk figures draw the paper's numbers beside the run: Fig. 16's roughly 45 % speed
change after a push and its recovery horizon, the 30 / 55 N m torque capacities."""
from __future__ import annotations

import numpy as np
import pytest

from bipedlab.robots.mabel.walking import plots
from bipedlab.viz import figures


@pytest.mark.parametrize("force, level, horizon", [(78.0, 1.45, 10), (-71.0, 0.55, 3)])
def test_push_speed_marks_the_papers_change_and_recovery(force, level, horizon):
    sp = [0.70, 0.72, 0.71, 0.70, 1.0, 0.9, 0.8]
    fig, ax = figures.subplots()
    plots._paper_push_marks(ax, sp, 4, force)
    base = np.mean(sp[1:4])
    h = sorted(float(ln.get_ydata()[0]) for ln in ax.get_lines() if ln.get_linestyle() in (":", "--"))
    assert h == pytest.approx(sorted([base, base * level]), rel=1e-12)
    v = [float(ln.get_xdata()[0]) for ln in ax.get_lines() if ln.get_linestyle() == "-."]
    assert v == [4 + 1 + horizon]
    figures.pyplot().close(fig)


def test_torque_plots_mark_both_capacities():
    fig, ax = figures.subplots()
    ax.plot([0, 1], [2.0, -3.0])
    plots._capacities(ax)
    levels = sorted(float(ln.get_ydata()[0]) for ln in ax.get_lines()[1:])
    assert levels == [-55.0, -30.0, 30.0, 55.0]
    lo, hi = ax.get_ylim()
    assert lo < -55.0 and hi > 55.0  # both capacities inside the axis
    figures.pyplot().close(fig)
