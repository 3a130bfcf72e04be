"""How the swarm's robots are driven: the controller that turns a target into wheel and jet
commands, the route follower that picks the target, and the gains and radii both run on.

One home below the simulator (`swarm.sim.world`, `swarm.sim.routes`) and the plan's way in through
the surf (`swarm.mission.surf_drive`), which both call these kernels, so the plan drives as the
simulator does.

The controller, shared by the simulator's command mode, its scripted policy and the plan's way in:
drive each robot toward a target point, on wheels ashore and with the jet (and paddling wheels) in
water.

A pure-pursuit style heading controller, vectorized over the swarm: the robot turns toward the
target at a yaw rate proportional to the heading error, slowing its forward speed by cos(error)
and turning in place when the error exceeds `PIVOT_ERROR_RAD`. Wheel surface speeds come from the
commanded forward speed and yaw rate through the skid-steer effective track width
d / `EFFECTIVE_TRACK_SCALE` (thesis eqs. 2.23-2.26: a skid-steered robot turns as if its track were
d / 0.73 wide), so the commanded turn is close to the one the `skid` model produces.

An inverted robot (turned over by a breaker, thesis 1.2) is driven through the inverse of the
physics' wheel mapping (physical = -command[:, ::-1]), so the controller's intent is unchanged.

The route follower. Routes are flat: every robot's waypoints in one (m, 2) array, robot i's the
slice [start[i], end[i]) and its cursor the waypoint it drives for. A waypoint counts as reached
within `CAPTURE_M` (the last one within `FINAL_CAPTURE_M`), or once the robot is beyond its leg's
end and within `PASS_CROSS_TRACK_M` of the leg's line; the robot steers for the point
`LOOKAHEAD_M` ahead of its projection on the leg (pure pursuit).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from swarm.robot.npmath import maximum, minimum
from swarm.robot.terrain import GROUND_SUBMERSION, JET_SUBMERSION

#: Thesis eq. 2.26: the effective track width of the skid-steered robot is d / 0.73.
EFFECTIVE_TRACK_SCALE = 0.73
#: Heading error beyond which the robot turns in place before driving on (rad).
PIVOT_ERROR_RAD = math.radians(60.0)
#: Yaw-rate gain on the heading error (1/s) and the largest commanded yaw rate (rad/s).
YAW_GAIN_PER_S = 1.5
MAX_YAW_RATE_RADPS = 1.2
#: Within this distance of its target a robot stops (m).
ARRIVE_M = 0.25
#: The largest wheel surface speed, as a multiple of the cruise speed (robot.wheel_speed_mps).
MAX_WHEEL_SPEED_FACTOR = 1.5

#: A waypoint counts as reached within this distance (m); the last one of a route, where the
#: robot stops, within `FINAL_CAPTURE_M` (inside the controller's stopping distance).
CAPTURE_M = 1.0
FINAL_CAPTURE_M = 0.3
#: Pure pursuit: the robot steers for the point this far ahead of its projection on the leg it is
#: driving (m). Steering for the far end of a 900 m search track instead lets a cross-slope push
#: carry the robot metres off the track it was planned to sweep; chasing a point on the leg pulls
#: it back. Long enough that the controller does not slow for it (its slowdown starts at 1 m).
LOOKAHEAD_M = 1.5
#: A leg's end counts as passed once the robot is beyond it along the leg and within this distance
#: of the leg's line (m), so a robot pushed wide of a corner does not circle back for it.
PASS_CROSS_TRACK_M = 2.0


def afloat(submersion: np.ndarray) -> np.ndarray:
    """Which robots the route follower steers as boats (`steer_point`): those whose wheels do not
    ground, where the simulator's surf phase has not ended (`GROUND_SUBMERSION`)."""
    return np.asarray(submersion) > GROUND_SUBMERSION


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


@numba.njit(cache=True, error_model="numpy")
def advance_cursors(points, start, end, cursor, xy, mask, afloat):
    """Each robot's cursor (`swarm.sim.routes.Routes.advance`) past every waypoint it has reached,
    a few a step, robot by robot. The clear cases are settled without a square root
    (`_within`, `_may_pass`): each decision is the one `math.hypot` and `leg` give. A robot
    `afloat` passes a leg's end once abeam of it, however far off the leg the current has set it
    (`steer_point`)."""
    for i in range(cursor.shape[0]):
        if not mask[i]:
            continue
        x, y = xy[i, 0], xy[i, 1]
        for _ in range(4):
            cur = cursor[i]
            if cur >= end[i]:
                break
            final = cur == end[i] - 1
            hit = _within(points[cur, 0] - x, points[cur, 1] - y, FINAL_CAPTURE_M if final else CAPTURE_M)
            if not hit and not final and _may_pass(points, start[i], cur, x, y):
                _, _, _, _, length, along, cross = leg(points, start[i], cur, x, y)
                # a waypoint repeating the one before (a path's joint) is passed with it
                hit = length == 0 and cur > start[i]
                hit = hit or (
                    length > 0 and along >= length and (afloat[i] or abs(cross) <= PASS_CROSS_TRACK_M)
                )
            if not hit:
                break
            cursor[i] += 1


