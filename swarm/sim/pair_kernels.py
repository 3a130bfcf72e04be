"""Compiled kernels for the radio graph of a batch of runs (`swarm.sim.comms`) and the mine
sensors (`swarm.sim.sensing`): the loops over robots and pairs that numpy can only do with sorts,
k-d trees and Python loops over runs.

Every kernel does the arithmetic of the numpy or scipy code it replaces, operation for operation
(squared distances as ``dx * dx + dy * dy``, square roots; no transcendental functions, no fast
math), so it gives the same answers bit for bit; tests/sim/test_comms_kernels.py and
tests/sim/test_sensing.py pin each to a reference.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from swarm.planning.detection import MIN_LATERAL_M

#: Robots per grid cell the nearest-neighbour search aims at.
_CELL_ROBOTS = 4.0
#: Most grid cells along either side (a swarm strung out along a line).
_MAX_CELLS = 4096
#: Most grid cells per robot (a swarm in a few tight clusters).
_MAX_GRID = 16
#: Up to this many robots in a run, its candidate pairs are read off a pair matrix (`_emit_pairs`).
_DENSE_EMIT = 256


@numba.njit(cache=True)
def table_candidates(
    xy: np.ndarray,
    live: np.ndarray,
    runs: np.ndarray,
    fixed: np.ndarray,
    ff_keys: np.ndarray,
    k: int,
    r2_rr: float,
    r_rf: float,
    big_n: int,
) -> tuple[np.ndarray, np.ndarray]:
    """Candidate pair keys ``b * N^2 + i * N + j`` (i < j, sorted) of the runs ``runs[r]`` with
    neighbour tables: robots at `xy` (R, n, 2), `live` (R, n) those with a position. A robot pair
    is a candidate when either end has the other among its `k` nearest live robots (itself
    included) at squared distance below `r2_rr`, as a k-d tree query with that upper bound; a
    robot-fixed pair when ``sqrt(dx^2 + dy^2) <= r_rf`` (if r_rf > 0); the run's fixed-fixed keys
    `ff_keys` follow its other keys.

    A run where some robot's k-th and (k+1)-th nearest are at the same distance (robots launched
    from one spot) has no single answer: the k-d tree keeps whichever it visits first. Such a run
    is flagged in the second output, without keys, for the caller to ask the k-d tree."""
    n_runs, n = live.shape
    f = len(fixed)
    nn = np.int64(big_n) * big_n
    total = 0
    for r in range(n_runs):
        total += np.count_nonzero(live[r])
    # k: a pair per table entry; one spare place for `_emit_pairs`' branchless writes
    keys = np.empty(total * (k + f) + n_runs * len(ff_keys) + 1, np.int64)
    tie = np.zeros(n_runs, np.bool_)
    m = 0
    for r in range(n_runs):
        idx = np.flatnonzero(live[r])
        px = xy[r, idx, 0].copy()
        py = xy[r, idx, 1].copy()
        nbr = _nearest(px, py, k, r2_rr, False)
        if len(nbr) != len(idx):
            tie[r] = True
            continue
        base = runs[r] * nn
        m = _emit_pairs(nbr, idx, px, py, fixed, r_rf, n, big_n, base, keys, m)
        for key in ff_keys:
            keys[m] = base + key
            m += 1
    return keys[:m], tie


@numba.njit(cache=True, inline="always")
def _after(d_a: float, j_a: int, d_b: float, j_b: int, by_index: bool) -> bool:
    """Whether point j_a at squared distance d_a comes after point j_b at d_b: farther, or (if
    `by_index`) as far with a higher index."""
    return d_a > d_b or (by_index and d_a == d_b and j_a > j_b)


@numba.njit(cache=True)
def _nearest(px: np.ndarray, py: np.ndarray, k: int, r2: float, others: bool) -> np.ndarray:
    """(L, k) each point's k nearest points (itself included) with squared distance < r2, -1
    where fewer; empty (0, k) if some point's k-th and (k+1)-th nearest tie. With `others`, each
    point's k nearest other points instead, equal distances to the lower index, nearest first
    (never empty). A grid search: cells hold a few points each, and rings of cells are visited
    outwards until no unvisited point can come closer than the last one kept or than the range."""
    count = len(px)
    x0, y0 = px.min(), py.min()
    w, h = px.max() - x0, py.max() - y0
    # a few rings' worth of points for a table of k: fewer, larger cells for a long table
    cell, nx, ny, cx, cy = _grid(px - x0, py - y0, w, h, max(_CELL_ROBOTS, k / 4.0))
    slack = 1e-9 * (abs(x0) + abs(y0) + w + h + cell)  # rounding of the cells' edges
    start, members = _bin(cx * ny + cy, nx * ny)
    # the points in cell order: a cell's points lie together in memory, and neighbours follow
    # each other through the search
    px, py, cx, cy = px[members], py[members], cx[members], cy[members]
    kept = k if others else k + 1  # one more than needed, to see a tie at the table's edge
    best_d = np.empty(kept)  # a max-heap by distance, then index
    best_j = np.empty(kept, np.int64)  # the points' own indices
    out = np.full((count, k), -1, np.int64)
    for i in range(count):
        found = 0
        q = 0
        while True:
            for gx in range(max(cx[i] - q, 0), min(cx[i] + q, nx - 1) + 1):
                edge = abs(gx - cx[i]) == q
                for gy in range(max(cy[i] - q, 0), min(cy[i] + q, ny - 1) + 1):
                    if not edge and abs(gy - cy[i]) != q:
                        continue
                    c = gx * ny + gy
                    for j in range(start[c], start[c + 1]):
                        if others and j == i:
                            continue
                        dx = px[j] - px[i]
                        dy = py[j] - py[i]
                        found = _keep(dx * dx + dy * dy, members[j], r2, best_d, best_j, found, others)
            q += 1
            # the least distance from point i to a cell outside the rings visited so far
            bound = math.inf
            if cx[i] - q >= 0:
                bound = min(bound, px[i] - (x0 + (cx[i] - q + 1) * cell))
            if cx[i] + q < nx:
                bound = min(bound, x0 + (cx[i] + q) * cell - px[i])
            if cy[i] - q >= 0:
                bound = min(bound, py[i] - (y0 + (cy[i] - q + 1) * cell))
            if cy[i] + q < ny:
                bound = min(bound, y0 + (cy[i] + q) * cell - py[i])
            if bound == math.inf:
                break
            bound = max(bound - slack, 0.0)
            if bound * bound >= r2 or (found == kept and bound * bound > best_d[0]):
                break
        if others:  # the heap, nearest first
            for s in range(found - 1, 0, -1):
                d_last, j_last = best_d[s], best_j[s]
                out[members[i], s] = best_j[0]
                _sift_down(best_d, best_j, s, d_last, j_last, others)
            if found:
                out[members[i], 0] = best_j[0]
            continue
        if found == kept:  # drop the farthest; a tie if the next farthest is as far
            farthest = best_d[0]
            _sift_down(best_d, best_j, k, best_d[k], best_j[k], others)
            if best_d[0] == farthest:
                return np.empty((0, k), np.int64)
            found = k
        out[members[i], :found] = best_j[:found]
    return out


@numba.njit(cache=True)
def nearest_others(px: np.ndarray, py: np.ndarray, k: int) -> np.ndarray:
    """(L, k) each point's k nearest other points, nearest first, equal distances to the lower
    index, -1 where fewer: the order of comparing every pair (`_nearest` with `others`)."""
    if len(px) == 0:
        return np.full((0, k), -1, np.int64)
    return _nearest(px, py, k, math.inf, True)


@numba.njit(cache=True)
def _grid(
    x: np.ndarray, y: np.ndarray, w: float, h: float, per_cell: float
) -> tuple[float, int, int, np.ndarray, np.ndarray]:
    """Square cells over the box [0, w] x [0, h] of the points (x, y): their side, the cells
    along x and y, and each point's cell. Sized for `per_cell` points a cell on average, then made
    smaller while the points crowd into few cells (a swarm in clusters), within a cell budget."""
    count = len(x)
    cell = max(math.sqrt(w * h * per_cell / count), max(w, h) / _MAX_CELLS, 1e-9)
    while True:
        nx, ny = int(w / cell) + 1, int(h / cell) + 1
        cx = np.minimum(x / cell, nx - 1).astype(np.int64)
        cy = np.minimum(y / cell, ny - 1).astype(np.int64)
        crowd = np.bincount(cx * ny + cy)
        # the robots a robot shares its cell with, on average over the robots
        shared = np.sum(crowd * crowd) / count
        smaller = cell * math.sqrt(per_cell / shared)
        if shared <= 2.0 * per_cell or (w / smaller + 1.0) * (h / smaller + 1.0) > _MAX_GRID * count:
            return cell, nx, ny, cx, cy
        cell = smaller


@numba.njit(cache=True)
def _keep(
    d2: float, j: int, r2: float, heap_d: np.ndarray, heap_j: np.ndarray, found: int, by_index: bool
) -> int:
    """Offer point j at squared distance d2 to the max-heap of the nearest points found so far
    (full at len(heap_d)): taken if in range and before the last kept (`after`), which it then
    replaces. Returns the heap's size."""
    if not d2 < r2:
        return found
    if found < len(heap_d):  # not full: sift up from the end
        at = found
        while at > 0 and _after(d2, j, heap_d[(at - 1) >> 1], heap_j[(at - 1) >> 1], by_index):
            heap_d[at] = heap_d[(at - 1) >> 1]
            heap_j[at] = heap_j[(at - 1) >> 1]
            at = (at - 1) >> 1
        heap_d[at] = d2
        heap_j[at] = j
        return found + 1
    if not _after(heap_d[0], heap_j[0], d2, j, by_index):
        return found
    _sift_down(heap_d, heap_j, found, d2, j, by_index)
    return found


