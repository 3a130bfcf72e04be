"""The thesis's four drive patterns as wheel angular-velocity commands over time (section 3.1, ch. 4).

Each builder returns a `DrivePattern`: left and right wheel angular velocities (rad/s) on a uniform
time grid, the kind of series the simulation export (`.ssv`) and the encoder logs carry. They feed
the motion models, and `to_encoder_ticks` turns them into synthetic encoder logs.

Conventions: SI units; body x forward, y to the left; positive ``right - left`` turns the robot
counter-clockwise. Turns use the kinematic relation

    yaw rate = r (omega_R - omega_L) / d_eff,     forward speed = r (omega_L + omega_R) / 2,

with an *effective* track width ``d_eff`` (``track_width_m``): a four-wheel skid steer turns less
than its axle length suggests, which the thesis expresses as a 0.73 heading factor (d_eff = d / 0.73).

Default ``d_eff`` (`SQUARE_TRACK_WIDTH_M` = 1.17 m) comes from the sample concrete square
(``swarm/data/robot-runs/concrete_square.ssv``, r = 0.11 m). Its four turns are half-sine
differentials: a least-squares fit gives ``omega_R - omega_L = 10.50 sin(pi tau / 2.49 s)`` rad/s
(rms residual 0.06 rad/s) about a constant mean of 5.45 rad/s, i.e. peak wheel speeds of about
(0.20, 10.70) rad/s, and ``integral (omega_R - omega_L) dt`` = 16.68 rad per turn. Calling that a
90 degree turn gives d_eff = r * 16.68 / (pi / 2) = 1.168 m, rounded to 1.17 m; with it,
``square()`` commands a peak differential of 10.50 rad/s, as in the sample. (The sample's truth
turns 90.7 degrees per turn on average, so 1.17 m is also the concrete d_eff to within 1%.)

Every command is continuous: speeds change along linear ramps (as in the sample runs) and turn
rates along half-sine or cosine profiles, so wheel angular acceleration is bounded. Builders refuse
(``InputError``) parameters whose commands would exceed `MAX_WHEEL_ACCEL_RADPS2` = 10 rad/s^2
(1.1 m/s^2 at the rim of a 0.11 m wheel). The defaults stay below 6.6 rad/s^2, as the sample square
does: 5.45 rad/s^2 in its speed ramps and, per the fitted half sine, 6.6 rad/s^2 per wheel entering
a turn (its recorded speeds add 100 Hz noise on top). `square()` matches the sample's recorded
wheel speeds to 0.03 rad/s rms.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy.special import j0

from swarm.errors import InputError

MAX_WHEEL_ACCEL_RADPS2 = 10.0
"""Largest wheel angular acceleration any pattern may command (rad/s^2)."""

SAMPLE_WHEEL_RADIUS_M = 0.11
"""Wheel radius of the sample robot (``robot.yaml``)."""

SQUARE_TRACK_WIDTH_M = 1.17
"""Effective track width d_eff fitted to the sample concrete square's turns (see module docs)."""

DEFAULT_DT_S = 0.01

_SQUARE_SPEED_MPS = 0.6
_SQUARE_TURN_S = 2.5
_SQUARE_LEG_S = 4.0

_FloatArray = np.ndarray
# A profile maps time into its piece (s) to (forward speed m/s, yaw rate rad/s).
_Profile = Callable[[_FloatArray], tuple[_FloatArray, _FloatArray]]


class Segment(NamedTuple):
    """A labelled part of a pattern, ``start_s <= t <= end_s``."""

    label: str
    start_s: float
    end_s: float


