"""The radio's compiled kernels against the scipy code they replace: the same candidate pairs as
per-run k-d tree queries (ties at a table's edge flagged), the same CSR arrays as a stable sort,
the same component labels as `connected_components` and the same hops as a breadth-first search,
bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse
from scipy.sparse.csgraph import connected_components, shortest_path
from scipy.spatial import cKDTree

from swarm.sim import pair_kernels


def _kd_tree_keys(
    xy: np.ndarray, live: np.ndarray, fixed: np.ndarray, k: int, r: float, r_rf: float
) -> np.ndarray:
    """One run's candidate keys i * N + j as `comms.RadioNet._candidates` finds them."""
    n, big_n = len(xy), len(xy) + len(fixed)
    idx = np.flatnonzero(live)
    _, nb = cKDTree(xy[idx]).query(xy[idx], k=k, distance_upper_bound=r)
    a = np.repeat(np.arange(len(idx)), k)
    b = nb.ravel()
    ok = (b < len(idx)) & (a != b)
    lo, hi = np.minimum(a[ok], b[ok]), np.maximum(a[ok], b[ok])
    keys = np.unique(idx[lo].astype(np.int64) * big_n + idx[hi])
    d = np.linalg.norm(xy[idx, None, :] - fixed[None, :, :], axis=2)
    row, col = np.nonzero(d <= r_rf)
    return np.sort(np.concatenate([keys, idx[row].astype(np.int64) * big_n + col + n]))


@pytest.mark.parametrize("k", [9, 33])  # a short table, and the radios' (32 and the robot itself)
@pytest.mark.parametrize("n", [120, 300])  # the pairs read off a pair matrix (up to 256), or row by row
@pytest.mark.parametrize("layout", ["uniform", "clusters", "line"])
def test_table_candidates_are_the_k_d_trees(layout: str, n: int, k: int) -> None:
    rng = np.random.default_rng(5)
    runs = 4
    if layout == "uniform":
        xy = rng.uniform(0, 200, size=(runs, n, 2))
    elif layout == "clusters":  # a swarm just off its launch points, as in a benchmark
        xy = rng.uniform(0, 300, size=(runs, 12, 1, 2)) + rng.normal(0, 0.5, size=(runs, 12, n // 12, 2))
        xy = xy.reshape(runs, n, 2)
    else:
        xy = np.stack([rng.uniform(0, 500, size=(runs, n)), np.full((runs, n), 3.0)], axis=2)
    live = rng.random((runs, n)) > 0.1
    fixed = np.array([[50.0, 50.0], [120.0, 10.0]])
    ff = np.array([n * (n + 2) + n + 1], np.int64)
    r, r_rf = 60.0, 40.0
    order = np.array([2, 0, 3, 1])  # batch run numbers need not be in order
    keys, tie = pair_kernels.table_candidates(xy, live, order, fixed, ff, k, r * r, r_rf, n + 2)
    assert not tie.any()
    nn = (n + 2) ** 2
    want = [_kd_tree_keys(xy[q], live[q], fixed, k, r, r_rf) for q in range(runs)]
    want = np.concatenate([np.append(w, ff) + order[q] * nn for q, w in enumerate(want)])
    np.testing.assert_array_equal(keys, want)


def test_a_tie_at_a_tables_edge_is_left_to_the_k_d_tree() -> None:
    """Robots launched in stacks: which of the equally near a robot keeps is the k-d tree's choice."""
    xy = np.repeat(np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]]), 4, axis=0)[None]
    live = np.ones((1, 12), bool)
    spread = xy + np.arange(12)[None, :, None] * 1e-3 * np.array([1.0, 0.3])
    both, lives = np.concatenate([xy, spread]), np.repeat(live, 2, axis=0)
    no_fixed, no_keys = np.empty((0, 2)), np.empty(0, np.int64)
    keys, tie = pair_kernels.table_candidates(both, lives, np.arange(2), no_fixed, no_keys, 5, 1e4, 0.0, 12)
    np.testing.assert_array_equal(tie, [True, False])
    np.testing.assert_array_equal(keys, 144 + _kd_tree_keys(spread[0], live[0], no_fixed, 5, 100.0, 0.0))


