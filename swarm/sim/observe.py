"""The default task's observation (`swarm.sim.layout`: 106 floats per robot by default) of any runs
of a batch (`swarm.sim.world.World`) at once.

Everything but the nearest object still to mark is written robot by robot in one numba pass over
all the runs' robots (`_fill`: own state, the terrain patch in the body frame, the table
neighbours, links, the task's goal and progress); the nearest object in a second pass over the
runs with few objects (k-d trees where many); each run's radio neighbour table is remade only at
its radio updates and arrivals. The numbers are the same for a run whether it is observed alone
(`SwarmEnv`, B = 1) or with others (`swarm.sim.vector_env`): every robot's numbers come from its
own run's arrays alone.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np
from scipy.spatial import cKDTree

from swarm.robot.driving import to_body
from swarm.sim.layout import ELEVATION_CLIP_M, ROLES, ObservationLayout
from swarm.sim.pair_kernels import nearest_others
from swarm.sim.physics_kernels import cell_index, cell_index_inside
from swarm.sim.runview import FOLLOW, RETURN
from swarm.sim.setup import MissionSetup

#: Up to this many robot-object pairs in a run, the nearest object comes from every pair (faster
#: than building and querying a k-d tree).
DENSE_NEAREST_PAIRS = 2_000_000
#: Up to this many robots on the map, a run's neighbour table comes from every pair (fewer
#: steps than a grid search).
BRUTE_NEAREST_ROBOTS = 256


class OpenObjects(NamedTuple):
    """The objects found and not yet marked of some runs of a batch, as `_observe_objects` looks
    for the nearest: every pair for the runs with few, a k-d tree for those with many."""

    dense: np.ndarray  # places in the runs observed of the runs with few (every pair looked at)
    objs: np.ndarray  # (objects, 2) their objects, run after run
    open_: np.ndarray  # (objects,) which are still open
    starts: np.ndarray  # where each of those runs' objects begin (one more than the runs)
    many: list[int]  # places of the runs with many (a k-d tree each)


class Observer:
    """The default observation of the runs of one batch (module docstring)."""

    def __init__(self, setup: MissionSetup, layout: ObservationLayout, runs: int) -> None:
        self.setup = setup
        self.layout = layout
        self.n = setup.n
        self.capacity_wh = setup.capacity_wh
        k, h = layout.patch_size, layout.patch_spacing_m
        offs = (np.arange(k) - (k - 1) / 2) * h
        fx, fy = np.meshgrid(offs, offs, indexing="ij")
        #: Body-frame sample offsets of the terrain patch (rows forward, columns left), flattened.
        self.patch_offsets = (fx.ravel(), fy.ravel())
        #: How far the patch reaches from the robot, in cells, with a cell to spare for rounding:
        #: a robot this far inside the grid samples it without clamping (`_fill`'s fast path).
        self.patch_reach_cells = float(np.hypot(fx, fy).max() / setup.beach.cell_m + 1.0)
        self.patch_grid = setup.patch_grid
        k = layout.neighbours
        #: (runs, n, k) each robot's table neighbours (-1: none) and whether the link to each works.
        self._tables = np.full((runs, self.n, k), -1, dtype=np.intp)
        self._linked = np.zeros((runs, self.n, k), bool)
        #: (runs,) the radio update each run's table is of; (runs, n) who was on the map then.
        self._table_version = np.full(runs, -1, dtype=np.int64)
        self._table_on = np.zeros((runs, self.n), bool)
        #: `_open_objects`' last answer, the world and runs it is for, and their `objects_version`.
        self._objects_cache: tuple[object, list[int], np.ndarray, OpenObjects] | None = None

    def reset_run(self, b: int) -> None:
        """Forget run b's neighbour tables (a new episode)."""
        self._tables[b] = -1
        self._linked[b] = False
        self._table_version[b] = -1
        self._table_on[b] = False

    def observe(self, world, runs: list[int]) -> np.ndarray:
        """(len(runs), n, obs_dim) float32: every robot's observation in runs `runs` now."""
        n, lay, r = self.n, self.layout, len(runs)
        out = np.empty((r * n, lay.size), np.float32)  # `_fill` writes every column
        sl = lay.slices
        on = world.alive & world.on_map
        self._refresh_stale(world, runs, on[runs])
        bm, routes = self.setup.beach, world.routes
        fx, fy = self.patch_offsets
        _fill(
            out, np.asarray(runs, dtype=np.intp), n, world.robot_state, world.energy_wh, world.inverted,
            world.submersion, world.slip, world.phase, float(self.capacity_wh), fx, fy, self.patch_grid,
            float(bm.origin_m[0]), float(bm.origin_m[1]), 1.0 / bm.cell_m, bm.shape[0], bm.shape[1],
            self.patch_reach_cells, world.link_degree, world.source_hops, world.isolated_s, world.role,
            world.command, FOLLOW, RETURN, routes.points, routes.start, routes.end, routes.cursor,
            world.target_m, world.marking, self._tables, self._linked, on, sl["patch_speed"].start,
            sl["neighbours"].start, sl["links"].start, sl["task"].start, len(ROLES),
        )  # fmt: skip
        task = out[:, sl["task"]]
        nr = len(ROLES)
        self._observe_objects(world, runs, task[:, nr + 5 : nr + 7])
        clearance = self.setup.clearance
        t_s = world.t_s[runs]
        task[:, nr + 7] = np.repeat(np.minimum(1.0, t_s / self.setup.time_limit_s), n)
        if clearance is not None:
            waiting = np.array([not world.runs[b].cleared for b in runs])
            task[:, nr + 8] = np.repeat(np.where(waiting, np.maximum(0.0, clearance.at_s - t_s), 0.0), n)
        return out.reshape(r, n, lay.size)

    # neighbours ---------------------------------------------------------------------------------------
    def _refresh_stale(self, world, runs: list[int], here: np.ndarray) -> None:
        """Refresh the neighbour tables of the runs whose radio updated or where a robot arrived on
        the map since their table was made. `here` (len(runs), n): on the map now.

        A run's table: (n, k) ids of each robot's k nearest robots on the map, as of the last
        radio update or arrival on the map (the table its radio keeps), and which of those links
        work; fixed until the next radio update. A robot lost since shows as absent (`_fill`)
        until then, as a radio's table loses a silent neighbour."""
        if self.layout.neighbours == 0:
            return
        versions = world.links_version[runs]
        arrived = (here & ~self._table_on[runs]).any(axis=1)
        stale = np.flatnonzero((versions != self._table_version[runs]) | arrived)
        if not len(stale):
            return
        run_ids = np.asarray(runs, dtype=np.intp)
        picked = run_ids[stale]  # every stale run in one pass
        links = [world.runs[b].links for b in picked.tolist()]
        indptr = np.stack([x.indptr for x in links])
        starts = np.concatenate(([0], np.cumsum(indptr[:, -1], dtype=np.int64)))
        indices = np.concatenate([x.indices for x in links])
        _refresh(world.robot_state, picked, here[stale], indptr, indices, starts, self._tables, self._linked)
        self._table_version[run_ids[stale]], self._table_on[run_ids[stale]] = versions[stale], here[stale]

    def _observe_objects(self, world, runs: list[int], block: np.ndarray) -> None:
        """Body-frame offset to the nearest object found and not yet marked: every pair looked at
        for the runs whose objects are few (all of them in one pass), a k-d tree where many."""
        n = self.n
        found = self._open_objects(world, runs)
        for j in found.many:
            run = world.runs[runs[j]]
            objs = run.objects_m[run.object_marker < 0]
            xy = run.robot_state[:, :2]
            near = cKDTree(objs).query(xy)[1]
            block[j * n : (j + 1) * n] = to_body(objs[near] - xy, run.robot_state[:, 2])
        if len(found.dense):
            picked = np.asarray(runs, np.intp)[found.dense]
            _nearest_open(
                world.robot_state, picked, found.dense * n, found.objs, found.open_, found.starts, block
            )

    def _open_objects(self, world, runs: list[int]) -> OpenObjects:
        """For `_observe_objects`, made again only when a run's objects or markers have changed
        (`World.objects_version`)."""
        versions = world.objects_version[runs]
        cached = self._objects_cache
        same = cached is not None and cached[0] is world and cached[1] == runs
        if same and np.array_equal(cached[2], versions):
            return cached[3]
        dense: list[int] = []
        many: list[int] = []
        for j in np.flatnonzero(world.object_count[runs] > 0).tolist():
            count = int(np.count_nonzero(world.runs[runs[j]].object_marker < 0))
            if count:
                (dense if count * self.n <= DENSE_NEAREST_PAIRS else many).append(j)
        picked = [world.runs[runs[j]] for j in dense]
        objs = np.concatenate([run.objects_m for run in picked]) if picked else np.empty((0, 2))
        open_ = np.concatenate([run.object_marker < 0 for run in picked]) if picked else np.empty(0, bool)
        starts = np.cumsum([0] + [len(run.objects_m) for run in picked])
        found = OpenObjects(np.asarray(dense, np.intp), objs, open_, starts, many)
        self._objects_cache = (world, list(runs), versions, found)
        return found


