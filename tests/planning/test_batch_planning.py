"""Many robots: a process pool, per-pair seeds, input order, same paths whatever the worker count."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import GOAL, OPTIMAL, ROADMAP, START, clearance_violations, wall_map

from swarm.planning.batch import pair_seeds, plan_many
from swarm.planning.costmap import EndpointError, NoPathError
from swarm.planning.profiles import DEFAULT_PROFILE

PAIRS = [
    (START, GOAL),
    ((25.0, 18.0), (4.0, 9.0)),
    ((3.0, 10.0), (27.0, 12.0)),
    ((20.0, 5.0), (10.0, 17.0)),
    ((12.0, 3.0), (28.0, 18.0)),
]


def test_pair_seeds_depend_on_seed_and_index_only():
    assert pair_seeds(5, 3) == pair_seeds(5, 10)[:3]
    assert pair_seeds(5, 3) != pair_seeds(6, 3)
    assert all(0 < s < 2**31 for s in pair_seeds(0, 50))


@pytest.mark.parametrize("profile", [DEFAULT_PROFILE, OPTIMAL, ROADMAP], ids=lambda p: p.name)
def test_same_paths_in_input_order_whatever_the_worker_count(wall_costmap, profile):
    one = plan_many(wall_costmap, PAIRS, profile, seed=42, workers=1)
    two = plan_many(wall_costmap, PAIRS, profile, seed=42, workers=2)
    assert len(one) == len(two) == len(PAIRS)
    for (start, goal), a, b in zip(PAIRS, one, two, strict=True):
        assert np.allclose(a.waypoints_m[0], start) and np.allclose(a.waypoints_m[-1], goal)
        assert np.array_equal(a.waypoints_m, b.waypoints_m)
        bad, _ = clearance_violations(wall_map(), wall_costmap.half_width_m, a.waypoints_m)
        assert len(bad) == 0


def test_a_bad_pair_is_named_before_planning(wall_costmap):
    pairs = [*PAIRS[:2], ((15.2, 6.0), GOAL)]
    with pytest.raises(EndpointError, match=r"^pair 2: start \(15\.2, 6\) is on boulder"):
        plan_many(wall_costmap, pairs, DEFAULT_PROFILE, workers=2)


def test_budget_failures_raise_or_come_back_as_none(wall_costmap):
    from dataclasses import replace

    tiny = replace(DEFAULT_PROFILE, name="tiny", params={"range": 0.5}, iterations=3)
    pairs = [((3.0, 10.0), (4.0, 10.0)), (START, GOAL)]  # the first is a straight metre
    with pytest.raises(NoPathError, match=r"^pair 1: planner profile 'tiny'"):
        plan_many(wall_costmap, pairs, tiny, workers=1)
    results = plan_many(wall_costmap, pairs, tiny, workers=1, strict=False)
    assert results[0] is not None and results[1] is None


def test_empty_and_malformed_pairs(wall_costmap):
    assert plan_many(wall_costmap, [], DEFAULT_PROFILE) == []
    with pytest.raises(ValueError, match=r"\(n, 2, 2\)"):
        plan_many(wall_costmap, [(1.0, 2.0, 3.0)], DEFAULT_PROFILE)
