"""Reports from files on disk: which kind of output a path is, reading it back, and its `Report`.

| kind         | the folder holds                                       |
| ---          | ---                                                    |
| `study`      | summary.json and results.parquet                       |
| `simulation` | outcome.json, events.jsonl and trajectories.npz        |
| `plan`       | plan.json (and none of the simulation log's files)     |
| `validation` | validation.json (and validation.npz)                   |

PATH may be the folder or one of those files (its folder is used). The map comes back through the
files plan.json records (`source.map_file`, `source.terrain_file`) and, for a study, the mission
file in summary.json / study.json; a map that has moved leaves the report without map figures.

```python
report = report_for("reports/landing-sim")    # or swarm.report.build_report
report.kind                                   # "simulation"
report.write("reports/landing-sim/report.md")
```
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any

import pyarrow as pa
import pyarrow.parquet as pq
from pydantic import BaseModel, ConfigDict, Field, model_validator
from pydantic_core import PydanticCustomError

from swarm import files
from swarm.errors import InputError, SwarmError
from swarm.inputs import XY, expected, validate
from swarm.mission.plan import MissionPlan
from swarm.report.document import Report
from swarm.report.plan_report import plan_report
from swarm.report.sim_report import sim_report
from swarm.report.study_report import study_report
from swarm.report.validation_report import VALIDATION_FILE, read_validation, validation_report
from swarm.sim.run import LOG_FILES, read_log
from swarm.studies.evaluate import EVALUATION_FILE
from swarm.studies.store import RESULTS, SPEC
from swarm.studies.table import schema as results_schema

KINDS = ("plan", "simulation", "study", "validation")
STUDY_FILES = ("summary.json", RESULTS)
PLAN_FILE = "plan.json"
#: The results-table columns a study report rests on: summary.json is computed from them
#: (`swarm.studies.study.summarize`) and the figures read them. Their types are the writer's
#: (`swarm.studies.table.schema`); other columns are not read, so not checked.
RESULT_COLUMNS = ("point", "success", "completed_s", "losses")
EXPECTED = (
    "a plan (folder with plan.json), a simulation log (outcome.json, events.jsonl, trajectories.npz), "
    "a study (summary.json, results.parquet) or a model validation (validation.json), or one of those files"
)
#: Every file whose folder may be given by naming the file.
KNOWN_FILES = {
    PLAN_FILE,
    VALIDATION_FILE,
    *LOG_FILES,
    *STUDY_FILES,
    SPEC,
    "validation.npz",
    "plan.geojson",
}
#: The files that mark each kind's folder, however far its command got; a simulation's folder
#: holds a plan.json too, so its own files are looked for first.
OUTPUT_MARKS = {
    "simulation": LOG_FILES,
    "study": (SPEC, *STUDY_FILES),
    "plan": (PLAN_FILE,),
    "validation": (VALIDATION_FILE,),
}


def output_kind(folder: Path) -> str | None:
    """Which command's output `folder` holds (a kind), None for none or no folder: where a command
    must not write another's (`swarm ... --out`). `detect` is the strict reading for a report."""
    if folder.is_dir():
        for kind, marks in OUTPUT_MARKS.items():
            if any((folder / name).is_file() for name in marks):
                return kind
    return None


