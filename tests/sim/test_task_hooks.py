"""The task hooks of `SwarmEnv` (`observation_box`, `observe`, `reward`, `terminated`, `info`): a
subclass changes what robots see, what they are rewarded for and when they leave, PettingZoo's
own parallel API test still passes on it, and the values handed out are the subclass's. And
`step_arrays`/`reset_arrays`, the array form of the same step, agree with the dict form exactly."""

from __future__ import annotations

import warnings
from pathlib import Path

import gymnasium
import numpy as np
import pytest
from pettingzoo.test import parallel_api_test
from tiny_missions import write_mission

from swarm.errors import SwarmError
from swarm.sim.env import StepOutcome, SwarmEnv

#: Random failures every 0.1 h: some of the robots are lost in the API test's 150 steps.
HAZARDOUS = {"attrition": {"mtbf_h": 0.1}}
#: Where the custom reward pulls the robots (m, on test_small's beach).
GOAL_M = np.array([60.0, 60.0])
#: The custom task ends robot_0's episode at this step.
RETIRE_STEP = 10


class GoalTask(SwarmEnv):
    """Robots see their position, battery and distance to `GOAL_M`; each is rewarded for closing on
    it (its own reward, not the team's); robot_0 retires at `RETIRE_STEP`."""

    def observation_box(self) -> gymnasium.spaces.Box:
        x0, y0, x1, y1 = self.beach.bounds_m
        low = np.array([x0 - 500.0, y0 - 500.0, 0.0, 0.0], np.float32)
        high = np.array([x1 + 500.0, y1 + 500.0, 1.0, 2000.0], np.float32)
        return gymnasium.spaces.Box(low, high, dtype=np.float32)

    def observe(self) -> np.ndarray:
        xy = self.robot_state[:, :2]
        battery = np.clip(self.energy_wh / self.mission.hazards.battery.capacity_wh, 0.0, 1.0)
        return np.column_stack([xy, battery, np.hypot(*(xy - GOAL_M).T)]).astype(np.float32)

    def reward(self, step: StepOutcome) -> np.ndarray:
        return -np.hypot(*(self.robot_state[:, :2] - GOAL_M).T) / 100.0

    def terminated(self, step: StepOutcome) -> np.ndarray:
        out = step.ended.copy()
        out[0] |= self.steps == RETIRE_STEP
        return out

    def info(self, robots: np.ndarray) -> list[dict]:
        return [{"battery_wh": float(self.energy_wh[i])} for i in robots.tolist()]


