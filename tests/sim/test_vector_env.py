"""`swarm.sim.vector_env`: B runs on arrays. Each run's episode is exactly a lone `SwarmEnv` reset
with the run's seed (bit for bit on observations, rewards, terminations and agents), masks follow
the robots that leave, finished runs reset themselves with the next seed of their stream and hand
back their last observation, and normalized observations lie in [-1, 1] and map back exactly."""

from __future__ import annotations

from pathlib import Path

import gymnasium
import numpy as np
import pytest
from tiny_missions import write_mission

import swarm.sim
from swarm.errors import SwarmError
from swarm.sim.actions import Commands
from swarm.sim.env import SwarmEnv
from swarm.sim.vector import episode_seed

ROBOTS = 6
RUNS = 3
#: Random failures every 0.005 h (18 s): every robot is lost within a few hundred steps, each run at
#: its own time.
DEADLY = {"attrition": {"mtbf_h": 0.005}}
#: Random failures every 0.1 h: a few robots are lost in a hundred steps.
HAZARDOUS = {"attrition": {"mtbf_h": 0.1}}


@pytest.fixture(scope="module")
def missions(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("vector")
    return {
        "deadly": write_mission(d, "deadly", swarm={"count": ROBOTS}, hazards=DEADLY),
        "hazardous": write_mission(d, "hazardous", swarm={"count": ROBOTS}, hazards=HAZARDOUS),
    }


def _actions(rng: np.random.Generator, steps: int) -> np.ndarray:
    return rng.uniform(-1.0, 1.0, (steps, RUNS, ROBOTS, 3)).astype(np.float32)


def _lone_episode(env: SwarmEnv, seed: int, actions: np.ndarray) -> list[tuple[np.ndarray, ...]]:
    """A lone env's episode through the dict API, as (obs, reward, terminated, mask after) arrays
    over all robots (missing rows zero/False), the reset first (reward and terminated zero)."""
    n = env.n
    obs, _ = env.reset(seed=seed)
    out = []

    def rows(d: dict, width: int | None = None) -> np.ndarray:
        a = np.zeros((n, width), np.float32) if width else np.zeros(n, type(next(iter(d.values()))))
        for name, v in d.items():
            a[env.agent_index[name]] = v
        return a

    def mask() -> np.ndarray:
        return np.isin(np.arange(n), [env.agent_index[a] for a in env.agents])

    out.append((rows(obs, env.layout.size), np.zeros(n), np.zeros(n, bool), mask()))
    for act in actions:
        if not env.agents:
            break
        obs, rew, term, _, _ = env.step({a: act[env.agent_index[a]] for a in env.agents})
        out.append((rows(obs, env.layout.size), rows(rew), rows(term), mask()))
    return out


@pytest.mark.slow
def test_each_run_is_a_lone_env_reset_with_its_seed_bit_for_bit(missions: dict[str, Path]) -> None:
    """Through losses, the end of each run's first episode (all robots lost, at its own step) and
    the autoreset into the second, with the run's next seed."""
    steps = 260
    vec = swarm.sim.vector_env(mission=missions["deadly"], num_envs=RUNS, seed=11, max_cycles=1000)
    actions = _actions(np.random.default_rng(11), steps)
    obs, infos = vec.reset()
    assert obs.shape == (RUNS, ROBOTS, vec.obs_dim) and obs.dtype == np.float32
    seeds = [episode_seed(11, b, 0) for b in range(RUNS)]
    assert infos["episode_seed"].tolist() == seeds and len(set(seeds)) == RUNS
    got = [(obs, np.zeros((RUNS, ROBOTS)), np.zeros((RUNS, ROBOTS), bool), infos["agent_mask"])]
    ends: list[dict] = []
    for k in range(steps):
        obs, rew, term, trunc, infos = vec.step(actions[k])
        assert not trunc.any()
        got.append((obs, rew, term, infos["agent_mask"]))
        ends.append(infos)

    lone = SwarmEnv(missions["deadly"], max_cycles=1000)  # plans for itself: the shared plan is the same
    for b in range(RUNS):
        expected = _lone_episode(lone, seeds[b], actions[:, b])
        last = len(expected) - 1  # the step at which every robot of run b is gone
        assert 0 < last < steps, "every robot of the run is lost within the test's steps"
        for k in range(last):
            for part, e, g in zip(("obs", "reward", "terminated", "mask"), expected[k], got[k], strict=True):
                np.testing.assert_array_equal(g[b], e, err_msg=f"run {b}, step {k}: {part}")
        # the last step: its results, and the last observations in the infos; then the new episode
        info = ends[last - 1]
        e_obs, e_rew, e_term, _ = expected[last]
        np.testing.assert_array_equal(got[last][1][b], e_rew)
        np.testing.assert_array_equal(got[last][2][b], e_term)
        assert info["_final_obs"][b] and info["_episode"][b] and info["_outcome"][b]
        np.testing.assert_array_equal(info["final_obs"][b], e_obs)
        assert info["episode"]["l"][b] == last
        assert info["episode"]["r"][b] == pytest.approx(sum(e[1] for e in expected))
        assert info["outcome"][b] == lone.outcome()
        assert info["episode_seed"][b] == episode_seed(11, b, 1)
        reset_obs, _ = lone.reset(seed=episode_seed(11, b, 1))
        np.testing.assert_array_equal(got[last][0][b], np.stack(list(reset_obs.values())))
        assert got[last][3][b].all(), "the new episode starts with every robot"
    assert len({int(np.flatnonzero([i.get("_final_obs", np.zeros(RUNS))[b] for i in ends])[0])
                for b in range(RUNS)}) > 1, "runs end at their own steps"  # fmt: skip


def test_episode_seeds_are_seed_sequence_children(missions: dict[str, Path]) -> None:
    for run, episode in [(0, 0), (2, 0), (1, 3)]:
        child = np.random.SeedSequence(5).spawn(run + 1)[run].spawn(episode + 1)[episode]
        assert episode_seed(5, run, episode) == int(child.generate_state(1, np.uint64)[0])
    vec = swarm.sim.vector_env(mission=missions["hazardous"], num_envs=RUNS, seed=5)
    first, _ = vec.reset()
    again, _ = vec.reset(seed=5)
    np.testing.assert_array_equal(first, again)
    _, infos = vec.reset()  # each run on to its next episode
    assert infos["episode_seed"].tolist() == [episode_seed(5, b, 1) for b in range(RUNS)]


def test_lost_robots_are_masked_with_zero_rows(missions: dict[str, Path]) -> None:
    vec = swarm.sim.vector_env(mission=missions["deadly"], num_envs=RUNS, seed=3, max_cycles=1000)
    vec.reset()
    rng = np.random.default_rng(3)
    mask = np.ones((RUNS, ROBOTS), bool)
    lost_seen = 0
    for _ in range(60):
        obs, rew, term, trunc, infos = vec.step(rng.uniform(-1.0, 1.0, (RUNS, ROBOTS, 3)))
        assert not (term & ~mask).any(), "only robots in the mission leave"
        assert not trunc.any(), "no time limit within 60 steps"
        left = mask & term
        assert (np.abs(obs[left]).sum(axis=1) > 0).all(), "a leaving robot's last observation is real"
        gone = ~mask & ~infos.get("_final_obs", np.zeros(RUNS, bool))[:, None]
        assert not obs[gone].any() and not rew[gone].any() and not term[gone].any()
        mask = infos["agent_mask"]
        lost_seen += int(left.sum())
        assert vec.observation_space.contains(obs)
    assert lost_seen >= 3


def test_normalized_observations_lie_in_minus_one_one_and_map_back(missions: dict[str, Path]) -> None:
    kwargs = {"mission": missions["hazardous"], "num_envs": RUNS, "seed": 9, "max_cycles": 100}
    raw_vec = swarm.sim.vector_env(**kwargs)
    vec = swarm.sim.vector_env(normalize_obs=True, **kwargs)
    assert vec.single_observation_space == gymnasium.spaces.Box(-1.0, 1.0, (vec.obs_dim,), np.float32)
    raw, _ = raw_vec.reset()
    obs, infos = vec.reset()
    rng = np.random.default_rng(9)
    resets = 0
    half = (raw_vec.single_observation_space.high - raw_vec.single_observation_space.low) / 2
    rows = infos["agent_mask"]  # the rows that hold an observation
    for k in range(120):  # through the truncation at 100 steps and the autoreset
        assert np.abs(obs).max() <= 1.0, f"step {k}"
        np.testing.assert_allclose(vec.denormalize(obs)[rows], raw[rows], rtol=1e-6, atol=1e-6 * half.max())
        np.testing.assert_allclose(vec.normalize(vec.denormalize(obs))[rows], obs[rows], atol=1e-6)
        assert not obs[~rows].any()
        before = infos["agent_mask"]
        act = rng.uniform(-1.0, 1.0, (RUNS, ROBOTS, 3))
        raw, *_ = raw_vec.step(act)
        obs, _, _, trunc, infos = vec.step(act)
        # robots in the mission before the step have an observation, and every robot after a reset
        reset = infos.get("_final_obs", np.zeros(RUNS, bool))
        if reset.any():
            resets += 1
            assert reset.all() and (trunc == before).all(), "all truncated together at max_cycles"
            assert np.abs(infos["final_obs"]).max() <= 1.0, "the final observations are normalized too"
        rows = np.where(reset[:, None], infos["agent_mask"], before)
    assert resets == 1


def test_a_subclassed_task_runs_batched(missions: dict[str, Path]) -> None:
    class Position(SwarmEnv):
        def observation_box(self) -> gymnasium.spaces.Box:
            return gymnasium.spaces.Box(-1e3, 1e3, (2,), np.float32)

        def observe(self) -> np.ndarray:
            return self.robot_state[:, :2].astype(np.float32)

        def reward(self, step: swarm.sim.StepOutcome) -> np.ndarray:
            return -self.robot_state[:, 0]

    vec = swarm.sim.vector_env(mission=missions["hazardous"], num_envs=2, seed=1, env_class=Position)
    obs, _ = vec.reset()
    assert obs.shape == (2, ROBOTS, 2)
    obs, rew, *_ = vec.step(np.zeros((2, ROBOTS, 3)))
    np.testing.assert_array_equal(rew, -np.stack([e.robot_state[:, 0] for e in vec.envs]))


def test_a_subclass_resets_its_own_state_on_autoreset(missions: dict[str, Path]) -> None:
    """A task that keeps state resets it in `reset_arrays`, alone and in the batch's autoreset."""

    class Counting(SwarmEnv):
        def observation_box(self) -> gymnasium.spaces.Box:
            return gymnasium.spaces.Box(0.0, 1e6, (1,), np.float32)

        def reset_arrays(self, seed: int | None = None) -> np.ndarray:
            self.looks = 0
            return super().reset_arrays(seed)

        def observe(self) -> np.ndarray:
            self.looks = getattr(self, "looks", 0) + 1
            return np.full((self.n, 1), self.looks, np.float32)

    vec = swarm.sim.vector_env(
        mission=missions["hazardous"], num_envs=2, seed=1, max_cycles=3, env_class=Counting
    )
    obs, _ = vec.reset()
    assert (obs == 1).all()
    for _ in range(3):
        obs, _, _, trunc, infos = vec.step(np.zeros((2, ROBOTS, 3)))
    assert infos["_final_obs"].all() and (trunc | ~infos["agent_mask"]).any()
    rows = infos["agent_mask"]
    assert (obs[rows] == 1).all(), "the new episode's first observation counts from the reset"
    assert (infos["final_obs"][:, :, 0].max(axis=1) == 4).all()


def test_bad_calls_say_what_was_expected(missions: dict[str, Path]) -> None:
    for num_envs in (0, 2.5, "3", True):  # "3" and 2.5 were a bare TypeError, True a numpy one
        with pytest.raises(SwarmError, match=rf"num_envs {num_envs!r}, expected a whole number >= 1"):
            swarm.sim.vector_env(mission=missions["hazardous"], num_envs=num_envs)
    with pytest.raises(SwarmError, match="normalize_obs 'False', expected True or False"):
        swarm.sim.vector_env(mission=missions["hazardous"], num_envs=2, normalize_obs="False")
    with pytest.raises(SwarmError, match=r"seed -1, expected None or a whole number >= 0"):
        swarm.sim.vector_env(mission=missions["hazardous"], num_envs=2, seed=-1)
    vec = swarm.sim.vector_env(mission=missions["hazardous"], num_envs=2)
    with pytest.raises(SwarmError, match=r"step\(\) before reset\(\)"):
        vec.step(np.zeros((2, ROBOTS, 3)))
    vec.reset(seed=0)
    shapes = rf"actions of shape \(2, {ROBOTS}, 2\), expected \(2, {ROBOTS}, 3\)"
    with pytest.raises(SwarmError, match=shapes):
        vec.step(np.zeros((2, ROBOTS, 2)))
    with pytest.raises(SwarmError, match="normalize_obs=True"):
        vec.normalize(np.zeros(vec.obs_dim))
    with pytest.raises(SwarmError, match=r"seed 2.5, expected None or a whole number >= 0"):
        vec.reset(seed=2.5)  # was the seed 2


def test_a_nan_action_of_a_robot_in_the_mission_is_refused_and_changes_nothing(missions) -> None:
    """A NaN wheel speed once made a robot's state NaN for good; a masked robot's row is ignored."""
    vec = swarm.sim.vector_env(mission=missions["hazardous"], num_envs=2, seed=3)
    vec.reset()
    for _ in range(30):
        mask = vec.step(np.full((2, ROBOTS, 3), 0.5))[4]["agent_mask"]
    before = vec.world.robot_state.copy()
    bad = np.full((2, ROBOTS, 3), 0.5)
    live = np.argwhere(mask)[0]
    bad[tuple(live)] = [np.nan, 0.0, 0.0]
    with pytest.raises(SwarmError, match=rf"actions\[{live[0]}, {live[1]}\]: found \[nan, 0.0, 0.0\]"):
        vec.step(bad)
    np.testing.assert_array_equal(vec.world.robot_state, before)
    vec.world.in_agents[0, 0] = False  # a robot out of the mission: its row is not read
    ignored = np.full((2, ROBOTS, 3), 0.5)
    ignored[0, 0] = np.nan
    vec.step(ignored)
    assert np.isfinite(vec.world.robot_state).all()


def test_every_sample_of_the_command_action_space_is_an_action(missions: dict[str, Path]) -> None:
    """Found by auditing the API: the Box sampled commands like 3.49, which step() refused. Each
    command now owns the unit interval around it, so random samples draw each command alike."""
    vec = swarm.sim.vector_env(mission=missions["hazardous"], num_envs=2, action_mode="command", seed=0)
    vec.reset()
    vec.action_space.seed(3)
    for _ in range(5):
        vec.step(vec.action_space.sample())
    low, high = vec.single_action_space.low[0], vec.single_action_space.high[0]
    assert (low, high) == (-0.5, len(swarm.sim.COMMANDS) - 0.5)
    nearest = [Commands.nearest(v) for v in (-0.5, 0.49, 0.5, 2.5, 5.5, np.float32(3.2))]
    assert nearest == [0, 0, 1, 3, 5, 3]
    assert Commands.nearest(5.6) == 5.6 and Commands.nearest(True) is True  # left for the check to refuse


def test_a_swarm_of_one_robot_runs_alone_and_batched(tmp_path: Path) -> None:
    """Found by auditing sweeps from one robot up: the hazards' inputs read a run's (B, 1) arrays as
    already flat, and every simulation of one robot was a reshape error."""
    mission = write_mission(
        tmp_path,
        "one",
        swarm={"count": 1},
        tasks=[{"type": "landing", "zones": ["landing_a"], "robots_per_zone": 1}],
    )
    alone = swarm.sim.parallel_env(mission=mission)
    alone.reset(seed=4)
    vec = swarm.sim.vector_env(mission=mission, num_envs=3, seed=4)
    vec.reset()
    rng = np.random.default_rng(0)
    for _ in range(40):
        action = rng.uniform(-1, 1, (3, 1, 3)).astype(np.float32)
        vec.step(action)
        if alone.agents:
            alone.step({"robot_0": action[0, 0]})
    assert np.isfinite(vec.world.robot_state).all() and vec.world.robot_state.shape == (3, 1, 6)
