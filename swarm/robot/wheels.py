"""What drives every model: the cumulative wheel angles, as the encoders (or a command) give them.

Keeping angles rather than speeds means any integrator can ask for the exact wheel travel over its
own step (`mean_speeds`), so resampling never loses or invents distance; the thesis's per-sample
speeds (`thesis_speeds`) are still there for the models that were written around them.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from swarm.robot.io import EncoderLog, SimExport, wheel_angles


@dataclass(frozen=True, eq=False)
class WheelInput:
    """Cumulative wheel angles (rad) at sample times (s), starting at t = 0."""

    t_s: np.ndarray
    left_rad: np.ndarray
    right_rad: np.ndarray

    @classmethod
    def from_encoders(cls, log: EncoderLog, ticks_per_rev: int) -> WheelInput:
        t, left, right = wheel_angles(log, ticks_per_rev)
        return cls(t - t[0], left, right)

    @classmethod
    def from_speeds(cls, t_s: np.ndarray, left_radps: np.ndarray, right_radps: np.ndarray) -> WheelInput:
        """From sampled speeds (an `.ssv` export or a pattern): trapezoid-integrated angles."""
        t = np.asarray(t_s, dtype=np.float64)
        dt = np.diff(t)
        left = np.concatenate([[0.0], np.cumsum(0.5 * (left_radps[1:] + left_radps[:-1]) * dt)])
        right = np.concatenate([[0.0], np.cumsum(0.5 * (right_radps[1:] + right_radps[:-1]) * dt)])
        return cls(t - t[0], left, right)

    @classmethod
    def from_ssv(cls, export: SimExport) -> WheelInput:
        return cls.from_speeds(export.t_s, export.left_radps, export.right_radps)

    @property
    def duration_s(self) -> float:
        return float(self.t_s[-1])

    def angles_at(self, t_s: np.ndarray | float) -> np.ndarray:
        """Wheel angles (..., 2) at times, linear between samples."""
        return np.stack(
            [np.interp(t_s, self.t_s, self.left_rad), np.interp(t_s, self.t_s, self.right_rad)], -1
        )

    def mean_speeds(self, t0_s: float, t1_s: float) -> np.ndarray:
        """Mean wheel angular velocity (2,) over [t0, t1]: exact travel divided by time."""
        return (self.angles_at(t1_s) - self.angles_at(t0_s)) / (t1_s - t0_s)

    def step_speeds(self, times_s: np.ndarray) -> np.ndarray:
        """`mean_speeds` over each step between consecutive `times_s` (k + 1,), as (k, 2), the
        same numbers: a fixed-step integrator looks them all up at once instead of one per step."""
        angles = self.angles_at(times_s)
        return (angles[1:] - angles[:-1]) / np.diff(times_s)[:, None]

    def smooth_speed_at(self, t_s: float) -> np.ndarray:
        """Continuous speed (2,): interval mean speeds joined linearly between interval midpoints.

        Adaptive integrators restart their step at every jump of a piecewise-constant input; this
        continuous version runs about four times faster and moves the wheels by the same distance
        to within one sample's worth of acceleration.
        """
        mid, left, right = self._interval_speeds
        return np.array([np.interp(t_s, mid, left), np.interp(t_s, mid, right)])

    @cached_property
    def _interval_speeds(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        dt = np.diff(self.t_s)
        mid = 0.5 * (self.t_s[1:] + self.t_s[:-1])
        return mid, np.diff(self.left_rad) / dt, np.diff(self.right_rad) / dt

    def thesis_speeds(self) -> tuple[np.ndarray, np.ndarray]:
        """The thesis's omega = 2 pi d(rev)/dt per sample, first sample zero (Fig. 3.7)."""
        dt = np.diff(self.t_s)
        left = np.concatenate([[0.0], np.diff(self.left_rad) / dt])
        right = np.concatenate([[0.0], np.diff(self.right_rad) / dt])
        return left, right
