"""How long a robot spends among the breakers: the plan's time in the surf zone.

The simulator (`swarm.sim.physics`) drags a robot in the surf zone on its velocity relative to the
water, the longshore current plus the wave's orbital flow u = (H/2) sqrt(g/h) along the shoreward
direction, shaped in time by `coastal.wave_shape`; its jet pushes where it floats and its wheels
grip where they bear. In big breakers the backwash takes back much of what each crest gives: over
relay's surf cells (1.5 m breakers, 0.6 m/s commanded) a robot makes 0.34-0.5 m/s, and over its
shallow-water cells 0.56, where the plan used to count the 0.5 m/s it swims in open water. Its
spares were 63 s among the breakers in the simulator (4 runs, hazards off) against the 48 s the
plan counted, so it met a third more breakers.

`SurfZone.crossing` gives the time from the same forces on the same `skid` model, reduced to one
robot held on the polyline's heading in each cell it crosses and averaged over wave periods after
one to settle (`mean_speed`): relay's spares 63-65 s. A breaker comes once a period wherever the
robot is (`SeaState.crests_by`), so it meets each local height in proportion to its time under it.

What it leaves out is the steering: the simulator's robots are pushed off their line by every wave
and steer back. Driven straight from relay's launch points to the beach by the simulator's physics
and controller, they are in the surf 66.5-67 s against 60-64 s from here (48.5 s at swim speed,
`tests/mission/test_surf_speed.py`); relay's two relays whose routes run 85-90 m along the surf
zone, 280 s against 253-255 s (170-180 s at swim speed).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from swarm.mission import budget
from swarm.mission.schema import Mission
from swarm.planning import CostMap
from swarm.robot.params import GRAVITY_MPS2
from swarm.robot.skid import HEADING, R, SkidModel, U, V, X, coeffs_for
from swarm.robot.terrain import GROUND_SUBMERSION, JET_SUBMERSION
from swarm.world.coastal import MIN_DEPTH_M, shoreward_direction, wave_shape

#: Integration step of `mean_speed`, s: the simulator's physics substep (`swarm.sim.env.SimConfig`).
SUBSTEP_S = 0.25
#: Wave periods `mean_speed` lets a robot settle for, then averages over (its motion is periodic
#: once settled: the robot's transients die out within seconds against the quadratic drag).
SETTLE_PERIODS, MEASURED_PERIODS = 1, 1
#: Headings are taken in bins this wide (degrees) for the cache: a cell crossed in one direction
#: makes the same way whichever polyline crosses it.
HEADING_BIN_DEG = 5.0
#: The slowest way a robot is counted to make, as a share of its commanded speed: where the flow
#: holds it back entirely the simulator strands it (`surf_timeout`), which the budget counts apart
#: on the way in (`swarm.mission.surf_drive`).
SLOWEST_SHARE = 0.1


class Crossing(NamedTuple):
    """A polyline's way over the surf zone."""

    metres: float  # over surf-zone cells
    seconds: float  # at the way the robot makes there (`mean_speed`)
    hazard_per_hit: float  # -log(1 - p) of one breaker, averaged over the time (0 without any)


def mean_speed(
    mission: Mission,
    classes: list[str],
    depth_m: np.ndarray,
    height_m: np.ndarray,
    flow_dir: np.ndarray,
    grade: np.ndarray,
    speed_mps: float,
    current: np.ndarray,
) -> np.ndarray:
    """(k,) the mean way (m/s) a robot makes holding a heading at `speed_mps` through k surf cells:
    terrain class, still-water depth, local breaker height, and (k, 2) in the frame of the heading
    (forward, left) the shoreward direction, the gradient of the ground and the longshore current
    (m/s). The forces are the simulator's (`swarm.sim.physics`, its numpy `_run`): drag on the
    velocity relative to the water, the jet on the submerged part above `JET_SUBMERSION`, the slope
    on the weight the water leaves, the wheels' normal load by the slope's cosine; heading and yaw
    rate held at zero."""
    lib, robot = mission.terrain_library, mission.robot_params
    surf = mission.hazards.surf
    k = len(classes)
    modes = [lib[c] for c in classes]
    coeffs = coeffs_for(modes)
    buoy = np.array([m.buoyancy_fraction for m in modes])
    drag = np.array([m.drag_n_s2_per_m2 for m in modes])
    jet = mission.robot.jet_thrust_n or lib.default_jet_thrust_n(mission.robot.swim_speed_mps)
    thrust = np.where(buoy > JET_SUBMERSION, jet * buoy, 0.0)
    amplitude = 0.5 * height_m * np.sqrt(GRAVITY_MPS2 / np.maximum(MIN_DEPTH_M, depth_m))
    cos_slope = 1.0 / np.sqrt(1.0 + grade[:, 0] ** 2 + grade[:, 1] ** 2)
    slope = -(1.0 - buoy)[:, None] * (robot.mass_kg * GRAVITY_MPS2) * grade * cos_slope[:, None]
    omega = np.full((k, 2), speed_mps / robot.wheel_radius_m)
    state = np.zeros((k, 6))
    state[:, U] = speed_mps
    period = float(surf.wave_period_s)
    settle = round(SETTLE_PERIODS * period / SUBSTEP_S)
    steps = settle + round(MEASURED_PERIODS * period / SUBSTEP_S)
    model = SkidModel(robot)
    wrench = np.zeros((k, 3))
    start = state[:, X].copy()
    for step in range(steps):
        if step == settle:
            start = state[:, X].copy()
        shape = wave_shape(2.0 * math.pi * step * SUBSTEP_S / period)
        wx = current[:, 0] + shape * amplitude * flow_dir[:, 0]
        wy = current[:, 1] + shape * amplitude * flow_dir[:, 1]
        u, v = state[:, U], state[:, V]
        ru, rv = u - wx, v - wy
        speed, rel = np.sqrt(u * u + v * v), np.sqrt(ru * ru + rv * rv)
        wrench[:, 0] = drag * (speed * u - rel * ru) + thrust + slope[:, 0]
        wrench[:, 1] = drag * (speed * v - rel * rv) + slope[:, 1]
        state = model.step(state, omega, coeffs, SUBSTEP_S, wrench, cos_slope)
        state[:, HEADING] = 0.0
        state[:, R] = 0.0
    made = (state[:, X] - start) / ((steps - settle) * SUBSTEP_S)
    return np.maximum(made, SLOWEST_SHARE * speed_mps)