@dataclass(frozen=True, eq=False)
class DrivePattern:
    """Wheel angular-velocity commands on a uniform time grid.

    `wheel_radius_m` and `track_width_m` (the effective d_eff) record the nominal geometry the
    pattern was built for; `segments` names its parts (e.g. ``"turn 1"``, ``"pivot"``).
    Arrays are float64 and read-only.
    """

    name: str
    t_s: np.ndarray
    left_radps: np.ndarray
    right_radps: np.ndarray
    wheel_radius_m: float | None = None
    track_width_m: float | None = None
    segments: tuple[Segment, ...] = ()

    def __post_init__(self) -> None:
        source = f"{self.name} pattern"
        arrays = {}
        for key in ("t_s", "left_radps", "right_radps"):
            value = np.array(getattr(self, key), dtype=np.float64)
            if value.ndim != 1 or value.size < 2:
                raise InputError(source, key, value.shape, "a 1-D array of at least 2 samples")
            if not np.all(np.isfinite(value)):
                raise InputError(source, key, "non-finite values", "finite numbers")
            value.setflags(write=False)
            arrays[key] = value
        n = arrays["t_s"].size
        for key in ("left_radps", "right_radps"):
            if arrays[key].size != n:
                raise InputError(source, key, arrays[key].size, f"{n} samples, as many as t_s")
        steps = np.diff(arrays["t_s"])
        dt = (arrays["t_s"][-1] - arrays["t_s"][0]) / (n - 1)
        if not dt > 0 or not np.allclose(steps, dt, rtol=1e-6, atol=1e-9):
            raise InputError(
                source, "t_s", f"steps {steps.min():g}..{steps.max():g} s", "a uniform, rising grid"
            )
        for key, value in arrays.items():
            object.__setattr__(self, key, value)
        object.__setattr__(self, "segments", tuple(Segment(*s) for s in self.segments))

    @property
    def dt_s(self) -> float:
        return float((self.t_s[-1] - self.t_s[0]) / (self.t_s.size - 1))

    @property
    def duration_s(self) -> float:
        return float(self.t_s[-1] - self.t_s[0])

    def segment(self, label: str) -> Segment:
        """The first segment with this label; `InputError` if there is none."""
        for seg in self.segments:
            if seg.label == label:
                return seg
        raise InputError(
            f"{self.name} pattern", "segments", label, f"one of {[s.label for s in self.segments]}"
        )

    def mask(self, label: str) -> np.ndarray:
        """Boolean mask of the grid samples inside the named segment."""
        seg = self.segment(label)
        return (self.t_s >= seg.start_s - 1e-9) & (self.t_s <= seg.end_s + 1e-9)

    def distance_m(self, wheel_radius_m: float | None = None) -> float:
        """Nominal (no-slip) path length of the robot centre, integral of r |omega_L + omega_R| / 2 dt."""
        r = _radius(self, wheel_radius_m)
        speed = r * np.abs(self.left_radps + self.right_radps) / 2.0
        return float(np.trapezoid(speed, self.t_s))

    def heading_change_rad(
        self, wheel_radius_m: float | None = None, track_width_m: float | None = None
    ) -> float:
        """Nominal kinematic heading change, integral of r (omega_R - omega_L) / d_eff dt."""
        r = _radius(self, wheel_radius_m)
        d = track_width_m if track_width_m is not None else self.track_width_m
        if d is None or not d > 0:
            raise InputError(f"{self.name} pattern", "track_width_m", d, "a positive effective track width")
        return float(np.trapezoid(r * (self.right_radps - self.left_radps) / d, self.t_s))

    def wheel_angle_rad(self, times_s: Sequence[float] | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Left and right wheel angles (rad, zero at the first sample) at the given times.

        Exact integral of the commands taken as piecewise linear between grid samples.
        """
        t = np.asarray(times_s, dtype=np.float64)
        if t.size and (t.min() < self.t_s[0] - 1e-9 or t.max() > self.t_s[-1] + 1e-9):
            raise InputError(
                f"{self.name} pattern",
                "times_s",
                f"{t.min():g}..{t.max():g} s",
                f"times within {self.t_s[0]:g}..{self.t_s[-1]:g} s",
            )
        steps = np.diff(self.t_s)
        k = np.clip(np.searchsorted(self.t_s, t, side="right") - 1, 0, self.t_s.size - 2)
        tau = t - self.t_s[k]
        angles = []
        for w in (self.left_radps, self.right_radps):
            cum = np.concatenate(([0.0], np.cumsum((w[1:] + w[:-1]) / 2.0 * steps)))
            slope = (w[k + 1] - w[k]) / steps[k]
            angles.append(cum[k] + w[k] * tau + 0.5 * slope * tau**2)
        return angles[0], angles[1]

    def max_wheel_accel_radps2(self) -> float:
        """Largest |d omega / dt| of either wheel between grid samples."""
        steps = np.diff(self.t_s)
        return float(
            max(
                np.abs(np.diff(self.left_radps) / steps).max(),
                np.abs(np.diff(self.right_radps) / steps).max(),
            )
        )

    def to_encoder_ticks(
        self,
        ticks_per_rev: int,
        sample_period_s: float = 0.026,
        jitter_s: float = 0.0,
        rng: np.random.Generator | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """See `to_encoder_ticks`."""
        return to_encoder_ticks(self, ticks_per_rev, sample_period_s, jitter_s, rng)


def _radius(pattern: DrivePattern, wheel_radius_m: float | None) -> float:
    r = wheel_radius_m if wheel_radius_m is not None else pattern.wheel_radius_m
    if r is None or not r > 0:
        raise InputError(f"{pattern.name} pattern", "wheel_radius_m", r, "a positive wheel radius")
    return float(r)


def to_encoder_ticks(
    pattern: DrivePattern,
    ticks_per_rev: int,
    sample_period_s: float = 0.026,
    jitter_s: float = 0.0,
    rng: np.random.Generator | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sample the pattern as the thesis's encoder log would: ``(time_ms, left_ticks, right_ticks)``.

    Samples fall every `sample_period_s` from the pattern's start, each moved by a uniform
    offset in [-jitter_s, +jitter_s] drawn from `rng` (required when jitter_s > 0; no global RNG),
    then rounded to whole milliseconds. Ticks are the wheel angle integrated from the start,
    ``floor(angle / 2 pi * ticks_per_rev)``, evaluated at the logged millisecond time. All three
    arrays are int64; times rise strictly.
    """
    source = f"{pattern.name} pattern"
    if (
        isinstance(ticks_per_rev, bool)
        or not isinstance(ticks_per_rev, (int, np.integer))
        or ticks_per_rev <= 0
    ):
        raise InputError(source, "ticks_per_rev", ticks_per_rev, "a positive integer")
    if not sample_period_s >= 0.002:
        raise InputError(source, "sample_period_s", sample_period_s, "a period of at least 0.002 s")
    if not 0.0 <= jitter_s < sample_period_s / 2 - 0.001:
        raise InputError(source, "jitter_s", jitter_s, f"0 <= jitter < {sample_period_s / 2 - 0.001:g} s")
    if jitter_s > 0 and rng is None:
        raise InputError(
            source, "rng", None, "a numpy Generator (np.random.default_rng(seed)) for the jitter"
        )
    t0, t1 = float(pattern.t_s[0]), float(pattern.t_s[-1])
    n = math.floor((t1 - t0) / sample_period_s + 1e-9) + 1
    times = t0 + np.arange(n) * sample_period_s
    if jitter_s > 0:
        assert rng is not None
        offsets = rng.uniform(-jitter_s, jitter_s, size=n)
        offsets[0] = 0.0
        times = times + offsets
    time_ms = np.rint(np.clip(times, t0, t1) * 1000.0).astype(np.int64)
    time_ms = time_ms[
        (time_ms >= math.ceil(t0 * 1000.0 - 1e-6)) & (time_ms <= math.floor(t1 * 1000.0 + 1e-6))
    ]
    if np.any(np.diff(time_ms) <= 0):
        raise InputError(
            source, "sample_period_s", sample_period_s, "a period giving rising millisecond times"
        )
    left, right = pattern.wheel_angle_rad(time_ms / 1000.0)
    scale = ticks_per_rev / (2.0 * math.pi)
    left_ticks = np.floor(left * scale).astype(np.int64)
    right_ticks = np.floor(right * scale).astype(np.int64)
    return time_ms, left_ticks, right_ticks


# --- building blocks: pieces of (speed, yaw rate) profiles -------------------------------------


@dataclass(frozen=True)
class _Piece:
    label: str
    duration_s: float
    profile: _Profile


def _ramp(label: str, v0: float, v1: float, duration_s: float, curvature: float = 0.0) -> _Piece:
    """Linear speed change on a path of constant curvature (1/m, positive = left)."""

    def profile(tau: _FloatArray) -> tuple[_FloatArray, _FloatArray]:
        v = v0 + (v1 - v0) * np.clip(tau / duration_s, 0.0, 1.0)
        return v, v * curvature

    return _Piece(label, duration_s, profile)


def _hold(label: str, v: float, duration_s: float) -> _Piece:
    return _ramp(label, v, v, duration_s)


def _half_sine_turn(label: str, v: float, turn_rad: float, duration_s: float) -> _Piece:
    """Constant speed with a half-sine yaw rate whose integral is `turn_rad` (car turn, or pivot at v = 0)."""
    peak = turn_rad * math.pi / (2.0 * duration_s)

    def profile(tau: _FloatArray) -> tuple[_FloatArray, _FloatArray]:
        x = np.clip(tau / duration_s, 0.0, 1.0)
        return np.full_like(tau, v), peak * np.sin(math.pi * x)

    return _Piece(label, duration_s, profile)


def _spiral_piece(label: str, v0: float, v1: float, r0: float, r1: float, duration_s: float) -> _Piece:
    """Speed rising linearly v0 -> v1 while the turn radius shrinks linearly r0 -> r1 (left turn)."""

    def profile(tau: _FloatArray) -> tuple[_FloatArray, _FloatArray]:
        x = np.clip(tau / duration_s, 0.0, 1.0)
        v = v0 + (v1 - v0) * x
        return v, v / (r0 + (r1 - r0) * x)

    return _Piece(label, duration_s, profile)


def _straighten_piece(
    label: str, v0: float, v1: float, curvature: float, unwind_s: float, duration_s: float
) -> _Piece:
    """Linear speed change v0 -> v1 while the curvature fades to zero along a half cosine in `unwind_s`."""

    def profile(tau: _FloatArray) -> tuple[_FloatArray, _FloatArray]:
        v = v0 + (v1 - v0) * np.clip(tau / duration_s, 0.0, 1.0)
        fade = 0.5 * (1.0 + np.cos(math.pi * np.clip(tau / unwind_s, 0.0, 1.0)))
        return v, v * curvature * fade

    return _Piece(label, duration_s, profile)


def _assemble(
    name: str,
    pieces: Sequence[_Piece],
    wheel_radius_m: float,
    track_width_m: float | None,
    dt_s: float,
) -> DrivePattern:
    """Sample the pieces, end to end, on a uniform grid and convert them to wheel commands."""
    source = f"{name} pattern"
    pieces = [p for p in pieces if p.duration_s > 1e-12]
    starts = np.cumsum([0.0] + [p.duration_s for p in pieces])
    total = float(starts[-1])
    n = math.ceil(total / dt_s - 1e-6) + 1
    t = np.arange(n) * dt_s
    v = np.zeros(n)
    yaw = np.zeros(n)
    index = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(pieces) - 1)
    for i, piece in enumerate(pieces):
        sel = index == i
        if np.any(sel):
            v[sel], yaw[sel] = piece.profile(t[sel] - starts[i])
    d = track_width_m if track_width_m is not None else 0.0
    left = (v - yaw * d / 2.0) / wheel_radius_m
    right = (v + yaw * d / 2.0) / wheel_radius_m
    segments = tuple(Segment(p.label, float(starts[i]), float(starts[i + 1])) for i, p in enumerate(pieces))
    pattern = DrivePattern(name, t, left, right, wheel_radius_m, track_width_m, segments)
    accel = pattern.max_wheel_accel_radps2()
    if accel > MAX_WHEEL_ACCEL_RADPS2:
        raise InputError(
            source,
            "wheel commands",
            f"{accel:.2f} rad/s^2",
            f"at most {MAX_WHEEL_ACCEL_RADPS2:g} rad/s^2 (lengthen ramps or turns, or lower speeds)",
        )
    return pattern


