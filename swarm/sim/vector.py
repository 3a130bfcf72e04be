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

The B runs are one batched world (`swarm.sim.world.World`): one `advance` moves every robot of
every run. The task is B `SwarmEnv`s (or a subclass with its own task hooks, `env_class=`) bound
to the world's runs; the default task's observations (`swarm.sim.observe`) and rewards are
computed for all runs at once, a subclass's hooks run by run. Either way run b's results are those
of a lone `SwarmEnv` reset with its seed, bit for bit.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium
import numpy as np

from swarm.errors import SwarmError
from swarm.mission.plan import MissionPlan
from swarm.mission.schema import Mission
from swarm.sim.actions import Commands, wheel_array
from swarm.sim.env import COMMANDS, SimConfig, StepOutcome, SwarmEnv, check_seed
from swarm.sim.observe import Observer
from swarm.sim.world import World, is_whole


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
        if not is_whole(num_envs) or num_envs < 1:
            raise SwarmError(f"sim: num_envs {num_envs!r}, expected a whole number >= 1")
        if not isinstance(normalize_obs, bool | np.bool_):
            raise SwarmError(f"sim: normalize_obs {normalize_obs!r}, expected True or False")
        if not (isinstance(env_class, type) and issubclass(env_class, SwarmEnv)):
            raise SwarmError(f"sim: env_class {env_class!r}, expected SwarmEnv or a subclass of it")
        num_envs = int(num_envs)
        check_seed(seed)
        opts = {"action_mode": action_mode, "config": config, "max_cycles": max_cycles}
        first = env_class(mission, overrides, plan=plan, plan_workers=plan_workers, **opts)
        cfg = first.config
        self.world = World(first.setup, num_envs, comms_period_s=cfg.comms_period_s, max_cycles=max_cycles)
        self.envs = [
            env_class(first.mission, setup=first.setup, world=self.world, run=b, **opts)
            for b in range(num_envs)
        ]
        kind = type(self.envs[0])
        #: The default task's hooks run for every run at once (`swarm.sim.observe`); a subclass's
        #: overridden hooks run by run.
        self._batched_observe = kind.observe is SwarmEnv.observe and kind._observe is SwarmEnv._observe
        self._batched_reward = kind.reward is SwarmEnv.reward
        self._batched_terminated = kind.terminated is SwarmEnv.terminated
        self.observer = Observer(first.setup, first.layout, num_envs)
        self.limits = first.limits
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
        else:  # command (the nearest whole number: `Commands.nearest`), target x, y (m)
            self._command_check = Commands(first.beach.bounds_m)
            x0, y0, x1, y1 = first.beach.bounds_m
            self.single_action_space = gymnasium.spaces.Box(
                np.array([-0.5, x0, y0], np.float32),
                np.array([len(COMMANDS) - 0.5, x1, y1], np.float32),
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

    def _reset_runs(self, runs: list[int]) -> np.ndarray:
        """Start runs `runs` on their next episodes; returns their observations (len(runs), n,
        obs_dim), raw. The world's runs are reset together, then each run's env through its own
        `reset_arrays` (a subclass that keeps state of its own resets it there, as alone)."""
        assert self._root is not None
        seeds = []
        for b in runs:
            s = episode_seed(self._root, b, int(self._episode[b]))
            self._episode[b] += 1
            self._seeds[b] = s
            seeds.append(s)
        self.world.reset(seeds, runs=runs)
        obs = []
        for b, s in zip(runs, seeds, strict=True):
            obs.append(self.envs[b].reset_arrays(s))
            self.observer.reset_run(b)
            self._active[b] = self.world.in_agents[b]
            self._returns[b] = 0.0
            self._lengths[b] = 0
        return np.stack(obs)

    def _observe(self, runs: list[int]) -> np.ndarray:
        """The task's observations of runs `runs` (len(runs), n, obs_dim), raw."""
        if self._batched_observe:
            return self.observer.observe(self.world, runs)
        return np.stack([self.envs[b].task_observe() for b in runs])

    def _commands(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Wheel (B, n, 2) and jet (B, n) commands from the actions of the robots in the mission,
        every one checked before any is applied (`swarm.sim.actions`)."""
        inside = self.world.in_agents
        if self.action_mode == "command":
            if actions.dtype.kind not in "iuf":
                raise SwarmError(f"sim: actions of dtype {actions.dtype}, expected numbers")
            check = self._command_check
            given = [
                check.from_rows(actions[b], np.flatnonzero(row), f"run {b}, ") for b, row in enumerate(inside)
            ]
            for env, rows in zip(self.envs, given, strict=True):
                for i, cmd, target in rows:
                    env.set_command(i, cmd, target)
            return self.world.controller_commands()
        lim = self.limits
        act = wheel_array(actions, inside)
        wheels = np.where(
            inside[..., None], act[..., :2] * (lim.max_wheel_speed_mps / lim.wheel_radius_m), 0.0
        )
        jet = np.where(inside, act[..., 2] * lim.jet_thrust_max_n, 0.0)
        return wheels, jet

    # the API ------------------------------------------------------------------------------------
    def reset(self, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict]:
        """Every run to a new episode: with `seed`, each run's stream from its start (episode 0);
        without, each run's next episode (the first reset uses the constructor's `seed`, fresh
        entropy if that is None). Returns observations (B, n, obs_dim) and infos."""
        if check_seed(seed) is not None:
            self._root, self._episode[:] = int(seed), 0
        elif self._root is None:
            self._root = self.seed if self.seed is not None else int(np.random.SeedSequence().entropy)
        obs = self._reset_runs(list(range(self.num_envs)))
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
        b = self.num_envs
        was_in = self.world.in_agents.copy()
        ended, time_up, change = self.world.advance(*self._commands(actions))
        runs = list(range(b))
        obs = self._observe(runs)
        obs[~was_in] = 0.0
        outcomes = (
            []
            if self._batched_reward and self._batched_terminated
            else [StepOutcome(float(change[k]), ended[k], bool(time_up[k])) for k in runs]
        )
        if self._batched_reward:
            rewards = np.where(was_in, change[:, None], 0.0)
        else:
            hooks = [env.task_rows("reward", o) for env, o in zip(self.envs, outcomes, strict=True)]
            rewards = np.where(was_in, np.stack(hooks), 0.0)
        if self._batched_terminated:
            terminated = ended & was_in
        else:
            hooks = [env.task_rows("terminated", o) for env, o in zip(self.envs, outcomes, strict=True)]
            terminated = np.stack(hooks) & was_in
        truncated = was_in & ~terminated & time_up[:, None]
        self.world.finish(terminated, time_up)
        for k in np.flatnonzero((was_in & ~self.world.in_agents).any(axis=1)).tolist():
            self.envs[k].synced()  # the runs some robot left
        was_active = self._active.copy()
        self._returns += rewards
        self._lengths += 1
        self._active &= ~(terminated | truncated)
        done = ~self._active.any(axis=1)
        infos: dict[str, Any] = {}
        if done.any():
            final = self._finish_obs(obs, was_active, keep_raw=True)
            runs_done = np.flatnonzero(done)
            infos["final_obs"] = np.where(done[:, None, None], final, np.float32(0.0))
            infos["episode"] = {
                "r": np.where(done[:, None], self._returns, 0.0),
                "l": np.where(done, self._lengths, 0),
            }
            outcome = np.full(b, None, dtype=object)
            for k in runs_done.tolist():
                outcome[k] = self.envs[k].outcome()
            obs[runs_done] = self._reset_runs(runs_done.tolist())
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
        return (self._obs_rows(obs) - self._centre) / self._half

    def denormalize(self, obs: np.ndarray) -> np.ndarray:
        """The inverse of `normalize`: observations in [-1, 1] back to raw units."""
        if not self.normalize_obs:
            raise SwarmError("sim: denormalize() needs vector_env(..., normalize_obs=True)")
        return self._obs_rows(obs) * self._half + self._centre

    def _obs_rows(self, obs: np.ndarray) -> np.ndarray:
        out = np.asarray(obs, np.float32)
        if out.shape[-1:] != (self.obs_dim,):
            raise SwarmError(f"sim: observations of shape {out.shape}, expected (..., {self.obs_dim})")
        return out

    def _finish_obs(self, raw: np.ndarray, rows: np.ndarray, keep_raw: bool = False) -> np.ndarray:
        """Scaled if asked, with the rows of robots out of the mission zero; in place in `raw`
        (the step's own fresh array) unless `keep_raw`."""
        out = self.normalize(raw) if self.normalize_obs else raw.copy() if keep_raw else raw
        out[~rows] = 0.0
        return out


def _batched(space: gymnasium.spaces.Box, lead: tuple[int, ...]) -> gymnasium.spaces.Box:
    low = np.broadcast_to(space.low, (*lead, *space.shape))
    high = np.broadcast_to(space.high, (*lead, *space.shape))
    return gymnasium.spaces.Box(low, high, dtype=space.dtype)