@numba.njit(cache=True, error_model="numpy")
def _fill(
    out, runs, n, state, energy, inverted, submersion, slip, phase, capacity,
    fx, fy, grid, origin_x, origin_y, inv_cell, grid_rows, grid_cols, reach,
    degree, hops, isolated, role, command, follow, ret, points, start, end, cursor, target, marking,
    tables, linked, here, patch_at, neighbours_at, links_at, task_at, n_roles,
):  # fmt: skip
    """Every column of `out` (row r * n + i: robot i of run `runs[r]`), zero for the nearest object
    and the clock: one pass per robot, each number computed in numpy's order and precision (the
    module docstring's promise: alone or batched, the same floats). A robot whose whole patch is
    inside the grid (`reach` cells from its edges) reads its cells without clamping them."""
    cap32 = np.float32(capacity)
    clip = np.float32(ELEVATION_CLIP_M)
    k2 = fx.shape[0]
    kn = tables.shape[2]
    width = out.shape[1]
    for r in range(runs.shape[0]):
        b = runs[r]
        for i in range(n):
            row = b * n + i
            line = out[r * n + i]
            for col in range(width):
                line[col] = 0.0
            x, y, th = state[b, i, 0], state[b, i, 1], state[b, i, 2]
            c, s = np.cos(th), np.sin(th)
            line[0], line[1], line[2], line[3] = x, y, c, s
            line[4], line[5], line[6] = state[b, i, 3], state[b, i, 4], state[b, i, 5]
            e = np.float32(energy[b, i])
            line[7] = min(max(e, np.float32(0.0)), cap32) / cap32
            line[8] = inverted[b, i]
            line[9] = submersion[b, i]
            line[10] = min(max(np.float32(slip[b, i]), np.float32(0.0)), np.float32(1.0))
            line[11 + phase[b, i]] = 1.0
            # the terrain patch in the body frame, one cell per sample: the cell the physics reads
            # there; elevation against the robot's own cell (the patch's centre when it has one)
            here_elev = grid[cell_index(x, y, origin_x, origin_y, inv_cell, grid_rows, grid_cols), 1]
            u, v = (x - origin_x) * inv_cell, (y - origin_y) * inv_cell
            inside = u >= reach and v >= reach and u + reach < grid_cols and v + reach < grid_rows
            for q in range(k2):
                px = x + c * fx[q] - s * fy[q]
                py = y + s * fx[q] + c * fy[q]
                if inside:
                    cell = cell_index_inside(px, py, origin_x, origin_y, inv_cell, grid_cols)
                else:
                    cell = cell_index(px, py, origin_x, origin_y, inv_cell, grid_rows, grid_cols)
                line[patch_at + q] = grid[cell, 0]
                d = grid[cell, 1] - here_elev
                line[patch_at + k2 + q] = min(max(d, -clip), clip)
            # table neighbours present now, body-frame offset, distance, link working
            if here[b, i]:
                for j in range(kn):
                    other = tables[b, i, j]
                    if other < 0 or not here[b, other]:
                        continue
                    dx = state[b, other, 0] - x
                    dy = state[b, other, 1] - y
                    fwd = c * dx + s * dy
                    left = c * dy - s * dx
                    at = neighbours_at + 5 * j
                    line[at] = 1.0
                    line[at + 1] = fwd
                    line[at + 2] = left
                    line[at + 3] = math.sqrt(fwd * fwd + left * left)
                    line[at + 4] = linked[b, i, j]
            h = hops[b, i]
            line[links_at] = degree[b, i]
            line[links_at + 1] = h >= 0
            line[links_at + 2] = h
            line[links_at + 3] = isolated[b, i]
            line[task_at + role[b, i]] = 1.0
            if command[b, i] == follow or command[b, i] == ret:
                # the last point of its route, its own position without one
                last = end[row] - 1 if end[row] > start[row] else -1
                gx = points[last, 0] - x if last >= 0 else x - x
                gy = points[last, 1] - y if last >= 0 else y - y
            else:
                gx, gy = target[b, i, 0] - x, target[b, i, 1] - y
            fwd = c * gx + s * gy
            left = c * gy - s * gx
            line[task_at + n_roles] = fwd
            line[task_at + n_roles + 1] = left
            line[task_at + n_roles + 2] = math.sqrt(fwd * fwd + left * left)
            length = end[row] - start[row]  # the fraction of its route's waypoints passed, 1 without one
            line[task_at + n_roles + 3] = (cursor[row] - start[row]) / max(length, 1) if length > 0 else 1.0
            line[task_at + n_roles + 4] = marking[b, i] >= 0


