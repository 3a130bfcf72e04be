"""Drive patterns: thesis numbers, sample-run commands, continuity, synthetic encoder logs."""

from __future__ import annotations

import math
from importlib.resources import files

import numpy as np
import pytest
from scipy.integrate import cumulative_trapezoid

from swarm.errors import InputError
from swarm.robot.patterns import (
    MAX_WHEEL_ACCEL_RADPS2,
    PATTERNS,
    SAMPLE_SQUARE_SIDE_M,
    SQUARE_TRACK_WIDTH_M,
    DrivePattern,
    make_pattern,
    spiral,
    square,
    square_spiral_line,
    straight,
    to_encoder_ticks,
    turn_corner_offset_m,
)

R = 0.11
TICKS = 98 * 20


def sample_ssv(name: str) -> np.ndarray:
    return np.loadtxt(str(files("swarm") / "data" / "robot-runs" / f"{name}.ssv"))


def kinematic_heading_deg(p: DrivePattern, mask: np.ndarray | None = None) -> float:
    """Integrate r (wR - wL) / d_eff with the pattern's own d_eff, independently of the module."""
    sel = slice(None) if mask is None else mask
    rate = R * (p.right_radps[sel] - p.left_radps[sel]) / p.track_width_m
    return math.degrees(np.trapezoid(rate, p.t_s[sel]))


# --- straight ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("speed", "duration", "ramp"),
    [(0.62, 5.52, 1.47), (0.3, 10.0, 0.5), (0.8, 4.0, 2.0)],
)
def test_straight_equal_wheels_and_nominal_distance(speed, duration, ramp):
    p = straight(speed_mps=speed, duration_s=duration, ramp_s=ramp)
    assert np.array_equal(p.left_radps, p.right_radps)
    assert p.duration_s == pytest.approx(duration, abs=0.011)
    expected = speed * (duration - ramp)
    assert p.distance_m(R) == pytest.approx(expected, rel=0.01)
    assert p.left_radps.max() == pytest.approx(speed / R)
    assert p.left_radps[0] == 0.0 and p.left_radps[-1] == pytest.approx(0.0, abs=1e-9)


def test_straight_defaults_are_the_thesis_run():
    p = straight()
    assert p.duration_s == pytest.approx(5.52)
    assert p.distance_m() == pytest.approx(2.51, abs=0.01)
    assert p.dt_s == pytest.approx(0.01)
    assert p.t_s.dtype == np.float64 and p.left_radps.dtype == np.float64


def test_straight_rejects_ramps_longer_than_half_the_run():
    with pytest.raises(InputError, match="ramp_s"):
        straight(duration_s=2.0, ramp_s=1.5)


# --- square --------------------------------------------------------------------------------------


def test_square_turns_360_degrees_with_its_track_width():
    p = square()
    assert p.track_width_m == SQUARE_TRACK_WIDTH_M
    assert kinematic_heading_deg(p) == pytest.approx(360.0, abs=1.0)
    for k in range(1, 5):
        assert kinematic_heading_deg(p, p.mask(f"turn {k}")) == pytest.approx(90.0, abs=0.25)
    # mean speed constant through the turns: a car turn, not a pivot
    mean = (p.left_radps + p.right_radps) / 2
    turns = p.mask("turn 1") | p.mask("turn 4")
    assert np.allclose(mean[turns], 0.6 / R)


@pytest.mark.parametrize(("turn_deg", "d_eff"), [(80.0, 1.17), (90.0, 0.822), (100.0, 1.0)])
def test_square_turn_angle_follows_turn_deg_and_track_width(turn_deg, d_eff):
    p = square(turn_deg=turn_deg, track_width_m=d_eff)
    assert kinematic_heading_deg(p) == pytest.approx(4 * turn_deg, abs=1.0)


def test_square_reproduces_the_sample_concrete_commands():
    ssv = sample_ssv("concrete_square")
    p = square()
    assert p.duration_s == pytest.approx(ssv[-1, 0], abs=0.011)
    n = min(len(ssv), p.t_s.size)
    assert np.allclose(p.t_s[:n], ssv[:n, 0], atol=1e-6)
    for col, cmd in ((1, p.left_radps), (2, p.right_radps)):
        err = ssv[:n, col] - cmd[:n]
        assert np.sqrt(np.mean(err**2)) < 0.06
        assert np.abs(err).max() < 0.35
    # per-turn differential integral matches the sample's (16.68 rad) within 1%
    diff_ssv = ssv[:, 2] - ssv[:, 1]
    for k in range(1, 5):
        seg = p.segment(f"turn {k}")
        m_ssv = (ssv[:, 0] >= seg.start_s - 0.05) & (ssv[:, 0] <= seg.end_s + 0.05)
        m = p.mask(f"turn {k}")
        ours = np.trapezoid(p.right_radps[m] - p.left_radps[m], p.t_s[m])
        theirs = np.trapezoid(diff_ssv[m_ssv], ssv[m_ssv, 0])
        assert ours == pytest.approx(theirs, rel=0.01)
    # peak wheel speeds of a turn: inner wheel near zero, outer near 10.7 rad/s
    assert p.left_radps.min() == pytest.approx(0.0, abs=1e-9)
    turn = p.mask("turn 1")
    assert p.left_radps[turn].min() == pytest.approx(0.20, abs=0.05)
    assert p.right_radps[turn].max() == pytest.approx(10.70, abs=0.05)


