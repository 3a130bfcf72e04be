"""The plan's way in through the surf (`swarm.mission.surf_drive`) against the simulator's own
physics, controller and route follower, and the surf losses the budget makes of it against the
formulas and against simulated runs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from swarm.mission import budget, exposure, load_mission, surf_drive
from swarm.mission.plan import _budget, plan_mission
from swarm.mission.surf_speed import SurfZone
from swarm.planning.router import Router
from swarm.robot.driving import DriveLimits, drive_toward
from swarm.robot.terrain import GROUND_SUBMERSION
from swarm.sim import setup
from swarm.sim.env import SimConfig
from swarm.sim.hazards import RATE_CAUSES, HazardInputs, HazardModel
from swarm.sim.mines import MineField
from swarm.sim.physics import Physics, SeaState
from swarm.sim.routes import Routes
from swarm.sim.run import simulate_batch
from swarm.studies.stats import count_mean_interval

LANDING = "missions/landing.yaml"


def _landing(height_m: float, **overrides: object):
    return load_mission(LANDING, {"hazards.surf.wave_height_m": height_m, **overrides})


@pytest.fixture(scope="module")
def landing_plan():
    mission = _landing(4.0)
    return mission, plan_mission(mission, seed=mission.seed, workers=1)


def _ways_in(mission, plan) -> list[np.ndarray]:
    """Each robot's way in as the budget drives it (`exposure.route_in` of the stitched routes)."""
    cm = plan.costmap
    zone = SurfZone(mission, cm)
    ashore = exposure.nearest_ashore(mission, cm, zone.heights > 0)
    router = Router(cm, seed=mission.seed)
    return [exposure.route_in(exposure.drivable(rp, router), ashore) for rp in plan.robots]


def _simulated_ways_in(mission, lines: list[np.ndarray], phases: np.ndarray):
    """The same ways in driven by the simulator's classes (`Physics`, `drive_toward`, `Routes`),
    flips left out and no robot lost: each one's seconds in the surf zone until its wheels ground
    or the limit passes, whether it passed, and the integral of its immobilization rate until
    then (`HazardModel.rates_per_s`)."""
    cfg = SimConfig()
    swim = mission.robot.swim_speed_mps
    jet = mission.robot.jet_thrust_n or mission.terrain_library.default_jet_thrust_n(swim)
    sea = SeaState.from_mission(mission)
    physics = Physics(mission.beach_map, mission.terrain_library, mission.robot_params, sea,
                      jet_thrust_max_n=jet, substep_s=cfg.substep_s)  # fmt: skip
    cruise = mission.robot.wheel_speed_mps
    limits = DriveLimits(mission.robot_params.wheel_radius_m, mission.robot_params.track_width_m,
                         cruise, setup.MAX_WHEEL_SPEED_FACTOR * cruise, jet)  # fmt: skip
    every = [line for line in lines for _ in phases]
    n = len(every)
    follow = Routes(n)
    for i, line in enumerate(every):
        follow.set(i, line)
    state = np.zeros((n, 6))
    state[:, :2] = [line[0] for line in every]
    state[:, 2] = [math.atan2(*(line[1] - line[0])[::-1]) for line in every]
    submersion, inverted = np.zeros(n), np.zeros(n, bool)
    surf_s, done, timed_out = np.zeros(n), np.zeros(n, bool), np.zeros(n, bool)
    limit = mission.phases.surf_crossing.time_limit_s
    wave_phase, each = np.tile(phases, len(lines)), np.arange(n)  # each robot a run of its own
    dt = cfg.dt_s
    bm = mission.beach_map
    hazards = HazardModel(mission.hazards, mission.phases, bm.terrain_classes, mission.terrain_library,
                          MineField(np.empty((0, 2))), np.empty((0, 2)), n)  # fmt: skip
    stuck = np.zeros(n)
    for step in range(int(2 * limit / dt)):
        afloat = submersion > GROUND_SUBMERSION
        follow.advance(state[:, :2], np.ones(n, bool), afloat)
        wheels, thrust, _ = drive_toward(
            state, follow.steer_points(state[:, :2], afloat), cruise, submersion, inverted, limits
        )
        res = physics.step(state, wheels, thrust, inverted, np.full(n, step * dt), dt, wave_phase, run=each)
        state, submersion = res.state, res.submersion
        live = ~done & ~timed_out
        surf_s += np.where(live & res.in_surf, dt, 0.0)
        no, zero = np.zeros(n, bool), np.zeros(n)
        inputs = HazardInputs(
            t_s=(step + 1) * dt, dt_s=dt, alive=live, at_sea=no, xy=state[:, :2], terrain=res.terrain,
            distance_m=res.distance_m, slip=res.slip, driving=live, wave_hits=no,
            obstacle_hit=np.full(n, -1), energy_wh=np.ones(n), sea_time_s=zero, surf_time_s=surf_s,
            isolated_s=zero, radio_ok=~no,
        )  # fmt: skip
        stuck += hazards.rates_per_s(inputs)[:, RATE_CAUSES.index("immobilized")] * dt
        done |= live & (submersion < GROUND_SUBMERSION)
        timed_out |= live & ~done & (surf_s > limit)
        if (done | timed_out).all():
            break
    k = len(phases)
    return surf_s.reshape(-1, k), timed_out.reshape(-1, k), stuck.reshape(-1, k)


