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

Batches: `update_nets` updates the nets of several runs of one configuration (a batched world's
runs) together: the geometry and link budgets as arrays over all their pairs, the components and
hops as one graph search on the block-diagonal graph of all the runs. Each run still draws its
shadowing from its own generator, in its own key order, so each gets the `Links` it would alone
(`RadioNet.update` is `update_nets` with one net).

Disjoint paths (Menger's theorem, e.g. Diestel, *Graph Theory*, 5th ed., 2017, section 3.3): the
number of internally node-disjoint a-b paths equals the fewest nodes whose removal separates a
from b; it is found as a maximum flow after splitting every node into an in- and an out-node
joined by an arc of capacity 1 (node splitting: Ahuja, Magnanti, Orlin, *Network Flows*, 1993).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import scipy.sparse
from scipy.sparse.csgraph import maximum_flow
from scipy.spatial import cKDTree

from swarm.errors import SwarmError
from swarm.planning.radio import RadioParams, comm_range_m, received_power_dbm
from swarm.sim import draws, pair_kernels

#: Candidate pairs: the link could close with shadowing this many standard deviations favourable.
CANDIDATE_SIGMAS = 4.0
#: Robots in each robot's radio neighbour table (module docstring).
NEIGHBOUR_TABLE = 32
#: Pairs closer than this are evaluated at this distance (path loss needs d > 0), metres.
MIN_DISTANCE_M = 1e-3

#: Up to this many robots the candidate pairs of all the runs of a batch are found at once on dense
#: (runs, N, N) distances; where the neighbour tables apply, by one compiled grid search over all
#: the runs (`pair_kernels.table_candidates`); otherwise run by run with k-d trees.
DENSE_ROBOTS = 64

_RR, _RF, _FF = 0, 1, 2  # pair classes: robot-robot, robot-fixed, fixed-fixed


@dataclass(eq=False)
class Links:
    """The radio graph at one step. Nodes: robots ``0..n-1``, then the fixed nodes (source, sinks).

    The working links are held as the CSR arrays of the symmetric margin matrix; `adjacency` and
    `margin_db` are built from them when first asked for (a batch's steps mostly need neither)."""

    indptr: np.ndarray  # (N + 1,) int32 CSR row pointers of the working links, both directions
    indices: np.ndarray  # int32 the other end of each, ascending within a row
    margins: np.ndarray  # P_rx - X - sensitivity of each, dB (>= 0)
    degree: np.ndarray  # (n,) working links of each robot (to robots and fixed nodes)
    component: np.ndarray  # (N,) connected-component label
    source_hops: np.ndarray  # (n,) hops from the source to each robot; -1 unreachable or no source

    @functools.cached_property
    def margin_db(self) -> scipy.sparse.csr_matrix:
        """(N, N) float: P_rx - X - sensitivity of the working links, dB; symmetric."""
        return self._matrix(self.margins.copy())

    @functools.cached_property
    def adjacency(self) -> scipy.sparse.csr_matrix:
        """(N, N) bool: the working links; symmetric."""
        return self._matrix(np.ones(len(self.indices), dtype=bool))

    def _matrix(self, data: np.ndarray) -> scipy.sparse.csr_matrix:
        big_n = self.n_nodes
        return scipy.sparse.csr_matrix((data, self.indices.copy(), self.indptr.copy()), shape=(big_n, big_n))

    @property
    def n_robots(self) -> int:
        return len(self.degree)

    @property
    def n_nodes(self) -> int:
        return len(self.indptr) - 1

    def connected(self, a: int, b: int) -> bool:
        """Can nodes a and b reach each other over working links (any number of hops)?"""
        return bool(self.component[a] == self.component[b])

    def disjoint_paths(self, a: int, b: int, limit: int = 2) -> int:
        """Internally node-disjoint paths between nodes a and b, counted up to `limit`.

        A direct a-b link counts as one path. Every other node, fixed or robot, can carry at most
        one path (module docstring: node splitting and maximum flow)."""
        return _node_connectivity(self.indptr, self.indices, a, [b], limit)[0]

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
        counts = _node_connectivity(self.indptr, self.indices, n, sinks, redundancy, uncuttable=fixed)
        return min(counts) >= redundancy


def _node_connectivity(
    indptr: np.ndarray,
    indices: np.ndarray,
    a: int,
    targets: list[int],
    limit: int,
    uncuttable: np.ndarray | None = None,
) -> list[int]:
    """For each b in `targets`: min(limit, internally node-disjoint a-b paths), by maximum flow on
    the split graph of the links in CSR form (`indptr`, `indices`, both directions).

    In-node v, out-node v + N; arc v -> v + N has capacity 1 (``limit`` for a, b and `uncuttable`
    nodes); each link u-v gives arcs u + N -> v and v + N -> u of capacity 1 (``limit`` between two
    uncuttable nodes, which no robot loss can break). A super-source 2N feeds a + N through an arc
    of capacity ``limit``, so the flow, and with it Dinic's work, stops at ``limit``."""
    big_n = len(indptr) - 1
    for node in (a, *targets):
        if not 0 <= node < big_n:
            raise IndexError(f"comms: nodes must be in 0..{big_n - 1}, found {node}")
    if limit <= 0:
        return [0] * len(targets)
    targets = list(targets)
    out: dict[int, int] = {}
    # a quick lower bound first: the direct link and each common neighbour w (path a-w-b) are
    # node-disjoint paths; in a dense swarm they settle it without a flow computation
    near_a = set(indices[indptr[a] : indptr[a + 1]].tolist())
    for b in targets:
        near_b = indices[indptr[b] : indptr[b + 1]].tolist()
        if a == b or (b in near_a) + len(near_a.intersection(near_b)) >= limit:
            out[b] = limit
    rest = [b for b in targets if b not in out]
    if not rest:
        return [out[b] for b in targets]
    u = np.repeat(np.arange(big_n, dtype=np.int32), np.diff(indptr))
    v = indices.astype(np.int32)
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


@functools.lru_cache(maxsize=64)
def _shared(config: tuple) -> tuple:
    """The first of equal configurations, so that the nets of a batch compare theirs by identity."""
    return config


@functools.lru_cache(maxsize=64)
def _candidate_range_m(radio: RadioParams, sigmas: float) -> float:
    """Largest distance at which P_rx(d) + sigmas * sigma >= sensitivity; 0 if not even at 1 mm.
    Cached: every run of a study builds its nets with the same radios."""
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
        # what nets updated together must share (`update_nets`); equal ones are one object
        self._config = _shared((self._radios, self.n, fixed.tobytes(), self.decorrelation_m, neighbour_table))
        # per-pair state, sorted by key i * N + j (i < j)
        self._keys = np.empty(0, dtype=np.int64)
        self._shadow_db = np.empty(0)
        # (the state of the last `update_nets` call that held this net's, its index there)
        self._batch: tuple[_BatchState, int] | None = None
        self._all_pairs: tuple[np.ndarray, np.ndarray] | None = None  # (live robots, their pair keys)
        self._last_xy = np.full((self.n_nodes, 2), np.nan)
        self._last_xy[self.n :] = fixed
        # fixed-fixed pairs never change: enumerate them once
        fi, fj = np.triu_indices(self.f, k=1)
        dff = np.linalg.norm(fixed[fi] - fixed[fj], axis=1) if self.f else np.empty(0)
        keep = dff <= self.candidate_range_m[_FF]
        self._ff_keys = (fi[keep] + self.n).astype(np.int64) * self.n_nodes + (fj[keep] + self.n)
        self._ff_mask = np.zeros((self.f, self.f), dtype=bool)
        self._ff_mask[fi[keep], fj[keep]] = True
        self._upper = np.triu(np.ones((self.n, self.n), dtype=bool), k=1) if self.n <= DENSE_ROBOTS else None

    def reset(self) -> None:
        """Forget all shadowing state (a new episode)."""
        self._batch = None
        self._keys = np.empty(0, dtype=np.int64)
        self._shadow_db = np.empty(0)
        self._last_xy[: self.n] = np.nan

    def update(self, xy: np.ndarray, up: np.ndarray, rng: np.random.Generator) -> Links:
        """Advance the shadowing to the robots' new positions `xy` (n, 2) and return the working
        links; `up` (n,) marks robots whose radio is on."""
        n = self.n
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        up = np.asarray(up, dtype=bool).reshape(-1)
        if len(xy) != n or len(up) != n:
            raise ValueError(f"comms: expected xy ({n}, 2) and up ({n},), found {xy.shape}, {up.shape}")
        return update_nets([self], xy[None], up[None], [rng])[0]

    # candidate pairs ----------------------------------------------------------------------------------
    def _candidate_keys(self, pos: np.ndarray, finite: np.ndarray) -> np.ndarray:
        """Keys ``b * N^2 + i * N + j`` (i < j) of the candidate pairs of runs ``b = 0..k-1`` at
        positions `pos` (k, N, 2), sorted; `finite` (k, N) marks the nodes with a position."""
        k, n, big_n = len(pos), self.n, self.n_nodes
        nn = big_n * big_n
        table = self.neighbour_table
        dense = np.full(k, n <= DENSE_ROBOTS)
        tabled = np.zeros(k, dtype=bool)
        if table is not None and n > table + 1:
            live = np.count_nonzero(finite[:, :n], axis=1)
            dense &= live <= table + 1
            tabled = (live > table + 1) & (self.candidate_range_m[_RR] > 0)
        parts = []
        if dense.all():
            parts.append(np.flatnonzero(self._dense_candidates(pos, finite)))
        elif dense.any():
            runs = np.flatnonzero(dense)
            run, key = np.divmod(np.flatnonzero(self._dense_candidates(pos[runs], finite[runs])), nn)
            parts.append(runs[run] * nn + key)
        rest = ~dense & ~tabled
        if tabled.any():
            parts.append(self._table_candidates(pos, finite, np.flatnonzero(tabled), rest))
        for b in np.flatnonzero(rest).tolist():
            parts.append(self._candidates(pos[b], finite[b]) + b * nn)
        return parts[0] if len(parts) == 1 else np.sort(np.concatenate(parts))

    def _table_candidates(
        self, pos: np.ndarray, finite: np.ndarray, runs: np.ndarray, rest: np.ndarray
    ) -> np.ndarray:
        """Batch keys of the runs `runs`, whose robots keep neighbour tables, from one compiled
        grid search over all of them; a run with a tie at some table's edge is marked in `rest`
        for the k-d tree, whose choice among equals the grid search cannot know."""
        n = self.n
        r_rr, r_rf = self.candidate_range_m[_RR], self.candidate_range_m[_RF]
        keys, tie = pair_kernels.table_candidates(
            pos[runs, :n], finite[runs, :n], runs, self.fixed_m, self._ff_keys,
            self.neighbour_table + 1, r_rr * r_rr, r_rf, self.n_nodes,
        )  # fmt: skip
        rest[runs[tie]] = True
        return keys

    def _dense_candidates(self, pos: np.ndarray, finite: np.ndarray) -> np.ndarray:
        """(k, N, N) bool, upper triangle: the candidate pairs of k runs whose robots are all in
        each other's neighbour tables. The same rule as `_candidates`, with the same arithmetic
        (squared distances against the squared range, as the k-d tree's pair query)."""
        n, big_n, k = self.n, self.n_nodes, len(pos)
        mask = np.zeros((k, big_n, big_n), dtype=bool)
        live = finite[:, :n]
        r_rr, r_rf = self.candidate_range_m[_RR], self.candidate_range_m[_RF]
        with np.errstate(invalid="ignore"):
            if n >= 2 and r_rr > 0:
                x, y = pos[:, :n, 0], pos[:, :n, 1]
                pairs = live[:, :, None] & live[:, None, :] & self._upper
                dx, dy = x[:, :, None] - x[:, None, :], y[:, :, None] - y[:, None, :]
                near = dx * dx + dy * dy <= r_rr * r_rr
                near &= pairs
                if not np.array_equal(near, pairs):
                    # a compact swarm (bounding box diagonal within range) has every pair in range
                    span_x = np.where(live, x, -np.inf).max(axis=1) - np.where(live, x, np.inf).min(axis=1)
                    span_y = np.where(live, y, -np.inf).max(axis=1) - np.where(live, y, np.inf).min(axis=1)
                    near |= pairs & (np.hypot(span_x, span_y) <= r_rr)[:, None, None]
                mask[:, :n, :n] = near
            if self.f and r_rf > 0:
                # sqrt(dx^2 + dy^2), as `np.linalg.norm` computes it in `_candidates`
                dx = pos[:, :n, 0, None] - self.fixed_m[:, 0]
                dy = pos[:, :n, 1, None] - self.fixed_m[:, 1]
                mask[:, :n, n:] = (np.sqrt(dx * dx + dy * dy) <= r_rf) & live[:, :, None]
        mask[:, n:, n:] = self._ff_mask
        return mask

    def _candidates(self, pos: np.ndarray, finite: np.ndarray) -> np.ndarray:
        """Keys ``i * N + j`` (i < j) of the candidate pairs of one run, sorted."""
        n, big_n = self.n, self.n_nodes
        live = np.flatnonzero(finite[:n])
        r_rr = self.candidate_range_m[_RR]
        keys = np.empty(0, dtype=np.int64)
        table = self.neighbour_table
        if len(live) >= 2 and r_rr > 0 and table is not None and len(live) > table + 1:
            # each robot's `table` nearest robots within range; a pair if either end lists the other
            _, nb = cKDTree(pos[live]).query(pos[live], k=table + 1, distance_upper_bound=r_rr)
            a = np.repeat(np.arange(len(live)), table + 1)
            b = nb.ravel()
            # missing neighbours are index len(live); itself (or a twin at the same spot) is not a pair
            ok = (b < len(live)) & (a != b)
            a, b = a[ok], b[ok]
            lo_, hi_ = np.minimum(a, b), np.maximum(a, b)
            keys = sorted_unique(live[lo_].astype(np.int64) * big_n + live[hi_])
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

    # the link budget ----------------------------------------------------------------------------------
    def _received_dbm(self, d: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
        """Mean received power over pairs at distances `d` between nodes `i` < `j` (local ids),
        with the antenna heights of each pair's class."""
        n = self.n
        prx = received_power_dbm(d, self._radios[_RR])
        for c in (_RF, _FF):
            sel = np.flatnonzero(j >= n) if c == _RF else np.flatnonzero(i >= n)
            if c == _RF:
                sel = sel[i[sel] < n]
            if len(sel):
                prx[sel] = received_power_dbm(d[sel], self._radios[c])
        return prx


def sorted_unique(keys: np.ndarray) -> np.ndarray:
    """`np.unique` of int keys by sorting (several times faster than its hash table here)."""
    keys = np.sort(keys)
    return keys[np.concatenate(([True], keys[1:] != keys[:-1]))] if len(keys) else keys


def update_nets(
    nets: Sequence[RadioNet], xy: np.ndarray, up: np.ndarray, rngs: Sequence[np.random.Generator]
) -> list[Links]:
    """`RadioNet.update` of k nets of one configuration at once (the runs of a batch): robots at
    `xy` (k, n, 2), radios `up` (k, n), each net drawing from its own generator in `rngs`.

    Every net takes its draws in its own key order, as alone, so each gets the `Links` it would
    get from its own `update` (module docstring: batches)."""
    if not nets:
        return []
    net = nets[0]
    k, n, big_n = len(nets), net.n, net.n_nodes
    if any(other._config is not net._config and other._config != net._config for other in nets[1:]):
        raise ValueError("comms: nets updated together must share radio, robots and fixed nodes")
    xy = np.asarray(xy, dtype=np.float64)
    up = np.asarray(up, dtype=bool)
    if xy.shape != (k, n, 2) or up.shape != (k, n) or len(rngs) != k:
        raise ValueError(f"comms: expected xy ({k}, {n}, 2), up ({k}, {n}) and {k} generators")
    pos = np.empty((k, big_n, 2))
    pos[:, :n] = xy
    pos[:, n:] = net.fixed_m
    finite = np.isfinite(pos).all(axis=2)
    on = finite.copy()
    on[:, :n] &= up

    keys = net._candidate_keys(pos, finite)  # b * N^2 + i * N + j
    together = _updated_together(nets)
    old, prev = _previous_shadowing(nets, keys, together)
    last = together.last_xy.copy() if together is not None else np.stack([m._last_xy for m in nets])
    with np.errstate(invalid="ignore"):
        step = np.sqrt(np.sum((pos - last) ** 2, axis=2)).ravel()
    step[~np.isfinite(step)] = np.inf
    px, py = pos[:, :, 0].ravel(), pos[:, :, 1].ravel()
    node_i, node_j, run, moved, d = pair_kernels.pair_geometry(keys, big_n, px, py, step, MIN_DISTANCE_M)
    shadow = _shadowing(net, old, prev, moved, run, rngs)

    first = run * big_n
    margin = net._received_dbm(d, node_i - first, node_j - first) - shadow - net.radio.sensitivity_dbm
    on = on.ravel()
    works = (margin >= 0.0) & on[node_i] & on[node_j]

    # hand each net its state back: its slice of the pairs (local keys), its positions
    ends = np.searchsorted(keys, np.arange(1, k) * (big_n * big_n)).tolist()
    local = keys - run * (big_n * big_n)
    last[finite] = pos[finite]
    batch = _BatchState(keys, shadow, last)
    for b, (m, lo, hi, last_b) in enumerate(zip(nets, [0, *ends], [*ends, len(keys)], last, strict=True)):
        m._keys, m._shadow_db, m._last_xy = local[lo:hi], shadow[lo:hi], last_b
        m._batch = (batch, b)
    return _links(net, k, node_i[works], node_j[works], margin[works])


class _BatchState(NamedTuple):
    """The pair state of the nets of one `update_nets` call, whole: each net holds its slices."""

    keys: np.ndarray  # batch keys b * N^2 + i * N + j
    shadow_db: np.ndarray
    last_xy: np.ndarray  # (k, N, 2)


def _updated_together(nets: Sequence[RadioNet]) -> _BatchState | None:
    """The state of the last `update_nets` call when it was these nets', in this order, and none
    has been reset since (the usual step of a batch): their state whole, without gathering it."""
    first = nets[0]._batch
    if first is None or first[1] != 0 or len(first[0].last_xy) != len(nets):
        return None
    batch = first[0]
    for b, m in enumerate(nets):
        mine = m._batch
        if mine is None or mine[0] is not batch or mine[1] != b:
            return None
    return batch


def _previous_shadowing(
    nets: Sequence[RadioNet], keys: np.ndarray, together: _BatchState | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Which of the pairs `keys` (batch keys) each net already had, and their shadowing then (0
    for new pairs). `together`: the nets' state whole (`_updated_together`)."""
    big_n = nets[0].n_nodes
    if together is not None:
        old_keys, old_shadow = together.keys, together.shadow_db
    elif len(nets) == 1:
        old_keys, old_shadow = nets[0]._keys, nets[0]._shadow_db
    else:
        nn = big_n * big_n
        old_keys = np.concatenate([m._keys + b * nn for b, m in enumerate(nets)])
        old_shadow = np.concatenate([m._shadow_db for m in nets])
    # all of them, when the candidate set did not change
    if np.array_equal(keys, old_keys):
        return np.ones(len(keys), dtype=bool), old_shadow
    return pair_kernels.carried_over(keys, old_keys, old_shadow)


def _shadowing(
    net: RadioNet,
    old: np.ndarray,
    prev: np.ndarray,
    moved_m: np.ndarray,
    run: np.ndarray,
    rngs: Sequence[np.random.Generator],
) -> np.ndarray:
    """X_new = rho X_old + sqrt(1 - rho^2) sigma Z over the pairs of all runs; rho = 1 (X kept, no
    draw) for a pair that did not move, 0 (a fresh draw) for a new pair. Run b's draws come from
    ``rngs[b]``, in its pairs' order."""
    if net.sigma_db <= 0:
        return np.zeros(len(old))
    rho = np.exp(moved_m / -net.decorrelation_m)
    rho[~old] = 0.0
    fresh = rho < 1.0
    z = np.zeros(len(old))
    counts = np.bincount(run[fresh], minlength=len(rngs))
    if counts.any():  # each run's draws in its pairs' order, run after run (`run` is sorted)
        fresh_z = np.empty(int(counts.sum()))
        draws.fill_normal(rngs, np.arange(len(rngs)), np.concatenate(([0], np.cumsum(counts))), fresh_z)
        z[fresh] = fresh_z
    return rho * prev + np.sqrt(1.0 - rho * rho) * (net.sigma_db * z)


def _links(net: RadioNet, k: int, u: np.ndarray, v: np.ndarray, margin: np.ndarray) -> list[Links]:
    """Each run's `Links` from the working pairs u < v (batch node ids ``b * N + i``, in key order)
    of k runs: one CSR of the block-diagonal graph of all the runs, then its components and the
    hops from each run's source (`pair_kernels`)."""
    n, big_n = net.n, net.n_nodes
    indptr, indices, margins, counts = pair_kernels.link_csr(u, v, margin, k * big_n)
    component, hops = pair_kernels.components_and_hops(indptr, indices, k, n, big_n)
    degree = counts.reshape(k, big_n)[:, :n]
    # each run's CSR in its own node ids: a link never leaves its run
    ends = indptr[np.arange(k + 1) * big_n]
    ptr = np.empty((k, big_n + 1), dtype=np.int32)
    ptr[:, :big_n] = indptr[:-1].reshape(k, big_n)
    ptr[:, big_n] = ends[1:]
    ptr -= ends[:-1, None]
    local = indices % np.int32(max(big_n, 1))
    ends = ends.tolist()
    return [
        Links(ptr[b], local[lo:hi], margins[lo:hi], degree[b], component[b], hops[b])
        for b, lo, hi in zip(range(k), ends[:-1], ends[1:], strict=True)
    ]
