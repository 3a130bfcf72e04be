"""Paths for many robots at once, across worker processes.

OMPL holds the GIL while it plans and its objects do not pickle, so the work goes to processes
(`concurrent.futures.ProcessPoolExecutor` with the 'forkserver' start method where the platform
has it, else 'spawn'): each worker receives the cost map, the profile and (for PRM profiles) the
roadmap arrays once, then plans its share of the pairs.

Seeds: pair i is planned with OMPL seeded from `numpy.random.SeedSequence(seed).spawn(n)[i]`,
set just before its planner is made, so a pair's path depends on the seed and the pair, not on
which worker plans it or how many workers there are (with an iteration budget). Results come
back in input order.
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from swarm.planning.costmap import CostMap, NoPathError, PlanningError
from swarm.planning.paths import PathResult, Roadmap, build_roadmap, ompl_seed, plan_with_seed
from swarm.planning.profiles import PlannerProfile

_WORKER: dict[str, object] = {}


def _init_worker(cm: CostMap, profile: PlannerProfile, roadmap: Roadmap | None) -> None:
    _WORKER.update(cm=cm, profile=profile, roadmap=roadmap)


def _plan_one(task: tuple[int, np.ndarray, np.ndarray, int]) -> tuple[int, PathResult | str]:
    index, start, goal, seed = task
    try:
        result = plan_with_seed(
            _WORKER["cm"],  # type: ignore[arg-type]
            start,
            goal,
            _WORKER["profile"],  # type: ignore[arg-type]
            seed,
            _WORKER["roadmap"],  # type: ignore[arg-type]
        )
    except PlanningError as exc:
        return index, str(exc)
    return index, result


def pair_seeds(seed: int, n: int) -> list[int]:
    """The OMPL seed of each of n pairs: one child of SeedSequence(seed) per pair."""
    return [ompl_seed(child) for child in np.random.SeedSequence(seed).spawn(n)]


def process_context() -> multiprocessing.context.BaseContext:
    """forkserver (with the planner preloaded) where the platform has it, else spawn."""
    if "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        # the server imports the planner once; every worker forks from it with it loaded
        ctx.set_forkserver_preload(["swarm.planning.batch", "swarm.planning.benchmark", "ompl.geometric"])
        return ctx
    return multiprocessing.get_context("spawn")


def plan_many(
    cm: CostMap,
    pairs: Sequence[tuple[Sequence[float], Sequence[float]]] | np.ndarray,
    profile: PlannerProfile,
    *,
    seed: int = 0,
    workers: int | None = None,
    roadmap: Roadmap | None = None,
    strict: bool = True,
    progress: Callable[[int, int], None] | None = None,
    label: str = "pair",
) -> list[PathResult | None]:
    """Plan a path for each (start, goal) pair, in input order, on `workers` processes.

    `progress(done, total)` is called as paths finish (in input order); `label` names a pair in
    error messages ("pair 3", "robot route 3").

    Every endpoint is checked first: a bad one raises `EndpointError` / `NoPathError` naming the
    pair before any planning. `workers` defaults to the CPU count (at most one per pair);
    `workers=1` plans in this process. A PRM profile builds one roadmap (from `seed`, unless
    given) and every pair queries it. With `strict`, a pair the planner cannot solve within its
    budget raises `NoPathError` naming the pair; otherwise its result is None.
    """
    pts = np.asarray(pairs, dtype=np.float64)
    if pts.size == 0:
        return []
    if pts.ndim != 3 or pts.shape[1:] != (2, 2):
        raise ValueError(f"pairs must be (n, 2, 2): n pairs of (start xy, goal xy), not {pts.shape}")
    n = len(pts)
    for i, (start, goal) in enumerate(pts):
        cm.check_endpoints(start, goal, who=f"{label} {i}")
    if profile.roadmap is not None and roadmap is None:
        roadmap = build_roadmap(cm, profile, seed)
    seeds = pair_seeds(seed, n)
    tasks = [(i, pts[i, 0], pts[i, 1], seeds[i]) for i in range(n)]
    workers = min(os.cpu_count() or 1, n) if workers is None else max(1, min(int(workers), n))
    outcomes: list[tuple[int, PathResult | str]] = []

    def collect(iterable: Iterable[tuple[int, PathResult | str]]) -> None:
        for outcome in iterable:
            outcomes.append(outcome)
            if progress is not None:
                progress(len(outcomes), n)

    if workers == 1:
        _init_worker(cm, profile, roadmap)
        try:
            collect(_plan_one(t) for t in tasks)
        finally:
            _WORKER.clear()
    else:
        chunk = max(1, n // (4 * workers))
        with ProcessPoolExecutor(
            max_workers=workers,
            mp_context=process_context(),
            initializer=_init_worker,
            initargs=(cm, profile, roadmap),
        ) as pool:
            collect(pool.map(_plan_one, tasks, chunksize=chunk))
    results: list[PathResult | None] = []
    for index, outcome in outcomes:
        if isinstance(outcome, str):
            if strict:
                raise NoPathError(f"{label} {index}: {outcome}")
            results.append(None)
        else:
            results.append(outcome)
    return results
