"""A run that would not fit in memory is refused with the estimate before anything is allocated."""

from __future__ import annotations

import tracemalloc
from pathlib import Path

import pytest

import swarm.sim.memory as memory
from swarm.cli import main
from swarm.errors import InputError
from swarm.mission import load_mission
from swarm.studies.sweep import check_points, parse_sweeps

REPO = Path(__file__).resolve().parents[2]
LANDING = REPO / "missions" / "landing.yaml"


def test_the_estimate_grows_with_the_map_the_swarm_and_the_mission_time() -> None:
    base = memory.estimate_bytes(10_000, 10, 3600.0)
    assert memory.estimate_bytes(20_000, 10, 3600.0) - base == 10_000 * (
        memory.PLAN_BYTES_PER_CELL + memory.SIM_BYTES_PER_CELL
    )
    per_robot = memory.estimate_bytes(10_000, 11, 3600.0) - base
    assert per_robot == memory.BYTES_PER_ROBOT + (3600 // 2 + 2) * memory.BYTES_PER_ROBOT_SAMPLE
    assert memory.estimate_bytes(10_000, 10, 3600.0, simulate=False) < base
    # the example: 10,000 robots on a 20 km x 200 m beach of 1 m cells, a 9600 s mission
    assert memory.estimate_bytes(20_000 * 200, 10_000, 9600.0) > 8e9


@pytest.mark.slow
def test_the_planning_estimate_is_not_an_underestimate() -> None:
    """Measured: the peak Python/numpy allocation of planning the landing mission (tracemalloc)."""
    from swarm.mission.plan import plan_mission

    mission = load_mission(LANDING)
    tracemalloc.start()
    try:
        plan_mission(mission, seed=0, workers=1)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    cells = mission.beach_map.terrain.size
    assert peak <= memory.estimate_bytes(cells, mission.swarm.count, 0.0, simulate=False)


@pytest.mark.parametrize("command", ["simulate", "plan"])
def test_a_run_too_big_for_the_machine_is_one_line_and_writes_nothing(
    command, tmp_path, monkeypatch, capsys
) -> None:
    """1000 robots (the schema's cap) on test_small with 50 MB free: refused before planning."""
    monkeypatch.setattr(memory, "available_bytes", lambda: 50_000_000)
    out = tmp_path / "out"
    argv = [command, str(LANDING), "--set", "swarm.count=1000", "--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    mission = load_mission(LANDING, {"swarm.count": 1000})
    need = memory.estimate_bytes(9600, 1000, memory.mission_time_s(mission), simulate=command == "simulate")
    assert err == (
        f"swarm: error: {LANDING}: swarm.count: found '1000 robots on test_small (120 x 80 m, 9,600 cells)', "
        f"expected a run that fits in memory: it needs about {need / 1e6:.3g} MB, 50 MB is available\n"
    )
    assert not out.exists()


def test_a_study_counts_the_runs_it_starts_at_once(monkeypatch) -> None:
    mission = load_mission(LANDING, {"swarm.count": 40})
    one = memory.check_fits(mission)
    monkeypatch.setattr(memory, "available_bytes", lambda: int(2.5 * one))
    sweeps = parse_sweeps(["swarm.count=40"])
    check_points(LANDING, sweeps, at_once=2)
    with pytest.raises(InputError) as err:
        check_points(LANDING, sweeps, at_once=3)
    assert "x 3 runs at once (fewer --workers would fit)" in str(err.value)


def test_a_run_too_long_to_record_blames_the_time_limits(tmp_path, capsys) -> None:
    """12 robots fit; their tracks over 1e12 s do not: the message names the time, not the count."""
    out = tmp_path / "out"
    argv = ["simulate", str(LANDING), "--set", "phases.beach_operations.time_limit_s=1e12", "--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"swarm: error: {LANDING}: phases (time limits): found '1e+12 s of mission time")
    assert err.count("\n") == 1
    assert not out.exists()
