"""Getting clear of a blast over drivable ground: the distances are scipy's Dijkstra's over the
8-connected free cells, float for float; each step is the first of the shortest in `STEPS` order;
the path ends clear of every mine, runs over free cells only, is as long as the distance says,
and is never shorter than the straight line; the cells near the mines are those a k-d tree finds;
the router's batched `reachable_many` agrees with `reachable` point by point."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from swarm.mission.load import load_mission
from swarm.planning import build_costmap
from swarm.planning.router import Router
from swarm.sim.standoff import (
    NO_STEP,
    STEPS,
    SafeGround,
    _distances_to,
    _step_lengths,
    _step_of,
    _walk,
    free_cell_graph,
    near_any,
)

MINE_CLEAR = Path(__file__).resolve().parents[2] / "missions" / "mine_clear.yaml"


@pytest.fixture(scope="module")
def costmap():
    mission = load_mission(MINE_CLEAR)
    return build_costmap(mission.beach_map, mission.robot_params, mission.terrain_library)


def test_paths_to_safe_ground_are_free_clear_and_as_long_as_the_distance(costmap) -> None:
    cm = costmap
    mines = np.array([[238.1, 113.2], [237.9, 98.0], [297.4, 106.6], [237.3, 125.9], [360.1, 108.6]])
    safe_m = 60.0
    ground = SafeGround(cm, mines, safe_m)
    rng = np.random.default_rng(0)
    starts = mines[rng.integers(len(mines), size=200)] + rng.uniform(-50, 50, size=(200, 2))
    starts = starts[cm.is_free(starts[:, 0], starts[:, 1])]
    row, col = cm.cell_of(starts[:, 0], starts[:, 1])
    starts = np.column_stack(cm.center_of(row, col))  # from cell centres: the distance is exact
    assert len(starts) > 100
    dist = ground.distance_m(starts)
    assert np.isfinite(dist).mean() > 0.9
    for xy, d in zip(starts, dist, strict=True):
        if not np.isfinite(d):
            continue
        path = ground.path(xy)
        length = float(np.hypot(*np.diff(path, axis=0).T).sum())
        assert length == pytest.approx(d, abs=1e-6)
        assert np.min(np.hypot(*(mines - path[-1]).T)) >= safe_m
        if len(path) > 1:
            assert cm.segments_free(path[:-1], path[1:]).all()
        # never shorter than the way out of the standoff as the crow flies
        gap = safe_m - float(np.min(np.hypot(*(mines - xy).T)))
        assert length >= gap - cm.cell_m
    safe = dist == 0
    assert safe.any() and (cKDTree(mines).query(starts[safe])[0] >= safe_m).all()


def test_reach_bounds_every_distance_to_safe_ground(costmap) -> None:
    cm = costmap
    mines = np.array([[238.1, 113.2], [237.9, 98.0], [297.4, 106.6]])
    ground = SafeGround(cm, mines, 60.0)
    finite = ground.dist[np.isfinite(ground.dist)]
    assert ground.reach_m == finite.max() > 0
    rows, cols = np.nonzero(~cm.blocked)
    d = ground.distance_m(np.column_stack(cm.center_of(rows, cols)))
    assert (d[np.isfinite(d)] <= ground.reach_m).all()
    nowhere = SafeGround(cm, mines, 1e6)  # no cell is clear: none finite
    assert nowhere.reach_m == -np.inf


def test_the_farthest_distance_is_the_largest_finite_distance_m(costmap) -> None:
    """`farthest_m` (one compiled pass) is the largest finite `distance_m` of the points, on
    random points over and beyond the map (cut-off cells among them), and -inf with none finite."""
    cm = costmap
    mines = np.array([[238.1, 113.2], [237.9, 98.0], [297.4, 106.6]])
    ground = SafeGround(cm, mines, 60.0)
    rng = np.random.default_rng(2)
    xmin, ymin, xmax, ymax = cm.bounds_m
    for k in (1, 3, 40, 400):
        xy = rng.uniform((xmin - 5, ymin - 5), (xmax + 5, ymax + 5), size=(k, 2))
        d = ground.distance_m(xy)
        finite = d[np.isfinite(d)]
        assert ground.farthest_m(xy) == (finite.max() if len(finite) else -np.inf)
    assert SafeGround(cm, mines, 1e6).farthest_m(xy) == -np.inf


def test_near_any_is_a_kd_tree_query_of_every_cell(costmap) -> None:
    """The windowed mask is exactly `distance < radius` from a k-d tree of the points, at every
    cell, with points near and beyond the map's edges and radii from under a cell to most of it."""
    cm = costmap
    rows, cols = np.indices(cm.shape)
    centres = np.column_stack([c.ravel() for c in cm.center_of(rows, cols)])
    x0, y0, x1, y1 = cm.bounds_m
    rng = np.random.default_rng(3)
    for radius_m in (0.3, 17.3, 70.0, 400.0):
        objs = np.column_stack([rng.uniform(x0 - 50, x1 + 50, 6), rng.uniform(y0 - 50, y1 + 50, 6)])
        want = (cKDTree(objs).query(centres)[0] < radius_m).reshape(cm.shape)
        assert np.array_equal(near_any(cm, objs, radius_m), want)


def _scipy_distances(free: np.ndarray, sources: np.ndarray, cell_m: float) -> np.ndarray:
    """The reference: scipy's multi-source Dijkstra over the same graph."""
    if not len(sources):
        return np.full(free.size, np.inf)
    return dijkstra(free_cell_graph(free, cell_m), directed=False, indices=sources, min_only=True)


