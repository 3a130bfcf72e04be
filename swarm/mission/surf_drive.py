"""The way in through the surf as the simulator's robots drive it: whether it ends ashore before
the surf crossing's time limit (`surf_timeout` in `swarm.sim.hazards`), how long it takes and the
breakers it meets.

Why not `surf_speed.SurfZone.crossing` alone: that holds a robot on its line. The simulator's
robots are not held. Afloat in deep water (a mode with buoyancy 1) the wheels have no grip, and
the longshore current sets a robot along the beach (Longuet-Higgins,
`SurfHazard.longshore_current`: 0.32 m/s for 1 m breakers, 0.64 for 4 m at the default 5
degrees) while it closes on its leg's line at up to 45 degrees (`swarm.robot.driving.steer_point`).
It lands down-current of its leg, later than a robot held on it, and where the current and the
breakers' orbital flow beat its jet, not at all before the limit. (Before the route follower
steered afloat robots along the leg's line it headed them back up-current for the leg's end:
landing at 4 m breakers stranded 3.0 robots of 12 a run, and the plan, holding robots on their
line, counted 0.15 losses in the surf in all.)

So the plan drives each robot's way in (its sea leg and ground path, as the simulator's routes have
it) from its launch point with the simulator's own rules, reduced to one robot with no hazards:
the forces of `swarm.sim.physics` (as `surf_speed.mean_speed`, now on the world frame and the
cell under the robot at each substep), and the controller and route follower the simulator calls
(`swarm.robot.driving`: pure pursuit for a point `LOOKAHEAD_M` ahead on the leg, yaw rate by the
heading error, the jet by its cosine; the same compiled kernels), at `WAVE_PHASES` phases of the
wave spread over a period (each run draws its own, uniformly). A drive ends when the wheels ground
(`GROUND_SUBMERSION`, where the simulator's surf phase ends) or when its time in the surf zone
passes the limit: the share of phases that pass it is the plan's chance of a `surf_timeout`. A
breaker of the local height hits at each crest while the robot is in the surf zone, as
`Physics.step` counts them.
Left out: the flips (the controller drives an inverted robot through the inverse of the wheel
mapping, so its way is the same), obstacles (none at sea) and the robot's own losses.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from swarm.mission import budget
from swarm.mission.schema import Mission
from swarm.mission.surf_speed import SurfZone
from swarm.robot.driving import (
    MAX_WHEEL_SPEED_FACTOR,
    DriveLimits,
    advance_cursors,
    afloat,
    drive_toward,
    steer_points,
)
from swarm.robot.params import GRAVITY_MPS2
from swarm.robot.skid import COEFFICIENTS, HEADING, SkidModel, U, V, X, Y, mean_wheel_slip
from swarm.robot.terrain import GROUND_SUBMERSION
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
    landed_m: np.ndarray  # (phases, 2) where the wheels grounded, NaN where they did not
    #: -log(1 - p) of getting stuck on the way, the simulator's rate (`budget.immobilization_per_m`
    #: x `budget.slip_factor`) over each step's distance, its slip and the class it ends on
    stuck: np.ndarray

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
        self.stuck_per_m = budget.immobilization_per_m(mission, bm.terrain_classes)
        self.wheel_m = robot.wheel_radius_m * self.coef["rolling_radius_scale"]
        p = mission.hazards.surf.damage_probability(self.height)
        self.hit_hazard = np.where(self.height > 0, -np.log1p(-np.minimum(p, 1.0 - 1e-12)), 0.0)

    def of(self, xy: np.ndarray) -> np.ndarray:
        """Flat cell index under points (n, 2), clipped to the grid (`BeachMap.cell_of`)."""
        col = np.clip(((xy[:, 0] - self.x0) / self.cell_m).astype(np.intp), 0, self.cols - 1)
        row = np.clip(((xy[:, 1] - self.y0) / self.cell_m).astype(np.intp), 0, self.rows - 1)
        return row * self.cols + col


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
    limits = DriveLimits(
        robot.wheel_radius_m, robot.track_width_m, cruise, MAX_WHEEL_SPEED_FACTOR * cruise, jet_max
    )
    limit = float(mission.phases.surf_crossing.time_limit_s)
    period = float(surf.wave_period_s)
    phases = np.arange(WAVE_PHASES) * period / WAVE_PHASES
    # the routes flat, as the simulator's `Routes` keeps them: robot i's waypoints [start, end)
    lines = [np.asarray(r, np.float64).reshape(-1, 2) for r in routes for _ in phases]
    n = len(lines)
    points = np.concatenate(lines)
    end = np.cumsum([len(r) for r in lines])
    start = end - [len(r) for r in lines]
    cursor = start.copy()
    phase = np.tile(phases, len(routes))
    state = np.zeros((n, 6))
    state[:, X], state[:, Y] = points[start, 0], points[start, 1]
    first = points[np.minimum(start + 1, end - 1)] - points[start]
    state[:, HEADING] = np.arctan2(first[:, 1], first[:, 0])
    target, upright = np.empty((n, 2)), np.zeros(n, bool)
    submersion = np.zeros(n)  # the simulator's, until a first step reads the cell
    surf_s, hazard, stuck = np.zeros(n), np.zeros(n), np.zeros(n)
    ashore, timed_out = np.zeros(n, bool), np.zeros(n, bool)
    landed = np.full((n, 2), np.nan)
    model = SkidModel(robot)
    subs = round(STEP_S / SUBSTEP_S)
    t = 0.0
    for _ in range(math.ceil(HORIZON_LIMITS * limit / STEP_S)):
        live = ~ashore & ~timed_out
        if not live.any():
            break
        # the simulator's route follower and controller (`World.controller_commands`)
        boats = afloat(submersion)
        advance_cursors(points, start, end, cursor, state[:, :2], live, boats)
        steer_points(points, start, end, cursor, state[:, :2], boats, target)
        omega, jet, _ = drive_toward(state, target, cruise, submersion, upright, limits, live)
        metres, slip = np.zeros(n), np.zeros(n)
        for k in range(subs):
            t0 = t + k * SUBSTEP_S
            cell = cells.of(state[:, :2])
            crest = np.floor((t0 + SUBSTEP_S - phase) / period) > np.floor((t0 - phase) / period)
            hazard += np.where(live & crest, cells.hit_hazard[cell], 0.0)
            new = _substep(model, cells, state, omega, jet, cell, _shape(t0, phase, period))
            metres += np.hypot(new[:, X] - state[:, X], new[:, Y] - state[:, Y])
            w = 0.5 * (omega[:, 0] + omega[:, 1]) * cells.wheel_m[cells.terrain[cell]]
            slip += mean_wheel_slip(w, new[:, U])
            state = new
        t += STEP_S
        cell = cells.of(state[:, :2])
        per_m = cells.stuck_per_m[cells.terrain[cell]]
        stuck += np.where(live, per_m * budget.slip_factor(slip / subs) * metres, 0.0)
        submersion = cells.buoyancy[cells.terrain[cell]]
        surf_s += np.where(live & (cells.height[cell] > 0), STEP_S, 0.0)
        grounded = live & (submersion < GROUND_SUBMERSION)
        landed[grounded] = state[grounded, :2]
        ashore |= grounded
        timed_out |= live & ~ashore & (surf_s > limit)
    k, each = WAVE_PHASES, (surf_s, hazard, ashore, timed_out, landed, stuck)
    return [WayIn(*(a[i : i + k] for a in each)) for i in range(0, n, k)]


def _shape(t_s: float, phase_s: np.ndarray, period_s: float) -> np.ndarray:
    """The wave shape at `t_s` for each robot's wave phase (`coastal.wave_shape`, vectorized)."""
    phi = 2.0 * np.pi * (t_s - phase_s) / period_s
    return (np.cos(phi) + WAVE_SKEW * np.cos(2.0 * phi)) / (1.0 + WAVE_SKEW)


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