def _positive(source: str, **values: float) -> None:
    for key, value in values.items():
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or not math.isfinite(value)
            or value <= 0
        ):
            raise InputError(source, key, value, "a positive number")


def _non_negative(source: str, **values: float) -> None:
    for key, value in values.items():
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or not math.isfinite(value)
            or value < 0
        ):
            raise InputError(source, key, value, "a number >= 0")


def turn_corner_offset_m(speed_mps: float, turn_rad: float, turn_s: float) -> float:
    """Distance from a half-sine car turn's start (and end) to the corner of the ideal polygon.

    With heading theta(tau) = Theta (1 - cos(pi tau / T)) / 2 at speed v, the turn's displacement
    is v T J0(Theta/2) (cos Theta/2, sin Theta/2); the incoming and outgoing lines meet at
    v T J0(Theta/2) / (2 cos(Theta/2)) from either end. Valid for 0 <= Theta < pi.
    """
    half = turn_rad / 2.0
    return float(speed_mps * turn_s * j0(half) / (2.0 * math.cos(half)))


SAMPLE_SQUARE_SIDE_M = _SQUARE_SPEED_MPS * _SQUARE_LEG_S + 2.0 * turn_corner_offset_m(
    _SQUARE_SPEED_MPS, math.pi / 2.0, _SQUARE_TURN_S
)
"""Side of the sample square's ideal polygon, about 4.207 m: 4.0 s legs at 0.6 m/s plus 2 x 0.903 m."""


