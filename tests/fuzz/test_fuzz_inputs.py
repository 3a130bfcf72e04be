"""Fuzzing every kind of input the commands read: from each shipped example (missions, maps and
their grids, planner profiles, the bundled robot and terrain files, an ESRI ASCII DEM, a study.json
and a plan.json made here), random mutations go through the loaders the CLI calls. Whatever the
bytes, the only exception allowed is the project's own `SwarmError`, with a one-line message: the
CLI prints it and exits 2, with no traceback.

Derandomized (a fixed seed per test) so CI is reproducible; the example counts are in `EXAMPLES`,
times `SWARM_FUZZ_SCALE` (default 1) for a longer hunt on demand:
`SWARM_FUZZ_SCALE=20 python -m pytest tests/fuzz --hypothesis-show-statistics`.
"""

from __future__ import annotations

import functools
import io
import json
import os
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mutations import mutated_bytes, mutated_table, mutated_text

from swarm.errors import SwarmError
from swarm.mission import read_mission_yaml
from swarm.mission.load import mission_from_dict
from swarm.planning.profiles import load_profile
from swarm.robot.params import load_robot
from swarm.robot.terrain import load_library
from swarm.world.io import load_map, read_esri_ascii

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "swarm" / "data"
#: Examples per input kind in the default run.
EXAMPLES = {
    "mission": 300,
    "map": 300,
    "planner": 300,
    "robot": 300,
    "terrain": 300,
    "grid": 300,
    "dem": 300,
    "robot run": 300,
    "study.json": 200,
    "plan.json": 200,
    "summary.json": 200,
    "simulation log": 200,
    "evaluation.json": 200,
    "validation.json": 200,
}


SCALE = int(os.environ.get("SWARM_FUZZ_SCALE", "1"))
#: Each test runs a few hundred loads: seconds, not minutes; CI runs them with the slow tests. A
#: warning would be lines on stderr beside the one-line error: it fails the test too.
pytestmark = [pytest.mark.slow, pytest.mark.filterwarnings("error")]


def fuzz(kind: str):
    return settings(
        max_examples=EXAMPLES[kind] * SCALE,
        derandomize=True,
        deadline=None,
        database=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )


def only_our_error(load: Callable[[Path], object], path: Path) -> None:
    """`load(path)` returns, or raises a `SwarmError` of one line; anything else fails the test."""
    try:
        load(path)
    except SwarmError as exc:
        message = str(exc)
        assert message.strip(), f"an empty error message for {path}"
        assert "\n" not in message, f"a message of more than one line: {message!r}"


def _shipped(*patterns: str) -> list[Path]:
    return sorted(p for pattern in patterns for p in REPO.glob(pattern))


@pytest.fixture(scope="module")
def work(tmp_path_factory) -> Path:
    """A folder for the mutated files, with the shipped grids beside them (maps refer to them)."""
    folder = tmp_path_factory.mktemp("fuzz")
    for grid in _shipped("maps/*.npz"):
        (folder / grid.name).symlink_to(grid)
    return folder


def _text_kind(kind: str, sources: list[Path], load: Callable[[Path], object]):
    """A fuzz test of a text input kind: mutate one of `sources`, write it, load it."""

    @fuzz(kind)
    @given(data=st.data())
    def test(work: Path, data) -> None:
        src = data.draw(st.sampled_from(sources), label="source")
        path = work / src.name
        path.write_bytes(data.draw(mutated_text(src.read_text(encoding="utf-8")), label="file"))
        only_our_error(load, path)

    return test


# --- missions: the references they name load once (the maps, robots and terrain are fuzzed below) ----


@pytest.fixture(scope="module", autouse=True)
def cached_references():
    import swarm.planning.profiles as profiles
    import swarm.robot.params as params
    import swarm.robot.terrain as terrain
    import swarm.world.io as world_io

    def cache(load):
        done: dict = {}

        @functools.wraps(load)
        def cached(*args):
            key = tuple(str(a) if isinstance(a, str | Path) else id(a) for a in args)
            if key not in done:
                done[key] = load(*args)
            return done[key]

        return cached

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(world_io, "load_map", cache(world_io.load_map))
        mp.setattr(params, "load_robot", cache(params.load_robot))
        mp.setattr(terrain, "load_library", cache(terrain.load_library))
        mp.setattr(profiles, "load_profile", cache(profiles.load_profile))
        yield


MISSIONS = _shipped("missions/*.yaml")


def _load_mission(path: Path) -> object:
    """`load_mission`, with the references relative to the shipped missions' folder."""
    return mission_from_dict(read_mission_yaml(path), path, base_dir=REPO / "missions")