def detect(path: str | Path) -> tuple[str, Path]:
    """(kind, folder) of a report input; anything else is an `InputError` naming `path`."""
    p = Path(path)
    if p.is_file():
        if p.name not in KNOWN_FILES:
            raise InputError(p, "(path)", f"a file named {p.name}", EXPECTED)
        p = p.parent
    elif not p.exists():
        raise InputError(p, "(path)", "nothing there", EXPECTED)
    elif not p.is_dir():
        raise InputError(p, "(path)", "neither a file nor a folder", EXPECTED)
    has = {name for name in KNOWN_FILES if (p / name).is_file()}
    if "summary.json" in has:
        missing = [f for f in STUDY_FILES if f not in has]
        if missing:
            raise InputError(
                p, "(study)", f"summary.json without {', '.join(missing)}", "a finished study folder"
            )
        return "study", p
    if "outcome.json" in has:
        missing = [f for f in LOG_FILES if f not in has]
        if missing:
            raise InputError(
                p, "(simulation)", f"outcome.json without {', '.join(missing)}", "a whole simulation log"
            )
        return "simulation", p
    log = [f for f in LOG_FILES if f in has]
    if log:
        raise InputError(
            p, "(simulation)", f"{', '.join(log)} without outcome.json", "a whole simulation log"
        )
    if PLAN_FILE in has:
        return "plan", p
    if VALIDATION_FILE in has:
        return "validation", p
    names = sorted(x.name for x in p.iterdir())
    found = (
        f"a folder holding {', '.join(names[:6])}{', ...' if len(names) > 6 else ''}"
        if names
        else "an empty folder"
    )
    raise InputError(p, "(folder)", found, EXPECTED)


def read_json(path: Path, what: str) -> dict:
    """A JSON object from `path`; anything else is an `InputError`."""
    data = files.read_json(path, what)
    if not isinstance(data, dict):
        raise InputError(path, "(top level)", type(data).__name__, f"a JSON object ({what})")
    return data


def load_beach_map(source: dict):
    """The map a plan recorded (`source.map_file`, with `source.terrain_file`'s modes), or None when
    it is not recorded or cannot be read."""
    from swarm.robot.terrain import load_library
    from swarm.world.io import load_map

    map_file = (source or {}).get("map_file")
    if not map_file or not Path(map_file).is_file():
        return None
    try:
        return load_map(map_file, load_library(source.get("terrain_file")))
    except SwarmError:
        return None


class _Written(BaseModel):
    """A file swarm wrote, read back: the keys the report needs, checked; other keys ignored."""

    model_config = ConfigDict(extra="ignore", strict=True, frozen=True)


class _RobotEntry(_Written):
    model_config = ConfigDict(extra="ignore", strict=True, frozen=True, allow_inf_nan=False)

    id: str
    role: str
    task: str | None = None
    launch_m: XY
    release_s: float
    sea_leg_m: list[XY]
    ground_m: list[XY]
    waypoints_m: list[XY] = Field(min_length=1)
    eta_s: float
    sea_time_s: float
    ground_time_s: float
    length_m: float


class _SearchEntry(_Written):
    task: str
    area: str = ""
    area_m: list[Any]
    sweep_width_m: float
    spacing_m: float
    model: str
    tracks_m: list[list[list[XY]]] = []
    expected_detection: float
    swath_coverage: float
    design: dict[str, Any] = {}


class _RelayEntry(_Written):
    task: str
    source_m: XY
    sinks_m: list[XY]
    positions_m: list[XY]
    edges: list[Annotated[list[int], Field(min_length=2, max_length=2)]]
    comm_range_m: float
    redundancy: int
    radio: dict[str, Any] | None = None
    fixed_height_m: float | None = None


class PlanFile(_Written):
    """plan.json (`swarm.mission.plan.plan_json`) as `swarm report` reads it."""

    mission: str
    map: str
    seed: int
    robots: list[_RobotEntry]
    search: list[_SearchEntry] = []
    relay: _RelayEntry | None = None
    source: dict[str, Any] | None = None
    criteria: dict[str, Any] | None = None
    budget: dict[str, Any] | None = None

    @model_validator(mode="after")
    def _edges(self) -> PlanFile:
        r = self.relay
        if r is not None:
            nodes = 1 + len(r.sinks_m) + len(r.positions_m)
            for i, edge in enumerate(r.edges):
                if not all(0 <= n < nodes for n in edge):
                    raise expected(f"node indices in 0..{nodes - 1}", found=edge, key=f"relay.edges[{i}]")
        return self


_Count = Annotated[int, Field(ge=0)]