def test_the_drive_steps_as_the_simulator_does() -> None:
    """The drive's step and substep are the simulator's defaults, and it follows its route and
    turns it into commands with the simulator's own kernels (`swarm.robot.driving`)."""
    from swarm.sim import routes, world

    cfg = SimConfig()
    assert (cfg.dt_s, cfg.substep_s) == (surf_drive.STEP_S, surf_drive.SUBSTEP_S)
    assert surf_drive.drive_toward is world.drive_toward
    assert surf_drive.advance_cursors is routes.advance_cursors
    assert surf_drive.steer_points is routes.steer_points


def test_the_way_in_is_the_simulator_s() -> None:
    """landing's ways in at 4 m breakers with 100 s to cross the surf, driven by the simulator's
    physics, controller and route follower at the drive's wave phases: the same robots run out of
    time at the same phases (the longest ways in take 98 to 136 s), and the others are among the
    breakers as long, phase by phase, and as likely to get stuck there: the breakers surge them
    over the bed, wheels spinning (the plan counted no such loss; 0.19 robots a run in 32 runs of
    mine_clear at 4 m)."""
    mission = _landing(4.0, **{"phases.surf_crossing.time_limit_s": 100})
    plan = plan_mission(mission, seed=mission.seed, workers=1)
    lines = _ways_in(mission, plan)
    zone = SurfZone(mission, plan.costmap)
    drives = surf_drive.drive_in(mission, zone, lines)
    period = mission.hazards.surf.wave_period_s
    phases = np.arange(surf_drive.WAVE_PHASES) * period / surf_drive.WAVE_PHASES
    simulated_s, simulated_out, simulated_stuck = _simulated_ways_in(mission, lines, phases)
    planned_out = np.array([d.timed_out for d in drives])
    assert planned_out.any() and not planned_out.all()
    assert np.array_equal(planned_out, simulated_out)
    planned_s = np.array([d.surf_s for d in drives])
    landed = ~planned_out
    assert planned_s[landed] == pytest.approx(simulated_s[landed], abs=2 * surf_drive.STEP_S)
    planned_stuck = np.array([d.stuck for d in drives])
    assert simulated_stuck[landed].min() > 0.0
    assert planned_stuck[landed] == pytest.approx(simulated_stuck[landed], rel=0.05)


def test_the_surf_s_losses_are_the_mean_of_the_wave_phases(landing_plan) -> None:
    """A way in that times out at some phases: the surf's breaker and timeout losses the budget
    makes of it (`exposure.surf_terms`, `robot_losses`, `expected_by_cause`) are the phases' mean
    of 1 - exp(-hazard) and exp(-hazard) x timed out; the breakers come first."""
    mission, plan = landing_plan
    cm = plan.costmap
    drive = surf_drive.WayIn(
        surf_s=np.array([100.0, 300.0, 601.0, 601.0]),
        hazard=np.array([0.05, 0.2, 0.6, 0.9]),
        ashore=np.array([True, True, False, False]),
        timed_out=np.array([False, False, True, True]),
        landed_m=np.array([[10.0, 40.0], [12.0, 41.0], [np.nan, np.nan], [np.nan, np.nan]]),
        stuck=np.zeros(4),
    )
    surf_s, per_hit, timeout = exposure.surf_terms(drive, mission.hazards.surf.wave_period_s)
    assert surf_s == pytest.approx(drive.surf_s.mean())
    exposed = budget.Exposure(0.0, surf_s, 0.0, breaker_hazard=per_hit, surf_timeout=timeout)
    losses = budget.robot_losses(mission, cm, exposed)
    losses["surf"].pop("failure")
    by_cause = budget.expected_by_cause(losses)["surf"]
    survive = np.exp(-drive.hazard)
    assert by_cause["wave_impact"] == pytest.approx(np.mean(1.0 - survive))
    assert by_cause["surf_timeout"] == pytest.approx(np.mean(survive * drive.timed_out))