test_missions = _text_kind("mission", MISSIONS, _load_mission)
test_maps = _text_kind("map", _shipped("maps/*.yaml"), load_map)
test_planner_profiles = _text_kind("planner", _shipped("planners/*.yaml"), load_profile)
test_robots = _text_kind("robot", _shipped("swarm/data/robots/*.yaml"), load_robot)
test_terrain_modes = _text_kind(
    "terrain", _shipped("swarm/data/terrain/*.yaml", "swarm/data/terrain_modes.yaml"), load_library
)


# --- binary and other formats ----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def small_map(work: Path) -> Path:
    """A 6 x 5 cell map with its grid, to mutate the grid of."""
    from swarm.world import BeachMap, save_map

    terrain = np.array([[0] * 6, [1] * 6, [2] * 6, [3] * 6, [4] * 6], dtype=np.int8)
    elevation = np.linspace(-2.0, 3.0, 30, dtype=np.float32).reshape(5, 6)
    classes = ("deep_water", "surf", "shallow_water", "wet_hard_sand", "soft_sand")
    path = work / "small.yaml"
    save_map(BeachMap("small", 2.0, (0.0, 0.0), classes, terrain, elevation, {}), path)
    return path


LIBRARY = load_library()


def _npz(arrays: dict[str, np.ndarray]) -> bytes:
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    return buf.getvalue()


@st.composite
def mutated_grid(draw, original: bytes) -> bytes:
    """The grid's bytes damaged, or well-formed arrays with the wrong names, types, shapes, values."""
    if draw(st.booleans()):
        return draw(mutated_bytes(original))
    with np.load(io.BytesIO(original)) as npz:
        arrays = {k: npz[k] for k in npz.files}
    name = draw(st.sampled_from(sorted(arrays)))
    how = draw(st.sampled_from(("dtype", "shape", "value", "drop", "extra", "rename", "empty")))
    a = arrays[name]
    if how == "dtype":
        dtypes = [np.int32, np.float64, np.uint8, np.bool_, np.complex64]
        arrays[name] = a.astype(draw(st.sampled_from(dtypes)))
    elif how == "shape":
        arrays[name] = draw(st.sampled_from([a.ravel(), a[:-1], a[None], a.T, a[:, :0]]))
    elif how == "value":
        a = a.copy()
        value = draw(st.sampled_from([np.nan, np.inf, -np.inf, -1, 127, -128, 5, 1e30]))
        with np.errstate(invalid="ignore", over="ignore"):
            a.flat[draw(st.integers(0, a.size - 1))] = np.asarray(value).astype(a.dtype)
        arrays[name] = a
    elif how == "drop":
        del arrays[name]
    elif how == "extra":
        arrays["slope"] = a
    elif how == "rename":
        arrays[name.upper()] = arrays.pop(name)
    else:
        arrays = {}
    return _npz(arrays)


@fuzz("grid")
@given(data=st.data())
def test_grids(small_map: Path, data) -> None:
    grid = small_map.with_suffix(".npz")
    original = getattr(test_grids, "original", None) or grid.read_bytes()
    test_grids.original = original  # type: ignore[attr-defined]
    grid.write_bytes(data.draw(mutated_grid(original), label="grid"))
    only_our_error(lambda p: load_map(p, LIBRARY), small_map)


DEM = """ncols 4
nrows 3
xllcorner 500000.0
yllcorner 4100000.0
cellsize 2.0
NODATA_value -9999
1.0 2.0 3.0 4.0
0.5 1.5 -9999 3.5
-1.0 -0.5 0.0 0.5
"""


@fuzz("dem")
@given(text=mutated_table(DEM), fill=st.sampled_from([None, 0.0]))
def test_dems(work: Path, text: bytes, fill: float | None) -> None:
    path = work / "dem.asc"
    path.write_bytes(text)
    only_our_error(lambda p: read_esri_ascii(p, fill=fill), path)


RUNS = DATA / "robot-runs"
#: The first 40 rows of a shipped run of each format, and its reader (`swarm model validate`).
ROBOT_RUNS = {
    "encoders.txt": ("concrete_straight_encoders.txt", "read_encoders"),
    "truth.txt": ("concrete_straight_truth.txt", "read_truth"),
    "run.ssv": ("concrete_straight.ssv", "read_ssv"),
}


