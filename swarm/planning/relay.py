"""Relay positioning: the fewest robots that link a source to its sinks by radio, on ground they
can stand on, with spare paths if asked.

The problem is the Steiner tree problem with bounded edge length and a minimum number of Steiner
points (NP-hard). The heuristic here is the Steinerized minimum spanning tree (Lin and Xue,
"Steiner tree problem with minimum number of Steiner points and bounded edge-length", Information
Processing Letters 69, 1999; approximation ratio 4 in the plane, Chen, Du, Hu, Lin, Wang, Xue,
Theoretical Computer Science 262, 2001), improved two ways:

1. Steiner hubs (redundancy 1 only): a relay at the Fermat point of three terminals can replace
   the long MST edges among them; hubs are added greedily while the relay count of the
   Steinerized MST drops (the iterated 1-Steiner idea of Kahng and Robins, IEEE T-CAD 11(7), 1992,
   with relay count as the cost).
2. Candidate-cell search: each MST edge of length d needs at least ceil(d / R) - 1 relays (each
   hop at most R); they are placed by dynamic programming over the standable cells near the evenly
   spaced ideal points, minimizing the longest hop (the best worst-case link margin), with one or
   a few more relays if the ground forces it; when the straight line is blocked by ground no relay
   can stand on (a lagoon, a river mouth), by the fewest hops through a coarse lattice of standable
   cells. A relay is at most R from the next one on its chain.

Redundancy 2: every MST edge longer than R gets two node-disjoint relay chains (no shared relay,
relays at least `separation_m` apart), so losing any single relay leaves every terminal linked;
no hubs (a hub is a single point of failure). `plan_relays` checks this by removing each relay in
turn and counting connected components (scipy.sparse.csgraph).

Where a robot can stand (`standable_grid`): passable terrain, not water deeper than shallow
(``buoyancy_fraction <= SHALLOW_MAX_BUOYANCY``: shallow_water yes, surf and deep water no), slope no
steeper than the mode lets the wheels climb, and no part of the cell in a ``keep_out`` region.
Relays stand on cell centres. Terminals (the source and the sinks) are given and can be anywhere:
the source may be a boat.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import shapely
from scipy.ndimage import binary_erosion
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import breadth_first_order, connected_components, minimum_spanning_tree
from scipy.spatial import cKDTree
from scipy.spatial.distance import cdist

from swarm.errors import SwarmError
from swarm.planning.radio import RadioParams, comm_range_m, link_margin_db
from swarm.robot.terrain import TerrainLibrary, load_library
from swarm.world.beachmap import BeachMap

#: Water modes up to this buoyancy fraction are standable (bundled shallow_water 0.2; surf 0.6).
SHALLOW_MAX_BUOYANCY = 0.25
#: Default least distance between two relays: room for two robots and a margin.
RELAY_SEPARATION_M = 2.0
#: Candidate cells per ideal relay point in the placement search: this many nearest cells, and
#: a spread sample of the cells within half a range up to CANDIDATES_PER_POINT in all.
NEAREST_CANDIDATES = 24
#: At most about this many lattice points in the detour search.
MAX_LATTICE_POINTS = 20_000
CANDIDATES_PER_POINT = 96


class RelayError(SwarmError):
    """No relay placement can close a link: the message says which link and where it breaks."""


@dataclass(frozen=True, eq=False)
class StandGrid:
    """Where a relay may stand: a boolean grid in the `BeachMap` convention (row 0 south, column 0
    west, cell (r, c) covering x0 + c cell .. x0 + (c+1) cell)."""

    standable: np.ndarray  # bool (rows, cols)
    cell_m: float
    origin_m: tuple[float, float]

    @cached_property
    def centers_m(self) -> np.ndarray:
        """(k, 2) world centres of the standable cells, row-major order."""
        rows, cols = np.nonzero(self.standable)
        x = self.origin_m[0] + (cols + 0.5) * self.cell_m
        y = self.origin_m[1] + (rows + 0.5) * self.cell_m
        return np.column_stack([x, y]).astype(np.float64)

    @cached_property
    def tree(self) -> cKDTree:
        return cKDTree(self.centers_m)

    def is_standable(self, xy: np.ndarray) -> np.ndarray:
        """Per world point: inside the grid and on a standable cell."""
        p = np.atleast_2d(np.asarray(xy, dtype=np.float64))
        col = np.floor((p[:, 0] - self.origin_m[0]) / self.cell_m).astype(np.intp)
        row = np.floor((p[:, 1] - self.origin_m[1]) / self.cell_m).astype(np.intp)
        rows, cols = self.standable.shape
        inside = (row >= 0) & (row < rows) & (col >= 0) & (col < cols)
        out = np.zeros(len(p), dtype=bool)
        out[inside] = self.standable[row[inside], col[inside]]
        return out


def standable_grid(
    beach: BeachMap,
    library: TerrainLibrary | None = None,
    *,
    max_buoyancy_fraction: float = SHALLOW_MAX_BUOYANCY,
) -> StandGrid:
    """The cells of `beach` where a robot can stand still as a relay (module docstring)."""
    library = load_library() if library is None else library
    modes = [library[name] for name in beach.terrain_classes]
    class_ok = np.array(
        [m.passable and (not m.is_water or m.buoyancy_fraction <= max_buoyancy_fraction) for m in modes]
    )
    climb = np.array([m.max_climb_slope_deg for m in modes])
    terrain = beach.terrain.astype(np.intp)
    ok = class_ok[terrain] & (beach.slope_deg <= climb[terrain])
    for region in beach.regions_of_kind("keep_out"):
        ok &= ~_cells_touching(beach, region.geometry)
    return StandGrid(ok, float(beach.cell_m), (float(beach.origin_m[0]), float(beach.origin_m[1])))


def _cells_touching(beach: BeachMap, geometry) -> np.ndarray:
    """Cells any part of which `geometry` covers."""
    out = np.zeros(beach.shape, dtype=bool)
    xmin, ymin, xmax, ymax = geometry.bounds
    r0, c0 = beach.cell_of(xmin, ymin)
    r1, c1 = beach.cell_of(xmax, ymax)
    rows, cols = np.mgrid[int(r0) : int(r1) + 1, int(c0) : int(c1) + 1]
    x0 = beach.origin_m[0] + cols * beach.cell_m
    y0 = beach.origin_m[1] + rows * beach.cell_m
    boxes = shapely.box(x0, y0, x0 + beach.cell_m, y0 + beach.cell_m)
    hit = shapely.intersects(geometry, boxes) & ~shapely.touches(geometry, boxes)
    out[rows[hit], cols[hit]] = True
    return out


@dataclass(frozen=True)
class RelayPlan:
    """Relay positions and the links they make.

    Nodes are numbered ``[source, sinks..., relays...]``; `edges` are planned radio links between
    node indices, each at most `range_m` long where a relay is at one end (two terminals in reach
    of each other link directly).
    """

    terminals_m: np.ndarray  # (1 + n_sinks, 2): the source, then the sinks
    positions_m: np.ndarray  # (k, 2): the relays
    edges: np.ndarray  # (e, 2) int node indices
    hop_lengths_m: np.ndarray  # (e,)
    range_m: float
    redundancy: int
    min_margin_db: float | None  # worst planned link's margin over sensitivity + fade (with a radio)
    hubs: tuple[int, ...] = field(default=())  # node indices of Steiner hub relays

    @property
    def n_relays(self) -> int:
        return len(self.positions_m)

    @property
    def n_terminals(self) -> int:
        return len(self.terminals_m)

    @property
    def nodes_m(self) -> np.ndarray:
        return np.vstack([self.terminals_m, self.positions_m.reshape(-1, 2)])

    @property
    def min_slack_m(self) -> float:
        """Range left on the longest hop with a relay at one end."""
        hops = self.hop_lengths_m[relayed_links(self.edges, self.n_terminals)]
        return float(self.range_m - hops.max()) if len(hops) else self.range_m


def relayed_links(edges: np.ndarray, n_terminals: int) -> np.ndarray:
    """(e,) bool: the links with a relay robot at one end (not two terminals linked directly)."""
    e = np.asarray(edges, dtype=np.intp).reshape(-1, 2)
    return e.max(axis=1, initial=-1) >= n_terminals


def terminals_connected(
    n_nodes: int, edges: np.ndarray, n_terminals: int, removed: Sequence[int] = ()
) -> bool:
    """Are nodes 0 .. n_terminals-1 in one connected component once the `removed` nodes are gone?"""
    e = np.asarray(edges, dtype=np.intp).reshape(-1, 2)
    if len(removed):
        gone = np.zeros(n_nodes, dtype=bool)
        gone[list(removed)] = True
        e = e[~(gone[e[:, 0]] | gone[e[:, 1]])]
    graph = coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n_nodes, n_nodes))
    _, labels = connected_components(graph, directed=False)
    return bool(np.all(labels[:n_terminals] == labels[0]))


def single_loss_cuts(plan: RelayPlan) -> list[int]:
    """Relays (node indices) whose loss alone disconnects some terminal."""
    n = plan.n_terminals + plan.n_relays
    return [
        node
        for node in range(plan.n_terminals, n)
        if not terminals_connected(n, plan.edges, plan.n_terminals, [node])
    ]


# ---------------------------------------------------------------------------------------------
# where relays may go


class _Ground:
    """Candidate relay positions near a point: standable cell centres (or, with no grid, the point
    itself and rings around it), keeping `separation_m` from relays already placed."""

    def __init__(self, grid: StandGrid | None, range_m: float, separation_m: float) -> None:
        self.grid = grid
        self.range_m = range_m
        self.separation_m = separation_m
        self.placed: list[np.ndarray] = []
        if grid is not None and not grid.standable.any():
            raise RelayError("relay: no cell of the map is standable (passable, dry or shallow, climbable)")

    def _free(self, pts: np.ndarray, exclude: Sequence[np.ndarray] = ()) -> np.ndarray:
        taken = [*self.placed, *exclude]
        if not taken or not len(pts):
            return np.ones(len(pts), dtype=bool)
        return cdist(pts, np.asarray(taken)).min(axis=1) >= self.separation_m

    def near(self, q: np.ndarray, exclude: Sequence[np.ndarray] = ()) -> np.ndarray:
        """Up to CANDIDATES_PER_POINT free candidates within range of q, nearest first."""
        if self.grid is None:
            step = max(self.separation_m, 1e-3 * self.range_m)
            pts = [q]
            for ring in range(1, 4):
                n = 8 * ring
                ang = np.arange(n) * 2 * math.pi / n
                pts.extend(q + ring * step * np.column_stack([np.cos(ang), np.sin(ang)]))
            cand = np.asarray(pts)
        else:
            # the nearest cells, then a spread sample of the disc of radius range/2 around q (the
            # nearest cell in each square of a coarse pitch), so a chain can bend round obstacles
            k = min(NEAREST_CANDIDATES * 4, len(self.grid.centers_m))
            dist, idx = self.grid.tree.query(q, k=k, distance_upper_bound=self.range_m)
            idx = np.atleast_1d(idx)[np.isfinite(np.atleast_1d(dist))]
            nearest = self.grid.centers_m[idx]
            nearest = nearest[self._free(nearest, exclude)][:NEAREST_CANDIDATES]
            ball = self.grid.centers_m[self.grid.tree.query_ball_point(q, self.range_m / 2.0)]
            pitch = max(self.grid.cell_m, self.range_m / 10.0)
            ball = ball[np.argsort(np.hypot(*(ball - q).T), kind="stable")]
            _, first = np.unique(np.floor(ball / pitch), axis=0, return_index=True)
            spread = ball[np.sort(first)]
            spread = spread[self._free(spread, exclude)][: CANDIDATES_PER_POINT - len(nearest)]
            return _unique_rows(np.vstack([nearest, spread]))
        return cand[self._free(cand, exclude)][:CANDIDATES_PER_POINT]

    def lattice(self, exclude: Sequence[np.ndarray] = ()) -> np.ndarray:
        """A coarse sample of free standable positions for detours: every `stride`-th cell (about
        range/4 apart), and one edge cell per stride square, so thin strips of standable ground
        (a sand bar, a jetty) between the sampled rows are not lost."""
        if self.grid is None:
            return np.empty((0, 2))
        ok = self.grid.standable
        stride = max(1, int(self.range_m / (4.0 * self.grid.cell_m)))
        stride = max(stride, math.ceil(math.sqrt(ok.sum() / MAX_LATTICE_POINTS)))
        mask = np.zeros_like(ok)
        mask[::stride, ::stride] = True
        edge = ok & ~binary_erosion(ok, structure=np.ones((3, 3), bool), border_value=0)
        rows, cols = np.nonzero(edge)
        _, first = np.unique(np.column_stack([rows // stride, cols // stride]), axis=0, return_index=True)
        mask[rows[first], cols[first]] = True
        rows, cols = np.nonzero(mask & ok)
        pts = np.column_stack(
            [
                self.grid.origin_m[0] + (cols + 0.5) * self.grid.cell_m,
                self.grid.origin_m[1] + (rows + 0.5) * self.grid.cell_m,
            ]
        )
        return pts[self._free(pts, exclude)]

    def frontier(
        self, side_a: np.ndarray, side_b: np.ndarray, exclude: Sequence[np.ndarray] = ()
    ) -> tuple[np.ndarray, np.ndarray]:
        """The closest pair of points reachable from two sides: each side's points plus every free
        standable cell within range of one of them."""
        sides = []
        for side in (side_a, side_b):
            pts = side
            if self.grid is not None:
                cells = self.grid.centers_m[self._free(self.grid.centers_m, exclude)]
                dist, _ = cKDTree(side).query(cells, distance_upper_bound=self.range_m)
                pts = np.vstack([side, cells[np.isfinite(dist)]])
            sides.append(pts)
        dist, j = cKDTree(sides[1]).query(sides[0])
        i = int(np.argmin(dist))
        return sides[0][i], sides[1][int(j[i])]

    def snap(self, q: np.ndarray) -> np.ndarray:
        if self.grid is None:
            return q
        _, i = self.grid.tree.query(q)
        return self.grid.centers_m[int(i)]


# ---------------------------------------------------------------------------------------------
# one chain of relays between two nodes


@dataclass
class _Failure:
    hop: int  # 1-based
    hops: int
    start: np.ndarray
    end: np.ndarray


def _along(polyline: np.ndarray, k: int) -> np.ndarray:
    """k points splitting the polyline into k + 1 equal lengths."""
    seg = np.hypot(*np.diff(polyline, axis=0).T)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    s = cum[-1] * np.arange(1, k + 1) / (k + 1)
    return np.column_stack([np.interp(s, cum, polyline[:, 0]), np.interp(s, cum, polyline[:, 1])])


def _dp_chain(
    a: np.ndarray, b: np.ndarray, ideals: np.ndarray, ground: _Ground, exclude: Sequence[np.ndarray]
) -> np.ndarray | _Failure:
    """Relays near `ideals` linking a to b, minimizing the longest hop; or where it breaks."""
    r = ground.range_m
    layers = [ground.near(q, exclude) for q in ideals]
    if len(layers):  # the cells nearest each end, so a terminal off the standable ground is reached
        layers[0] = _unique_rows(np.vstack([layers[0], ground.near(a, exclude)]))
        layers[-1] = _unique_rows(np.vstack([layers[-1], ground.near(b, exclude)]))
    prev_pts = a[None, :]
    prev_cost = np.zeros(1)
    back: list[np.ndarray] = []
    for i, cand in enumerate([*layers, b[None, :]]):
        if not len(cand):
            return _Failure(i + 1, len(ideals) + 1, _at(ideals, i - 1, a), _at(ideals, i, b))
        d = cdist(prev_pts, cand)
        total = np.maximum(prev_cost[:, None], d)
        total[d > r] = np.inf
        j = np.argmin(total, axis=0)
        cost = total[j, np.arange(len(cand))]
        if not np.isfinite(cost).any():
            return _Failure(i + 1, len(ideals) + 1, _at(ideals, i - 1, a), _at(ideals, i, b))
        back.append(j)
        prev_pts, prev_cost = cand, cost
    # walk back from b through the argmins
    out = []
    idx = 0
    for i in range(len(layers) - 1, -1, -1):
        idx = int(back[i + 1][idx])
        out.append(layers[i][idx])
    return np.asarray(out[::-1]).reshape(-1, 2)


def _unique_rows(pts: np.ndarray) -> np.ndarray:
    """Rows in first-seen order without repeats."""
    _, first = np.unique(pts, axis=0, return_index=True)
    return pts[np.sort(first)]


def _at(ideals: np.ndarray, i: int, default: np.ndarray) -> np.ndarray:
    return ideals[i] if 0 <= i < len(ideals) else default


def _lattice_path(
    a: np.ndarray, b: np.ndarray, ground: _Ground, exclude: Sequence[np.ndarray]
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Fewest hops from a to b through the coarse lattice (a polyline a .. b), or, when none
    exists, the closest pair of standable points reachable from a and from b.

    When the lattice finds no path, the frontier is refined at full resolution (every standable
    cell within range of either side); if that closes the gap, the pair joins the lattice and the
    search runs again."""
    extra = np.empty((0, 2))
    gap = (a, b)
    for _ in range(8):
        pts = _unique_rows(
            np.vstack(
                [a, b, ground.near(a, exclude), ground.near(b, exclude), extra, ground.lattice(exclude)]
            )
        )
        tree = cKDTree(pts)
        pairs = tree.query_pairs(ground.range_m, output_type="ndarray")
        n = len(pts)
        graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n)).tocsr()
        order, pred = breadth_first_order(graph, 0, directed=False, return_predecessors=True)
        if pred[1] >= 0:
            path = [1]
            while path[-1] != 0:
                path.append(int(pred[path[-1]]))
            return pts[path[::-1]]
        _, labels = connected_components(graph, directed=False)
        gap = ground.frontier(pts[order], pts[labels == labels[1]], exclude)
        if float(np.hypot(*(gap[1] - gap[0]))) > ground.range_m:
            break
        extra = np.vstack([extra, *gap])
    return gap


