"""OMPL's own benchmark log for a map and a set of planner profiles.

`ompl.tools.Benchmark` runs every profile's planner `runs` times on one start/goal query of the
map and writes the standard OMPL log, which `ompl_benchmark_statistics.py bench.log -d bench.db`
turns into the SQLite database Planner Arena (plannerarena.org) and other OMPL tools read.

What carries over from a profile: the planner, its parameters and its name (the planner's name
in the log). What cannot: OMPL's benchmark stops every run on one wall-clock limit, so iteration
budgets do not apply (`time_s`, default the largest `budget.time_s` of the profiles, else 1 s);
a PRM profile runs OMPL's own PRM, which grows its roadmap per run; simplification is one switch
for all. The objective is one for the whole experiment: the profiles' common one; if they differ,
terrain_cost, unless a PRM-family planner is among them (OMPL's PRM checks for solutions on a
second thread, which cannot call the Python terrain-cost objective), then length.
"""

from __future__ import annotations

import contextlib
import io
import os
import sqlite3
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from swarm.errors import InputError
from swarm.planning.batch import process_context
from swarm.planning.costmap import CostMap
from swarm.planning.paths import (
    _ompl_quiet,
    _space_information,
    _state,
    make_objective,
    make_planner,
    ompl_seed,
    seed_ompl,
)
from swarm.planning.profiles import ROADMAP_PLANNERS, PlannerProfile


@dataclass(frozen=True)
class PlannerSummary:
    name: str
    runs: int
    solved: int
    mean_time_s: float
    mean_length_m: float | None
    mean_cost: float | None

    def as_dict(self) -> dict:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


@dataclass(frozen=True)
class BenchmarkExport:
    path: Path
    objective: str
    time_s: float
    runs: int
    start: tuple[float, float]
    goal: tuple[float, float]
    planners: tuple[PlannerSummary, ...]

    def as_dict(self) -> dict:
        return {
            "log": str(self.path),
            "objective": self.objective,
            "time_s_per_run": self.time_s,
            "runs_per_planner": self.runs,
            "start": list(self.start),
            "goal": list(self.goal),
            "planners": [p.as_dict() for p in self.planners],
        }


def choose_objective(profiles: Sequence[PlannerProfile], objective: str | None) -> str:
    """The one objective of the experiment (see the module docstring)."""
    has_prm = [p for p in profiles if p.planner in ROADMAP_PLANNERS]
    if objective is None:
        found = {p.objective for p in profiles}
        objective = found.pop() if len(found) == 1 else "terrain_cost"
        return "length" if has_prm else objective
    if objective == "terrain_cost" and has_prm:
        raise InputError(
            has_prm[0].source,
            "planner",
            has_prm[0].planner,
            "a planner that is not PRM-family for a terrain_cost benchmark (OMPL's PRM checks for "
            "solutions on a second thread, which cannot call the Python objective): use --objective length",
        )
    return objective


def default_query(cm: CostMap) -> tuple[tuple[float, float], tuple[float, float]]:
    """A long query across the largest free area: its westmost and eastmost free cells, each the
    one nearest the area's middle row."""
    counts = np.bincount(cm.component.ravel())
    counts[0] = 0
    rows, cols = np.nonzero(cm.component == int(np.argmax(counts)))
    mid = np.median(rows)
    picks = []
    for col in (cols.min(), cols.max()):
        at = rows[cols == col]
        row = at[np.argmin(np.abs(at - mid))]
        x, y = cm.center_of(row, col)
        picks.append((float(x), float(y)))
    return picks[0], picks[1]


def summarize_log(path: str | Path) -> list[PlannerSummary]:
    """Read an OMPL benchmark log the way ompl_benchmark_statistics.py does (into SQLite).

    A planner's mean length is that of the paths its runs return: simplified, when the benchmark
    simplified them, as `swarm path` returns its path."""
    from ompl import tools as ot

    with tempfile.TemporaryDirectory() as tmp:
        db = os.path.join(tmp, "bench.db")
        with contextlib.redirect_stdout(io.StringIO()):
            ot.readBenchmarkLog(db, [str(path)], False)
        con = sqlite3.connect(db)
        try:
            columns = {row[1] for row in con.execute("PRAGMA table_info(runs)")}
            cost = "AVG(best_cost)" if "best_cost" in columns else "NULL"
            # the length of the path a run returns: the simplified one when the benchmark
            # simplified (solution_length is the planner's raw path, before simplification)
            length = (
                "COALESCE(simplified_solution_length, solution_length)"
                if "simplified_solution_length" in columns
                else "solution_length"
            )
            rows = con.execute(
                "SELECT plannerConfigs.name, COUNT(*), SUM(solved), AVG(time), "
                f"AVG(CASE WHEN solved THEN {length} END), {cost} "
                "FROM runs JOIN plannerConfigs ON runs.plannerid = plannerConfigs.id "
                "GROUP BY plannerConfigs.id ORDER BY plannerConfigs.id"
            ).fetchall()
        finally:
            con.close()
    return [
        PlannerSummary(
            name=str(name),
            runs=int(n),
            solved=int(solved or 0),
            mean_time_s=float(t),
            mean_length_m=None if length is None else float(length),
            mean_cost=None if c is None else float(c),
        )
        for name, n, solved, t, length, c in rows
    ]


