"""A Monte Carlo study: a mission run N times at every point of a parameter grid, results stored
as they come (resumable), then summarized with confidence intervals.

```python
spec = StudySpec("missions/mine_clear.yaml", runs=40, sweeps=parse_sweeps(["swarm.count=10:60:10"]))
table, summary = run_study(spec, "reports/mine_clear-study", workers=2)
summary["required"]     # the smallest swept swarm size that succeeds with P >= 0.95, at 95% confidence
```
"""

from __future__ import annotations

import datetime
import json
import math
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pyarrow as pa

import swarm
from swarm.errors import SwarmError
from swarm.files import folder_lock, write_text_atomic
from swarm.sim.hazards import CAUSES
from swarm.studies import backends, stats
from swarm.studies.runner import RunTask, run_seed
from swarm.studies.store import ResultStore
from swarm.studies.sweep import Sweep, feasibility, points
from swarm.studies.table import param_cell, param_column, param_type, schema

#: Interval half-widths (±) the summary says how many runs would reach.
HALF_WIDTHS = (0.1, 0.05)
#: Runs per stored chunk, at most (a kill loses at most the runs in flight and one chunk's worth).
CHUNK_RUNS = 20

Progress = Callable[[float, int], None]


@dataclass(frozen=True)
class StudySpec:
    """What a study is: the mission, the grid, runs per point and the seed its run seeds come from."""

    mission_path: str
    runs: int
    sweeps: list[Sweep] = field(default_factory=list)
    seed: int = 0
    target: float = 0.95
    confidence: float = 0.95
    #: points that cannot run, by index: the loader's line on why (`sweep.feasibility`); no runs
    infeasible: dict[int, str] = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        if self.runs < 1:
            raise SwarmError(f"study: runs must be >= 1, found {self.runs}")
        if not 0.0 < self.target < 1.0 or not 0.0 < self.confidence < 1.0:
            raise SwarmError("study: target and confidence must lie strictly between 0 and 1")

    def points(self) -> list[dict[str, object]]:
        return points(self.sweeps)

    def tasks(self) -> list[RunTask]:
        """Every run of the study, point by point."""
        kinds = {s.key: param_type(s.values) for s in self.sweeps}
        out = []
        for p, overrides in enumerate(self.points()):
            if p in self.infeasible:
                continue
            items = tuple(overrides.items())
            cells = tuple((param_column(k), param_cell(v, kinds[k])) for k, v in items)
            for r in range(self.runs):
                out.append(RunTask(self.mission_path, p, r, items, run_seed(self.seed, p, r), cells))
        return out

    def as_dict(self) -> dict:
        """What identifies the study (a resume must match it)."""
        return {
            "mission": str(Path(self.mission_path).resolve()),
            "runs": self.runs,
            "sweeps": {s.key: list(s.values) for s in self.sweeps},
            "seed": self.seed,
        }

    def table_schema(self) -> pa.Schema:
        return schema([(s.key, param_type(s.values)) for s in self.sweeps])


def run_study(
    spec: StudySpec,
    out: str | Path,
    *,
    backend: str = "local",
    workers: int | None = None,
    address: str | None = None,
    progress: Progress | None = None,
    batch: int | None = None,
) -> tuple[pa.Table, dict]:
    """Run what is missing of the study in `out`, then write results.parquet and summary.json.

    Each worker runs its runs of a point in batches of `batch` runs on the batched world core
    (`swarm.sim.world`; 1: one at a time; None: `backends.auto_batch`): the same table either way
    (apart from `runtime_s`). `progress(done, total)` is called as runs finish (`done` counts runs
    found from before) and, on the local backend, now and then in between, with the share of the
    batches still running that is done added to `done` (a float then). The folder is locked while
    the study writes it: a second study into it raises `FolderBusy`."""
    if backend not in backends.BACKENDS:
        raise SwarmError(f"study: backend {backend!r}, expected one of {list(backends.BACKENDS)}")
    if batch is not None and batch < 1:
        raise SwarmError(f"study: batch must be >= 1, found {batch}")
    at_once = (workers or backends.default_workers()) if backend == "local" else 1
    # the swept values as the schema reads them: an integer key's 10.0 is 10 in every output
    sweeps, infeasible = feasibility(spec.mission_path, spec.sweeps, at_once=at_once)
    spec = replace(spec, sweeps=sweeps, infeasible=infeasible)
    with folder_lock(out):
        return _run_locked(spec, Path(out), backend, workers, address, progress, batch)