def _fmt(p: np.ndarray) -> str:
    return f"({p[0]:.1f}, {p[1]:.1f})"


def _chain(
    a: np.ndarray,
    b: np.ndarray,
    ground: _Ground,
    names: tuple[str, str],
    *,
    max_extra: int,
    exclude: Sequence[np.ndarray] = (),
) -> np.ndarray:
    """Relays on standable ground linking a to b with hops <= range (none if a, b are in range)."""
    r = ground.range_m
    d = float(np.hypot(*(b - a)))
    if d <= r:
        return np.empty((0, 2))
    k0 = max(0, math.ceil(d / r - 1e-12) - 1)
    straight = np.vstack([a, b])
    failure = None
    best = None
    for k in range(k0, k0 + max_extra + 1):
        got = _dp_chain(a, b, _along(straight, k), ground, exclude)
        if not isinstance(got, _Failure):
            best = got
            break
        failure = failure or got
    if best is not None and len(best) == k0:
        return best  # the fewest any chain can have
    # blocked, or bent: the fewest hops through the standable lattice, then relays spread along it
    path = _lattice_path(a, b, ground, exclude)
    if isinstance(path, tuple):
        if best is not None:
            return best
        assert failure is not None
        raise RelayError(_blocked_message(a, b, names, r, failure, path, ground, exclude))
    length = float(np.sum(np.hypot(*np.diff(path, axis=0).T)))
    k_lattice = len(path) - 2
    limit = k_lattice if best is None else min(k_lattice, len(best))
    for k in range(max(k0, math.ceil(length / r - 1e-12) - 1), limit):
        got = _dp_chain(a, b, _along(path, k), ground, exclude)
        if not isinstance(got, _Failure):
            return got
    if best is not None and len(best) <= k_lattice:
        return best
    return path[1:-1].copy()


