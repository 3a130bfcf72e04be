"""The planning a mine_clear run does while it goes, against the library way of doing it.

    python benchmarks/bench_replanning.py [--fields 20] [--routes 60] [--seed 0]

Safe-ground fields (`swarm.sim.standoff`, one per new set of found mines): Dial's bucket search
against scipy's multi-source Dijkstra (`scipy.sparse.csgraph.dijkstra`, `min_only`) over the same
8-connected free cells of mine_clear's map, from the cells `--safe-m` clear of `--fields` random
sets of 5 to 25 mines. Prints ms per field for each, the ratio, and whether the distances are
equal (they must be, float for float).

Takeover routes (`swarm.planning.router`: the default profile, RRT-Connect then OMPL's simplifier)
between `--routes` random pairs of free cell centres whose straight line is blocked, with the grid
motion validator (`swarm.planning.paths._motion_free`) against OMPL's own `DiscreteMotionValidator`
(a Python call per checked point). Prints ms per route for each, the ratio, and whether the paths
are equal (they must be, point for point).

One core, wall clock, best of `--repeat`.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from scipy.sparse.csgraph import dijkstra

from swarm.mission.load import load_mission
from swarm.planning import build_costmap, paths
from swarm.planning.costmap import CostMap
from swarm.planning.profiles import DEFAULT_PROFILE
from swarm.sim.standoff import SafeGround, free_cell_graph

MINE_CLEAR = Path(__file__).resolve().parents[1] / "missions" / "mine_clear.yaml"


def best_of(repeat: int, fn) -> tuple[float, object]:
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def bench_fields(cm: CostMap, rng: np.random.Generator, count: int, safe_m: float, repeat: int) -> None:
    graph = free_cell_graph(~cm.blocked, cm.cell_m)
    free = np.argwhere(~cm.blocked)
    ours = theirs = 0.0
    equal = True
    for _ in range(count):
        cells = free[rng.choice(len(free), size=int(rng.integers(5, 26)), replace=False)]
        mines = np.column_stack(cm.center_of(cells[:, 0], cells[:, 1]))
        t, ground = best_of(repeat, lambda m=mines: SafeGround(cm, m, safe_m))
        ours += t
        sources = np.flatnonzero(ground.dist == 0.0)
        t, dist = best_of(repeat, lambda s=sources: dijkstra(graph, directed=False, indices=s, min_only=True))
        theirs += t
        equal &= bool(np.array_equal(dist, ground.dist))
    print(f"safe-ground fields ({count}, {(~cm.blocked).sum()} free cells, {safe_m:g} m clear):")
    print(f"  Dial's search (SafeGround, whole field) {ours / count * 1e3:7.1f} ms a field")
    print(f"  scipy Dijkstra (distances only)         {theirs / count * 1e3:7.1f} ms a field")
    print(f"  ratio {theirs / ours:.1f}x; distances equal: {'PASS' if equal else 'FAIL'}")


def bench_routes(cm: CostMap, rng: np.random.Generator, count: int, repeat: int) -> None:
    free = np.argwhere(~cm.blocked)
    pairs = []
    while len(pairs) < count:
        a, b = (
            np.array([float(v) for v in cm.center_of(*cell)])
            for cell in free[rng.integers(len(free), size=2)]
        )
        if not cm.segments_free(a[None], b[None])[0]:
            pairs.append((a, b))

    def plan_all() -> list[np.ndarray]:
        return [
            paths.plan_path(cm, a, b, DEFAULT_PROFILE, seed=k).waypoints_m for k, (a, b) in enumerate(pairs)
        ]

    ours, grid = best_of(repeat, plan_all)
    on_grid = paths._check_motions_on_grid
    paths._check_motions_on_grid = lambda si, cm: None  # OMPL's own validator throughout
    try:
        theirs, own = best_of(repeat, plan_all)
    finally:
        paths._check_motions_on_grid = on_grid
    equal = all(np.array_equal(x, y) for x, y in zip(grid, own, strict=True))
    print(
        f"takeover routes ({count}, profile {DEFAULT_PROFILE.name}: {DEFAULT_PROFILE.planner}, simplified):"
    )
    print(f"  grid motion validator   {ours / count * 1e3:7.2f} ms a route")
    print(f"  OMPL's own validator    {theirs / count * 1e3:7.2f} ms a route")
    print(f"  ratio {theirs / ours:.1f}x; paths equal: {'PASS' if equal else 'FAIL'}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--fields", type=int, default=20)
    ap.add_argument("--routes", type=int, default=60)
    ap.add_argument("--safe-m", type=float, default=60.0, help="mine_clear's standoff plus margin")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    mission = load_mission(MINE_CLEAR)
    cm = build_costmap(mission.beach_map, mission.robot_params, mission.terrain_library)
    rng = np.random.default_rng(args.seed)
    SafeGround(cm, np.zeros((1, 2)), args.safe_m)  # compile (or load) the kernels first
    bench_fields(cm, rng, args.fields, args.safe_m, args.repeat)
    bench_routes(cm, rng, args.routes, args.repeat)


if __name__ == "__main__":
    main()
