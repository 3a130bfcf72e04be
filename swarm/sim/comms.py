"""The radio graph of the swarm, step by step: which links work, with what margin, and what the
graph can still carry (components, hops from the source, node-disjoint paths).

Nodes are the ``n`` robots first, then ``f`` fixed nodes: the relay source (node ``n``), then its
sinks. Fixed nodes never move and are always up.

Link rule (the simulator's, as `swarm.planning.radio.link_closes`): a link i-j works while both
radios are up and ``P_rx(d_ij) - X_ij >= sensitivity``, with ``P_rx`` the mean received power of
`swarm.planning.radio.received_power_dbm` (Friis below the crossover distance, two-ray above it,
for the antenna heights of the two ends: robots `RadioParams.tx_height_m`, fixed nodes
``fixed_height_m``) and ``X_ij`` the pair's shadowing loss in dB. The planner's fade margin is its
reserve against ``X``; it is not subtracted here. Pairs closer than `MIN_DISTANCE_M` are treated
as that far apart (the path-loss law has no meaning at zero distance).

Shadowing (Rappaport, *Wireless Communications*, 2nd ed., 2002, section 4.9.2): ``X_ij`` is
zero-mean Gaussian with standard deviation ``radio.shadowing_sigma_db``, the same both ways
(reciprocity), and correlated in space as Gudmundson's exponential model ("Correlation model for
shadow fading in mobile radio systems", Electronics Letters 27(23), 1991): for a displacement
``Δ`` the correlation is ``exp(-Δ / decorrelation_m)``. Each update the state evolves as the
first-order autoregression ``X_new = rho X_old + sqrt(1 - rho^2) sigma Z`` with
``rho = exp(-Δ / decorrelation_m)``, which keeps the marginal N(0, sigma^2) and composes over
steps into ``exp(-(total path) / decorrelation_m)``, as Gudmundson's model does along a route.
Gudmundson moved one end only; with both ends moving this module takes ``Δ`` as the larger of the
two ends' displacements since the last update (an approximation: a separable model, with one
exponential per end, would use their sum and decorrelate faster). A pair that does not move keeps
its ``X`` (``rho = 1``, no draw).

Only candidate pairs are evaluated: pairs within the distance at which the link could close with
``X`` as favourable as ``-4 sigma`` (chance 3e-5 of more). A pair leaves the state when it leaves
that range and draws a fresh ``X`` if it comes back. Robots that are down keep their pairs'
shadowing (it belongs to the geometry, not the radio); they just have no working link. Robots with
non-finite positions have no pairs at all.

Neighbour tables: mesh radios keep a bounded table of the neighbours they route through (802.15.4
/ Zigbee stacks hold a few tens of entries), so a robot links with at most its `neighbour_table`
nearest robots (the strongest mean signals; 32 by default) besides any fixed node in range; a pair
is a candidate when either end has the other in its table. A swarm of a few tens of robots never
notices; a dense swarm of a thousand keeps O(n) pairs instead of O(n^2), with every robot still
linked to its neighbourhood, so the graph's components and hops are those of the local mesh.

Determinism: pairs are kept sorted by key ``i * N + j`` (``i < j``) and the Gaussian draws are
taken in that order, one per new or moved pair, so the same inputs and seed give the same `Links`.

Disjoint paths (Menger's theorem, e.g. Diestel, *Graph Theory*, 5th ed., 2017, section 3.3): the
number of internally node-disjoint a-b paths equals the fewest nodes whose removal separates a
from b; it is found as a maximum flow after splitting every node into an in- and an out-node
joined by an arc of capacity 1 (node splitting: Ahuja, Magnanti, Orlin, *Network Flows*, 1993).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse
from scipy.sparse.csgraph import breadth_first_order, connected_components, maximum_flow
from scipy.spatial import cKDTree

from swarm.errors import SwarmError
from swarm.planning.radio import RadioParams, comm_range_m, received_power_dbm

#: Candidate pairs: the link could close with shadowing this many standard deviations favourable.
CANDIDATE_SIGMAS = 4.0
#: Robots in each robot's radio neighbour table (module docstring).
NEIGHBOUR_TABLE = 32
#: Pairs closer than this are evaluated at this distance (path loss needs d > 0), metres.
MIN_DISTANCE_M = 1e-3

_RR, _RF, _FF = 0, 1, 2  # pair classes: robot-robot, robot-fixed, fixed-fixed


@dataclass
class Links:
    """The radio graph at one step. Nodes: robots ``0..n-1``, then the fixed nodes (source, sinks)."""

    adjacency: scipy.sparse.csr_matrix  # (N, N) bool, symmetric
    margin_db: scipy.sparse.csr_matrix  # (N, N) float, same pattern: P_rx - X - sensitivity, dB
    degree: np.ndarray  # (n,) working links of each robot (to robots and fixed nodes)
    component: np.ndarray  # (N,) connected-component label
    source_hops: np.ndarray  # (n,) hops from the source to each robot; -1 unreachable or no source

    @property
    def n_robots(self) -> int:
        return len(self.degree)

    @property
    def n_nodes(self) -> int:
        return self.adjacency.shape[0]

    def connected(self, a: int, b: int) -> bool:
        """Can nodes a and b reach each other over working links (any number of hops)?"""
        return bool(self.component[a] == self.component[b])

    def disjoint_paths(self, a: int, b: int, limit: int = 2) -> int:
        """Internally node-disjoint paths between nodes a and b, counted up to `limit`.

        A direct a-b link counts as one path. Every other node, fixed or robot, can carry at most
        one path (module docstring: node splitting and maximum flow)."""
        return _node_connectivity(self.adjacency, a, [b], limit)[0]

    def fixed_linked(self, redundancy: int = 1) -> bool:
        """Does the source reach every sink with at least `redundancy` node-disjoint paths?

        As the relay planner counts redundancy (`swarm.planning.relay.single_loss_cuts`: only relay
        robots can be lost), fixed nodes are never cut: a path may pass through another sink, and
        a direct link between fixed nodes cannot be broken by losing robots. So this is "no set of
        fewer than `redundancy` robots separates the source from any sink". True when there are
        no sinks."""
        n, big_n = self.n_robots, self.n_nodes
        sinks = list(range(n + 1, big_n))
        if redundancy <= 0 or not sinks:
            return True
        if not all(self.connected(n, s) for s in sinks):
            return False
        if redundancy == 1:
            return True
        fixed = np.zeros(big_n, dtype=bool)
        fixed[n:] = True
        return min(_node_connectivity(self.adjacency, n, sinks, redundancy, uncuttable=fixed)) >= redundancy


def _node_connectivity(
    adjacency: scipy.sparse.csr_matrix,
    a: int,
    targets: list[int],
    limit: int,
    uncuttable: np.ndarray | None = None,
) -> list[int]:
    """For each b in `targets`: min(limit, internally node-disjoint a-b paths), by maximum flow on
    the split graph.

    In-node v, out-node v + N; arc v -> v + N has capacity 1 (``limit`` for a, b and `uncuttable`
    nodes); each link u-v gives arcs u + N -> v and v + N -> u of capacity 1 (``limit`` between two
    uncuttable nodes, which no robot loss can break). A super-source 2N feeds a + N through an arc
    of capacity ``limit``, so the flow, and with it Dinic's work, stops at ``limit``."""
    big_n = adjacency.shape[0]
    for node in (a, *targets):
        if not 0 <= node < big_n:
            raise IndexError(f"comms: nodes must be in 0..{big_n - 1}, found {node}")
    if limit <= 0:
        return [0] * len(targets)
    targets = list(targets)
    out: dict[int, int] = {}
    # a quick lower bound first: the direct link and each common neighbour w (path a-w-b) are
    # node-disjoint paths; in a dense swarm they settle it without a flow computation
    ptr, idx = adjacency.indptr, adjacency.indices
    near_a = set(idx[ptr[a] : ptr[a + 1]].tolist())
    for b in targets:
        near_b = idx[ptr[b] : ptr[b + 1]].tolist()
        if a == b or (b in near_a) + len(near_a.intersection(near_b)) >= limit:
            out[b] = limit
    rest = [b for b in targets if b not in out]
    if not rest:
        return [out[b] for b in targets]
    coo = adjacency.tocoo()
    u, v = coo.row.astype(np.int32), coo.col.astype(np.int32)
    if uncuttable is None:
        arc_cap = np.ones(len(u), dtype=np.int32)
    else:
        arc_cap = np.where(uncuttable[u] & uncuttable[v], limit, 1).astype(np.int32)
    nodes = np.arange(big_n, dtype=np.int32)
    rows = np.concatenate([nodes, u + big_n, [2 * big_n]]).astype(np.int32)
    cols = np.concatenate([nodes + big_n, v, [a + big_n]]).astype(np.int32)
    for b in rest:
        node_cap = np.ones(big_n, dtype=np.int32)
        if uncuttable is not None:
            node_cap[uncuttable] = limit
        node_cap[[a, b]] = limit
        caps = np.concatenate([node_cap, arc_cap, [limit]]).astype(np.int32)
        graph = scipy.sparse.csr_matrix((caps, (rows, cols)), shape=(2 * big_n + 1, 2 * big_n + 1))
        out[b] = int(min(maximum_flow(graph, 2 * big_n, b).flow_value, limit))
    return [out[b] for b in targets]


