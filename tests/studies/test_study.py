"""Studies end to end on tiny missions: seeds that do not depend on workers or order, resume after
kill -9, the Ray backend, a required swarm size against the k-out-of-n closed form, bad sweeps."""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import yaml
from scipy.stats import t

from swarm.cli import main
from swarm.errors import InputError
from swarm.sim.hazards import CAUSES
from swarm.studies import backends
from swarm.studies.runner import run_seed
from swarm.studies.stats import k_out_of_n, wilson_interval
from swarm.studies.study import StudySpec, run_study
from swarm.studies.sweep import parse_sweep, parse_sweeps, points
from swarm.studies.table import VOLATILE, param_cell, param_type

REPO = Path(__file__).resolve().parents[2]
#: Hazards that take nobody but random failure: a calm sea where no breaker rolls a robot over or
#: turns it broadside, so nobody overstays the surf crossing's time limit.
QUIET = {
    "surf": {"damage_h50_m": 10.0, "flip_probability": 0.0, "wave_height_m": 0.3},
    "immobilization": {"per_km": 0.0},
    "rocks": {"damage_per_km": 0.0, "collision_damage_probability": 0.0},
}


def _mission(tmp: Path, name: str = "tiny", **changes: object) -> Path:
    """Robots by hand 20 m off maps/test_small, landing on one zone: a run is about a second."""
    mission = {
        "name": name,
        "map": str(REPO / "maps" / "test_small.yaml"),
        "planner": str(REPO / "planners" / "fast.yaml"),
        "swarm": {"count": 3},
        "launch": {"platform": "by_hand", "points": ["launch_1"], "offshore_m": 20, "interval_s": 0},
        "phases": {
            "sea_transit": {"time_limit_s": 300},
            "surf_crossing": {"time_limit_s": 300},
            "beach_operations": {"time_limit_s": 120},
            "return_to_sea": {"enabled": False},
        },
        "tasks": [{"type": "landing", "zones": ["landing_a"], "robots_per_zone": 2}],
        "hazards": {**QUIET, "attrition": {"mtbf_h": 0.05}},
    }
    mission.update(changes)
    path = tmp / f"{name}.yaml"
    path.write_text(yaml.safe_dump(mission, sort_keys=False))
    return path


def _stable(table: pa.Table) -> pa.Table:
    """The table without the wall-clock column, as one chunk (for equality)."""
    return table.drop_columns(list(VOLATILE)).combine_chunks()


@pytest.fixture(scope="module")
def tiny(tmp_path_factory) -> Path:
    return _mission(tmp_path_factory.mktemp("study"))


@pytest.fixture(scope="module")
def reference(tiny, tmp_path_factory) -> tuple[StudySpec, pa.Table]:
    """An uninterrupted study on one worker: 2 points x 5 runs."""
    spec = StudySpec(str(tiny), runs=5, sweeps=parse_sweeps(["swarm.count=2,3"]), seed=7)
    table, _ = run_study(spec, tmp_path_factory.mktemp("reference"), workers=1)
    return spec, table


#: The Ray tests on one core (`scripts/test`'s loadgroup): one `local_ray` for them, and never two
#: Rays starting at once on a two-core machine.
RAY_GROUP = pytest.mark.xdist_group("ray")


@pytest.fixture(scope="module")
def local_ray() -> Iterator[None]:
    """One local Ray instance for this module's in-process Ray studies: `run_study` uses Ray when
    it is already running and leaves it running, so each test does not pay Ray's start and stop
    (some 8 s of a 13 s test here). The killed-worker test kills a worker, which Ray replaces."""
    pytest.importorskip("ray")  # the `ray` extra; CI installs it
    started = backends.start_ray(2, None)
    yield
    if started:
        backends.stop_ray()


def test_run_seeds_come_from_the_study_seed_and_the_runs_place() -> None:
    seeds = {run_seed(7, p, r) for p in range(4) for r in range(50)}
    assert len(seeds) == 200  # all distinct
    assert run_seed(7, 2, 3) == run_seed(7, 2, 3) != run_seed(8, 2, 3)


@pytest.mark.slow
def test_the_table_does_not_depend_on_the_worker_count_or_order(reference, tmp_path) -> None:
    spec, table = reference
    assert table.num_rows == 10
    assert table.column("point").to_pylist() == [0] * 5 + [1] * 5
    assert table.column("swarm.count").to_pylist() == [2] * 5 + [3] * 5
    two, _ = run_study(spec, tmp_path / "two", workers=2)
    assert _stable(two).equals(_stable(table))
    # and in any order: the reversed task list on one process gives the same rows
    rows = list(backends.run_local(list(reversed(spec.tasks())), 1))
    reordered = pa.Table.from_pylist(rows, schema=spec.table_schema()).sort_by(
        [("point", "ascending"), ("run", "ascending")]
    )
    assert _stable(reordered).equals(_stable(table))


def _study_in_a_session(tiny: Path, out: Path, runs: int, stderr: int) -> subprocess.Popen:
    """`swarm study` of the tiny mission, 2 points on 2 workers, as a new session's leader."""
    code = "import sys; from swarm.cli import main; sys.exit(main(sys.argv[1:]))"
    argv = [sys.executable, "-c", code, "study", str(tiny), "--runs", str(runs), "--sweep", "swarm.count=2,3",
            "--seed", "7", "--workers", "2", "--out", str(out)]  # fmt: skip
    return subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=stderr, text=True, start_new_session=True)


def _wait_for_a_part(proc: subprocess.Popen, out: Path) -> None:
    """Until the study has a chunk of rows on disk (its workers busy with the rest)."""
    deadline = time.monotonic() + 120
    while not list((out / "parts").glob("part-*.parquet")):
        assert proc.poll() is None, "the study ended before it could be stopped"
        assert time.monotonic() < deadline
        time.sleep(0.05)


