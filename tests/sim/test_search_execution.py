"""What makes a search driven as planned: legs followed by pure pursuit, obstacles detoured where
they are, found mines side-stepped, finders that keep searching, lost tracks before marks."""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import LineString, Point
from tiny_missions import write_mission

from swarm.mission.load import load_mission
from swarm.robot.driving import LOOKAHEAD_M
from swarm.sim.env import SwarmEnv
from swarm.sim.policy import ScriptedPolicy, WorkItem
from swarm.sim.routes import Routes, clear_of

QUIET = {
    "attrition": {"mtbf_h": 1.0e6},
    "surf": {"damage_h50_m": 10.0},
    "immobilization": {"per_km": 0.0},
    "rocks": {"damage_per_km": 0.0, "collision_damage_probability": 0.0},
}


def test_a_robot_off_its_leg_steers_back_onto_it() -> None:
    """Two metres to the side of a 900 m track, the robot steers for the point LOOKAHEAD_M ahead of
    its projection on the track, not for the track's far end 900 m away (which would let any side
    push carry it along a parallel line)."""
    routes = Routes(1)
    routes.set(0, np.array([[0.0, 0.0], [900.0, 0.0]]))
    routes.cursor[0] += 1  # on the leg from (0, 0) to (900, 0)
    target = routes.steer_points(np.array([[100.0, 2.0]]))[0]
    np.testing.assert_allclose(target, [100.0 + LOOKAHEAD_M, 0.0])
    # near the leg's end it steers for the end itself, and a robot beside the end has passed it
    np.testing.assert_allclose(routes.steer_points(np.array([[899.5, 0.5]]))[0], [900.0, 0.0])
    routes.set(0, np.array([[0.0, 0.0], [900.0, 0.0], [900.0, 50.0]]))
    routes.cursor[0] += 1
    routes.advance(np.array([[900.4, 1.5]]), np.array([True]))
    assert routes.cursor[0] == routes.start[0] + 2


def test_clear_of_sidesteps_a_found_mine_and_keeps_the_rest() -> None:
    line = np.array([[0.0, 0.0], [50.0, 0.0], [50.0, 30.0]])
    mines = np.array([[20.0, 0.2], [50.3, 12.0], [5.0, 9.0]])  # the last is nowhere near the route
    out, where = clear_of(line, mines, 1.0)
    path = LineString(out)
    assert path.distance(Point(20.0, 0.2)) >= 1.0 - 1e-9 and path.distance(Point(50.3, 12.0)) >= 1.0 - 1e-9
    np.testing.assert_allclose(out[where], line)  # every original waypoint is still there, in order
    assert len(out) == len(line) + 4  # two side-steps of two points each
    # away from the mines the route is the route
    far = shapely.difference(path, shapely.union_all([Point(m).buffer(2.0) for m in mines]))
    assert far.distance(LineString(line)) < 1e-9


def _search_env(tmp_path, count: int, **search: object) -> tuple[SwarmEnv, ScriptedPolicy]:
    task = {
        "type": "search",
        "area": "search_beach",
        "sensor": {"model": "cookie_cutter", "sweep_width_m": 4.0},
        "robots": count,
        "mark": True,
        **search,
    }
    hazards = {**QUIET, "mines": {"count": 30, "trigger_probability": 0.0}}
    path = write_mission(tmp_path, swarm={"count": count + 1}, tasks=[task], hazards=hazards)
    env = SwarmEnv(load_mission(path), action_mode="command")
    policy = ScriptedPolicy(env)
    env.reset(seed=4)
    return env, policy


def test_a_searcher_that_finds_a_mine_searches_on_and_a_reserve_marks_it(tmp_path) -> None:
    env, policy = _search_env(tmp_path, 1)
    (searcher,) = [i for i, r in enumerate(env.plan.robots) if r.role == "search"]
    found = []
    while env.agents and not found:
        policy.update()
        env.advance({})
        found = [ev for ev in env.events if ev["kind"] == "detection" and ev["robot"] == f"robot_{searcher}"]
    assert found, "the searcher must find a mine for this test to mean anything"

    def route_left_m() -> float:  # metres of its route (to its track and along it) from where it stands
        return float(env.routes.remaining_m(np.array([searcher]), env.robot_state[searcher, :2][None])[0])

    before = route_left_m()
    for _ in range(40):
        policy.update()
        env.advance({})
    assert env.marking[searcher] < 0 and len(env.routes.remaining_track(searcher)) > 0
    # it drives on along its route: 20 s at up to 0.6 m/s, less the few metres of a side-step
    assert before - 12.5 < route_left_m() < before - 5.0
    marks = [ev for ev in env.events if ev["kind"] == "takeover" and ev["item"] == "mark"]
    assert marks and all(ev["robot"] != f"robot_{searcher}" for ev in marks)


def test_a_lost_track_goes_before_a_mark(tmp_path) -> None:
    """One idle robot, a mine to mark and a lost searcher's track, both known to it: it takes the
    track (the search is what the criterion counts; the mark can wait)."""
    env, policy = _search_env(tmp_path, 1)
    spare = next(i for i, r in enumerate(env.plan.robots) if r.role == "spare")
    while env.agents and not policy._idle()[spare]:
        policy.update()
        env.advance({})
    xy = env.robot_state[spare, :2]
    east = np.array([1.0, 0.0])
    everyone = np.ones(env.n, bool)
    env.objects_m = np.vstack([env.objects_m, xy + 3.0 * east])  # a find right beside it
    env.object_mine = np.append(env.object_mine, -1)
    env.object_marker = np.append(env.object_marker, -1)
    k = len(env.objects_m) - 1
    mark = WorkItem("mark", "search", env.objects_m[k].copy(), obj=k, audience=everyone.copy())
    track = WorkItem("route", "search", xy + 30.0 * east, np.array([xy + 30.0 * east, xy + 60.0 * east]),
                     track=True, audience=everyone.copy())  # fmt: skip
    policy.items = [mark, track]
    policy._allocate()
    assert track.taken_by == spare and mark.taken_by == -1
