"""The batched world core (`swarm.sim.world`): a run's result is the same whether it runs alone
(through the PettingZoo adapter, `simulate`) or in a batch of any size (`simulate_batch`), bit for
bit on its events, outcome, losses and trajectories; runs of one batch keep their own seeds, mine
fields and hazards; the scripted policy drives each run through its `RunView` only."""

from __future__ import annotations

import math

import numpy as np
import pytest
from tiny_missions import write_mission

from swarm.mission.load import load_mission
from swarm.mission.plan import plan_mission
from swarm.robot.terrain import GROUND_SUBMERSION
from swarm.sim import world as world_module
from swarm.sim.run import MissionLog, simulate, simulate_batch
from swarm.sim.runview import MARK, RunView
from swarm.sim.setup import MissionSetup
from swarm.sim.world import World

#: One core runs the module (`scripts/test`'s loadgroup), so the runs alone (`alone`) are made once.
pytestmark = pytest.mark.xdist_group("world")

SHORT_RADIO = {"tx_power_dbm": 0.0, "rx_sensitivity_dbm": -70.0, "fade_margin_db": 3.0}
#: Everything at once on the small beach: a landing, a search that marks what it finds and clears
#: it together, a relay chain, losses from failures, breakers and mines, and the return to sea.
TASKS = [
    {"type": "landing", "zones": ["landing_a"], "robots_per_zone": 1},
    {
        "type": "search",
        "area": "search_beach",
        "sensor": {"sweep_width_m": 4.0},
        "mark": True,
        "clearance": {"at_s": 700, "standoff_m": 8},
    },
    {"type": "relay", "source": "relay_source", "sinks": ["relay_sink"], "radio": SHORT_RADIO},
]
HAZARDS = {
    "attrition": {"mtbf_h": 0.4},
    "mines": {"count": 5, "trigger_probability": 0.5},
    "surf": {"wave_height_m": 2.0},  # breakers that disable a robot now and then
}
PHASES = {
    "sea_transit": {"time_limit_s": 300},
    "surf_crossing": {"time_limit_s": 300},
    "beach_operations": {"time_limit_s": 420},
    "return_to_sea": {"enabled": True, "time_limit_s": 120},
}
SEEDS = [3, 10, 29]


@pytest.fixture(scope="module")
def mission_and_plan(tmp_path_factory: pytest.TempPathFactory):
    path = write_mission(
        tmp_path_factory.mktemp("world"),
        "busy",
        swarm={"count": 10},
        tasks=TASKS,
        hazards=HAZARDS,
        phases=PHASES,
    )
    mission = load_mission(path)
    return mission, plan_mission(mission, seed=mission.seed, workers=1)


@pytest.fixture(scope="module")
def alone(mission_and_plan) -> dict[int, MissionLog]:
    mission, plan = mission_and_plan
    return {s: simulate(mission, seed=s, plan=plan) for s in SEEDS}


def _same(a: MissionLog, b: MissionLog) -> None:
    assert a.events == b.events
    assert a.summary() == b.summary()
    assert a.mines_state == b.mines_state
    assert a.end_reasons == b.end_reasons
    assert a.completed_s == b.completed_s
    for name in (
        "times_s",
        "xy_m",
        "heading_rad",
        "alive",
        "phase",
        "role",
        "mines_m",
        "objects_m",
        "object_mine",
    ):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.shape == y.shape, name
        assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), name


def test_the_runs_are_busy_enough_to_tell(alone) -> None:
    """The runs lose robots to several causes, find and clear mines and differ from each other:
    an identity below means something."""
    causes = {x["cause"] for log in alone.values() for x in log.losses}
    assert len(causes) >= 2, causes
    kinds = {ev["kind"] for log in alone.values() for ev in log.events}
    assert {"detection", "mark", "clearance", "relay_connected", "takeover"} <= kinds, kinds
    assert len({len(log.events) for log in alone.values()}) == len(SEEDS)


@pytest.mark.parametrize(
    "order",
    [
        SEEDS,
        pytest.param([*SEEDS[::-1], SEEDS[1]], marks=pytest.mark.slow),  # reordered, a seed twice
        pytest.param([SEEDS[2]], marks=pytest.mark.slow),  # a batch of one
    ],
)
def test_a_run_is_the_same_alone_and_in_a_batch_of_any_size(mission_and_plan, alone, order) -> None:
    mission, plan = mission_and_plan
    logs = simulate_batch(mission, order, plan=plan)
    assert [log.seed for log in logs] == order
    for seed, log in zip(order, logs, strict=True):
        _same(alone[seed], log)