# --- the four patterns ---------------------------------------------------------------------------


def straight(
    speed_mps: float = 0.62,
    duration_s: float = 5.52,
    ramp_s: float = 1.47,
    wheel_radius_m: float = SAMPLE_WHEEL_RADIUS_M,
    dt_s: float = DEFAULT_DT_S,
) -> DrivePattern:
    """Straight line: linear ramp 0 -> speed in `ramp_s`, cruise, linear ramp back to 0, both wheels equal.

    Nominal distance is speed * (duration - ramp_s); the defaults give 0.62 * 4.05 = 2.51 m in
    5.52 s, the thesis's run (the sample run ramps up in 1.2 s and down in 1.3 s, then rests).
    """
    source = "straight pattern"
    _positive(
        source,
        speed_mps=speed_mps,
        duration_s=duration_s,
        ramp_s=ramp_s,
        wheel_radius_m=wheel_radius_m,
        dt_s=dt_s,
    )
    if 2 * ramp_s > duration_s:
        raise InputError(source, "ramp_s", ramp_s, f"at most half the duration ({duration_s / 2:g} s)")
    pieces = [
        _ramp("accelerate", 0.0, speed_mps, ramp_s),
        _hold("cruise", speed_mps, duration_s - 2 * ramp_s),
        _ramp("stop", speed_mps, 0.0, ramp_s),
    ]
    return _assemble("straight", pieces, wheel_radius_m, None, dt_s)


