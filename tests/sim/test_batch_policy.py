"""`BatchPolicy` updates a run's scripted policy only when it may act
(`ScriptedPolicy.quiet_until_s`, new events, a new radio graph, a battery at its reserve). The
contract that makes that safe, checked step by step on a busy run: whenever a step is quiet by
those rules, `update` changes nothing, and when only the radio graph is new it does no more than
`spread`. And a batch that skips the quiet updates gives the same
runs as the runs alone, with a battery reserve reached as well."""

from __future__ import annotations

import numpy as np
import pytest
from test_world import HAZARDS, PHASES, SEEDS, TASKS, _same
from tiny_missions import write_mission

from swarm.mission.load import load_mission
from swarm.mission.plan import plan_mission
from swarm.sim.policy import ScriptedPolicy
from swarm.sim.run import simulate, simulate_batch
from swarm.sim.setup import MissionSetup
from swarm.sim.world import World

#: A battery that reaches its reserve in beach operations (about 10 Wh used by then).
LOW_BATTERY = {**HAZARDS, "battery": {"capacity_wh": 16.0, "reserve_fraction": 0.4}}
#: The tasks without the clearance, whose watch (from 900 s before it) spans the whole short run.
NO_CLEARANCE = [{**task, "clearance": None} if task["type"] == "search" else task for task in TASKS]


#: Beach operations ending between two allocations (every 5 s from 0): the return to sea has to
#: wake the policy itself.
PHASES_OFF_BEAT = {**PHASES, "beach_operations": {"time_limit_s": 422.5}}


def _mission(tmp_path, hazards: dict, tasks: list[dict] = TASKS, phases: dict = PHASES):
    path = write_mission(tmp_path, "busy", swarm={"count": 10}, tasks=tasks, hazards=hazards, phases=phases)
    mission = load_mission(path)
    return mission, plan_mission(mission, seed=mission.seed, workers=1)


def _state(run, policy: ScriptedPolicy) -> tuple:
    """Everything `update` may change: commands, targets, marks, roles, routes, events, the work
    items and the policy's own schedule and holds."""
    r = run.routes
    return (
        run.command.tobytes(),
        run.target_m.tobytes(),
        run.marking.tobytes(),
        run.role.tobytes(),
        r.start.tobytes(),
        r.end.tobytes(),
        r.cursor.tobytes(),
        r.sensing_from.tobytes(),
        len(run.events),
        [(it.kind, it.obj, it.taken_by, it.audience.tobytes(), it.start_m.tobytes()) for it in policy.items],
        policy.quiet_until_s(),
        policy.events_read,
        policy.links_read,
        sorted(policy._held),
        sorted(policy._waiting),
        policy._news,
    )


@pytest.mark.parametrize(
    ("tasks", "hazards"),
    [(TASKS, HAZARDS), (NO_CLEARANCE, LOW_BATTERY)],
    ids=["busy", "low battery, no clearance"],
)
def test_a_quiet_step_changes_nothing(tmp_path, tasks, hazards) -> None:
    mission, plan = _mission(tmp_path, hazards, tasks, PHASES_OFF_BEAT)
    world = World(MissionSetup(mission, plan, dt_s=0.5, substep_s=0.25), 1)
    world.reset([SEEDS[0]])
    run = world.runs[0]
    policy = ScriptedPolicy(run)
    battery = mission.hazards.battery
    reserve_wh = battery.reserve_fraction * battery.capacity_wh
    quiet = loud = heard = 0
    while world.in_agents.any():
        t = float(world.t_s[0])
        quiet_but_radio = (
            t + 1e-6 < policy.quiet_until_s()
            and policy.events_read == len(run.events)
            and not (world.energy_wh[0] <= reserve_wh).any()
        )
        if quiet_but_radio and policy.links_read == int(world.links_version[0]):
            before = _state(run, policy)
            policy.update()
            assert _state(run, policy) == before, f"t = {t}"
            quiet += 1
        elif quiet_but_radio:  # a new radio graph alone: `update` does what `spread` does, no more
            policy.spread()
            spread = _state(run, policy)
            policy.update()
            assert _state(run, policy) == spread, f"t = {t}"
            heard += 1
        else:
            policy.update()
            loud += 1
        wheels, jet = world.controller_commands()
        ended, up, _ = world.advance(wheels, jet)
        world.finish(ended, up)
    assert quiet > 300 and loud > 300 and heard > 50, (quiet, loud, heard)  # each kind many times
    kinds = {ev["kind"] for ev in run.events}
    assert "takeover" in kinds, kinds
    if tasks is TASKS:
        assert "clearance" in kinds, kinds
    if hazards is LOW_BATTERY:
        assert "battery_reserve" in kinds


def test_a_batch_with_batteries_at_their_reserve_is_the_same_as_its_runs_alone(tmp_path) -> None:
    mission, plan = _mission(tmp_path, LOW_BATTERY)
    logs = simulate_batch(mission, SEEDS, plan=plan)
    reserves = 0
    for seed, log in zip(SEEDS, logs, strict=True):
        _same(simulate(mission, seed=seed, plan=plan), log)
        reserves += sum(ev["kind"] == "battery_reserve" for ev in log.events)
    assert reserves >= len(SEEDS)
    assert np.isfinite(logs[0].times_s).all()


def test_late_markers_are_the_markers_whose_arrival_is_too_late(tmp_path) -> None:
    """`_late_markers` (one compiled pass, asked at every step of the clearance's watch) picks the
    markers on their way whose `_arrivals_s` is at least the time left, at every step of a busy
    run and for times left that split them: late and on time both, many times."""
    from swarm.sim.policy import BatchPolicy

    mission, plan = _mission(tmp_path, HAZARDS)
    world = World(MissionSetup(mission, plan, dt_s=0.5, substep_s=0.25), len(SEEDS))
    world.reset(SEEDS)
    batch = BatchPolicy(world.runs)
    late = on_time = 0
    while world.in_agents.any():
        batch.update(np.flatnonzero(world.in_agents.any(axis=1)).tolist())
        for policy in batch.policies:
            who = policy._markers_on_the_way()
            arrivals = policy._arrivals_s(who)
            for left in (*arrivals, *(arrivals + 1e-9), 0.0, np.inf):
                expected = who[arrivals >= left]
                assert np.array_equal(policy._late_markers(float(left)), expected)
                late += len(expected)
                on_time += len(who) - len(expected)
        wheels, jet = world.controller_commands()
        ended, up, _ = world.advance(wheels, jet)
        world.finish(ended, up)
    assert late > 100 and on_time > 100, (late, on_time)
