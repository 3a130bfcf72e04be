"""OMPL path planning over a `BeachMap`: the planner's cost map, planner profiles, one path, many.

`build_costmap(beach_map, robot)` marks impassable ground, inflates it by the footprint and costs
each metre by terrain; `load_profile("planners/optimal.yaml")` reads which OMPL planner to run,
with which objective and budget; `plan_path(cm, start, goal, profile, seed=0)` returns one
`PathResult` (numpy waypoints and stats); `plan_many(cm, pairs, profile, seed=0, workers=4)`
plans many robots on worker processes; `export_benchmark(cm, profiles, "bench.log")` writes
OMPL's benchmark log."""

from swarm.planning.batch import plan_many
from swarm.planning.benchmark import export_benchmark
from swarm.planning.costmap import (
    CostMap,
    EndpointError,
    NoPathError,
    PlanningError,
    build_costmap,
    mode_speeds,
)
from swarm.planning.paths import PathResult, Roadmap, build_roadmap, plan_path
from swarm.planning.profiles import DEFAULT_PROFILE, PlannerProfile, load_profile

__all__ = [
    "DEFAULT_PROFILE",
    "CostMap",
    "EndpointError",
    "NoPathError",
    "PathResult",
    "PlannerProfile",
    "PlanningError",
    "Roadmap",
    "build_costmap",
    "build_roadmap",
    "export_benchmark",
    "load_profile",
    "mode_speeds",
    "plan_many",
    "plan_path",
]
