"""Parameter-shared PPO with Stable-Baselines3 on the tiny landing mission, through SuperSuit.

    pip install -e ".[examples]"        # CPU torch: add --extra-index-url https://download.pytorch.org/whl/cpu
    python examples/sb3_ppo.py [--iterations 20] [--copies 4] [--seed 0]

Every robot is one sub-environment of a Stable-Baselines3 vector env and all share one policy:
- `black_death_v3` keeps a lost robot in the batch with zero observations (SB3 needs a fixed
  number of sub-environments);
- `normalize_obs_v0` scales each observation column from its bounds to [-1, 1] (raw bounds run to
  3.6e4), the same map as `vector_env(normalize_obs=True)`;
- `pettingzoo_env_to_vec_env_v1` makes the robots a vector env, `concat_vec_envs_v1` stacks
  `--copies` missions. It has no `seed()`, so `PPO(..., seed=N)` fails on it, and so does
  `reset(seed=N)` of SuperSuit's SB3 wrapper around it (it calls `seed()`): reset the concatenated
  env inside with the seed (copy k gets seed N + k; the unseeded resets that follow, SB3's and the
  autoresets, carry on each copy's seeded stream), and seed torch with `set_random_seed`.
Then it prints the mean return per robot of the trained policy and of a random one, on
`swarm.sim.vector_env` (`examples/task.py`).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import supersuit as ss
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.logger import Logger
from stable_baselines3.common.utils import set_random_seed
from stable_baselines3.common.vec_env import VecEnv
from task import evaluate, make_env, random_policy

N_STEPS = 128  # steps per sub-environment per PPO iteration


def make_vec_env(copies: int) -> VecEnv:
    env = ss.normalize_obs_v0(ss.black_death_v3(make_env()), env_min=-1.0, env_max=1.0)
    vec = ss.pettingzoo_env_to_vec_env_v1(env)
    return ss.concat_vec_envs_v1(vec, copies, num_cpus=0, base_class="stable_baselines3")


def main(argv: list[str] | None = None) -> dict[str, float]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--iterations", type=int, default=20, help="PPO iterations (rollout + update)")
    ap.add_argument("--copies", type=int, default=4, help="missions stacked in the vector env")
    ap.add_argument("--episodes", type=int, default=8, help="evaluation episodes per policy")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)

    set_random_seed(args.seed)
    torch.set_num_threads(1)  # small networks: threads only contend
    venv = make_vec_env(args.copies)
    venv.venv.reset(seed=args.seed)  # concat_vec_envs_v1 has no seed(): PPO(seed=...) would fail on it
    model = PPO(
        "MlpPolicy", venv, n_steps=N_STEPS, batch_size=256, n_epochs=4, learning_rate=3e-4,
        gamma=0.99, ent_coef=0.0, verbose=0, device="cpu",
    )  # fmt: skip
    # a logger that writes nowhere: SB3's default makes an empty /tmp/SB3-<time> folder every run
    model.set_logger(Logger(folder=None, output_formats=[]))
    t0 = time.perf_counter()
    model.learn(total_timesteps=args.iterations * N_STEPS * venv.num_envs)
    train_s = time.perf_counter() - t0
    venv.close()

    def trained(obs: np.ndarray) -> np.ndarray:
        flat = obs.reshape(-1, obs.shape[-1])
        act, _ = model.predict(flat, deterministic=True)
        return act.reshape(*obs.shape[:2], -1)

    ppo = evaluate(trained, args.episodes, seed=args.seed + 1000)
    rand = evaluate(random_policy(args.seed), args.episodes, seed=args.seed + 1000)
    steps = args.iterations * N_STEPS * venv.num_envs
    print(f"SB3 PPO, {args.iterations} iterations, {steps} robot-steps in {train_s:.1f} s")
    print(f"mean return per robot over {args.episodes} episodes: PPO {ppo:.2f}, random {rand:.2f}")
    return {"ppo": ppo, "random": rand}


if __name__ == "__main__":
    main()
