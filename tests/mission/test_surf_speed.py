"""The plan's time in the surf zone (`swarm.mission.surf_speed`) against the simulator's physics
and against the closed forms it reduces to."""

from __future__ import annotations

import math

import numpy as np
import pytest

from swarm.mission import exposure, load_mission
from swarm.mission.plan import pickup_points, place_xy
from swarm.mission.surf_speed import SUBSTEP_S, SurfZone, mean_speed
from swarm.planning import build_costmap
from swarm.planning.router import Router
from swarm.robot.driving import DriveLimits, drive_toward
from swarm.robot.terrain import GROUND_SUBMERSION
from swarm.sim.env import SimConfig
from swarm.sim.physics import Physics, SeaState

RELAY = "missions/relay.yaml"


@pytest.fixture(scope="module")
def relay():
    mission = load_mission(RELAY)
    cm = build_costmap(mission.beach_map, mission.robot_params, mission.terrain_library)
    return mission, cm, SurfZone(mission, cm)


def _length(polyline: np.ndarray) -> float:
    return float(np.hypot(*np.diff(polyline, axis=0).T).sum())


def _frame(k: int, forward: float, left: float) -> np.ndarray:
    return np.tile([forward, left], (k, 1))


def test_in_calm_deep_water_a_robot_makes_the_speed_its_jet_holds_against_drag(relay) -> None:
    """No breakers, no current, no ground: the jet's thrust T against the hull's quadratic drag c
    gives sqrt(T / c), 1.5 x the swim speed with the default jet (`default_jet_thrust_n`)."""
    mission, _, _ = relay
    lib = mission.terrain_library
    k = 3
    made = mean_speed(
        mission, ["deep_water"] * k, np.full(k, 5.0), np.zeros(k), _frame(k, 1.0, 0.0),
        np.zeros((k, 2)), mission.robot.wheel_speed_mps, np.zeros((k, 2)),
    )  # fmt: skip
    thrust = lib.default_jet_thrust_n(mission.robot.swim_speed_mps)
    expected = math.sqrt(thrust / lib["deep_water"].drag_n_s2_per_m2)
    assert expected == pytest.approx(1.5 * mission.robot.swim_speed_mps)
    assert made == pytest.approx(expected, rel=1e-3)


def test_bigger_breakers_hold_a_robot_back_more(relay) -> None:
    """Over the same surf cell, heading shoreward: the more the orbital flow overpowers the wheels'
    grip and the jet, the less way each wave leaves; and a current across the heading slows it too
    (the drag of the relative speed grows with it)."""
    mission, _, _ = relay
    heights = np.array([0.2, 0.5, 0.8, 1.1, 1.4])
    k = len(heights)
    args = (mission, ["surf"] * k, heights / 0.78, heights, _frame(k, 1.0, 0.0), np.zeros((k, 2)), 0.6)
    still = mean_speed(*args, np.zeros((k, 2)))
    assert np.all(np.diff(still) < 0.0)
    assert still[-1] < 0.8 * still[0]
    assert np.all(mean_speed(*args, _frame(k, 0.0, 0.5)) < still)


