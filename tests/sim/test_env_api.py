"""`SwarmEnv` against the PettingZoo API: PettingZoo's own API tests (parallel and AEC), the
registry entries, multi-step determinism, robots lost for good, truncation at the time limit,
mission overrides, observation and state shapes, and wheel actions that move robots.

PettingZoo's `parallel_seed_test` compares a single step only, so determinism is checked here over
500 steps of a hazardous mission, every returned dict, `state()` and the event log included.
(`render_test` lives in test_render.py.)"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
import pettingzoo
import pytest
from pettingzoo.test import api_test, parallel_api_test
from tiny_missions import write_mission

import swarm.sim
from swarm.errors import InputError, SwarmError
from swarm.sim.env import SwarmEnv
from swarm.sim.hazards import CAUSES
from swarm.sim.layout import STATE_FIELDS

#: Random failures every 0.1 h (360 s): about half of 12 robots are lost within 500 steps (250 s).
HAZARDOUS = {"attrition": {"mtbf_h": 0.1}}
#: Random failures every 0.01 h (36 s): every robot is lost within a few hundred steps.
DEADLY = {"attrition": {"mtbf_h": 0.01}}
#: Nothing takes a robot in the few steps these tests run.
QUIET = {
    "attrition": {"mtbf_h": 1.0e9},
    "surf": {"damage_h50_m": 10.0},
    "immobilization": {"per_km": 0.0},
    "rocks": {"damage_per_km": 0.0, "collision_damage_probability": 0.0},
}
#: Two points on dry soft sand of test_small, with room to drive east.
BEACH_POINTS = [[45.0, 56.0], [95.0, 56.0]]
DETERMINISM_STEPS = 500


@pytest.fixture(scope="module")
def missions(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("env_api")
    beach_launch = {"platform": "beach", "points": BEACH_POINTS, "interval_s": 0}
    return {
        "hazardous": write_mission(d, "hazardous", swarm={"count": 12}, hazards=HAZARDOUS),
        "deadly": write_mission(d, "deadly", swarm={"count": 8}, hazards=DEADLY),
        "quiet": write_mission(d, "quiet", hazards=QUIET),
        "beach": write_mission(
            d,
            "beach",
            swarm={"count": 2},
            launch=beach_launch,
            tasks=[{"type": "beacon", "points": [[20.0, 52.0]]}],
            hazards=QUIET,
        ),
    }


def _wheel_actions(rng: np.random.Generator, env: SwarmEnv) -> dict[str, np.ndarray]:
    """Random wheel actions for every possible agent (so the draws do not depend on who is alive),
    handed only to the live ones."""
    acts = rng.uniform(-1.0, 1.0, (len(env.possible_agents), 3)).astype(np.float32)
    return {a: acts[env.agent_index[a]] for a in env.agents}


def _command_actions(rng: np.random.Generator, env: SwarmEnv) -> dict[str, dict[str, Any]]:
    x0, y0, x1, y1 = env.beach.bounds_m
    n = len(env.possible_agents)
    cmds = rng.integers(0, len(swarm.sim.COMMANDS), n)
    targets = rng.uniform([x0, y0], [x1, y1], (n, 2)).astype(np.float32)
    index = env.agent_index
    return {a: {"command": int(cmds[index[a]]), "target": targets[index[a]]} for a in env.agents}


def _actions(rng: np.random.Generator, env: SwarmEnv) -> dict[str, Any]:
    return _wheel_actions(rng, env) if env.action_mode == "wheels" else _command_actions(rng, env)


# PettingZoo's own API tests --------------------------------------------------------------------------
@pytest.mark.parametrize("action_mode", ["wheels", "command"])
def test_pettingzoo_parallel_api_test_passes(missions: dict[str, Path], action_mode: str) -> None:
    """Two episodes of 150 steps with losses (mtbf 0.1 h) and the truncation at max_cycles; the test's
    own warnings (an agent given a dict entry after it died, ...) count as failures."""
    env = swarm.sim.parallel_env(mission=missions["hazardous"], action_mode=action_mode, max_cycles=150)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        parallel_api_test(env, num_cycles=200)
    assert not env.agents  # the episode ran to its end (truncation at 150 steps)


def test_pettingzoo_aec_api_test_passes(missions: dict[str, Path]) -> None:
    aec = swarm.sim.env(mission=missions["hazardous"], max_cycles=40)
    assert isinstance(aec, pettingzoo.AECEnv)
    assert isinstance(aec.unwrapped, SwarmEnv)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        api_test(aec, num_cycles=60)


def test_registered_in_both_pettingzoo_registries(missions: dict[str, Path]) -> None:
    assert swarm.sim.ENV_ID == "surf_swarm/Swarm-v0"
    assert swarm.sim.ENV_ID in pettingzoo.parallel_registry
    assert swarm.sim.ENV_ID in pettingzoo.aec_registry
    par = pettingzoo.make("parallel", "surf_swarm/Swarm-v0", mission=missions["quiet"], max_cycles=7)
    assert isinstance(par, SwarmEnv)
    assert par.max_steps == 7  # make()'s max_cycles reaches the environment
    assert par.possible_agents == [f"robot_{i}" for i in range(6)]
    aec = pettingzoo.make("aec", "surf_swarm/Swarm-v0", mission=missions["quiet"], action_mode="command")
    assert isinstance(aec, pettingzoo.AECEnv)
    assert isinstance(aec.unwrapped, SwarmEnv)
    assert aec.unwrapped.action_mode == "command"
    aec.reset(seed=0)
    assert aec.agent_selection == "robot_0"
    assert aec.agents == par.possible_agents


# determinism ---------------------------------------------------------------------------------------------
def _episode(env: SwarmEnv, seed: int | None, steps: int, action_seed: int = 2024) -> Iterator[tuple]:
    """(reset outputs, state), then per step (obs, rewards, terms, truncs, infos, state)."""
    rng = np.random.default_rng(action_seed)
    obs, infos = env.reset(seed=seed)
    yield obs, infos, env.state()
    for _ in range(steps):
        if not env.agents:
            return
        out = env.step(_actions(rng, env))
        yield (*out, env.state())


def _assert_same_step(a: tuple, b: tuple, k: int) -> None:
    *dicts_a, state_a = a
    *dicts_b, state_b = b
    for da, db in zip(dicts_a, dicts_b, strict=True):
        assert list(da) == list(db), f"step {k}: agents differ"
        for agent in da:
            if isinstance(da[agent], np.ndarray):
                np.testing.assert_array_equal(da[agent], db[agent], err_msg=f"step {k}, {agent}")
            else:
                assert da[agent] == db[agent], f"step {k}, {agent}: {da[agent]!r} != {db[agent]!r}"
    np.testing.assert_array_equal(state_a, state_b, err_msg=f"step {k}: state()")


@pytest.mark.slow
def test_same_seed_same_episode_over_500_steps(missions: dict[str, Path]) -> None:
    env1 = swarm.sim.parallel_env(mission=missions["hazardous"])
    env2 = swarm.sim.parallel_env(mission=missions["hazardous"])
    seed7 = []
    for k, (a, b) in enumerate(
        zip(_episode(env1, 7, DETERMINISM_STEPS), _episode(env2, 7, DETERMINISM_STEPS), strict=True)
    ):
        _assert_same_step(a, b, k)
        assert env1.events == env2.events, f"step {k}: events differ"
        seed7.append(a)
    assert len(seed7) == DETERMINISM_STEPS + 1
    losses = [(ev["robot"], ev["t_s"]) for ev in env1.events if ev["kind"] == "loss"]
    assert 2 <= len(losses) < 12, "the mission must lose some robots, not all, within 500 steps"
    phase7 = env1.wave_phase_s

    # another seed (same actions): other waves, other losses, another episode
    seed8 = list(_episode(env1, 8, DETERMINISM_STEPS))
    assert env1.wave_phase_s != phase7
    assert [(ev["robot"], ev["t_s"]) for ev in env1.events if ev["kind"] == "loss"] != losses
    differs = 0
    for a, b in zip(seed7, seed8, strict=False):
        try:
            _assert_same_step(a, b, 0)
        except AssertionError:
            differs += 1
    assert differs > DETERMINISM_STEPS // 2


@pytest.mark.slow
@pytest.mark.parametrize("action_mode", ["wheels", "command"])
def test_reset_with_the_same_seed_replays_the_episode(missions: dict[str, Path], action_mode: str) -> None:
    """A used environment reset with a seed gives the episode a fresh one gives (what Monte Carlo
    studies that reuse one environment across runs rely on). Command mode plans routes with OMPL
    during the run (the "return" command), so it checks that the route planner is reseeded too."""
    fresh = swarm.sim.parallel_env(mission=missions["hazardous"], action_mode=action_mode)
    used = swarm.sim.parallel_env(mission=missions["hazardous"], action_mode=action_mode)
    for _ in _episode(used, 3, 400, action_seed=99):  # an earlier, different episode
        pass
    for k, (a, b) in enumerate(zip(_episode(fresh, 7, 400), _episode(used, 7, 400), strict=True)):
        try:
            _assert_same_step(a, b, k)
        except AssertionError as err:
            raise AssertionError(
                f"{action_mode}: reset(seed=7) on a used environment diverges from a fresh one at step "
                f"{k}. Look for state that outlives reset() in SwarmEnv._reset_state (swarm/sim/env.py), "
                f"e.g. the Router's call counter (self.router.calls), which seeds every OMPL path it "
                f"plans and must restart at 0 each episode.\n{err}"
            ) from err
    assert fresh.events == used.events
    if action_mode == "command":
        assert used.router.calls > 0, "the replay must exercise OMPL replanning"


def test_reset_without_a_seed_continues_the_seeded_stream(missions: dict[str, Path]) -> None:
    """Gymnasium's convention (which PettingZoo follows): seed the first reset, then `reset()` with no
    seed goes on deterministically from it. Vector wrappers (SuperSuit's MarkovVectorEnv, gymnasium's
    autoreset) reset finished episodes without a seed, so a seeded training run is reproducible only
    if this holds."""
    second = []
    for _ in range(2):
        env = swarm.sim.parallel_env(mission=missions["hazardous"], max_cycles=100)
        first = list(_episode(env, 5, 100))
        second.append((list(_episode(env, None, 100)), env.wave_phase_s, list(env.events)))
    assert len(first) == 101
    (run_a, phase_a, events_a), (run_b, phase_b, events_b) = second
    assert phase_a == phase_b and events_a == events_b, (
        "two environments seeded alike give different second (unseeded) episodes: "
        f"wave phase {phase_a} vs {phase_b}. Cause: SwarmEnv._reset_state (swarm/sim/env.py) builds "
        "np.random.SeedSequence(seed) from seed=None, i.e. fresh OS entropy. Fix: keep the episode's "
        "SeedSequence and, on reset(seed=None) after a seeded reset, use self._seed_seq.spawn(1)[0] "
        "(seeded resets stay as they are)."
    )
    for k, (a, b) in enumerate(zip(run_a, run_b, strict=True)):
        _assert_same_step(a, b, k)


# lost robots ------------------------------------------------------------------------------------------
def test_lost_robots_report_once_then_leave_for_good(missions: dict[str, Path]) -> None:
    env = swarm.sim.parallel_env(mission=missions["deadly"])
    possible = list(env.possible_agents)
    spaces = {a: (env.observation_space(a), env.action_space(a)) for a in possible}
    rng = np.random.default_rng(5)
    obs, infos = env.reset(seed=4)
    assert list(obs) == list(infos) == possible
    gone: set[str] = set()
    reported: dict[str, str] = {}
    while env.agents:
        before = list(env.agents)
        assert not gone & set(before), "a lost robot came back into env.agents"
        assert set(before) <= set(possible)
        obs, rewards, terms, truncs, infos = env.step(_wheel_actions(rng, env))
        for d in (obs, rewards, terms, truncs, infos):
            assert list(d) == before, "every live agent, and only those, gets an entry"
        for a in before:
            if terms[a]:
                assert not truncs[a]
                reason = infos[a].get("lost_reason")
                if reason is not None:  # a loss (not a recovery)
                    assert reason in CAUSES
                    assert infos[a]["end_reason"] == reason
                    reported[a] = reason
                assert env.observation_space(a).contains(obs[a])
                assert a not in env.agents
                gone.add(a)
            elif not truncs[a]:
                assert a in env.agents
                assert "lost_reason" not in infos[a] and "end_reason" not in infos[a]
    assert len(reported) >= len(possible) // 2, f"only {len(reported)} losses with mtbf 0.01 h"
    loss_events = [(ev["robot"], ev["cause"]) for ev in env.events if ev["kind"] == "loss"]
    assert sorted(loss_events) == sorted(reported.items()), "one loss event per lost robot, same cause"
    assert env.possible_agents == possible, "possible_agents never change"
    assert len(set(env.possible_agents)) == len(env.possible_agents)
    alive = env.state()[: len(possible) * len(STATE_FIELDS)].reshape(len(possible), -1)[:, 0]
    assert not alive.any()
    for a in possible:  # spaces for every id, the same objects as before the losses
        assert env.observation_space(a) is spaces[a][0]
        assert env.action_space(a) is spaces[a][1]
    # a new episode brings every robot back, under the same ids
    obs, _ = env.reset(seed=5)
    assert list(obs) == env.agents == possible


# truncation ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("max_cycles", [1, 12])
def test_max_cycles_truncates_every_live_agent(missions: dict[str, Path], max_cycles: int) -> None:
    """12 steps (6 s): some robots are still waiting on the boat (one leaves every 2 s); they are
    live agents too and are truncated with the rest."""
    env = swarm.sim.parallel_env(mission=missions["quiet"], max_cycles=max_cycles)
    env.reset(seed=0)
    for k in range(1, max_cycles + 1):
        live = list(env.agents)
        obs, _, terms, truncs, infos = env.step({a: np.ones(3, np.float32) for a in live})
        assert list(truncs) == live
        if k < max_cycles:
            assert not any(truncs.values()) and not any(terms.values())
            assert env.agents == live
    assert live == env.possible_agents
    assert all(truncs.values()) and not any(terms.values())
    for a in live:
        assert infos[a]["end_reason"] == "time_limit"
        assert "lost_reason" not in infos[a]
        assert env.observation_space(a).contains(obs[a])
    assert env.agents == []
    if max_cycles == 12:
        assert {i["phase"] for i in infos.values()} >= {"waiting", "sea_transit"}


def test_max_cycles_beyond_the_time_limit_is_the_time_limit(missions: dict[str, Path]) -> None:
    env = swarm.sim.parallel_env(mission=missions["quiet"], max_cycles=10**9)
    # 300 + 300 + 300 s of phases, 0.5 s steps
    assert env.max_steps == round(env.time_limit_s / env.config.dt_s) == 1800


# overrides ----------------------------------------------------------------------------------------------
def test_overrides_change_the_swarm_size(missions: dict[str, Path]) -> None:
    env = swarm.sim.parallel_env(mission=missions["quiet"], overrides={"swarm.count": 9})
    assert env.possible_agents == [f"robot_{i}" for i in range(9)]
    assert env.state_space.shape == (9 * len(STATE_FIELDS) + 5,)
    obs, _ = env.reset(seed=0)
    assert len(obs) == 9
    assert all(env.observation_space(a) is env.observation_space(a) for a in env.possible_agents)


@pytest.mark.parametrize("key", ["swarm.cuont", "hazards.attrition.mtbf"])
def test_a_bad_override_key_is_an_input_error_naming_it(missions: dict[str, Path], key: str) -> None:
    with pytest.raises(InputError) as err:
        swarm.sim.parallel_env(mission=missions["quiet"], overrides={key: 9})
    assert key in str(err.value)


# observations and state -----------------------------------------------------------------------------------
@pytest.mark.parametrize("action_mode", ["wheels", "command"])
def test_observations_and_state_stay_in_their_spaces(missions: dict[str, Path], action_mode: str) -> None:
    env = swarm.sim.parallel_env(mission=missions["hazardous"], action_mode=action_mode)
    size = env.layout.size
    assert len(env.layout.names) == size
    space = env.observation_space("robot_0")
    assert isinstance(space, gymnasium.spaces.Box)
    assert space.shape == (size,) and space.dtype == np.float32
    assert np.all(np.isfinite(space.low)) and np.all(np.isfinite(space.high))
    assert isinstance(env.state_space, gymnasium.spaces.Box)
    assert env.state_space.dtype == np.float32
    rng = np.random.default_rng(17)
    obs, _ = env.reset(seed=17)
    checked = 0
    for k in range(201):
        for a, o in obs.items():
            assert isinstance(o, np.ndarray) and o.dtype == np.float32 and o.shape == (size,)
            bad = np.flatnonzero((o < space.low) | (o > space.high) | ~np.isfinite(o))
            assert space.contains(o), (k, a, [(env.layout.names[j], float(o[j])) for j in bad])
            checked += 1
        state = env.state()
        assert state.shape == env.state_space.shape and state.dtype == np.float32
        assert env.state_space.contains(state)
        if not env.agents:
            break
        acts = _actions(rng, env)
        assert all(env.action_space(a).contains(v) for a, v in acts.items())
        obs, *_ = env.step(acts)
    assert checked > 12 * 150


# wheel actions --------------------------------------------------------------------------------------------
def _drive(env: SwarmEnv, action: list[float], steps: int) -> tuple[np.ndarray, np.ndarray]:
    env.reset(seed=0)
    assert env.on_map.all()  # placed on the beach: on the map from the start
    start = env.robot_state.copy()
    for _ in range(steps):
        env.step({a: np.array(action, np.float32) for a in env.agents})
    return start, env.robot_state.copy()


def test_full_forward_wheels_drive_along_the_heading_near_top_wheel_speed(missions: dict[str, Path]) -> None:
    env = swarm.sim.parallel_env(mission=missions["beach"])
    dt = env.config.dt_s
    vmax = env.limits.max_wheel_speed_mps
    start, mid = _drive(env, [1.0, 1.0, 0.0], 4)  # 2 s to get up to speed
    for _ in range(6):
        env.step({a: np.array([1.0, 1.0, 0.0], np.float32) for a in env.agents})
    end = env.robot_state
    heading = np.column_stack([np.cos(start[:, 2]), np.sin(start[:, 2])])
    d = end[:, :2] - start[:, :2]
    along = np.sum(d * heading, axis=1)
    assert np.all(along > 0.9 * np.hypot(d[:, 0], d[:, 1])), "forward is along the heading"
    speed = np.hypot(*(end[:, :2] - mid[:, :2]).T) / (6 * dt)
    # soft sand: slip near 0.1 costs about a tenth of the wheel speed
    assert np.all(speed > 0.75 * vmax) and np.all(speed < 1.02 * vmax), (speed, vmax)
    assert np.allclose(end[:, 2], start[:, 2], atol=0.05), "equal wheels do not turn"


def test_wheel_actions_reverse_turn_and_hold(missions: dict[str, Path]) -> None:
    env = swarm.sim.parallel_env(mission=missions["beach"])
    start, end = _drive(env, [-1.0, -1.0, 0.0], 6)
    heading = np.column_stack([np.cos(start[:, 2]), np.sin(start[:, 2])])
    assert np.all(np.sum((end - start)[:, :2] * heading, axis=1) < -1.0), "full reverse backs up"
    start, end = _drive(env, [1.0, -1.0, 0.0], 4)
    assert np.all(end[:, 2] - start[:, 2] < -1.0), "left forward, right back turns clockwise"
    assert np.all(np.hypot(*(end - start)[:, :2].T) < 0.5), "a spin turn stays in place"
    start, end = _drive(env, [-1.0, 1.0, 0.0], 4)
    assert np.all(end[:, 2] - start[:, 2] > 1.0), "left back, right forward turns anticlockwise"
    start, end = _drive(env, [0.0, 0.0, 1.0], 6)  # no wheels; the jet pushes only in water
    assert np.all(np.hypot(*(end - start)[:, :2].T) < 0.05)


def test_wheel_actions_do_not_move_robots_before_they_reach_the_map(missions: dict[str, Path]) -> None:
    """Tiny mission: one robot leaves the boat every 2 s and swims 20 m before it appears."""
    env = swarm.sim.parallel_env(mission=missions["quiet"])
    env.reset(seed=0)
    start = env.robot_state.copy()
    for _ in range(4):
        env.step({a: np.ones(3, np.float32) for a in env.agents})
    assert not env.on_map.any()
    np.testing.assert_array_equal(env.robot_state, start)


def _continue(env: SwarmEnv, steps: int, action_seed: int) -> list[tuple]:
    rng = np.random.default_rng(action_seed)
    out = []
    for _ in range(steps):
        if not env.agents:
            break
        out.append((*env.step(_actions(rng, env)), env.state()))
    return out


@pytest.mark.parametrize("how", ["pickle", "deepcopy"])
def test_a_copied_env_goes_on_as_the_original(missions: dict[str, Path], how: str) -> None:
    """SuperSuit's `concat_vec_envs_v1` copies an env with cloudpickle: the copy's robots once never
    moved (its runs wrote to arrays pickle had cut loose from the world's). Both go on alike."""
    import copy
    import pickle

    env = swarm.sim.parallel_env(mission=missions["hazardous"])
    for _ in _episode(env, 3, 40):
        pass
    twin = pickle.loads(pickle.dumps(env)) if how == "pickle" else copy.deepcopy(env)
    start = env.robot_state.copy()
    ours, theirs = _continue(env, 120, 5), _continue(twin, 120, 5)
    assert len(ours) == len(theirs) == 120
    for k, (a, b) in enumerate(zip(ours, theirs, strict=True)):
        _assert_same_step(a, b, k)
    assert env.events == twin.events
    moved = np.hypot(*(twin.robot_state[:, :2] - start[:, :2]).T)
    assert (moved[twin.alive] > 1.0).all()  # every robot still in the mission drove on
    assert not np.shares_memory(env.robot_state, twin.robot_state)


def test_a_copied_vector_env_goes_on_as_the_original(missions: dict[str, Path]) -> None:
    import pickle

    vec = swarm.sim.vector_env(mission=missions["hazardous"], num_envs=3, seed=4)
    vec.reset()
    rng = np.random.default_rng(1)
    actions = rng.uniform(-1, 1, (80, 3, vec.n, 3)).astype(np.float32)
    for a in actions[:20]:
        vec.step(a)
    twin = pickle.loads(pickle.dumps(vec))
    for a in actions[20:]:
        got, want = twin.step(a), vec.step(a)
        for x, y in zip(got[:4], want[:4], strict=True):
            np.testing.assert_array_equal(x, y)
    np.testing.assert_array_equal(twin.world.robot_state, vec.world.robot_state)
    assert [r.events for r in twin.world.runs] == [r.events for r in vec.world.runs]


def _warm(env: SwarmEnv, steps: int = 20) -> SwarmEnv:
    env.reset(seed=0)
    for _ in range(steps):
        env.step(_actions(np.random.default_rng(0), env))
    return env


#: (action mode, what the first live agent is given, the error's words)
BAD_ACTIONS = [
    ("wheels", np.array([np.nan, 0.0, 0.0], np.float32), "action of robot_0: found array([nan,"),
    ("wheels", 1.0, "action of robot_0: found 1.0, expected 3 finite numbers"),
    ("wheels", np.zeros(4), "action of robot_0: found array([0., 0., 0., 0.]), expected 3"),
    ("wheels", np.array([None, 1, 2], dtype=object), "action of robot_0: found array([None, 1, 2]"),
    ("wheels", np.array(["1", "0", "0.5"]), "action of robot_0: found array(['1', '0', '0.5']"),
    ("command", {"command": 1, "target": np.array([np.nan, 40.0])}, "action of robot_0: found {'command': 1"),
    ("command", {"command": 1, "target": np.array([1e6, 1e6])}, "on the map, x 0..120, y 0..80"),
    ("command", {"command": 1.7, "target": np.array([60.0, 40.0])}, "a whole number 0..5"),
    ("command", {"command": 1}, 'expected {"command": a whole number 0..5'),
    ("command", {"command": "goto", "target": np.array([60.0, 40.0])}, "found {'command': 'goto'"),
    ("command", {"command": 9, "target": np.array([60.0, 40.0])}, "a whole number 0..5"),
]


@pytest.mark.parametrize(("action_mode", "given", "says"), BAD_ACTIONS)
def test_a_bad_action_is_refused_and_no_action_of_the_step_applied(
    missions: dict[str, Path], action_mode: str, given: Any, says: str
) -> None:
    """Each was numpy's error from deep inside, or silently wrong (NaN state for good, a NaN goal in
    every later observation, a target off the map driven to); and the robots before the bad one
    had their commands already set."""
    env = _warm(swarm.sim.parallel_env(mission=missions["quiet"], action_mode=action_mode))
    actions = _actions(np.random.default_rng(1), env)
    actions = {a: v for a, v in actions.items() if a != "robot_0"} | {"robot_0": given}  # last
    state, command, target = env.robot_state.copy(), env.command.copy(), env.target_m.copy()
    with pytest.raises(SwarmError) as err:
        env.step(actions)
    assert says in str(err.value) and "\n" not in str(err.value)
    np.testing.assert_array_equal(env.robot_state, state)
    np.testing.assert_array_equal(env.command, command)
    np.testing.assert_array_equal(env.target_m, target)


def test_bad_calls_to_the_parallel_env_say_what_was_expected(missions: dict[str, Path]) -> None:
    mission = missions["quiet"]
    env = swarm.sim.parallel_env(mission=mission)
    with pytest.raises(SwarmError, match=r"step\(\) before reset\(\)"):
        env.step({a: np.zeros(3) for a in env.possible_agents})
    last = f"robot_{env.n - 1}"
    for agent in ("robot_99", None, 0):
        with pytest.raises(SwarmError, match=rf"agent {agent!r}, expected one of robot_0 \.\. {last}"):
            env.action_space(agent)
        with pytest.raises(SwarmError, match="expected one of robot_0"):
            env.observation_space(agent)
    assert env.action_space(last) is env.action_space("robot_0")  # one object, as PettingZoo wants
    for seed in (-1, 2.5, "7", True):
        with pytest.raises(SwarmError, match=rf"seed {seed!r}, expected None or a whole number >= 0"):
            env.reset(seed=seed)
    env.reset(seed=np.int64(3))
    with pytest.raises(
        SwarmError, match=rf"an action for 'robot_99', expected agent ids robot_0 \.\. {last}"
    ):
        env.step({"robot_99": np.zeros(3)})
    with pytest.raises(SwarmError, match="actions of type list, expected a dict of agent id to action"):
        env.step([np.zeros(3)] * 4)
    for max_cycles in (0, -1, 2.5, "3"):
        with pytest.raises(
            SwarmError, match=rf"max_cycles {max_cycles!r}, expected None or a whole number >= 1"
        ):
            swarm.sim.parallel_env(mission=mission, max_cycles=max_cycles)
    with pytest.raises(SwarmError, match=r"overrides \['swarm.count=5'\], expected a dict of dotted keys"):
        swarm.sim.parallel_env(mission=mission, overrides=["swarm.count=5"])
    with pytest.raises(SwarmError, match=r"config \{'dt_s': 0.5\}, expected a SimConfig"):
        swarm.sim.parallel_env(mission=mission, config={"dt_s": 0.5})
    with pytest.raises(SwarmError, match="mission None, expected a mission file's path or a Mission"):
        swarm.sim.parallel_env(mission=None)


def test_the_aec_form_refuses_a_bad_action_from_the_agent_that_gives_it(missions: dict[str, Path]) -> None:
    """The parallel env checks a cycle's actions at its last agent: a bad first action was named
    only when the last agent acted."""
    aec = swarm.sim.env(mission=missions["quiet"])
    aec.reset(seed=0)
    first = aec.agent_selection
    with pytest.raises(SwarmError, match=rf"action of {first}: found array\(\[nan"):
        aec.step(np.array([np.nan, 0.0, 0.0], np.float32))
    assert aec.agent_selection == first  # its turn still: it may act again
    aec.step(np.zeros(3, np.float32))
    assert aec.agent_selection != first


def test_the_aec_form_wants_none_for_an_agent_that_is_done_and_only_then(missions: dict[str, Path]) -> None:
    """Found by auditing the API: None for a working agent was taken, then failed at the cycle's
    last agent and every step after; an action for a done agent was PettingZoo's bare assert."""
    aec = swarm.sim.env(mission=missions["quiet"])
    aec.reset(seed=0)
    first = aec.agent_selection
    with pytest.raises(SwarmError, match=rf"action of {first}: found None, expected 3 finite numbers"):
        aec.step(None)
    for _ in aec.agents:  # a whole cycle goes through
        aec.step(np.zeros(3, np.float32))
    aec.unwrapped.lose("robot_1")
    while aec.agent_selection != "robot_1" or not aec.terminations["robot_1"]:
        aec.step(np.zeros(3, np.float32))
    with pytest.raises(
        SwarmError, match=r"action of robot_1: found array\(.*\), expected None: robot_1 is done"
    ):
        aec.step(np.zeros(3, np.float32))
    aec.step(None)
    assert "robot_1" not in aec.agents


def test_infos_are_each_robot_s_own(missions: dict[str, Path]) -> None:
    """Robots of one phase and role shared one dict: a key a caller added to one robot's info showed
    in the others', and after reset."""
    env = swarm.sim.parallel_env(mission=missions["quiet"])
    _, infos = env.reset(seed=0)
    infos["robot_0"]["mine"] = 1
    *_, infos = env.step({})
    assert all("mine" not in i for i in infos.values())
    waiting = [i for i in infos.values() if i["phase"] == "waiting"]  # launched one at a time
    assert len(waiting) > 1 and len({id(i) for i in waiting}) == len(waiting)  # equal, not one dict
    infos["robot_0"]["mine"] = 1
    _, infos = env.reset(seed=1)
    assert all("mine" not in i for i in infos.values())


def test_an_action_for_a_robot_that_has_left_is_ignored_whatever_it_is(missions: dict[str, Path]) -> None:
    env = swarm.sim.parallel_env(mission=missions["quiet"])
    env.reset(seed=0)
    env.lose("robot_3")
    env.step({})
    assert "robot_3" not in env.agents
    env.step({"robot_3": np.full(3, np.nan), "robot_0": np.zeros(3)})  # as the module says
    with pytest.raises(SwarmError, match="an action for 'robot_99'"):
        env.step({"robot_3": np.full(3, np.nan), "robot_99": np.zeros(3)})
    with pytest.raises(SwarmError, match=r"agent 'robot_99', expected one of robot_0"):
        env.lose("robot_99")


def test_a_command_is_a_whole_number_not_a_truth_value(missions: dict[str, Path]) -> None:
    env = swarm.sim.parallel_env(mission=missions["quiet"], action_mode="command")
    env.reset(seed=0)
    for command in (True, np.bool_(True)):
        with pytest.raises(SwarmError, match=r'expected \{"command": a whole number 0\.\.5'):
            env.step({"robot_0": {"command": command, "target": [50.0, 50.0]}})


@pytest.mark.parametrize(
    ("field", "value", "says"),
    [
        ("dt_s", "0.5", "expected seconds > 0 and at most 5 s"),
        ("dt_s", float("inf"), "expected seconds > 0 and at most 5 s"),
        ("substep_s", 1.0, "expected seconds > 0 and at most 0.5 s"),
        ("comms_period_s", 0.0, "expected seconds > 0"),
        ("patch_spacing_m", float("nan"), "expected metres > 0"),
        ("patch_size", 2.5, "expected a whole number >= 1"),
        ("neighbours", True, "expected a whole number >= 0"),
    ],
)
def test_sim_config_names_the_setting_it_refuses(field: str, value: object, says: str) -> None:
    """Found by auditing the API: a string step was a TypeError from a comparison, an endless one
    an OverflowError mid-step, a NaN patch spacing an observation patch of zeros."""
    with pytest.raises(SwarmError) as err:
        swarm.sim.SimConfig(**{field: value})
    assert str(err.value) == f"sim: SimConfig.{field} {value!r}, {says}"