#: Relative margin far above the rounding of the squared forms in `_within` and `_may_pass`.
_MARGIN = 1e-9


@numba.njit(cache=True, error_model="numpy", inline="always")
def _within(dx, dy, radius):
    """`math.hypot(dx, dy) < radius`, from the squared distance unless it is within rounding of
    the radius."""
    d2, r2 = dx * dx + dy * dy, radius * radius
    if d2 < r2 * (1.0 - _MARGIN):
        return True
    if d2 > r2 * (1.0 + _MARGIN):
        return False
    return math.hypot(dx, dy) < radius


@numba.njit(cache=True, error_model="numpy", inline="always")
def _may_pass(points, start, cur, x, y):
    """False where a robot is surely short of its leg's end (`leg`'s along < length): the leg
    l and the robot r from the leg's start give r . l < |l|^2 by more than rounding."""
    prev = cur - 1 if cur > start else cur
    lx, ly = points[cur, 0] - points[prev, 0], points[cur, 1] - points[prev, 1]
    rx, ry = x - points[prev, 0], y - points[prev, 1]
    ll = lx * lx + ly * ly
    return rx * lx + ry * ly >= ll - _MARGIN * (abs(rx * lx) + abs(ry * ly) + ll)


@numba.njit(cache=True, error_model="numpy", inline="always")
def leg(points, start, cur, x, y):
    """The leg a robot is on (from the waypoint before its cursor `cur` to the cursor's): its
    first point, its direction, its length (0 on a route's first waypoint) and the robot's
    position along and across it."""
    prev = cur - 1 if cur > start else cur
    px, py = points[prev, 0], points[prev, 1]
    lx, ly = points[cur, 0] - px, points[cur, 1] - py
    length = math.hypot(lx, ly)
    ux, uy = lx / maximum(length, 1e-12), ly / maximum(length, 1e-12)
    rx, ry = x - px, y - py
    return px, py, lx, ly, length, rx * ux + ry * uy, ux * ry - uy * rx


@numba.njit(cache=True, error_model="numpy")
def steer_points(points, start, end, cursor, xy, afloat, out):
    """Each robot's steer point (`steer_point`) into `out`, robot by robot."""
    for i in range(xy.shape[0]):
        out[i, 0], out[i, 1] = steer_point(points, start[i], end[i], cursor[i], xy[i, 0], xy[i, 1], afloat[i])


@numba.njit(cache=True, error_model="numpy", inline="always")
def steer_point(points, start, end, cur, x, y, afloat):
    """Where one robot at (x, y) steers (`swarm.sim.routes.Routes.steer_points`), from its route's
    slice and cursor: `LOOKAHEAD_M` ahead of its projection on its leg, capped at the leg's end.

    Afloat, the wheels have no grip and the longshore current sets the robot off its leg: it
    steers for a point as far ahead along the leg's line as it is off it (line-of-sight guidance
    with a lookahead that grows with the cross-track error, as marine craft are steered in a
    current: Fossen, Handbook of Marine Craft Hydrodynamics and Motion Control, 2011, ch. 10;
    Lekkas and Fossen, 2012), past the leg's end but the route's last: it closes on the line at
    most 45 degrees off its direction and keeps making way, where a fixed lookahead turned it
    square into the current, back for the leg, and the surf's time limit stranded it."""
    if cur < end:
        px, py, lx, ly, length, along, cross = leg(points, start, cur, x, y)
        if afloat:
            ahead = maximum(along, 0.0) + maximum(LOOKAHEAD_M, abs(cross))
            if cur < end - 1 and length > 0:  # on along the leg's line, past its end
                return px + lx * (ahead / length), py + ly * (ahead / length)
        else:
            ahead = minimum(maximum(along, 0.0), length) + LOOKAHEAD_M
        if length > 0 and ahead < length:
            frac = ahead / maximum(length, 1e-12)
            return px + lx * frac, py + ly * frac
        return points[cur, 0], points[cur, 1]
    if end > start:
        return points[end - 1, 0], points[end - 1, 1]
    return x, y