def test_square_geometry_and_nominal_distance():
    p = square()
    assert abs(SAMPLE_SQUARE_SIDE_M - 4.2066) < 1e-3
    assert p.duration_s == pytest.approx(26.0, abs=0.011)
    # legs run corner offset to corner offset; the sample keeps 4.0 s legs at 0.6 m/s
    corner = turn_corner_offset_m(0.6, math.pi / 2, 2.5)
    assert p.distance_m() == pytest.approx(15.0, abs=0.01)
    assert p.segment("turn 1").start_s == pytest.approx(2.5, abs=1e-6)
    leg = p.segment("straight 1")
    assert (leg.end_s - leg.start_s) * 0.6 == pytest.approx(SAMPLE_SQUARE_SIDE_M - 2 * corner)


def test_corner_offset_matches_numerical_turn_integration():
    v, turn, dur = 0.6, math.radians(75.0), 3.0
    tau = np.linspace(0.0, dur, 20001)
    heading = turn * (1 - np.cos(np.pi * tau / dur)) / 2
    x = np.trapezoid(v * np.cos(heading), tau)
    y = np.trapezoid(v * np.sin(heading), tau)
    c = turn_corner_offset_m(v, turn, dur)
    # start -> corner along the incoming line, corner -> end along the outgoing one
    assert x == pytest.approx(c + c * math.cos(turn), rel=1e-6)
    assert y == pytest.approx(c * math.sin(turn), rel=1e-6)


def test_square_rejects_sides_too_short_for_its_turns():
    with pytest.raises(InputError, match="side_m"):
        square(side_m=1.0)
    with pytest.raises(InputError, match="turn_deg"):
        square(turn_deg=180.0)


# --- spiral and square-spiral-line ---------------------------------------------------------------


def test_spiral_is_counter_clockwise_tightening_and_speeding_up():
    p = spiral()
    m = p.mask("spiral")
    speed = R * (p.left_radps[m] + p.right_radps[m]) / 2
    yaw = R * (p.right_radps[m] - p.left_radps[m]) / p.track_width_m
    assert np.all(yaw >= 0) and kinematic_heading_deg(p) > 270.0
    assert np.all(np.diff(speed) > 0)
    moving = speed > 0.02
    curvature = yaw[moving] / speed[moving]
    assert np.all(np.diff(curvature) > 0)
    assert curvature[0] == pytest.approx(1.0, rel=0.05) and curvature[-1] == pytest.approx(1 / 0.6, rel=0.01)
    assert np.all(np.diff(yaw[1:]) > 0)  # the turn rate keeps changing


def test_spiral_rejects_a_widening_spiral():
    with pytest.raises(InputError, match="radius_end_m"):
        spiral(radius_start_m=0.5, radius_end_m=1.0)


def test_square_spiral_line_matches_the_thesis_run():
    p = square_spiral_line()
    assert p.duration_s == pytest.approx(60.0, abs=0.5)
    assert p.distance_m() == pytest.approx(22.16, rel=0.10)
    assert p.distance_m() == pytest.approx(22.16, rel=0.02)
    labels = [s.label for s in p.segments]
    assert labels.index("stop") < labels.index("pivot") < labels.index("spiral") < labels.index("line")
    # the square part carries the square's commands
    sq = square()
    n = sq.t_s.size
    assert np.allclose(p.left_radps[:n], sq.left_radps) and np.allclose(p.right_radps[:n], sq.right_radps)


def test_pivot_is_equal_and_opposite_and_turns_180_degrees():
    p = square_spiral_line()
    m = p.mask("pivot")
    assert m.sum() > 100
    assert np.array_equal(p.left_radps[m], -p.right_radps[m])
    assert np.abs(p.right_radps[m]).max() > 1.0
    assert kinematic_heading_deg(p, m) == pytest.approx(180.0, abs=0.5)
    clockwise = square_spiral_line(pivot_deg=-170.0)
    assert kinematic_heading_deg(clockwise, clockwise.mask("pivot")) == pytest.approx(-170.0, abs=0.5)


def test_line_accelerates_straight_after_the_spiral():
    p = square_spiral_line()
    seg = p.segment("line")
    m = p.mask("line")
    speed = R * (p.left_radps[m] + p.right_radps[m]) / 2
    assert np.all(np.diff(speed) > 0)
    straight_part = p.t_s[m] > seg.start_s + 1.0 + 1e-9  # after the default 1 s unwind
    assert np.allclose(p.left_radps[m][straight_part], p.right_radps[m][straight_part])
    assert speed[-1] == pytest.approx(0.65, abs=0.01)


# --- every pattern -------------------------------------------------------------------------------


