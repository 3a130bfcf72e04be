"""The acceptance measure: calibrated on a square, the `skid` model predicts a held-out run.

The held-out square-spiral-line runs in swarm/data/robot-runs/heldout/ come from the MuJoCo
reference simulator (benchmarks/reference/), fitted to the sample runs; the `skid` model never saw
them. Target (issue 2): path RMSE under 3% of the distance travelled, and far better than the
thesis's own models with the thesis's own correction factors.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest
import yaml

from swarm.robot.calibrate import calibrate
from swarm.robot.params import load_robot
from swarm.robot.runs import load_encoder_run
from swarm.robot.terrain import load_library
from swarm.robot.validate import validate

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "swarm" / "data"
ROBOT = load_robot(DATA / "robots" / "skid4.yaml")


def run(folder: Path, name: str):
    return load_encoder_run(ROBOT, folder / f"{name}_encoders.txt", folder / f"{name}_truth.txt")


@pytest.mark.slow
@pytest.mark.parametrize(("surface", "mode"), [("concrete", "concrete"), ("hardsand", "wet_hard_sand")])
def test_shipped_calibration_predicts_held_out_square_spiral_line(surface: str, mode: str) -> None:
    fitted = load_library(DATA / "terrain" / f"skid4-{surface}.yaml")[mode]
    held = run(DATA / "robot-runs" / "heldout", f"{surface}_square_spiral_line")
    skid = validate(held, ROBOT, fitted, "skid")[0]
    assert skid.path_rmse_pct < 3.0
    base = load_library()[mode]
    thesis_kin = validate(
        held, ROBOT, replace(base, model_params={"kinematic": {"heading_scale": 0.73}}), "kinematic"
    )[0]
    thesis_dyn = validate(held, ROBOT, base, "lagrangian")[0]
    assert skid.path_rmse_m < 0.3 * min(thesis_kin.path_rmse_m, thesis_dyn.path_rmse_m)


@pytest.mark.slow
def test_shipped_calibration_is_what_calibrate_makes() -> None:
    """The shipped file is reproducible: calibrating the bundled square gives the same coefficients."""
    shipped = yaml.safe_load((DATA / "terrain" / "skid4-concrete.yaml").read_text())
    square = run(DATA / "robot-runs", "concrete_square")
    result = calibrate([square], ROBOT, load_library()["concrete"], "skid")
    for name, value in shipped["fitted"]["parameters"].items():
        assert result.parameters[name] == pytest.approx(value, abs=1e-5)
    straight = run(DATA / "robot-runs", "concrete_straight")
    assert validate(straight, ROBOT, result.mode, "skid")[0].path_rmse_pct < 1.0
