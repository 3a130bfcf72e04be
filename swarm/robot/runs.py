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


#: How far apart the encoder log's and the pose reference's starts are looked for (s).
TRUTH_OFFSET_REACH_S = 2.0
#: The step of that search (s): the reference's 100 Hz.
TRUTH_OFFSET_STEP_S = 0.01
#: An offset is only taken from the speeds where it leaves at most this share of what the logs
#: taken to start together leave unexplained (`truth_offset_s`).
TRUTH_OFFSET_CLEAR = 0.5
#: An estimated offset at least this large is worth a warning when the logs are taken to start
#: together: the sample runs and the MuJoCo reference's, started together, estimate 0.00-0.04 s
#: (0.13 s on the thesis's soft-sand straight, where slip keeps the body behind its wheels).
TRUTH_OFFSET_WARN_S = 0.25


def truth_offset_s(run: Run, robot: RobotParams) -> float:
    """When the pose reference's first sample was taken on the encoder log's clock (s; negative:
    before the encoder log began), from the motion both logs record.

    It is the shift, in steps of `TRUTH_OFFSET_STEP_S` within `TRUTH_OFFSET_REACH_S`, at which
    the reference's speed and turn rate are best explained by the wheels', over an overlap of at
    least half the reference. Each is taken as a multiple of the wheels' own (slip and skid scale
    them, they do not shift them), and the turn as the speed it gives the sides, so that a
    straight's turn, all noise, weighs next to nothing. The answer is 0 unless that shift leaves
    at most `TRUTH_OFFSET_CLEAR` of what no shift leaves unexplained and lies inside the search:
    a run of steady speed and turn says little about its clock.

    Both logs start at 0 (the thesis's convention, `Run`); a motion-capture log started half a
    second after the robot's makes every prediction start from the wrong pose at the wrong time
    (concrete_straight: 8.2% path RMSE against 0.09%)."""
    h = TRUTH_OFFSET_STEP_S
    truth, wheels = run.truth, run.wheels
    t = np.arange(0.0, float(truth.t_s[-1]), h)
    if len(t) < 8:
        return 0.0
    x, y = np.interp(t, truth.t_s, truth.x_m), np.interp(t, truth.t_s, truth.y_m)
    turn = np.gradient(np.interp(t, truth.t_s, truth.heading_rad), h)
    body = np.stack([np.hypot(np.gradient(x, h), np.gradient(y, h)), turn * (0.5 * robot.track_width_m)])
    reach = round(TRUTH_OFFSET_REACH_S / h)
    # the wheels' mean and half-difference rolling speeds on the same grid, widened by the reach
    # both ways (NaN off the log)
    te = np.arange(-reach, len(t) + reach) * h
    on_log = (te >= 0.0) & (te <= wheels.duration_s)
    rates = np.gradient(wheels.angles_at(np.clip(te, 0.0, wheels.duration_s)), h, axis=0)
    half = 0.5 * robot.wheel_radius_m
    rolling = np.stack([np.abs(rates[:, 0] + rates[:, 1]) * half, (rates[:, 1] - rates[:, 0]) * half])
    rolling[:, ~on_log] = np.nan
    unexplained = {}
    for k in range(-reach, reach + 1):
        w = rolling[:, reach + k : reach + k + len(t)]
        ok = np.isfinite(w[0])
        if 2 * np.count_nonzero(ok) < len(t):
            continue
        b, e = body[:, ok], w[:, ok]
        # each signal's least-squares multiple of the wheels', and what is left of both
        fit = np.sum(b * e, axis=1) / np.maximum(np.sum(e * e, axis=1), 1e-300)
        unexplained[k] = float(np.sum((b - fit[:, None] * e) ** 2) / max(np.sum(b * b), 1e-300))
    if 0 not in unexplained:
        return 0.0
    best = min(unexplained, key=lambda k: (unexplained[k], abs(k)))
    clear = unexplained[best] <= TRUTH_OFFSET_CLEAR * unexplained[0] and abs(best) < reach
    return best * h if clear else 0.0


def with_truth_offset(run: Run, offset_s: float) -> Run:
    """`run` with its pose reference's first sample taken `offset_s` into the encoder log
    (negative: before it began): both cut to the span they share, and started at 0 again."""
    if offset_s == 0.0:
        return run
    wheels, truth = run.wheels, run.truth
    on_log = truth.t_s + offset_s  # the reference's samples on the encoder log's clock
    keep = (on_log >= 0.0) & (on_log <= wheels.duration_s)
    if np.count_nonzero(keep) < 2:
        raise InputError(
            truth.source, "truth offset", f"{offset_s:g} s", "an offset under which the two logs overlap"
        )
    start, end = float(on_log[keep][0]), float(on_log[keep][-1])
    inside = (wheels.t_s > start) & (wheels.t_s < end)
    ends = wheels.angles_at(np.array([start, end]))
    cut = WheelInput(
        np.concatenate([[start], wheels.t_s[inside], [end]]) - start,
        np.concatenate([[ends[0, 0]], wheels.left_rad[inside], [ends[1, 0]]]),
        np.concatenate([[ends[0, 1]], wheels.right_rad[inside], [ends[1, 1]]]),
    )
    ref = Truth(on_log[keep] - start, truth.x_m[keep], truth.y_m[keep], truth.heading_rad[keep], truth.source)
    return Run(run.name, cut, ref)
