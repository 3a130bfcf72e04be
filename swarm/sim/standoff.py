"""Getting clear of a blast: from anywhere on the beach, the distance over drivable ground to the
nearest point clear of a set of marked mines, and the path there.

The nearest safe point as the crow flies can lie behind a dune or a driftwood log, and an OMPL
route around it may lead through the standoff instead of away from it (mine_clear lost robots
that way). One multi-source Dijkstra (`scipy.sparse.csgraph.dijkstra`, `min_only`) from every safe
cell over the cost map's free cells, 8-connected, answers for every robot at once.
"""

from __future__ import annotations

import weakref
from functools import cached_property

import numpy as np
from scipy.sparse import coo_matrix, csr_matrix
from scipy.sparse.csgraph import dijkstra

from swarm.planning.costmap import CostMap

#: Neighbour offsets (row, col) of the 8-connected grid, each edge once.
_STEPS = ((0, 1), (1, 0), (1, 1), (1, -1))


#: `free_cell_graph` of each cost map in use (a batch's runs and their policies share one map).
_GRAPHS: weakref.WeakKeyDictionary[CostMap, csr_matrix] = weakref.WeakKeyDictionary()


def free_cell_graph(cm: CostMap) -> csr_matrix:
    """The cost map's free cells as an undirected graph: node row * cols + col, edges to the 8
    neighbours that are free too, weighted by the distance between centres (m). Built once per
    cost map and shared: treat it as read-only."""
    graph = _GRAPHS.get(cm)
    if graph is None:
        graph = _GRAPHS[cm] = _build_free_cell_graph(cm)
    return graph


def _build_free_cell_graph(cm: CostMap) -> csr_matrix:
    rows, cols = cm.shape
    free = ~cm.blocked
    heads, tails, weights = [], [], []
    for dr, dc in _STEPS:
        r0, r1 = 0, rows - dr
        c0, c1 = max(0, -dc), cols - max(0, dc)
        a = free[r0:r1, c0:c1] & free[r0 + dr : r1 + dr, c0 + dc : c1 + dc]
        r, c = np.nonzero(a)
        r, c = r + r0, c + c0
        heads.append(r * cols + c)
        tails.append((r + dr) * cols + (c + dc))
        weights.append(np.full(len(r), cm.cell_m * float(np.hypot(dr, dc))))
    n = rows * cols
    graph = coo_matrix(
        (np.concatenate(weights), (np.concatenate(heads), np.concatenate(tails))), shape=(n, n)
    )
    return graph.tocsr()


def near_any(cm: CostMap, objs: np.ndarray, radius_m: float) -> np.ndarray:
    """(rows, cols) bool: cells whose centre lies closer than `radius_m` to a point of `objs`. Each
    point looks only at the window of cells around it, with the distance a k-d tree computes
    (the root of the summed squared differences), so the mask is the one a query of every cell
    against a `cKDTree` of `objs` gives (`distance < radius_m`), at a fraction of its cost. The
    window's centres are a column of y by a row of x, broadcast: the same sums, without a grid of
    indices to build and scatter through."""
    out = np.zeros(cm.shape, bool)
    nrows, ncols = cm.shape
    for ox, oy in objs.tolist():
        r0, c0 = (int(v) for v in cm.cell_of(ox - radius_m, oy - radius_m))
        r1, c1 = (int(v) for v in cm.cell_of(ox + radius_m, oy + radius_m))
        r0, c0 = max(r0 - 1, 0), max(c0 - 1, 0)
        r1, c1 = min(r1 + 1, nrows - 1), min(c1 + 1, ncols - 1)
        if r1 < r0 or c1 < c0:
            continue
        x, y = cm.center_of(np.arange(r0, r1 + 1)[:, None], np.arange(c0, c1 + 1)[None, :])
        dx, dy = x - ox, y - oy
        out[r0 : r1 + 1, c0 : c1 + 1] |= np.sqrt(dx * dx + dy * dy) < radius_m
    return out


class SafeGround:
    """Distances and paths over free ground to the nearest free cell at least `safe_m` from every
    point of `objs`; with `dry` (a cell mask), to the nearest such cell on dry ground when there is
    one: the nearest clear cell can lie in the surf, where breakers roll a waiting robot over."""

    def __init__(
        self,
        cm: CostMap,
        graph: csr_matrix,
        objs: np.ndarray,
        safe_m: float,
        dry: np.ndarray | None = None,
    ) -> None:
        self.cm = cm
        # masks over the whole grid (cheaper than indexing the free cells out first); the sources
        # come out in node order, as the free cells' own order would give them
        safe = ~cm.blocked & ~near_any(cm, np.asarray(objs, dtype=np.float64).reshape(-1, 2), safe_m)
        if dry is not None and (safe & dry).any():
            safe &= dry
        sources = np.flatnonzero(safe)
        if not len(sources):
            self.dist = np.full(cm.shape[0] * cm.shape[1], np.inf)
            self.pred = np.full(len(self.dist), -9999)
            return
        self.dist, self.pred, _ = dijkstra(
            graph, directed=False, indices=sources, min_only=True, return_predecessors=True
        )

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

    def path(self, xy: np.ndarray) -> np.ndarray:
        """Waypoints (k, 2) from the free point `xy` along cell centres to the nearest safe cell;
        just `xy` where it is safe already or no safe ground can be reached from it."""
        xy = np.asarray(xy, dtype=np.float64).reshape(2)
        node = int(self._node(xy))
        if not np.isfinite(self.dist[node]):
            return xy[None]
        nodes = []
        while node >= 0:
            nodes.append(node)
            node = int(self.pred[node])
        cells = np.asarray(nodes[1:], dtype=np.intp)
        x, y = self.cm.center_of(cells // self.cm.shape[1], cells % self.cm.shape[1])
        return np.vstack([xy[None], np.column_stack([x, y])])
