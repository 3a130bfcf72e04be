"""Calibration: recovers coefficients it generated, and a fit on one pattern transfers to another."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml

from swarm.robot.calibrate import (
    calibrate,
    default_free,
    physical_warnings,
    predicted_poses,
    write_calibration,
)
from swarm.robot.io import Truth
from swarm.robot.params import load_robot
from swarm.robot.predict import FIXED_STEP_S, predict
from swarm.robot.runs import Run, load_encoder_run
from swarm.robot.terrain import library_from_dict, load_library
from swarm.robot.validate import validate
from swarm.robot.wheels import WheelInput

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "swarm" / "data" / "robot-runs"
ROBOT = load_robot(ROOT / "swarm" / "data" / "robots" / "skid4.yaml")
LIB = load_library()


def synthetic_run(mode, seconds: float = 12.0, robot=ROBOT, adaptive: bool = True) -> Run:
    """A drive with a car turn and a pivot, its 'truth' from the skid model itself (adaptive, or
    in fine fixed steps)."""
    t = np.arange(0.0, seconds + 1e-9, 0.01)
    base = 5.0 * np.clip(t, 0, 1)
    turn = 4.0 * np.sin(np.pi * np.clip((t - 3.0) / 3.0, 0, 1)) ** 2
    pivot = 4.0 * np.sin(np.pi * np.clip((t - 7.0) / 3.0, 0, 1)) ** 2
    left = np.where(t < 7, base - turn, -pivot)
    right = np.where(t < 7, base + turn, pivot)
    stop = np.clip((t - 6.0) / 1.0, 0, 1)
    left, right = np.where(t < 7, left * (1 - stop), left), np.where(t < 7, right * (1 - stop), right)
    wheels = WheelInput.from_speeds(t, left, right)
    dt = 0.01 if adaptive else 0.001
    traj = predict("skid", wheels, robot, mode, (0.0, 0.0, 0.5), adaptive=adaptive, dt_s=dt)
    truth = Truth(traj.t_s, traj.x_m, traj.y_m, traj.heading_rad, "synthetic")
    return Run("synthetic", wheels, truth)


@pytest.mark.slow
def test_skid_calibration_recovers_the_coefficients_that_made_the_data() -> None:
    """Without the prior toward the defaults, the fit finds what generated the data (up to the
    difference of calibration's own fixed step, the default, from the adaptive run that made it:
    measured, mu_lateral 0.2475 and turning resistance 0.0796 m)."""
    true = replace(LIB["concrete"], mu_lateral=0.25, turning_resistance_m=0.08, shear_slip=0.05)
    run = synthetic_run(true)
    result = calibrate(
        [run],
        ROBOT,
        LIB["concrete"],
        "skid",
        free=["mu_lateral", "turning_resistance_m"],
        max_evaluations=30,
        prior_m=0.0,
    )
    assert result.parameters["mu_lateral"] == pytest.approx(0.25, rel=0.05)
    assert result.parameters["turning_resistance_m"] == pytest.approx(0.08, rel=0.1)
    assert result.after[0].path_rmse_m < 0.1 * result.before[0].path_rmse_m


def test_kinematic_icr_fit_finds_the_four_wheel_skid() -> None:
    """A four-wheel skid-steer turns less than its track says (chi > 1, as Mandow et al. found)."""
    square = load_encoder_run(
        ROBOT, DATA / "concrete_square_encoders.txt", DATA / "concrete_square_truth.txt"
    )
    result = calibrate([square], ROBOT, LIB["concrete"], "kinematic")
    assert result.parameters["chi"] > 1.3
    assert result.after[0].path_rmse_m < 0.5 * result.before[0].path_rmse_m


@pytest.mark.slow
def test_written_calibration_reads_back_as_the_same_mode(tmp_path: Path) -> None:
    run = synthetic_run(LIB["wet_hard_sand"], seconds=6.0)
    result = calibrate(
        [run], ROBOT, LIB["wet_hard_sand"], "skid", free=["mu_lateral"], max_evaluations=5, name="beach_a"
    )
    out = tmp_path / "fit.yaml"
    write_calibration(out, result, ROBOT, [run])
    doc = yaml.safe_load(out.read_text())
    assert doc["fitted"]["runs"] == ["synthetic"]
    mode = library_from_dict(doc, out, LIB)["beach_a"]
    assert mode.mu_lateral == pytest.approx(result.mode.mu_lateral, abs=1e-6)
    assert mode.mu_peak == LIB["wet_hard_sand"].mu_peak
    assert load_library(out)["beach_a"].shear_slip == pytest.approx(result.mode.shear_slip, abs=1e-6)
    assert list(tmp_path.iterdir()) == [out]


def test_unknown_free_parameter_is_refused() -> None:
    run = synthetic_run(LIB["concrete"], seconds=2.0)
    with pytest.raises(ValueError, match="cannot fit"):
        calibrate([run], ROBOT, LIB["concrete"], "kinematic", free=["mu_peak"])


MODE_OF_SURFACE = {"concrete": "concrete", "hardsand": "wet_hard_sand", "softsand": "soft_sand"}
BUNDLED_RUNS = sorted(
    (p.parent, p.name.removesuffix("_encoders.txt"))
    for p in [*DATA.glob("*_encoders.txt"), *DATA.glob("heldout/*_encoders.txt")]
)


def _bundled(folder: Path, name: str):
    run = load_encoder_run(ROBOT, folder / f"{name}_encoders.txt", folder / f"{name}_truth.txt")
    return run, LIB[MODE_OF_SURFACE[name.split("_")[0]]]


@pytest.mark.slow
@pytest.mark.parametrize(("folder", "name"), BUNDLED_RUNS, ids=[n for _, n in BUNDLED_RUNS])
def test_validation_predicts_what_calibration_fits(folder: Path, name: str) -> None:
    """Validation integrates as calibration does, so a fitted mode scores what the fit saw."""
    run, mode = _bundled(folder, name)
    t, poses = predicted_poses(run, ROBOT, [mode], FIXED_STEP_S)
    traj = validate(run, ROBOT, mode, "skid")[1]
    np.testing.assert_allclose(traj.t_s, t)
    np.testing.assert_allclose(np.stack([traj.x_m, traj.y_m, traj.heading_rad], -1), poses[:, 0], atol=1e-9)


@pytest.mark.slow
def test_adaptive_validation_with_a_bounded_step_agrees_with_the_fixed_step() -> None:
    """Unbounded, LSODA once stepped over whole turns and ended a square 180 degrees off; bounded
    by calibration's step it lands within a fraction of a percent of the fixed-step answer."""
    run, mode = _bundled(DATA, "concrete_square")
    fixed = validate(run, ROBOT, mode, "skid")[0]
    adaptive = validate(run, ROBOT, mode, "skid", adaptive=True)[0]
    assert abs(adaptive.path_rmse_pct - fixed.path_rmse_pct) < 0.1
    # over 500 degrees of turning; the rest is load transfer, lagged a step in the fixed scheme
    assert abs(adaptive.final_heading_error_deg - fixed.final_heading_error_deg) < 3.0