def test_the_plans_time_in_the_surf_is_the_simulators(relay) -> None:
    """Robots driven by the simulator's physics and controller from relay's launch points to the
    nearest dry ground, at four wave phases: their time in the surf zone is within 12% of
    `SurfZone.crossing` on the same line (66.5-67 s against 60-64: the controller's steering
    against the waves' sideways push, which the reduced model leaves out, costs the rest), where
    the swim speed, the plan's count before, is 25% short of it (48.5 s)."""
    mission, cm, zone = relay
    bm = mission.beach_map
    ashore = exposure.nearest_ashore(mission, cm, zone.heights > 0)
    lines = [ashore(np.array(place_xy(bm, p), dtype=np.float64)) for p in mission.launch.points]
    swim = mission.robot.swim_speed_mps
    jet = mission.robot.jet_thrust_n or mission.terrain_library.default_jet_thrust_n(swim)
    physics = Physics(bm, mission.terrain_library, mission.robot_params, SeaState.from_mission(mission),
                      jet_thrust_max_n=jet)  # fmt: skip
    limits = DriveLimits(
        mission.robot_params.wheel_radius_m, mission.robot_params.track_width_m,
        mission.robot.wheel_speed_mps, 1.5 * mission.robot.wheel_speed_mps, jet,
    )  # fmt: skip
    period = mission.hazards.surf.wave_period_s
    phases = np.arange(4) * period / 4
    start = np.array([line[0] for line in lines for _ in phases])
    target = np.array([line[-1] for line in lines for _ in phases])
    d = target - start
    state = np.zeros((len(start), 6))
    state[:, :2], state[:, 2] = start, np.arctan2(d[:, 1], d[:, 0])
    in_surf = np.zeros(len(start))
    inverted = np.zeros(len(start), bool)
    submersion = np.zeros(len(start))
    dt = 0.5
    for step in range(int(600 / dt)):
        wheels, thrust, dist = drive_toward(
            state, target, mission.robot.wheel_speed_mps, submersion, inverted, limits
        )
        res = physics.step(state, wheels, thrust, inverted, step * dt, dt, np.tile(phases, len(lines)))
        state, submersion = res.state, res.submersion
        in_surf += np.where(res.in_surf & (dist > 0.5), dt, 0.0)
    assert np.all(dist < 1.0)  # every robot made it ashore
    simulated = in_surf.reshape(len(lines), len(phases)).mean(axis=1)
    planned = np.array([zone.crossing(line).seconds for line in lines])
    at_swim_speed = np.array([zone.crossing(line).metres for line in lines]) / swim
    assert simulated == pytest.approx(planned, rel=0.12)
    assert np.all(planned <= simulated)
    assert np.all(at_swim_speed < 0.75 * simulated)


def test_a_crossing_counts_the_surf_metres_and_the_breakers_by_time(relay) -> None:
    """A straight line from deep water to the beach, past the surf zone: its surf metres are the
    line's length over surf cells (checked on a 1 cm walk), one breaker's hazard lies between the
    smallest and the largest local breaker's, and a line on dry ground crosses nothing."""
    mission, cm, zone = relay
    heights = zone.heights
    rows, cols = np.nonzero(heights > 0)
    x, y = cm.center_of(rows, cols)
    x0 = float(np.median(x[y < 100.0]))  # the open beach's surf, not the river's
    y = y[np.abs(x - x0) < 3.0 * cm.cell_m]
    line = np.array([[x0, float(y.min()) - 20.0], [x0, float(y.max()) + 20.0]])
    crossing = zone.crossing(line)
    t = np.linspace(0.0, 1.0, int(np.hypot(*(line[1] - line[0])) / 0.01) + 1)
    walk = line[0] + (line[1] - line[0]) * t[:, None]
    r, c = cm.cell_of(walk[:, 0], walk[:, 1])
    on = heights[r, c] > 0
    assert crossing.metres == pytest.approx(on.mean() * np.hypot(*(line[1] - line[0])), abs=cm.cell_m)
    hazard = -np.log1p(-mission.hazards.surf.damage_probability(heights[r, c][on]))
    assert hazard.min() - 1e-12 <= crossing.hazard_per_hit <= hazard.max() + 1e-12
    assert crossing.seconds > crossing.metres / (1.5 * mission.robot.wheel_speed_mps)
    clear = ~np.lib.stride_tricks.sliding_window_view(heights > 0, 8, axis=1).any(axis=-1)
    r0, c0 = np.argwhere(clear)[0]  # 8 cells in a row off the surf zone
    dry = np.array(cm.center_of(np.array([r0, r0]), np.array([c0, c0 + 5]))).T
    assert zone.crossing(dry) == (0.0, 0.0, 0.0)