@pytest.mark.slow
def test_a_study_killed_mid_way_resumes_to_the_same_table(reference, tiny, tmp_path) -> None:
    """kill -9 the whole process group once a chunk is on disk; the same command then finishes the
    study with exactly the uninterrupted table (and does not rerun what was stored)."""
    spec, expected = reference
    out = tmp_path / "killed"
    proc = _study_in_a_session(tiny, out, runs=5, stderr=subprocess.DEVNULL)
    try:
        _wait_for_a_part(proc, out)
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    kept = pq.read_table(out / "parts").num_rows if (out / "parts").exists() else 0
    assert 0 < kept < 10
    assert not (out / "results.parquet").exists()
    calls: list[tuple[int, int]] = []
    table, _ = run_study(spec, out, workers=2, progress=lambda done, total: calls.append((done, total)))
    assert calls[0] == (kept, 10)  # it starts from what was kept
    assert _stable(table).equals(_stable(expected))
    assert _stable(pq.read_table(out / "results.parquet")).equals(_stable(expected))


def _session_processes(sid: int) -> list[int]:
    """Pids of the processes in session `sid` (Linux /proc: field 6 of stat)."""
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        with contextlib.suppress(OSError):
            fields = stat.read_text().rsplit(")", 1)[1].split()
            if int(fields[3]) == sid:
                out.append(int(stat.parent.name))
    return out


