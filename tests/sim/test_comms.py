"""The radio graph: the link rule against the closed-form range, the fraction of working links
against the outage probability, shadowing that persists and decorrelates as Gudmundson's model
says, hop counts, node-disjoint paths (against brute force) and the relay's redundancy.

Statistical checks use 4-sigma bounds (binomial, or the standard error of a correlation
coefficient, (1 - rho^2) / sqrt(K)): a correct implementation fails one with chance < 1e-4; the
seeds are fixed, so the outcome is reproducible."""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest
from scipy.sparse.csgraph import connected_components, shortest_path
from scipy.stats import norm

from swarm.planning.radio import RadioParams, comm_range_m, outage_probability, received_power_dbm
from swarm.sim.comms import RadioNet, update_nets

#: Low power so ranges are tens of metres: R0 (sigma 0, no fade margin) about 36 m, two-ray regime.
RADIO = RadioParams(tx_power_dbm=-30.0, sensitivity_dbm=-100.0, shadowing_sigma_db=6.0)
QUIET = dataclasses.replace(RADIO, shadowing_sigma_db=0.0)


def _r0(radio: RadioParams, **heights: float) -> float:
    """The sim's link range with no shadowing: P_rx(d) = sensitivity (the fade margin is not used)."""
    return comm_range_m(dataclasses.replace(radio, fade_margin_db=0.0, **heights))