@numba.njit(cache=True)
def _sift_down(heap_d: np.ndarray, heap_j: np.ndarray, size: int, d2: float, j: int, by_index: bool) -> None:
    """Put (d2, j) at the root of the max-heap of `size` entries and sift it down."""
    at = 0
    while True:
        child = 2 * at + 1
        if child >= size:
            break
        if child + 1 < size and _after(
            heap_d[child + 1], heap_j[child + 1], heap_d[child], heap_j[child], by_index
        ):
            child += 1
        if not _after(heap_d[child], heap_j[child], d2, j, by_index):
            break
        heap_d[at] = heap_d[child]
        heap_j[at] = heap_j[child]
        at = child
    heap_d[at] = d2
    heap_j[at] = j


@numba.njit(cache=True)
def _bin(cell: np.ndarray, cells: int) -> tuple[np.ndarray, np.ndarray]:
    """Counting sort of points by cell: (cells + 1,) start of each cell's points, and the points."""
    start = np.zeros(cells + 1, np.int64)
    for c in cell:
        start[c + 1] += 1
    for c in range(cells):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    members = np.empty(len(cell), np.int64)
    for p in range(len(cell)):
        members[fill[cell[p]]] = p
        fill[cell[p]] += 1
    return start, members


@numba.njit(cache=True)
def _emit_pairs(
    nbr: np.ndarray,
    idx: np.ndarray,
    px: np.ndarray,
    py: np.ndarray,
    fixed: np.ndarray,
    r_rf: float,
    n: int,
    big_n: int,
    base: int,
    keys: np.ndarray,
    m: int,
) -> int:
    """Write one run's robot keys from its neighbour lists `nbr` (points `idx` of the run) into
    `keys` from place m, in key order: for each robot, the robots after it that it lists or that
    list it, then the fixed nodes in range. Returns the next free place. Up to `_DENSE_EMIT`
    points, from a pair matrix read row by row (sorted as it is read, and written without a
    branch: `keys` has a spare place at its end for that); beyond, row by row from the lists."""
    count, k = nbr.shape
    if count <= _DENSE_EMIT:
        pair = np.zeros((count, count), np.uint8)
        for i in range(count):
            for j in nbr[i]:
                if j > i:
                    pair[i, j] = 1
                elif 0 <= j < i:
                    pair[j, i] = 1
        for a in range(count):
            first = base + idx[a] * big_n
            for b in range(a + 1, count):
                keys[m] = first + idx[b]
                m += pair[a, b]
            m = _emit_fixed(a, idx, px, py, fixed, r_rf, n, big_n, base, keys, m)
        return m
    # who lists each point that comes before it: the other half of its pairs
    back_start = np.zeros(count + 1, np.int64)
    for i in range(count):
        for j in nbr[i]:
            if 0 <= j < i:
                back_start[j + 1] += 1
    for i in range(count):
        back_start[i + 1] += back_start[i]
    fill = back_start[:-1].copy()
    back = np.empty(back_start[count], np.int64)
    for i in range(count):
        for j in nbr[i]:
            if 0 <= j < i:
                back[fill[j]] = i
                fill[j] += 1
    seen = np.full(count, -1, np.int64)
    row = np.empty(k + back_start[count], np.int64)
    for a in range(count):
        size = 0
        for j in nbr[a]:
            if j > a and seen[j] != a:
                seen[j] = a
                row[size] = j
                size += 1
        for s in range(back_start[a], back_start[a + 1]):
            j = back[s]
            if seen[j] != a:
                seen[j] = a
                row[size] = j
                size += 1
        _insertion_sort(row, size)
        for s in range(size):
            keys[m] = base + idx[a] * big_n + idx[row[s]]
            m += 1
        m = _emit_fixed(a, idx, px, py, fixed, r_rf, n, big_n, base, keys, m)
    return m