def test_the_way_back_meets_the_breakers_only_crossing_them_in_front_of_the_pick_up(relay) -> None:
    """From dry ground all along relay's beach (away from the river) back to the nearest pick-up
    point: the way out (`WayOut`) ends at the pick-up point, straight out from its exit, the dry
    ground nearest it, and its metres in the surf zone are that crossing's, but for the swash its
    route along the waterline brushes (24.2 m, and up to 27.2). Routed to the pick-up point itself,
    as the simulator's robots were, the way runs along the surf zone: 28-44 m, in all 19% more time
    among the breakers than the way out (525 s against 441 over eight starts)."""
    mission, cm, zone = relay
    launches = np.array([place_xy(mission.beach_map, p) for p in mission.launch.points])
    way_out = exposure.WayOut(mission, cm, pickup_points(mission, launches))
    router = Router(cm, seed=0)
    out_s, routed_s = [], []
    for x in (20.0, 60.0, 100.0, 150.0, 350.0, 420.0, 480.0, 540.0):
        r, c = cm.cell_of(np.array([x]), np.array([85.0]))
        start = np.array(cm.center_of(r, c)).ravel()
        assert cm.is_free(*start) and zone.heights[r[0], c[0]] == 0.0
        way = way_out.route(router, start)
        k = way_out.nearest(start)
        pickup, exit_m = way_out.pickups[k], way_out.exits[k]
        assert np.allclose(way[-1], pickup) and np.allclose(way[-2], exit_m)
        crossing = zone.crossing(np.vstack([exit_m, pickup])).metres
        assert crossing > 5.0  # it does cross the surf zone
        assert crossing <= zone.crossing(way).metres <= 1.15 * crossing
        out_s.append(zone.crossing(way).seconds)
        routed_s.append(zone.crossing(router.route(start, pickup)).seconds)
    assert np.all(np.array(out_s) <= np.array(routed_s) + 1.0)
    assert sum(out_s) < 0.9 * sum(routed_s)


def test_a_way_in_is_cut_where_the_wheels_ground(relay) -> None:
    """`SurfZone.landfall` on a line from deep water up the beach: the cut lies within half a cell
    past the last cell deep enough to float the wheels (`GROUND_SUBMERSION`, where the simulator
    starts its beach phase) and on the first shallow enough; the two parts are the line, and their
    surf metres add up to its own. A line that never grounds is all afloat."""
    mission, cm, zone = relay
    lib = mission.terrain_library
    line = np.array([[300.5, 5.0], [300.5, 40.0], [300.5, 80.0]])
    afloat, wading = zone.landfall(line)
    assert np.allclose(afloat[0], line[0]) and np.allclose(wading[-1], line[-1])
    assert np.allclose(afloat[-1], wading[0])
    assert _length(afloat) + _length(wading) == pytest.approx(_length(line))
    ys = np.arange(5.0, 80.0, 0.01)
    r, c = cm.cell_of(np.full_like(ys, 300.5), ys)
    buoyancy = np.array([lib[k].buoyancy_fraction for k in cm.terrain_classes])[cm.terrain[r, c]]
    first = ys[np.argmax(buoyancy < GROUND_SUBMERSION)]
    assert first - cm.cell_m / 2 - 1e-9 <= wading[0, 1] <= first + 1e-9
    whole, parts = zone.crossing(line), (zone.crossing(afloat), zone.crossing(wading))
    assert parts[1].metres > 0.0  # shallow water still among the breakers
    assert parts[0].metres + parts[1].metres == pytest.approx(whole.metres, abs=cm.cell_m)
    at_sea = np.array([[300.5, 5.0], [300.5, 20.0]])
    afloat, wading = zone.landfall(at_sea)
    assert np.array_equal(afloat, at_sea) and np.array_equal(wading, at_sea[-1:])


def test_the_reduced_model_steps_as_the_simulator_does() -> None:
    """`mean_speed` integrates with the simulator's physics substep, so the two meet the same
    numerical damping of the linearly implicit skid step."""
    assert SimConfig().substep_s == SUBSTEP_S
