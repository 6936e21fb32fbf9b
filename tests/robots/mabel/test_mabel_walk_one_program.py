"""The experiments of the HZD paper that walk the stance plant under one controller share one
compiled closed loop: the gait, its gains, a push, the impact scaling, the sensing mode and
the torque limits are data of the loop (traced), so a second variant lowers no new program."""
from __future__ import annotations

import numpy as np
from helpers import new_programs

from bipedlab.robots.mabel.walking import study as ws


def test_variants_of_a_walk_run_on_the_first_walks_program():
    import jax

    jax.clear_caches()  # a walk run earlier in this process (another test file) must not count as this one's
    first, built = new_programs(ws.run_walk, "paper-nominal", "pdff", 1)
    assert built > 0
    s1, log1, _ = first
    # another gait, a push in the first step, scaled impacts, ideal sensing, torque limits
    second, built = new_programs(ws.run_walk, "paper-efficient", "pdff", 1, push=(40.0, 0), eta=0.98,
                                 sensing="ideal", torque_limits=(20.0, 40.0, 20.0, 40.0))
    assert built == 0, f"the second variant lowered {built} new programs"
    s2, log2, _ = second
    assert int(s1.x.step) == 1 and int(s2.x.step) == 1
    # a different walk, not the first one again
    assert not np.allclose(np.asarray(log1["u"])[:200], np.asarray(log2["u"])[:200])