def test_a_batch_says_how_far_its_runs_have_got_without_changing_them(mission_and_plan, alone, monkeypatch):
    """`working` hears the batch's progress in runs while its runs are still going (they finish
    together, so a bar counting finished runs would wait for the end), never more than the runs,
    never back, and the runs are the same as without it."""
    monkeypatch.setattr("swarm.sim.run.WORKING_EVERY_S", 0.0)  # every step
    mission, plan = mission_and_plan
    said: list[float] = []
    logs = simulate_batch(mission, SEEDS, plan=plan, working=said.append)
    for seed, log in zip(SEEDS, logs, strict=True):
        _same(alone[seed], log)
    assert said == sorted(said) and said[0] >= 0.0 and said[-1] <= len(SEEDS)
    partial = [x for x in said if 0.0 < x < 1.0]  # before the first run has finished
    assert len(set(partial)) > 10
    assert said[-1] >= len(SEEDS) - 1  # the last call is a step before the last run ends


def test_runs_of_a_batch_have_their_own_mines_and_waves(mission_and_plan) -> None:
    mission, plan = mission_and_plan
    world = World(MissionSetup(mission, plan, dt_s=0.5, substep_s=0.25), 3)
    world.reset([5, 6, 5])
    a, b, c = world.runs
    assert not np.array_equal(a.minefield.positions_m, b.minefield.positions_m)
    assert np.array_equal(a.minefield.positions_m, c.minefield.positions_m)
    assert world.wave_phase_s[0] != world.wave_phase_s[1] and world.wave_phase_s[0] == world.wave_phase_s[2]
    # a run's arrays are views of the batch's: writing one changes the world, and nothing else
    a.robot_state[0, 0] += 1.0
    assert world.robot_state[0, 0, 0] == a.robot_state[0, 0]
    assert world.robot_state[2, 0, 0] != a.robot_state[0, 0]


def test_the_policy_reads_a_run_through_its_view_only() -> None:
    """No private attribute of the run or the world is read by the policy's source."""
    import inspect
    import re

    from swarm.sim import policy

    source = inspect.getsource(policy)
    assert not re.findall(r"\benv\._[a-z]", source)
    assert "RunView" in source and isinstance(RunView, type)


@pytest.mark.parametrize("typed_streams", [True, False], ids=["typed streams", "plain streams"])
def test_resetting_some_runs_leaves_the_others_alone(mission_and_plan, typed_streams, monkeypatch) -> None:
    """A run reset in the middle of a batch (autoreset) starts over from its seed exactly; the
    others go on as if nothing happened (with the runs' generators in a typed list for compiled
    draws, as large batches keep them, and in a plain list)."""
    monkeypatch.setattr(world_module, "TYPED_STREAMS_MIN_RUNS", 1 if typed_streams else 10**9)
    mission, plan = mission_and_plan
    setup = MissionSetup(mission, plan, dt_s=0.5, substep_s=0.25)

    def steps(world: World, k: int) -> None:
        for _ in range(k):
            wheels, jet = world.controller_commands()
            ended, up, _ = world.advance(wheels, jet)
            world.finish(ended, up)

    w = World(setup, 2)
    w.reset([1, 2])
    steps(w, 150)
    w.reset([7], runs=[0])
    steps(w, 100)
    lone_a, lone_b = World(setup, 1), World(setup, 1)
    lone_a.reset([7])
    steps(lone_a, 100)
    lone_b.reset([2])
    steps(lone_b, 250)
    assert np.array_equal(w.robot_state[0], lone_a.robot_state[0])
    assert w.runs[0].events == lone_a.runs[0].events
    assert np.array_equal(w.robot_state[1], lone_b.robot_state[0])
    assert w.runs[1].events == lone_b.runs[0].events
    for run, lone in ((w.runs[0], lone_a.runs[0]), (w.runs[1], lone_b.runs[0])):  # every draw made
        for name, gen in run.rngs.items():
            assert gen.bit_generator.state == lone.rngs[name].bit_generator.state, name