class _PointEntry(_Written):
    index: int | None = None
    params: dict[str, Any] = {}
    infeasible: str | None = None  # why the point could not run: no runs, no rate
    runs: _Count
    successes: _Count = 0
    success_rate: float | None
    wilson_low: float | None
    wilson_high: float | None
    lost_mean: float | None = None
    losses_by_cause: dict[str, _Count] = {}
    losses_by_phase: dict[str, dict[str, _Count]] = {}
    completed_s: dict[str, float | None] = {}
    runs_for_width: dict[str, _Count | None] = {}  # None: no runs at the point
    more_runs_for_width: dict[str, _Count | None] = {}

    @model_validator(mode="after")
    def _rated(self) -> _PointEntry:
        """A point that ran has its rate and interval; only an infeasible one goes without."""
        if self.infeasible is None:
            for key in ("success_rate", "wilson_low", "wilson_high"):
                if getattr(self, key) is None:
                    # found: None itself (`expected` takes None for "not given")
                    raise PydanticCustomError(
                        "expected", "{expected}", {"expected": "a number", "found": None, "key": key}
                    )
        return self


class _Required(_Written):
    key: str | None = None
    value: Any = None  # the swept value found (a number, or whatever the swept key takes)
    note: str | None = None
    target: float | None = None
    confidence: float | None = None
    held: dict[str, Any] = {}


class SummaryFile(_Written):
    """A study's summary.json (`swarm.studies.study.run_study`) as `swarm report` reads it."""

    mission: str = Field(description="The mission's name, for the report's title.")
    map: str | None = None
    seed: int | None = None
    date: str | None = None
    version: str | None = None
    backend: str | None = None
    workers: int | None = None
    mission_path: str | None = None
    target: float | None = None
    confidence: float = Field(0.95, gt=0, lt=1)
    runs: _Count = Field(description="Runs made, one row of results.parquet each.")
    runs_per_point: _Count | None = None
    sweeps: dict[str, list[Any]] = {}
    required: _Required | None = None
    losses_by_cause: dict[str, _Count] = {}
    losses_by_phase: dict[str, dict[str, _Count]] = {}
    points: list[_PointEntry] = Field(min_length=1, description="Each parameter point's results.")


class _Distribution(_Written):
    mean: float | None = None
    median: float | None = None
    min: float | None = None
    max: float | None = None


class _QuickSize(_Written):
    count: int
    runs: _Count
    success_rate: float
    wilson_low: float
    wilson_high: float


class EvaluationFile(_Written):
    """A plan's evaluation.json (`swarm.studies.evaluate.evaluate_plan`) as `swarm report` reads it."""

    runs: _Count
    successes: _Count
    success_rate: float
    wilson_low: float
    wilson_high: float
    target: float
    confidence: float = Field(gt=0, lt=1)
    detection: _Distribution | None = None
    detection_values: list[float] = []
    lost: _Distribution
    lost_values: list[float] = []
    losses_by_cause: dict[str, _Count] = {}
    losses_by_phase: dict[str, dict[str, _Count]] = {}
    sizes: list[_QuickSize] = []
    runs_needed: _Count | None = None
    suggested_count: int | None = None


def read_plan(folder: str | Path) -> tuple[MissionPlan, dict]:
    """The plan in `folder`/plan.json (with its map when it can be found) and the JSON itself."""
    path = Path(folder) / PLAN_FILE
    d = read_json(path, "plan.json")
    validate(PlanFile, d, path)
    try:
        return MissionPlan.from_dict(d, load_beach_map(d.get("source") or {})), d
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        raise InputError(
            path, "(contents)", f"{type(exc).__name__}: {exc}", "a plan.json written by swarm"
        ) from None


