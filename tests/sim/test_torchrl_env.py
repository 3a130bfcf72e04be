"""`SwarmTorchEnv`: the batched vector env as a native TorchRL `EnvBase`. TorchRL's own spec check
passes, and a rollout through two autoresets holds, step for step, what the vector env hands out
(with the finished runs' final observations on the step that ends them, and the new episodes'
first observations after TorchRL's reset)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")  # the `examples` extra; CI installs it
pytest.importorskip("torchrl")

from torchrl.envs.utils import check_env_specs  # noqa: E402

import swarm.sim  # noqa: E402
from swarm.sim.torchrl_env import SwarmTorchEnv  # noqa: E402

MISSION = Path(__file__).resolve().parents[2] / "examples" / "tiny_landing.yaml"
RUNS, CYCLES, STEPS = 3, 8, 20


def _kwargs() -> dict:
    return {"mission": MISSION, "num_envs": RUNS, "seed": 4, "max_cycles": CYCLES, "normalize_obs": True}


def test_the_specs_pass_torchrls_check() -> None:
    check_env_specs(SwarmTorchEnv(**_kwargs()))


def test_a_rollout_is_the_vector_env_step_for_step() -> None:
    env = SwarmTorchEnv(**_kwargs())
    n = env.n
    rng = np.random.default_rng(4)
    actions = rng.uniform(-1.0, 1.0, (STEPS, RUNS, n, 3)).astype(np.float32)
    k = iter(range(STEPS))

    def policy(td):
        td.set(("robot", "action"), torch.as_tensor(actions[next(k)]))
        return td

    roll = env.rollout(STEPS, policy=policy, break_when_any_done=False)
    vec = swarm.sim.vector_env(**_kwargs())
    obs, infos = vec.reset()
    for t in range(STEPS):
        np.testing.assert_array_equal(roll["robot", "observation"][:, t].numpy(), obs, err_msg=f"step {t}")
        np.testing.assert_array_equal(roll["robot", "mask"][:, t].numpy(), infos["agent_mask"])
        obs, rew, term, trunc, infos = vec.step(actions[t])
        np.testing.assert_array_equal(
            roll["next", "robot", "reward"][:, t, :, 0].numpy(), rew.astype(np.float32)
        )
        np.testing.assert_array_equal(roll["next", "robot", "terminated"][:, t, :, 0].numpy(), term)
        np.testing.assert_array_equal(roll["next", "robot", "truncated"][:, t, :, 0].numpy(), trunc)
        ended = infos.get("_final_obs", np.zeros(RUNS, bool))
        np.testing.assert_array_equal(roll["next", "done"][:, t, 0].numpy(), ended)
        if ended.any():
            got = roll["next", "robot", "observation"][:, t].numpy()
            np.testing.assert_array_equal(got[ended], infos["final_obs"][ended])
    assert roll["next", "done"].sum() == 2 * RUNS  # every run ended twice: at steps 8 and 16


def test_a_reset_of_runs_still_going_is_refused_not_made_of_every_run() -> None:
    """Asking to reset run 0 alone, mid-episode, once reset both runs, throwing run 1's away."""
    from tensordict import TensorDict

    from swarm.errors import SwarmError

    env = SwarmTorchEnv(mission=MISSION, num_envs=2, seed=0)
    td = env.reset()
    for _ in range(5):
        td.set(("robot", "action"), torch.full((2, env.n, 3), 0.5))
        td = env.step(td)["next"]
    steps = [r.steps for r in env.vec.world.runs]
    with pytest.raises(
        SwarmError, match=r"resets the runs whose episodes ended, or all of them; asked for runs \[0\] of 2"
    ):
        env.reset(TensorDict({"_reset": torch.tensor([[True], [False]])}, batch_size=[2]))
    assert [r.steps for r in env.vec.world.runs] == steps
