"""The grid motion validator (`swarm.planning.paths._motion_free`) against OMPL's own
`DiscreteMotionValidator`, and every planner a profile may name on a beach-sized map."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import clearance_violations

from swarm.planning import paths
from swarm.planning.costmap import CostMap, build_costmap
from swarm.planning.paths import _space_information, plan_path
from swarm.planning.profiles import PLANNERS, ROADMAP_PLANNERS, profile_from_dict
from swarm.world.io import load_map

GENTLE = Path(__file__).resolve().parents[2] / "maps" / "gentle_fine.yaml"


@pytest.fixture(scope="module")
def gentle_costmap(robot) -> CostMap:
    return build_costmap(load_map(GENTLE), robot)


def _motions(cm: CostMap, rng: np.random.Generator, count: int) -> np.ndarray:
    """(count, 4) motions x1, y1, x2, y2 inside the bounds: random ones of every length, ones
    along cell edges, ones ending on the map's north and east edges, and zero-length ones."""
    xmin, ymin, xmax, ymax = cm.bounds_m
    lo, hi = np.array([xmin, ymin]), np.array([xmax, ymax])
    a = rng.uniform(lo, hi, size=(count, 2))
    reach = rng.choice([1.0, 5.0, 30.0, 1e9], size=(count, 1))
    b = np.clip(a + rng.uniform(-1.0, 1.0, size=(count, 2)) * reach, lo, hi)
    k = count // 8
    b[:k, 0] = a[:k, 0]  # along a column of cells
    a[k : 2 * k] = np.round(a[k : 2 * k] / cm.cell_m) * cm.cell_m  # from cell corners
    b[2 * k : 3 * k, 0] = xmax  # onto the east edge
    b[3 * k : 4 * k, 1] = ymax  # onto the north edge
    b[4 * k : 4 * k + 10] = a[4 * k : 4 * k + 10]  # no length at all
    return np.hstack([a, b])


def _check_motions(cm: CostMap, planners: tuple[str, ...], motions: np.ndarray) -> np.ndarray:
    si = _space_information(cm, planners)
    space = si.getStateSpace()
    s1, s2 = space.allocState(), space.allocState()
    out = np.empty(len(motions), bool)
    for i, (x1, y1, x2, y2) in enumerate(motions.tolist()):
        s1[0], s1[1], s2[0], s2[1] = x1, y1, x2, y2
        out[i] = si.checkMotion(s1, s2)
    return out


@pytest.mark.parametrize("costmap", ["wall_costmap", "gentle_costmap"])
def test_a_motion_is_valid_on_the_grid_exactly_when_omples_own_validator_says_so(costmap, request):
    cm = request.getfixturevalue(costmap)
    motions = _motions(cm, np.random.default_rng(7), 4000)
    grid = _check_motions(cm, (), motions)
    ompl = _check_motions(cm, ("KPIECE1",), motions)  # a planner that keeps OMPL's validator
    assert 0.1 < grid.mean() < 0.9  # both answers are well represented
    np.testing.assert_array_equal(grid, ompl)


def test_paths_are_the_same_with_either_validator(wall_costmap, monkeypatch):
    """RRT-Connect and the simplifier make the same calls and get the same answers, so the same
    path point for point (the takeover routes of a run depend on it)."""
    profile = profile_from_dict({"planner": "RRTConnect", "params": {"range": 5.0}}, name="t")
    queries = [((3.0, 4.0), (27.0, 4.0)), ((3.0, 17.0), (27.0, 9.0)), ((10.0, 2.5), (20.0, 19.0))]
    grid = [plan_path(wall_costmap, a, b, profile, seed=s).waypoints_m for s, (a, b) in enumerate(queries)]
    ompl_only = paths._space_information
    monkeypatch.setattr(paths, "_space_information", lambda cm, planners=(): ompl_only(cm, ("KPIECE1",)))
    ompl = [plan_path(wall_costmap, a, b, profile, seed=s).waypoints_m for s, (a, b) in enumerate(queries)]
    for x, y in zip(grid, ompl, strict=True):
        np.testing.assert_array_equal(x, y)


def test_a_roadmap_grown_with_the_grid_validator_is_omples_own(wall_costmap, monkeypatch):
    """The growth checks motions on the grid, the expansion with OMPL's validator: the same
    roadmap as OMPL's validator throughout."""
    profile = profile_from_dict(
        {"planner": "PRM", "roadmap": {"grow_iterations": 600, "expand_iterations": 200}}, name="t"
    )
    grid = paths.build_roadmap(wall_costmap, profile, seed=3)
    monkeypatch.setattr(paths, "_check_motions_on_grid", lambda si, cm: None)
    ompl = paths.build_roadmap(wall_costmap, profile, seed=3)
    assert grid.n_vertices > 100
    for field in ("vertices_m", "edges", "weights"):
        np.testing.assert_array_equal(getattr(grid, field), getattr(ompl, field))


@pytest.mark.parametrize("planner", PLANNERS)
def test_every_planner_a_profile_may_name_plans_on_a_beach_sized_map(planner, gentle_costmap):
    """1000 m x 200 m, round deep water: no planner may crash the interpreter (ompl 2.0.1's AORRTC
    did, and is not offered) and every path stays on free ground."""
    data: dict = {"planner": planner, "budget": {"iterations": 3000}}
    if planner in ROADMAP_PLANNERS:
        data["roadmap"] = {"grow_iterations": 800, "expand_iterations": 200}
    profile = profile_from_dict(data, name=planner)
    roadmap = paths.build_roadmap(gentle_costmap, profile) if planner in ROADMAP_PLANNERS else None
    start, goal = (230.5, 174.5), (233.5, 114.5)  # a straight line between them is blocked
    path = plan_path(gentle_costmap, start, goal, profile, seed=1, roadmap=roadmap).waypoints_m
    np.testing.assert_allclose(path[[0, -1]], [start, goal])
    bad, closest = clearance_violations(load_map(GENTLE), gentle_costmap.half_width_m, path, step_m=0.25)
    assert len(bad) == 0, f"{len(bad)} points of the path too close to deep water (closest {closest:.3f} m)"
