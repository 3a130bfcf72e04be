"""Who does what: assigning robots to tasks, once (optimal) or again and again (auction).

Both solve the same problem. ``cost[i, j]`` is what robot ``i`` doing task ``j`` costs (time, energy,
risk: any additive unit); ``inf`` marks a pair that cannot happen. Task ``j`` takes
``robots_per_task[j]`` robots (default one each); every robot does at most one task. The answer
is one task index per robot, ``-1`` for a robot left idle. Among all assignments it:

1. fills as many task slots as the feasible pairs allow (maximum cardinality), then
2. has the least total cost among those.

With more robots than slots some robots stay idle; with more slots than robots (or infeasible
pairs) some slots stay empty. A task needing k robots is expanded into k identical columns
("slots"); a robot takes at most one slot.

- `assign` solves it exactly with scipy's ``linear_sum_assignment`` (the Jonker-Volgenant shortest
  augmenting path algorithm, Crouse, IEEE T-AES 52(4), 2016). Infeasible pairs get a cost ``M``
  larger than any difference in feasible costs, so leaving a slot empty always costs more than any
  rearrangement; pairs at ``M`` are dropped from the answer.
- `auction` is Bertsekas's forward auction (Bertsekas, "The auction algorithm: a distributed
  relaxation method for the assignment problem", Annals of OR 14, 1988; *Network Optimization:
  Continuous and Discrete Models*, 1998, ch. 7) with epsilon-scaling. Robots bid for slots with
  prices, which is what a swarm can run over its radio and what the simulator re-runs when robots
  are lost: re-run it with the survivors in ``active_robots`` (and finished tasks dropped from
  ``active_tasks``); the lost robots' tasks go back to the survivors, indices stay the same.

The auction's optimality gap. Rectangular, partly infeasible problems are made square and always
feasible (the usual reduction of asymmetric assignment, Bertsekas 1998, ch. 7): persons are the
n_r robots plus one "vacancy" per slot, objects are the n_s slots plus one "idle" object per
robot; a robot values slot s at ``-cost``, any idle object at ``-M``; a vacancy values everything
at 0. The auction ends with every person within ``eps`` of its best value at the final prices
(eps-complementary slackness), so its total is within ``n eps`` of the optimum, with
``n = n_r + n_s`` persons of the square problem (`AuctionResult.gap_bound`). The duality gap at
the final prices, `AuctionResult.certified_gap`, is a tighter a-posteriori bound (always
``<= gap_bound``): ``total_cost <= optimal cost + certified_gap``. ``M`` is chosen larger than
the spread of feasible costs plus ``gap_bound``, so the auction also fills the maximum number of
slots. With integer costs and ``eps < 1 / n`` the auction is exactly optimal.

Deterministic: the same inputs give the same answer (bids in index order, ties to the lowest
index). No randomness is drawn.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numba
import numpy as np
from scipy.optimize import linear_sum_assignment

from swarm.errors import SwarmError

#: Epsilon is divided by this factor from one scaling phase to the next (Bertsekas suggests 4-10).
EPS_SCALING_FACTOR = 5.0


def _check_cost(cost: np.ndarray | list) -> np.ndarray:
    c = np.array(cost, dtype=np.float64)
    if c.ndim != 2:
        raise SwarmError(f"allocation: cost must be a 2-D (robots, tasks) array, found shape {c.shape}")
    if np.isnan(c).any() or np.isneginf(c).any():
        raise SwarmError("allocation: cost holds NaN or -inf; use +inf to mark an infeasible pair")
    return c


def _slot_tasks(robots_per_task: int | np.ndarray | list, n_tasks: int) -> np.ndarray:
    """The task of each slot: task j repeated robots_per_task[j] times."""
    k = np.broadcast_to(np.asarray(robots_per_task), (n_tasks,))
    if not np.issubdtype(k.dtype, np.integer) and not np.all(np.equal(np.mod(k, 1), 0)):
        raise SwarmError(f"allocation: robots_per_task must be whole numbers, found {k.tolist()}")
    k = k.astype(np.intp)
    if (k < 0).any():
        raise SwarmError(f"allocation: robots_per_task must be >= 0, found {k.tolist()}")
    return np.repeat(np.arange(n_tasks, dtype=np.intp), k)


def _big_m(finite: np.ndarray, n_pairs: int, gap: float = 0.0) -> float:
    """A cost for "no feasible pair" exceeding any gain from rearranging `n_pairs` feasible pairs.

    An assignment with one slot fewer filled costs at least M - (max + (n_pairs - 1) * spread)
    more, so M = max + n_pairs * spread + gap + 1 makes filling a slot always worth it, even
    through an approximation `gap`.
    """
    hi, lo = float(finite.max()), float(finite.min())
    return hi + n_pairs * (hi - lo) + gap + 1.0


def assignment_cost(cost: np.ndarray, assignment: np.ndarray) -> float:
    """Total cost of a per-robot assignment (-1 entries cost nothing)."""
    c = np.asarray(cost, dtype=np.float64)
    a = np.asarray(assignment)
    rows = np.flatnonzero(a >= 0)
    return float(c[rows, a[rows]].sum())


def check_assignment(
    cost: np.ndarray, assignment: np.ndarray, robots_per_task: int | np.ndarray | list = 1
) -> None:
    """Raise `SwarmError` unless every robot has one task or -1, no task has more robots than it
    takes, and no robot sits on an infeasible (inf) pair."""
    c = _check_cost(cost)
    a = np.asarray(assignment)
    n_robots, n_tasks = c.shape
    if a.shape != (n_robots,) or ((a < -1) | (a >= n_tasks)).any():
        raise SwarmError(f"allocation: assignment must be {n_robots} task indices or -1, found {a.tolist()}")
    k = np.broadcast_to(np.asarray(robots_per_task), (n_tasks,))
    counts = np.bincount(a[a >= 0], minlength=n_tasks)
    over = np.flatnonzero(counts > k)
    if over.size:
        j = int(over[0])
        raise SwarmError(f"allocation: task {j} has {int(counts[j])} robots but takes {int(k[j])}")
    rows = np.flatnonzero(a >= 0)
    bad = rows[~np.isfinite(c[rows, a[rows]])]
    if bad.size:
        i = int(bad[0])
        raise SwarmError(f"allocation: robot {i} is on task {int(a[i])}, an infeasible (inf) pair")


def assign(cost: np.ndarray | list, robots_per_task: int | np.ndarray | list = 1) -> np.ndarray:
    """Optimal one-shot assignment: per robot, its task index or -1.

    `cost` is (n_robots, n_tasks), inf where a robot cannot do a task; task j takes
    `robots_per_task[j]` robots (an int applies to all). Fills the most slots, then minimizes the
    total cost (module docstring).
    """
    c = _check_cost(cost)
    n_robots, n_tasks = c.shape
    out = np.full(n_robots, -1, dtype=np.intp)
    slot_task = _slot_tasks(robots_per_task, n_tasks)
    if n_robots == 0 or slot_task.size == 0:
        return out
    expanded = c[:, slot_task]
    feasible = np.isfinite(expanded)
    if not feasible.any():
        return out
    big = _big_m(expanded[feasible], min(n_robots, slot_task.size))
    rows, cols = linear_sum_assignment(np.where(feasible, expanded, big))
    keep = feasible[rows, cols]
    out[rows[keep]] = slot_task[cols[keep]]
    return out


@dataclass(frozen=True)
class AuctionResult:
    """What `auction` found, and the state a re-run starts from."""

    assignment: np.ndarray  # (n_robots,) task index or -1 (inactive robots: -1)
    total_cost: float
    eps: float
    gap_bound: float  # n * eps, n = active robots + slots: total_cost <= optimum + gap_bound
    certified_gap: float  # duality gap at the final prices, <= gap_bound
    n_bids: int
    n_persons: int  # active robots + slots of active tasks: the n of the gap bound
    slot_keys: np.ndarray = field(repr=False)  # (n_slots, 2): task, copy
    prices: np.ndarray = field(repr=False)  # (n_slots + n_active,): slots, then idle objects

    @property
    def slot_prices(self) -> dict[tuple[int, int], float]:
        """Price of each (task, copy) slot at the end of the auction."""
        return {
            (int(t), int(c)): float(p)
            for (t, c), p in zip(self.slot_keys, self.prices[: len(self.slot_keys)], strict=True)
        }


def _bid_phase(
    benefit: np.ndarray,
    prices: np.ndarray,
    person_object: np.ndarray,
    object_person: np.ndarray,
    eps: float,
    cap: float,
    max_bids: int,
) -> int:
    """Gauss-Seidel forward auction until every person holds an object (arrays updated in place)."""
    bids = _bids(benefit, prices, person_object, object_person, eps, cap, max_bids)
    if bids < 0:
        raise SwarmError(f"auction: no assignment after {max_bids} bids (eps {eps:g} too small?)")
    return bids


@numba.njit(cache=True, error_model="numpy")
def _bids(benefit, prices, person_object, object_person, eps, cap, max_bids):
    """`_bid_phase`'s bids, one at a time in first-in first-out order of the unassigned persons
    (each bid a handful of scalar operations: compiled, as numpy's per-call overhead would
    dominate). Returns the bids made, or -1 once more than `max_bids`."""
    n = prices.shape[0]
    queue = np.empty(n + 1, np.intp)  # the unassigned persons, each at most once
    head, tail = 0, 0
    for i in range(n):
        if person_object[i] < 0:
            queue[tail] = i
            tail += 1
    values = np.empty(n)
    bids = 0
    while head != tail:
        i = queue[head]
        head = (head + 1) % (n + 1)
        j = 0
        for k in range(n):
            values[k] = benefit[i, k] - prices[k]
            if values[k] > values[j]:  # the first of equals, as argmax
                j = k
        best = values[j]
        second = -np.inf
        for k in range(n):
            if k != j and values[k] > second:
                second = values[k]
        if not np.isfinite(second):  # one feasible object: any finite raise keeps eps-CS
            second = best - cap
        prices[j] += best - second + eps
        previous = object_person[j]
        object_person[j] = i
        person_object[i] = j
        if previous >= 0:
            person_object[previous] = -1
            queue[tail] = previous
            tail = (tail + 1) % (n + 1)
        bids += 1
        if bids > max_bids:
            return -1
    return bids


def auction(
    cost: np.ndarray | list,
    robots_per_task: int | np.ndarray | list = 1,
    eps: float = 1e-3,
    *,
    active_robots: np.ndarray | list | None = None,
    active_tasks: np.ndarray | list | None = None,
    max_bids: int = 10_000_000,
) -> AuctionResult:
    """Bertsekas forward auction with eps-scaling; within `gap_bound` = n eps of the optimum.

    `cost` (n_robots, n_tasks) and `robots_per_task` as for `assign`. `active_robots` and
    `active_tasks` are boolean masks (default all): lost robots and finished tasks take no part
    and inactive robots get -1, so a re-run after losses keeps robot and task indices and hands
    the lost robots' tasks to the survivors. Epsilon runs from a fifth of the benefit spread down
    to `eps`, divided by `EPS_SCALING_FACTOR` each phase; each phase starts from the previous
    phase's prices with no assignment. This epsilon-scaling keeps the work polynomial in
    log(n spread / eps) (Bertsekas and Eckstein, Math. Programming 42, 1988) where a single phase
    at a small eps can run "price wars" of O(spread / eps) bids.

    To keep robots on their current tasks when it costs little, subtract a switching bonus from
    ``cost[i, current_task[i]]`` before re-running.
    """
    c = _check_cost(cost)
    if not (np.isfinite(eps) and eps > 0):
        raise SwarmError(f"auction: eps must be a positive number, found {eps!r}")
    n_robots, n_tasks = c.shape
    robots_on = np.ones(n_robots, bool) if active_robots is None else np.asarray(active_robots, bool)
    tasks_on = np.ones(n_tasks, bool) if active_tasks is None else np.asarray(active_tasks, bool)
    if robots_on.shape != (n_robots,) or tasks_on.shape != (n_tasks,):
        raise SwarmError(
            f"auction: active_robots {robots_on.shape} / active_tasks {tasks_on.shape} "
            f"must match cost {c.shape}"
        )
    slot_task = _slot_tasks(robots_per_task, n_tasks)
    copy = np.arange(slot_task.size) - np.searchsorted(slot_task, slot_task)
    on = tasks_on[slot_task]
    slot_keys = np.column_stack([slot_task[on], copy[on]]).astype(np.intp).reshape(-1, 2)
    robot_ids = np.flatnonzero(robots_on)
    n_r, n_s = robot_ids.size, slot_keys.shape[0]
    n = n_r + n_s
    assignment = np.full(n_robots, -1, dtype=np.intp)

    # the square problem: persons = robots, vacancies; objects = slots, idle objects
    robot_slot = c[np.ix_(robot_ids, slot_keys[:, 0])]  # (n_r, n_s)
    feasible = np.isfinite(robot_slot)
    gap_bound = n * eps
    big = _big_m(robot_slot[feasible], min(n_r, n_s), gap_bound) if feasible.any() else 1.0
    benefit = np.zeros((n, n))
    benefit[:n_r, :n_s] = np.where(feasible, -robot_slot, -np.inf)
    benefit[:n_r, n_s:] = -big
    finite = benefit[np.isfinite(benefit)]
    spread = float(finite.max() - finite.min()) if finite.size else 0.0
    cap = spread + eps

    prices = np.zeros(n)
    person_object = np.full(n, -1, dtype=np.intp)
    object_person = np.full(n, -1, dtype=np.intp)
    bids = 0
    if n == 0:
        return AuctionResult(assignment, 0.0, float(eps), 0.0, 0.0, 0, 0, slot_keys, prices)

    phase_eps = max(eps, spread / EPS_SCALING_FACTOR)
    while True:
        person_object[:] = -1
        object_person[:] = -1
        bids += _bid_phase(benefit, prices, person_object, object_person, phase_eps, cap, max_bids)
        if phase_eps <= eps:
            break
        phase_eps = max(eps, phase_eps / EPS_SCALING_FACTOR)

    held = person_object[:n_r]
    on_slot = held < n_s
    assignment[robot_ids[on_slot]] = slot_keys[held[on_slot], 0]
    values = benefit - prices
    total_benefit = float(benefit[np.arange(n), person_object].sum())
    dual = float(values.max(axis=1).sum() + prices.sum())
    return AuctionResult(
        assignment=assignment,
        total_cost=assignment_cost(c, assignment),
        eps=float(eps),
        gap_bound=float(gap_bound),
        certified_gap=max(0.0, dual - total_benefit),
        n_bids=bids,
        n_persons=n,
        slot_keys=slot_keys,
        prices=prices,
    )
