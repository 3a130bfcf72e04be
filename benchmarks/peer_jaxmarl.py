"""JaxMARL's MPE `simple_spread_v3` on the CPU: agent-steps per second of B environments of N agents
stepped together (`jax.vmap` of the step, `jax.jit`-compiled), random continuous actions, the peer
`bench_env.py --jaxmarl-python` puts beside the batched vector env.

Run it with a Python that has JaxMARL (not a dependency of surf-swarm; a throwaway venv):

    python3 -m venv /tmp/jaxvenv && /tmp/jaxvenv/bin/pip install jaxmarl "jax[cpu]"
    /tmp/jaxvenv/bin/python benchmarks/peer_jaxmarl.py 100x100 10x1000 [--steps 50] [--box-s 20]

One core: XLA's CPU threads are turned off (set before jax is imported), as numpy's work is on one
thread. Method: build the env, reset B keys, draw `--steps` actions beforehand, compile with one
untimed step, then time `--steps` steps (or until `--box-s` seconds), blocking on the results of
each. A rate is B * N * steps / wall time. Prints one JSON line per configuration.
"""

from __future__ import annotations

import argparse
import json
import os
import time

os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1")

import jax
from jaxmarl import make
from jaxmarl.environments.mpe.default_params import CONTINUOUS_ACT


def rate(b: int, n: int, steps: int, box_s: float, seed: int) -> dict:
    env = make("MPE_simple_spread_v3", num_agents=n, num_landmarks=n, action_type=CONTINUOUS_ACT)
    keys = jax.random.split(jax.random.PRNGKey(seed), b)
    _, states = jax.vmap(env.reset)(keys)
    dim = env.action_space(env.agents[0]).shape[0]
    acts = jax.random.uniform(jax.random.PRNGKey(seed + 1), (steps + 1, n, b, dim))

    @jax.jit
    def step(keys, states, a):
        actions = {agent: a[i] for i, agent in enumerate(env.agents)}
        _, states, rew, _, _ = jax.vmap(env.step)(keys, states, actions)
        return states, rew

    states, rew = step(keys, states, acts[0])  # compile
    jax.block_until_ready(rew)
    done, t0 = 0, time.perf_counter()
    while done < steps and (done == 0 or time.perf_counter() - t0 < box_s):
        states, rew = step(keys, states, acts[done + 1])
        jax.block_until_ready(rew)
        done += 1
    wall = time.perf_counter() - t0
    return {
        "B": b,
        "N": n,
        "steps": done,
        "agent_steps_per_s": b * n * done / wall,
        "ms_per_step": wall / done * 1e3,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("configs", nargs="+", help="BxN, e.g. 100x100")
    ap.add_argument("--steps", type=int, default=50)
    ap.add_argument("--box-s", type=float, default=20.0)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    for c in args.configs:
        b, n = (int(v) for v in c.lower().split("x"))
        out = rate(b, n, args.steps, args.box_s, args.seed)
        out["jax"] = jax.__version__
        print(json.dumps(out), flush=True)


if __name__ == "__main__":
    main()
