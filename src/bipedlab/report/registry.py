"""Finding the papers: every robot package's ``reproduce`` module lists its :class:`Paper`s.

Found like the commands (:func:`bipedlab.registry.robot_cli_modules`): ``pkgutil.iter_modules`` over
``bipedlab.robots``, importing ``bipedlab.robots.<name>.reproduce`` where it exists. The
modules import their studies only when an experiment runs, so listing papers is fast.
"""
from __future__ import annotations

import importlib
import os
import pkgutil

from bipedlab.report.spec import Paper

ROBOTS_PACKAGE = "bipedlab.robots"


def reproduce_modules() -> list[str]:
    pkg = importlib.import_module(ROBOTS_PACKAGE)
    names = []
    for info in sorted(pkgutil.iter_modules(pkg.__path__), key=lambda m: m.name):
        where = getattr(info.module_finder, "path", None)
        if info.ispkg and where and any(m.name == "reproduce"
                                        for m in pkgutil.iter_modules([os.path.join(where, info.name)])):
            names.append(f"{ROBOTS_PACKAGE}.{info.name}.reproduce")
    return names


def papers() -> dict[str, Paper]:
    """{key: Paper} of every registered paper, by (Paper.order, key)."""
    found: dict[str, Paper] = {}
    for name in reproduce_modules():
        for p in getattr(importlib.import_module(name), "PAPERS", []):
            if not isinstance(p, Paper):
                raise TypeError(f"{name}: PAPERS must hold bipedlab.report.Paper, got {p!r}")
            if p.key in found:
                raise ValueError(f"two papers named {p.key!r}")
            found[p.key] = p
    return {k: found[k] for k in sorted(found, key=lambda k: (found[k].order, k))}
