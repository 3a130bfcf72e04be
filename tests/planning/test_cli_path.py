"""`swarm path` end to end, in a subprocess: one path as JSON, bad points, the benchmark export."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from conftest import wall_map

from swarm.world.io import save_map

ROOT = Path(__file__).resolve().parents[2]


def swarm(*args: object, cwd: Path | None = None) -> subprocess.CompletedProcess:
    env = os.environ | {"MPLBACKEND": "Agg"}
    command = [sys.executable, "-m", "swarm.cli", *map(str, args)]
    return subprocess.run(command, capture_output=True, text=True, timeout=120, cwd=cwd, env=env)


@pytest.fixture(scope="module")
def maps(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("maps")
    save_map(wall_map(), folder / "wall.yaml")
    save_map(wall_map(gap=False), folder / "closed.yaml")
    return {"wall": folder / "wall.yaml", "closed": folder / "closed.yaml"}


@pytest.mark.slow
def test_one_path_as_json_same_seed_same_path(maps):
    first = swarm("path", maps["wall"], "--from", "3,4", "--to", "27,4", "--seed", "5", "--json")
    assert first.returncode == 0, first.stderr
    assert first.stderr == ""  # no OMPL logging, no leak reports at exit
    out = json.loads(first.stdout)
    for key in ("waypoints_m", "length_m", "cost", "solve_ms", "time_s", "planner", "profile", "status"):
        assert key in out
    assert out["waypoints_m"][0] == [3.0, 4.0] and out["waypoints_m"][-1] == [27.0, 4.0]
    assert out["profile"] == "fast" and out["planner"] == "RRTConnect"
    again = json.loads(
        swarm("path", maps["wall"], "--from", "3,4", "--to", "27,4", "--seed", "5", "--json").stdout
    )
    assert again["waypoints_m"] == out["waypoints_m"] and again["cost"] == out["cost"]


def test_text_output_with_a_profile(maps, tmp_path):
    profile = tmp_path / "quick.yaml"
    profile.write_text(
        yaml.safe_dump(
            {
                "planner": "BITstar",
                "params": {"samples_per_batch": 100},
                "objective": "terrain_cost",
                "budget": {"iterations": 1000},
            }
        )
    )
    done = swarm("path", maps["wall"], "--from", "3,4", "--to", "27,4", "--profile", profile)
    assert done.returncode == 0, done.stderr
    assert done.stderr == ""
    assert "path: " in done.stdout and "profile 'quick' (BITstar, objective terrain_cost" in done.stdout


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("--from", "15.2,6", "--to", "27,4"), "start (15.2, 6) is on boulder, impassable terrain"),
        (("--from", "3,4", "--to", "40,4"), "goal (40, 4) is outside the map 'wall'"),
        # a negative x is a point, not an option (argparse said "expected one argument")
        (("--from", "-1.5,4", "--to", "27,4"), "start (-1.5, 4) is outside the map 'wall'"),
        (("--from", "3,4", "--to", "-2,4"), "goal (-2, 4) is outside the map 'wall'"),
        (("--from", "6,16", "--to", "27,4"), "start (6, 16) is inside keep-out zone 'minefield'"),
        (("--from", "3,4", "--to", "14.8,5.25"), "goal (14.8, 5.25) is too close to boulder"),
        (("--from", "3;4", "--to", "27,4"), "--from: found '3;4', expected X,Y in metres"),
        (("--from", "3,4"), "--to: found 'nothing'"),
        (("--from", "3,4", "--to", "27,4", "-o", "x.log"), "--out: found 'x.log', expected --benchmark"),
    ],
)
def test_bad_points_one_line_exit_2(maps, args, message):
    done = swarm("path", maps["wall"], *args)
    assert done.returncode == 2
    assert done.stdout == ""
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("swarm: error: ")
    assert message in lines[0]


def test_no_path_exit_2(maps):
    done = swarm("path", maps["closed"], "--from", "3,4", "--to", "27,4")
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [
        "swarm: error: no path from start (3, 4) to goal (27, 4): impassable ground (rocks, steep slopes, "
        "water without traction) or keep-out zones separate them for a robot 0.60 m wide"
    ]


def test_bad_profile_exit_2(maps, tmp_path):
    profile = tmp_path / "bad.yaml"
    profile.write_text("planner: RRTConect\n")
    done = swarm("path", maps["wall"], "--from", "3,4", "--to", "27,4", "--profile", profile)
    assert done.returncode == 2
    assert f"{profile}: planner: found 'RRTConect', expected one of 'RRTConnect', 'RRT'," in done.stderr


@pytest.mark.slow
def test_benchmark_export(maps, tmp_path):
    quick = tmp_path / "quick.yaml"
    quick.write_text(
        yaml.safe_dump({"planner": "RRTstar", "objective": "length", "budget": {"iterations": 500}})
    )
    log = tmp_path / "bench.log"
    done = swarm(
        "path",
        maps["wall"],
        "--benchmark",
        f"{ROOT / 'planners' / 'fast.yaml'},{quick}",
        "--runs",
        "2",
        "--time",
        "0.2",
        "-o",
        log,
        "--json",
    )
    assert done.returncode == 0, done.stderr
    assert done.stderr == ""
    out = json.loads(done.stdout)
    assert out["objective"] == "length" and out["runs_per_planner"] == 2
    assert [p["name"] for p in out["planners"]] == ["geometric_fast", "geometric_quick"]
    assert log.read_text().startswith("OMPL version")
    bad = swarm(
        "path", maps["wall"], "--benchmark", ROOT / "planners" / "fast.yaml", "-o", tmp_path / "b.txt"
    )
    assert bad.returncode == 2 and "a file name ending in .log" in bad.stderr
