"""The default observation of a batch of runs (`swarm.sim.observe.Observer`), checked against the
layout's definitions computed robot by robot: the nearest known unmarked mine and the table
neighbours in each robot's body frame. Observing some of the runs gives those runs' rows of
observing all of them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from tiny_missions import write_mission

import swarm.sim
from swarm.sim import observe

RUNS, ROBOTS = 3, 6


@pytest.fixture(scope="module")
def vec(tmp_path_factory: pytest.TempPathFactory):
    path: Path = write_mission(tmp_path_factory.mktemp("observe"), "observe", swarm={"count": ROBOTS})
    env = swarm.sim.vector_env(mission=path, num_envs=RUNS, seed=3)
    env.reset(seed=3)
    rng = np.random.default_rng(0)
    for _ in range(150):  # everyone on the map
        env.step(rng.uniform(-1.0, 1.0, (RUNS, ROBOTS, 3)).astype(np.float32))
    return env


def _column(env, name: str) -> int:
    return env.envs[0].layout.names.index(name)


def _body(dxy: np.ndarray, heading: float) -> np.ndarray:
    c, s = np.cos(heading), np.sin(heading)
    return np.array([c * dxy[0] + s * dxy[1], -s * dxy[0] + c * dxy[1]])


@pytest.mark.parametrize("dense_pairs", [observe.DENSE_NEAREST_PAIRS, 0], ids=["dense", "k-d tree"])
def test_nearest_unmarked_mine_in_the_body_frame(vec, dense_pairs, monkeypatch) -> None:
    """Runs with none, one and many mines found, half of them marked: each robot sees the offset
    to the nearest unmarked one (0 when there is none), whichever way it is searched for."""
    monkeypatch.setattr(observe, "DENSE_NEAREST_PAIRS", dense_pairs)
    rng = np.random.default_rng(7)
    saved = [(r.objects_m, r.object_marker) for r in vec.world.runs]
    try:
        for run, count in zip(vec.world.runs, (0, 1, 40), strict=True):
            run.objects_m = rng.uniform(-50.0, 50.0, (count, 2)) + run.robot_state[0, :2]
            run.object_marker = np.where(np.arange(count) % 2 == 0, -1, 0)
        obs = vec.observer.observe(vec.world, list(range(RUNS)))
        x = _column(vec, "mine_dx_m")
        for b, run in enumerate(vec.world.runs):
            unmarked = run.objects_m[run.object_marker < 0]
            for i in range(ROBOTS):
                xy, heading = run.robot_state[i, :2], run.robot_state[i, 2]
                if len(unmarked):
                    nearest = unmarked[np.argmin(np.hypot(*(unmarked - xy).T))]
                    expected = _body(nearest - xy, heading)
                else:
                    expected = np.zeros(2)
                np.testing.assert_allclose(obs[b, i, x : x + 2], expected, rtol=1e-6, atol=1e-4)
    finally:
        for run, (objects, marker) in zip(vec.world.runs, saved, strict=True):
            run.objects_m, run.object_marker = objects, marker


def test_the_nearest_open_object_follows_every_change_to_the_objects_and_their_markers(vec) -> None:
    """The observer keeps which objects are open from step to step; each way a run's objects
    change (found, marked, unmarked, moved, all marked) shows in the very next observation's
    nearest-object columns, as a fresh observer sees them."""
    runs = list(range(RUNS))
    x = _column(vec, "mine_dx_m")
    run = vec.world.runs[1]
    saved = (run.objects_m, run.object_marker)

    def fresh() -> np.ndarray:
        return observe.Observer(vec.observer.setup, vec.observer.layout, RUNS).observe(vec.world, runs)

    me = run.robot_state[0, :2]
    changes = [
        lambda: setattr(run, "objects_m", np.array([me + 1.0, me + 30.0])),
        lambda: setattr(run, "object_marker", np.array([-1, -1])),
        lambda: run.set_marker(0, 3),
        lambda: run.set_marker(0, -1),
        lambda: setattr(run, "objects_m", np.array([me - 2.0, me + 30.0])),
        lambda: setattr(run, "object_marker", np.array([5, 5])),
    ]
    try:
        run.objects_m, run.object_marker = np.empty((0, 2)), np.empty(0, np.int64)
        before = vec.observer.observe(vec.world, runs)[1, 0, x : x + 2]
        for change in changes:
            change()
            now = vec.observer.observe(vec.world, runs)[..., x : x + 2]
            np.testing.assert_array_equal(now, fresh()[..., x : x + 2])
            assert not np.array_equal(now[1, 0], before) or change is changes[0]
            before = now[1, 0]
    finally:
        run.objects_m, run.object_marker = saved


def test_neighbours_are_the_table_robots_in_the_body_frame(vec) -> None:
    """Each present neighbour's columns: the offset to that robot in the body frame, its
    distance, and whether their link works; absent slots are zero."""
    obs = vec.observer.observe(vec.world, list(range(RUNS)))
    first = _column(vec, "n0_present")
    k = vec.envs[0].layout.neighbours
    checked = 0
    for b, run in enumerate(vec.world.runs):
        links = run.links.adjacency.tocsr()
        here = run.alive & run.on_map
        table = vec.observer._tables[b]
        for i in np.flatnonzero(here):
            for slot in range(k):
                cols = obs[b, i, first + 5 * slot : first + 5 * slot + 5]
                j = table[i, slot]
                if j < 0 or not here[j]:
                    assert not cols.any()
                    continue
                offset = _body(run.robot_state[j, :2] - run.robot_state[i, :2], run.robot_state[i, 2])
                np.testing.assert_allclose(cols[1:3], offset, rtol=1e-6, atol=1e-4)
                assert cols[0] == 1.0
                assert cols[3] == pytest.approx(np.hypot(*offset), rel=1e-6, abs=1e-4)
                assert cols[4] == float(links[i, j] != 0)
                checked += 1
    assert checked >= RUNS * ROBOTS  # most robots have neighbours


def test_observing_some_runs_gives_their_rows_of_all(vec) -> None:
    every = vec.observer.observe(vec.world, list(range(RUNS)))
    some = vec.observer.observe(vec.world, [2, 0])
    np.testing.assert_array_equal(some, every[[2, 0]])


@pytest.mark.parametrize("size", [3, 4], ids=["odd", "even"])
def test_terrain_patch_samples_the_cells_around_each_robot_in_its_body_frame(tmp_path, size) -> None:
    """Sample (i, j) lies (i - (k-1)/2) h forward and (j - (k-1)/2) h left of the robot; its speed
    fraction and its elevation above the robot's own cell come from the cell under it, the one the
    physics drives on there (the nearest edge cell off the map)."""
    path = write_mission(tmp_path, "patch", swarm={"count": ROBOTS})
    config = swarm.sim.SimConfig(patch_size=size, patch_spacing_m=1.5)
    env = swarm.sim.vector_env(mission=path, num_envs=2, seed=5, config=config)
    env.reset(seed=5)
    rng = np.random.default_rng(1)
    for _ in range(120):
        obs, *_ = env.step(rng.uniform(-1.0, 1.0, (2, ROBOTS, 3)).astype(np.float32))
    setup = env.observer.setup
    beach, speed = setup.beach, setup.speed_grid
    cols = beach.shape[1]

    def cell(x: float, y: float) -> tuple[int, int]:  # as the physics finds the terrain under a point
        flat = int(env.world.setup.physics._cells(np.array([x]), np.array([y]))[0])
        return flat // cols, flat % cols

    first = _column(env, "speed_0_0")
    elev = _column(env, "elevation_0_0_m")
    checked = 0
    for b in range(2):
        for i in np.flatnonzero(env.world.in_agents[b]).tolist():
            x, y, th = env.world.robot_state[b, i, :3]
            own = beach.elevation_m[cell(x, y)]
            for q in range(size * size):
                fwd = (q // size - (size - 1) / 2) * 1.5
                left = (q % size - (size - 1) / 2) * 1.5
                rc = cell(x + np.cos(th) * fwd - np.sin(th) * left, y + np.sin(th) * fwd + np.cos(th) * left)
                assert obs[b, i, first + q] == pytest.approx(speed[rc], abs=1e-6)
                want = np.clip(np.float32(beach.elevation_m[rc]) - np.float32(own), -5.0, 5.0)
                assert obs[b, i, elev + q] == pytest.approx(want, abs=1e-5)
                checked += 1
    assert checked >= 2 * ROBOTS * size * size // 2


def test_the_patch_reads_the_cells_the_physics_reads_from_the_middle_of_the_map_to_past_its_edge(
    tmp_path,
) -> None:
    """Robots put anywhere from the map's middle to past its corner, at every heading: each sample
    is the cell the physics finds under it (the nearest edge cell off the map), on both sides of
    the distance from the edge where the observation stops clamping its cell lookups. The grid's
    values are made different in every cell, so reading a neighbouring cell cannot pass."""
    path = write_mission(tmp_path, "edges", swarm={"count": ROBOTS})
    env = swarm.sim.vector_env(mission=path, num_envs=2, seed=2, config=swarm.sim.SimConfig(patch_size=5))
    env.reset(seed=2)
    setup, world = env.observer.setup, env.world
    beach = setup.beach
    rows, cols = beach.shape
    x0, y0 = beach.origin_m
    reach_m = env.observer.patch_reach_cells * beach.cell_m
    rng = np.random.default_rng(4)
    grid = rng.permutation(rows * cols * 2).reshape(-1, 2).astype(np.float32)
    env.observer.patch_grid = grid
    first = _column(env, "speed_0_0")
    checked = 0
    width_m = cols * beach.cell_m
    places = (0.5 * width_m, reach_m - 1e-9, reach_m, reach_m + 0.37, 2.0, 1.0, 0.3, -2.0)
    for along in (*places, width_m - reach_m, width_m - 1.0, width_m + 2.0):
        for b in range(2):
            world.robot_state[b, :, 0] = x0 + along + rng.uniform(-0.01, 0.01, ROBOTS)
            world.robot_state[b, :, 1] = y0 + rng.uniform(-3.0, rows * beach.cell_m + 3.0, ROBOTS)
            world.robot_state[b, :, 2] = rng.uniform(-np.pi, np.pi, ROBOTS)
        obs = env.observer.observe(world, [0, 1])
        for b in range(2):
            for i in range(ROBOTS):
                x, y, th = world.robot_state[b, i, :3]
                fwd = (np.arange(25) // 5 - 2.0) * 1.0
                left = (np.arange(25) % 5 - 2.0) * 1.0
                px = x + np.cos(th) * fwd - np.sin(th) * left
                py = y + np.sin(th) * fwd + np.cos(th) * left
                cells = setup.physics._cells(px, py)
                np.testing.assert_array_equal(obs[b, i, first : first + 25], grid[cells, 0])
                checked += 25
    assert checked == 11 * 2 * ROBOTS * 25


def test_a_lost_neighbour_shows_absent_until_the_radio_table_is_made_again(tmp_path) -> None:
    """The table is each robot's k nearest robots on the map when it was made (at a radio update
    or an arrival); a robot lost since is absent from it (present 0), not replaced, until the
    table is made again, which leaves it out."""
    path = write_mission(tmp_path, "lost", swarm={"count": ROBOTS})
    env = swarm.sim.vector_env(mission=path, num_envs=1, seed=7)
    env.reset(seed=7)
    rng = np.random.default_rng(2)
    for _ in range(150):
        env.step(rng.uniform(-1.0, 1.0, (1, ROBOTS, 3)).astype(np.float32))
    world, observer = env.world, env.observer
    on = np.flatnonzero(world.alive[0] & world.on_map[0])
    assert len(on) >= 4
    observer.observe(world, [0])
    table = observer._tables[0].copy()
    lost = int(table[on[0], 0])
    world.alive[0, lost] = False  # as a hazard takes it
    obs = observer.observe(world, [0])
    np.testing.assert_array_equal(observer._tables[0], table)
    first = _column(env, "n0_present")
    for i, slot in zip(*np.nonzero(table == lost), strict=True):
        assert not obs[0, i, first + 5 * slot : first + 5 * slot + 5].any()
    observer._table_version[0] = -1  # as the next radio update does
    observer.observe(world, [0])
    here = np.flatnonzero(world.alive[0] & world.on_map[0])
    xy = world.robot_state[0, here, :2]
    d = np.linalg.norm(xy[:, None] - xy[None], axis=2)
    k = min(observer.layout.neighbours, len(here) - 1)
    for row, i in enumerate(here):
        want = here[np.argsort(d[row], kind="stable")[1 : k + 1]]
        assert set(observer._tables[0, i, :k]) == set(want.tolist())
    assert lost not in observer._tables[0]


def test_every_pair_table_is_the_k_d_tree_one() -> None:
    """The small-run table (every pair looked at) names the same neighbours, nearest first, as
    scipy's k-d tree; links come out of the CSR arrays as the dense matrix has them."""
    from scipy.sparse import random as sparse_random
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(4)
    xy = rng.uniform(0.0, 50.0, (200, 2))
    live = np.flatnonzero(rng.random(200) < 0.7)
    k = 4
    table = np.full((200, k), -1, dtype=np.intp)
    observe._nearest(xy, live, k, table)
    _, idx = cKDTree(xy[live]).query(xy[live], k=k + 1)
    np.testing.assert_array_equal(table[live], live[idx[:, 1:]])
    assert (table[np.setdiff1d(np.arange(200), live)] == -1).all()
    links = sparse_random(200, 200, density=0.05, random_state=1, format="csr")
    links.sort_indices()
    linked = np.zeros((200, k), bool)
    observe._linked_slots(links.indptr, links.indices, table, linked)
    dense = links.toarray() != 0
    want = np.where(table >= 0, dense[np.arange(200)[:, None], np.maximum(table, 0)], False)
    np.testing.assert_array_equal(linked, want)