class SurfZone:
    """A mission's surf zone as the plan sees it: local breaker heights (`budget.surf_heights`),
    the shoreward direction and the way a robot makes over each cell (`mean_speed`, cached by cell,
    heading bin and speed)."""

    def __init__(self, mission: Mission, cm: CostMap) -> None:
        self.mission, self.cm = mission, cm
        bm = mission.beach_map
        self.heights = budget.surf_heights(mission)
        #: (rows, cols, 2) where the breakers run (`coastal.shoreward_direction`)
        self.shoreward = shoreward_direction(bm.elevation_m, bm.cell_m)
        self._gradient = np.stack(bm.gradient, axis=-1)
        self._depth = -bm.elevation_m.astype(np.float64)
        self._classes = list(bm.terrain_classes)
        self._terrain = bm.terrain.astype(np.intp)
        self._current = np.array([mission.hazards.surf.longshore_current(), 0.0])
        lib = mission.terrain_library
        self._buoyancy = np.array([lib[c].buoyancy_fraction for c in self._classes])
        self._speeds: dict[tuple[int, int, int, float], float] = {}

    def crossing(self, polyline: np.ndarray, speed_mps: float | None = None) -> Crossing:
        """The way over the surf zone of `polyline`, driven at `speed_mps` (default the robot's
        cruise speed, `robot.wheel_speed_mps`, which the simulator commands in the surf)."""
        speed = float(speed_mps if speed_mps is not None else self.mission.robot.wheel_speed_mps)
        pts = np.asarray(polyline, dtype=np.float64).reshape(-1, 2)
        _, piece, row, col, heading = budget.samples_along(self.cm, pts)
        h = self.heights[row, col]
        on = np.flatnonzero(h > 0)
        if not len(on):
            return Crossing(0.0, 0.0, 0.0)
        bins = np.round(np.degrees(heading[on]) / HEADING_BIN_DEG).astype(np.int64)
        bins %= round(360 / HEADING_BIN_DEG)
        made = self._made(row[on], col[on], bins, speed)
        seconds = piece[on] / made
        surf = self.mission.hazards.surf
        hazard = -np.log1p(-surf.damage_probability(h[on]))
        total = float(seconds.sum())
        return Crossing(float(piece[on].sum()), total, float(seconds @ hazard) / total)

    def landfall(self, polyline: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """`polyline` cut where a robot along it comes ashore, the start of its first half-cell
        piece on ground that gives its wheels traction (`GROUND_SUBMERSION`), where the simulator
        starts its beach phase: the part afloat, and the part from there on (one point if it never
        grounds). The shallow water between there and dry ground is still among the breakers."""
        pts = np.asarray(polyline, dtype=np.float64).reshape(-1, 2)
        _, piece, row, col, _ = budget.samples_along(self.cm, pts)
        ground = self._buoyancy[self._terrain[row, col]] < GROUND_SUBMERSION
        if not ground.any():
            return pts, pts[-1:]
        at = float(piece[: int(np.argmax(ground))].sum())  # metres along the polyline
        ends = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])
        j = min(int(np.searchsorted(ends, at, side="right")) - 1, len(pts) - 2)
        t = (at - ends[j]) / max(ends[j + 1] - ends[j], 1e-12)
        cut = pts[j] + t * (pts[j + 1] - pts[j])
        return np.vstack([pts[: j + 1], cut]), np.vstack([cut, pts[j + 1 :]])

    def _made(self, row: np.ndarray, col: np.ndarray, bins: np.ndarray, speed: float) -> np.ndarray:
        """`mean_speed` over cells (row, col) on heading bins `bins`, from the cache or computed
        together for those not in it."""
        keys = list(zip(row.tolist(), col.tolist(), bins.tolist(), [speed] * len(row), strict=True))
        todo = sorted({k for k in keys if k not in self._speeds})
        if todo:
            r, c, b = np.array([k[:3] for k in todo]).T
            theta = np.radians(b * HEADING_BIN_DEG)
            fwd = np.stack([np.cos(theta), np.sin(theta)], axis=1)
            left = np.stack([-fwd[:, 1], fwd[:, 0]], axis=1)

            def frame(v: np.ndarray) -> np.ndarray:
                return np.stack([(v * fwd).sum(axis=1), (v * left).sum(axis=1)], axis=1)

            made = mean_speed(
                self.mission,
                [self._classes[t] for t in self._terrain[r, c]],
                self._depth[r, c],
                self.heights[r, c],
                frame(self.shoreward[r, c]),
                frame(self._gradient[r, c]),
                speed,
                current=frame(np.broadcast_to(self._current, (len(r), 2))),
            )
            self._speeds.update(zip(todo, made.tolist(), strict=True))
        return np.array([self._speeds[k] for k in keys])
