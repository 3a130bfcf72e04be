"""The validation figure's legend for a run that goes nowhere."""

from __future__ import annotations

import math

import numpy as np

from swarm.report.validation import validation_figure
from swarm.robot.predict import Trajectory
from swarm.robot.validate import Score


def test_a_run_with_no_distance_has_no_percentage_in_the_legend() -> None:
    """RMSE as a share of no distance is no number: the legend says so instead of "nan%"."""
    t = np.linspace(0.0, 5.0, 11)
    still = Trajectory(t, np.zeros_like(t), np.zeros_like(t), np.zeros_like(t))
    score = Score(
        model="skid", run="still", terrain="concrete", distance_m=0.0, duration_s=5.0,
        final_error_m=0.0, path_rmse_m=0.0, path_rmse_pct=math.nan, max_error_m=0.0,
        heading_rmse_deg=0.0, final_heading_error_deg=0.0,
    )  # fmt: skip
    fig = validation_figure("still", 0.0, still, {"skid": still}, {"skid": score})
    (legend,) = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    texts = [x.get_text() for x in legend.get_texts()]
    assert any("n/a: no distance" in x for x in texts)
    assert not any("nan" in x for x in texts)
