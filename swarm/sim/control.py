"""Low-level control shared by the high-level command mode and the scripted policy: drive each
robot toward a target point, on wheels ashore and with the jet (and paddling wheels) in water.

A pure-pursuit style heading controller, vectorized over the swarm: the robot turns toward the
target at a yaw rate proportional to the heading error, slowing its forward speed by cos(error)
and turning in place when the error exceeds `PIVOT_ERROR_RAD`. Wheel surface speeds come from the
commanded forward speed and yaw rate through the skid-steer effective track width
d / `EFFECTIVE_TRACK_SCALE` (thesis eqs. 2.23-2.26: a skid-steered robot turns as if its track were
d / 0.73 wide), so the commanded turn is close to the one the `skid` model produces.

An inverted robot (turned over by a breaker, thesis 1.2) is driven through the inverse of the
physics' wheel mapping (physical = -command[:, ::-1]), so the controller's intent is unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from swarm.robot.driving import (
    ARRIVE_M,
    EFFECTIVE_TRACK_SCALE,
    MAX_YAW_RATE_RADPS,
    PIVOT_ERROR_RAD,
    YAW_GAIN_PER_S,
)
from swarm.robot.terrain import JET_SUBMERSION
from swarm.sim.physics_kernels import maximum, minimum


@dataclass(frozen=True)
class DriveLimits:
    """One robot type's drive limits, from the mission's robot section."""

    wheel_radius_m: float
    track_width_m: float
    cruise_speed_mps: float  # wheel surface speed at cruise (robot.wheel_speed_mps)
    max_wheel_speed_mps: float  # the largest wheel surface speed the motors give
    jet_thrust_max_n: float

    @property
    def effective_half_track_m(self) -> float:
        return self.track_width_m / EFFECTIVE_TRACK_SCALE / 2.0


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Angles wrapped to [-pi, pi)."""
    return (np.asarray(a) + np.pi) % (2.0 * np.pi) - np.pi


def to_body(dxy: np.ndarray, heading_rad: np.ndarray) -> np.ndarray:
    """World-frame vectors (n, 2) or (n, k, 2) in each robot's body frame (x forward, y left)."""
    c, s = np.cos(heading_rad), np.sin(heading_rad)
    if dxy.ndim == 3:
        c, s = c[:, None], s[:, None]
    x, y = dxy[..., 0], dxy[..., 1]
    out = np.empty_like(dxy)
    fwd, left = out[..., 0], out[..., 1]
    np.multiply(c, x, out=fwd)  # c x + s y
    fwd += s * y
    np.multiply(c, y, out=left)  # -s x + c y, the same float as c y - s x
    left -= s * x
    return out


def drive_toward(
    state: np.ndarray,
    target_m: np.ndarray,
    speed_mps: np.ndarray | float,
    submersion: np.ndarray,
    inverted: np.ndarray,
    limits: DriveLimits,
    moving: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Wheel commands (n, 2) rad/s and jet thrust (n,) N that take each robot toward its target.

    `speed_mps` is the wanted forward speed; `moving` (n,) False holds a robot still (wheels and
    jet off). Returns the commands and each robot's distance to its target."""
    d = target_m - state[:, :2]
    dist = np.hypot(d[:, 0], d[:, 1])
    bearing = np.arctan2(d[:, 1], d[:, 0])  # numpy's own arctan2 (libm's differs in the last bit)
    m = len(dist)
    wheels, jet = np.empty((m, 2)), np.empty(m)
    speed = np.asarray(speed_mps, np.float64)
    if speed.shape != (m,):  # one speed for all: np.full costs a tenth of np.broadcast_to
        speed = np.full(m, speed) if speed.ndim == 0 else np.broadcast_to(speed, (m,))
    _drive(
        state, bearing, dist, speed, submersion,
        inverted, np.ones(m, bool) if moving is None else moving, limits.effective_half_track_m,
        limits.max_wheel_speed_mps, limits.wheel_radius_m, limits.jet_thrust_max_n, wheels, jet,
    )  # fmt: skip
    return wheels, jet, dist


@numba.njit(cache=True, error_model="numpy")
def _drive(
    state,
    bearing,
    dist,
    speed_mps,
    submersion,
    inverted,
    moving,
    half,
    max_wheel,
    radius,
    jet_max,
    wheels,
    jet,
):
    """`drive_toward`'s commands robot by robot from each target's bearing and distance, in the
    numpy path's arithmetic: heading error wrapped to [-pi, pi), yaw rate by the gain and clipped,
    forward speed slowed near the target and by cos(error) (zero beyond `PIVOT_ERROR_RAD`), both
    wheels' surface speeds scaled together into the motors' limit."""
    for i in range(dist.shape[0]):
        left = right = jet[i] = 0.0
        if dist[i] > ARRIVE_M and moving[i]:
            err = (bearing[i] - state[i, 2] + np.pi) % (2.0 * np.pi) - np.pi
            cos_err = np.cos(err)
            yaw = minimum(maximum(YAW_GAIN_PER_S * err, -MAX_YAW_RATE_RADPS), MAX_YAW_RATE_RADPS)
            speed = minimum(speed_mps[i], 0.1 + 0.5 * dist[i])
            forward = speed * cos_err if abs(err) < PIVOT_ERROR_RAD else 0.0
            left, right = forward - half * yaw, forward + half * yaw
            scale = minimum(1.0, max_wheel / maximum(maximum(abs(left), abs(right)), 1e-9))
            left, right = left * scale / radius, right * scale / radius
            if submersion[i] > JET_SUBMERSION:
                jet[i] = jet_max * maximum(cos_err, 0.0)
        if inverted[i]:  # turned over: sides swapped, each wheel the other way (a stop too: -0)
            left, right = -right, -left
        wheels[i, 0], wheels[i, 1] = left, right