def export_benchmark(
    cm: CostMap,
    profiles: Sequence[PlannerProfile],
    out: str | Path,
    *,
    start: Sequence[float] | None = None,
    goal: Sequence[float] | None = None,
    runs: int = 10,
    time_s: float | None = None,
    objective: str | None = None,
    seed: int = 0,
) -> BenchmarkExport:
    """Run OMPL's Benchmark over `profiles` on one query of `cm` and write its log to `out`.

    The query defaults to `default_query(cm)`. The log is written under a temporary name and
    renamed when complete.
    """
    if not profiles:
        raise ValueError("no profiles to benchmark")
    names = [p.name for p in profiles]
    if len(set(names)) != len(names):
        dup = next(n for n in names if names.count(n) > 1)
        raise InputError(
            "command line", "--benchmark", dup, "profiles with different names (the log's planner names)"
        )
    if start is None or goal is None:
        start, goal = default_query(cm)
    cm.check_endpoints(start, goal)
    objective = choose_objective(profiles, objective)
    if time_s is None:
        given = [p.time_s for p in profiles if p.time_s is not None]
        time_s = max(given) if given else 1.0
    out = Path(out)
    tmp = out.with_name(f".{out.name}.tmp-{os.getpid()}")
    job = (
        cm,
        tuple(profiles),
        str(tmp),
        tuple(map(float, start)),
        tuple(map(float, goal)),
        objective,
        float(time_s),
        int(runs),
        int(seed),
    )
    # In a child process: OMPL's Benchmark leaves a reference cycle behind with BIT* (nanobind
    # then reports leaked instances at exit); the child ends with os._exit, so nothing reports.
    ctx = process_context()
    receive, send = ctx.Pipe(duplex=False)
    child = ctx.Process(target=_benchmark_child, args=(send, job), daemon=True)
    child.start()
    send.close()
    try:
        outcome = receive.recv()
    except EOFError:
        outcome = f"the benchmark process died (exit code {child.exitcode})"
    child.join()
    if outcome is not None:
        if tmp.exists():
            tmp.unlink()
        raise RuntimeError(f"OMPL benchmark failed: {outcome}")
    try:
        planners = summarize_log(tmp)
        os.replace(tmp, out)
    finally:
        if tmp.exists():
            tmp.unlink()
    return BenchmarkExport(
        path=out,
        objective=objective,
        time_s=float(time_s),
        runs=int(runs),
        start=(float(start[0]), float(start[1])),
        goal=(float(goal[0]), float(goal[1])),
        planners=tuple(planners),
    )


def _benchmark_child(conn, job) -> None:
    """Run OMPL's Benchmark and write its log; send None or an error message; exit hard."""
    try:
        _run_benchmark(*job)
        conn.send(None)
    except BaseException as exc:  # report anything to the parent, which raises
        conn.send(f"{type(exc).__name__}: {exc}")
    finally:
        conn.close()
        os._exit(0)


def _run_benchmark(cm, profiles, tmp, start, goal, objective, time_s, runs, seed) -> None:
    from ompl import geometric as og
    from ompl import tools as ot

    with _ompl_quiet():
        seed_ompl(ompl_seed(np.random.SeedSequence(seed)))
        si = _space_information(cm, [p.planner for p in profiles])
        space = si.getStateSpace()
        ss = og.SimpleSetup(si)
        ss.setStartAndGoalStates(_state(space, start), _state(space, goal))
        ss.setOptimizationObjective(make_objective(si, cm, objective, goal))
        bench = ot.Benchmark(ss, f"{cm.name}")
        for key, kind, value in (
            ("map", "TEXT", cm.name),
            ("cell_m", "REAL", cm.cell_m),
            ("robot_half_width_m", "REAL", cm.half_width_m),
            ("check_resolution_m", "REAL", cm.resolution_m),
            ("objective", "TEXT", objective),
            ("start_x_m", "REAL", start[0]),
            ("start_y_m", "REAL", start[1]),
            ("goal_x_m", "REAL", goal[0]),
            ("goal_y_m", "REAL", goal[1]),
            ("swarm_seed", "INTEGER", seed),
        ):
            bench.addExperimentParameter(key, kind, str(value))
        for profile in profiles:
            bench.addPlanner(make_planner(si, profile))
        request = ot.Request(time_s, 4096.0, runs, 0.05, False, False, any(p.simplify for p in profiles))
        bench.benchmark(request)
        if not bench.saveResultsToFile(tmp):
            raise OSError(f"OMPL could not write the benchmark log {tmp}")
