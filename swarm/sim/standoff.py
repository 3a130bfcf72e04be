"""Getting clear of a blast: from anywhere on the beach, the distance over drivable ground to the
nearest point clear of a set of marked mines, and the path there.

The nearest safe point as the crow flies can lie behind a dune or a driftwood log, and an OMPL
route around it may lead through the standoff instead of away from it (mine_clear lost robots
that way). One multi-source shortest-path search from every safe cell over the cost map's free
cells, 8-connected (a step to any of the 8 neighbours that is free too, as long as the distance
between their centres), answers for every robot at once.

The search is Dial's: with every step at least one cell long, cells in buckets one cell wide
are settled bucket by bucket, in any order within a bucket, because no cell can shorten another in
its own bucket. That is Dijkstra's answer without a heap: the same distances, float for float, as
`scipy.sparse.csgraph.dijkstra` over the same graph (tested), several times faster on a beach-sized
grid, which matters because a mine_clear run asks for a new field at each find. Among equally
short ways out, a cell steps to the first neighbour in `STEPS` order (straight steps before
diagonal ones), so the path does not depend on a heap's order; a path works out the steps of the
cells it passes only (`_walk`), not a whole field of them.
"""

from __future__ import annotations

import math
from functools import cached_property

import numba
import numpy as np
from scipy.sparse import coo_matrix, csr_matrix

from swarm.planning.costmap import CostMap, clamped_cell

#: The 8 neighbour steps (row, col), straight ones first: the order in which a cell picks its next
#: step among equally short ways to safe ground.
STEPS = np.array([(0, 1), (1, 0), (0, -1), (-1, 0), (1, 1), (1, -1), (-1, 1), (-1, -1)], np.int64)
#: Buckets kept at once: a step is under two cells long, so a cell in bucket k reaches k + 2 at most.
_BUCKETS = 4
#: Predecessor of a cell without one (safe, blocked or cut off), as scipy's.
NO_STEP = -9999


def free_cell_graph(free: np.ndarray, cell_m: float) -> csr_matrix:
    """The graph the search walks, as scipy takes one: cell row * cols + col joined to each of its
    8 neighbours that is free too by the distance between centres (each edge once: undirected).
    The reference the search is checked and timed against with `scipy.sparse.csgraph.dijkstra`
    (tests, `benchmarks/bench_replanning.py`)."""
    rows, cols = free.shape
    heads, tails, weights = [], [], []
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
        r0, r1, c0, c1 = 0, rows - dr, max(0, -dc), cols - max(0, dc)
        r, c = np.nonzero(free[r0:r1, c0:c1] & free[r0 + dr : r1 + dr, c0 + dc : c1 + dc])
        heads.append((r + r0) * cols + c + c0)
        tails.append((r + r0 + dr) * cols + c + c0 + dc)
        weights.append(np.full(len(r), cell_m * float(np.hypot(dr, dc))))
    edges = (np.concatenate(heads), np.concatenate(tails))
    return coo_matrix((np.concatenate(weights), edges), shape=(free.size, free.size)).tocsr()


def near_any(cm: CostMap, objs: np.ndarray, radius_m: float) -> np.ndarray:
    """(rows, cols) bool: cells whose centre lies closer than `radius_m` to a point of `objs`. Each
    point looks only at the window of cells around it (`CostMap.cell_of` of its corners, one cell
    wider), with the centres `CostMap.center_of` gives and the distance a k-d tree computes (the
    root of the summed squared differences), so the mask is the one a query of every cell against
    a `cKDTree` of `objs` gives (`distance < radius_m`), at a fraction of its cost."""
    out = np.zeros(cm.shape, bool)
    points = np.ascontiguousarray(objs, dtype=np.float64).reshape(-1, 2)
    x0, y0 = (float(v) for v in cm.origin_m)
    _near_any(points, float(radius_m), x0, y0, float(cm.cell_m), out)
    return out


