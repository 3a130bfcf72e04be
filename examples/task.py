"""What the examples share: their small mission, a task with a dense reward (a `SwarmEnv` subclass,
by the task hooks), and the evaluation of a policy on `swarm.sim.vector_env`.

The mission's own reward, the change of the mission score, comes mostly at the end; a few minutes of
training learn little from it. `GoalProgress` adds, for each robot, the metres it closed on its goal
(the end of its planned route) this step, and is what the examples train on.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

import swarm.sim
from swarm.sim import StepOutcome, SwarmEnv

MISSION = Path(__file__).resolve().parent / "tiny_landing.yaml"
#: Steps per episode (0.5 s each): the robots are on the map after 10 s.
MAX_CYCLES = 200


class GoalProgress(SwarmEnv):
    """The default observation; reward: the team reward plus each robot's progress to its goal (m)."""

    def observe(self) -> np.ndarray:
        obs = super().observe()
        goal = obs[:, self.layout.names.index("goal_distance_m")].astype(np.float64)
        self.goal_before = getattr(self, "goal_now", goal)  # step() calls observe, then reward
        self.goal_now = goal
        return obs

    def reset_arrays(self, seed: int | None = None) -> np.ndarray:
        self.__dict__.pop("goal_now", None)  # a new episode: no progress to count yet
        return super().reset_arrays(seed)

    def reward(self, step: StepOutcome) -> np.ndarray:
        return step.score_change + (self.goal_before - self.goal_now)

    def info(self, robots: np.ndarray) -> list[dict]:
        """Numbers only, the same keys for every robot at every step (TorchRL's `PettingZooWrapper`
        makes a tensor of each value): phase and role index, and whether the robot was lost."""
        lost = self.lost_at[robots, 0] >= 0  # NaN until lost
        rows = zip(self.phase[robots].tolist(), self.role[robots].tolist(), lost.tolist(), strict=True)
        return [{"phase": p, "role": r, "lost": float(x)} for p, r, x in rows]


def make_env(max_cycles: int = MAX_CYCLES) -> GoalProgress:
    return GoalProgress(MISSION, max_cycles=max_cycles)


def evaluate(act: Callable[[np.ndarray], np.ndarray], episodes: int, seed: int, num_envs: int = 4) -> float:
    """Mean return per robot over `episodes` episodes of the task, on a vector env with normalized
    observations; `act` maps observations (B, n, obs_dim) to actions (B, n, 3)."""
    vec = swarm.sim.vector_env(
        mission=MISSION, num_envs=num_envs, normalize_obs=True, seed=seed,
        max_cycles=MAX_CYCLES, env_class=GoalProgress,
    )  # fmt: skip
    obs, _ = vec.reset()
    returns: list[float] = []
    while len(returns) < episodes:
        obs, _, _, _, infos = vec.step(act(obs))
        if "_episode" in infos:
            returns += infos["episode"]["r"][infos["_episode"]].mean(axis=1).tolist()
    return float(np.mean(returns[:episodes]))


def random_policy(seed: int) -> Callable[[np.ndarray], np.ndarray]:
    rng = np.random.default_rng(seed)
    return lambda obs: rng.uniform(-1.0, 1.0, (*obs.shape[:2], 3)).astype(np.float32)
