"""A pose reference whose log started before or after the encoder log: `runs.truth_offset_s`
finds the offset from the speeds, `runs.with_truth_offset` puts both logs on one clock, and a
prediction from the shifted run scores as the run recorded together."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from swarm.robot.io import Truth
from swarm.robot.params import load_robot
from swarm.robot.runs import (
    Run,
    load_encoder_run,
    truth_offset_s,
    with_truth_offset,
)
from swarm.robot.terrain import load_library
from swarm.robot.validate import validate
from swarm.robot.wheels import WheelInput

ROOT = Path(__file__).resolve().parents[2]
RUNS = ROOT / "swarm" / "data" / "robot-runs"
ROBOT = load_robot(ROOT / "swarm" / "data" / "robots" / "skid4.yaml")
#: The mode fitted to the concrete square (`swarm model calibrate`), bundled.
CONCRETE = load_library(ROOT / "swarm" / "data" / "terrain" / "skid4-concrete.yaml")


def _run(name: str) -> Run:
    return load_encoder_run(ROBOT, RUNS / f"{name}_encoders.txt", RUNS / f"{name}_truth.txt")


def _truth_started_late(run: Run, late_s: float) -> Run:
    """The run as a motion-capture log started `late_s` after the encoder log would record it,
    on its own clock from 0 (negative: started earlier, holding the first pose until then)."""
    t = run.truth
    if late_s >= 0:
        keep = t.t_s >= late_s
        ref = Truth(t.t_s[keep] - t.t_s[keep][0], t.x_m[keep], t.y_m[keep], t.heading_rad[keep], t.source)
        return Run(run.name, run.wheels, ref)
    lead = np.arange(0.0, -late_s, 0.01)
    held = np.ones_like(lead)
    ref = Truth(
        np.concatenate([lead, t.t_s - late_s]),
        np.concatenate([held * t.x_m[0], t.x_m]),
        np.concatenate([held * t.y_m[0], t.y_m]),
        np.concatenate([held * t.heading_rad[0], t.heading_rad]),
        t.source,
    )
    return Run(run.name, run.wheels, ref)


@pytest.mark.parametrize("name", ["concrete_square", "concrete_straight", "hardsand_square"])
def test_runs_recorded_together_have_no_offset_worth_a_warning(name: str) -> None:
    assert truth_offset_s(_run(name), ROBOT) == 0.0  # no shift explains the motion clearly better


@pytest.mark.parametrize("late_s", [0.5, 1.2, -0.4])
@pytest.mark.parametrize("name", ["concrete_square", "concrete_straight"])
def test_the_offset_is_found_to_a_step(name: str, late_s: float) -> None:
    found = truth_offset_s(_truth_started_late(_run(name), late_s), ROBOT)
    assert found == pytest.approx(late_s, abs=0.03)  # three steps of the search


@pytest.mark.parametrize("late_s", [0.5, -0.4])
@pytest.mark.parametrize("name", ["concrete_square", "concrete_straight"])
def test_a_run_on_one_clock_again_scores_as_recorded(name: str, late_s: float) -> None:
    """The prediction from the run put back on one clock scores within 0.2% of the distance of
    the run as recorded; left as it is, the shifted run scores 1.5-8% worse. (A reference started
    well into the motion scores worse however it is aligned: the model starts it at rest.)"""
    run = _run(name)
    shifted = _truth_started_late(run, late_s)
    mode = CONCRETE["concrete"]
    want, _ = validate(run, ROBOT, mode, "skid")
    got, _ = validate(with_truth_offset(shifted, truth_offset_s(shifted, ROBOT)), ROBOT, mode, "skid")
    left, _ = validate(shifted, ROBOT, mode, "skid")
    assert abs(got.path_rmse_pct - want.path_rmse_pct) < 0.2
    assert left.path_rmse_pct > want.path_rmse_pct + 1.0


def test_with_truth_offset_puts_both_logs_on_the_span_they_share() -> None:
    wheels = WheelInput(np.array([0.0, 1.0, 2.0, 3.0]), np.array([0.0, 1.0, 2.0, 3.0]), np.zeros(4))
    t = np.arange(0.0, 2.5, 0.5)
    truth = Truth(t, t * 10.0, np.zeros(5), np.zeros(5), "truth.txt")
    run = with_truth_offset(Run("r", wheels, truth), 1.5)  # its samples at 1.5 .. 3.0 on the log
    np.testing.assert_allclose(run.truth.t_s, [0.0, 0.5, 1.0, 1.5])
    np.testing.assert_allclose(run.truth.x_m, [0.0, 5.0, 10.0, 15.0])
    np.testing.assert_allclose(run.wheels.t_s, [0.0, 0.5, 1.5])
    np.testing.assert_allclose(run.wheels.left_rad, [1.5, 2.0, 3.0])  # the angles at 1.5, 2 and 3 s
    early = with_truth_offset(Run("r", wheels, truth), -1.0)  # samples at -1 .. 1: from 0 on
    np.testing.assert_allclose(early.truth.x_m, [10.0, 15.0, 20.0])
    np.testing.assert_allclose(early.wheels.t_s, [0.0, 1.0])


def test_an_offset_past_the_log_is_one_error_naming_the_reference() -> None:
    from swarm.errors import InputError

    run = _run("concrete_straight")
    with pytest.raises(InputError, match="truth offset"):
        with_truth_offset(run, run.wheels.duration_s + 1.0)
