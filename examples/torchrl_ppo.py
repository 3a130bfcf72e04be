"""Parameter-shared PPO with TorchRL on the tiny landing mission, through its `PettingZooWrapper`.

    pip install -e ".[examples]"        # CPU torch: add --extra-index-url https://download.pytorch.org/whl/cpu
    python examples/torchrl_ppo.py [--iterations 20] [--seed 0]

- `PettingZooWrapper(env=..., use_mask=True)`: the robots are one group ("robot"), with a mask of
  those still in the mission (robots leave the parallel env when lost). The wrapper makes a tensor
  of every info value, so the task's `info` hook returns numbers only (`examples/task.py`).
- `ObservationNorm` scales each observation column from its bounds to [-1, 1], the same map as
  `vector_env(normalize_obs=True)`.
- One `MultiAgentMLP` with shared parameters is every robot's policy (a tanh-squashed Gaussian),
  another the critic; `ClipPPOLoss` with GAE, as TorchRL's multi-agent PPO tutorial does.
Then it prints the mean return per robot of the trained policy and of a random one, on
`swarm.sim.vector_env` (`examples/task.py`).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import torch
from task import evaluate, make_env, random_policy
from tensordict import TensorDict
from tensordict.nn import NormalParamExtractor, TensorDictModule
from torch import nn
from torchrl.collectors import Collector
from torchrl.envs import (
    ExplorationType,
    ObservationNorm,
    PettingZooWrapper,
    TransformedEnv,
    set_exploration_type,
)
from torchrl.modules import MultiAgentMLP, ProbabilisticActor, TanhNormal
from torchrl.objectives import ClipPPOLoss, ValueEstimators

FRAMES = 512  # environment steps per PPO iteration (each step: every robot)
OBS = ("robot", "observation")


def make_torchrl_env(seed: int) -> TransformedEnv:
    swarm_env = make_env()
    space = swarm_env.observation_space(swarm_env.possible_agents[0])
    low, high = torch.as_tensor(space.low), torch.as_tensor(space.high)
    env = PettingZooWrapper(env=swarm_env, use_mask=True, categorical_actions=False, seed=seed)
    # ObservationNorm computes obs * scale + loc: (x - centre) / half_width
    half = (high - low) / 2
    norm = ObservationNorm(loc=-(high + low) / 2 / half, scale=1 / half, in_keys=[OBS])
    return TransformedEnv(env, norm)


def main(argv: list[str] | None = None) -> dict[str, float]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--iterations", type=int, default=20, help="PPO iterations (rollout + update)")
    ap.add_argument("--episodes", type=int, default=8, help="evaluation episodes per policy")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)

    torch.manual_seed(args.seed)
    torch.set_num_threads(1)  # small networks: threads only contend
    env = make_torchrl_env(args.seed)
    n = len(env.group_map["robot"])
    obs_dim = env.observation_spec[OBS].shape[-1]
    act_dim = env.full_action_spec["robot", "action"].shape[-1]

    actor_net = nn.Sequential(
        MultiAgentMLP(obs_dim, 2 * act_dim, n, centralised=False, share_params=True, depth=2, num_cells=64,
                      activation_class=nn.Tanh),
        NormalParamExtractor(),
    )  # fmt: skip
    actor = ProbabilisticActor(
        TensorDictModule(actor_net, in_keys=[OBS], out_keys=[("robot", "loc"), ("robot", "scale")]),
        spec=env.full_action_spec["robot", "action"],
        in_keys=[("robot", "loc"), ("robot", "scale")],
        out_keys=[("robot", "action")],
        distribution_class=TanhNormal,
        distribution_kwargs={"low": -1.0, "high": 1.0},
        return_log_prob=True,
    )
    critic = TensorDictModule(
        MultiAgentMLP(obs_dim, 1, n, centralised=False, share_params=True, depth=2, num_cells=64,
                      activation_class=nn.Tanh),
        in_keys=[OBS],
        out_keys=[("robot", "state_value")],
    )  # fmt: skip
    loss = ClipPPOLoss(actor_network=actor, critic_network=critic, clip_epsilon=0.2, entropy_coeff=0.0)
    loss.set_keys(
        reward=("robot", "reward"),
        action=("robot", "action"),
        value=("robot", "state_value"),
        done=("robot", "done"),
        terminated=("robot", "terminated"),
        sample_log_prob=("robot", "action_log_prob"),
    )
    loss.make_value_estimator(ValueEstimators.GAE, gamma=0.99, lmbda=0.95)
    optim = torch.optim.Adam(loss.parameters(), lr=3e-4)
    # the policy is a plain MLP with no recurrent state to reset, so the env needs no InitTracker
    # (TorchRL 0.14 warns that it lacks one whatever the policy, and from 0.15 would append it)
    collector = Collector(
        env,
        actor,
        frames_per_batch=FRAMES,
        total_frames=FRAMES * args.iterations,
        device="cpu",
        auto_register_policy_transforms=False,
    )

    t0 = time.perf_counter()
    for batch in collector:
        with torch.no_grad():
            loss.value_estimator(
                batch, params=loss.critic_network_params, target_params=loss.target_critic_network_params
            )
        flat = batch.reshape(-1)
        for _ in range(4):  # epochs
            for idx in torch.randperm(len(flat)).split(128):
                out = loss(flat[idx])
                total = out["loss_objective"] + out["loss_critic"] + out["loss_entropy"]
                optim.zero_grad()
                total.backward()
                nn.utils.clip_grad_norm_(loss.parameters(), 1.0)
                optim.step()
        collector.update_policy_weights_()
    train_s = time.perf_counter() - t0
    collector.shutdown()

    def trained(obs: np.ndarray) -> np.ndarray:
        td = TensorDict({OBS: torch.as_tensor(obs)}, batch_size=obs.shape[:1])
        with torch.no_grad(), set_exploration_type(ExplorationType.DETERMINISTIC):
            return actor(td)["robot", "action"].numpy()

    ppo = evaluate(trained, args.episodes, seed=args.seed + 1000)
    rand = evaluate(random_policy(args.seed), args.episodes, seed=args.seed + 1000)
    steps = FRAMES * args.iterations * n
    print(f"TorchRL PPO, {args.iterations} iterations, {steps} robot-steps in {train_s:.1f} s")
    print(f"mean return per robot over {args.episodes} episodes: PPO {ppo:.2f}, random {rand:.2f}")
    return {"ppo": ppo, "random": rand}


if __name__ == "__main__":
    main()
