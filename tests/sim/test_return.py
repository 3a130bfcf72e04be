"""The way back to sea in the simulator: the plan's way (`exposure.WayOut`), picked up afloat
beyond the surf in front of the pick-up point, or by hand at a pick-up point on dry ground."""

from __future__ import annotations

import numpy as np
from tiny_missions import write_mission

from swarm.mission import exposure, load_mission
from swarm.mission.plan import pickup_points, plan_mission
from swarm.mission.surf_speed import SurfZone
from swarm.sim.criteria import STATION_RADIUS_M
from swarm.sim.layout import PHASES
from swarm.sim.run import simulate

RETURNING = PHASES.index("returning")
QUIET = {"enabled": False}


def _picked_up(log) -> dict[str, np.ndarray]:
    """Where each robot was picked up, by name."""
    return {e["robot"]: np.array([e["x_m"], e["y_m"]]) for e in log.events if e["kind"] == "recovered"}


def _phases(return_s: float) -> dict:
    return {
        "sea_transit": {"time_limit_s": 300},
        "surf_crossing": {"time_limit_s": 300},
        "beach_operations": {"time_limit_s": 240},
        "return_to_sea": {"enabled": True, "time_limit_s": return_s},
    }


def test_survivors_cross_the_surf_in_front_of_their_pick_up_point_and_are_picked_up_there(tmp_path) -> None:
    """Six robots land on both zones of the small beach and go back to one pick-up point, off the
    western zone: each is picked up afloat within a few metres of the straight way out from the
    point's exit (the waves push it sideways), and is among the breakers about as long as that way
    takes (`SurfZone.crossing`, 46 s; the robots 36-48 s), those from the eastern zone too, 35-47 m
    along the beach."""
    phases = {**_phases(600), "return_to_sea": {"enabled": True, "time_limit_s": 600, "points": ["launch_1"]}}
    mission = load_mission(write_mission(tmp_path, phases=phases, hazards=QUIET))
    plan = plan_mission(mission, seed=mission.seed, workers=1)
    log = simulate(mission, seed=1, plan=plan)
    assert log.end_reasons == ["recovered"] * mission.swarm.count
    launches = np.array([r.launch_m for r in plan.robots])
    way_out = exposure.WayOut(mission, plan.costmap, pickup_points(mission, launches))
    (exit_m,), (pickup,) = way_out.exits, way_out.pickups
    zone = SurfZone(mission, plan.costmap)
    crossing_s = zone.crossing(np.vstack([exit_m, pickup])).seconds
    picked = _picked_up(log)
    dt = np.diff(log.times_s, append=log.times_s[-1])
    for j, rid in enumerate(log.robots):
        out = pickup - exit_m
        along = exit_m + np.clip((picked[rid] - exit_m) @ out / (out @ out), 0.0, 1.0) * out
        assert np.hypot(*(picked[rid] - along)) < 5.0
        back_j = log.phase[:, j] == RETURNING
        r, c = mission.beach_map.cell_of(*log.xy_m[back_j, j].astype(float).T)
        in_surf = dt[back_j][zone.heights[r, c] > 0].sum()
        # routed to the pick-up point itself, the eastern robots were 70-88 s among the breakers
        assert 0.6 * crossing_s < in_surf < 1.15 * crossing_s


def test_a_beach_launch_picks_its_survivors_up_where_they_were_put_down(tmp_path) -> None:
    """Launched from dry ground, the survivors drive back to their launch points, and each is
    picked up on reaching one: as many as the plan expects back (hazards off: all of them)."""
    launch = {"platform": "beach", "points": [[30.0, 55.0], [80.0, 55.0]], "interval_s": 2}
    mission = load_mission(write_mission(tmp_path, launch=launch, phases=_phases(300), hazards=QUIET))
    plan = plan_mission(mission, seed=mission.seed, workers=1)
    log = simulate(mission, seed=1, plan=plan)
    assert log.end_reasons == ["recovered"] * mission.swarm.count
    assert plan.budget["expected_recovered"] == [mission.swarm.count] * 2
    for xy in _picked_up(log).values():
        assert min(np.hypot(*(xy - p)) for p in ([30.0, 55.0], [80.0, 55.0])) <= STATION_RADIUS_M