@fuzz("robot run")
@given(data=st.data())
def test_robot_runs(work: Path, data) -> None:
    import swarm.robot.io as robot_io

    name = data.draw(st.sampled_from(sorted(ROBOT_RUNS)), label="format")
    source, reader = ROBOT_RUNS[name]
    original = "".join((RUNS / source).read_text().splitlines(keepends=True)[:40])
    path = work / name
    path.write_bytes(data.draw(mutated_table(original), label="file"))
    only_our_error(getattr(robot_io, reader), path)


# --- files swarm wrote and reads back (swarm report, a resumed study) ----------------------------------


@pytest.fixture(scope="module")
def study_json(work: Path) -> Path:
    from swarm.studies.study import StudySpec
    from swarm.studies.sweep import parse_sweeps

    spec = StudySpec(str(REPO / "missions" / "landing.yaml"), 3, parse_sweeps(["swarm.count=6,8"]), seed=4)
    path = work / "study" / "study.json"
    path.parent.mkdir()
    path.write_text(json.dumps(spec.as_dict(), indent=1, sort_keys=True) + "\n")
    return path


@fuzz("study.json")
@given(data=st.data())
def test_study_json(study_json: Path, data) -> None:
    from swarm.studies.store import read_study_file

    original = getattr(test_study_json, "original", None) or study_json.read_text()
    test_study_json.original = original  # type: ignore[attr-defined]
    study_json.write_bytes(data.draw(mutated_text(original, dump=json.dumps), label="file"))
    only_our_error(read_study_file, study_json)


@pytest.fixture(scope="module")
def plan_json(work: Path) -> Path:
    """The landing mission's plan.json, as swarm plan writes it (about a second)."""
    from swarm.mission import load_mission
    from swarm.mission.plan import plan_mission, write_plan

    folder = work / "plan"
    write_plan(plan_mission(load_mission(REPO / "missions" / "landing.yaml"), seed=0, workers=1), folder)
    shutil.copy(folder / "plan.json", work / "plan.json.orig")
    return folder / "plan.json"


@fuzz("plan.json")
@given(data=st.data())
def test_plan_json(plan_json: Path, data) -> None:
    from swarm.report.load import read_plan

    original = (plan_json.parent.parent / "plan.json.orig").read_text()
    plan_json.write_bytes(data.draw(mutated_text(original, dump=json.dumps), label="file"))
    only_our_error(read_plan, plan_json.parent)


@pytest.fixture(scope="module")
def summary_json(work: Path) -> Path:
    """A study folder: summary.json as `run_study` writes it, from `summarize` over a small results
    table made here (two points of three runs and one point never run, whose rates are NaN and
    whose run counts are null), beside that table as results.parquet."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from swarm.studies.study import StudySpec, summarize
    from swarm.studies.sweep import parse_sweeps

    spec = StudySpec(
        str(REPO / "missions" / "landing.yaml"), 3, parse_sweeps(["swarm.count=8,10,12"]), seed=4
    )
    loss = {"cause": "surf_timeout", "phase": "surf_crossing", "t_s": 100.5, "x_m": 39.0, "y_m": 14.7}
    table = pa.table(
        {
            "point": pa.array([0, 0, 0, 1, 1, 1], pa.int32()),
            "run": pa.array([0, 1, 2, 0, 1, 2], pa.int32()),
            "swarm.count": [8, 8, 8, 10, 10, 10],
            "success": [False, True, False, True, True, True],
            "losses": [[loss, {**loss, "cause": "failure", "phase": "beach"}], [], [loss], [], [loss], []],
            "completed_s": [None, 310.5, None, 280.0, 295.5, 301.0],
        }
    )
    summary = summarize(spec, table) | {
        "backend": "local",
        "workers": 1,
        "map": "test_small",
        "date": "2026-01-02",
    }
    folder = work / "study-summary"
    folder.mkdir()
    pq.write_table(table, folder / "results.parquet")
    path = folder / "summary.json"
    path.write_text(json.dumps(summary, indent=1, sort_keys=True) + "\n")
    return path


@fuzz("summary.json")
@given(data=st.data())
def test_summary_json(summary_json: Path, data) -> None:
    """`swarm report` on a study folder: reading summary.json and building the report's tables."""
    from swarm.report.load import report_for

    original = getattr(test_summary_json, "original", None) or summary_json.read_text()
    test_summary_json.original = original  # type: ignore[attr-defined]
    summary_json.write_bytes(data.draw(mutated_text(original, dump=json.dumps), label="file"))
    only_our_error(lambda p: report_for(p.parent).markdown(), summary_json)


# --- result folders swarm report reads: a simulation's log, a plan's evaluation, a validation --------


def _copy_folder(src: Path, dst: Path) -> Path:
    if dst.exists():
        shutil.rmtree(dst)
    shutil.copytree(src, dst)
    return dst


