"""A recorded run: what drove the wheels and, when there is one, the pose reference to score against."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from swarm.errors import InputError
from swarm.robot.io import Truth, read_encoders, read_ssv, read_truth
from swarm.robot.params import RobotParams
from swarm.robot.wheels import WheelInput


@dataclass(frozen=True, eq=False)
class Run:
    """Wheel input and pose reference on one clock starting at 0 (the thesis normalizes both)."""

    name: str
    wheels: WheelInput
    truth: Truth

    @property
    def pose0(self) -> tuple[float, float, float]:
        return float(self.truth.x_m[0]), float(self.truth.y_m[0]), float(self.truth.heading_rad[0])

    @property
    def distance_m(self) -> float:
        """Path length of the reference."""
        return float(np.sum(np.hypot(np.diff(self.truth.x_m), np.diff(self.truth.y_m))))


#: A skid-steered robot covers about what its wheels roll, less the slip: a reference path longer
#: than this many times the wheels' rolled distance (plus `TRAVEL_SLACK_M` of noise) is in other
#: units (millimetres), or of another robot.
MAX_TRAVEL_PER_ROLL = 3.0
TRAVEL_SLACK_M = 1.0


def _rebased(truth: Truth) -> Truth:
    return Truth(truth.t_s - truth.t_s[0], truth.x_m, truth.y_m, truth.heading_rad, truth.source)


def load_encoder_run(
    robot: RobotParams, encoders: str | Path, truth: str | Path, counter_bits: int | None = None
) -> Run:
    """An encoder log with its motion-capture reference."""
    log = read_encoders(encoders, counter_bits=counter_bits)
    wheels = WheelInput.from_encoders(log, robot.encoder_ticks_per_wheel_rev)
    ref = _rebased(read_truth(truth))
    if ref.t_s[-1] < 0.5 * wheels.duration_s or wheels.duration_s < 0.5 * ref.t_s[-1]:
        raise InputError(
            truth,
            "time span",
            f"{ref.t_s[-1]:.2f} s",
            f"about the encoder log's {wheels.duration_s:.2f} s ({encoders}): are these the same run?",
        )
    run = Run(Path(encoders).name.removesuffix("_encoders.txt").removesuffix(".txt"), wheels, ref)
    rolled = (
        robot.wheel_radius_m
        * 0.5
        * float(np.abs(np.diff(wheels.left_rad)).sum() + np.abs(np.diff(wheels.right_rad)).sum())
    )
    if run.distance_m > MAX_TRAVEL_PER_ROLL * rolled + TRAVEL_SLACK_M:
        raise InputError(
            truth,
            "path length",
            f"{run.distance_m:.2f} m",
            f"at most about the {rolled:.2f} m the wheels rolled ({encoders}, the robot's "
            "wheel_radius_m and encoder ticks): is the reference in metres?",
        )
    return run


def load_ssv_run(path: str | Path) -> Run:
    """A simulation export: measured wheel speeds and the simulated pose in one file."""
    export = read_ssv(path)
    truth = Truth(export.t_s - export.t_s[0], export.x_m, export.y_m, export.heading_rad, export.source)
    return Run(Path(path).stem, WheelInput.from_ssv(export), truth)
