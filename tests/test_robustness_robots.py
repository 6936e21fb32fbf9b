"""``bipedlab robustness`` of MABEL (walking and hopping), ATRIAS and the seven-link biped: a
trial is the robot's own closed loop from the same state (zero push and no noise is the
nominal walk; a push starting half a period into its step is the push of ``walk mabel
--push``; a drop from 2 cm is ``hop mabel``'s run), the nominal cases survive. Every one of
these loops compiles for minutes on a 2-core CPU: slow; the default suite checks the engine on
a fast study (tests/core/robustness) and the five-link command's options."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from bipedlab.robustness import engine

pytestmark = pytest.mark.slow


def _fixed(study, points: dict):
    """The study with its sampler replaced by the given trials (other sampled entries kept)."""
    n = len(next(iter(points.values())))

    def sample(rng, k):
        p = study.sample(rng, k)
        p.update({key: np.asarray(v)[:k] for key, v in points.items()})
        return p

    return dataclasses.replace(study, sample=sample), n


def _run(study, points, tmp_path):
    s, n = _fixed(study, points)
    rec = engine.run(s, n, out=str(tmp_path), progress=False)
    return rec, dict(np.load(tmp_path / "outcomes.npz"))


def test_mabel_walking_zero_push_is_the_nominal_walk_and_a_mid_step_push_is_walk_push(tmp_path):
    import jax
    import jax.numpy as jnp

    from bipedlab.robots.mabel.robustness import walking_study
    from bipedlab.robots.mabel.walking import loop as sw
    from bipedlab.robots.mabel.walking import stance as wk
    from bipedlab.robots.mabel.walking import study as ws
    from bipedlab.sim import loop as sl

    # exact sensing: with the 14-bit encoders a roundoff-level difference between two compiled
    # programs can flip one count and the walks then differ by millimetres (seen: 8 mm in 3.2 m)
    steps, force = 4, 30.0
    study = walking_study(steps=steps, controller="decentralized", sensing="ideal")
    rec, o = _run(study, dict(push_force=[0.0, 0.0, force], push_phase=[0.5, 0.2, 0.5]), tmp_path)
    vc, gains, grec = ws.load_gait("nominal")
    m = wk.walking_model()
    n = int(round(rec["simulated_s"] / sw.SAMPLE))
    z0 = jnp.asarray(grec["z_plus"], float)
    ref = jax.jit(lambda setup: sl.run(sw.closed_loop(m, "decentralized"), setup, sw.initial_state(setup, z0), n)[0])
    for i, push in ((0, (0.0, -1)), (2, (force, 2))):
        s = ref(ws.setup_for(vc, gains, grec["design"]["period"], push=push, sensing="ideal"))
        assert int(s.status) == o["status"][i] and int(s.x.step) == o["touchdowns"][i]
        assert float(s.x.distance) == pytest.approx(o["distance_m"][i], abs=1e-7)
    # a zero push is no push, whenever it starts
    assert o["touchdowns"][0] == o["touchdowns"][1] and o["distance_m"][0] == o["distance_m"][1]
    assert o["survived"][0] and o["touchdowns"][0] >= steps


def test_mabel_hopping_drop_of_2cm_is_hop_mabel(tmp_path):
    from bipedlab.robots.mabel.hopping import study as hs
    from bipedlab.robots.mabel.robustness import hopping_study

    hops = 3
    rec, o = _run(hopping_study(hops=hops), dict(drop_height=[0.02], forward_speed=[0.0]), tmp_path)
    run = hs.run_hops(hops)
    assert o["survived"][0] == (not run.fell)
    assert o["hops_landed"][0] >= hops and len(run.touchdowns) - 1 >= hops


def test_atrias_flat_ground_survives(tmp_path):
    from bipedlab.robots.atrias.robustness import study

    rec, o = _run(study(distance=6.0), dict(step_height=[0.0, 0.0]), tmp_path)
    assert o["survived"].all() and np.all(o["x_m"] >= 6.0)
    assert rec["survival_rate"] == 1.0


def test_seven_link_nominal_start_walks(tmp_path):
    from bipedlab.robots.seven_link import study as ss
    from bipedlab.robots.seven_link.robustness import study

    steps = 3
    rec, o = _run(study(steps=steps), dict(speed_change=[0.0], body_offset=[0.0]), tmp_path)
    res = ss.run_walk(steps)
    assert o["survived"][0] == (int(res.status) == 0)
    assert o["touchdowns"][0] == int(res.n_touchdowns)
    assert o["t_end_s"][0] == pytest.approx(float(res.t_end), abs=1e-12)