@pytest.fixture(scope="module")
def sim_folder(work: Path) -> Path:
    """A simulation folder as `swarm simulate` writes it: a short landing run (seconds)."""
    from swarm.mission import load_mission
    from swarm.mission.plan import plan_mission, write_plan
    from swarm.sim.run import simulate, write_log

    mission = load_mission(REPO / "missions" / "landing.yaml", {"phases.beach_operations.time_limit_s": 300})
    plan = plan_mission(mission, seed=0, workers=1)
    folder = work / "sim.orig"
    write_plan(plan, folder)
    write_log(simulate(mission, seed=1, plan=plan), folder)
    return folder


@fuzz("simulation log")
@given(data=st.data())
def test_simulation_logs(sim_folder: Path, data) -> None:
    """`swarm report` on a simulation folder with one of outcome.json, events.jsonl (one line of it,
    or the whole file) or trajectories.npz broken."""
    from swarm.report.load import report_for

    folder = _copy_folder(sim_folder, sim_folder.parent / "sim")
    name = data.draw(
        st.sampled_from(["outcome.json", "events.jsonl", "events.jsonl line", "trajectories.npz"])
    )
    if name in ("trajectories.npz", "events.jsonl"):
        path = folder / name
        path.write_bytes(data.draw(mutated_bytes(path.read_bytes()), label="file"))
    elif name == "events.jsonl line":
        path = folder / "events.jsonl"
        lines = path.read_bytes().splitlines(keepends=True)
        i = data.draw(st.integers(0, len(lines) - 1), label="line")
        lines[i] = data.draw(mutated_text(lines[i].decode(), dump=json.dumps), label="event") + b"\n"
        path.write_bytes(b"".join(lines))
    else:
        path = folder / name
        path.write_bytes(data.draw(mutated_text(path.read_text(), dump=json.dumps), label="file"))
    only_our_error(lambda p: report_for(p).markdown(), folder)


@fuzz("evaluation.json")
@given(data=st.data())
def test_plan_evaluations(plan_json: Path, data) -> None:
    """`swarm report` on a plan folder whose evaluation.json (`swarm plan --evaluate`) is broken."""
    from swarm.report.load import report_for

    original = {
        "runs": 4,
        "successes": 3,
        "success_rate": 0.75,
        "wilson_low": 0.3,
        "wilson_high": 0.95,
        "target": 0.9,
        "confidence": 0.95,
        "detection": None,
        "detection_values": [],
        "lost": {"mean": 1.0, "min": 0, "max": 2, "p50": 1.0},
        "lost_values": [0, 1, 2, 1],
        "losses_by_cause": {"failure": 4},
        "losses_by_phase": {"beach": {"failure": 4}},
        "seeds": [1, 2, 3, 4],
        "folder": "evaluation/plan",
        "suggested_count": 18,
        "sizes": [{"count": 18, "runs": 4, "success_rate": 1.0, "wilson_low": 0.5, "wilson_high": 1.0}],
    }
    plan_json.write_text((plan_json.parent.parent / "plan.json.orig").read_text())
    path = plan_json.parent / "evaluation.json"
    path.write_bytes(data.draw(mutated_text(json.dumps(original), dump=json.dumps), label="file"))
    only_our_error(lambda p: report_for(p).markdown(), plan_json.parent)


@pytest.fixture(scope="module")
def validation_folder(work: Path) -> Path:
    """A validation folder as `swarm model validate --compare --out` writes it, on a shipped run."""
    from swarm.cli import main

    folder = work / "validation.orig"
    args = ["model", "validate", "--robot", str(DATA / "robots" / "skid4.yaml")]
    args += ["--encoders", str(RUNS / "concrete_straight_encoders.txt")]
    args += ["--truth", str(RUNS / "concrete_straight_truth.txt"), "--compare", "--out", str(folder)]
    assert main(args) == 0
    return folder


@fuzz("validation.json")
@given(data=st.data())
def test_validations(validation_folder: Path, data) -> None:
    """`swarm report` on a validation folder with validation.json or validation.npz broken."""
    from swarm.report.load import report_for

    folder = _copy_folder(validation_folder, validation_folder.parent / "validation")
    name = data.draw(st.sampled_from(["validation.json", "validation.npz"]))
    path = folder / name
    if name.endswith(".npz"):
        path.write_bytes(data.draw(mutated_bytes(path.read_bytes()), label="file"))
    else:
        path.write_bytes(data.draw(mutated_text(path.read_text(), dump=json.dumps), label="file"))
    only_our_error(lambda p: report_for(p).markdown(), folder)