@pytest.mark.parametrize("layout", ["uniform", "stacks", "line", "lattice"])
def test_nearest_others_is_a_stable_sort_of_every_distance(layout: str) -> None:
    """The observation's neighbour table in runs of many robots: each point's k nearest others,
    nearest first and equal distances to the lower index, as a stable argsort of every squared
    distance orders them; stacked and lattice points make many ties, at the table's edge too."""
    rng = np.random.default_rng(8)
    n, k = 700, 4
    if layout == "uniform":
        xy = rng.uniform(0, 300, (n, 2))
    elif layout == "stacks":  # robots launched from a few spots
        xy = np.repeat(rng.uniform(0, 100, (35, 2)), 20, axis=0)
    elif layout == "line":  # a swarm strung along a beach
        xy = np.column_stack([rng.uniform(0, 900, n), rng.uniform(100, 120, n)])
    else:
        xy = rng.integers(0, 12, (n, 2)).astype(float)
    got = pair_kernels.nearest_others(xy[:, 0].copy(), xy[:, 1].copy(), k)
    dx, dy = xy[None, :, 0] - xy[:, None, 0], xy[None, :, 1] - xy[:, None, 1]
    d2 = dx * dx + dy * dy
    np.fill_diagonal(d2, np.inf)
    np.testing.assert_array_equal(got, np.argsort(d2, axis=1, kind="stable")[:, :k])
    few = pair_kernels.nearest_others(xy[:3, 0].copy(), xy[:3, 1].copy(), k)
    assert (few[:, 2:] == -1).all() and (np.sort(few[:, :2], axis=1) >= 0).all()


def test_link_csr_components_and_hops_are_scipys() -> None:
    rng = np.random.default_rng(9)
    k, n, big_n = 5, 40, 42
    pairs = []
    for b in range(k):
        i, j = np.triu_indices(big_n, k=1)
        pick = rng.random(len(i)) < 0.03
        pairs.append((b * big_n + i[pick], b * big_n + j[pick]))
    u = np.concatenate([p[0] for p in pairs])
    v = np.concatenate([p[1] for p in pairs])
    margin = rng.uniform(0, 20, len(u))
    indptr, indices, margins, counts = pair_kernels.link_csr(u, v, margin, k * big_n)
    rows = np.concatenate([v, u])
    order = np.argsort(rows, kind="stable")
    np.testing.assert_array_equal(indices, np.concatenate([u, v])[order])
    np.testing.assert_array_equal(margins, np.concatenate([margin, margin])[order])
    np.testing.assert_array_equal(
        indptr, np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=k * big_n))])
    )
    np.testing.assert_array_equal(counts, np.diff(indptr))
    assert indptr.dtype == indices.dtype == np.int32

    component, hops = pair_kernels.components_and_hops(indptr, indices, k, n, big_n)
    graph = scipy.sparse.csr_matrix((np.ones(len(indices)), indices, indptr), shape=(k * big_n,) * 2)
    _, labels = connected_components(graph, directed=True, connection="strong")
    labels = labels.reshape(k, big_n)
    np.testing.assert_array_equal(component, labels - labels.min(axis=1, keepdims=True))
    assert component.dtype == labels.dtype
    dist = shortest_path(graph, unweighted=True, indices=np.arange(k) * big_n + n)
    want = np.stack([dist[b, b * big_n : b * big_n + n] for b in range(k)])
    np.testing.assert_array_equal(hops, np.where(np.isfinite(want), want, -1).astype(np.int64))


def test_carried_over_is_a_binary_search() -> None:
    rng = np.random.default_rng(2)
    old_keys = np.unique(rng.integers(0, 5000, 800))
    old_values = rng.normal(size=len(old_keys))
    keys = np.unique(rng.integers(0, 5000, 900))
    old, values = pair_kernels.carried_over(keys, old_keys, old_values)
    where = np.minimum(np.searchsorted(old_keys, keys), len(old_keys) - 1)
    np.testing.assert_array_equal(old, old_keys[where] == keys)
    np.testing.assert_array_equal(values, np.where(old, old_values[where], 0.0))
    empty, none = pair_kernels.carried_over(keys, old_keys[:0], old_values[:0])
    assert not empty.any() and not none.any()