@numba.njit(cache=True, error_model="numpy")
def _nearest(xy, live, k, table):
    """Rows `live` of `table`: each robot's k nearest other robots of `live` by squared distance,
    nearest first, ties to the lower id (every pair looked at)."""
    m = live.shape[0]
    best_d = np.empty(k)
    best_j = np.empty(k, np.intp)
    for a in range(m):
        i = live[a]
        count = 0
        for c in range(m):
            if c == a:
                continue
            j = live[c]
            dx = xy[j, 0] - xy[i, 0]
            dy = xy[j, 1] - xy[i, 1]
            d = dx * dx + dy * dy
            if count < k:
                at = count
                count += 1
            elif d < best_d[k - 1]:
                at = k - 1
            else:
                continue
            while at > 0 and best_d[at - 1] > d:
                best_d[at] = best_d[at - 1]
                best_j[at] = best_j[at - 1]
                at -= 1
            best_d[at] = d
            best_j[at] = j
        for slot in range(count):
            table[i, slot] = best_j[slot]


@numba.njit(cache=True, error_model="numpy")
def _refresh(state, runs, here, indptr, indices, starts, tables, linked):
    """The neighbour tables of runs `runs`, `here[r]` run r's robots on the map, its links' CSR
    `indptr[r]` and `indices[starts[r]:starts[r + 1]]`: every pair looked at in a run of few
    robots, a grid search in one of many (the same neighbours in the same order)."""
    k = tables.shape[2]
    for r in range(runs.shape[0]):
        b = runs[r]
        tables[b] = -1
        live = np.flatnonzero(here[r])
        if live.shape[0] <= BRUTE_NEAREST_ROBOTS:
            _nearest(state[b], live, k, tables[b])
        else:
            near = nearest_others(state[b, live, 0].copy(), state[b, live, 1].copy(), k)
            for a in range(live.shape[0]):
                for slot in range(k):
                    if near[a, slot] >= 0:
                        tables[b, live[a], slot] = live[near[a, slot]]
        _linked_slots(indptr[r], indices[starts[r] : starts[r + 1]], tables[b], linked[b])


