"""The swarm simulator: a PettingZoo environment in which every robot moves by the `skid` model
over the mission's beach map, hazards take robots, and the survivors coordinate over radio.

The core is batched (`swarm.sim.world.World`: B runs on (B, n, ...) arrays, one `advance` for
all); `SwarmEnv` is its PettingZoo adapter for one run, `vector_env` its batched adapter,
`swarm.sim.run.simulate_batch` the scripted policy over a batch.

```python
import pettingzoo
import swarm.sim
env = swarm.sim.parallel_env(mission="missions/mine_clear.yaml", overrides={"swarm.count": 40})
aec = swarm.sim.env(mission="missions/landing.yaml")        # the AEC form, by PettingZoo's conversion
env = pettingzoo.make("parallel", "surf_swarm/Swarm-v0", mission="missions/relay.yaml")
vec = swarm.sim.vector_env(mission="missions/landing.yaml", num_envs=8)  # B runs on arrays (B, n, ...)
```

Importing `swarm.sim` registers `surf_swarm/Swarm-v0` in PettingZoo's registries (parallel and AEC).
"""

from __future__ import annotations

from typing import Any

import pettingzoo
from pettingzoo.utils import conversions, wrappers

from swarm.errors import SwarmError
from swarm.sim.env import ACTION_MODES, COMMANDS, SimConfig, StepOutcome, SwarmEnv
from swarm.sim.vector import SwarmVectorEnv

ENV_ID = "surf_swarm/Swarm-v0"


def parallel_env(**kwargs: Any) -> SwarmEnv:
    """The mission as a `ParallelEnv`: `mission=` path (or loaded Mission), `overrides=`,
    `action_mode=` "wheels" | "command", `render_mode=`, `config=` (`SimConfig`), `max_cycles=`."""
    return SwarmEnv(**kwargs)


class _CheckedAEC(conversions.parallel_to_aec_wrapper):
    """PettingZoo's parallel-to-AEC conversion, with each agent's action checked as it is given:
    the parallel env checks a cycle's actions together, at its last agent, which named a bad
    action agents late."""

    def step(self, action: Any) -> None:
        agent = self.agent_selection
        if not (self.terminations[agent] or self.truncations[agent]):
            self.env.check_action(agent, action)  # None too: it is for an agent that is done
        elif action is not None:  # PettingZoo's own check is a bare assert
            raise SwarmError(
                f"sim: action of {agent}: found {action!r}, expected None: {agent} is done (terminated or"
                " truncated), and the AEC API steps it with None"
            )
        super().step(action)


def env(**kwargs: Any) -> pettingzoo.AECEnv:
    """The AEC form, through PettingZoo's own parallel-to-AEC conversion (each action checked as
    its agent gives it) and order enforcement."""
    return wrappers.OrderEnforcingWrapper(_CheckedAEC(SwarmEnv(**kwargs)))


def vector_env(**kwargs: Any) -> SwarmVectorEnv:
    """B runs of the mission on arrays (`swarm.sim.vector`): `mission=`, `num_envs=`, `overrides=`,
    `action_mode=`, `normalize_obs=`, `seed=`, `config=`, `max_cycles=`, `env_class=` (a `SwarmEnv`
    subclass with its own task hooks)."""
    return SwarmVectorEnv(**kwargs)


raw_env = SwarmEnv


def _register() -> None:
    if ENV_ID not in pettingzoo.parallel_registry:
        pettingzoo.register("parallel", ENV_ID, entry_point=parallel_env)
    if ENV_ID not in pettingzoo.aec_registry:
        pettingzoo.register("aec", ENV_ID, entry_point=env)


_register()

__all__ = [
    "ACTION_MODES",
    "COMMANDS",
    "ENV_ID",
    "SimConfig",
    "StepOutcome",
    "SwarmEnv",
    "SwarmVectorEnv",
    "env",
    "parallel_env",
    "raw_env",
    "vector_env",
]