@pytest.fixture(scope="module")
def missions(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("hooks")
    return {"hazardous": write_mission(d, "hazardous", swarm={"count": 6}, hazards=HAZARDOUS)}


def test_a_subclassed_task_passes_pettingzoo_parallel_api_test(missions: dict[str, Path]) -> None:
    env = GoalTask(missions["hazardous"], max_cycles=150)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        parallel_api_test(env, num_cycles=200)
    assert env.observation_space("robot_3").shape == (4,)


def test_a_subclass_hands_out_its_own_observations_rewards_terminations_and_infos(
    missions: dict[str, Path],
) -> None:
    env = GoalTask(missions["hazardous"], max_cycles=60)
    obs, infos = env.reset(seed=4)
    assert all(o.shape == (4,) and env.observation_space(a).contains(o) for a, o in obs.items())
    assert set(infos["robot_1"]) == {"battery_wh"}
    rng = np.random.default_rng(4)
    for _ in range(RETIRE_STEP + 5):
        before = list(env.agents)
        acts = {a: rng.uniform(-1.0, 1.0, 3).astype(np.float32) for a in env.agents}
        obs, rew, term, _, infos = env.step(acts)
        for a in before:
            i = env.agent_index[a]
            xy = env.robot_state[i, :2]
            distance = float(np.hypot(*(xy - GOAL_M)))
            assert rew[a] == pytest.approx(-distance / 100.0, rel=1e-12)
            assert obs[a][3] == pytest.approx(distance, rel=1e-6)
            assert infos[a] == {"battery_wh": float(env.energy_wh[i])}
        if env.steps == RETIRE_STEP:
            assert term["robot_0"] and "robot_0" not in env.agents
    assert "robot_0" not in env.agents
    # robots differ in their rewards: each is its own, not the team's
    assert len(set(rew.values())) > 1


def _rollout_dicts(env: SwarmEnv, actions: np.ndarray) -> list[tuple[np.ndarray, ...]]:
    """The dict API's results as arrays over all robots (missing rows zero/False)."""
    out = []
    env.reset(seed=2)
    for act in actions:
        if not env.agents:
            break
        obs, rew, term, trunc, _ = env.step({a: act[env.agent_index[a]] for a in env.agents})
        o = np.zeros((env.n, env.layout.size), np.float32)
        r, t, u = np.zeros(env.n), np.zeros(env.n, bool), np.zeros(env.n, bool)
        for a in obs:
            i = env.agent_index[a]
            o[i], r[i], t[i], u[i] = obs[a], rew[a], term[a], trunc[a]
        out.append((o, r, t, u))
    return out


def test_step_arrays_is_step_on_arrays(missions: dict[str, Path]) -> None:
    """Over an episode with losses and the truncation at max_cycles, bit for bit."""
    steps = 80
    a = SwarmEnv(missions["hazardous"], max_cycles=steps)
    b = SwarmEnv(missions["hazardous"], max_cycles=steps, plan=a.plan)
    actions = np.random.default_rng(2).uniform(-1.0, 1.0, (steps, a.n, 3)).astype(np.float32)
    expected = _rollout_dicts(a, actions)
    first = b.reset_arrays(seed=2)
    assert first.shape == (b.n, b.layout.size)
    got = [b.step_arrays(act) for act in actions[: len(expected)]]
    assert len(got) == steps and not b.agents
    assert any(t.any() for _, _, t, _ in got), "some robot was lost: the masks were exercised"
    assert got[-1][3].any(), "the last step truncates"
    for (eo, er, et, eu), (go, gr, gt, gu) in zip(expected, got, strict=True):
        np.testing.assert_array_equal(go, eo)
        np.testing.assert_array_equal(gr, er)
        np.testing.assert_array_equal(gt, et)
        np.testing.assert_array_equal(gu, eu)
    with pytest.raises(SwarmError, match="after the episode ended"):
        b.step_arrays(actions[0])


def test_step_arrays_rejects_a_wrong_action_shape(missions: dict[str, Path]) -> None:
    env = SwarmEnv(missions["hazardous"])
    env.reset_arrays(seed=0)
    with pytest.raises(SwarmError, match=r"actions of shape \(6, 2\), expected \(6, 3\)"):
        env.step_arrays(np.zeros((6, 2)))


class _FlatObservation(SwarmEnv):
    """observe() one column short of its box."""

    def observation_box(self) -> gymnasium.spaces.Box:
        return gymnasium.spaces.Box(-1e3, 1e3, (3,), np.float32)

    def observe(self) -> np.ndarray:
        return self.robot_state[:, :2]


class _TeamScalar(SwarmEnv):
    """reward() a scalar, not a value per robot."""

    def reward(self, step: StepOutcome) -> float:
        return step.score_change


class _Float64Observation(SwarmEnv):
    def observation_box(self) -> gymnasium.spaces.Box:
        return gymnasium.spaces.Box(-1e4, 1e4, (2,), np.float32)

    def observe(self) -> np.ndarray:
        return self.robot_state[:, :2]  # float64


def test_a_hook_of_the_wrong_shape_is_named_in_every_form(missions: dict[str, Path]) -> None:
    """Found by auditing the API: these came out as numpy's broadcast error from the step, or as
    observations a space check fails on later (and the vector env took any class as env_class)."""
    import swarm.sim

    mission = missions["hazardous"]
    for make in (
        lambda cls: cls(mission),
        lambda cls: swarm.sim.vector_env(mission=mission, num_envs=2, env_class=cls),
    ):
        with pytest.raises(
            SwarmError, match=r"_FlatObservation.observe\(\) gave shape \(6, 2\), expected \(6, 3\)"
        ):
            make(_FlatObservation).reset(seed=0)
        env = make(_TeamScalar)
        env.reset(seed=0)
        with pytest.raises(SwarmError, match=r"_TeamScalar.reward\(\) gave shape \(\), expected \(6,\)"):
            env.step({} if isinstance(env, SwarmEnv) else np.zeros(env.action_space.shape, np.float32))
        obs = make(_Float64Observation).reset(seed=0)[0]
        rows = obs["robot_0"] if isinstance(obs, dict) else obs
        assert rows.dtype == np.float32  # cast to the box's dtype
    with pytest.raises(SwarmError, match="env_class <class 'dict'>, expected SwarmEnv or a subclass"):
        swarm.sim.vector_env(mission=mission, num_envs=1, env_class=dict)