@numba.njit(cache=True, error_model="numpy")
def _linked_slots(indptr, indices, table, out):
    """`out[i, s]`: whether robot i's link to its table neighbour `table[i, s]` works, from the
    radio's links in CSR form (columns ascending within each row)."""
    for i in range(table.shape[0]):
        lo, hi = indptr[i], indptr[i + 1]
        for slot in range(table.shape[1]):
            j = table[i, slot]
            if j < 0:
                out[i, slot] = False
                continue
            at = lo + np.searchsorted(indices[lo:hi], j)
            out[i, slot] = at < hi and indices[at] == j


@numba.njit(cache=True, error_model="numpy")
def _nearest_open(state, runs, rows, objs, open_, starts, block):
    """Rows `rows[d]` onward of `block`: for every robot of run `runs[d]`, the body-frame offset
    to the nearest of that run's objects `objs[starts[d]:starts[d + 1]]` still open (the first
    of equals), looked at pair by pair; untouched where the run has none open."""
    for d in range(runs.shape[0]):
        b, lo, hi = runs[d], starts[d], starts[d + 1]
        for i in range(state.shape[1]):
            x, y = state[b, i, 0], state[b, i, 1]
            best, at = np.inf, -1
            for q in range(lo, hi):
                if not open_[q]:
                    continue
                dx, dy = objs[q, 0] - x, objs[q, 1] - y
                d2 = dx * dx + dy * dy
                if d2 < best:
                    best, at = d2, q
            if at < 0:
                continue
            c, s = np.cos(state[b, i, 2]), np.sin(state[b, i, 2])
            dx, dy = objs[at, 0] - x, objs[at, 1] - y
            block[rows[d] + i, 0] = c * dx + s * dy
            block[rows[d] + i, 1] = c * dy - s * dx
