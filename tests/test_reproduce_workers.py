"""``bipedlab reproduce``'s worker processes (:mod:`bipedlab.report.workers`): how papers are dealt
to workers, and that a worker that dies ends the run with an error instead of a hang. (The
normal path, two papers in two workers, is the browser test's run.)"""
from __future__ import annotations

import time

import pytest

from bipedlab.report import workers


def test_makespan_is_the_longest_worker_under_longest_first_dealing():
    # 4 then 2 on one worker, 3 + 3 on the other (longest first, each to the least loaded)
    assert workers.makespan([3.0, 2.0, 4.0, 3.0], 2) == pytest.approx(6.0)
    assert workers.makespan([3.0, 2.0, 4.0, 3.0], 1) == pytest.approx(12.0)
    assert workers.makespan([5.0, 1.0], 8) == pytest.approx(5.0)
    assert [g[0] for g in workers.deal([("a", 1.0, []), ("b", 9.0, []), ("c", 4.0, [])])] == ["b", "c", "a"]


def test_an_experiment_longer_than_the_rest_of_its_paper_is_a_unit_of_its_own():
    from bipedlab.report.runner import work_groups

    todo = [("hzd", "design", 300.0), ("hzd", "push", 500.0), ("hzd", "sensitivity", 4000.0),
            ("identification", "identify", 100.0), ("identification", "hop", 100.0)]
    groups = work_groups(todo)
    assert groups == [("hzd", 4000.0, ["sensitivity"]), ("hzd", 800.0, ["design", "push"]),
                      ("identification", 200.0, ["identify", "hop"])]
    # two workers: the long experiment beside the rest, instead of after it
    assert workers.makespan([x for _, x, _ in groups], 2) == pytest.approx(4000.0)
    # no experiment longer than the rest: the paper is one unit, in order; a lone experiment too
    assert work_groups([("a", "x", 2.0), ("a", "y", 2.0)]) == [("a", 4.0, ["x", "y"])]
    assert work_groups([("a", "x", 9.0)]) == [("a", 9.0, ["x"])]


def test_a_worker_that_dies_is_an_error_not_a_hang():
    seen = []
    t0 = time.monotonic()
    with pytest.raises(RuntimeError, match="worker process died|failed"):
        # an experiment name the paper does not have: the worker raises before it can report
        workers.run([("seven-link", 1.0, ["no-such-experiment"])], quick=True, use_cache=False, jobs=1,
                    on_start=lambda *a: seen.append(a), on_say=lambda *a: None, on_done=lambda *a: seen.append(a),
                    poll_s=0.2)
    assert seen == [] and time.monotonic() - t0 < 120
