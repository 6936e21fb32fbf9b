"""bipedlab.viz.figures (one way to make and save a figure) and bipedlab.viz.stick (segments
drawn as polylines, ground as a level line or a terrain)."""
from __future__ import annotations

import numpy as np
import pytest

from bipedlab.viz import figures, stick


def test_save_creates_the_directory_and_collects_the_path(tmp_path):
    fig, ax = figures.subplots(figsize=(3, 2))
    ax.plot([0, 1], [0, 1])
    paths = []
    p = figures.save(fig, tmp_path / "a" / "b" / "line.png", paths)
    assert paths == [p] and (tmp_path / "a" / "b" / "line.png").stat().st_size > 500
    assert figures.pyplot().get_fignums() == []  # closed
    assert figures.output_dir(tmp_path / "c").is_dir()


def test_consecutive_segments_become_one_polyline():
    hip, knee, foot, top = [0.0, 1.0], [0.1, 0.5], [0.0, 0.0], [0.0, 1.6]
    segs = [[hip, knee], [knee, foot], [hip, top]]
    ch = list(stick.chains(segs, colors="k", widths=[1.5, 1.5, 2.5]))
    assert len(ch) == 2
    np.testing.assert_array_equal(ch[0][0], [hip, knee, foot])
    assert ch[1][2] == 2.5
    # a colour per segment splits the chain
    assert len(list(stick.chains(segs, colors=["k", "r", "k"]))) == 3
    # an RGBA colour is one colour, not four
    assert len(list(stick.chains(segs, colors=(0.1, 0.2, 0.3, 1.0)))) == 2


def test_sequence_draws_frames_and_ground(tmp_path):
    fig, ax = figures.subplots()
    frames = np.zeros((3, 2, 2, 2))
    frames[:, 0, 1] = [0.0, 1.0]
    frames[:, 1, 0] = [0.0, 1.0]
    frames[:, 1, 1] = [0.3, 1.2]
    stick.sequence(ax, frames, colors=figures.pyplot().get_cmap("viridis"), offsets=[0.0, 0.5, 1.0])
    assert len(ax.lines) == 3 * 1 + 1  # one polyline per frame, then the ground
    np.testing.assert_allclose(ax.lines[2].get_xdata(), [1.0, 1.0, 1.3])
    stick.draw_ground(ax, np.array([[0.0, 0.0], [1.0, 0.1]]))
    assert len(ax.lines) == 5
    with pytest.raises(ValueError):
        stick.as_frames(np.zeros((3, 2, 3)))
    figures.close(fig)