def read_results(path: Path, runs: int) -> pa.Table:
    """A study's results.parquet, checked against what swarm study writes (`RESULT_COLUMNS`, a row
    per run of summary.json's `runs`), so a foreign or cut table is one line here rather than a
    KeyError from a figure or a report of nothing."""
    try:
        table = pq.read_table(path)
    except (OSError, pa.ArrowException) as exc:
        raise InputError(path, "(file)", str(exc), "a Parquet results table") from None
    _check_columns(path, table.schema)
    if table.num_rows != runs:
        raise InputError(
            path,
            "(rows)",
            f"{table.num_rows} row{'s' if table.num_rows != 1 else ''}",
            f"one per run: the {runs} runs summary.json counts",
        )
    return table


def _check_columns(path: Path, found: pa.Schema) -> None:
    """Each of `RESULT_COLUMNS` there once, with the type the study's writer gives it."""
    missing = [c for c in RESULT_COLUMNS if c not in found.names]
    if missing:
        raise InputError(
            path,
            "(columns)",
            _listing(found.names),
            f"the columns swarm study writes, including {', '.join(missing)}",
        )
    written = results_schema([])
    for c in RESULT_COLUMNS:
        at = found.get_all_field_indices(c)
        if len(at) > 1:
            raise InputError(path, f"column {c}", f"{len(at)} columns of that name", "one")
        kind, want = found.field(at[0]).type, written.field(c).type
        if not kind.equals(want):
            raise InputError(path, f"column {c}", str(kind), f"{want}, as swarm study writes it")


def _listing(names: list[str], most: int = 8) -> str:
    """'columns a, b, ...': the first `most` names, so a wide foreign table stays one short line."""
    if not names:
        return "no columns"
    return f"columns {', '.join(names[:most])}{', ...' if len(names) > most else ''}"


def _study_map(folder: Path, summary: dict):
    """The study's map, through its mission file (as given, else as study.json resolved it)."""
    from swarm.mission.load import load_mission

    candidates = [summary.get("mission_path")]
    spec = folder / SPEC
    if spec.is_file():
        from swarm.studies.store import read_study_file

        with contextlib.suppress(SwarmError):
            candidates.append(read_study_file(spec).mission)
    for c in candidates:
        if c and Path(c).is_file():
            try:
                return load_mission(c).beach_map
            except SwarmError:
                continue
    return None


def report_for(path: str | Path, *, date: str | None = None) -> Report:
    """The report of whatever `path` holds (see the module docstring). `date` goes in the header
    (default: today; a study's default is the day it ran). Bad input is an `InputError`."""
    kind, folder = detect(path)
    if kind == "plan":
        plan, d = read_plan(folder)
        ev_path = folder / EVALUATION_FILE
        evaluation = read_json(ev_path, EVALUATION_FILE) if ev_path.is_file() else None
        if evaluation is not None:
            validate(EvaluationFile, evaluation, ev_path)
        return _guard(
            folder / PLAN_FILE, lambda: plan_report(plan, date=date, plan_dict=d, evaluation=evaluation)
        )
    if kind == "simulation":
        plan = read_plan(folder)[0] if (folder / PLAN_FILE).is_file() else None
        log = read_log(folder, plan=plan)
        return _guard(folder / "outcome.json", lambda: sim_report(log, date=date))
    if kind == "study":
        summary = read_json(folder / "summary.json", "summary.json")
        runs = validate(SummaryFile, summary, folder / "summary.json").runs
        table = read_results(folder / RESULTS, runs)
        beach = _study_map(folder, summary)
        no_map = "No map: the study's mission file could not be found." if beach is None else "No map given."
        return _guard(
            folder / "summary.json", lambda: study_report(table, summary, beach, date=date, no_map=no_map)
        )
    v = read_validation(folder)
    return _guard(folder / VALIDATION_FILE, lambda: validation_report(v, date=date))


def _guard(source: Path, build: Callable[[], Report]) -> Report:
    """Build a report; a file with missing or mistyped keys is an `InputError` naming it."""
    try:
        return build()
    except (KeyError, TypeError, ValueError, IndexError, AttributeError) as exc:
        raise InputError(
            source, "(contents)", f"{type(exc).__name__}: {exc}", "a file written by swarm"
        ) from None


build_report = report_for
