"""A surveillance dwell or beacon hold must fit the time robots have at the point: the loader refuses
what robots placed on the beach cannot reach in time at wheel speed, and the plan holds each point
to the arrivals it planned."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from swarm.errors import InputError
from swarm.mission import load_mission
from swarm.mission.plan import plan_json, plan_mission
from swarm.report.plan_report import plan_data

REPO = Path(__file__).resolve().parents[2]
RECON = REPO / "missions" / "recon.yaml"
LOOKOUT = (83.5, 62.5)  # test_small's dune_lookout
LAUNCHES = ((45.0, 56.0), (95.0, 56.0))  # recon's


def _drive_s(point, speed: float = 0.6) -> float:
    """The straight drive from recon's nearest launch point to within 3 m of `point`."""
    return (min(math.dist(point, p) for p in LAUNCHES) - 3.0) / speed


def test_a_dwell_robots_on_the_beach_cannot_reach_in_time_is_one_line() -> None:
    limit = 1800.0
    drive = _drive_s(LOOKOUT)
    assert 10.0 < drive < 30.0
    with pytest.raises(InputError) as info:
        load_mission(RECON, {"phases.beach_operations.time_limit_s": limit})
    err = info.value
    assert err.where == "tasks[0].dwell_s" and err.found == 1800.0
    assert f"at most {math.floor(limit - drive)} s" in err.expected
    assert "dune_lookout" in err.expected and "robot.wheel_speed_mps 0.6" in err.expected
    # a second short of the drive loads; faster wheels leave more time; a beacon's hold too
    fits = {"phases.beach_operations.time_limit_s": limit, "tasks.1.hold_s": 1000.0}
    load_mission(RECON, {**fits, "tasks.0.dwell_s": limit - drive - 1.0})
    with pytest.raises(InputError):
        load_mission(RECON, {**fits, "tasks.0.dwell_s": limit - drive + 1.0})
    load_mission(
        RECON, {**fits, "tasks.0.dwell_s": limit - _drive_s(LOOKOUT, 1.2) - 1.0, "robot.wheel_speed_mps": 1.2}
    )
    beacon = (20.0, 52.0)  # recon's first beacon, the farthest from a launch point
    with pytest.raises(InputError) as info:
        load_mission(
            RECON, {**fits, "tasks.0.dwell_s": 600.0, "tasks.1.hold_s": limit - _drive_s(beacon) + 1.0}
        )
    assert info.value.where == "tasks[1].hold_s" and "[20, 52]" in info.value.expected


@pytest.fixture(scope="module")
def late():
    """recon at an 1800 s limit with a dwell the loader lets through and the plan cannot keep."""
    m = load_mission(
        RECON,
        {"phases.beach_operations.time_limit_s": 1800, "tasks.0.dwell_s": 1780, "tasks.1.hold_s": 1700},
    )
    return plan_mission(m, seed=0, workers=1)


def test_the_plan_holds_each_point_to_its_planned_arrival(late) -> None:
    """A point's time is the arrival of the last of its robots_per_point robots (recon: 2 at the
    lookout); the lookout's leaves less than the dwell, so the plan falls short on it and says by
    how much; the beacons' holds fit."""
    stations = late.budget["stations"]
    watchers = sorted(rp.eta_s for rp in late.robots if rp.role == "surveillance")
    assert len(watchers) == 2
    assert stations["surveillance_1"]["arrivals_s"] == [pytest.approx(watchers[1])]
    assert stations["surveillance_1"]["end_s"] == 1800.0
    left = 1800.0 - watchers[1]
    assert left < 1780.0 < 1800.0
    verdict = plan_data(json.loads(plan_json(late)))["verdict"]
    assert verdict["status"] == "not met"
    (dwell,) = [c for c in verdict["checks"] if "surveillance_1" in c["criterion"]]
    assert not dwell["met"] and dwell["value"] == 0.0 and f"{left:.0f} s left" in dwell["criterion"]
    (hold,) = [c for c in verdict["checks"] if "landing_markers" in c["criterion"]]
    assert hold["met"] and hold["value"] == 1.0


def test_a_shorter_dwell_meets_and_a_lower_criterion_forgives_a_late_point(late) -> None:
    d = json.loads(plan_json(late))
    d["budget"]["stations"]["surveillance_1"]["required_s"] = 1700.0
    assert plan_data(d)["verdict"]["status"] == "met"
    d["budget"]["stations"]["surveillance_1"]["required_s"] = 1790.0
    d["criteria"]["min_surveillance_fraction"] = 0.0
    assert plan_data(d)["verdict"]["status"] == "met"


def test_the_loader_s_station_radius_is_the_simulator_s() -> None:
    from swarm.mission import load
    from swarm.sim import criteria

    assert load.STATION_RADIUS_M == criteria.STATION_RADIUS_M
