"""The built-in controller (`swarm.robot.driving.drive_toward`): its per-robot kernel gives the floats
of the rule as first written in numpy, stopped and turned-over robots included."""

from __future__ import annotations

import numpy as np

from swarm.robot import driving as control
from swarm.robot.driving import DriveLimits, drive_toward
from swarm.robot.validate import wrap_angle

LIMITS = DriveLimits(
    wheel_radius_m=0.06,
    track_width_m=0.3,
    cruise_speed_mps=0.5,
    max_wheel_speed_mps=0.8,
    jet_thrust_max_n=4.0,
)


def _numpy_rule(state, target, speed, submersion, inverted, limits, moving):
    d = target - state[:, :2]
    dist = np.hypot(d[:, 0], d[:, 1])
    go = (dist > control.ARRIVE_M) & moving
    err = wrap_angle(np.arctan2(d[:, 1], d[:, 0]) - state[:, 2])
    cos_err = np.cos(err)
    yaw = np.clip(control.YAW_GAIN_PER_S * err, -control.MAX_YAW_RATE_RADPS, control.MAX_YAW_RATE_RADPS)
    fwd = np.where(np.abs(err) < control.PIVOT_ERROR_RAD, np.minimum(speed, 0.1 + 0.5 * dist) * cos_err, 0.0)
    half = limits.effective_half_track_m
    surface = np.stack([fwd - half * yaw, fwd + half * yaw], axis=1)
    peak = np.maximum(np.abs(surface[:, 0]), np.abs(surface[:, 1]))
    surface *= np.minimum(1.0, limits.max_wheel_speed_mps / np.maximum(peak, 1e-9))[:, None]
    wheels = surface / limits.wheel_radius_m
    thrust = limits.jet_thrust_max_n * np.maximum(cos_err, 0.0)
    jet = np.where(submersion > control.JET_SUBMERSION, thrust, 0.0)
    wheels[~go] = 0.0
    jet[~go] = 0.0
    flipped = np.flatnonzero(inverted)
    wheels[flipped] = -wheels[flipped][:, ::-1]
    return wheels, jet, dist


def test_drive_toward_is_the_numpy_rule_bit_for_bit() -> None:
    rng = np.random.default_rng(5)
    n = 4000
    state = np.zeros((n, 6))
    state[:, :2] = rng.uniform(0.0, 20.0, (n, 2))
    state[:, 2] = rng.uniform(-10.0, 10.0, n)
    target = state[:, :2] + rng.normal(0.0, 3.0, (n, 2)) * rng.choice([0.01, 1.0, 10.0], (n, 1))
    submersion = rng.choice([0.0, 0.2, 0.9], n)
    inverted = rng.random(n) < 0.2
    moving = rng.random(n) < 0.8
    speed = rng.uniform(0.1, 1.0, n)
    got = drive_toward(state, target, speed, submersion, inverted, LIMITS, moving)
    want = _numpy_rule(state, target, speed, submersion, inverted, LIMITS, moving)
    for g, w in zip(got, want, strict=True):
        assert np.array_equal(g, w)
        assert np.array_equal(np.signbit(g), np.signbit(w))  # a stopped, turned-over robot's -0
    assert (got[0][~moving] == 0.0).all() and got[0][moving].any()
