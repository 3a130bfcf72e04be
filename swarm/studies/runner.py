"""One run of a study: a mission at one parameter point with one seed, simulated with the built-in
policy, turned into one row of the results table (`swarm.studies.table`).

A run's seed is ``SeedSequence(study seed, spawn_key=(point, run))``: it depends only on where the
run sits in the study, never on which worker ran it or when, so a study gives the same table on
one process, on many, or on a Ray cluster, and resuming reruns exactly the missing runs.

Workers keep the mission and its plan of each point they have seen (`_prepared`, keyed by the
point's overrides as JSON, since a value may be a list or a mapping): planning a point's routes
(seconds for a large swarm) happens once per worker, not once per run.

`run_batch` runs several runs of one point together on the batched world core
(`swarm.sim.world`, `simulate_batch`): the same rows as `run_task` one by one (a run's result does
not depend on the batch it is in), each with its share of the batch's wall time as `runtime_s`.
"""

from __future__ import annotations

import json
import math
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from swarm.sim.hazards import CAUSES
from swarm.studies.table import CRITERIA, END_COUNTS, MINE_COUNTS, loss_row

#: Points whose mission and plan a worker keeps.
PREPARED_CACHE = 16


@dataclass(frozen=True)
class RunTask:
    """What a worker needs for one run: picklable, small."""

    mission_path: str
    point: int
    run: int
    overrides: tuple[tuple[str, object], ...]
    seed: int
    #: The point's columns of the table (`swarm.studies.table.param_cell`); none outside a study.
    cells: tuple[tuple[str, object], ...] = ()


def run_seed(study_seed: int, point: int, run: int) -> int:
    """The simulator seed of run `run` at point `point` (module docstring)."""
    ss = np.random.SeedSequence(study_seed, spawn_key=(point, run))
    return int(ss.generate_state(1, dtype=np.uint64)[0])


class _Point:
    """A point's overrides as the caches' key: hashed and compared by their JSON, since a value
    may be a list or a mapping (`--set launch.points=[launch_1]`), which has no hash."""

    def __init__(self, overrides: tuple[tuple[str, object], ...]) -> None:
        self.overrides = overrides
        self.key = json.dumps(overrides, default=str)

    def __hash__(self) -> int:
        return hash(self.key)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, _Point) and self.key == other.key


def _prepared(mission_path: str, overrides: tuple[tuple[str, object], ...]):
    """The point's mission and plan, made once per worker."""
    return _prepared_at(mission_path, _Point(overrides))


def _setup(mission_path: str, overrides: tuple[tuple[str, object], ...]):
    """The point's `MissionSetup` (what every batch of its runs shares), kept like its plan."""
    return _setup_at(mission_path, _Point(overrides))


@lru_cache(maxsize=PREPARED_CACHE)
def _prepared_at(mission_path: str, point: _Point):
    from swarm.mission.load import load_mission
    from swarm.mission.plan import plan_mission

    mission = load_mission(mission_path, dict(point.overrides), overrides_source="--sweep")
    return mission, plan_mission(mission, seed=mission.seed, workers=1)


@lru_cache(maxsize=PREPARED_CACHE)
def _setup_at(mission_path: str, point: _Point):
    from swarm.sim.env import SimConfig
    from swarm.sim.setup import MissionSetup

    mission, plan = _prepared_at(mission_path, point)
    config = SimConfig()
    return MissionSetup(mission, plan, dt_s=config.dt_s, substep_s=config.substep_s)


def run_task(task: RunTask, working: Callable[[float], None] | None = None) -> dict:
    """Simulate one run and return its row (column name -> value). `working(share)`: as in
    `run_batch`, the share of the run's time limit simulated so far."""
    from swarm.sim.run import WORKING_EVERY_S, simulate

    started = time.perf_counter()
    mission, plan = _prepared(task.mission_path, task.overrides)
    progress = None
    if working is not None:
        said_at = [time.monotonic()]

        def progress(t_s: float, limit_s: float) -> None:
            if time.monotonic() >= said_at[0] + WORKING_EVERY_S:
                said_at[0] = time.monotonic()
                working(min(t_s / limit_s, 1.0))

    log = simulate(mission, seed=task.seed, plan=plan, record_every_s=math.inf, progress=progress)
    return _row(task, mission, plan, log, time.perf_counter() - started)


def run_batch(tasks: list[RunTask], working: Callable[[float], None] | None = None) -> list[dict]:
    """Simulate runs of one point together on the batched core and return their rows, in order
    (one task: `run_task`, the one-run path). `working(runs_worth)` is told now and then how much
    of the batch is done, in runs (`swarm.sim.run.simulate_batch`), for a progress bar."""
    from swarm.sim.run import simulate_batch

    if len(tasks) == 1:
        return [run_task(tasks[0], working)]
    first = tasks[0]
    if any(
        (t.mission_path, t.point, t.overrides) != (first.mission_path, first.point, first.overrides)
        for t in tasks
    ):
        raise ValueError("study: a batch holds runs of one point")
    started = time.perf_counter()
    mission, plan = _prepared(first.mission_path, first.overrides)
    setup = _setup(first.mission_path, first.overrides)
    logs = simulate_batch(
        mission, [t.seed for t in tasks], plan=plan, setup=setup, record_every_s=math.inf, working=working
    )
    share = (time.perf_counter() - started) / len(tasks)
    return [_row(t, mission, plan, log, share) for t, log in zip(tasks, logs, strict=True)]


def _row(task: RunTask, mission, plan, log, runtime_s: float) -> dict:
    """One run's row of the results table."""
    from swarm.mission.exposure import STATION_ROLES
    from swarm.mission.plan import success_chance

    row: dict = {"point": task.point, "run": task.run, "seed": task.seed}
    row.update(task.cells)
    row["robots"] = mission.swarm.count
    row["success"] = bool(log.outcome["success"])
    criteria = log.outcome["criteria"]
    for c in CRITERIA:
        got = criteria.get(c)
        row[f"value_{c}"] = float(got["value"]) if got is not None else None
        row[f"met_{c}"] = bool(got["met"]) if got is not None else False
    causes = Counter(x["cause"] for x in log.losses)
    row["lost"] = len(log.losses)
    for c in CAUSES:
        row[f"lost_{c}"] = causes.get(c, 0)
    row["planned_lost"] = plan.expected_lost
    by_cause = plan.expected_lost_by_cause
    for c in CAUSES:
        row[f"planned_lost_{c}"] = None if by_cause is None else by_cause.get(c, 0.0)
    row["planned_detection"] = plan.expected_detection
    row["planned_success"] = success_chance(mission, plan)
    row["takeovers"] = sum(
        e["kind"] == "takeover" and e["item"] == "route" and e["role"] in STATION_ROLES for e in log.events
    )
    row["planned_takeovers"] = plan.expected_takeovers
    summary = log.summary()
    row.update({c: int(summary[c]) for c in MINE_COUNTS})
    row.update({c: int(summary["end_states"].get(c, 0)) for c in END_COUNTS})
    row["losses"] = [loss_row(x) for x in log.losses]
    row["completed_s"] = None if log.completed_s is None else float(log.completed_s)
    row["duration_s"] = float(log.times_s[-1]) if len(log.times_s) else 0.0
    row["runtime_s"] = runtime_s
    return row