def _run_locked(
    spec: StudySpec,
    out: Path,
    backend: str,
    workers: int | None,
    address: str | None,
    progress: Progress | None,
    batch: int | None = None,
) -> tuple[pa.Table, dict]:
    # Ray first: an address with no cluster behind it is refused before anything is written
    started = backends.start_ray(workers, address) if backend == "ray" else False
    store = ResultStore(out, spec.table_schema())
    try:
        store.open(spec.as_dict())
    except BaseException:
        if started:
            backends.stop_ray()
        raise
    done = store.done()
    tasks = [t for t in spec.tasks() if (t.point, t.run) not in done]
    total = (len(spec.points()) - len(spec.infeasible)) * spec.runs
    if progress is not None:
        progress(total - len(tasks), total)
    n_workers = workers or backends.default_workers()
    sizes = _batch_sizes(spec, tasks, batch, n_workers)
    finished = total - len(tasks)
    if backend == "local":

        def working(runs_worth: float) -> None:  # the batches still running, between their rows
            if progress is not None:
                progress(finished + runs_worth, total)

        rows = backends.run_local(tasks, n_workers, sizes, working)
    else:
        rows = backends.run_ray(tasks, workers, address, sizes, started=started)
    buffer: list[dict] = []
    chunk = max(1, min(CHUNK_RUNS, len(tasks) // (4 * n_workers) or 1))
    try:
        for row in rows:
            buffer.append(row)
            finished += 1
            if len(buffer) >= chunk:
                store.append(buffer)
                buffer = []
            if progress is not None:
                progress(finished, total)
    finally:
        store.append(buffer)  # keep what finished, also on Ctrl-C
    table = store.finish()
    summary = summarize(spec, table)
    from swarm.mission.load import load_mission

    summary.update(
        {
            "backend": backend,
            "workers": n_workers,
            "map": load_mission(spec.mission_path).beach_map.name,
            "date": datetime.date.today().isoformat(),
        }
    )
    # in the order written, not sorted: the sweeps' order is the table's and the report's
    write_text_atomic(out / "summary.json", json.dumps(summary, indent=1) + "\n")
    return table, summary


def _batch_sizes(spec: StudySpec, tasks: list[RunTask], batch: int | None, workers: int) -> dict[int, int]:
    """Runs per batch at each point: `batch`, or automatic from the runs left at the point, the
    workers and the point's swarm size (`backends.auto_batch`)."""
    from swarm.mission.load import load_mission

    left = Counter(t.point for t in tasks)
    if batch is not None:
        return {p: batch for p in left}
    pts = spec.points()
    out = {}
    for p, runs in left.items():
        robots = load_mission(spec.mission_path, pts[p], overrides_source="--sweep").swarm.count
        out[p] = backends.auto_batch(runs, workers, robots)
    return out


def summarize(spec: StudySpec, table: pa.Table) -> dict:
    """Per point: success rate with its Wilson interval, completion times, losses by cause and
    phase beside the plan's, the mines found beside the plan's (each mean with its t interval),
    mean mines cleared and robots back at sea, runs for narrower intervals; the required value of
    the first swept key; totals."""
    cols = table.to_pydict()
    point_of = np.asarray(cols["point"], dtype=np.int64)
    success = np.asarray(cols["success"], dtype=bool)
    completed = np.array([np.nan if v is None else v for v in cols["completed_s"]], dtype=np.float64)
    losses = cols["losses"]
    robots = cols.get("robots") or [0] * len(point_of)
    planned = cols.get("planned_lost") or [None] * len(point_of)  # absent from older tables
    found = cols.get("value_detection") or [None] * len(point_of)
    planned_found = cols.get("planned_detection") or [None] * len(point_of)
    planned_success = cols.get("planned_success") or [None] * len(point_of)
    takeovers = cols.get("takeovers") or [None] * len(point_of)
    planned_takeovers = cols.get("planned_takeovers") or [None] * len(point_of)
    lost_to = {c: cols.get(f"lost_{c}") or [0] * len(point_of) for c in CAUSES}
    planned_to = {c: cols.get(f"planned_lost_{c}") or [None] * len(point_of) for c in CAUSES}
    ends = {c: cols.get(c) or [None] * len(point_of) for c in ("mines_cleared", "recovered")}
    out_points = []
    for p, params in enumerate(spec.points()):
        mine = np.flatnonzero(point_of == p)
        k, n = int(success[mine].sum()), len(mine)
        low, high = stats.wilson_interval(k, n, spec.confidence) if n else (0.0, 1.0)
        rate = k / n if n else float("nan")
        by_cause, by_phase = _loss_counts(losses[i] for i in mine)
        why = spec.infeasible.get(p)
        out_points.append(
            {
                "index": p,
                "params": params,
                # why the point cannot run (None: it ran): no runs, no rate (null in summary.json)
                "infeasible": why,
                "runs": n,
                "successes": k,
                "success_rate": None if why else rate,
                "wilson_low": None if why else low,
                "wilson_high": None if why else high,
                # the plan's chance of success (`success_chance`), to hold against the interval
                "planned_success": _first_of(planned_success, mine),
                "completed_s": stats.distribution(completed[mine]),
                "losses_by_cause": by_cause,
                "losses_by_phase": by_phase,
                "lost_mean": float(np.mean([len(losses[i]) for i in mine])) if n else None if why else 0.0,
                "lost_interval": _count_interval(
                    [len(losses[i]) for i in mine], spec.confidence, max((robots[i] for i in mine), default=0)
                ),
                "planned_lost": _first_of(planned, mine),
                # each cause's robots lost a run against the plan's, where the plan has them
                "lost_by_cause": _by_cause(lost_to, planned_to, mine, spec.confidence, robots),
                # the mines found a run against the plan's expectation after its losses
                "detection_mean": _mean_of([found[i] for i in mine]),
                "detection_interval": _interval_of([found[i] for i in mine], spec.confidence, (0.0, 1.0)),
                "planned_detection": _first_of(planned_found, mine),
                # lost robots' stations the spares took over a run, against the plan's
                "takeovers_mean": _mean_of([takeovers[i] for i in mine]),
                "takeovers_interval": _count_interval(
                    [takeovers[i] for i in mine if takeovers[i] is not None], spec.confidence, 0
                ),
                "planned_takeovers": _first_of(planned_takeovers, mine),
                # how the mission ended besides its losses: mines the clearance set off, robots
                # picked up at sea (None from tables written before they were counted)
                **{f"{c}_mean": _mean_of([v[i] for i in mine]) for c, v in ends.items()},
                # total runs for a Wilson interval of ± h at the observed rate, and how many more
                "runs_for_width": {f"{h:g}": _runs_for(rate, h, spec.confidence, n) for h in HALF_WIDTHS},
                "more_runs_for_width": {
                    f"{h:g}": max(0, _runs_for(rate, h, spec.confidence, n) - n) if n else None
                    for h in HALF_WIDTHS
                },
            }
        )
    by_cause, by_phase = _loss_counts(losses)
    return {
        "mission": Path(spec.mission_path).stem,
        "mission_path": str(spec.mission_path),
        "seed": spec.seed,
        "runs_per_point": spec.runs,
        "runs": len(point_of),
        "target": spec.target,
        "confidence": spec.confidence,
        "sweeps": {s.key: list(s.values) for s in spec.sweeps},
        "points": out_points,
        "required": _required(spec, out_points),
        "losses_by_cause": by_cause,
        "losses_by_phase": by_phase,
        "version": getattr(swarm, "__version__", "unknown"),
    }


def _by_cause(
    lost_to: dict[str, list], planned_to: dict[str, list], rows: np.ndarray, confidence: float, robots: list
) -> list[dict]:
    """Of a point's runs `rows`, each cause's robots lost a run (mean and `_count_interval`) and
    the plan's expectation, for the causes the runs lost robots to or the plan expects any from;
    empty where the table has no plan's expectation by cause (no hazards, or an older table)."""
    planned = {c: _first_of(planned_to[c], rows) for c in CAUSES}
    if not len(rows) or all(v is None for v in planned.values()):
        return []
    most = max((robots[i] for i in rows), default=0)
    out = []
    for c in CAUSES:
        counts = [lost_to[c][i] or 0 for i in rows]
        if any(counts) or (planned[c] or 0.0) > 0.0:
            out.append(
                {
                    "cause": c,
                    "mean": float(np.mean(counts)),
                    "interval": _count_interval(counts, confidence, most),
                    "planned": planned[c],
                }
            )
    return out


def _first_of(values: list, rows: np.ndarray) -> float | None:
    """The first of `values` at `rows` that is there: a point's plan's number, the same in each of
    its rows (None in rows of tables written before the column existed)."""
    return next((values[i] for i in rows if values[i] is not None), None)


def _mean_of(values: list) -> float | None:
    """The mean of the values that are there; None when none is."""
    there = [v for v in values if v is not None]
    return float(np.mean(there)) if there else None


def _interval_of(values: list, confidence: float, within: tuple[float, float]) -> list[float] | None:
    """The t interval of the mean of the values that are there (`stats.mean_interval`, cut to
    `within`), as JSON."""
    interval = stats.mean_interval([v for v in values if v is not None], confidence, within)
    return None if interval is None else list(interval)


def _count_interval(counts: list[int], confidence: float, robots: int) -> list[float] | None:
    """`stats.count_mean_interval` of robots lost a run, at most the robots launched, as JSON."""
    interval = stats.count_mean_interval(counts, confidence, (0.0, float(robots) if robots else math.inf))
    return None if interval is None else list(interval)


def _runs_for(rate: float, half_width: float, confidence: float, n: int) -> int | None:
    return stats.runs_for_width(rate, 2 * half_width, confidence) if n else None


def _loss_counts(per_run) -> tuple[dict[str, int], dict[str, dict[str, int]]]:
    causes: Counter = Counter()
    phases: dict[str, Counter] = {}
    for run in per_run:
        for loss in run:
            causes[loss["cause"]] += 1
            phases.setdefault(loss["phase"], Counter())[loss["cause"]] += 1
    return dict(sorted(causes.items())), {p: dict(sorted(c.items())) for p, c in sorted(phases.items())}


def _required(spec: StudySpec, pts: list[dict]) -> dict | None:
    """The smallest value of the first swept numeric key reaching the target (others held at their
    first value); None without a numeric sweep of two values or more (a `--set` is a sweep of one
    value: a key held, not a question of how much)."""
    numeric = [s for s in spec.sweeps if s.is_number and len(s.values) > 1]
    if not numeric:
        return None
    key = numeric[0].key
    fixed = {s.key: s.values[0] for s in spec.sweeps if s.key != key}
    chosen = [pt for pt in pts if all(pt["params"][k] == v for k, v in fixed.items()) and pt["runs"]]
    if not chosen:
        return None
    name = "swarm size" if key == "swarm.count" else key
    answer = stats.required_value(
        [float(pt["params"][key]) for pt in chosen],
        [pt["successes"] for pt in chosen],
        [pt["runs"] for pt in chosen],
        spec.target,
        spec.confidence,
        name=name,
    )
    value = answer.value
    if value is not None and numeric[0].is_integer:
        value = int(value)
    note = answer.note
    held = [pt for pt in pts if all(pt["params"][k] == v for k, v in fixed.items())]
    skipped = [f"{key} = {pt['params'][key]} ({pt['infeasible']})" for pt in held if pt.get("infeasible")]
    if skipped:  # not run, so not among the values the answer could be
        note = "; ".join(filter(None, [note, f"not run, infeasible: {'; '.join(skipped)}"]))
    return {
        "key": key,
        "value": value,
        "target": spec.target,
        "confidence": spec.confidence,
        "held": fixed,
        "note": note,
        "planned": _planned_required(key, chosen, spec.target, numeric[0].is_integer),
    }


def _planned_required(key: str, chosen: list[dict], target: float, integer: bool) -> dict | None:
    """The plan's own answer to the study's question: the smallest swept value whose plan gives
    P(success) >= target (`success_chance`; None where none does), with each point's chance;
    None when no point's plan gives one."""
    chances = sorted(
        (float(pt["params"][key]), pt["planned_success"])
        for pt in chosen
        if pt.get("planned_success") is not None
    )
    if not chances:
        return None
    value = next((v for v, p in chances if p >= target), None)
    if value is not None and integer:
        value = int(value)
    return {"value": value, "chances": [[int(v) if integer else v, p] for v, p in chances]}