def straight_run(mode, robot=ROBOT, seconds: float = 8.0) -> Run:
    """A short straight with a speed change: says much about traction, nothing about turning."""
    t = np.arange(0.0, seconds + 1e-9, 0.01)
    speed = 5.0 * np.clip(t / 0.5, 0, 1) * np.clip((seconds - t) / 0.5, 0, 1)
    wheels = WheelInput.from_speeds(t, speed, speed)
    traj = predict("skid", wheels, robot, mode, (0.0, 0.0, 0.3))
    return Run("straight", wheels, Truth(traj.t_s, traj.x_m, traj.y_m, traj.heading_rad, "synthetic"))


@pytest.mark.slow
def test_a_parameter_the_runs_cannot_see_is_held_by_its_prior_and_reported() -> None:
    """A straight says nothing about turning resistance: its resolution is ~0, it stays at the
    prior, and the report says so; the rolling radius the straight does show is set by the run."""
    true = replace(LIB["concrete"], rolling_radius_scale=0.95)
    result = calibrate(
        [straight_run(true)],
        ROBOT,
        LIB["concrete"],
        "skid",
        free=["turning_resistance_m", "rolling_radius_scale"],
        max_evaluations=8,
    )
    assert result.resolution["turning_resistance_m"] < 0.01
    assert result.parameters["turning_resistance_m"] == pytest.approx(LIB["concrete"].turning_resistance_m)
    assert result.held_by_prior == ["turning_resistance_m"]
    assert result.resolution["rolling_radius_scale"] > 0.8
    assert result.parameters["rolling_radius_scale"] == pytest.approx(0.95, abs=0.01)
    sigma = LIB["concrete"].uncertainty["turning_resistance_m"]
    assert result.priors["turning_resistance_m"] == (LIB["concrete"].turning_resistance_m, sigma)
    # what the runs do not say is as uncertain as the prior says; what they do say, much less
    assert result.std_errors["turning_resistance_m"] == pytest.approx(sigma, rel=0.02)
    radius_sd = LIB["concrete"].uncertainty["rolling_radius_scale"]
    assert result.std_errors["rolling_radius_scale"] < 0.2 * radius_sd