def _blocked_message(
    a: np.ndarray,
    b: np.ndarray,
    names: tuple[str, str],
    r: float,
    failure: _Failure,
    gap: tuple[np.ndarray, np.ndarray],
    ground: _Ground,
    exclude: Sequence[np.ndarray],
) -> str:
    d = float(np.hypot(*(b - a)))
    head = (
        f"relay: the link from {names[0]} {_fmt(a)} to {names[1]} {_fmt(b)} ({d:.1f} m) cannot be closed "
        f"with hops of at most {r:.1f} m between cells a robot can stand on"
    )
    for end, name in ((a, names[0]), (b, names[1])):
        if not len(ground.near(end, exclude)):
            spot = ground.snap(end)
            return (
                f"{head}: no standable cell lies within {r:.1f} m of {name} "
                f"(the nearest, {_fmt(spot)}, is {float(np.hypot(*(spot - end))):.1f} m away)"
            )
    start = names[0] if failure.hop == 1 else f"a relay near {_fmt(failure.start)}"
    end = names[1] if failure.hop == failure.hops else f"a relay near {_fmt(failure.end)}"
    near_a, near_b = gap
    return (
        f"{head}: on the straight line hop {failure.hop} of {failure.hops}, from {start} to {end}, cannot "
        f"be closed, and going round, the standable ground reachable from {names[0]} ends near "
        f"{_fmt(near_a)}, {float(np.hypot(*(near_b - near_a))):.1f} m from standable ground at "
        f"{_fmt(near_b)} on {names[1]}'s side"
    )


