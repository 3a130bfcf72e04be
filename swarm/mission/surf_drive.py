"""The way in through the surf as the simulator's robots drive it: whether it ends ashore before
the surf crossing's time limit (`surf_timeout` in `swarm.sim.hazards`), how long it takes and the
breakers it meets.

Why not `surf_speed.SurfZone.crossing` alone: that holds a robot on its line. The simulator's
robots are not held. Afloat in deep water (a mode with buoyancy 1) the wheels have no grip, so
nothing turns the robot: it swims on the heading it arrived with while the longshore current sets
it along the beach (Longuet-Higgins, `SurfHazard.longshore_current`: 0.32 m/s for 1 m breakers,
0.64 for 4 m at the default 5 degrees). Pushed off its leg by more than the route follower's
`PASS_CROSS_TRACK_M`, it is steered back to the leg's end, upstream into the current, where the
breakers' orbital flow leaves it little way; it is swept along until the limit runs out. Landing
at 4 m breakers (16 runs): 3.0 robots of 12 a run timed out in the surf and 1.0 more were
disabled by breakers over the longer stay; the plan counted 0.15 losses in the surf in all.

So the plan drives each robot's way in (its sea leg and ground path, as the simulator's routes have
it) from its launch point with the simulator's own rules, reduced to one robot with no hazards:
the forces of `swarm.sim.physics` (as `surf_speed.mean_speed`, now on the world frame and the
cell under the robot at each substep), the controller of `swarm.sim.control` (pure pursuit for a
point `LOOKAHEAD_M` ahead on the leg, yaw rate by the heading error, the jet by its cosine) and
the route follower of `swarm.sim.routes` (on the gains and radii of `swarm.robot.driving`,
which the simulator imports too), at `WAVE_PHASES` phases of the wave spread over a period
(each run draws its own, uniformly). A drive ends when the wheels ground (`GROUND_SUBMERSION`,
where the simulator's surf phase ends) or when its time in the surf zone passes the limit: the
share of phases that pass it is the plan's chance of a `surf_timeout`. A breaker of the local
height hits at each crest while the robot is in the surf zone, as `Physics.step` counts them.
Left out: the flips (the controller drives an inverted robot through the inverse of the wheel
mapping, so its way is the same), obstacles (none at sea) and the robot's own losses.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from swarm.mission.schema import Mission
from swarm.mission.surf_speed import SurfZone
from swarm.robot.driving import (
    ARRIVE_M,
    CAPTURE_M,
    EFFECTIVE_TRACK_SCALE,
    FINAL_CAPTURE_M,
    LOOKAHEAD_M,
    MAX_WHEEL_SPEED_FACTOR,
    MAX_YAW_RATE_RADPS,
    PASS_CROSS_TRACK_M,
    PIVOT_ERROR_RAD,
    YAW_GAIN_PER_S,
)
from swarm.robot.params import GRAVITY_MPS2
from swarm.robot.skid import COEFFICIENTS, HEADING, SkidModel, U, V, X, Y
from swarm.robot.terrain import GROUND_SUBMERSION, JET_SUBMERSION
from swarm.world.coastal import MIN_DEPTH_M, WAVE_SKEW

#: The simulator's env step (`swarm.sim.env.SimConfig.dt_s`): commands, route cursors and the
#: phase rules are updated once a step; and its physics substep (`SimConfig.substep_s`).
STEP_S, SUBSTEP_S = 0.5, 0.25
#: Wave phases a way in is driven at, spread evenly over a period.
WAVE_PHASES = 8
#: A drive neither ashore nor past the limit after this many limits' time is given up: it swims
#: outside the surf zone, where no surf time runs (neither ashore nor timed out).
HORIZON_LIMITS = 4.0


class WayIn(NamedTuple):
    """One way in, driven at each of the wave phases (arrays (phases,))."""

    surf_s: np.ndarray  # seconds in the surf zone until the wheels ground, or the limit
    hazard: np.ndarray  # sum over the breakers met of -log(1 - p) at their local height
    ashore: np.ndarray  # bool: grounded within the limit
    timed_out: np.ndarray  # bool: its time in the surf zone passed the limit first

    @property
    def p_timeout(self) -> float:
        """The chance of a `surf_timeout`, over the wave's phase."""
        return float(self.timed_out.mean())


