"""Small synthetic beaches for the planning tests, and an independent clearance check."""

from __future__ import annotations

import itertools
from importlib.resources import files
from pathlib import Path

import numpy as np
import pytest
import shapely
from shapely.geometry import Polygon

from swarm.planning.costmap import CostMap, build_costmap
from swarm.planning.profiles import PlannerProfile, RoadmapSettings
from swarm.robot.params import RobotParams, load_robot
from swarm.world.beachmap import BeachMap, Region

ROBOT_YAML = Path(str(files("swarm") / "data" / "robots" / "skid4.yaml"))
CLASSES = ("wet_hard_sand", "soft_sand", "boulder", "deep_water")
CELL_M = 0.5
ROWS, COLS = 40, 60  # 20 m north-south, 30 m east-west
WALL_COL = 30  # boulders at x 15.0 .. 15.5
GAP_ROWS = slice(16, 24)  # the gap: y 8 .. 12
KEEP_OUT = Polygon([(4.0, 14.0), (9.0, 14.0), (9.0, 18.0), (4.0, 18.0)])
#: Small budgets for the tests: the shipped profiles' planners, tuned down for 30 m maps.
OPTIMAL = PlannerProfile(
    name="optimal-test",
    planner="BITstar",
    params={"samples_per_batch": 100},
    objective="terrain_cost",
    iterations=1500,
    interpolate_m=1.0,
)
ROADMAP = PlannerProfile(
    name="roadmap-test",
    planner="PRM",
    params={"max_nearest_neighbors": 10},
    objective="terrain_cost",
    interpolate_m=1.0,
    roadmap=RoadmapSettings(grow_iterations=600, expand_iterations=200, connect_neighbours=10),
)

START, GOAL = (3.0, 4.0), (27.0, 4.0)  # straight between them hits the wall


def wall_map(*, gap: bool = True, keep_out: bool = True) -> BeachMap:
    """60 x 40 cells of wet hard sand: a boulder wall across x = 15 m with a 4 m gap (y 8..12),
    deep water along the south edge (y < 1.5 m), a keep-out square (4..9, 14..18) in the west."""
    terrain = np.zeros((ROWS, COLS), dtype=np.int8)
    terrain[:, WALL_COL] = CLASSES.index("boulder")
    if gap:
        terrain[GAP_ROWS, WALL_COL] = 0
    terrain[:3, :] = CLASSES.index("deep_water")
    regions = {}
    if keep_out:
        regions["minefield"] = Region("minefield", "keep_out", KEEP_OUT)
    return BeachMap(
        name="wall",
        cell_m=CELL_M,
        origin_m=(0.0, 0.0),
        terrain_classes=CLASSES,
        terrain=terrain,
        elevation_m=np.zeros((ROWS, COLS), dtype=np.float32),
        regions=regions,
    )


def soft_band_map() -> BeachMap:
    """All wet hard sand but a soft-sand band x 6..24, y 8..12: straight across it is 24 m with
    18 m in soft sand; round its north edge is ~25.6 m on hard sand, cheaper by terrain cost."""
    terrain = np.zeros((ROWS, COLS), dtype=np.int8)
    terrain[16:24, 12:48] = CLASSES.index("soft_sand")
    return BeachMap(
        name="soft-band",
        cell_m=CELL_M,
        origin_m=(0.0, 0.0),
        terrain_classes=CLASSES,
        terrain=terrain,
        elevation_m=np.zeros((ROWS, COLS), dtype=np.float32),
    )


@pytest.fixture(scope="session")
def robot() -> RobotParams:
    return load_robot(ROBOT_YAML)


@pytest.fixture(scope="session")
def wall_costmap(robot: RobotParams) -> CostMap:
    return build_costmap(wall_map(), robot)


def clearance_violations(beach: BeachMap, half_width_m: float, waypoints: np.ndarray, step_m: float = 0.01):
    """Points along the path (every `step_m`, waypoints included) closer than `half_width_m` to a
    boulder or deep-water cell (as squares), to a keep-out region, or to the map edge.

    Independent of the cost map: geometry from the BeachMap alone.
    """
    pts = [waypoints[:1]]
    for a, b in itertools.pairwise(waypoints):
        n = max(2, int(np.ceil(np.hypot(*(b - a)) / step_m)) + 1)
        pts.append(a + np.linspace(0.0, 1.0, n)[1:, None] * (b - a))
    pts = np.vstack(pts)
    bad_classes = [
        beach.terrain_classes.index(c) for c in ("boulder", "deep_water") if c in beach.terrain_classes
    ]
    rr, cc = np.nonzero(np.isin(beach.terrain, bad_classes))
    cx = beach.origin_m[0] + (cc + 0.5) * beach.cell_m
    cy = beach.origin_m[1] + (rr + 0.5) * beach.cell_m
    h = beach.cell_m / 2
    worst = np.full(len(pts), np.inf)
    for k in range(0, len(pts), 2000):
        p = pts[k : k + 2000]
        dx = np.maximum(np.abs(p[:, None, 0] - cx[None, :]) - h, 0.0)
        dy = np.maximum(np.abs(p[:, None, 1] - cy[None, :]) - h, 0.0)
        worst[k : k + 2000] = np.hypot(dx, dy).min(axis=1) if len(cx) else np.inf
    for region in beach.regions_of_kind("keep_out"):
        worst = np.minimum(worst, shapely.distance(region.geometry, shapely.points(pts)))
    xmin, ymin, xmax, ymax = beach.bounds_m
    edge = np.minimum.reduce([pts[:, 0] - xmin, xmax - pts[:, 0], pts[:, 1] - ymin, ymax - pts[:, 1]])
    worst = np.minimum(worst, edge)
    return pts[worst < half_width_m - 1e-9], float(worst.min())