def _square_pieces(
    source: str,
    side_m: float,
    speed_mps: float,
    turn_deg: float,
    turn_s: float,
    ramp_s: float,
    stop_short_m: float,
) -> list[_Piece]:
    _positive(source, side_m=side_m, speed_mps=speed_mps, turn_deg=turn_deg, turn_s=turn_s, ramp_s=ramp_s)
    _non_negative(source, stop_short_m=stop_short_m)
    if not turn_deg < 180.0:
        raise InputError(source, "turn_deg", turn_deg, "a turn between 0 and 180 degrees")
    turn = math.radians(turn_deg)
    corner = turn_corner_offset_m(speed_mps, turn, turn_s)
    ramp_m = speed_mps * ramp_s / 2.0
    first_s = (side_m / 2.0 - corner - ramp_m) / speed_mps
    leg_s = (side_m - 2.0 * corner) / speed_mps
    last_s = (side_m / 2.0 - corner - stop_short_m - ramp_m) / speed_mps
    need = 2.0 * corner + 2.0 * max(ramp_m, ramp_m + stop_short_m)
    if min(first_s, leg_s, last_s) < -1e-9:
        raise InputError(
            source, "side_m", side_m, f"at least {need:.3f} m for these turns, ramps and stop_short_m"
        )
    pieces = [_ramp("accelerate", 0.0, speed_mps, ramp_s), _hold("straight 0", speed_mps, first_s)]
    for k in range(1, 5):
        pieces.append(_half_sine_turn(f"turn {k}", speed_mps, turn, turn_s))
        pieces.append(_hold(f"straight {k}", speed_mps, leg_s if k < 4 else last_s))
    pieces.append(_ramp("stop", speed_mps, 0.0, ramp_s))
    return pieces


