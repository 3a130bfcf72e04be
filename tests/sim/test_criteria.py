"""The running mission score (`swarm.sim.criteria.MissionScore`): the value it keeps between changes
is the value it would compute afresh."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from swarm.mission.load import load_mission
from swarm.sim.criteria import MissionScore

MISSIONS = Path(__file__).resolve().parents[2] / "missions"


@pytest.mark.parametrize("name", ["landing", "mine_clear", "relay", "full_conops"])
def test_the_kept_score_is_the_score_computed_afresh(name: str) -> None:
    mission = load_mission(MISSIONS / f"{name}.yaml")
    relay = 2 if mission.tasks_of("relay") else None
    score = MissionScore(mission, relay, n_mines=12)
    rng = np.random.default_rng(0)
    seen = set()
    for step in range(300):
        change = rng.integers(0, 5)
        if change == 0:
            score.detected = min(12, score.detected + 1)
        elif change == 1 and len(score.zone_reached):
            score.zone_reached[rng.integers(len(score.zone_reached))] = True
        elif change == 2:
            score.recovered += 1
        if step == 20:
            score.beach_start_s = 10.0
        score.update(10.0 + step, 1.0, rng.uniform(0.0, 50.0, (3, 2)), bool(rng.integers(2)))
        kept = score.score()
        assert kept == score._score()
        seen.add(kept)
    assert len(seen) > 3  # the score moved