@pytest.mark.slow
def test_a_study_sent_sigterm_stops_its_workers_too(tiny, tmp_path) -> None:
    """`kill PID` (SIGTERM to the CLI alone, as `timeout` and batch schedulers send it) used to end
    the main process only: its pool's workers, under a forkserver, went on at full load with
    nobody to read their rows. Now the study unwinds as on Ctrl-C: exit 143, one line, and no
    process of its session left; what is on disk resumes (the test above)."""
    out = tmp_path / "termed"
    proc = _study_in_a_session(tiny, out, runs=20, stderr=subprocess.PIPE)
    try:
        _wait_for_a_part(proc, out)
        assert len(_session_processes(proc.pid)) >= 3  # the CLI, the forkserver, workers
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=30)
        assert proc.returncode == 143
        assert err.strip().splitlines()[-1].endswith("swarm: terminated")
        assert "Traceback" not in err
        deadline = time.monotonic() + 10
        while _session_processes(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert _session_processes(proc.pid) == []
    finally:
        for pid in _session_processes(proc.pid):
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        proc.wait()
    assert not (out / "results.parquet").exists()


def test_the_table_is_the_same_one_run_at_a_time_and_in_batches(tiny, tmp_path) -> None:
    """`--batch 1` runs each run alone (the PettingZoo adapter); `--batch 3` and `--batch 2` step a
    worker's runs of a point together on the batched core (a batch of 2 and one of 1 at a point
    of 3 runs): the same rows, apart from the wall-clock runtime."""
    spec = StudySpec(str(tiny), runs=3, sweeps=parse_sweeps(["swarm.count=2,3"]), seed=11)
    one, _ = run_study(spec, tmp_path / "one", workers=1, batch=1)
    assert one.num_rows == 6 and sum(one.column("lost").to_pylist()) > 0  # losses to tell runs apart
    for b in (3, 2):
        batched, _ = run_study(spec, tmp_path / f"b{b}", workers=1, batch=b)
        assert _stable(batched).equals(_stable(one)), b


def test_the_progress_moves_while_a_batch_runs(tiny, tmp_path, monkeypatch) -> None:
    """A batch's runs finish together at its end: between its rows, the study's progress counts
    the share of the batches still running that is done, as a fraction of runs; the table is the
    same as without a progress callback."""
    monkeypatch.setattr("swarm.sim.run.WORKING_EVERY_S", 0.0)
    spec = StudySpec(str(tiny), runs=3, sweeps=parse_sweeps(["swarm.count=2,3"]), seed=11)
    calls: list[tuple[float, int]] = []
    table, _ = run_study(spec, tmp_path / "p", workers=1, batch=3, progress=lambda d, t: calls.append((d, t)))
    quiet, _ = run_study(spec, tmp_path / "q", workers=1, batch=3)
    assert _stable(table).equals(_stable(quiet))
    done = [d for d, _ in calls]
    assert {t for _, t in calls} == {6} and done[0] == 0 and done[-1] == 6
    assert len({d for d in done if 0 < d < 3}) > 5  # the first batch, before its rows
    assert all(0 <= d <= 6 for d in done)


def test_a_worker_takes_its_batch_share_back_when_its_rows_are_ready(tiny, monkeypatch) -> None:
    """On local workers the batches add their progress to one shared count (`run_local` reads it
    between rows); a batch that ends takes its share back, as its rows count instead."""
    import multiprocessing

    monkeypatch.setattr("swarm.sim.run.WORKING_EVERY_S", 0.0)
    shared = multiprocessing.get_context("forkserver").Value("d", 0.0)
    seen: list[float] = []
    monkeypatch.setattr(backends, "_WORK_DONE", shared)
    spec = StudySpec(str(tiny), runs=3, sweeps=parse_sweeps(["swarm.count=3"]), seed=5)
    group = spec.tasks()
    real = backends.run_batch

    def watched(tasks, working=None):
        def tell(x: float) -> None:
            working(x)
            seen.append(shared.value)

        return real(tasks, tell)

    monkeypatch.setattr(backends, "run_batch", watched)
    rows = backends._run_shared(group)
    assert max(seen) > 1.0 and shared.value == 0.0
    assert [r["seed"] for r in rows] == [t.seed for t in group]


def test_batches_hold_runs_of_one_point_up_to_their_size(tiny) -> None:
    spec = StudySpec(str(tiny), runs=5, sweeps=parse_sweeps(["swarm.count=2,3"]), seed=1)
    groups = backends.batches(spec.tasks(), {0: 2, 1: 5})
    assert [[(t.point, t.run) for t in g] for g in groups] == [
        [(0, 0), (0, 1)], [(0, 2), (0, 3)], [(0, 4)], [(1, 0), (1, 1), (1, 2), (1, 3), (1, 4)]
    ]  # fmt: skip
    assert backends.auto_batch(100, 2, 24) == 50  # each worker's share in one batch
    assert backends.auto_batch(1000, 1, 24) == backends.AUTO_BATCH_RUNS
    assert backends.auto_batch(10, 4, 24) == 3
    assert backends.auto_batch(100, 1, 1000) == 4
    assert backends.auto_batch(5, 1, 100_000) == 1


@pytest.mark.slow
@RAY_GROUP
def test_the_ray_backend_gives_the_same_table_in_batches(reference, local_ray, tmp_path) -> None:
    spec, table = reference
    batched, _ = run_study(spec, tmp_path / "ray", backend="ray", workers=2, batch=2)
    assert _stable(batched).equals(_stable(table))


@pytest.mark.slow
@RAY_GROUP
def test_the_ray_backend_gives_the_same_table(reference, local_ray, tmp_path) -> None:
    spec, expected = reference
    table, summary = run_study(spec, tmp_path / "ray", backend="ray", workers=2)
    assert summary["backend"] == "ray"
    assert _stable(table).equals(_stable(expected))


@pytest.mark.slow
@RAY_GROUP
def test_the_ray_backend_starts_quietly(tiny, tmp_path) -> None:
    """`swarm study --backend ray` printed Ray's "Token authentication is enabled for this Ray
    cluster..." warning on a local start: stderr holds the progress bar and nothing else."""
    pytest.importorskip("ray")  # the `ray` extra; CI installs it
    env = {k: v for k, v in os.environ.items() if k != "RAY_AUTH_MODE"}  # Ray's default: it warns
    out = tmp_path / "s"
    argv = ["study", str(tiny), "--runs", "2", "--backend", "ray", "--workers", "1", "--out", str(out)]
    done = subprocess.run(
        [sys.executable, "-m", "swarm.cli", *argv], capture_output=True, text=True, timeout=300, env=env
    )
    assert done.returncode == 0, done.stderr
    lines = [x.strip() for x in done.stderr.replace("\r", "\n").splitlines() if x.strip()]
    assert not [x for x in lines if "token" in x.lower()], done.stderr
    assert all(x.startswith("study:") for x in lines), done.stderr


@pytest.mark.slow
def test_a_resume_with_other_arguments_is_refused(reference, tmp_path) -> None:
    spec, _ = reference
    out = tmp_path / "one"
    run_study(StudySpec(spec.mission_path, 1, spec.sweeps, spec.seed), out, workers=1)
    with pytest.raises(InputError, match="a different study"):
        run_study(StudySpec(spec.mission_path, 2, spec.sweeps, spec.seed), out, workers=1)


@pytest.mark.slow
def test_the_required_swarm_size_matches_the_k_out_of_n_closed_form(tmp_path) -> None:
    """Robots swim 600 m (1200 s at 0.5 m/s) and need 20 s more to the zone; only random failure
    acts, so each reaches the zone with p = exp(-T / MTBF), and the landing needs k = 2 of them:
    P(success) = P(Binomial(n, p) >= 2). Each point's Wilson 99.9% interval must hold the closed
    form, and the required size must lie where the closed form puts it."""
    mtbf_h = 1.5
    path = _mission(
        tmp_path,
        "kofn",
        launch={"platform": "by_hand", "points": ["launch_1"], "offshore_m": 600, "interval_s": 0},
        phases={  # just long enough: the run ends soon after the landing
            "sea_transit": {"time_limit_s": 1300},
            "surf_crossing": {"time_limit_s": 100},
            "beach_operations": {"time_limit_s": 60},
            "return_to_sea": {"enabled": False},
        },
        hazards={**QUIET, "attrition": {"mtbf_h": mtbf_h}},
    )
    spec = StudySpec(str(path), runs=30, sweeps=parse_sweeps(["swarm.count=2:5:1"]), seed=1, target=0.7)
    table, summary = run_study(spec, tmp_path / "out", workers=2)
    times = [t for ev in table.column("completed_s").to_pylist() if (t := ev) is not None]
    exposure = sum(times) / len(times)  # release to the landing's completion, mean over runs
    p = math.exp(-exposure / (mtbf_h * 3600))
    truth = {n: k_out_of_n(n, 2, p) for n in (2, 3, 4, 5)}
    for pt in summary["points"]:
        n = pt["params"]["swarm.count"]
        low, high = wilson_interval(pt["successes"], pt["runs"], 0.999)
        assert low <= truth[n] <= high, (n, pt["successes"], truth[n])
    smallest = min(n for n, v in truth.items() if v >= spec.target)
    required = summary["required"]["value"]
    assert required is not None and smallest <= required <= 5, (required, truth)


def test_sweeps_parse_lists_and_ranges() -> None:
    assert parse_sweep("swarm.count=10:60:10").values == (10, 20, 30, 40, 50, 60)
    assert parse_sweep("hazards.surf.wave_height_m=0.5,1,2").values == (0.5, 1, 2)
    assert parse_sweep("hazards.surf.wave_height_m=0.5:1.5:0.5").values == (0.5, 1.0, 1.5)
    grid = points(parse_sweeps(["swarm.count=2,3", "hazards.surf.wave_height_m=0.5,1"]))
    assert grid == [
        {"swarm.count": 2, "hazards.surf.wave_height_m": 0.5},
        {"swarm.count": 2, "hazards.surf.wave_height_m": 1},
        {"swarm.count": 3, "hazards.surf.wave_height_m": 0.5},
        {"swarm.count": 3, "hazards.surf.wave_height_m": 1},
    ]


@pytest.mark.parametrize(
    ("sweep", "names"),
    [
        ("swarm.cont=1,2", "swarm.cont"),
        ("swarm.count=-1,2", "swarm.count"),
        ("swarm.count=5:1:1", "--sweep swarm.count"),
        ("swarm.count=1:5", "--sweep swarm.count"),
        ("swarm.count", "--sweep"),
        ("hazards.surf.wave_height_m=1,big", "hazards.surf.wave_height_m"),
        ("swarm.count=2,3.5", "swarm.count: found 3.5, expected a whole number"),  # as --set says
        ("swarm.count=3,3.0", "swarm.count: found '3,3.0', expected values without repeats"),
        ("swarm.count=1", "tasks[0].robots_per_zone: found 2, expected at most 1"),  # no point can run
    ],
)
def test_a_bad_sweep_is_one_line_naming_the_key(tiny, tmp_path, sweep, names) -> None:
    out = tmp_path / "bad"
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(["study", str(tiny), "--runs", "2", "--sweep", sweep, "--out", str(out)])
    assert code == 2
    lines = err.getvalue().strip().splitlines()
    assert len(lines) == 1 and names in lines[0] and "Traceback" not in err.getvalue()
    assert not out.exists()  # nothing written


def test_an_integer_key_swept_with_a_whole_float_is_swept_over_integers(tiny, tmp_path) -> None:
    """`--sweep swarm.count=2,3.0` swept the count over 2 and the float 3.0: a float column, 3.0
    in study.json and summary.json. Each value is read as the schema reads one `--set`."""
    out = tmp_path / "study"
    with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
        code = main(["study", str(tiny), "--runs", "1", "--sweep", "swarm.count=2,3.0", "--workers", "1",
                     "--out", str(out)])  # fmt: skip
    assert code == 0
    for name in ("study.json", "summary.json"):
        counts = json.loads((out / name).read_text())["sweeps"]["swarm.count"]
        assert counts == [2, 3] and all(type(c) is int for c in counts), name
    params = [p["params"]["swarm.count"] for p in json.loads((out / "summary.json").read_text())["points"]]
    assert all(type(c) is int for c in params)
    assert pq.read_schema(out / "results.parquet").field("swarm.count").type == pa.int64()


def test_any_value_a_mission_takes_can_be_swept_and_held(tiny, tmp_path) -> None:
    """Found by fuzzing: a list (`launch.points=[launch_1],[launch_2]`) crashed the workers' plan
    cache (a list has no hash), a null beside a number the table (a text column given an int),
    and a seed from 2**63 on the table's int64 column, each after study.json was written."""
    out = tmp_path / "study"
    argv = ["study", str(tiny), "--runs", "1", "--workers", "1", "--out", str(out)]
    argv += ["--sweep", "launch.points=[launch_1],[launch_2]", "--sweep", "hazards.comms.cutoff_s=null,100"]
    argv += ["--set", f"seed={2**63}"]
    with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
        assert main(argv) == 0
    table = pq.read_table(out / "results.parquet")
    assert table.schema.field("launch.points").type == pa.string()
    assert table.schema.field("hazards.comms.cutoff_s").type == pa.int64()
    assert table.schema.field("mission.seed").type == pa.uint64()
    rows = table.select(["launch.points", "hazards.comms.cutoff_s", "mission.seed"]).to_pylist()
    assert [tuple(r.values()) for r in rows] == [
        ('["launch_1"]', None, 2**63),
        ('["launch_1"]', 100, 2**63),
        ('["launch_2"]', None, 2**63),
        ('["launch_2"]', 100, 2**63),
    ]
    points = json.loads((out / "summary.json").read_text())["points"]
    assert [p["params"]["launch.points"] for p in points] == [["launch_1"]] * 2 + [["launch_2"]] * 2
    assert (out / "report.html").is_file()


def test_an_infeasible_point_is_reported_and_the_others_run(tiny, tmp_path) -> None:
    """`swarm study missions/recon.yaml --sweep swarm.count=2,8` stopped on 2 (its stations hold 5):
    a point whose values do not fit together runs no run, says why in summary.json and the point
    table, and is not among the sizes the answer can be; the rest of the sweep runs."""
    out = tmp_path / "study"
    printed = io.StringIO()
    argv = ["study", str(tiny), "--runs", "3", "--sweep", "swarm.count=1,3", "--target", "0.2"]
    with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(printed):
        assert main([*argv, "--workers", "1", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    one, three = summary["points"]
    assert "tasks[0].robots_per_zone: found 2, expected at most 1" in one["infeasible"]
    assert one["runs"] == 0 and one["success_rate"] is None and one["lost_mean"] is None
    assert three["infeasible"] is None and three["runs"] == 3
    assert summary["runs"] == 3
    table = pq.read_table(out / "results.parquet")
    assert table.num_rows == 3 and set(table.column("swarm.count").to_pylist()) == {3}
    required = summary["required"]
    low, _ = wilson_interval(three["successes"], 3, 0.95)
    assert required["value"] == (3 if low >= 0.2 else None)  # never the infeasible 1
    assert "not run, infeasible: swarm.count = 1 (tasks[0].robots_per_zone" in required["note"]
    text = printed.getvalue()
    assert "infeasible" in text and "expected at most 1" in text
    # the report reads it back, the reason in the point table's last column
    md = tmp_path / "report.md"
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["report", str(out), "-o", str(md)]) == 0
    rows = [line for line in md.read_text().splitlines() if line.startswith("| 1 |")]
    assert len(rows) == 1 and "expected at most 1" in rows[0]


def test_a_column_holds_its_sweep_s_values_as_arrow_types_them() -> None:
    assert param_type([1, None, 3]) == pa.int64()
    assert param_type([2**63, 0]) == pa.uint64()
    assert param_type([-1, 2**63]) == pa.string()  # neither int64 nor uint64 holds both
    assert param_type([1, 2.5]) == pa.float64()
    assert param_type([True, None]) == pa.bool_()
    assert param_type([1, "a"]) == param_type([None]) == param_type([[1], [2]]) == pa.string()
    assert [param_cell(v, pa.string()) for v in (1, "a", None, ["x"], {"k": 0.5})] == [
        "1",
        "a",
        None,
        '["x"]',
        '{"k": 0.5}',
    ]
    assert param_cell(3, pa.int64()) == 3


def test_a_bad_batch_is_one_line_and_a_good_one_runs_in_batches(tiny, tmp_path) -> None:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(["study", str(tiny), "--runs", "2", "--batch", "0", "--out", str(tmp_path / "bad")])
    assert code == 2 and "--batch" in err.getvalue() and len(err.getvalue().strip().splitlines()) == 1
    out = tmp_path / "good"
    with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
        code = main(["study", str(tiny), "--runs", "2", "--batch", "2", "--workers", "1", "--out", str(out)])
    assert code == 0 and pq.read_table(out / "results.parquet").num_rows == 2


@pytest.mark.slow
def test_a_failed_row_replays_with_swarm_simulate(tmp_path, capsys) -> None:
    """`swarm simulate MISSION --seed <row seed> --set <row's swept values>` reproduces the run of a
    study row: the same outcome and the same losses, cause, phase and time. Immobilization per
    kilometre makes the losses depend on the routes driven, so the replay must plan as the study did."""
    hazards = {**QUIET, "attrition": {"mtbf_h": 0.2}, "immobilization": {"per_km": 20.0}}
    mission = _mission(tmp_path, "replay", hazards=hazards, seed=5)
    spec = StudySpec(str(mission), runs=6, sweeps=parse_sweeps(["swarm.count=3"]), seed=11)
    table, _ = run_study(spec, tmp_path / "study", workers=1)
    rows = [r for r in table.to_pylist() if not r["success"] and r["lost"] > 0]
    assert len(rows) >= 2, "the study must have failed runs with losses to replay"
    for row in rows[:2]:
        out = tmp_path / f"replay-{row['point']}-{row['run']}"
        args = ["simulate", str(mission), "--seed", str(row["seed"]), "--workers", "1", "--out", str(out)]
        assert main([*args, "--set", f"swarm.count={row['swarm.count']}"]) == 0
        outcome = yaml.safe_load((out / "outcome.json").read_text())
        assert outcome["success"] == row["success"]
        assert outcome["lost"] == row["lost"]
        replayed = sorted((x["cause"], x["phase"], round(x["t_s"], 3)) for x in _losses(out))
        assert replayed == sorted((x["cause"], x["phase"], round(x["t_s"], 3)) for x in row["losses"])
    capsys.readouterr()


def _losses(folder: Path) -> list[dict]:
    events = [yaml.safe_load(line) for line in (folder / "events.jsonl").read_text().splitlines()]
    return [e for e in events if e["kind"] == "loss"]


@pytest.mark.slow
def test_twice_the_robots_never_succeed_less(tmp_path) -> None:
    """A search of the small beach under random failures: with twice the robots the plan searches
    with more robots and keeps more in reserve, so P(success) must not drop (one-sided, 2.5 sigma)."""
    search = {
        "type": "search",
        "area": "search_beach",
        "sensor": {"model": "inverse_cube", "sweep_width_m": 4.0},
        "mark": False,
    }
    mission = _mission(
        tmp_path,
        "monotone",
        tasks=[search],
        success={"min_detection_fraction": 0.85},
        phases={
            "sea_transit": {"time_limit_s": 300},
            "surf_crossing": {"time_limit_s": 300},
            "beach_operations": {"time_limit_s": 420},
            "return_to_sea": {"enabled": False},
        },
        hazards={**QUIET, "attrition": {"mtbf_h": 0.25}, "mines": {"count": 20, "trigger_probability": 0.0}},
    )
    spec = StudySpec(str(mission), runs=24, sweeps=parse_sweeps(["swarm.count=3,6"]), seed=3)
    _, summary = run_study(spec, tmp_path / "study", workers=2)
    (few, many) = summary["points"]
    p1, p2 = few["success_rate"], many["success_rate"]
    se = math.sqrt((p1 * (1 - p1) + p2 * (1 - p2)) / 24 + 1e-12)
    assert p2 >= p1 - 2.5 * se, (p1, p2)
    assert p2 > 0.5, "the bigger swarm must mostly succeed for the comparison to mean anything"


@pytest.mark.slow
def test_plan_evaluate_puts_the_simulations_beside_the_plan(tmp_path, capsys) -> None:
    """`swarm plan --evaluate N`: N runs of the plan through the study machinery, P(success) with its
    Wilson interval in evaluation.json and the report, and, when the target is missed, a quick sweep
    that suggests a size."""
    mission = _mission(tmp_path, "evaluated", **{"swarm": {"count": 2}})
    out = tmp_path / "plan"
    args = ["plan", str(mission), "--evaluate", "6", "--target", "0.99", "--workers", "1", "--out", str(out)]
    assert main(args) == 0
    printed = capsys.readouterr().out
    ev = yaml.safe_load((out / "evaluation.json").read_text())
    assert ev["runs"] == 6 and len(ev["seeds"]) == 6
    low, high = wilson_interval(ev["successes"], 6, 0.95)
    assert (ev["wilson_low"], ev["wilson_high"]) == pytest.approx((low, high))
    assert ev["lost"]["mean"] == pytest.approx(sum(ev["lost_values"]) / 6)
    # a lower bound of at most 0.61 with 6 runs misses 0.99: the quick sweep tried 3 and 4 robots
    assert [s["count"] for s in ev["sizes"]] == [3, 4]
    assert "in simulation" in printed and "P(success)" in printed
    html = (out / "report.html").read_text()
    assert "The plan in simulation" in html and html.count("data:image/png;base64,") >= 2
    # the report rebuilt from the folder says the same
    assert main(["report", str(out), "--format", "md", "-o", str(tmp_path / "again.md")]) == 0
    assert "The plan in simulation" in (tmp_path / "again.md").read_text()


@pytest.mark.slow
def test_plan_evaluate_prints_the_detection_beside_the_plan_s(tmp_path, capsys) -> None:
    """A search's promise is its detection: `swarm plan --evaluate N` prints the simulated runs'
    mean detection beside the plan's expected detection after its losses (plan.json's budget)."""
    search = {
        "type": "search",
        "area": "search_beach",
        "sensor": {"model": "inverse_cube", "sweep_width_m": 4.0},
    }
    mission = _mission(
        tmp_path,
        "searched",
        tasks=[search],
        success={"min_detection_fraction": 0.5},
        hazards={**QUIET, "attrition": {"mtbf_h": 0.25}, "mines": {"count": 20, "trigger_probability": 0.0}},
    )
    out = tmp_path / "plan"
    assert main(["plan", str(mission), "--evaluate", "3", "--workers", "1", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    ev = json.loads((out / "evaluation.json").read_text())
    found = ev["detection"]["mean"]
    (search,) = json.loads((out / "plan.json").read_text())["budget"]["search"].values()
    planned = search["expected_detection_after_losses"]
    # the runs' Student t interval of the mean, and where the plan's expectation lies against it
    values = np.asarray(ev["detection_values"])
    sem = values.std(ddof=1) / np.sqrt(len(values))
    low, high = t.interval(0.95, len(values) - 1, loc=values.mean(), scale=sem) if sem else (found, found)
    low, high = max(low, 0.0), min(high, 1.0)  # a share's interval stops at 0 and 1
    said = "agrees" if low <= planned <= high else ("optimistic" if planned > high else "conservative")
    line = next(x for x in printed.splitlines() if "in simulation" in x)
    assert (
        f"detection {found:.1%} a run (95% interval {low:.1%} to {high:.1%}; plan {planned:.1%}: {said})"
        in line
    )
    # judged by its mines found alone: the plan's chance of success is its search's after losses,
    # against the runs' Wilson interval
    chance = ev["planned_success"]
    assert chance == pytest.approx(search["p_criterion_met_after_losses"], abs=5e-4)  # plan.json: 3 places
    low, high = wilson_interval(ev["successes"], 3, 0.95)
    said = "agrees" if low <= chance <= high else ("optimistic" if chance > high else "conservative")
    assert f"({low:.2f} to {high:.2f}; plan {chance:.2f}: {said}), target 0.9" in line


def test_planning_again_into_a_folder_replaces_its_evaluation(tmp_path, capsys) -> None:
    """Another plan into the same folder: its evaluation is its own (a refusal to resume the old
    plan's runs came after the new plan.json, and a report then mixed the two); without
    --evaluate the old evaluation goes; the same plan evaluated again resumes its runs."""
    mission = _mission(tmp_path, "again", **{"swarm": {"count": 2}})
    out = tmp_path / "plan"

    def plan(*more: str) -> dict | None:
        assert main(["plan", str(mission), *more, "--workers", "1", "--out", str(out)]) == 0
        capsys.readouterr()
        path = out / "evaluation.json"
        return json.loads(path.read_text()) if path.exists() else None

    first = plan("--evaluate", "3")
    parts = sorted((out / "evaluation" / "plan" / "parts").iterdir())
    assert plan("--evaluate", "3") == first  # resumed: the same runs, the parts kept
    assert sorted((out / "evaluation" / "plan" / "parts").iterdir()) == parts
    again = plan("--set", "swarm.count=3", "--evaluate", "3")
    assert len(json.loads((out / "plan.json").read_text())["robots"]) == 3
    held = json.loads((out / "evaluation" / "plan" / "study.json").read_text())["sweeps"]
    assert held["swarm.count"] == [3] and again["runs"] == 3
    assert plan("--set", "swarm.count=2") is None
    assert not (out / "evaluation").exists()


@pytest.mark.slow
def test_two_studies_into_one_folder_one_proceeds_and_no_row_is_doubled(tmp_path) -> None:
    """Issue 15: two `swarm study` at once into one --out used to leave 5 rows for a 3-run study."""
    out = tmp_path / "cc"
    argv = ["swarm", "study", str(REPO / "missions" / "landing.yaml"), "--runs", "3", "--workers", "1",
            "--out", str(out)]  # fmt: skip
    code = "import sys; from swarm.cli import main; sys.exit(main(sys.argv[2:]))"
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", code, *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        for _ in range(2)
    ]
    results = [(p, *p.communicate(timeout=300)) for p in procs]
    assert sorted(p.returncode for p, _, _ in results) == [0, 2]
    (winner, _, _), (_, _, err) = sorted(results, key=lambda r: r[0].returncode)
    assert err.strip().splitlines() == [
        f"swarm: error: {out}: in use by pid {winner.pid} ({' '.join(argv)}); "
        "wait for it to finish, or write to another folder"
    ]
    table = pq.read_table(out / "results.parquet")
    keys = list(zip(table.column("point").to_pylist(), table.column("run").to_pylist(), strict=True))
    assert keys == [(0, 0), (0, 1), (0, 2)]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["runs"] == 3 and summary["points"][0]["runs"] == 3


@pytest.mark.slow
def test_a_full_disk_stops_the_study_in_one_line_and_keeps_only_whole_parts(
    reference, tmp_path, monkeypatch
) -> None:
    """The disk fills while the third chunk is written: one line, two whole parts, no temporary
    files; once there is room again the same study finishes with the uninterrupted table."""
    import errno

    from swarm.errors import OutputError
    from swarm.studies import store

    spec, expected = reference
    out = tmp_path / "full"
    write_table = store.pq.write_table
    calls = []

    def filling(table, where, *args, **kwargs):
        calls.append(where)
        if len(calls) >= 3:
            Path(where).write_bytes(b"PAR1 half a part")  # what reached the disk before it filled
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return write_table(table, where, *args, **kwargs)

    monkeypatch.setattr(store.pq, "write_table", filling)
    with pytest.raises(OutputError) as caught:
        run_study(spec, out, workers=1)
    message = str(caught.value)
    assert "\n" not in message and "No space left on device" in message
    assert sorted(p.name for p in (out / "parts").iterdir()) == ["part-000000.parquet", "part-000001.parquet"]
    assert pq.read_table(out / "parts").num_rows == 4  # chunks of 2 runs, each whole
    assert not (out / "results.parquet").exists()
    monkeypatch.setattr(store.pq, "write_table", write_table)
    table, summary = run_study(spec, out, workers=1)
    assert _stable(table).equals(_stable(expected))
    assert summary["runs"] == 10


def _descendants(pid: int) -> set[int]:
    """Processes below `pid` (from /proc): only those this test started may be killed."""
    parent: dict[int, int] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        with contextlib.suppress(OSError, ValueError, IndexError):
            parent[int(stat.parent.name)] = int(stat.read_text().rsplit(")", 1)[1].split()[1])
    out: set[int] = set()
    frontier = {pid}
    while frontier:
        frontier = {c for c, p in parent.items() if p in frontier} - out
        out |= frontier
    return out


@pytest.mark.slow
@RAY_GROUP
def test_a_ray_worker_killed_mid_study_is_retried_to_the_same_table(reference, local_ray, tmp_path) -> None:
    """kill -9 the Ray worker running a run: Ray runs it again and the table is the same."""
    import threading

    spec, expected = reference
    killed: list[int] = []
    stop = threading.Event()

    def kill_one_worker() -> None:
        while not stop.is_set() and not killed:
            for pid in _descendants(os.getpid()):
                with contextlib.suppress(OSError):
                    if Path(f"/proc/{pid}/cmdline").read_bytes().startswith(b"ray::run_batch"):
                        os.kill(pid, signal.SIGKILL)
                        killed.append(pid)
                        break
            time.sleep(0.02)

    killer = threading.Thread(target=kill_one_worker, daemon=True)
    killer.start()
    try:
        table, summary = run_study(spec, tmp_path / "ray", backend="ray", workers=2)
    finally:
        stop.set()
        killer.join()
    assert killed, "no Ray worker was running a run to kill"
    assert summary["runs"] == 10
    assert _stable(table).equals(_stable(expected))


def test_each_point_carries_its_plan_s_expected_losses(tmp_path) -> None:
    """Every row of a point holds the expected losses of the plan its runs followed (the plan the
    study makes for that point, with the mission's seed), and the summary sets it beside the mean
    lost; with the hazards off there is none."""
    from swarm.mission.load import load_mission
    from swarm.mission.plan import plan_mission

    path = str(REPO / "missions" / "landing.yaml")
    spec = StudySpec(
        path, runs=2, sweeps=parse_sweeps(["swarm.count=10,12", "hazards.enabled=true,false"]), seed=1
    )
    table, summary = run_study(spec, tmp_path / "study", workers=1)
    cols = table.to_pydict()
    for p, point in enumerate(summary["points"]):
        params = point["params"]
        rows = [cols["planned_lost"][i] for i in range(table.num_rows) if cols["point"][i] == p]
        mine = [i for i in range(table.num_rows) if cols["point"][i] == p]
        by_cause = [[cols[f"planned_lost_{c}"][i] for c in CAUSES] for i in mine]
        if not params["hazards.enabled"]:
            assert rows == [None, None] and point["planned_lost"] is None
            assert by_cause == [[None] * len(CAUSES)] * 2 and point["lost_by_cause"] == []
            continue
        m = load_mission(path, params)
        plan = plan_mission(m, seed=m.seed, workers=1)
        expected = plan.budget["expected_lost"]
        assert rows == [pytest.approx(expected)] * 2
        assert point["planned_lost"] == pytest.approx(expected)
        # the causes' parts add up to the total, each the plan's own over its phases
        assert [sum(r) for r in by_cause] == [pytest.approx(expected)] * 2
        failures = sum(c.get("failure", 0.0) for c in plan.budget["expected_losses"].values())
        assert by_cause[0][CAUSES.index("failure")] == pytest.approx(failures)
        planned = {c["cause"]: c["planned"] for c in point["lost_by_cause"]}
        assert set(planned) >= {c for c in CAUSES if by_cause[0][CAUSES.index(c)] > 0}
    # landing has no search: no plan's detection to set beside the runs'
    assert cols["planned_detection"] == [None] * table.num_rows
    # its spares take a lost landing robot's zone: the plan's takeovers beside the runs'
    for p, point in enumerate(summary["points"]):
        mine = [i for i in range(table.num_rows) if cols["point"][i] == p]
        planned = [cols["planned_takeovers"][i] for i in mine]
        if not point["params"]["hazards.enabled"]:
            assert planned == [None, None] and point["planned_takeovers"] is None
        else:
            m = load_mission(path, point["params"])
            expected = plan_mission(m, seed=m.seed, workers=1).expected_takeovers
            assert planned == [pytest.approx(expected)] * 2 and expected > 0
        assert point["takeovers_mean"] == pytest.approx(np.mean([cols["takeovers"][i] for i in mine]))


def test_a_row_counts_the_stations_its_spares_took_over(tmp_path) -> None:
    """relay: a lost relay's place goes to a spare, at most one place each, each after a loss of
    a robot holding one (the relay, or a spare that had taken it); beside it, the plan's."""
    from swarm.mission.load import load_mission
    from swarm.mission.plan import plan_mission
    from swarm.studies.runner import RunTask, run_task

    path = REPO / "missions" / "relay.yaml"
    row = run_task(RunTask(str(path), 0, 0, (), 3))
    ashore = [x for x in row["losses"] if x["phase"] != "returning"]
    assert 1 <= row["takeovers"] <= min(8, len(ashore))
    m = load_mission(path)
    planned = plan_mission(m, seed=m.seed, workers=1).expected_takeovers
    assert row["planned_takeovers"] == pytest.approx(planned)


def test_a_held_key_is_no_sweep_and_the_answer_says_what_was_held(tiny, tmp_path, capsys) -> None:
    """`--set` holds a key at one value: the study answers with the success rate at it, naming it,
    not with "the smallest swept value" of a one-point sweep (nor advice to sweep it larger)."""
    out = tmp_path / "held"
    args = ["study", str(tiny), "--runs", "3", "--workers", "1", "--out", str(out)]
    assert main([*args, "--set", "hazards.attrition.mtbf_h=0.01", "--set", "swarm.count=2"]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    summary = json.loads((out / "summary.json").read_text())
    point = summary["points"][0]
    assert summary["required"] is None
    assert first.startswith(
        f"tiny with hazards.attrition.mtbf_h = 0.01, 2 robots: P(success) = {point['success_rate']:.3f} "
        f"over 3 runs (95% Wilson interval {point['wilson_low']:.3f} to {point['wilson_high']:.3f}): "
    )
    assert "swept" not in first


def test_the_mission_seed_held_by_a_study_has_its_own_column(tiny, tmp_path) -> None:
    """`--set seed=5` (and `plan --seed 1 --evaluate N`, which holds it) once wrote the mission's
    seed over each run's in the column 'seed', and the table's two 'seed' fields failed to read."""
    spec = StudySpec(str(tiny), runs=3, sweeps=parse_sweeps(["seed=5"]), seed=7)
    table, summary = run_study(spec, tmp_path / "s", workers=1)
    assert table.column("mission.seed").to_pylist() == [5, 5, 5]
    assert table.column("seed").to_pylist() == [run_seed(7, 0, r) for r in range(3)]
    assert summary["points"][0]["params"] == {"seed": 5}


def test_plan_with_a_seed_and_an_evaluation(tiny, tmp_path, capsys) -> None:
    """README's `swarm plan M --seed N --evaluate R` exited 2 after every run of the evaluation."""
    out = tmp_path / "p"
    assert (
        main(["plan", str(tiny), "--seed", "1", "--evaluate", "2", "--workers", "1", "--out", str(out)]) == 0
    )
    evaluation = json.loads((out / "evaluation.json").read_text())
    assert evaluation["runs"] == 2
    assert "in simulation" in capsys.readouterr().out


def test_the_summary_keeps_the_sweeps_in_their_order(tiny, tmp_path) -> None:
    """A report rebuilt from summary.json lists the swept keys as the command line gave them (a
    sorted summary put hazards.* before swarm.count)."""
    from swarm.report.study_figures import swept_keys

    sweeps = parse_sweeps(["swarm.count=2,3", "hazards.attrition.mtbf_h=1,2"])
    run_study(StudySpec(str(tiny), runs=1, sweeps=sweeps, seed=3), tmp_path / "s", workers=1)
    summary = json.loads((tmp_path / "s" / "summary.json").read_text())
    assert swept_keys(summary) == ["swarm.count", "hazards.attrition.mtbf_h"]


@pytest.mark.slow
def test_a_row_counts_the_mines_and_how_every_robot_ended(tmp_path) -> None:
    """8 robots search the small beach, mark what they find, clear it together and go back to sea:
    the row's mines found are its detection's share of the mines laid, each robot expended cleared
    one mine, and every robot launched is lost, expended, recovered or stopped at the time limit."""
    from swarm.studies.runner import RunTask, run_task

    search = {
        "type": "search",
        "area": "search_beach",
        "sensor": {"model": "cookie_cutter", "sweep_width_m": 4.0},
        "mark": True,
        "clearance": {"at_s": 700.0, "standoff_m": 8.0},
    }
    phases = {
        "sea_transit": {"time_limit_s": 300},
        "surf_crossing": {"time_limit_s": 300},
        "beach_operations": {"time_limit_s": 600},
        "return_to_sea": {"enabled": True, "time_limit_s": 600},
    }
    path = _mission(
        tmp_path,
        "cleared",
        swarm={"count": 8},
        tasks=[search],
        phases=phases,
        hazards={**QUIET, "mines": {"count": 4, "trigger_probability": 0.0}},
    )
    row = run_task(RunTask(str(path), 0, 0, (), 2))
    assert row["mines"] == 4
    assert row["mines_detected"] == round(row["value_detection"] * 4)
    assert row["expended"] == row["mines_cleared"] >= 1, (
        "the search must mark mines for this to mean anything"
    )
    assert row["recovered"] >= 1
    assert row["lost"] + row["expended"] + row["recovered"] <= row["robots"] == 8


def test_a_plan_s_detection_weighs_its_searches_by_their_mines() -> None:
    """`MissionPlan.expected_detection`: each search's detection after losses (before them where
    the hazards are off), weighted by the mines it expects, as a run's detection criterion counts
    the mines of every search together; equal weights where no mines are expected, None without a
    search."""
    from types import SimpleNamespace

    from swarm.mission.plan import MissionPlan

    def plan(*searches: tuple[str, float, float | None, float]) -> SimpleNamespace:
        return SimpleNamespace(
            search=[SimpleNamespace(task=t, design={"mines_expected": m}) for t, _, _, m in searches],
            budget={
                "search": {
                    t: {"expected_detection": d, "expected_detection_after_losses": a}
                    for t, d, a, _ in searches
                }
            },
        )

    detection = MissionPlan.expected_detection.fget
    assert detection(plan(("a", 0.9, 0.8, 30.0), ("b", 0.99, 0.95, 10.0))) == pytest.approx(
        (0.8 * 30 + 0.95 * 10) / 40
    )
    assert detection(plan(("a", 0.9, None, 0.0), ("b", 0.7, None, 0.0))) == pytest.approx(0.8)
    assert detection(SimpleNamespace(search=[], budget={})) is None