def _candidate_range_m(radio: RadioParams, sigmas: float) -> float:
    """Largest distance at which P_rx(d) + sigmas * sigma >= sensitivity; 0 if not even at 1 mm."""
    try:
        return comm_range_m(dataclasses.replace(radio, fade_margin_db=-sigmas * radio.shadowing_sigma_db))
    except SwarmError:
        return 0.0


class RadioNet:
    """Links among `n_robots` robots and the fixed nodes at `fixed_m` (source first, then sinks),
    with per-pair shadowing that persists and decorrelates as the ends move (module docstring)."""

    def __init__(
        self,
        radio: RadioParams,
        n_robots: int,
        fixed_m: np.ndarray | None = None,
        *,
        fixed_height_m: float = 2.0,
        decorrelation_m: float = 20.0,
        neighbour_table: int | None = NEIGHBOUR_TABLE,
    ) -> None:
        if n_robots < 0:
            raise SwarmError(f"comms: n_robots must be >= 0, found {n_robots}")
        if not (math.isfinite(decorrelation_m) and decorrelation_m > 0):
            raise SwarmError(f"comms: decorrelation_m must be a positive number, found {decorrelation_m!r}")
        fixed = np.empty((0, 2)) if fixed_m is None else np.asarray(fixed_m, dtype=np.float64).reshape(-1, 2)
        if not np.all(np.isfinite(fixed)):
            raise SwarmError("comms: fixed node positions must be finite")
        self.radio = radio
        self.n = int(n_robots)
        self.f = len(fixed)
        self.n_nodes = self.n + self.f
        self.fixed_m = fixed
        self.decorrelation_m = float(decorrelation_m)
        if neighbour_table is not None and neighbour_table < 1:
            raise SwarmError(f"comms: neighbour_table must be >= 1 or None, found {neighbour_table}")
        self.neighbour_table = neighbour_table
        self.sigma_db = float(radio.shadowing_sigma_db)
        h = radio.tx_height_m
        # one link budget per pair class: only the antenna heights differ
        self._radios = (
            dataclasses.replace(radio, tx_height_m=h, rx_height_m=h),
            dataclasses.replace(radio, tx_height_m=h, rx_height_m=fixed_height_m),
            dataclasses.replace(radio, tx_height_m=fixed_height_m, rx_height_m=fixed_height_m),
        )
        self.candidate_range_m = tuple(_candidate_range_m(r, CANDIDATE_SIGMAS) for r in self._radios)
        # per-pair state, sorted by key i * N + j (i < j)
        self._keys = np.empty(0, dtype=np.int64)
        self._shadow_db = np.empty(0)
        self._all_pairs: tuple[np.ndarray, np.ndarray] | None = None  # (live robots, their pair keys)
        self._last_xy = np.full((self.n_nodes, 2), np.nan)
        self._last_xy[self.n :] = fixed
        # fixed-fixed pairs never change: enumerate them once
        fi, fj = np.triu_indices(self.f, k=1)
        dff = np.linalg.norm(fixed[fi] - fixed[fj], axis=1) if self.f else np.empty(0)
        keep = dff <= self.candidate_range_m[_FF]
        self._ff_keys = (fi[keep] + self.n).astype(np.int64) * self.n_nodes + (fj[keep] + self.n)

    def reset(self) -> None:
        """Forget all shadowing state (a new episode)."""
        self._keys = np.empty(0, dtype=np.int64)
        self._shadow_db = np.empty(0)
        self._last_xy[: self.n] = np.nan

    def _candidates(self, pos: np.ndarray, finite: np.ndarray) -> np.ndarray:
        """Keys ``i * N + j`` (i < j) of the candidate pairs, sorted."""
        n, big_n = self.n, self.n_nodes
        live = np.flatnonzero(finite[:n])
        r_rr = self.candidate_range_m[_RR]
        keys = np.empty(0, dtype=np.int64)
        table = self.neighbour_table
        if len(live) >= 2 and r_rr > 0 and table is not None and len(live) > table + 1:
            # each robot's `table` nearest robots within range; a pair if either end lists the other
            dist, nb = cKDTree(pos[live]).query(pos[live], k=table + 1, distance_upper_bound=r_rr)
            a = np.repeat(np.arange(len(live)), table + 1)
            b = nb.ravel()
            ok = np.isfinite(dist.ravel()) & (a != b)  # itself (or a twin at the same spot) is not a pair
            a, b = a[ok], b[ok]
            lo_, hi_ = np.minimum(a, b), np.maximum(a, b)
            keys = np.unique(live[lo_].astype(np.int64) * big_n + live[hi_])
        elif len(live) >= 2 and r_rr > 0:
            lo, hi = pos[live].min(axis=0), pos[live].max(axis=0)
            if float(np.hypot(*(hi - lo))) <= r_rr:
                # every pair is in range (a compact swarm): the upper triangle, already in key order
                if self._all_pairs is None or not np.array_equal(self._all_pairs[0], live):
                    a, b = np.triu_indices(len(live), k=1)
                    self._all_pairs = (live, live[a].astype(np.int64) * big_n + live[b])
                keys = self._all_pairs[1]
            else:
                pairs = cKDTree(pos[live]).query_pairs(r_rr, output_type="ndarray")
                keys = live[pairs[:, 0]].astype(np.int64) * big_n + live[pairs[:, 1]]
                keys.sort()
        if len(live) and self.f and self.candidate_range_m[_RF] > 0:
            d = np.linalg.norm(pos[live, None, :] - self.fixed_m[None, :, :], axis=2)
            r, c = np.nonzero(d <= self.candidate_range_m[_RF])  # row-major: in key order
            rf = live[r].astype(np.int64) * big_n + (c + n)
            keys = np.insert(keys, np.searchsorted(keys, rf), rf)
        # fixed-fixed keys (i >= n) come after all the others
        return np.concatenate([keys, self._ff_keys])

    def update(self, xy: np.ndarray, up: np.ndarray, rng: np.random.Generator) -> Links:
        """Advance the shadowing to the robots' new positions `xy` (n, 2) and return the working
        links; `up` (n,) marks robots whose radio is on."""
        n, big_n = self.n, self.n_nodes
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        up = np.asarray(up, dtype=bool).reshape(-1)
        if len(xy) != n or len(up) != n:
            raise ValueError(f"comms: expected xy ({n}, 2) and up ({n},), found {xy.shape}, {up.shape}")
        pos = np.vstack([xy, self.fixed_m])
        finite = np.all(np.isfinite(pos), axis=1)
        on = np.concatenate([up, np.ones(self.f, dtype=bool)]) & finite

        keys = self._candidates(pos, finite)
        i = keys // big_n
        j = keys - i * big_n

        # match with last step's pairs (all of them, when the candidate set did not change)
        if np.array_equal(keys, self._keys):
            old = np.ones(len(keys), dtype=bool)
            prev = self._shadow_db
        elif len(self._keys):
            where = np.minimum(np.searchsorted(self._keys, keys), len(self._keys) - 1)
            old = self._keys[where] == keys
            prev = np.where(old, self._shadow_db[where], 0.0)
        else:
            old = np.zeros(len(keys), dtype=bool)
            prev = np.zeros(len(keys))
        with np.errstate(invalid="ignore"):
            step = np.sqrt(np.sum((pos - self._last_xy) ** 2, axis=1))
        step[~np.isfinite(step)] = np.inf
        moved_m = np.maximum(step[i], step[j])

        # shadowing: X_new = rho X_old + sqrt(1 - rho^2) sigma Z; rho = 1 (X kept, no draw) for a pair
        # that did not move, 0 (a fresh draw) for a new pair
        if self.sigma_db > 0:
            rho = np.exp(moved_m / -self.decorrelation_m)
            rho[~old] = 0.0
            fresh = rho < 1.0
            n_fresh = int(np.count_nonzero(fresh))
            if n_fresh == len(keys):
                z = rng.standard_normal(n_fresh)
            else:
                z = np.zeros(len(keys))
                z[fresh] = rng.standard_normal(n_fresh)
            shadow = rho * prev + np.sqrt(1.0 - rho * rho) * (self.sigma_db * z)
        else:
            shadow = np.zeros(len(keys))

        # mean received power, with the antenna heights of each pair class
        px, py = np.ascontiguousarray(pos[:, 0]), np.ascontiguousarray(pos[:, 1])
        dx, dy = px[i] - px[j], py[i] - py[j]
        d = np.maximum(np.sqrt(dx * dx + dy * dy), MIN_DISTANCE_M)
        prx = received_power_dbm(d, self._radios[_RR])
        for c in (_RF, _FF):
            sel = np.flatnonzero(j >= n) if c == _RF else np.flatnonzero(i >= n)
            if c == _RF:
                sel = sel[i[sel] < n]
            if len(sel):
                prx[sel] = received_power_dbm(d[sel], self._radios[c])

        self._keys, self._shadow_db = keys, shadow
        self._last_xy[finite] = pos[finite]

        margin = prx - shadow - self.radio.sensitivity_dbm
        works = (margin >= 0.0) & on[i] & on[j]
        return self._links(i[works], j[works], margin[works])

    def _links(self, i: np.ndarray, j: np.ndarray, margin: np.ndarray) -> Links:
        n, big_n = self.n, self.n_nodes
        i32, j32 = i.astype(np.int32), j.astype(np.int32)
        # lower triangle first: with the keys sorted, the stable row sort of the COO -> CSR conversion
        # leaves every row's columns ascending, so scipy need not sort them
        margin_db = scipy.sparse.csr_matrix(
            (np.concatenate([margin, margin]), (np.concatenate([j32, i32]), np.concatenate([i32, j32]))),
            shape=(big_n, big_n),
        )
        indices, indptr = margin_db.indices, margin_db.indptr
        adjacency = scipy.sparse.csr_matrix(
            (np.ones(len(indices), dtype=bool), indices.copy(), indptr.copy()), shape=(big_n, big_n)
        )
        degree = np.diff(indptr)[:n].astype(np.intp)
        # csgraph works on float weights: hand it one (unit weights) rather than have it convert the
        # bool matrix twice; the matrix is symmetric, so "directed" saves a transpose, same answer
        graph = scipy.sparse.csr_matrix((np.ones(len(indices)), indices, indptr), shape=(big_n, big_n))
        _, component = connected_components(graph, directed=True, connection="strong")
        source_hops = np.full(n, -1, dtype=np.intp)
        if self.f:
            order, pred = breadth_first_order(graph, n, directed=True, return_predecessors=True)
            hops = [-1] * big_n
            hops[n] = 0
            parent = pred.tolist()
            for v in order[1:].tolist():  # BFS order: a node's parent comes before it
                hops[v] = hops[parent[v]] + 1
            source_hops[:] = hops[:n]
        return Links(adjacency, margin_db, degree, component, source_hops)
