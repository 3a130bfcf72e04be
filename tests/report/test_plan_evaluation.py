"""The plan report's evaluation table puts the simulated losses beside the plan's, phase by phase."""

from __future__ import annotations

from swarm.report.plan_report import evaluation_table, lost_by_phase
from swarm.sim.layout import PHASES


def _evaluation() -> dict:
    # 4 runs: 6 lost at sea (waiting and sea transit), 2 in the surf, 8 ashore, 2 on the way back
    return {
        "runs": 4,
        "confidence": 0.95,
        "success_rate": 1.0,
        "successes": 4,
        "wilson_low": 0.51,
        "wilson_high": 1.0,
        "target": 0.9,
        "lost": {"mean": 4.5, "min": 3, "max": 6},
        "losses_by_cause": {"failure": 14, "wave_impact": 4},
        "losses_by_phase": {
            "waiting": {"failure": 1},
            "sea_transit": {"failure": 5},
            "surf_crossing": {"wave_impact": 2},
            "beach": {"failure": 8},
            "returning": {"wave_impact": 2},
        },
    }


def test_every_simulator_phase_maps_to_a_budget_phase() -> None:
    from swarm.report.plan_report import BUDGET_PHASE

    assert set(BUDGET_PHASE) == set(PHASES) - {"done"}
    assert set(BUDGET_PHASE.values()) == {"sea", "surf", "beach", "return"}


def test_simulated_losses_are_per_run_in_the_plan_s_phases() -> None:
    assert lost_by_phase(_evaluation()) == {"sea": 1.5, "surf": 0.5, "beach": 2.0, "return": 0.5}


def test_the_table_puts_simulated_and_planned_side_by_side() -> None:
    expected = {
        "hazards": True,
        "total": 4.2,
        "by_phase": {
            "sea": {"failure": 1.2},
            "surf": {"wave_impact": 0.4, "failure": 0.1},
            "beach": {"failure": 2.5},
        },
    }
    rows = dict(map(tuple, evaluation_table(_evaluation(), expected)))
    assert rows["lost per run: simulated / planned"] == (
        "4.5 / 4.2 (sea 1.5 / 1.2, surf 0.5 / 0.5, beach 2.0 / 2.5, return 0.5 / 0.0)"
    )
    # without the plan's losses (hazards off, or an older plan), no such row
    assert "lost per run: simulated / planned" not in dict(map(tuple, evaluation_table(_evaluation())))
    off = {**expected, "hazards": False}
    assert "lost per run: simulated / planned" not in dict(map(tuple, evaluation_table(_evaluation(), off)))
