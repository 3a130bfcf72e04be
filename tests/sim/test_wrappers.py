"""`SwarmEnv` under SuperSuit, the way MARL trainers batch it: `black_death_v3` keeps lost robots in
place with zero observations, `pettingzoo_env_to_vec_env_v1` turns the robots into a vector of
`len(possible_agents)` sub-environments, and `concat_vec_envs_v1` stacks copies of the mission.
Wheels mode (a Box action, the same for every robot). Needs supersuit (tested with 3.11)."""

from __future__ import annotations

from pathlib import Path

import gymnasium
import numpy as np
import pytest
import supersuit as ss
from tiny_missions import write_mission

import swarm.sim
from swarm.errors import SwarmError
from swarm.sim.env import SwarmEnv

ROBOTS = 6
COPIES = 2
#: Random failures every 0.05 h (180 s): a few of the 6 robots are lost in 200 steps (100 s).
ATTRITION = {"attrition": {"mtbf_h": 0.05}}
#: Random failures every 0.005 h (18 s): every robot is lost within about a minute.
DEADLY = {"attrition": {"mtbf_h": 0.005}}
QUIET = {
    "attrition": {"mtbf_h": 1.0e9},
    "surf": {"damage_h50_m": 10.0},
    "immobilization": {"per_km": 0.0},
    "rocks": {"damage_per_km": 0.0, "collision_damage_probability": 0.0},
}


@pytest.fixture(scope="module")
def missions(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("wrappers")
    return {
        "attrition": write_mission(d, "attrition", swarm={"count": ROBOTS}, hazards=ATTRITION),
        "quiet": write_mission(d, "quiet", swarm={"count": ROBOTS}, hazards=QUIET),
        "deadly": write_mission(d, "deadly", swarm={"count": ROBOTS}, hazards=DEADLY),
    }


def _vector(env: SwarmEnv) -> gymnasium.vector.VectorEnv:
    vec = ss.pettingzoo_env_to_vec_env_v1(ss.black_death_v3(env))
    return ss.concat_vec_envs_v1(vec, COPIES, num_cpus=0, base_class="gymnasium")


def _inner(cv: gymnasium.vector.VectorEnv) -> list[tuple[object, SwarmEnv]]:
    """(black_death wrapper, SwarmEnv) of each copy inside the concatenated vector env."""
    out = []
    for markov in cv.vec_envs:
        out.append((markov.par_env, markov.par_env.unwrapped))
    return out


def test_black_death_vector_env_keeps_the_batch_shape_through_losses(missions: dict[str, Path]) -> None:
    env = swarm.sim.parallel_env(mission=missions["attrition"], max_cycles=1000)
    obs_dim = env.layout.size
    cv = _vector(env)
    assert cv.num_envs == ROBOTS * COPIES
    assert cv.observation_space == env.observation_space("robot_0")
    assert cv.action_space == env.action_space("robot_0")
    obs, infos = cv.reset(seed=10)
    assert obs.shape == (ROBOTS * COPIES, obs_dim) and obs.dtype == np.float32
    assert len(infos) == ROBOTS * COPIES
    inner = _inner(cv)
    assert [e.seed for _, e in inner] == [10, 11]  # each copy gets its own seed
    cv.action_space.seed(3)
    rng = np.random.default_rng(3)
    dead_seen = np.zeros(ROBOTS * COPIES, bool)
    for k in range(200):
        actions = rng.uniform(-1.0, 1.0, (ROBOTS * COPIES, 3)).astype(np.float32)
        obs, rew, term, trunc, infos = cv.step(actions)
        assert obs.shape == (ROBOTS * COPIES, obs_dim) and obs.dtype == np.float32
        assert rew.shape == term.shape == trunc.shape == (ROBOTS * COPIES,)
        assert len(infos) == ROBOTS * COPIES
        assert not term.any() and not trunc.any(), f"step {k}: black_death hides single losses"
        for c, (bd, e) in enumerate(inner):
            assert len(bd.agents) == ROBOTS, "black_death keeps the agent count constant"
            rows = slice(c * ROBOTS, (c + 1) * ROBOTS)
            for a in e.possible_agents:
                i = e.agent_index[a]
                row = obs[rows][i]
                if a in e.agents:
                    assert e.observation_space(a).contains(row)
                    assert row.any()
                elif dead_seen[c * ROBOTS + i]:  # lost before this step: zero observation and reward
                    assert not row.any() and rew[rows][i] == 0.0
                dead_seen[c * ROBOTS + i] |= a not in e.agents
    for c, (_, e) in enumerate(inner):
        lost = ROBOTS - len(e.agents)
        assert 1 <= lost < ROBOTS, f"copy {c}: {lost} lost; the test needs some losses, not all"
        assert int(dead_seen[c * ROBOTS : (c + 1) * ROBOTS].sum()) == lost
    # the two copies are different episodes
    assert [ev for ev in inner[0][1].events if ev["kind"] == "loss"] != [
        ev for ev in inner[1][1].events if ev["kind"] == "loss"
    ]


@pytest.mark.parametrize("ending", ["time_limit", "all_lost"])
def test_black_death_vector_env_resets_at_the_end_of_an_episode(
    missions: dict[str, Path], ending: str
) -> None:
    """The vector env must report the end of the episode (every flag set) and carry on with a fresh
    one, both at the time limit and when the last robot is lost."""
    if ending == "time_limit":
        env = swarm.sim.parallel_env(mission=missions["quiet"], max_cycles=20)
    else:
        env = swarm.sim.parallel_env(mission=missions["deadly"])
    cv = _vector(env)
    cv.reset(seed=1)
    inner = _inner(cv)
    rng = np.random.default_rng(1)
    ended = np.zeros(COPIES, bool)
    for k in range(400):
        actions = rng.uniform(-1.0, 1.0, (ROBOTS * COPIES, 3)).astype(np.float32)
        try:
            obs, _, term, trunc, _ = cv.step(actions)
        except SwarmError as err:
            raise AssertionError(
                f"step {k}: the vector env stepped a finished SwarmEnv ({err}). Cause: supersuit "
                "3.11 black_death_par.step ends the episode only when every agent is terminated AND "
                "truncated (`(terminations & truncations).all()`, fixed to `|` in SuperSuit PR #265), "
                "so it steps the env again with no agents; SwarmEnv.step then raises (swarm/sim/env.py, "
                "_advance: 'step() after the episode ended') where PettingZoo's own parallel envs "
                "return five empty dicts, which lets black_death end the episode one step late. Fix: "
                "SwarmEnv.step returns ({}, {}, {}, {}, {}) when env.agents is empty."
            ) from err
        done = (term | trunc).reshape(COPIES, ROBOTS)
        for c, (bd, e) in enumerate(inner):
            assert done[c].all() or not done[c].any(), "black_death ends an episode for all at once"
            if done[c].all():
                ended[c] = True
                # auto-reset: a fresh episode of every robot, its observations in the batch
                assert e.steps == 0 and e.agents == e.possible_agents and len(bd.agents) == ROBOTS
                rows = obs[c * ROBOTS : (c + 1) * ROBOTS]
                for a, row in zip(e.possible_agents, rows, strict=True):
                    assert e.observation_space(a).contains(row)
        if ended.all():
            break
    assert ended.all(), f"no episode ended within 400 steps ({ending})"
