"""The branched test tree (base, revolute arm, prismatic slide on the arm, revolute leg on
the base, revolute tip on the slide), shared by several test modules."""
from __future__ import annotations

from bipedlab.mechanics import Body, Point, build_model

SPEC = {
    "base": dict(mass=5.0, com=(0.10, 0.05), inertia=0.30, offset=(0.0, 0.0), axis=(1.0, 0.0)),
    "arm": dict(mass=2.0, com=(0.15, 0.02), inertia=0.05, offset=(0.20, -0.10), axis=(1.0, 0.0)),
    "slide": dict(mass=1.5, com=(0.05, -0.03), inertia=0.02, offset=(0.30, 0.00), axis=(3.0, 4.0)),
    "leg": dict(mass=1.2, com=(0.00, -0.20), inertia=0.04, offset=(-0.20, 0.10), axis=(1.0, 0.0)),
    "tip": dict(mass=0.7, com=(0.10, 0.01), inertia=0.01, offset=(0.10, 0.00), axis=(1.0, 0.0)),
}
# declaration order interleaves the branches: base, arm, slide (prismatic, on arm),
# leg (on base), tip (on slide); coordinates follow the same order
PARENTS = {"base": None, "arm": "base", "slide": "arm", "leg": "base", "tip": "slide"}
ORDER = ("base", "arm", "slide", "leg", "tip")
POINTS = [Point("tip_end", "tip", (0.25, -0.05)), Point("leg_end", "leg", (0.0, -0.4)),
          Point("slider_pt", "slide", (0.02, 0.03))]


def make_model(rotors=(), gravity=9.81):
    bodies = []
    for name in ORDER:
        s = SPEC[name]
        bodies.append(Body(name, PARENTS[name], s["mass"], s["com"], s["inertia"],
                           joint="prismatic" if name == "slide" else "revolute",
                           offset=s["offset"], axis=s["axis"]))
    return build_model(bodies, POINTS, rotors=rotors, gravity=gravity)