def _pairs(distances: np.ndarray, spacing_m: float) -> np.ndarray:
    """Robots 2k, 2k+1 at `distances[k]` apart; pairs on a square grid `spacing_m` apart."""
    k = len(distances)
    side = math.ceil(math.sqrt(k))
    base = np.column_stack([np.arange(k) % side, np.arange(k) // side]) * spacing_m
    xy = np.empty((2 * k, 2))
    xy[0::2] = base
    xy[1::2] = base + np.column_stack([distances, np.zeros(k)])
    return xy


def _pair_links(links, k: int) -> np.ndarray:
    a = np.arange(k) * 2
    return np.asarray(links.adjacency[a, a + 1]).ravel().astype(bool)


def _pair_margins(links, k: int) -> np.ndarray:
    a = np.arange(k) * 2
    return np.asarray(links.margin_db[a, a + 1]).ravel()


# the link rule -----------------------------------------------------------------------------------


def test_without_shadowing_a_link_works_exactly_within_the_zero_margin_range() -> None:
    r0 = _r0(QUIET)
    assert 25.0 < r0 < comm_range_m(dataclasses.replace(QUIET, fade_margin_db=-1.0))
    # the planner's range keeps the fade margin in reserve; the simulator does not
    assert comm_range_m(QUIET) < 0.6 * r0
    d = r0 * np.concatenate([np.linspace(0.05, 0.999, 40), np.linspace(1.001, 2.0, 40)])
    net = RadioNet(QUIET, 2 * len(d))
    links = net.update(_pairs(d, 5.0 * r0), np.ones(2 * len(d), bool), np.random.default_rng(0))
    works = _pair_links(links, len(d))
    np.testing.assert_array_equal(works, d <= r0)
    # margin: the mean received power over sensitivity
    expected = received_power_dbm(d[works], QUIET) - QUIET.sensitivity_dbm
    np.testing.assert_allclose(_pair_margins(links, len(d))[works], expected, rtol=0, atol=1e-9)
    assert links.adjacency.nnz == 2 * works.sum()


def test_fixed_nodes_link_with_their_own_antenna_height() -> None:
    h_fixed = 2.0
    r_rr = _r0(QUIET)
    r_rf = _r0(QUIET, rx_height_m=h_fixed)
    assert r_rf > 1.3 * r_rr  # the higher antenna moves the two-ray crossover out
    d = r_rf * np.array([0.5, 0.9, 0.99, 1.01, 1.2])
    net = RadioNet(QUIET, len(d), np.array([[0.0, 0.0]]), fixed_height_m=h_fixed)
    xy = np.column_stack([d * np.cos(np.arange(len(d))), d * np.sin(np.arange(len(d)))])
    links = net.update(xy, np.ones(len(d), bool), np.random.default_rng(0))
    source = len(d)
    np.testing.assert_array_equal(links.adjacency[source, : len(d)].toarray().ravel(), d <= r_rf)
    margin = links.margin_db[source, 0]
    radio_rf = dataclasses.replace(QUIET, rx_height_m=h_fixed)
    assert margin == pytest.approx(float(received_power_dbm(d[0], radio_rf)) - QUIET.sensitivity_dbm)


@pytest.mark.parametrize("fraction_of_r0", [0.7, 1.0, 1.3])
def test_working_fraction_matches_one_minus_outage_probability(fraction_of_r0: float) -> None:
    k = 3000
    d = fraction_of_r0 * _r0(RADIO)
    net = RadioNet(RADIO, 2 * k)
    links = net.update(
        _pairs(np.full(k, d), 3.0 * net.candidate_range_m[0]), np.ones(2 * k, bool), np.random.default_rng(7)
    )
    p = 1.0 - float(outage_probability(d, RADIO))
    assert 0.05 < p < 0.95
    observed = _pair_links(links, k).mean()
    assert abs(observed - p) < 4.0 * math.sqrt(p * (1 - p) / k)
    # the shadowing behind it is N(0, sigma): on working links X = mean margin - margin <= mean margin,
    # and its mean is that of a normal truncated above at the mean margin m: -sigma phi(a) / Phi(a)
    works = _pair_links(links, k)
    mean_margin = float(received_power_dbm(d, RADIO)) - RADIO.sensitivity_dbm
    x = mean_margin - _pair_margins(links, k)[works]
    a = mean_margin / RADIO.shadowing_sigma_db
    expected = -RADIO.shadowing_sigma_db * norm.pdf(a) / norm.cdf(a)
    assert x.max() <= mean_margin + 1e-9
    assert abs(x.mean() - expected) < 4.0 * RADIO.shadowing_sigma_db / math.sqrt(len(x))


# shadowing in space and time ---------------------------------------------------------------------

#: Short, strong links (24 dB mean margin at 1 m, sigma 2 dB): every link works, so each pair's
#: shadowing can be read back as X = mean margin - margin.
STRONG = RadioParams(tx_power_dbm=-40.0, sensitivity_dbm=-100.0, shadowing_sigma_db=2.0)


def _shadowing(links, k: int, d: float) -> np.ndarray:
    assert _pair_links(links, k).all()
    return float(received_power_dbm(d, STRONG)) - STRONG.sensitivity_dbm - _pair_margins(links, k)


def test_robots_that_do_not_move_keep_their_link_states() -> None:
    rng = np.random.default_rng(3)
    n = 60
    xy = rng.uniform(0, 3 * _r0(RADIO), size=(n, 2))
    net = RadioNet(RADIO, n, np.array([[0.0, -20.0], [150.0, 250.0]]))
    first = net.update(xy, np.ones(n, bool), rng)
    assert 0 < first.adjacency.nnz < n * (n - 1)  # some links work, some do not
    for _ in range(5):
        again = net.update(xy, np.ones(n, bool), rng)
        assert (again.adjacency != first.adjacency).nnz == 0
        np.testing.assert_array_equal(again.margin_db.toarray(), first.margin_db.toarray())


@pytest.mark.parametrize(("move_m", "rho"), [(20.0, math.exp(-1.0)), (5.0, math.exp(-0.25)), (2000.0, 0.0)])
def test_shadowing_decorrelates_as_gudmundson(move_m: float, rho: float) -> None:
    """Both ends move `move_m` (decorrelation 20 m): corr(X_before, X_after) = exp(-move / 20)."""
    k, d = 4000, 1.0
    net = RadioNet(STRONG, 2 * k, decorrelation_m=20.0)
    assert net.candidate_range_m[0] < 100.0
    xy = _pairs(np.full(k, d), 5000.0)
    up = np.ones(2 * k, bool)
    rng = np.random.default_rng(11)
    x0 = _shadowing(net.update(xy, up, rng), k, d)
    x1 = _shadowing(net.update(xy + np.array([move_m, 0.0]), up, rng), k, d)
    r = np.corrcoef(x0, x1)[0, 1]
    assert abs(r - rho) < 4.0 * (1.0 - rho**2) / math.sqrt(k)
    for x in (x0, x1):  # the marginal stays N(0, sigma^2)
        assert abs(x.mean()) < 4.0 * STRONG.shadowing_sigma_db / math.sqrt(k)
        assert abs(x.std() / STRONG.shadowing_sigma_db - 1.0) < 4.0 / math.sqrt(2 * k)


def test_small_steps_compose_into_the_correlation_of_the_whole_path() -> None:
    """Ten 2 m steps decorrelate as one 20 m move: exp(-1) (the exponential model is Markov)."""
    k, d = 4000, 1.0
    net = RadioNet(STRONG, 2 * k, decorrelation_m=20.0)
    xy = _pairs(np.full(k, d), 5000.0)
    up = np.ones(2 * k, bool)
    rng = np.random.default_rng(5)
    x0 = _shadowing(net.update(xy, up, rng), k, d)
    for step in range(1, 11):
        links = net.update(xy + np.array([2.0 * step, 0.0]), up, rng)
    r = np.corrcoef(x0, _shadowing(links, k, d))[0, 1]
    rho = math.exp(-1.0)
    assert abs(r - rho) < 4.0 * (1.0 - rho**2) / math.sqrt(k)


def test_same_inputs_and_seed_give_the_same_links() -> None:
    def run(seed: int) -> list:
        rng = np.random.default_rng(seed)
        geometry = np.random.default_rng(99)
        net = RadioNet(RADIO, 80, np.array([[0.0, 0.0], [300.0, 0.0]]))
        xy = geometry.uniform(0, 300, size=(80, 2))
        out = []
        for _ in range(4):
            xy = xy + geometry.normal(0, 3.0, size=xy.shape)
            up = geometry.random(80) > 0.1
            links = net.update(xy, up, rng)
            out.append((links.margin_db.toarray(), links.source_hops.copy(), links.component.copy()))
        return out

    a, b, c = run(1), run(1), run(2)
    for x, y in zip(a, b, strict=True):
        for u, v in zip(x, y, strict=True):
            np.testing.assert_array_equal(u, v)
    assert not np.array_equal(a[-1][0], c[-1][0])


def test_adjacency_is_symmetric_and_margins_are_non_negative() -> None:
    rng = np.random.default_rng(4)
    n = 150
    net = RadioNet(RADIO, n, np.array([[0.0, 0.0], [200.0, 100.0], [400.0, 0.0]]))
    links = net.update(rng.uniform(0, 400, size=(n, 2)), np.ones(n, bool), rng)
    assert (links.adjacency != links.adjacency.T).nnz == 0
    assert abs(links.margin_db - links.margin_db.T).max() == 0.0
    assert links.margin_db.data.min() >= 0.0
    assert links.adjacency.diagonal().sum() == 0
    np.testing.assert_array_equal(links.degree, np.asarray(links.adjacency.sum(axis=1)).ravel()[:n])
    _, labels = connected_components(links.adjacency, directed=False)
    # same partition as the returned labels
    for a, b in itertools.combinations(range(0, n + 3, 7), 2):
        assert (labels[a] == labels[b]) == links.connected(a, b)


def test_a_robot_whose_radio_is_off_has_no_links_and_the_others_are_unchanged() -> None:
    n = 40
    xy = np.random.default_rng(8).uniform(0, 150, size=(n, 2))
    all_up = RadioNet(RADIO, n, np.array([[0.0, 0.0]])).update(xy, np.ones(n, bool), np.random.default_rng(1))
    up = np.ones(n, bool)
    up[[3, 17]] = False
    some = RadioNet(RADIO, n, np.array([[0.0, 0.0]])).update(xy, up, np.random.default_rng(1))
    assert all_up.degree[3] > 0 and all_up.degree[17] > 0
    assert some.degree[3] == 0 and some.degree[17] == 0
    assert some.source_hops[3] == -1
    keep = np.ones(n + 1, bool)
    keep[[3, 17]] = False
    a = all_up.adjacency.toarray()[np.ix_(keep, keep)]
    b = some.adjacency.toarray()[np.ix_(keep, keep)]
    np.testing.assert_array_equal(a, b)  # the shadowing draws do not depend on who is up
    jammed = RadioNet(RADIO, n, np.array([[0.0, 0.0]])).update(
        xy, np.zeros(n, bool), np.random.default_rng(1)
    )
    assert jammed.adjacency.nnz == 0 and np.all(jammed.source_hops == -1)


def test_robots_without_a_position_are_left_out() -> None:
    xy = np.array([[0.0, 0.0], [10.0, 0.0], [np.nan, np.nan]])
    links = RadioNet(QUIET, 3).update(xy, np.ones(3, bool), np.random.default_rng(0))
    np.testing.assert_array_equal(links.degree, [1, 1, 0])


# graph quantities --------------------------------------------------------------------------------


def _chain(n_robots: int, hop: float) -> np.ndarray:
    return np.column_stack([hop * np.arange(1, n_robots + 1), np.zeros(n_robots)])


def test_source_hops_along_a_hand_built_chain() -> None:
    r0 = _r0(QUIET)
    hop = 0.9 * r0  # two hops apart is 1.8 r0: no shortcut
    xy = np.vstack([_chain(5, hop), [[0.0, 10 * r0]]])  # robot 5 far away
    # source at the origin, a sink just beyond the last robot; fixed antennas at robot height
    fixed = np.array([[0.0, 0.0], [6 * hop, 0.0]])
    net = RadioNet(QUIET, 6, fixed, fixed_height_m=QUIET.tx_height_m)
    links = net.update(xy, np.ones(6, bool), np.random.default_rng(0))
    np.testing.assert_array_equal(links.source_hops, [1, 2, 3, 4, 5, -1])
    np.testing.assert_array_equal(links.degree, [2, 2, 2, 2, 2, 0])
    assert links.connected(6, 7) and not links.connected(6, 5)
    assert links.fixed_linked(1) and not links.fixed_linked(2)
    assert links.disjoint_paths(6, 7) == 1
    assert links.disjoint_paths(0, 4, limit=5) == 1
    assert links.disjoint_paths(0, 5) == 0
    # no fixed nodes: no hops
    plain = RadioNet(QUIET, 6).update(xy, np.ones(6, bool), np.random.default_rng(0))
    np.testing.assert_array_equal(plain.source_hops, -1)
    assert plain.fixed_linked(2)  # no sinks: nothing to link


def test_disjoint_paths_on_a_ring_and_a_ladder() -> None:
    r0 = _r0(QUIET)
    side = 0.9 * r0
    k = 8  # octagon: second neighbours are 1.85 sides apart, out of range
    radius = side / (2 * math.sin(math.pi / k))
    ang = 2 * math.pi * np.arange(k) / k
    ring = np.column_stack([radius * np.cos(ang), radius * np.sin(ang)])
    links = RadioNet(QUIET, k).update(ring, np.ones(k, bool), np.random.default_rng(0))
    assert np.all(links.degree == 2)
    assert links.disjoint_paths(0, 4) == 2
    assert links.disjoint_paths(0, 4, limit=5) == 2
    assert links.disjoint_paths(0, 4, limit=1) == 1
    assert links.disjoint_paths(0, 1, limit=5) == 2  # the direct link and the long way round
    # ladder: two rails with rungs; any two nodes have 2 disjoint paths, never 3 between the ends
    rails = np.vstack([_chain(6, side), _chain(6, side) + np.array([0.0, side])])
    ladder = RadioNet(QUIET, 12).update(rails, np.ones(12, bool), np.random.default_rng(0))
    assert ladder.disjoint_paths(0, 11, limit=3) == 2
    assert ladder.disjoint_paths(0, 5, limit=3) == 2


def _brute_force_paths(adj: np.ndarray, a: int, b: int, limit: int) -> int:
    """Menger by enumeration: (direct link) + the smallest node set separating a and b without it."""
    n = len(adj)
    direct = int(adj[a, b])
    g = adj.copy()
    g[a, b] = g[b, a] = False
    others = [v for v in range(n) if v not in (a, b)]

    def separated(removed: tuple[int, ...]) -> bool:
        keep = np.ones(n, bool)
        keep[list(removed)] = False
        seen, todo = {a}, [a]
        while todo:
            u = todo.pop()
            for v in np.flatnonzero(g[u] & keep):
                if v not in seen:
                    seen.add(int(v))
                    todo.append(int(v))
        return b not in seen

    for size in range(limit - direct):
        if any(separated(cut) for cut in itertools.combinations(others, size)):
            return direct + size
    return limit


def test_disjoint_paths_match_brute_force_on_random_graphs() -> None:
    rng = np.random.default_rng(21)
    r0 = _r0(QUIET)
    checked = 0
    for _ in range(25):
        n = 11
        xy = rng.uniform(0, 2.2 * r0, size=(n, 2))
        links = RadioNet(QUIET, n).update(xy, np.ones(n, bool), rng)
        adj = links.adjacency.toarray()
        for a, b in itertools.combinations(range(0, n, 2), 2):
            for limit in (1, 2, 3):
                assert links.disjoint_paths(a, b, limit) == _brute_force_paths(adj, a, b, limit)
                checked += 1
    assert checked == 25 * 15 * 3


def test_fixed_linked_counts_redundancy_as_the_relay_planner_does() -> None:
    r0 = _r0(QUIET)
    h = QUIET.tx_height_m
    # two parallel chains of 4 from a source to a sink, 1.1 r0 apart (no links between the chains)
    top = _chain(4, 0.8 * r0) + np.array([0.0, 0.55 * r0])
    bottom = _chain(4, 0.8 * r0) - np.array([0.0, 0.55 * r0])
    fixed = np.array([[0.0, 0.0], [4.0 * r0, 0.0]])
    xy = np.vstack([top, bottom])
    net = RadioNet(QUIET, 8, fixed, fixed_height_m=h)
    links = net.update(xy, np.ones(8, bool), np.random.default_rng(0))
    assert links.fixed_linked(2) and links.fixed_linked(1)
    assert links.disjoint_paths(8, 9, limit=3) == 2
    up = np.ones(8, bool)
    up[1] = False  # one relay of the top chain lost
    one = net.update(xy, up, np.random.default_rng(0))
    assert one.fixed_linked(1) and not one.fixed_linked(2)
    up[6] = False  # and one of the bottom chain
    none = net.update(xy, up, np.random.default_rng(0))
    assert not none.fixed_linked(1)


def test_fixed_nodes_are_never_cut() -> None:
    """A direct source-sink link, or a path through another sink, cannot be broken by losing robots:
    `fixed_linked` counts it as the planner does; `disjoint_paths` counts node-disjoint paths."""
    r0 = _r0(QUIET)
    h = QUIET.tx_height_m
    direct = RadioNet(QUIET, 1, np.array([[0.0, 0.0], [0.5 * r0, 0.0]]), fixed_height_m=h)
    links = direct.update(np.array([[0.0, 5 * r0]]), np.ones(1, bool), np.random.default_rng(0))
    assert links.fixed_linked(2) and links.fixed_linked(3)
    assert links.disjoint_paths(1, 2, limit=3) == 1
    # source -- two robots in parallel -- sink 2 (directly linked) -- sink 1 beyond it
    fixed = np.array([[0.0, 0.0], [2.4 * r0, 0.0], [1.6 * r0, 0.0]])
    robots = np.array([[0.8 * r0, 0.3 * r0], [0.8 * r0, -0.3 * r0]])
    net = RadioNet(QUIET, 2, fixed, fixed_height_m=h)
    links = net.update(robots, np.ones(2, bool), np.random.default_rng(0))
    assert links.adjacency[3, 4] and not links.adjacency[2, 3]
    assert links.fixed_linked(2)
    assert links.disjoint_paths(2, 3) == 1  # strictly, every path goes through sink 2
    one = net.update(robots, np.array([True, False]), np.random.default_rng(0))
    assert one.fixed_linked(1) and not one.fixed_linked(2)


def test_a_dense_swarm_links_through_bounded_neighbour_tables() -> None:
    """300 robots all within range of each other: each keeps only its `neighbour_table` nearest as
    candidates, so the pair count is O(n) and every robot still links to its nearest neighbours."""
    rng = np.random.default_rng(7)
    xy = rng.uniform(0.0, 10.0, size=(300, 2))  # R0 is about 36 m: every pair could link
    table = 8
    net = RadioNet(QUIET, 300, neighbour_table=table)
    links = net.update(xy, np.ones(300, bool), rng)
    n_links = links.adjacency.nnz // 2
    assert n_links <= 300 * table
    assert n_links >= 300 * table // 2  # each robot's own table is at least half the union
    d = np.hypot(*(xy[:, None, :] - xy[None, :, :]).transpose(2, 0, 1))
    np.fill_diagonal(d, np.inf)
    nearest = np.argsort(d, axis=1)[:, :table]
    rows = np.repeat(np.arange(300), table)
    assert np.asarray(links.adjacency[rows, nearest.ravel()]).all()
    full = RadioNet(QUIET, 300, neighbour_table=None).update(xy, np.ones(300, bool), rng)
    assert full.adjacency.nnz // 2 == 300 * 299 // 2  # without tables: every pair
    assert len(np.unique(links.component)) == 1


# batches ------------------------------------------------------------------------------------------


def _assert_same_links(a, b) -> None:
    for name in ("margin_db", "adjacency"):
        x, y = getattr(a, name), getattr(b, name)
        np.testing.assert_array_equal(x.indptr, y.indptr)
        np.testing.assert_array_equal(x.indices, y.indices)
        np.testing.assert_array_equal(x.data, y.data)
    for name in ("degree", "component", "source_hops"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


@pytest.mark.parametrize("n_robots", [12, 40])  # 40 > table + 1: some runs use the neighbour tables
def test_a_batch_of_nets_gives_each_run_the_links_it_gets_alone(n_robots: int) -> None:
    """Runs updated together (`update_nets`) draw from their own generators in their own order:
    each run's links, hops, components and generator state are those of updating it alone."""
    rng = np.random.default_rng(3)
    r0 = _r0(RADIO)
    fixed = np.array([[0.0, 0.0], [3 * r0, 0.0], [0.0, 3 * r0]])
    k = 4
    alone = [RadioNet(RADIO, n_robots, fixed, neighbour_table=8) for _ in range(k)]
    together = [RadioNet(RADIO, n_robots, fixed, neighbour_table=8) for _ in range(k)]
    rngs_alone = [np.random.default_rng(s) for s in range(k)]
    rngs_together = [np.random.default_rng(s) for s in range(k)]
    xy = rng.uniform(0, 3 * r0, size=(k, n_robots, 2))
    for _ in range(5):
        xy += rng.normal(0.0, 3.0, size=xy.shape) * (rng.random((k, n_robots, 1)) < 0.5)
        pos = xy.copy()
        pos[rng.random((k, n_robots)) < 0.1] = np.nan
        pos[1, 9:] = np.nan  # run 1 keeps few robots: all pairs, while the others use tables
        up = rng.random((k, n_robots)) < 0.8
        one = [net.update(pos[b], up[b], rngs_alone[b]) for b, net in enumerate(alone)]
        batch = update_nets(together, pos, up, rngs_together)
        for b in range(k):
            _assert_same_links(one[b], batch[b])
            assert one[b].fixed_linked(2) == batch[b].fixed_linked(2)
            assert rngs_alone[b].bit_generator.state == rngs_together[b].bit_generator.state
            # hops and components as a plain search on the run's own graph finds them
            hops = shortest_path(batch[b].adjacency, unweighted=True, indices=n_robots)[:n_robots]
            np.testing.assert_array_equal(batch[b].source_hops, np.where(np.isfinite(hops), hops, -1))
            _, labels = connected_components(batch[b].adjacency, directed=False)
            np.testing.assert_array_equal(batch[b].component, labels)


def test_nets_updated_in_changing_groups_and_reset_between_give_what_they_give_alone() -> None:
    """The state a group of nets carries from one `update_nets` call to the next is taken whole
    only when the very same nets, in the same order, come again unreset: groups that change, come
    in another order or hold a net reset since give every net what it gets alone."""
    rng = np.random.default_rng(5)
    r0 = _r0(RADIO)
    fixed = np.array([[0.0, 0.0], [2 * r0, 0.0]])
    k, n = 4, 12
    alone = [RadioNet(RADIO, n, fixed) for _ in range(k)]
    grouped = [RadioNet(RADIO, n, fixed) for _ in range(k)]
    rngs_alone = [np.random.default_rng(s) for s in range(k)]
    rngs_grouped = [np.random.default_rng(s) for s in range(k)]
    xy = rng.uniform(0, 2 * r0, size=(k, n, 2))
    groups = [[0, 1, 2, 3], [0, 1, 2, 3], [2, 0], [0, 1, 2, 3], [1, 3], [1, 3], [3, 1], [0, 1, 2, 3]]
    for step, group in enumerate(groups):
        xy += rng.normal(0.0, 3.0, size=xy.shape)
        up = rng.random((k, n)) < 0.9
        if step == 5:  # a new episode for one net of the group
            alone[3].reset()
            grouped[3].reset()
        one = [alone[b].update(xy[b], up[b], rngs_alone[b]) for b in group]
        nets, rngs = [grouped[b] for b in group], [rngs_grouped[b] for b in group]
        batch = update_nets(nets, xy[group], up[group], rngs)
        for b, a, g in zip(group, one, batch, strict=True):
            _assert_same_links(a, g)
            assert rngs_alone[b].bit_generator.state == rngs_grouped[b].bit_generator.state


def test_nets_of_different_configurations_are_not_updated_together() -> None:
    nets = [RadioNet(RADIO, 3), RadioNet(QUIET, 3)]
    with pytest.raises(ValueError):
        update_nets(nets, np.zeros((2, 3, 2)), np.ones((2, 3), bool), [np.random.default_rng(0)] * 2)