# ---------------------------------------------------------------------------------------------
# the tree


def _mst_edges(points: np.ndarray) -> list[tuple[int, int]]:
    n = len(points)
    if n < 2:
        return []
    d = cdist(points, points)
    d = np.where(np.eye(n, dtype=bool), 0.0, np.maximum(d, 1e-9))  # 0 would mean "no edge"
    tree = minimum_spanning_tree(d).tocoo()
    return sorted((int(min(i, j)), int(max(i, j))) for i, j in zip(tree.row, tree.col, strict=True))


def _relay_count(points: np.ndarray, range_m: float) -> int:
    return sum(
        max(0, math.ceil(float(np.hypot(*(points[i] - points[j]))) / range_m - 1e-12) - 1)
        for i, j in _mst_edges(points)
    )


def _fermat_point(p: np.ndarray) -> np.ndarray:
    """Geometric median of a few points (Weiszfeld's iteration)."""
    x = p.mean(axis=0)
    for _ in range(200):
        d = np.maximum(np.hypot(*(p - x).T), 1e-12)
        nxt = (p / d[:, None]).sum(axis=0) / (1.0 / d).sum()
        if np.hypot(*(nxt - x)) < 1e-9:
            return nxt
        x = nxt
    return x


def _steiner_hubs(terminals: np.ndarray, ground: _Ground, range_m: float) -> np.ndarray:
    """Greedy hubs at (snapped) Fermat points of point triples while the relay count drops."""
    points = terminals.copy()
    hubs: list[np.ndarray] = []
    best = _relay_count(points, range_m)
    for _ in range(len(terminals)):
        n = len(points)
        near = np.argsort(cdist(points, points), axis=1)[:, 1:6]
        triples = sorted(
            {
                tuple(sorted((i, int(j), int(k))))
                for i in range(n)
                for j, k in itertools.combinations(near[i], 2)
            }
        )
        choice = None
        for t in triples:
            hub = ground.snap(_fermat_point(points[list(t)]))
            count = _relay_count(np.vstack([points, hub]), range_m) + len(hubs) + 1
            if count < best and (choice is None or count < choice[0]):
                choice = (count, hub)
        if choice is None:
            break
        best = choice[0]
        hubs.append(choice[1])
        points = np.vstack([points, choice[1]])
    return np.asarray(hubs).reshape(-1, 2)


