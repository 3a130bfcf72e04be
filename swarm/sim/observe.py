"""The default task's observation (`swarm.sim.layout`: 106 floats per robot by default) of any runs
of a batch (`swarm.sim.world.World`) at once.

Everything that is per robot (own state, the terrain patch in the body frame, links, the task's
goal and progress) is computed over all the runs' robots in one pass; what depends on a run's own
objects (its radio neighbour tables, the nearest object still to mark, its clock) run by run. The
numbers are the same for a run whether it is observed alone (`SwarmEnv`, B = 1) or with others
(`swarm.sim.vector_env`): every operation is elementwise over robots.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from swarm.sim.control import to_body
from swarm.sim.layout import ELEVATION_CLIP_M, ROLES, ObservationLayout
from swarm.sim.runview import FOLLOW, RETURN
from swarm.sim.setup import MissionSetup

#: Up to this many point pairs, nearest neighbours come from a dense distance matrix (faster
#: than building a k-d tree for a handful of objects).
DENSE_NEAREST_PAIRS = 200_000


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
        self.patch_grid = setup.patch_grid
        k = layout.neighbours
        #: (runs, n, k) each robot's table neighbours (-1: none) and whether the link to each works.
        self._tables = np.full((runs, self.n, k), -1, dtype=np.intp)
        self._linked = np.zeros((runs, self.n, k), bool)
        #: (runs,) the radio update and the count of robots on the map each run's table is of.
        self._table_version = np.full(runs, -1, dtype=np.int64)
        self._table_count = np.full(runs, -1, dtype=np.int64)

    def reset_run(self, b: int) -> None:
        """Forget run b's neighbour tables (a new episode)."""
        self._tables[b] = -1
        self._linked[b] = False
        self._table_version[b] = -1

    def flat_cell(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Row-major index of the cell under each point (the nearest edge cell outside the map)."""
        bm = self.setup.beach
        rows, cols = bm.shape
        c = np.clip(((x - bm.origin_m[0]) / bm.cell_m).astype(np.intp), 0, cols - 1)
        r = np.clip(((y - bm.origin_m[1]) / bm.cell_m).astype(np.intp), 0, rows - 1)
        return r * cols + c

    def observe(self, world, runs: list[int]) -> np.ndarray:
        """(len(runs), n, obs_dim) float32: every robot's observation in runs `runs` now."""
        n, lay, r = self.n, self.layout, len(runs)
        every = runs == list(range(world.B))

        def pick(a: np.ndarray) -> np.ndarray:
            a = a if every else a[runs]
            return a.reshape(r * n, *a.shape[2:])

        m = r * n
        out = np.zeros((m, lay.size), np.float32)
        sl = lay.slices
        s = pick(world.robot_state)
        heading = s[:, 2]
        c, si = np.cos(heading), np.sin(heading)
        own = out[:, sl["own"]]
        own[:, 0:2] = s[:, :2]
        own[:, 2] = c
        own[:, 3] = si
        own[:, 4:7] = s[:, 3:6]
        own[:, 7] = pick(world.energy_wh)
        own[:, 8] = pick(world.inverted)
        own[:, 9] = pick(world.submersion)
        own[:, 10] = pick(world.slip)
        np.clip(own[:, 7:8], 0.0, self.capacity_wh, out=own[:, 7:8])
        own[:, 7] /= self.capacity_wh
        np.clip(own[:, 10], 0.0, 1.0, out=own[:, 10])
        own[np.arange(m), 11 + pick(world.phase)] = 1.0
        # terrain patch in the body frame: one gather of (speed, elevation) per sample
        fx, fy = self.patch_offsets
        c, si = c[:, None], si[:, None]
        px = s[:, 0:1] + c * fx - si * fy
        py = s[:, 1:2] + si * fx + c * fy
        patch = self.patch_grid[self.flat_cell(px, py)]  # (m, k*k, 2)
        k = lay.patch_size
        # the middle sample of an odd patch is the robot's own cell
        mid = patch[:, (k * k) // 2, 1] if k % 2 else None
        here = mid if mid is not None else self.patch_grid[self.flat_cell(s[:, 0], s[:, 1]), 1]
        out[:, sl["patch_speed"]] = patch[:, :, 0]
        np.clip(
            patch[:, :, 1] - here[:, None],
            -ELEVATION_CLIP_M,
            ELEVATION_CLIP_M,
            out=out[:, sl["patch_elevation"]],
        )
        links = out[:, sl["links"]]
        hops = pick(world.source_hops)
        links[:, 0] = pick(world.link_degree)
        links[:, 1] = hops >= 0
        links[:, 2] = hops
        links[:, 3] = pick(world.isolated_s)
        task = out[:, sl["task"]]
        task[np.arange(m), pick(world.role)] = 1.0
        nr = len(ROLES)
        command = pick(world.command)
        goal_all = world.route_goal()
        progress_all = world.routes.progress()
        if not every:
            rows = (np.asarray(runs)[:, None] * n + np.arange(n)).ravel()
            goal_all, progress_all = goal_all[rows], progress_all[rows]
        goal = np.where(((command == FOLLOW) | (command == RETURN))[:, None], goal_all, pick(world.target_m))
        gb = to_body(goal - s[:, :2], heading)
        task[:, nr : nr + 2] = gb
        task[:, nr + 2] = np.hypot(gb[:, 0], gb[:, 1])
        task[:, nr + 3] = progress_all
        task[:, nr + 4] = pick(world.marking) >= 0
        here = pick(world.alive & world.on_map).reshape(r, n)
        self._observe_neighbours(world, runs, here, s, out[:, sl["neighbours"]])
        self._observe_objects(world, runs, s, task[:, nr + 5 : nr + 7])
        clearance = self.setup.clearance
        t_s = world.t_s[runs]
        task[:, nr + 7] = np.repeat(np.minimum(1.0, t_s / self.setup.time_limit_s), n)
        if clearance is not None:
            waiting = np.array([not world.runs[b].cleared for b in runs])
            task[:, nr + 8] = np.repeat(np.where(waiting, np.maximum(0.0, clearance.at_s - t_s), 0.0), n)
        return out.reshape(r, n, lay.size)

    # neighbours ---------------------------------------------------------------------------------------
    def _refresh(self, run, b: int, on: np.ndarray) -> None:
        """Run b's neighbour table, (n, k) ids of each robot's k nearest live robots, as of the last
        radio update or change in who is on the map (the table its radio keeps), and which of
        those links work: fixed until the next radio update, which refreshes the table."""
        live = np.flatnonzero(on)
        k = self.layout.neighbours
        table = np.full((self.n, k), -1, dtype=np.intp)
        q = min(k + 1, len(live))
        if q >= 2:
            xy = run.robot_state[live, :2]
            _, idx = cKDTree(xy, balanced_tree=False, compact_nodes=False).query(xy, k=q)
            table[live, : q - 1] = live[idx[:, 1:]]  # the first is itself
        self._tables[b] = table
        # the working links as sorted keys row * N + col (CSR columns ascend within each row)
        links, big_n = run.links, run.links.n_nodes
        keys = np.repeat(np.arange(big_n, dtype=np.int64), np.diff(links.indptr)) * big_n + links.indices
        query = np.repeat(np.arange(self.n), k).astype(np.int64) * big_n
        query += np.maximum(table, 0).ravel()
        at = np.minimum(np.searchsorted(keys, query), max(len(keys) - 1, 0))
        hit = keys[at] == query if len(keys) else np.zeros(len(query), bool)
        self._linked[b] = hit.reshape(self.n, k) & (table >= 0)

    def _observe_neighbours(
        self, world, runs: list[int], here: np.ndarray, state: np.ndarray, block: np.ndarray
    ) -> None:
        """Each robot's table neighbours at their current positions, every run at once: present,
        body-frame offset, distance, radio link working (zero for robots not on the map).
        `here` (r, n): on the map; `state` (r * n, 6); `block` (r * n, 5 k) is written."""
        k = self.layout.neighbours
        if k == 0:
            return
        n, r = self.n, len(runs)
        counts = np.count_nonzero(here, axis=1)
        versions = np.fromiter((world.runs[b].links_version for b in runs), np.int64, r)
        stale = (versions != self._table_version[runs]) | (counts != self._table_count[runs])
        for j in np.flatnonzero(stale).tolist():
            b = runs[j]
            self._refresh(world.runs[b], b, here[j])
            self._table_version[b], self._table_count[b] = versions[j], counts[j]
        table = self._tables[runs].reshape(r * n, k)
        valid = table >= 0
        me = valid.any(axis=1) & here.ravel()
        if not me.any():
            return
        other = np.maximum(table, 0) + (np.arange(r) * n).repeat(n)[:, None]  # rows of `state`
        present = valid & here.ravel()[other] & me[:, None]
        rel = to_body(state[other, :2] - state[:, None, :2], state[:, 2])
        view = np.zeros((r * n, k, 5), np.float32)
        view[..., 0] = present
        view[..., 1:3] = rel
        view[..., 3] = np.hypot(rel[..., 0], rel[..., 1])
        view[..., 4] = self._linked[runs].reshape(r * n, k)
        view[~present] = 0.0
        block[me] = view[me].reshape(-1, 5 * k)

    def _observe_objects(self, world, runs: list[int], state: np.ndarray, block: np.ndarray) -> None:
        """Body-frame offset to the nearest object found and not yet marked, every run at once
        where the runs' objects are few (dense distances, padded), by a k-d tree where many."""
        n = self.n
        dense: list[int] = []
        for j, b in enumerate(runs):
            run = world.runs[b]
            if not len(run.object_marker):
                continue
            count = int(np.count_nonzero(run.object_marker < 0))
            if not count:
                continue
            if count * n <= DENSE_NEAREST_PAIRS:
                dense.append(j)
                continue
            rows = slice(j * n, (j + 1) * n)
            objs = run.objects_m[run.object_marker < 0]
            xy = state[rows, :2]
            near = cKDTree(objs).query(xy)[1]
            block[rows] = to_body(objs[near] - xy, state[rows, 2])
        if not dense:
            return
        width = max(len(world.runs[runs[j]].objects_m) for j in dense)
        objs = np.zeros((len(dense), width, 2))
        open_ = np.zeros((len(dense), width), bool)
        for d, j in enumerate(dense):
            run = world.runs[runs[j]]
            objs[d, : len(run.objects_m)] = run.objects_m
            open_[d, : len(run.objects_m)] = run.object_marker < 0
        rows = (np.asarray(dense)[:, None] * n + np.arange(n)).ravel()
        xy = state[rows, :2].reshape(len(dense), n, 2)
        d2 = (xy[:, :, None, 0] - objs[:, None, :, 0]) ** 2 + (xy[:, :, None, 1] - objs[:, None, :, 1]) ** 2
        near = np.argmin(np.where(open_[:, None, :], d2, np.inf), axis=2)  # the first of equals, as alone
        target = np.take_along_axis(objs, near[..., None], axis=1)
        block[rows] = to_body((target - xy).reshape(-1, 2), state[rows, 2])