def test_the_score_changes_add_up_to_the_score_computed_afresh(tmp_path) -> None:
    """A search-only mission's score is looked at only in runs whose counts changed: each step's
    change of a run's score (the reward's mission part) still adds up to its score computed
    afresh, run by run."""
    path = write_mission(tmp_path, "search", swarm={"count": 10}, tasks=[TASKS[1]], hazards=HAZARDS,
                         phases=PHASES)  # fmt: skip
    mission = load_mission(path)
    plan = plan_mission(mission, seed=1, workers=1)
    world = World(MissionSetup(mission, plan, dt_s=0.5, substep_s=0.25), 3)
    world.reset(SEEDS)
    assert not world.score_timed.any()
    total = np.zeros(3)
    for _ in range(600):
        wheels, jet = world.controller_commands()
        ended, up, change = world.advance(wheels, jet)
        total += change
        world.finish(ended, up)
        if not world.in_agents.any():
            break
    fresh = np.array([run.score._score() for run in world.runs])
    assert fresh.max() > 0  # mines were found
    assert np.allclose(total, fresh, rtol=0, atol=1e-12)


def test_a_placed_mark_is_its_robots_until_the_robot_moves_on(mission_and_plan) -> None:
    """`mark_placed` (the robots `_update_marks` passes by) holds only for a robot whose marking
    object's marker is that robot, at every step of a busy batch driven by the scripted policy,
    and it does hold for robots on their marks; a marking robot's target is its object."""
    from swarm.sim.policy import BatchPolicy

    mission, plan = mission_and_plan
    world = World(MissionSetup(mission, plan, dt_s=0.5, substep_s=0.25), len(SEEDS))
    world.reset(SEEDS)
    policies = BatchPolicy(world.runs)
    placed_steps = 0
    while world.in_agents.any():
        policies.update(np.flatnonzero(world.in_agents.any(axis=1)).tolist())
        wheels, jet = world.controller_commands()
        ended, up, _ = world.advance(wheels, jet)
        world.finish(ended, up)
        for run in world.runs:
            for i in np.flatnonzero(run.mark_placed).tolist():
                assert run.marking[i] >= 0 and run.object_marker[run.marking[i]] == i, (run.b, i)
            for i in np.flatnonzero(run.marking >= 0).tolist():  # `_update_marks` measures to it
                assert np.array_equal(run.target_m[i], run.objects_m[run.marking[i]]), (run.b, i)
            placed_steps += int(np.count_nonzero(run.mark_placed & run.alive))
    assert placed_steps > 100


def test_a_placed_mark_is_forgotten_when_its_robot_unmarks_or_marks_another(mission_and_plan) -> None:
    mission, plan = mission_and_plan
    world = World(MissionSetup(mission, plan, dt_s=0.5, substep_s=0.25), 2)
    world.reset(SEEDS[:2])
    run = world.runs[1]
    run.on_map[:] = True
    run.objects_m = np.array([[30.0, 20.0], [50.0, 25.0]])
    run.object_mine = np.array([-1, -1])
    run.object_marker = np.array([-1, -1])

    def place(i: int, k: int) -> None:
        run.set_command(i, MARK, run.objects_m[k])
        run.robot_state[i, :2] = run.objects_m[k]
        world._update_marks()
        assert run.mark_placed[i] and run.object_marker[k] == i

    place(2, 0)
    run.unmark(2)
    assert not run.mark_placed[2] and run.object_marker[0] == -1
    place(2, 0)
    run.set_command(2, MARK, run.objects_m[1])  # on to another object: not placed there yet
    assert not run.mark_placed[2]
    place(4, 1)
    run.lose(4, "failure")
    assert not run.mark_placed[4] and run.object_marker[1] == -1
    assert not world.mark_placed[0].any()  # the other run's robots are untouched


def _numpy_targets(world: World) -> tuple[np.ndarray, np.ndarray]:
    """The controller's target and drive mask as first written in numpy, whole arrays at a time."""
    from swarm.sim.runview import FOLLOW, LOITER, RELAY, RETURN

    xy = world.flat("robot_state")[:, :2]
    command = world.flat("command")
    done = world.routes.done()
    steer = world.routes.steer_points(xy, world.flat("submersion") > GROUND_SUBMERSION)
    gap = steer - xy
    off_station = np.hypot(gap[:, 0], gap[:, 1]) > world_module.STATION_KEEP_M
    follow = (command == FOLLOW) | (command == RETURN)
    routed = follow | ((command == MARK) & ~done)
    target = np.where(routed[:, None], steer, world.flat("target_m"))
    hold = (command == LOITER) | (command == RELAY)
    moving = world.flat("alive") & world.flat("on_map") & ~hold & ~(follow & done & ~off_station)
    return target, moving


