"""`SwarmTorchEnv`: the batched vector env (`swarm.sim.vector_env`) as a native TorchRL `EnvBase`,
batch size [B], with the robots as one group, "robot", of n agents; no per-step dicts.

```python
from swarm.sim.torchrl_env import SwarmTorchEnv
env = SwarmTorchEnv(mission="examples/tiny_landing.yaml", num_envs=8, normalize_obs=True, seed=0)
td = env.rollout(100)          # ("next", "robot", "reward") (8, 100, n, 1), ...
```

Keys, TorchRL's multi-agent conventions (as its `PettingZooWrapper` gives with use_mask=True):
`("robot", "observation")` (B, n, obs_dim), `("robot", "action")` (B, n, 3) (wheels mode: left,
right, jet in [-1, 1]), `("robot", "reward")`, `("robot", "terminated")`, `("robot", "truncated")`,
`("robot", "done")` (B, n, 1), `("robot", "mask")` (B, n): the robots still in the mission; and per
run `done`, `terminated`, `truncated` (B, 1): the run's episode is over (every robot gone, or out
of time).

Resets: the vector env resets a finished run in the same step (Gymnasium's same-step autoreset),
while TorchRL wants the step to end the episode and a reset to start the next. So a finished
run's step hands TorchRL its final observations, and the reset TorchRL then asks for hands back
the new episode's first observations, which the vector env already made (no second reset: the
run's episode seeds are the vector env's, `episode_seed`). Needs the `examples` extra (torch,
torchrl, tensordict); `swarm.sim` does not import this module.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch
from tensordict import TensorDict
from torchrl.data import Binary, Bounded, Composite, Unbounded
from torchrl.envs import EnvBase

from swarm.errors import SwarmError
from swarm.sim.env import check_seed
from swarm.sim.vector import SwarmVectorEnv

GROUP = "robot"


class SwarmTorchEnv(EnvBase):
    """B runs of a mission as one TorchRL environment (module docstring). Arguments are those of
    `swarm.sim.vector_env` (wheels mode), or `vec=` an existing `SwarmVectorEnv`."""

    def __init__(self, vec: SwarmVectorEnv | None = None, *, device: str = "cpu", **kwargs: Any) -> None:
        vec = vec if vec is not None else SwarmVectorEnv(**kwargs)
        if vec.action_mode != "wheels":
            raise SwarmError("sim: SwarmTorchEnv needs the vector env's wheels action mode")
        b, n, d = vec.num_envs, vec.n, vec.obs_dim
        super().__init__(batch_size=torch.Size([b]), device=device)
        self.vec = vec
        self.n = n
        space = vec.single_observation_space
        low = torch.as_tensor(np.broadcast_to(space.low, (b, n, d)).copy())
        high = torch.as_tensor(np.broadcast_to(space.high, (b, n, d)).copy())
        self.observation_spec = Composite(
            {
                GROUP: Composite(
                    {
                        "observation": Bounded(
                            low, high, shape=(b, n, d), dtype=torch.float32, device=device
                        ),
                        "mask": Binary(n=n, shape=(b, n), dtype=torch.bool, device=device),
                    },
                    shape=(b, n),
                )
            },
            shape=(b,),
        )
        self.action_spec = Composite(
            {GROUP: Composite({"action": Bounded(-1.0, 1.0, shape=(b, n, 3), device=device)}, shape=(b, n))},
            shape=(b,),
        )
        self.reward_spec = Composite(
            {GROUP: Composite({"reward": Unbounded(shape=(b, n, 1), device=device)}, shape=(b, n))},
            shape=(b,),
        )
        flags = ("done", "terminated", "truncated")
        per_robot = {k: Binary(n=1, shape=(b, n, 1), dtype=torch.bool, device=device) for k in flags}
        per_run = {k: Binary(n=1, shape=(b, 1), dtype=torch.bool, device=device) for k in flags}
        self.done_spec = Composite({**per_run, GROUP: Composite(per_robot, shape=(b, n))}, shape=(b,))
        self._pending: np.ndarray | None = None  # the runs reset by the vector env, not yet by TorchRL
        self._next_obs: np.ndarray | None = None  # their new episodes' first observations
        self._next_mask: np.ndarray | None = None
        self._seed: int | None = None

    def _obs_td(self, obs: np.ndarray, mask: np.ndarray) -> TensorDict:
        b, n = obs.shape[:2]
        return TensorDict(
            {
                GROUP: TensorDict(
                    {"observation": torch.as_tensor(obs), "mask": torch.as_tensor(mask)}, batch_size=(b, n)
                )
            },
            batch_size=(b,),
            device=self.device,
        )

    def _reset(self, tensordict: TensorDict | None = None, **kwargs: Any) -> TensorDict:
        want = None
        flags = None if tensordict is None else tensordict.get("_reset", None)
        if flags is not None:
            want = flags.reshape(-1).cpu().numpy().astype(bool)
        if self._pending is not None and want is not None and np.array_equal(want, self._pending):
            # the runs the vector env has just reset: their new episodes, as already made
            obs, mask = self._next_obs, self._next_mask
            self._pending = None
        elif want is None or want.all():
            obs, infos = self.vec.reset(seed=self._seed)
            self._seed = None
            mask = infos["agent_mask"]
            self._pending = None
        else:
            raise SwarmError(
                f"sim: SwarmTorchEnv resets the runs whose episodes ended, or all of them; asked for runs"
                f" {np.flatnonzero(want).tolist()} of {len(want)}"
            )
        self._last_obs, self._last_mask = obs, mask
        td = self._obs_td(obs, mask)
        b = obs.shape[0]
        zeros = torch.zeros((b, 1), dtype=torch.bool)
        for k in ("done", "terminated", "truncated"):
            td.set(k, zeros.clone())
            td.set((GROUP, k), torch.zeros((b, self.n, 1), dtype=torch.bool))
        return td

    def _step(self, tensordict: TensorDict) -> TensorDict:
        action = tensordict[GROUP, "action"].detach().cpu().numpy()
        obs, rewards, terminated, truncated, infos = self.vec.step(action)
        mask = infos["agent_mask"]
        done = infos.get("_final_obs", np.zeros(self.vec.num_envs, bool))
        if done.any():  # hand TorchRL the final observations; keep the new episodes for its reset
            self._pending = done.copy()
            self._next_obs, self._next_mask = obs.copy(), mask.copy()
            obs = np.where(done[:, None, None], infos["final_obs"], obs)
            mask = mask & ~done[:, None]
        td = self._obs_td(obs, mask)
        td.set((GROUP, "reward"), torch.as_tensor(rewards, dtype=torch.float32).unsqueeze(-1))
        term = torch.as_tensor(terminated).unsqueeze(-1)
        trunc = torch.as_tensor(truncated).unsqueeze(-1)
        td.set((GROUP, "terminated"), term)
        td.set((GROUP, "truncated"), trunc)
        td.set((GROUP, "done"), term | trunc)
        run_done = torch.as_tensor(done).unsqueeze(-1)
        run_trunc = torch.as_tensor(done & truncated.any(axis=1)).unsqueeze(-1)
        td.set("done", run_done)
        td.set("truncated", run_trunc)
        td.set("terminated", run_done & ~run_trunc)
        return td

    def _set_seed(self, seed: int | None) -> None:
        self._seed = check_seed(seed)