@numba.njit(cache=True)
def _near_any(points, radius_m, x0, y0, cell_m, out):
    """`near_any` point by point, in `cell_of`'s and `center_of`'s arithmetic."""
    nrows, ncols = out.shape
    for k in range(points.shape[0]):
        ox, oy = points[k, 0], points[k, 1]
        c0 = clamped_cell(ox - radius_m, x0, cell_m, ncols)
        r0 = clamped_cell(oy - radius_m, y0, cell_m, nrows)
        c1 = clamped_cell(ox + radius_m, x0, cell_m, ncols)
        r1 = clamped_cell(oy + radius_m, y0, cell_m, nrows)
        r0, c0 = max(r0 - 1, 0), max(c0 - 1, 0)
        r1, c1 = min(r1 + 1, nrows - 1), min(c1 + 1, ncols - 1)
        for r in range(r0, r1 + 1):
            dy = (y0 + (r + 0.5) * cell_m) - oy
            for c in range(c0, c1 + 1):
                dx = (x0 + (c + 0.5) * cell_m) - ox
                if math.sqrt(dx * dx + dy * dy) < radius_m:
                    out[r, c] = True


class SafeGround:
    """Distances and paths over free ground to the nearest free cell at least `safe_m` from every
    point of `objs`; with `dry` (a cell mask), to the nearest such cell on dry ground when there is
    one: the nearest clear cell can lie in the surf, where breakers roll a waiting robot over."""

    def __init__(
        self,
        cm: CostMap,
        objs: np.ndarray,
        safe_m: float,
        dry: np.ndarray | None = None,
    ) -> None:
        self.cm = cm
        self._free = np.ascontiguousarray(~cm.blocked)
        safe = self._free & ~near_any(cm, np.asarray(objs, dtype=np.float64).reshape(-1, 2), safe_m)
        if dry is not None and (safe & dry).any():
            safe &= dry
        self.dist = _distances_to(self._free, np.flatnonzero(safe), float(cm.cell_m))

    @cached_property
    def reach_m(self) -> float:
        """The largest finite distance to safe ground from any cell (-inf if none is finite): a
        bound on `distance_m` that answers "could anyone be that far?" without locating anyone."""
        finite = self.dist[np.isfinite(self.dist)]
        return float(finite.max()) if len(finite) else -np.inf

    def _node(self, xy: np.ndarray) -> np.ndarray:
        row, col = self.cm.cell_of(xy[..., 0], xy[..., 1])
        return row * self.cm.shape[1] + col

    def distance_m(self, xy: np.ndarray) -> np.ndarray:
        """Distance over free ground from each point's cell to safe ground (inf where none can be
        reached; 0 on safe ground)."""
        return self.dist[self._node(np.asarray(xy, dtype=np.float64).reshape(-1, 2))]

    def farthest_m(self, xy: np.ndarray) -> float:
        """The largest finite `distance_m` of the points `xy` (k, 2), -inf if none is finite: how
        far the farthest of them has to go (one compiled pass, `cell_of`'s arithmetic)."""
        xy = np.ascontiguousarray(xy, dtype=np.float64).reshape(-1, 2)
        x0, y0 = (float(v) for v in self.cm.origin_m)
        return _farthest(xy, self.dist, x0, y0, float(self.cm.cell_m), *self.cm.shape)

    def path(self, xy: np.ndarray) -> np.ndarray:
        """Waypoints (k, 2) from the free point `xy` along cell centres to the nearest safe cell;
        just `xy` where it is safe already or no safe ground can be reached from it."""
        xy = np.asarray(xy, dtype=np.float64).reshape(2)
        row, col = self.cm.cell_at(float(xy[0]), float(xy[1]))
        node = row * self.cm.shape[1] + col
        d = float(self.dist[node])
        if d == 0.0 or d == math.inf:  # on safe ground already (most retreats), or none reachable
            return xy[None]
        cells = _walk(self._free, self.dist, float(self.cm.cell_m), node)
        x, y = self.cm.center_of(cells // self.cm.shape[1], cells % self.cm.shape[1])
        return np.vstack([xy[None], np.column_stack([x, y])])


def _distances_to(
    free: np.ndarray, sources: np.ndarray, cell_m: float, capacity: int | None = None
) -> np.ndarray:
    """(rows * cols,) distance over `free` cells to the nearest of `sources` (flat indices; inf where
    none can be reached). `capacity`: queue entries to start with (a cell is queued once per
    improvement: about 1.2 times on mine_clear's beach, at most once per neighbour), quadrupled
    until the search fits."""
    rows, cols = free.shape
    # a border of blocked cells: every neighbour is one offset away, with no bounds to check
    padded = np.zeros((rows + 2, cols + 2), bool)
    padded[1:-1, 1:-1] = free
    sources = np.asarray(sources, dtype=np.int64)
    inner = (sources // cols + 1) * (cols + 2) + sources % cols + 1
    capacity = max(capacity or 2 * free.size, len(sources) + 1)  # the sources are queued first
    while True:
        dist, queued = _dial(padded.ravel(), cols + 2, inner, cell_m, capacity)
        if queued <= capacity:
            return np.ascontiguousarray(dist.reshape(rows + 2, cols + 2)[1:-1, 1:-1]).ravel()
        capacity *= 4


@numba.njit(cache=True)
def _dial(flat, stride, sources, cell_m, capacity):
    """Dial's multi-source search (module docstring) over a grid `flat` of rows `stride` long whose
    border cells are all blocked. Returns the distances and how many entries it queued: more than
    `capacity` means it ran out of room and stopped (call again with more)."""
    n = flat.shape[0]
    length = _step_lengths(cell_m)
    offset = STEPS[:, 0] * stride + STEPS[:, 1]
    dist = np.full(n, np.inf)
    # each bucket a linked list of queued entries (cell, its distance when queued)
    cell = np.empty(capacity, np.int64)
    key = np.empty(capacity)
    after = np.empty(capacity, np.int64)
    head = np.full(_BUCKETS, -1, np.int64)
    used = 0
    for s in sources:
        dist[s] = 0.0
        cell[used], key[used], after[used], head[0] = s, 0.0, head[0], used
        used += 1
    waiting = used
    inv = 1.0 / cell_m
    k = 0
    while waiting > 0:
        slot = k % _BUCKETS
        e = head[slot]
        head[slot] = -1
        while e >= 0:
            waiting -= 1
            u, d = cell[e], key[e]
            e = after[e]
            if d == dist[u]:  # else queued again since, nearer
                for q in range(8):
                    v = u + offset[q]
                    nd = d + length[q]
                    if flat[v] and nd < dist[v]:
                        if used == capacity:
                            return dist, capacity + 1
                        dist[v] = nd
                        b = max(int(nd * inv), k) % _BUCKETS  # k itself only by rounding
                        cell[used], key[used], after[used], head[b] = v, nd, head[b], used
                        used += 1
                        waiting += 1
            if e < 0:  # entries queued into this bucket meanwhile (rounding)
                e = head[slot]
                head[slot] = -1
        k += 1
    return dist, used


@numba.njit(cache=True)
def _step_of(flat, rows, cols, dist, length, v):
    """Cell v's step toward safe ground: the first neighbour in `STEPS` order through which its
    distance is reached (exactly: the same sum that set it); `NO_STEP` on safe ground, blocked or
    cut-off cells."""
    dv = dist[v]
    if not (0.0 < dv < np.inf):
        return NO_STEP
    r, c = v // cols, v % cols
    for q in range(8):
        rr, cc = r + STEPS[q, 0], c + STEPS[q, 1]
        u = rr * cols + cc
        if 0 <= rr < rows and 0 <= cc < cols and flat[u] and dist[u] + length[q] == dv:
            return u
    return NO_STEP


@numba.njit(cache=True)
def _walk(free, dist, cell_m, v):
    """The cells from cell v (not included) step by step (`_step_of`) to safe ground: the steps of
    the cells a path passes, not of the whole grid."""
    rows, cols = free.shape
    flat = free.ravel()
    length = _step_lengths(cell_m)
    out = []
    u = _step_of(flat, rows, cols, dist, length, v)
    while u >= 0:
        out.append(u)
        u = _step_of(flat, rows, cols, dist, length, u)
    return np.array(out, dtype=np.int64)


@numba.njit(cache=True)
def _step_lengths(cell_m):
    """The length of each of `STEPS` (m): a cell straight, its diagonal."""
    length = np.empty(8)
    length[:4] = cell_m
    length[4:] = cell_m * math.sqrt(2.0)
    return length


@numba.njit(cache=True)
def _farthest(xy, dist, x0, y0, cell_m, rows, cols):
    """`SafeGround.farthest_m`: the largest finite distance of the points' cells (-inf if none)."""
    out = -np.inf
    for k in range(xy.shape[0]):
        d = dist[clamped_cell(xy[k, 1], y0, cell_m, rows) * cols + clamped_cell(xy[k, 0], x0, cell_m, cols)]
        if d < np.inf and d > out:
            out = d
    return out