@pytest.mark.slow
@pytest.mark.parametrize(("sigma", "expect_near"), [(1e-4, "prior"), (1.0, "data")])
def test_the_prior_pulls_as_hard_as_its_stated_uncertainty(sigma: float, expect_near: str) -> None:
    """The same run and start: a mode whose default is certain keeps it; an uncertain one follows
    the data."""
    true = replace(LIB["concrete"], rolling_radius_scale=0.93)
    base = replace(
        LIB["concrete"], uncertainty={**LIB["concrete"].uncertainty, "rolling_radius_scale": sigma}
    )
    result = calibrate(
        [straight_run(true)], ROBOT, base, "skid", free=["rolling_radius_scale"], max_evaluations=8
    )
    target = 1.0 if expect_near == "prior" else 0.93
    assert result.parameters["rolling_radius_scale"] == pytest.approx(target, abs=0.003)


def test_a_fit_outside_the_physical_range_warns_in_one_line_per_value() -> None:
    lines = physical_warnings({"mu_peak": 2.26, "mu_lateral": 0.9, "rolling_radius_scale": 1.08}, ROBOT)
    assert len(lines) == 2
    assert lines[0].startswith("fitted mu_peak = 2.26 is outside its physical range [0.1, 1.2]")
    assert "rolling_radius_scale = 1.08" in lines[1] and "1.05" in lines[1]
    assert all("\n" not in line for line in lines)
    assert physical_warnings({"com_x_m": -0.067}, ROBOT) == []


def test_unstated_centre_of_mass_is_fitted_by_default_and_a_stated_one_is_not() -> None:
    unknown = replace(ROBOT, com_stated=False)
    assert default_free("skid", unknown)[-2:] == ["com_x_m", "com_y_m"]
    assert "com_x_m" not in default_free("skid", ROBOT)  # skid4.yaml states it
    assert "com_x_m" not in default_free("kinematic", unknown)


@pytest.mark.slow
def test_calibration_finds_a_rear_heavy_robots_centre_of_mass() -> None:
    """A robot 6 cm rear-heavy, its file silent on it: the fit finds the offset from a turning
    run, keeps it with the mode, and validation uses it."""
    heavy = replace(ROBOT, com_x_m=-0.06, com_stated=True)
    run = synthetic_run(LIB["concrete"], seconds=10.0, robot=heavy, adaptive=False)
    unknown = replace(ROBOT, com_stated=False)
    result = calibrate(
        [run], unknown, LIB["concrete"], "skid", free=["com_x_m"], max_evaluations=6, prior_m=0.0
    )
    assert result.parameters["com_x_m"] == pytest.approx(-0.06, abs=0.005)
    assert result.mode.model_params["skid"]["com_x_m"] == pytest.approx(result.parameters["com_x_m"])
    assert validate(run, unknown, result.mode, "skid")[0].path_rmse_m < 0.01


@pytest.mark.slow
def test_runs_are_fitted_jointly() -> None:
    """Two runs from one ground: the joint fit scores both and explains both."""
    true = replace(LIB["concrete"], mu_lateral=0.4, rolling_radius_scale=0.96)
    runs = [synthetic_run(true, seconds=6.0), straight_run(true, seconds=4.0)]
    result = calibrate(
        runs,
        ROBOT,
        LIB["concrete"],
        "skid",
        free=["mu_lateral", "rolling_radius_scale"],
        max_evaluations=6,
        prior_m=0.0,
    )
    assert [s.run for s in result.after] == ["synthetic", "straight"]
    assert all(a.path_rmse_m < 0.2 * b.path_rmse_m for a, b in zip(result.after, result.before, strict=True))
    assert result.parameters["rolling_radius_scale"] == pytest.approx(0.96, abs=0.01)