def test_the_controllers_targets_are_the_numpy_rules_at_every_step(mission_and_plan, monkeypatch) -> None:
    """`_command_targets` (one compiled pass) gives the target and drive mask the numpy rules give,
    float for float, at every step of a busy batch under the scripted policy (following, marking,
    loitering, relaying, keeping station and drifting off it)."""
    from swarm.sim.policy import BatchPolicy

    mission, plan = mission_and_plan
    world = World(MissionSetup(mission, plan, dt_s=0.5, substep_s=0.25), len(SEEDS))
    world.reset(SEEDS)
    policies = BatchPolicy(world.runs)
    seen, seen_args = [], []
    kernel = world_module._command_targets

    def checked(*args) -> None:
        kernel(*args)
        target, moving = _numpy_targets(world)
        assert np.array_equal(args[-2], target) and np.array_equal(args[-1], moving)
        seen.append(int(np.count_nonzero(moving)))
        seen_args[:] = [(args[-2], args[-1])]

    monkeypatch.setattr(world_module, "_command_targets", checked)
    while world.in_agents.any():
        policies.update(np.flatnonzero(world.in_agents.any(axis=1)).tolist())
        wheels, jet = world.controller_commands()
        ended, up, _ = world.advance(wheels, jet)
        world.finish(ended, up)
    assert len(seen) > 500 and len(set(seen)) > 5  # robots start, stop and start again
    # keeping station: back once drifted `STATION_KEEP_M` off the route's end, still within it
    world.reset(SEEDS)
    run = world.runs[1]
    run.on_map[:] = True
    end = np.array([40.0, 20.0])
    for i, offset in ((0, 1.5), (1, 0.5)):
        run.set_route(i, np.array([[35.0, 20.0], end]))
        run.routes.cursor[i] = run.routes.end[i]
        run.robot_state[i, :2] = end + np.array([offset, 0.0])
    world.controller_commands()
    target, moving = seen_args[-1]
    assert moving[world.n] and not moving[world.n + 1]
    assert np.array_equal(target[world.n], end)


def test_a_loss_at_sea_is_logged_when_its_clock_struck_not_at_the_end_of_the_stride(tmp_path) -> None:
    """The swim in is skipped in strides (`World.fast_forward`); a failure in one is logged at the
    first event of its exponential clock, so the logged times are the truncated exponential's:
    E[t | t < T] = 1/rate - T exp(-rate T) / (1 - exp(-rate T)) after release (relay used to log
    all of its 18 sea losses at 5999.5 s, the end of the swim)."""
    from swarm.sim.run import simulate_batch

    quiet = {"surf": {"wave_height_m": 0.3, "flip_probability": 0.0}, "immobilization": {"per_km": 0.0}}
    path = write_mission(
        tmp_path,
        "swim",
        swarm={"count": 20},
        launch={"platform": "by_hand", "points": ["launch_1"], "offshore_m": 1000, "interval_s": 0},
        phases={
            "sea_transit": {"time_limit_s": 3000},
            "surf_crossing": {"time_limit_s": 300},
            "beach_operations": {"time_limit_s": 60},
            "return_to_sea": {"enabled": False},
        },
        hazards={**quiet, "attrition": {"mtbf_h": 0.5}},
    )
    mission = load_mission(path)
    plan = plan_mission(mission, seed=mission.seed, workers=1)
    swim_s = mission.launch.release_offshore_m / mission.robot.swim_speed_mps
    rate = 1.0 / (mission.hazards.attrition.mtbf_h * 3600.0)
    at_sea = [
        x["t_s"]
        for log in simulate_batch(mission, range(6), plan=plan)
        for x in log.losses
        if x["phase"] == "sea_transit" and x["cause"] == "failure"
    ]
    times = [t for t in at_sea if t < swim_s]  # the swim in, before the map's own water
    assert len(times) > 40 and len(set(times)) > 0.9 * len(times)  # spread, not one stride's end
    assert min(times) > 0.0
    expected = 1 / rate - swim_s * math.exp(-rate * swim_s) / -math.expm1(-rate * swim_s)
    sd = math.sqrt(np.var(times) / len(times))
    assert abs(np.mean(times) - expected) < 4 * sd, (np.mean(times), expected, sd)