def square(
    side_m: float = SAMPLE_SQUARE_SIDE_M,
    speed_mps: float = _SQUARE_SPEED_MPS,
    turn_deg: float = 90.0,
    turn_s: float = _SQUARE_TURN_S,
    ramp_s: float = 1.0,
    stop_short_m: float = 0.6,
    track_width_m: float = SQUARE_TRACK_WIDTH_M,
    wheel_radius_m: float = SAMPLE_WHEEL_RADIUS_M,
    dt_s: float = DEFAULT_DT_S,
) -> DrivePattern:
    """Square of four left car turns, started from rest mid-side, as in the sample run.

    Accelerate linearly to `speed_mps` in `ramp_s`, then at each corner turn `turn_deg` in
    `turn_s` at constant mean speed, the wheel differential a half sine,
    ``omega_R - omega_L = turn * d_eff * pi / (2 r turn_s) * sin(pi tau / turn_s)``.
    `side_m` is the side of the ideal polygon (corner to corner along the legs); the run stops
    (linear ramp) `stop_short_m` before its start point. Defaults reproduce the sample square:
    5.45 rad/s cruise, turns at 2.5, 9.0, 15.5, 22.0 s peaking at (0.20, 10.70) rad/s, 4.0 s legs,
    stop at 26.0 s; nominal distance 15.0 m.
    """
    source = "square pattern"
    _positive(source, track_width_m=track_width_m, wheel_radius_m=wheel_radius_m, dt_s=dt_s)
    pieces = _square_pieces(source, side_m, speed_mps, turn_deg, turn_s, ramp_s, stop_short_m)
    return _assemble("square", pieces, wheel_radius_m, track_width_m, dt_s)


def _spiral_check(source: str, speed_start_mps: float, speed_end_mps: float, r0: float, r1: float) -> None:
    _non_negative(source, speed_start_mps=speed_start_mps)
    _positive(source, speed_end_mps=speed_end_mps, radius_start_m=r0, radius_end_m=r1)
    if not speed_end_mps > speed_start_mps:
        raise InputError(
            source, "speed_end_mps", speed_end_mps, f"more than speed_start_mps ({speed_start_mps:g})"
        )
    if not r1 < r0:
        raise InputError(
            source, "radius_end_m", r1, f"less than radius_start_m ({r0:g}): a tightening spiral"
        )


def spiral(
    duration_s: float = 22.0,
    speed_start_mps: float = 0.0,
    speed_end_mps: float = 0.35,
    radius_start_m: float = 1.0,
    radius_end_m: float = 0.6,
    ramp_s: float = 1.0,
    track_width_m: float = SQUARE_TRACK_WIDTH_M,
    wheel_radius_m: float = SAMPLE_WHEEL_RADIUS_M,
    dt_s: float = DEFAULT_DT_S,
) -> DrivePattern:
    """Counter-clockwise tightening spiral of rising speed.

    Over `duration_s` the speed rises linearly and the turn radius shrinks linearly from
    `radius_start_m` to `radius_end_m`, so the turn rate v / R changes continuously. If
    `speed_start_mps` > 0 the robot first accelerates from rest on the starting circle in
    `ramp_s`; it stops on the final circle in `ramp_s`. Defaults (the spiral of
    `square_spiral_line`): from rest to 0.35 m/s while the radius shrinks 1.0 -> 0.6 m in 22 s
    (3.85 m, 306 degrees nominal, yaw rate rising to 0.58 rad/s), then 1 s to stop: 23 s, 4.0 m.
    """
    source = "spiral pattern"
    _positive(
        source,
        duration_s=duration_s,
        ramp_s=ramp_s,
        track_width_m=track_width_m,
        wheel_radius_m=wheel_radius_m,
        dt_s=dt_s,
    )
    _spiral_check(source, speed_start_mps, speed_end_mps, radius_start_m, radius_end_m)
    pieces = [
        _ramp(
            "accelerate", 0.0, speed_start_mps, ramp_s if speed_start_mps > 0 else 0.0, 1.0 / radius_start_m
        ),
        _spiral_piece("spiral", speed_start_mps, speed_end_mps, radius_start_m, radius_end_m, duration_s),
        _ramp("stop", speed_end_mps, 0.0, ramp_s, 1.0 / radius_end_m),
    ]
    return _assemble("spiral", pieces, wheel_radius_m, track_width_m, dt_s)