def plan_relays(
    source_m: Sequence[float] | np.ndarray,
    sinks_m: Sequence[Sequence[float]] | np.ndarray,
    *,
    range_m: float | None = None,
    radio: RadioParams | None = None,
    terminal_range_m: float | None = None,
    grid: StandGrid | None = None,
    redundancy: int = 1,
    separation_m: float = RELAY_SEPARATION_M,
    max_extra_relays: int = 3,
    hubs: bool = True,
) -> RelayPlan:
    """Place relays linking `source_m` to every sink, each hop within range.

    The range is `range_m`, else `comm_range_m(radio)`; with a radio the plan reports its worst
    relay link's margin. `terminal_range_m` (default: the range) is the budget between two
    terminals, whose masts may stand higher than a robot's: terminals that close it link directly,
    with no relay between them and no second chain (no robot's loss can cut that link). With a
    `grid` (`standable_grid(beach)`) relays stand only on standable cell centres; without one,
    anywhere. `redundancy` 1: a tree; 2: any single relay may be lost.
    Relays keep `separation_m` from each other; a chain may use up to `max_extra_relays` more than
    its straight-line minimum before a detour is searched; `hubs=False` skips the Steiner hubs.
    Raises `RelayError` (a `SwarmError`) naming the link and the hop that cannot be closed.
    """
    if range_m is None:
        if radio is None:
            raise SwarmError("relay: give range_m or radio")
        range_m = comm_range_m(radio)
    if not (math.isfinite(range_m) and range_m > 0):
        raise SwarmError(f"relay: range_m must be a positive number, found {range_m!r}")
    if terminal_range_m is None:
        terminal_range_m = range_m
    if not (math.isfinite(terminal_range_m) and terminal_range_m > 0):
        raise SwarmError(f"relay: terminal_range_m must be a positive number, found {terminal_range_m!r}")
    if redundancy not in (1, 2):
        raise SwarmError(f"relay: redundancy must be 1 or 2, found {redundancy!r}")
    source = np.asarray(source_m, dtype=np.float64).reshape(2)
    sinks = np.asarray(sinks_m, dtype=np.float64).reshape(-1, 2)
    if not len(sinks):
        raise SwarmError("relay: need at least one sink")
    terminals = np.vstack([source, sinks])
    n_t = len(terminals)
    names = ["source", *(f"sink {i}" for i in range(len(sinks)))]
    ground = _Ground(grid, float(range_m), float(separation_m))
    # terminal pairs in reach of each other need no relay
    direct_t = cdist(terminals, terminals) <= terminal_range_m
    np.fill_diagonal(direct_t, False)

    hub_pts = np.empty((0, 2))
    if redundancy == 1 and hubs and n_t >= 3 and not direct_t.any():
        hub_pts = _steiner_hubs(terminals, ground, float(range_m))
    for h in hub_pts:
        ground.placed.append(h)
    nodes: list[np.ndarray] = [*terminals, *hub_pts]
    names += [f"hub relay {i}" for i in range(len(hub_pts))]
    edges: list[tuple[int, int]] = []

    def add_chain(i: int, j: int, relays: np.ndarray) -> None:
        ids = [i]
        for p in relays:
            nodes.append(p)
            ground.placed.append(p)
            ids.append(len(nodes) - 1)
        ids.append(j)
        edges.extend(itertools.pairwise(ids))

    base = np.asarray(nodes)
    direct = np.zeros((len(base), len(base)), dtype=bool)
    direct[:n_t, :n_t] = direct_t
    # (with direct pairs there are no hubs, and every other pair is longer: the tree takes them first)
    for i, j in _mst_edges(base):
        if direct[i, j]:
            edges.append((i, j))
            continue
        a, b = base[i], base[j]
        first = _chain(a, b, ground, (names[i], names[j]), max_extra=max_extra_relays)
        add_chain(i, j, first)
        if redundancy == 2 and len(first):
            second = _chain(
                a, b, ground, (names[i], names[j] + " (second, disjoint chain)"), max_extra=max_extra_relays
            )
            add_chain(i, j, second)

    all_nodes = np.asarray(nodes)
    e = np.asarray(edges, dtype=np.intp).reshape(-1, 2)
    hops = np.hypot(*(all_nodes[e[:, 0]] - all_nodes[e[:, 1]]).T) if len(e) else np.empty(0)
    by_robot = relayed_links(e, n_t)
    plan = RelayPlan(
        terminals_m=terminals,
        positions_m=all_nodes[n_t:].reshape(-1, 2),
        edges=e,
        hop_lengths_m=hops,
        range_m=float(range_m),
        redundancy=redundancy,
        min_margin_db=(
            float(np.min(link_margin_db(hops[by_robot], radio)))
            if radio is not None and by_robot.any()
            else None
        ),
        hubs=tuple(range(n_t, n_t + len(hub_pts))),
    )
    # the plan's own guarantees, checked
    if by_robot.any() and hops[by_robot].max() > range_m * (1 + 1e-9):
        longest = hops[by_robot].max()
        raise AssertionError(f"relay: a hop of {longest:.3f} m exceeds the range {range_m:.3f} m")
    if (~by_robot).any() and hops[~by_robot].max() > terminal_range_m * (1 + 1e-9):
        raise AssertionError("relay: a direct terminal link exceeds the terminal range")
    if not terminals_connected(len(all_nodes), e, n_t):
        raise AssertionError("relay: the plan does not connect every terminal")
    if redundancy == 2 and (cuts := single_loss_cuts(plan)):
        raise AssertionError(f"relay: losing relay node {cuts[0]} disconnects a terminal")
    return plan