class _Cells:
    """The map's per-cell inputs of the simulator's forces, flat by cell (`swarm.sim.physics`)."""

    def __init__(self, mission: Mission, heights: np.ndarray, shoreward: np.ndarray) -> None:
        bm, lib, robot = mission.beach_map, mission.terrain_library, mission.robot_params
        table = lib.table(bm.terrain_classes)
        self.coef = {c: np.asarray(table.columns[c], np.float64) for c in COEFFICIENTS}
        self.buoyancy = np.asarray(table.columns["buoyancy_fraction"], np.float64)
        self.drag = np.array([lib[c].drag_n_s2_per_m2 for c in bm.terrain_classes])
        self.terrain = bm.terrain.astype(np.intp).ravel()
        self.rows, self.cols = bm.terrain.shape
        self.x0, self.y0 = (float(v) for v in bm.origin_m)
        self.cell_m = float(bm.cell_m)
        elevation = bm.elevation_m.astype(np.float64)
        depth = np.maximum(MIN_DEPTH_M, -elevation)
        surf = heights > 0
        amplitude = np.where(surf, 0.5 * heights * np.sqrt(GRAVITY_MPS2 / depth), 0.0)
        d_dx, d_dy = bm.gradient
        cos_slope = 1.0 / np.sqrt(1.0 + d_dx * d_dx + d_dy * d_dy)
        weight = robot.mass_kg * GRAVITY_MPS2
        self.slope_x = (-weight * d_dx * cos_slope).ravel()
        self.slope_y = (-weight * d_dy * cos_slope).ravel()
        self.load = cos_slope.ravel()
        self.current_x = np.where(surf, mission.hazards.surf.longshore_current(), 0.0).ravel()
        self.wave_x = (amplitude * shoreward[..., 0]).ravel()
        self.wave_y = (amplitude * shoreward[..., 1]).ravel()
        self.height = heights.ravel()
        p = mission.hazards.surf.damage_probability(self.height)
        self.hit_hazard = np.where(self.height > 0, -np.log1p(-np.minimum(p, 1.0 - 1e-12)), 0.0)

    def of(self, xy: np.ndarray) -> np.ndarray:
        """Flat cell index under points (n, 2), clipped to the grid (`BeachMap.cell_of`)."""
        col = np.clip(((xy[:, 0] - self.x0) / self.cell_m).astype(np.intp), 0, self.cols - 1)
        row = np.clip(((xy[:, 1] - self.y0) / self.cell_m).astype(np.intp), 0, self.rows - 1)
        return row * self.cols + col


def _legs(points: np.ndarray, cursor: np.ndarray, xy: np.ndarray):
    """Each robot's leg (`swarm.sim.routes._leg`): from the waypoint before its cursor to the
    cursor's (a route's first waypoint: none), its start, unit direction, length, and the robot's
    position along and across it. `points` (n, m, 2) padded with each route's last point."""
    idx = np.arange(len(points))
    prev = np.maximum(cursor - 1, 0)
    p, q = points[idx, prev], points[idx, cursor]
    leg = q - p
    length = np.hypot(leg[:, 0], leg[:, 1])
    unit = leg / np.maximum(length, 1e-12)[:, None]
    r = xy - p
    along = r[:, 0] * unit[:, 0] + r[:, 1] * unit[:, 1]
    cross = unit[:, 0] * r[:, 1] - unit[:, 1] * r[:, 0]
    return p, unit, length, along, cross


