"""Task allocation: `assign` is optimal (brute force), `auction` is within its gap bound and re-runs
after losses."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from swarm.errors import SwarmError
from swarm.planning.allocation import assign, assignment_cost, auction, check_assignment


def brute_force(cost: np.ndarray, robots_per_task) -> tuple[int, float]:
    """(slots filled, least cost among assignments filling that many), over every robot -> task
    or idle choice that respects the task capacities and avoids infeasible pairs."""
    n, m = cost.shape
    k = np.broadcast_to(np.asarray(robots_per_task), (m,))
    best: tuple[int, float] | None = None
    for choice in itertools.product(range(-1, m), repeat=n):
        a = np.asarray(choice)
        if any((a == j).sum() > k[j] for j in range(m)):
            continue
        rows = np.flatnonzero(a >= 0)
        if not np.isfinite(cost[rows, a[rows]]).all():
            continue
        key = (-len(rows), float(cost[rows, a[rows]].sum()))
        if best is None or key < best:
            best = key
    assert best is not None
    return -best[0], best[1]


def random_case(rng: np.random.Generator, *, integer: bool = False):
    n = int(rng.integers(1, 6))
    m = int(rng.integers(1, 5))
    cost = rng.integers(0, 20, (n, m)).astype(float) if integer else rng.uniform(0.0, 10.0, (n, m))
    cost[rng.random((n, m)) < 0.3] = np.inf
    k = rng.integers(0, 3, m)
    return cost, k


# assign -----------------------------------------------------------------------------------------


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5])
def test_assign_square_matches_permutations(n: int) -> None:
    rng = np.random.default_rng(100 + n)
    for _ in range(10):
        cost = rng.uniform(0.0, 100.0, (n, n))
        best = min(sum(cost[i, p[i]] for i in range(n)) for p in itertools.permutations(range(n)))
        a = assign(cost)
        check_assignment(cost, a)
        assert sorted(a.tolist()) == list(range(n))
        assert assignment_cost(cost, a) == pytest.approx(best, abs=1e-9)


def test_assign_matches_brute_force_with_k_robots_and_infeasible_pairs() -> None:
    rng = np.random.default_rng(7)
    for _ in range(250):
        cost, k = random_case(rng)
        filled, best = brute_force(cost, k)
        a = assign(cost, k)
        check_assignment(cost, a, k)
        assert int((a >= 0).sum()) == filled
        assert assignment_cost(cost, a) == pytest.approx(best, abs=1e-9)


def test_more_robots_than_tasks_leaves_the_dearest_idle() -> None:
    cost = np.array([[5.0, 1.0], [2.0, 9.0], [1.0, 8.0], [7.0, 7.0], [3.0, 0.5]])
    a = assign(cost)
    assert a.tolist() == [-1, -1, 0, -1, 1]


def test_a_task_needing_three_robots_gets_the_three_cheapest() -> None:
    cost = np.array([[4.0], [1.0], [3.0], [2.0], [9.0]])
    a = assign(cost, [3])
    assert sorted(np.flatnonzero(a == 0).tolist()) == [1, 2, 3]
    assert a[0] == -1 and a[4] == -1


def test_filling_slots_comes_before_cost() -> None:
    # cheapest single pair is robot 0 on task 0 (1.0); filling both tasks needs robot 0 on task 1
    cost = np.array([[1.0, 1.0], [100.0, np.inf]])
    a = assign(cost)
    assert a.tolist() == [1, 0]
    r = auction(cost, eps=1e-3)
    assert r.assignment.tolist() == [1, 0]


def test_infeasible_pairs_give_minus_one() -> None:
    inf = np.inf
    assert assign(np.full((3, 2), inf)).tolist() == [-1, -1, -1]
    cost = np.array([[inf, inf], [1.0, 2.0], [3.0, inf]])
    a = assign(cost)
    assert a.tolist() == [-1, 1, 0]
    assert assign(np.zeros((0, 3))).shape == (0,)
    assert assign(np.ones((2, 2)), [0, 0]).tolist() == [-1, -1]


@pytest.mark.parametrize(
    ("cost", "k"),
    [
        (np.array([1.0, 2.0]), 1),
        (np.array([[np.nan, 1.0]]), 1),
        (np.array([[-np.inf, 1.0]]), 1),
        (np.ones((2, 2)), [-1, 1]),
        (np.ones((2, 2)), [1.5, 1]),
    ],
)
def test_bad_input_raises(cost, k) -> None:
    with pytest.raises(SwarmError):
        assign(cost, k)
    with pytest.raises(SwarmError):
        auction(cost, k)


def test_check_assignment_catches_violations() -> None:
    cost = np.array([[1.0, np.inf], [2.0, 3.0]])
    with pytest.raises(SwarmError, match="task 0 has 2 robots"):
        check_assignment(cost, np.array([0, 0]))
    with pytest.raises(SwarmError, match="infeasible"):
        check_assignment(cost, np.array([1, 0]))


# auction ----------------------------------------------------------------------------------------


def test_auction_within_n_eps_of_brute_force() -> None:
    rng = np.random.default_rng(11)
    for _ in range(250):
        cost, k = random_case(rng)
        eps = 0.05
        filled, best = brute_force(cost, k)
        r = auction(cost, k, eps=eps)
        check_assignment(cost, r.assignment, k)
        assert int((r.assignment >= 0).sum()) == filled
        assert r.gap_bound == pytest.approx(r.n_persons * eps)
        assert r.n_persons == cost.shape[0] + int(k.sum())
        assert 0.0 <= r.certified_gap <= r.gap_bound + 1e-9
        assert best - 1e-9 <= r.total_cost <= best + r.certified_gap + 1e-9


def test_auction_exact_on_integer_costs_when_eps_below_one_over_n() -> None:
    rng = np.random.default_rng(12)
    for _ in range(100):
        cost, k = random_case(rng, integer=True)
        _, best = brute_force(cost, k)
        n = cost.shape[0] + int(k.sum())
        r = auction(cost, k, eps=0.9 / n)
        assert r.total_cost == pytest.approx(best, abs=1e-9)


def test_auction_matches_assign_on_larger_problems() -> None:
    rng = np.random.default_rng(13)
    for n, m in [(30, 20), (20, 30), (40, 40)]:
        cost = rng.uniform(0.0, 500.0, (n, m))
        cost[rng.random((n, m)) < 0.25] = np.inf
        k = rng.integers(1, 3, m)
        a = assign(cost, k)
        r = auction(cost, k, eps=1e-3)
        check_assignment(cost, r.assignment, k)
        assert (r.assignment >= 0).sum() == (a >= 0).sum()
        assert assignment_cost(cost, a) - 1e-9 <= r.total_cost <= assignment_cost(cost, a) + r.certified_gap


def test_auction_rerun_after_losing_robots_and_finishing_tasks() -> None:
    rng = np.random.default_rng(21)
    n, m = 12, 6
    cost = rng.uniform(10.0, 100.0, (n, m))
    cost[rng.random((n, m)) < 0.2] = np.inf
    k = np.array([2, 1, 2, 1, 3, 1])
    first = auction(cost, k, eps=1e-3)
    check_assignment(cost, first.assignment, k)

    lost = np.flatnonzero(first.assignment >= 0)[:4]  # lose four robots that had tasks
    alive = np.ones(n, bool)
    alive[lost] = False
    tasks = np.ones(m, bool)
    tasks[1] = False  # task 1 is done
    again = auction(cost, k, eps=1e-3, active_robots=alive, active_tasks=tasks)
    check_assignment(cost, again.assignment, k)
    assert (again.assignment[lost] == -1).all()
    assert not (again.assignment == 1).any()

    # optimal over the survivors and open tasks, by the exact solver
    reduced = cost.copy()
    reduced[~alive] = np.inf
    reduced[:, ~tasks] = np.inf
    exact = assign(reduced, k)
    assert (again.assignment >= 0).sum() == (exact >= 0).sum()
    assert again.total_cost <= assignment_cost(reduced, exact) + again.certified_gap + 1e-9
    assert again.certified_gap <= again.gap_bound
    assert again.n_persons == alive.sum() + int(k[tasks].sum())


def test_auction_is_deterministic() -> None:
    rng = np.random.default_rng(5)
    cost = rng.integers(0, 5, (15, 10)).astype(float)  # many ties
    a = auction(cost, 1, eps=0.01)
    b = auction(cost.copy(), 1, eps=0.01)
    assert a.assignment.tolist() == b.assignment.tolist()
    assert a.n_bids == b.n_bids


def test_auction_identical_robots_needs_no_price_war() -> None:
    # 60 identical robots for 40 identical tasks: plain auction at eps 1e-4 would need ~1e7 bids
    r = auction(np.ones((60, 40)), 1, eps=1e-4)
    assert (r.assignment >= 0).sum() == 40
    assert r.n_bids < 100_000
    scarce = np.full((60, 40), np.inf)
    scarce[:, :3] = 5.0
    r = auction(scarce, 1, eps=1e-4)
    assert (r.assignment >= 0).sum() == 3


def test_auction_slot_prices_and_empty_problem() -> None:
    r = auction(np.array([[1.0, 2.0], [2.0, 1.0]]), [1, 2])
    assert set(r.slot_prices) == {(0, 0), (1, 0), (1, 1)}
    assert all(math.isfinite(p) for p in r.slot_prices.values())
    empty = auction(np.ones((3, 2)), 1, active_robots=[False, False, False])
    assert empty.assignment.tolist() == [-1, -1, -1] and empty.total_cost == 0.0
    with pytest.raises(SwarmError):
        auction(np.ones((2, 2)), eps=0.0)
    with pytest.raises(SwarmError):
        auction(np.ones((2, 2)), active_robots=[True])


def test_an_auction_out_of_bids_says_so() -> None:
    rng = np.random.default_rng(1)
    with pytest.raises(SwarmError, match="no assignment after 3 bids"):
        auction(rng.uniform(1.0, 9.0, (8, 8)), eps=1e-6, max_bids=3)