@pytest.mark.parametrize("name", sorted(PATTERNS))
def test_commands_are_continuous_with_bounded_acceleration(name):
    p = make_pattern(name)
    assert p.name == name
    for w in (p.left_radps, p.right_radps):
        accel = np.abs(np.diff(w)) / np.diff(p.t_s)
        assert accel.max() <= MAX_WHEEL_ACCEL_RADPS2
        assert w[0] == 0.0 and abs(w[-1]) < 1e-9
    assert np.allclose(np.diff(p.t_s), 0.01)
    assert p.max_wheel_accel_radps2() <= MAX_WHEEL_ACCEL_RADPS2


def test_builders_refuse_commands_above_the_acceleration_limit():
    with pytest.raises(InputError, match="rad/s\\^2"):
        square(ramp_s=0.1)
    with pytest.raises(InputError, match="rad/s\\^2"):
        square_spiral_line(pivot_s=1.0)


def test_patterns_are_read_only():
    p = square()
    with pytest.raises(ValueError):
        p.left_radps[0] = 1.0


def test_drive_pattern_validates_its_arrays():
    t = np.arange(5) * 0.01
    with pytest.raises(InputError, match="right_radps"):
        DrivePattern("x", t, np.zeros(5), np.zeros(4))
    with pytest.raises(InputError, match="t_s"):
        DrivePattern("x", np.array([0.0, 0.01, 0.03]), np.zeros(3), np.zeros(3))
    with pytest.raises(InputError, match="wheel_radius_m"):
        DrivePattern("x", t, np.ones(5), np.ones(5)).distance_m()


def test_registry_and_unknown_names():
    assert set(PATTERNS) == {"straight", "square", "spiral", "square-spiral-line"}
    assert make_pattern("square", turn_deg=85.0).duration_s == pytest.approx(26.0, abs=0.5)
    with pytest.raises(InputError, match="figure-eight"):
        make_pattern("figure-eight")


# --- synthetic encoder logs ----------------------------------------------------------------------


def test_encoder_ticks_monotone_for_forward_motion():
    p = straight()
    time_ms, left, right = to_encoder_ticks(p, TICKS)
    assert time_ms.dtype.kind == "i" and left.dtype.kind == "i" and right.dtype.kind == "i"
    assert time_ms[0] == 0 and np.all(np.diff(time_ms) == 26)
    assert np.all(np.diff(left) >= 0) and np.all(np.diff(right) >= 0)
    assert left[-1] > 0
    revs = p.distance_m() / (2 * math.pi * R)
    assert left[-1] == pytest.approx(revs * TICKS, abs=1.0)


def test_encoder_ticks_reproducible_with_the_same_seed():
    p = square()
    a = p.to_encoder_ticks(TICKS, jitter_s=0.0015, rng=np.random.default_rng(42))
    b = to_encoder_ticks(p, TICKS, jitter_s=0.0015, rng=np.random.default_rng(42))
    c = to_encoder_ticks(p, TICKS, jitter_s=0.0015, rng=np.random.default_rng(43))
    for x, y in zip(a, b, strict=True):
        assert np.array_equal(x, y)
    assert not np.array_equal(a[0], c[0])
    steps = np.diff(a[0])
    assert steps.min() >= 23 and steps.max() <= 29 and np.all(steps > 0)
    assert len(np.unique(steps)) > 1


@pytest.mark.parametrize("name", ["square", "square-spiral-line"])
def test_encoder_ticks_match_the_integrated_wheel_angle(name):
    p = make_pattern(name)
    time_ms, left, right = to_encoder_ticks(p, TICKS, jitter_s=0.001, rng=np.random.default_rng(1))
    t = time_ms / 1000.0
    tick_rad = 2 * math.pi / TICKS
    # linear interpolation of the trapezoid integral between 10 ms grid points is off by at most
    # max|accel| dt^2 / 8 ~ 1e-4 rad (3% of a tick): allow that on top of the one-tick floor
    interp = 1.5e-4
    for ticks, w in ((left, p.left_radps), (right, p.right_radps)):
        angle = np.interp(t, p.t_s, cumulative_trapezoid(w, p.t_s, initial=0.0))
        measured = ticks * tick_rad
        assert np.all(np.abs(measured - angle) <= tick_rad + interp)
        assert np.all(measured <= angle + interp)  # floor: never ahead of the wheel
        assert np.mean(angle - measured) == pytest.approx(tick_rad / 2, rel=0.1)


def test_encoder_ticks_count_backwards_in_the_pivot():
    p = square_spiral_line()
    time_ms, left, right = to_encoder_ticks(p, TICKS)
    seg = p.segment("pivot")
    inside = (time_ms >= seg.start_s * 1000) & (time_ms <= seg.end_s * 1000)
    assert np.all(np.diff(left[inside]) <= 0) and np.all(np.diff(right[inside]) >= 0)


def test_encoder_ticks_input_errors():
    p = straight()
    with pytest.raises(InputError, match="rng"):
        to_encoder_ticks(p, TICKS, jitter_s=0.002)
    with pytest.raises(InputError, match="jitter_s"):
        to_encoder_ticks(p, TICKS, jitter_s=0.02, rng=np.random.default_rng(0))
    with pytest.raises(InputError, match="ticks_per_rev"):
        to_encoder_ticks(p, 0)
