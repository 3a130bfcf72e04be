"""`SwarmVectorEnv`: B independent runs of one mission as one batched multi-agent environment, with
an array API in the manner of Gymnasium's vector environments.

```python
import swarm.sim
vec = swarm.sim.vector_env(mission="missions/landing.yaml", num_envs=8, normalize_obs=True, seed=0)
obs, infos = vec.reset()                            # obs (B, n, obs_dim) float32
for _ in range(1000):
    actions = policy(obs)                           # (B, n, 3)
    obs, rewards, terminated, truncated, infos = vec.step(actions)   # (B, n, ...) each
    mask = infos["agent_mask"]                      # (B, n): robots still in the mission
```

Every array has a row per robot of every run, `possible_agents` order, whether or not the robot is
still in the mission:
- `infos["agent_mask"]` (B, n) bool: the robots in the mission after the step (in the new episode,
  for a run that has just been reset). A lost, expended or recovered robot's last observation and
  reward come with terminated=True on the step it leaves; from then on its row is masked, its
  observation zero, its reward 0, its terminated/truncated False and its actions ignored.
- Autoreset, Gymnasium's "same step" mode: a run whose robots are all done is reset at once with
  the next seed of its stream; that step returns the new episode's first observation, the last
  step's rewards and terminations, and in the infos `final_obs` (B, n, obs_dim) (the finished
  runs' last observations, zero elsewhere), `episode` = {"r": (B, n) each robot's return, "l": (B,)
  steps} as Gymnasium's `RecordEpisodeStatistics` writes it, `outcome` (B,) the finished run's
  `SwarmEnv.outcome()` (None elsewhere); each with its `_key` (B,) mask of the runs it holds.
- Seeds: one seed s gives run b its k-th episode the seed `episode_seed(s, b, k)`, the child (b, k)
  of `SeedSequence(s)` (`spawn` makes the same children), so run b's episode is exactly a lone
  `SwarmEnv` reset with that seed; `infos["episode_seed"]` (B,) says which. `reset(seed=s)` starts
  every run's stream over at episode 0; `reset()` moves every run on to its next episode.
- `normalize_obs=True` maps every observation column affinely from its bounds in the observation
  space (`swarm.sim.layout.ObservationLayout.bounds`: raw bounds run to 3.6e4) to [-1, 1]:
  `(x - centre) / half_width`; `denormalize` inverts it. The bounds are loose for some columns
  (positions: four map extents; link counts: 1e4), so those use a small part of [-1, 1].

Today the batch is B `SwarmEnv`s (or a subclass with its own task hooks, `env_class=`) stepped one
after another through `SwarmEnv.step_arrays`, sharing one mission plan (planning is the expensive
part of building an env): the batched world core replaces this loop, keeping this API.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium
import numpy as np

from swarm.errors import SwarmError
from swarm.mission.plan import MissionPlan
from swarm.mission.schema import Mission
from swarm.sim.env import COMMANDS, SimConfig, SwarmEnv


def episode_seed(seed: int, run: int, episode: int) -> int:
    """The `SwarmEnv.reset` seed of a vector env's run `run`, episode `episode`, from its seed:
    `SeedSequence(seed).spawn(run + 1)[run].spawn(episode + 1)[episode]`, as one uint64."""
    ss = np.random.SeedSequence(seed, spawn_key=(run, episode))
    return int(ss.generate_state(1, dtype=np.uint64)[0])


class SwarmVectorEnv:
    """B runs of one mission stepped together on arrays (module docstring)."""

    metadata = {"autoreset_mode": "same_step"}  # noqa: RUF012 (Gymnasium's vector envs carry it)

    def __init__(
        self,
        mission: str | Path | Mission,
        num_envs: int,
        overrides: dict[str, Any] | None = None,
        *,
        action_mode: str = "wheels",
        normalize_obs: bool = False,
        seed: int | None = None,
        config: SimConfig | None = None,
        max_cycles: int | None = None,
        plan: MissionPlan | None = None,
        plan_workers: int | None = 1,
        env_class: type[SwarmEnv] = SwarmEnv,
    ) -> None:
        if num_envs < 1:
            raise SwarmError(f"sim: num_envs {num_envs}, expected at least 1")
        opts = {"action_mode": action_mode, "config": config, "max_cycles": max_cycles}
        first = env_class(mission, overrides, plan=plan, plan_workers=plan_workers, **opts)
        self.envs = [first] + [env_class(first.mission, plan=first.plan, **opts) for _ in range(num_envs - 1)]
        self.num_envs = num_envs
        self.n = first.n
        self.possible_agents = list(first.possible_agents)
        self.action_mode = action_mode
        self.normalize_obs = normalize_obs
        self.seed = seed

        raw = first.observation_space(first.possible_agents[0])
        if not isinstance(raw, gymnasium.spaces.Box) or len(raw.shape) != 1:
            raise SwarmError(f"sim: vector_env needs a flat Box observation per robot, got {raw}")
        self.raw_observation_space = raw
        self.obs_dim = raw.shape[0]
        if normalize_obs:
            low, high = raw.low.astype(np.float64), raw.high.astype(np.float64)
            if not (np.isfinite(low).all() and np.isfinite(high).all() and (high > low).all()):
                raise SwarmError("sim: normalize_obs needs finite observation bounds with high > low")
            self._centre = ((high + low) / 2).astype(np.float32)
            self._half = ((high - low) / 2).astype(np.float32)
            self.single_observation_space = gymnasium.spaces.Box(-1.0, 1.0, raw.shape, np.float32)
        else:
            self.single_observation_space = raw
        if action_mode == "wheels":
            self.single_action_space = first.action_space(first.possible_agents[0])
        else:  # command index (floored), target x, y (m): one row of floats
            x0, y0, x1, y1 = first.beach.bounds_m
            self.single_action_space = gymnasium.spaces.Box(
                np.array([0.0, x0, y0], np.float32),
                np.array([len(COMMANDS) - 1, x1, y1], np.float32),
                dtype=np.float32,
            )
        self.observation_space = _batched(self.single_observation_space, (num_envs, self.n))
        self.action_space = _batched(self.single_action_space, (num_envs, self.n))

        b, n = num_envs, self.n
        self._active = np.zeros((b, n), bool)
        self._returns = np.zeros((b, n))
        self._lengths = np.zeros(b, np.int64)
        self._episode = np.zeros(b, np.int64)
        self._seeds = np.zeros(b, np.uint64)
        self._root: int | None = None

    # seeds --------------------------------------------------------------------------------------
    @property
    def episode_seeds(self) -> np.ndarray:
        """(B,) the seed of each run's current episode (`SwarmEnv.reset(seed=...)` replays it)."""
        return self._seeds.copy()

    def _reset_run(self, b: int) -> np.ndarray:
        """Start run b's next episode; returns its observations (n, obs_dim), raw."""
        assert self._root is not None
        s = episode_seed(self._root, b, int(self._episode[b]))
        self._episode[b] += 1
        self._seeds[b] = s
        env = self.envs[b]
        obs = env.reset_arrays(s)
        self._active[b] = False
        self._active[b, [env.agent_index[a] for a in env.agents]] = True
        self._returns[b] = 0.0
        self._lengths[b] = 0
        return obs

    # the API ------------------------------------------------------------------------------------
    def reset(self, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict]:
        """Every run to a new episode: with `seed`, each run's stream from its start (episode 0);
        without, each run's next episode (the first reset uses the constructor's `seed`, fresh
        entropy if that is None). Returns observations (B, n, obs_dim) and infos."""
        if seed is not None:
            self._root, self._episode[:] = int(seed), 0
        elif self._root is None:
            self._root = self.seed if self.seed is not None else int(np.random.SeedSequence().entropy)
        obs = np.stack([self._reset_run(b) for b in range(self.num_envs)])
        obs = self._finish_obs(obs, self._active)
        return obs, {"agent_mask": self._active.copy(), "episode_seed": self.episode_seeds}

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict]:
        """One step of every run: `actions` (B, n, 3) (rows of robots out of the mission ignored).
        Returns observations (B, n, obs_dim) float32, rewards (B, n), terminated and truncated (B, n)
        bool, and infos (module docstring); finished runs are reset (autoreset)."""
        if self._root is None:
            raise SwarmError("sim: step() before reset()")
        actions = np.asarray(actions)
        shape = (self.num_envs, self.n, 3)
        if actions.shape != shape:
            raise SwarmError(f"sim: actions of shape {actions.shape}, expected {shape}")
        b, n = self.num_envs, self.n
        obs = np.empty((b, n, self.obs_dim), np.float32)
        rewards = np.empty((b, n))
        terminated = np.empty((b, n), bool)
        truncated = np.empty((b, n), bool)
        for k, env in enumerate(self.envs):
            obs[k], rewards[k], terminated[k], truncated[k] = env.step_arrays(actions[k])
        was_active = self._active.copy()
        self._returns += rewards
        self._lengths += 1
        self._active &= ~(terminated | truncated)
        done = ~self._active.any(axis=1)
        infos: dict[str, Any] = {}
        if done.any():
            final = self._finish_obs(obs, was_active)
            runs = np.flatnonzero(done)
            infos["final_obs"] = np.where(done[:, None, None], final, np.float32(0.0))
            infos["episode"] = {
                "r": np.where(done[:, None], self._returns, 0.0),
                "l": np.where(done, self._lengths, 0),
            }
            outcome = np.full(b, None, dtype=object)
            for k in runs.tolist():
                outcome[k] = self.envs[k].outcome()
                obs[k] = self._reset_run(k)
            infos["outcome"] = outcome
            for key in ("final_obs", "episode", "outcome"):
                infos[f"_{key}"] = done.copy()
        rows = np.where(done[:, None], self._active, was_active)
        obs = self._finish_obs(obs, rows)
        infos["agent_mask"] = self._active.copy()
        infos["episode_seed"] = self.episode_seeds
        return obs, rewards, terminated, truncated, infos

    def close(self) -> None:
        for env in self.envs:
            env.close()

    # observation scaling --------------------------------------------------------------------------
    def normalize(self, obs: np.ndarray) -> np.ndarray:
        """Raw observations (..., obs_dim) to [-1, 1] by their bounds (only with normalize_obs)."""
        if not self.normalize_obs:
            raise SwarmError("sim: normalize() needs vector_env(..., normalize_obs=True)")
        return (np.asarray(obs, np.float32) - self._centre) / self._half

    def denormalize(self, obs: np.ndarray) -> np.ndarray:
        """The inverse of `normalize`: observations in [-1, 1] back to raw units."""
        if not self.normalize_obs:
            raise SwarmError("sim: denormalize() needs vector_env(..., normalize_obs=True)")
        return np.asarray(obs, np.float32) * self._half + self._centre

    def _finish_obs(self, raw: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """Scaled if asked, with the rows of robots out of the mission zero."""
        out = self.normalize(raw) if self.normalize_obs else raw
        return np.where(rows[..., None], out, np.float32(0.0))


def _batched(space: gymnasium.spaces.Box, lead: tuple[int, ...]) -> gymnasium.spaces.Box:
    low = np.broadcast_to(space.low, (*lead, *space.shape))
    high = np.broadcast_to(space.high, (*lead, *space.shape))
    return gymnasium.spaces.Box(low, high, dtype=space.dtype)
