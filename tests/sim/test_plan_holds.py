"""The shipped missions' plans hold in simulation when nothing goes wrong: the mines found match
the plan's expected detection, and the searchers sweep the ground the plan swept."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString

from swarm.mission.load import load_mission
from swarm.mission.plan import plan_mission
from swarm.sim.layout import ROLES
from swarm.sim.run import simulate_batch
from swarm.studies.stats import wilson_interval

MISSIONS = Path(__file__).resolve().parents[2] / "missions"
#: Every hazard off; 200 mines a run, so that ten runs give a +-1% interval.
NO_HAZARDS = {"hazards.enabled": False, "hazards.mines.count": 200, "hazards.mines.density_per_ha": None}


def _driven_swath(log, area, width_m: float) -> float:
    """Share of `area` within W/2 of where the searchers drove (ashore, as searchers)."""
    search = ROLES.index("search")
    lines = []
    for i in range(log.xy_m.shape[1]):
        on = (log.role[:, i] == search) & log.alive[:, i] & np.isfinite(log.xy_m[:, i, 0])
        if on.sum() > 1:
            lines.append(LineString(log.xy_m[on, i]))
    swath = shapely.union_all([line.buffer(width_m / 2.0) for line in lines])
    return float(swath.intersection(area).area / area.area)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["mine_clear", "full_conops"])
def test_with_no_hazards_the_simulation_finds_what_the_plan_expects(name: str) -> None:
    """mine_clear: an inverse-cube sensor on tracks the planner spaced; full_conops: a tabulated
    lateral-range curve, beside landing, relay and surveillance. The plan is the shipped mission's
    own; ten runs (one batch) take every hazard off and lay 200 mines each, for a +-1% interval.

    What the swarm finds must match the plan's expected detection (its Wilson interval holds it).
    The whole swarm, not the searchers alone: a pass is decided as a robot closes on a mine, so a
    lander or a stand-by that comes near a mine first finds one the searchers' tracks would have
    found too; and the searchers sweep the ground the plan swept."""
    plan_for = load_mission(MISSIONS / f"{name}.yaml")
    plan = plan_mission(plan_for, seed=plan_for.seed, workers=1)
    mission = load_mission(MISSIONS / f"{name}.yaml", NO_HAZARDS)
    (search,) = plan.search
    area = mission.beach_map.regions["search_beach"].geometry
    found = total = 0
    for log in simulate_batch(mission, range(1, 11), plan=plan):
        assert not log.losses
        found += int(np.sum(log.mines_state["detected"]))
        total += len(log.mines_m)
        driven = _driven_swath(log, area, search.sweep_width_m)
        planned = shapely.union_all(
            [t.buffer(search.sweep_width_m / 2) for run in search.tracks for t in run]
        )
        assert driven >= 0.95 * planned.intersection(area).area / area.area
    low, high = wilson_interval(found, total, 0.95)
    assert high - low <= 0.025  # enough mines for a +-1% interval
    assert low <= search.expected_detection <= high, (found, total, search.expected_detection)