def test_getting_stuck_among_the_breakers_is_the_mean_of_the_wave_phases(landing_plan) -> None:
    """The way in's chance of getting stuck in the surf (`WayIn.stuck`, made a hazard by
    `exposure.way_in`) is the phases' mean of 1 - exp(-stuck), counted in the surf phase; wheels
    in shallow water ashore (`Exposure.wet_m`) get stuck at the mode's per-metre rate with its
    slip, afloat in deep water never."""
    mission, plan = landing_plan
    cm = plan.costmap
    stuck = np.array([0.0, 0.01, 0.03, 0.2])
    hazard = -math.log(np.exp(-stuck).mean())
    losses = budget.robot_losses(mission, cm, budget.Exposure(0.0, 0.0, 0.0, surf_stuck_hazard=hazard))
    assert losses["surf"]["immobilized"] == pytest.approx(np.mean(1.0 - np.exp(-stuck)))
    assert "immobilized" not in losses["beach"]
    imm = mission.hazards.immobilization
    speeds = cm.speeds
    slip = 1.0 - speeds.speed_mps[speeds.names.index("shallow_water")] / speeds.nominal_wheel_speed_mps
    per_m = imm.per_km / 1000.0 * imm.mode_factors.get("shallow_water", 1.0) * (1.0 + (slip / 0.3) ** 2)
    wading = budget.Exposure(0.0, 0.0, 0.0, wet_m={"shallow_water": 500.0, "deep_water": 500.0})
    beach = budget.robot_losses(mission, cm, wading)["beach"]
    assert beach["immobilized"] == pytest.approx(1.0 - math.exp(-per_m * 500.0))


def test_a_timeout_takes_what_the_other_causes_leave() -> None:
    """A certain timeout beside a breaker's chance p: the breakers take p, the timeout the rest
    (a hazard-weighted share would give the timeout all of it)."""
    p = 0.3
    losses = {"surf": {"wave_impact": p, "surf_timeout": 1.0}, "beach": {"failure": 0.5}}
    out = budget.expected_by_cause(losses)
    assert out["surf"] == pytest.approx({"wave_impact": p, "surf_timeout": 1.0 - p})
    assert out["beach"]["failure"] == pytest.approx(0.0)


def test_the_same_routes_lose_more_in_the_surf_the_bigger_the_breakers(landing_plan) -> None:
    """landing's routes budgeted at 1, 2.5 and 4 m breakers: the expected losses in the surf grow
    with the breakers. None times out: afloat, a robot the longshore current sets off its leg
    steers along the leg's line and makes way ashore (`swarm.robot.driving.steer_point`), where
    it used to head back up-current for the leg and 4 of the 12 were stranded at 4 m; with a
    surf limit shorter than the slowest ways in, those robots are named and expected lost."""
    _, plan = landing_plan
    surf = []
    for h in (1.0, 2.5, 4.0):
        b = _budget(_landing(h), plan)
        surf.append(sum(b["expected_losses"]["surf"].values()))
        assert "surf_timeout" not in b["expected_losses"]["surf"] and b["stranded_in_surf"] == []
    assert np.all(np.diff(surf) > 0.0)
    short = _budget(_landing(4.0, **{"phases.surf_crossing.time_limit_s": 50}), plan)
    assert len(short["stranded_in_surf"]) == 12  # the quickest way in takes 56 s
    assert sum(short["expected_losses"]["surf"].values()) > 11.9


@pytest.mark.slow
@pytest.mark.parametrize("height_m", [1.5, 3.0, 4.0])
def test_landing_s_plan_agrees_with_its_runs_at_any_breakers(height_m: float) -> None:
    """The plan's expected losses lie in the 95% interval of 16 simulated runs' (as `plan
    --evaluate` judges them); the plan without the drive counted 1.1 robots at 3 and 4 m against
    3.9 and 4.8 simulated, when the route follower still stranded robots in the current."""
    mission = _landing(height_m)
    plan = plan_mission(mission, seed=mission.seed, workers=1)
    logs = simulate_batch(mission, list(range(100, 116)), plan=plan)
    lost = [len(log.losses) for log in logs]
    low, high = count_mean_interval(lost, within=(0.0, mission.swarm.count))
    assert low <= plan.budget["expected_lost"] <= high


def test_a_robot_set_down_current_drives_back_to_its_route_across_the_beach() -> None:
    """Grounded 30 m down-current of its landfall, a robot drives straight to its ground route's
    nearest point and on along it: that way ashore, not the planned one from the landfall, is the
    beach exposure (the mean of the phases that landed; the ones that did not are left out)."""
    ground = np.array([[0.0, 0.0], [0.0, 50.0], [20.0, 50.0]])
    landed = np.array([[30.0, 9.0], [30.0, 11.0], [np.nan, np.nan]])
    driven = exposure.as_driven_ashore(ground, landed)
    np.testing.assert_allclose(driven, [[30.0, 10.0], [0.0, 10.0], [0.0, 50.0], [20.0, 50.0]])
    assert exposure.polyline_m(driven) == pytest.approx(30.0 + 40.0 + 20.0)
    # no phase landed, or no ground route: the planned one
    assert exposure.as_driven_ashore(ground, np.full((2, 2), np.nan)) is ground
    one = ground[:1]
    assert exposure.as_driven_ashore(one, landed) is one