def _next_steps(free: np.ndarray, dist: np.ndarray, cell_m: float) -> np.ndarray:
    """Every cell's step toward safe ground (`_step_of`): the whole field a path's walk must
    follow cell by cell."""
    rows, cols = free.shape
    flat, length = free.ravel(), _step_lengths(cell_m)
    return np.array([_step_of(flat, rows, cols, dist, length, v) for v in range(free.size)], np.int64)


def _check_steps(free: np.ndarray, dist: np.ndarray, pred: np.ndarray, cell_m: float) -> None:
    """Each reachable cell not safe steps to the first neighbour in `STEPS` order whose distance
    plus the step is exactly its own; safe, blocked and cut-off cells have no step."""
    rows, cols = free.shape
    lengths = cell_m * np.hypot(*STEPS.T.astype(float))
    for v in range(free.size):
        if not (0.0 < dist[v] < np.inf):
            assert pred[v] == NO_STEP
            continue
        r, c = divmod(v, cols)
        ways = [
            (rr * cols + cc)
            for (dr, dc), step in zip(STEPS.tolist(), lengths, strict=True)
            if 0 <= (rr := r + dr) < rows
            and 0 <= (cc := c + dc) < cols
            and free[rr, cc]
            and dist[rr * cols + cc] + step == dist[v]
        ]
        assert pred[v] == ways[0]


def _check_walks(free: np.ndarray, dist: np.ndarray, pred: np.ndarray, cell_m: float) -> None:
    """A path's walk, step by step from one cell, passes the cells the whole field's steps chain
    from it, to a safe cell."""
    for v in np.flatnonzero((dist > 0) & np.isfinite(dist)).tolist():
        chain = []
        u = int(pred[v])
        while u != NO_STEP:
            chain.append(u)
            u = int(pred[u])
        walk = _walk(free, dist, cell_m, v)
        np.testing.assert_array_equal(walk, chain)
        assert dist[walk[-1]] == 0.0


@pytest.mark.parametrize("seed", range(6))
def test_distances_are_scipys_dijkstra_on_small_grids(seed) -> None:
    """Random free cells (walls reaching every edge, so steps off a row's end would show), random
    sources (none, one, many), cell sizes that round differently."""
    rng = np.random.default_rng(seed)
    rows, cols = rng.integers(1, 40, size=2)
    free = rng.random((rows, cols)) < rng.uniform(0.5, 0.95)
    cell_m = [1.0, 0.5, 0.3, 2.7, 1e-3, 7.1][seed]
    share = [0.0, 0.002, 0.05, 0.3, 0.02, 0.1][seed]
    sources = np.flatnonzero(free.ravel() & (rng.random(free.size) < share))
    dist = _distances_to(free, sources, cell_m)
    np.testing.assert_array_equal(dist, _scipy_distances(free, sources, cell_m))
    pred = _next_steps(free, dist, cell_m)
    _check_steps(free, dist, pred, cell_m)
    _check_walks(free, dist, pred, cell_m)
    # a queue that starts too small grows until the search fits, with the same answer
    np.testing.assert_array_equal(_distances_to(free, sources, cell_m, capacity=4), dist)


def test_distances_on_the_beach_are_scipys_dijkstra(costmap) -> None:
    """mine_clear's map and mines, with and without the dry-ground rule."""
    cm = costmap
    mines = np.array([[238.1, 113.2], [237.9, 98.0], [297.4, 106.6], [237.3, 125.9], [360.1, 108.6]])
    free = ~cm.blocked
    dry = np.zeros(cm.shape, bool)
    dry[cm.shape[0] // 2 :] = True
    for kw in ({}, {"dry": dry}):
        ground = SafeGround(cm, mines, 60.0, **kw)
        sources = np.flatnonzero(ground.dist == 0.0)
        assert len(sources) > 1000 and np.isfinite(ground.dist[ground.dist > 0]).sum() > 10_000
        np.testing.assert_array_equal(ground.dist, _scipy_distances(free, sources, cm.cell_m))
        # a path follows the field's steps cell by cell to safe ground
        pred = _next_steps(free, ground.dist, cm.cell_m)
        far = np.flatnonzero(np.isfinite(ground.dist) & (ground.dist > 30.0))[::997]
        rows, cols = np.divmod(far, cm.shape[1])
        x, y = cm.center_of(rows, cols)
        for v, p in zip(far.tolist(), np.column_stack([x, y]), strict=True):
            chain, u = [], int(pred[v])
            while u != NO_STEP:
                chain.append(u)
                u = int(pred[u])
            cx, cy = cm.center_of(np.array(chain) // cm.shape[1], np.array(chain) % cm.shape[1])
            np.testing.assert_array_equal(ground.path(p), np.vstack([p[None], np.column_stack([cx, cy])]))


def test_reachable_many_is_reachable_of_each_point(costmap) -> None:
    cm = costmap
    router = Router(cm, seed=1)
    xmin, ymin, xmax, ymax = cm.bounds_m
    rng = np.random.default_rng(3)
    pts = np.column_stack([rng.uniform(xmin - 20, xmax + 20, 3000), rng.uniform(ymin - 20, ymax + 20, 3000)])
    assert not cm.is_free(pts[:, 0], pts[:, 1]).all()  # some land on blocked ground or in the water
    expected = np.array([router.reachable(p) for p in pts])
    assert router.reachable_many(pts).tobytes() == expected.tobytes()
    assert router.reachable_many(np.empty((0, 2))).shape == (0, 2)
