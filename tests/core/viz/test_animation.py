"""bipedlab.viz.animation: a synthetic two-segment pendulum written as animated SVG, HTML and
GIF; the files parse, hold no network reference, and give back the frames and coordinates."""
from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from bipedlab.viz import animation

SVG = "{http://www.w3.org/2000/svg}"


def pendulum(n: int = 30, dt: float = 0.04):
    """Frames (n, 2, 2, 2) of a double pendulum hung at (0, 1) m, and their times."""
    t = np.arange(n) * dt
    a1, a2 = 0.6 * np.sin(2.0 * t), 0.9 * np.sin(3.1 * t + 0.4)
    pivot = np.tile([0.0, 1.0], (n, 1))
    elbow = pivot + 0.5 * np.stack([np.sin(a1), -np.cos(a1)], axis=1)
    tip = elbow + 0.4 * np.stack([np.sin(a2), -np.cos(a2)], axis=1)
    frames = np.stack([np.stack([pivot, elbow], axis=1), np.stack([elbow, tip], axis=1)], axis=1)
    return frames, t


def test_svg_parses_and_round_trips(tmp_path):
    frames, t = pendulum()
    [path] = animation.write(tmp_path / "sub" / "pendulum.svg", frames, t, ground=0.0, colors=["k", "C0"])
    root = ET.parse(path).getroot()
    assert root.tag == SVG + "svg"
    groups = [g for g in root.iter(SVG + "g") if g.get("class") == "frame"]
    assert len(groups) == len(frames)
    back = np.array([[[[float(ln.get("x1")), float(ln.get("y1"))], [float(ln.get("x2")), float(ln.get("y2"))]]
                      for ln in g.iter(SVG + "line")] for g in groups])
    np.testing.assert_allclose(back, frames, atol=1e-6)
    np.testing.assert_allclose([float(g.get("data-t")) for g in groups], t, atol=1e-6)
    # every frame but the first starts hidden and is switched on by SMIL at its time
    assert groups[0].get("visibility") == "visible" and all(g.get("visibility") == "hidden" for g in groups[1:])
    assert all(g.find(SVG + "animate") is not None for g in groups)
    assert [ln.get("stroke") for ln in groups[0].iter(SVG + "line")] == ["#000000", "#1f77b4"]
    ground = [p for p in root.iter(SVG + "polyline") if p.get("class") == "ground"]
    assert len(ground) == 1
    # no reference to anything outside the file (the SVG namespace is a name, not a fetch)
    text = open(path).read().replace('xmlns="http://www.w3.org/2000/svg"', "")
    assert not re.search(r"https?://", text)


def test_html_holds_the_frames_and_no_urls(tmp_path):
    frames, t = pendulum(12)
    terrain = np.array([[-1.0, 0.0], [0.0, 0.05], [1.0, 0.0]])
    [path] = animation.write(tmp_path / "pendulum.html", frames, t, ground=terrain, follow=True)
    html = open(path).read()
    assert "<canvas" in html and not re.search(r"https?://", html) and "src=" not in html
    blob = re.search(r'<script type="application/json" id="bipedlab-animation">(.*?)</script>', html, re.S).group(1)
    data = json.loads(blob)
    assert len(data["frames"]) == len(frames) and len(data["times"]) == len(frames)
    back = np.asarray(data["frames"]).reshape(frames.shape)
    np.testing.assert_allclose(back, frames, atol=1e-6)
    np.testing.assert_allclose(data["times"], t, atol=1e-6)
    np.testing.assert_allclose(data["ground"], terrain)
    # follow: the window moves with each frame's mean x
    np.testing.assert_allclose(data["shift"], -frames[..., 0].reshape(len(frames), -1).mean(axis=1), atol=1e-6)


def test_gif_through_pillow(tmp_path):
    pytest.importorskip("PIL")
    frames, t = pendulum(8)
    paths = animation.write(tmp_path / "pendulum.svg", frames, t, gif=True, size_px=160)
    assert len(paths) == 2 and paths[1].endswith(".gif")
    from PIL import Image

    with Image.open(paths[1]) as im:
        assert im.n_frames == len(frames)


@pytest.mark.parametrize("bad", ["frames", "times", "order", "suffix"])
def test_bad_input_is_refused(tmp_path, bad):
    frames, t = pendulum(5)
    name = "a.svg"
    if bad == "frames":
        frames = frames[..., :1]
    elif bad == "times":
        t = t[:-1]
    elif bad == "order":
        t = t[::-1]
    else:
        name = "a.mp4"
    with pytest.raises(ValueError):
        animation.write(tmp_path / name, frames, t)
