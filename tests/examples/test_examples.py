"""The training examples (`examples/`) run end to end for one PPO iteration each: they train,
evaluate the trained and the random policy on `swarm.sim.vector_env`, and print both mean returns;
the SB3 one is reproducible from its seed. They need the `examples` extra (torch,
stable-baselines3, torchrl), which scripts/test installs: without it these tests fail."""

from __future__ import annotations

import importlib.util
import math
import re
import sys
import tempfile
import warnings
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
RESULT = re.compile(r"mean return per robot over (\d+) episodes: PPO (-?[\d.]+), random (-?[\d.]+)")


def _load(name: str) -> ModuleType:
    if str(EXAMPLES) not in sys.path:
        sys.path.insert(0, str(EXAMPLES))  # the scripts import their shared `task` module
    spec = importlib.util.spec_from_file_location(f"example_{name}", EXAMPLES / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _check(out: str, result: dict[str, float]) -> None:
    m = RESULT.search(out)
    assert m, out
    assert int(m.group(1)) == 2
    assert float(m.group(2)) == pytest.approx(result["ppo"], abs=0.006)
    assert float(m.group(3)) == pytest.approx(result["random"], abs=0.006)
    assert math.isfinite(result["ppo"]) and math.isfinite(result["random"])


@pytest.mark.slow
def test_sb3_example_trains_and_replays_from_its_seed(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """...and leaves nothing behind: SB3's default logger made an empty SB3-<time> folder in the
    temporary directory on every run."""
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    sb3 = _load("sb3_ppo")
    args = ["--iterations", "1", "--copies", "2", "--episodes", "2", "--seed", "3"]
    first = sb3.main(args)
    _check(capsys.readouterr().out, first)
    assert sb3.main(args) == first, "same seed, same training, same returns"
    assert not list(tmp_path.glob("SB3-*"))


@pytest.mark.slow
def test_torchrl_example_trains(capsys: pytest.CaptureFixture[str]) -> None:
    """...and uses TorchRL's current API: no FutureWarning (its collector warned that the env
    lacked an InitTracker, a transform the example's MLP policy has no use for)."""
    torchrl = _load("torchrl_ppo")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", FutureWarning)
        result = torchrl.main(["--iterations", "1", "--episodes", "2", "--seed", "3"])
    assert not [str(w.message) for w in caught if issubclass(w.category, FutureWarning)]
    _check(capsys.readouterr().out, result)


def test_the_examples_task_rewards_progress_to_the_goal() -> None:
    """GoalProgress's reward is the team reward plus the metres each robot closed on its goal."""
    task = _load("task")
    env = task.make_env()
    env.reset(seed=0)
    goal = env.layout.names.index("goal_distance_m")
    before = env.observe()[:, goal].astype(np.float64)
    score = env.score.score()
    for _ in range(40):  # onto the map, driving forward
        prev = env.observe()[:, goal].astype(np.float64)
        acts = {a: np.array([1.0, 1.0, 1.0], np.float32) for a in env.agents}
        obs, rew, *_ = env.step(acts)
        change = env.score.score() - score
        score = env.score.score()
        for a, r in rew.items():
            i = env.agent_index[a]
            assert r == pytest.approx(change + prev[i] - obs[a][goal], abs=1e-9)
    assert not np.array_equal(env.observe()[:, goal], before), "the robots moved"
