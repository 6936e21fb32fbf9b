"""Runs shared by the running tests of several modules (made once per test process)."""
import pytest

from bipedlab.robots.atrias import study as ra


@pytest.fixture(scope="session")
def paper_flat_run():
    """The paper's controller as published on flat ground, energy conservation, 8 s, two trials
    batched (nominal start and a 10 deg trunk perturbation), with the per-sample log:
    ``(out, (rp, cp, gait, terrains))`` of :func:`bipedlab.robots.atrias.study.simulate`."""
    st = ra.Settings(terrain="flat", seconds=8.0, energy="conservation", controller="paper")
    return ra.simulate(st, 2, theta0_offsets_deg=[0.0, 10.0], log=True)