def _advance(points: np.ndarray, ends: np.ndarray, cursor: np.ndarray, xy: np.ndarray) -> None:
    """`swarm.sim.routes.Routes.advance`: past every waypoint within the capture radius, or past
    its leg's end and near the leg's line (the last one by its radius alone), a few a step."""
    idx = np.arange(len(points))
    for _ in range(4):
        going = cursor < ends
        cur = np.minimum(cursor, ends - 1)
        final = cur == ends - 1
        gap = points[idx, cur] - xy
        hit = np.hypot(gap[:, 0], gap[:, 1]) < np.where(final, FINAL_CAPTURE_M, CAPTURE_M)
        _, _, length, along, cross = _legs(points, cur, xy)
        hit |= ~final & (length > 0) & (along >= length) & (np.abs(cross) <= PASS_CROSS_TRACK_M)
        step = going & hit
        if not step.any():
            return
        cursor += step


def _steer_points(points: np.ndarray, ends: np.ndarray, cursor: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """`swarm.sim.routes.steer_point`: `LOOKAHEAD_M` ahead of the robot's projection on its leg,
    the leg's end when that is nearer; the route's last point once it is done."""
    idx = np.arange(len(points))
    cur = np.minimum(cursor, ends - 1)
    p, unit, length, along, _ = _legs(points, cur, xy)
    ahead = np.minimum(np.maximum(along, 0.0), length) + LOOKAHEAD_M
    on_leg = (length > 0) & (ahead < length)
    out = np.where(on_leg[:, None], p + unit * ahead[:, None], points[idx, cur])
    return np.where((cursor >= ends)[:, None], points[idx, ends - 1], out)


def drive_in(mission: Mission, zone: SurfZone, routes: list[np.ndarray]) -> list[WayIn]:
    """Each route of `routes` (waypoints (k, 2) from the launch point) driven from rest at its
    first point, headed for its second, at `WAVE_PHASES` phases (module docstring), over the
    surf zone `zone` (its local breaker heights and the breakers' direction)."""
    if not routes:
        return []
    cells = _Cells(mission, zone.heights, zone.shoreward)
    robot, surf = mission.robot_params, mission.hazards.surf
    cruise = mission.robot.wheel_speed_mps
    jet_max = mission.robot.jet_thrust_n or mission.terrain_library.default_jet_thrust_n(
        mission.robot.swim_speed_mps
    )
    half = robot.track_width_m / EFFECTIVE_TRACK_SCALE / 2.0
    limit = float(mission.phases.surf_crossing.time_limit_s)
    period = float(surf.wave_period_s)
    phases = np.arange(WAVE_PHASES) * period / WAVE_PHASES
    lines = [np.asarray(r, np.float64).reshape(-1, 2) for r in routes for _ in phases]
    n, m = len(lines), max(len(r) for r in lines)
    points = np.array([np.vstack([r, np.repeat(r[-1:], m - len(r), axis=0)]) for r in lines])
    ends = np.array([len(r) for r in lines])
    phase = np.tile(phases, len(routes))
    state = np.zeros((n, 6))
    state[:, X], state[:, Y] = points[:, 0, 0], points[:, 0, 1]
    first = points[:, min(1, m - 1)] - points[:, 0]
    state[:, HEADING] = np.arctan2(first[:, 1], first[:, 0])
    cursor = np.zeros(n, np.intp)
    submersion = np.zeros(n)  # the simulator's, until a first step reads the cell
    surf_s, hazard = np.zeros(n), np.zeros(n)
    ashore, timed_out = np.zeros(n, bool), np.zeros(n, bool)
    model = SkidModel(robot)
    subs = round(STEP_S / SUBSTEP_S)
    t = 0.0
    for _ in range(math.ceil(HORIZON_LIMITS * limit / STEP_S)):
        live = ~ashore & ~timed_out
        if not live.any():
            break
        _advance(points, ends, cursor, state[:, :2])
        omega, jet = _commands(points, ends, cursor, state, submersion, cruise, half, jet_max, robot)
        omega[~live], jet[~live] = 0.0, 0.0
        for k in range(subs):
            t0 = t + k * SUBSTEP_S
            cell = cells.of(state[:, :2])
            crest = np.floor((t0 + SUBSTEP_S - phase) / period) > np.floor((t0 - phase) / period)
            hazard += np.where(live & crest, cells.hit_hazard[cell], 0.0)
            state = _substep(model, cells, state, omega, jet, cell, _shape(t0, phase, period))
        t += STEP_S
        cell = cells.of(state[:, :2])
        submersion = cells.buoyancy[cells.terrain[cell]]
        surf_s += np.where(live & (cells.height[cell] > 0), STEP_S, 0.0)
        ashore |= live & (submersion < GROUND_SUBMERSION)
        timed_out |= live & ~ashore & (surf_s > limit)
    k = WAVE_PHASES
    return [
        WayIn(surf_s[i : i + k], hazard[i : i + k], ashore[i : i + k], timed_out[i : i + k])
        for i in range(0, n, k)
    ]


def _shape(t_s: float, phase_s: np.ndarray, period_s: float) -> np.ndarray:
    """The wave shape at `t_s` for each robot's wave phase (`coastal.wave_shape`, vectorized)."""
    phi = 2.0 * np.pi * (t_s - phase_s) / period_s
    return (np.cos(phi) + WAVE_SKEW * np.cos(2.0 * phi)) / (1.0 + WAVE_SKEW)


def _commands(points, ends, cursor, state, submersion, cruise, half, jet_max, robot):
    """Wheel speeds (n, 2) rad/s and jet thrust (n,) N toward each robot's steer point, by the
    simulator's controller (`swarm.sim.control.drive_toward`)."""
    target = _steer_points(points, ends, cursor, state[:, :2])
    d = target - state[:, :2]
    dist = np.hypot(d[:, 0], d[:, 1])
    err = (np.arctan2(d[:, 1], d[:, 0]) - state[:, HEADING] + np.pi) % (2.0 * np.pi) - np.pi
    cos_err = np.cos(err)
    yaw = np.clip(YAW_GAIN_PER_S * err, -MAX_YAW_RATE_RADPS, MAX_YAW_RATE_RADPS)
    speed = np.minimum(cruise, 0.1 + 0.5 * dist)
    forward = np.where(np.abs(err) < PIVOT_ERROR_RAD, speed * cos_err, 0.0)
    left, right = forward - half * yaw, forward + half * yaw
    top = MAX_WHEEL_SPEED_FACTOR * cruise
    scale = np.minimum(1.0, top / np.maximum(np.maximum(np.abs(left), np.abs(right)), 1e-9))
    moving = dist > ARRIVE_M
    wheels = np.column_stack([left, right]) * (scale / robot.wheel_radius_m)[:, None]
    omega = np.where(moving[:, None], wheels, 0.0)
    jet = np.where(moving & (submersion > JET_SUBMERSION), jet_max * np.maximum(cos_err, 0.0), 0.0)
    return omega, jet


def _substep(model: SkidModel, cells: _Cells, s: np.ndarray, omega, jet, cell, shape) -> np.ndarray:
    """One physics substep (`swarm.sim.physics.Physics._run`'s forces): drag on the velocity
    relative to the current and the wave's orbital flow, the jet on the buoyant part, the slope
    on the weight the water leaves, the wheels' load by the slope's cosine."""
    cls = cells.terrain[cell]
    coeffs = {c: v[cls] for c, v in cells.coef.items()}
    buoy, drag = cells.buoyancy[cls], cells.drag[cls]
    c, sn = np.cos(s[:, HEADING]), np.sin(s[:, HEADING])
    wx = cells.current_x[cell] + shape * cells.wave_x[cell]
    wy = shape * cells.wave_y[cell]
    u, v = s[:, U], s[:, V]
    ru, rv = u - (wx * c + wy * sn), v - (wy * c - wx * sn)
    speed, rel = np.sqrt(u * u + v * v), np.sqrt(ru * ru + rv * rv)
    support = 1.0 - buoy
    gx, gy = support * cells.slope_x[cell], support * cells.slope_y[cell]
    wrench = np.zeros((len(s), 3))
    wrench[:, 0] = drag * (speed * u - rel * ru) + jet * buoy + (gx * c + gy * sn)
    wrench[:, 1] = drag * (speed * v - rel * rv) + (gy * c - gx * sn)
    return model.step(s, omega, coeffs, SUBSTEP_S, wrench, cells.load[cell])