def square_spiral_line(
    side_m: float = SAMPLE_SQUARE_SIDE_M,
    speed_mps: float = _SQUARE_SPEED_MPS,
    turn_deg: float = 90.0,
    turn_s: float = _SQUARE_TURN_S,
    pivot_deg: float = 180.0,
    pivot_s: float = 5.0,
    spiral_s: float = 22.0,
    spiral_speed_mps: float = 0.35,
    spiral_radius_start_m: float = 1.0,
    spiral_radius_end_m: float = 0.6,
    line_s: float = 6.0,
    line_speed_mps: float = 0.65,
    unwind_s: float = 1.0,
    ramp_s: float = 1.0,
    stop_short_m: float = 0.6,
    track_width_m: float = SQUARE_TRACK_WIDTH_M,
    wheel_radius_m: float = SAMPLE_WHEEL_RADIUS_M,
    dt_s: float = DEFAULT_DT_S,
) -> DrivePattern:
    """The thesis's complex run (section 4.2.3): square, pivot, spiral, accelerating line.

    1. The `square` with the same commands (ends at rest, ~26 s).
    2. ``"pivot"``: in-place turn of `pivot_deg` (positive = counter-clockwise) in `pivot_s`,
       equal and opposite wheel commands, half-sine in time (peak 5.25 rad/s by default).
    3. ``"spiral"``: counter-clockwise tightening spiral from rest, speed rising linearly to
       `spiral_speed_mps`, radius shrinking from `spiral_radius_start_m` to `spiral_radius_end_m`.
    4. ``"line"``: speed rising linearly to `line_speed_mps` in `line_s` while the turn fades out
       along a half cosine in `unwind_s`; then ``"line stop"``, a linear ramp to rest in `ramp_s`.

    Defaults: 26 + 5 + 22 + 6 + 1 = 60 s and 15.0 + 0 + 3.85 + 3.0 + 0.325 = 22.175 m nominal,
    against the thesis's 60 s and 22.16 m; nominal heading change 360 + 180 + 306 + 17 degrees.
    """
    source = "square-spiral-line pattern"
    _positive(
        source,
        pivot_s=pivot_s,
        spiral_s=spiral_s,
        line_s=line_s,
        unwind_s=unwind_s,
        track_width_m=track_width_m,
        wheel_radius_m=wheel_radius_m,
        dt_s=dt_s,
    )
    if isinstance(pivot_deg, bool) or not isinstance(pivot_deg, (int, float)) or not math.isfinite(pivot_deg):
        raise InputError(source, "pivot_deg", pivot_deg, "a finite angle in degrees")
    _spiral_check(source, 0.0, spiral_speed_mps, spiral_radius_start_m, spiral_radius_end_m)
    _positive(source, line_speed_mps=line_speed_mps)
    if unwind_s > line_s:
        raise InputError(source, "unwind_s", unwind_s, f"at most line_s ({line_s:g} s)")
    pieces = _square_pieces(source, side_m, speed_mps, turn_deg, turn_s, ramp_s, stop_short_m)
    pieces += [
        _half_sine_turn("pivot", 0.0, math.radians(pivot_deg), pivot_s),
        _spiral_piece("spiral", 0.0, spiral_speed_mps, spiral_radius_start_m, spiral_radius_end_m, spiral_s),
        _straighten_piece(
            "line", spiral_speed_mps, line_speed_mps, 1.0 / spiral_radius_end_m, unwind_s, line_s
        ),
        _ramp("line stop", line_speed_mps, 0.0, ramp_s),
    ]
    return _assemble("square-spiral-line", pieces, wheel_radius_m, track_width_m, dt_s)


PATTERNS: dict[str, Callable[..., DrivePattern]] = {
    "straight": straight,
    "square": square,
    "spiral": spiral,
    "square-spiral-line": square_spiral_line,
}


def make_pattern(name: str, **kwargs: object) -> DrivePattern:
    """Build a registered pattern by name; unknown names raise `InputError`."""
    try:
        builder = PATTERNS[name]
    except (KeyError, TypeError):
        raise InputError("drive pattern", "name", name, f"one of {sorted(PATTERNS)}") from None
    return builder(**kwargs)
