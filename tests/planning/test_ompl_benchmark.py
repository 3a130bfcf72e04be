"""OMPL's benchmark log for a map and profiles: standard format, readable by ompl_benchmark_statistics."""

from __future__ import annotations

import sqlite3
import subprocess
import sys
from dataclasses import replace

import pytest
from conftest import GOAL, OPTIMAL, ROADMAP, START

from swarm.errors import InputError
from swarm.planning.benchmark import (
    _run_benchmark,
    choose_objective,
    default_query,
    export_benchmark,
    summarize_log,
)
from swarm.planning.paths import _objective_value, _states_xy
from swarm.planning.profiles import DEFAULT_PROFILE


def test_benchmark_log_is_ompls_format(wall_costmap, tmp_path):
    out = tmp_path / "bench.log"
    export = export_benchmark(
        wall_costmap, [DEFAULT_PROFILE, OPTIMAL], out, start=START, goal=GOAL, runs=2, time_s=0.2
    )
    assert out.exists() and not list(tmp_path.glob(".bench.log.tmp*"))
    text = out.read_text()
    assert text.startswith("OMPL version")
    assert "objective TEXT = terrain_cost" in text
    assert [p.name for p in export.planners] == ["geometric_fast", "geometric_optimal-test"]
    assert all(p.runs == 2 and p.solved == 2 for p in export.planners)
    # OMPL's own script turns it into the database Planner Arena reads
    db = tmp_path / "bench.db"
    done = subprocess.run(
        [sys.executable, "-m", "ompl.ompl_benchmark_statistics", str(out), "-d", str(db)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    con = sqlite3.connect(db)
    names = [r[0] for r in con.execute("SELECT name FROM plannerConfigs ORDER BY id")]
    runs = con.execute("SELECT COUNT(*) FROM runs").fetchone()[0]
    con.close()
    assert names == ["geometric_fast", "geometric_optimal-test"] and runs == 4


def test_default_query_spans_the_map(wall_costmap):
    start, goal = default_query(wall_costmap)
    assert start[0] < 2.0 and goal[0] > 28.0
    wall_costmap.check_endpoints(start, goal)


def test_objective_choice():
    optimal = OPTIMAL
    assert choose_objective([DEFAULT_PROFILE], None) == "length"
    assert choose_objective([optimal], None) == "terrain_cost"
    assert choose_objective([DEFAULT_PROFILE, optimal], None) == "terrain_cost"
    assert choose_objective([optimal, ROADMAP], None) == "length"  # OMPL's PRM: C++ objectives only
    assert choose_objective([DEFAULT_PROFILE], "terrain_cost") == "terrain_cost"
    with pytest.raises(InputError, match="use --objective length"):
        choose_objective([ROADMAP], "terrain_cost")


def test_duplicate_profile_names_are_refused(wall_costmap, tmp_path):
    with pytest.raises(InputError, match="profiles with different names"):
        export_benchmark(wall_costmap, [DEFAULT_PROFILE, replace(OPTIMAL, name="fast")], tmp_path / "b.log")


def test_benchmark_length_is_the_returned_paths_length(wall_costmap, tmp_path, monkeypatch):
    """With simplification on (the fast profile), each run returns the simplified path; the
    summary's mean length was the raw path's (`solution length`), longer by a tenth or more. Each run's path
    is caught after the run (OMPL's post-run event) and measured as a polyline."""
    import ompl.tools

    real, lengths = ompl.tools.Benchmark, []

    class Spy:
        """OMPL's Benchmark, measuring each run's solution path as the run ends."""

        def __init__(self, ss, name: str) -> None:
            self._bench = real(ss, name)
            self._bench.setPostRunEvent(
                lambda planner, run: lengths.append(
                    _objective_value(wall_costmap, "length", _states_xy(ss.getSolutionPath()))
                )
            )

        def __getattr__(self, name: str):
            return getattr(self._bench, name)

    monkeypatch.setattr(ompl.tools, "Benchmark", Spy)
    log = tmp_path / "bench.log"
    _run_benchmark(wall_costmap, (DEFAULT_PROFILE,), str(log), START, GOAL, "length", 1.0, 3, 0)
    (summary,) = summarize_log(log)
    assert summary.solved == 3 and len(lengths) == 3
    assert summary.mean_length_m == pytest.approx(sum(lengths) / 3, rel=1e-5)