@numba.njit(cache=True)
def _emit_fixed(a, idx, px, py, fixed, r_rf, n, big_n, base, keys, m):
    """Point a's keys to the fixed nodes within `r_rf` (none if r_rf <= 0), from place m."""
    if r_rf > 0:
        for c in range(len(fixed)):
            dx = px[a] - fixed[c, 0]
            dy = py[a] - fixed[c, 1]
            if math.sqrt(dx * dx + dy * dy) <= r_rf:
                keys[m] = base + idx[a] * big_n + n + c
                m += 1
    return m


@numba.njit(cache=True)
def link_csr(
    u: np.ndarray, v: np.ndarray, margin: np.ndarray, nodes: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The symmetric CSR arrays (indptr, indices, margins) of the links u < v (in key order) over
    `nodes` nodes, and each node's link count. Each row lists its lower ends (pairs (u, r), by u),
    then its upper ends (pairs (r, v), by v): ascending, by a counting sort instead of a sort."""
    counts = np.zeros(nodes, np.int64)
    for e in range(len(u)):
        counts[u[e]] += 1
        counts[v[e]] += 1
    indptr = np.zeros(nodes + 1, np.int32)
    for r in range(nodes):
        indptr[r + 1] = indptr[r] + counts[r]
    fill = indptr[:-1].astype(np.int64)
    indices = np.empty(2 * len(u), np.int32)
    margins = np.empty(2 * len(u))
    for lower in (True, False):
        for e in range(len(u)):
            row, col = (v[e], u[e]) if lower else (u[e], v[e])
            indices[fill[row]] = col
            margins[fill[row]] = margin[e]
            fill[row] += 1
    return indptr, indices, margins, counts


@numba.njit(cache=True)
def components_and_hops(
    indptr: np.ndarray, indices: np.ndarray, k: int, n: int, big_n: int
) -> tuple[np.ndarray, np.ndarray]:
    """For k runs of `big_n` nodes each (block-diagonal CSR): (k, N) int32 connected-component
    labels, numbered within each run in the order of their lowest node (as scipy's
    `connected_components` numbers them), and (k, n) hops from each run's source (node n) to its
    robots, -1 when unreachable or there is no source. Breadth-first searches."""
    component = np.full((k, big_n), -1, np.int32)
    hops = np.full((k, n), -1, np.int64)
    depth = np.empty(big_n, np.int64)
    queue = np.empty(big_n, np.int64)
    for b in range(k):
        base = b * big_n
        depth[:] = -1  # reached nodes keep theirs: each search covers one component
        label = 0
        for s in range(big_n):
            if depth[s] < 0:
                reached = _breadth_first(indptr, indices, base, s, depth, queue)
                component[b, queue[:reached]] = label
                label += 1
        if big_n > n:
            depth[:] = -1
            _breadth_first(indptr, indices, base, n, depth, queue)
            hops[b] = depth[:n]
    return component, hops


@numba.njit(cache=True, inline="always")
def _breadth_first(
    indptr: np.ndarray, indices: np.ndarray, base: int, start: int, depth: np.ndarray, queue: np.ndarray
) -> int:
    """Breadth-first search from local node `start` of the run whose nodes begin at row `base`:
    `depth` of each node reached (unreached ones must be -1 and stay so), the nodes reached in
    order in `queue`; returns how many."""
    depth[start] = 0
    queue[0] = start
    head, tail = 0, 1
    while head < tail:
        a = queue[head]
        head += 1
        for e in range(indptr[base + a], indptr[base + a + 1]):
            c = indices[e] - base
            if depth[c] < 0:
                depth[c] = depth[a] + 1
                queue[tail] = c
                tail += 1
    return tail


@numba.njit(cache=True)
def carried_over(
    keys: np.ndarray, old_keys: np.ndarray, old_values: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """For each of the sorted `keys`: is it among the sorted, distinct `old_keys`, and its value in
    `old_values` if so (0 if not). One merge of the two lists instead of a binary search per key."""
    old = np.zeros(len(keys), np.bool_)
    values = np.zeros(len(keys))
    p = 0
    for q in range(len(keys)):
        while p < len(old_keys) and old_keys[p] < keys[q]:
            p += 1
        if p < len(old_keys) and old_keys[p] == keys[q]:
            old[q] = True
            values[q] = old_values[p]
    return old, values


@numba.njit(cache=True)
def pair_geometry(
    keys: np.ndarray, big_n: int, px: np.ndarray, py: np.ndarray, step: np.ndarray, min_distance: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """For the pairs of batch keys ``b * N^2 + i * N + j``, over nodes ``b * N + i`` at (px, py)
    that moved `step` since the last update: the two nodes, the run, the larger of the two ends'
    moves and the distance ``max(sqrt(dx^2 + dy^2), min_distance)``, in one pass over the pairs."""
    count = len(keys)
    node_i = np.empty(count, np.int64)
    node_j = np.empty(count, np.int64)
    run = np.empty(count, np.int64)
    moved = np.empty(count)
    d = np.empty(count)
    for p in range(count):
        a = keys[p] // big_n
        b = a // big_n
        c = a + (keys[p] - a * big_n) - (a - b * big_n)
        node_i[p], node_j[p], run[p] = a, c, b
        moved[p] = max(step[a], step[c])
        dx = px[a] - px[c]
        dy = py[a] - py[c]
        d[p] = max(math.sqrt(dx * dx + dy * dy), min_distance)
    return node_i, node_j, run, moved, d


@numba.njit(cache=True)
def near_pairs(points: np.ndarray, mines: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """(point, mine) index pairs with ``dx^2 + dy^2 <= radius^2``, by point then mine (at least one
    mine): the same pairs as a dense distance check or a k-d tree's sparse distance matrix, from a
    grid over the mines with cells at least a little wider than `radius`, so each point looks at
    the 3 x 3 cells around it."""
    m = len(mines)
    r2 = radius * radius
    x0, y0 = mines[:, 0].min(), mines[:, 1].min()
    w, h = mines[:, 0].max() - x0, mines[:, 1].max() - y0
    cell = max(radius * (1.0 + 1e-6), math.sqrt(w * h / (4.0 * m)), max(w, h) / _MAX_CELLS, 1e-9)
    nx, ny = int(w / cell) + 1, int(h / cell) + 1
    cx = np.minimum((mines[:, 0] - x0) / cell, nx - 1).astype(np.int64)
    cy = np.minimum((mines[:, 1] - y0) / cell, ny - 1).astype(np.int64)
    start, members = _bin(cx * ny + cy, nx * ny)
    out_r = []
    out_j = []
    row = np.empty(m, np.int64)
    for i in range(len(points)):
        px, py = points[i, 0], points[i, 1]
        gx = math.floor((px - x0) / cell)
        gy = math.floor((py - y0) / cell)
        size = 0
        for ax in range(max(gx - 1, 0), min(gx + 1, nx - 1) + 1):
            for ay in range(max(gy - 1, 0), min(gy + 1, ny - 1) + 1):
                c = ax * ny + ay
                for s in range(start[c], start[c + 1]):
                    j = members[s]
                    dx = px - mines[j, 0]
                    dy = py - mines[j, 1]
                    if dx * dx + dy * dy <= r2:
                        row[size] = j
                        size += 1
        _insertion_sort(row, size)
        for s in range(size):
            out_r.append(i)
            out_j.append(row[s])
    return np.array(out_r, np.int64), np.array(out_j, np.int64)


@numba.njit(cache=True)
def runs_near_pairs(
    points: np.ndarray, run: np.ndarray, mines: np.ndarray, target: np.ndarray, radius2: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(point, mine) index pairs of a batch, by point then mine: point q of run ``run[q]`` and each
    target mine j of that run (`mines` (B, width, 2), `target` (B, width)) with
    ``dx^2 + dy^2 <= radius2[q]``; a run's padding mines (NaN) are never near."""
    out_r = []
    out_j = []
    for q in range(len(points)):
        b = run[q]
        for j in range(mines.shape[1]):
            if target[b, j]:
                dx = points[q, 0] - mines[b, j, 0]
                dy = points[q, 1] - mines[b, j, 1]
                if dx * dx + dy * dy <= radius2[q]:
                    out_r.append(q)
                    out_j.append(j)
    return np.array(out_r, np.int64), np.array(out_j, np.int64)


@numba.njit(cache=True)
def screened_pairs(
    xy: np.ndarray,
    last_xy: np.ndarray,
    robots: np.ndarray,
    n: int,
    range_m: np.ndarray,
    mine_count: np.ndarray,
    mines: np.ndarray,
    target: np.ndarray,
    dense_pairs: int,
):
    """The (robot, mine) pairs a batch's sensors look at this step, for the screened `robots`
    (global rows, run-major; n robots a run): each robot's step (its last position, or where it
    is when it has none, to where it is), and the pairs within its run's radius of the step's
    middle, the radius being the run's range plus its robots' largest half step (`runs_near_pairs`;
    none for a run with more than `dense_pairs` robot-mine pairs). Returns the steps' starts and
    ends, each robot's run, the runs (`ids`, in order), whether each was dense, the pairs (r, j)
    and where each run's pairs start (`at`, one more than the runs). In numpy's arithmetic."""
    k = robots.shape[0]
    start = np.empty((k, 2))
    end = np.empty((k, 2))
    mid = np.empty((k, 2))
    half = np.empty(k)
    run = np.empty(k, np.int64)
    for q in range(k):
        i = robots[q]
        run[q] = i // n
        for c in range(2):
            e = xy[i, c]
            s = last_xy[i, c]
            if not np.isfinite(s):
                s = e
            start[q, c] = s
            end[q, c] = e
            mid[q, c] = 0.5 * (s + e)
        dx, dy = end[q, 0] - start[q, 0], end[q, 1] - start[q, 1]
        half[q] = 0.5 * math.sqrt(dx * dx + dy * dy)
    groups = 0
    for q in range(k):
        if q == 0 or run[q] != run[q - 1]:
            groups += 1
    ids = np.empty(groups, np.int64)
    dense = np.empty(groups, np.bool_)
    radius2 = np.empty(k)
    g, q = 0, 0
    while q < k:
        lo, b, most = q, run[q], half[q]
        q += 1
        while q < k and run[q] == b:
            most = max(most, half[q])
            q += 1
        radius = range_m[b] + most
        ids[g] = b
        dense[g] = (q - lo) * mine_count[b] <= dense_pairs
        r2 = radius * radius if dense[g] else -1.0  # -1: nothing that near
        for p in range(lo, q):
            radius2[p] = r2
        g += 1
    r, j = runs_near_pairs(mid, run, mines, target, radius2)
    at = np.empty(groups + 1, np.int64)
    at[:groups] = np.searchsorted(run[r], ids)
    at[groups] = len(r)
    return start, end, run, ids, dense, r, j, at


@numba.njit(cache=True)
def pair_looks(
    start: np.ndarray, end: np.ndarray, mines: np.ndarray, run: np.ndarray, r: np.ndarray, j: np.ndarray
) -> np.ndarray:
    """`swarm.planning.detection.inverse_cube_look(start[r], end[r], mines[run[r], j])` pair by
    pair, operation for operation, without gathering the pairs' ends and mines first: each pair is
    the step start[q] -> end[q] of screened robot q = r[p] and mine j[p] of its run."""
    out = np.empty(len(r))
    for p in range(len(r)):
        q = r[p]
        ax, ay = start[q, 0], start[q, 1]
        vx, vy = end[q, 0] - ax, end[q, 1] - ay
        length = math.sqrt(vx * vx + vy * vy)
        if not length > 1e-12:
            out[p] = 0.0  # a robot standing still looks at nothing
            continue
        ux, uy = vx / length, vy / length
        wx, wy = mines[run[q], j[p], 0] - ax, mines[run[q], j[p], 1] - ay
        s0 = -(wx * ux + wy * uy)
        s1 = s0 + length
        x = max(abs(ux * wy - uy * wx), MIN_LATERAL_M)
        x2 = x * x
        out[p] = (s1 / math.sqrt(x2 + s1 * s1) - s0 / math.sqrt(x2 + s0 * s0)) / x2
    return out


@numba.njit(cache=True)
def _insertion_sort(a: np.ndarray, size: int) -> None:
    """Sort ``a[:size]`` in place: the few entries of one robot's row, faster than a library sort."""
    for p in range(1, size):
        v = a[p]
        q = p
        while q > 0 and a[q - 1] > v:
            a[q] = a[q - 1]
            q -= 1
        a[q] = v


@numba.njit(cache=True)
def screen(
    xy: np.ndarray,
    last_xy: np.ndarray,
    who: np.ndarray,
    n: int,
    size: float,
    keys: np.ndarray,
    key_at: np.ndarray,
    bin_offset: int,
    run_stride: int,
    margin2: float,
) -> tuple[np.ndarray, np.ndarray]:
    """For the robots `who` (rows of `xy`, runs of n robots): is each in a screen bin, i.e. is
    ``run * run_stride + ((bx + bin_offset) << 22) + (by + bin_offset)``, with ``b = floor(xy /
    size)``, among the sorted `keys` (run b's from ``key_at[b]`` to ``key_at[b + 1]``: the search
    stays within them); and did it move further than ``sqrt(margin2)`` since `last_xy` (never,
    from NaN)."""
    in_bins = np.zeros(len(who), np.bool_)
    jumped = np.zeros(len(who), np.bool_)
    for q in range(len(who)):
        g = who[q]
        b = g // n
        lo, hi = key_at[b], key_at[b + 1]
        if hi > lo:
            bx = np.int64(math.floor(xy[g, 0] / size)) + bin_offset
            by = np.int64(math.floor(xy[g, 1] / size)) + bin_offset
            key = b * run_stride + (bx << 22) + by
            at = min(lo + np.searchsorted(keys[lo:hi], key), hi - 1)
            in_bins[q] = keys[at] == key
        dx = xy[g, 0] - last_xy[g, 0]
        dy = xy[g, 1] - last_xy[g, 1]
        jumped[q] = dx * dx + dy * dy > margin2
    return in_bins, jumped
