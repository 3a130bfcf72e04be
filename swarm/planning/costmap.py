"""The planner's view of a `BeachMap`: where a robot's centre may go, and what each metre costs.

Impassable ground (`CostMap.reason`):

- terrain modes with `passable: false` (boulders, driftwood logs);
- modes where the robot makes no progress: the `skid` model's steady straight-line speed at the
  nominal wheel command is below `NO_PROGRESS_FRACTION` of the wheel surface speed. Deep water is
  one (no ground contact, no traction): ground planning never enters it; swimming is not planned;
- cells steeper than their mode lets the wheels climb (`slope_deg > mode.max_climb_slope_deg`);
- cells that a `keep_out` region covers any part of;
- everything outside the map (the planner cannot know what is there).

The brink: ground above land too steep to climb is kept `BRINK_MARGIN_M` farther from it than the
footprint alone asks. A robot crossing or turning on the slope above a dune face drifts down it,
and once on the face its wheels spin until the stuck rule takes it (`swarm.sim.hazards.STUCK_SLIP`).
Below a face (the foot of a dune, around a steep pile of wrack) the slope carries a robot away from
it, so only cells higher than their nearest steep cell get the margin; water too steep for
traction (surf on a steep beach) gets none: the robots swim in through it.

The footprint: the robot's centre must stay `half_width_m` from impassable ground, plus half the
motion-checking resolution. OMPL checks a motion at points at most `resolution_m` apart, so any
point between two checked points is within `resolution_m / 2` of one; blocking every cell any of
whose points is closer than `half_width_m + resolution_m / 2` to impassable ground therefore keeps
every point of every accepted motion at least `half_width_m` away. The distance from a cell to the
nearest impassable cell (square to square) is an exact Euclidean distance transform of the
impassable grid grown by one cell: `clearance_m`.

Cost: every metre costs the time the `skid` model says the robot needs on that terrain, relative
to the fastest land mode of the whole terrain library (so costs compare across maps; concrete for
the bundled modes): `cost_per_m = v_fastest_land / v_mode`. All modes run in one vectorized
`SkidModel` call. A path's cost is the exact integral of `cost_per_m` along its segments (cell by
cell), so `cost / reference_speed_mps` is its driving time at the nominal command.

Slope limits come from `TerrainMode.max_climb_slope_deg` as they are: the bundled surf mode's is
0° (its rolling resistance exceeds its buoyancy-reduced grip), so surf on any slope is impassable.
"""

from __future__ import annotations

import math
from array import array
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numba
import numpy as np
import shapely
from shapely.geometry import Point
from shapely.geometry.base import BaseGeometry

from swarm.errors import SwarmError
from swarm.robot.params import RobotParams
from swarm.robot.terrain import TerrainLibrary, load_library
from swarm.world.beachmap import BeachMap

#: A mode where the steady speed is below this fraction of the wheel surface speed is impassable.
NO_PROGRESS_FRACTION = 0.05
#: The wheel surface speed (m/s) of the nominal straight-line command: the thesis robot's cruise.
NOMINAL_WHEEL_SPEED_MPS = 0.6

#: Extra distance (m) a robot's centre keeps from land too steep to climb, on the ground above it,
#: beyond the footprint. Measured in the simulator (full_conops, 7761e18's plan): a robot crossing
#: a 15-17 degree slope in vegetation held its line 0.4-0.5 m below it, and in a lane-end turn slid
#: 1.3-1.6 m down onto the 19.5 degree face beneath, where it stuck in 31 of 32 runs. One metre
#: blocks 1199 more cells of relay's map and 1224 of mine_clear's (about 1% of their free ground),
#: cutting off no more than single cells.
BRINK_MARGIN_M = 1.0

#: `CostMap.reason` codes: why a cell is impassable.
FREE, IMPASSABLE_TERRAIN, NO_TRACTION, TOO_STEEP, KEEP_OUT = 0, 1, 2, 3, 4


class PlanningError(SwarmError):
    """A planning request that cannot be met: the message says which point or pair, and why."""


class EndpointError(PlanningError):
    """A start or goal outside the map, on impassable ground, in a keep-out zone or too close to one."""


class NoPathError(PlanningError):
    """No path between a start and a goal: none exists for the robot, or the planner's budget ran out."""


@dataclass(frozen=True)
class ModeSpeeds:
    """Steady straight-line speed of the robot on each terrain mode, and the cost per metre it gives."""

    names: tuple[str, ...]
    speed_mps: np.ndarray  # (n,)
    cost_per_m: np.ndarray  # (n,) reference speed / speed; inf where the robot makes no progress
    reference_mode: str  # the fastest passable land mode: cost 1.0 per metre
    reference_speed_mps: float
    nominal_wheel_speed_mps: float

    def as_dict(self) -> dict[str, dict[str, float | None]]:
        return {
            n: {
                "speed_mps": round(float(v), 4),
                "cost_per_m": round(float(c), 4) if math.isfinite(c) else None,
            }
            for n, v, c in zip(self.names, self.speed_mps, self.cost_per_m, strict=True)
        }


def mode_speeds(
    library: TerrainLibrary,
    robot: RobotParams,
    names: Sequence[str] | None = None,
    *,
    nominal_wheel_speed_mps: float = NOMINAL_WHEEL_SPEED_MPS,
    duration_s: float = 8.0,
    dt_s: float = 0.01,
) -> ModeSpeeds:
    """Drive the robot straight from rest on every mode at once (one vectorized `SkidModel` run)
    with both wheels at `nominal_wheel_speed_mps` of surface speed; the speed after `duration_s`
    is the steady speed (the skid model settles within a few seconds on every bundled mode).

    The fastest mode that is passable, dry and makes progress is the reference (cost 1.0 per
    metre). Modes passable=false are costed too (the planner never enters them).
    """
    from swarm.robot.skid import SkidModel, coeffs_for  # scipy.integrate: only where needed

    names = tuple(library) if names is None else tuple(names)
    modes = [library[n] for n in names]
    model = SkidModel(robot)
    coeffs = coeffs_for(modes)
    n = len(modes)
    omega = np.full((n, 2), nominal_wheel_speed_mps / robot.wheel_radius_m)
    state = np.zeros((n, 6))
    for _ in range(max(1, round(duration_s / dt_s))):
        state = model.step(state, omega, coeffs, dt_s)
    speed = np.maximum(state[:, 3], 0.0)
    moving = speed >= NO_PROGRESS_FRACTION * nominal_wheel_speed_mps
    land = np.array([m.passable and not m.is_water for m in modes]) & moving
    pool = land if land.any() else moving
    if not pool.any():
        raise PlanningError(f"the robot makes no progress on any of the terrain modes {list(names)}")
    ref = int(np.argmax(np.where(pool, speed, -1.0)))
    with np.errstate(divide="ignore"):
        cost = np.where(moving, speed[ref] / np.where(moving, speed, 1.0), np.inf)
    return ModeSpeeds(
        names=names,
        speed_mps=speed,
        cost_per_m=cost,
        reference_mode=names[ref],
        reference_speed_mps=float(speed[ref]),
        nominal_wheel_speed_mps=float(nominal_wheel_speed_mps),
    )


def robot_half_width_m(robot: RobotParams) -> float:
    """Half the robot's overall width: the body or the wheels, whichever sticks out further
    (skid4: wheel centres 0.6 m apart outside a 0.44 m body, so 0.30 m)."""
    return max(robot.width_m, robot.track_width_m) / 2.0


def format_point(p: Sequence[float]) -> str:
    """(x, y) as messages show it."""
    return f"({p[0]:.6g}, {p[1]:.6g})"


@dataclass(frozen=True, eq=False)
class CostMap:
    """Impassable cells, the footprint-inflated `blocked` grid the planner checks, and cost per metre.

    Arrays are (rows, cols) in the `BeachMap` grid convention (row 0 south, column 0 west). Plain
    numpy and shapely inside, so it pickles to worker processes.
    """

    name: str
    cell_m: float
    origin_m: tuple[float, float]
    terrain_classes: tuple[str, ...]
    terrain: np.ndarray  # int8 class index
    slope_deg: np.ndarray  # float32
    reason: np.ndarray  # int8: FREE or why the cell is impassable
    clearance_m: np.ndarray  # float32: distance from the cell (any point) to impassable ground
    blocked: np.ndarray  # bool: a robot centre here could come closer than half_width_m
    component: np.ndarray  # int32: 4-connected regions of unblocked cells (0 where blocked)
    cost_per_m: np.ndarray  # float32: terrain cost per metre (inf where the mode makes no progress)
    keep_out: tuple[tuple[str, BaseGeometry], ...]
    half_width_m: float
    resolution_m: float
    speeds: ModeSpeeds  # every mode of the terrain library (the reference is the library's fastest)
    climb_limit_deg: np.ndarray = field(repr=False)  # (classes,) steepest climbable slope per class
    brink_margin_m: float = 0.0  # extra clearance from land too steep to climb (`BRINK_MARGIN_M`)

    # geometry -------------------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int]:
        return self.blocked.shape  # type: ignore[return-value]

    @property
    def bounds_m(self) -> tuple[float, float, float, float]:
        x0, y0 = self.origin_m
        return x0, y0, x0 + self.shape[1] * self.cell_m, y0 + self.shape[0] * self.cell_m

    @property
    def margin_m(self) -> float:
        """Half the motion-checking resolution, added to the half-width when inflating."""
        return self.resolution_m / 2.0

    @property
    def inflation_m(self) -> float:
        """How far the robot's centre stays from impassable ground, checked cell by cell."""
        return self.half_width_m + self.margin_m

    @cached_property
    def min_cost_per_m(self) -> float:
        """The cheapest metre anywhere the robot may drive: scales the distance heuristic."""
        free = ~self.blocked
        return float(self.cost_per_m[free].min()) if free.any() else 1.0

    def contains(self, x: float, y: float) -> bool:
        xmin, ymin, xmax, ymax = self.bounds_m
        return bool(xmin <= x < xmax and ymin <= y < ymax)

    def cell_of(self, x: np.ndarray | float, y: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        col = np.floor((np.asarray(x, dtype=np.float64) - self.origin_m[0]) / self.cell_m).astype(np.intp)
        row = np.floor((np.asarray(y, dtype=np.float64) - self.origin_m[1]) / self.cell_m).astype(np.intp)
        rows, cols = self.blocked.shape
        # minimum/maximum rather than np.clip: the same cells at a fraction of clip's call overhead
        return np.minimum(np.maximum(row, 0), rows - 1), np.minimum(np.maximum(col, 0), cols - 1)

    def center_of(self, row: np.ndarray | int, col: np.ndarray | int) -> tuple[np.ndarray, np.ndarray]:
        x = self.origin_m[0] + (np.asarray(col) + 0.5) * self.cell_m
        y = self.origin_m[1] + (np.asarray(row) + 0.5) * self.cell_m
        return x, y

    def is_free(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        """True where a robot centre may be: inside the map and in an unblocked cell."""
        inside, row, col = self._locate(x, y)
        return inside & ~self.blocked[row, col]

    def ground_free(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        """True where the ground itself can be crossed: inside the map, on a cell no reason makes
        impassable (the footprint's margin aside). Where mines are laid and searched for."""
        inside, row, col = self._locate(x, y)
        return inside & (self.reason[row, col] == FREE)

    def on_brink(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        """True where a cell is blocked by the brink margin alone: the footprint fits there, so a
        robot may drive in to reach a point (a mine to mark), though routes keep off."""
        inside, row, col = self._locate(x, y)
        return inside & self.blocked[row, col] & (self.clearance_m[row, col] >= self.inflation_m)

    def free_at(self, x: float, y: float) -> bool:
        """`is_free` of one point, in plain floats (the same arithmetic, without numpy's per-call
        cost on scalars: the simulator asks it of one robot at a time)."""
        xmin, ymin, xmax, ymax = self.bounds_m
        if not (xmin <= x <= xmax and ymin <= y <= ymax):
            return False
        return not bool(self.blocked[self.cell_at(x, y)])

    def cell_at(self, x: float, y: float) -> tuple[int, int]:
        """`cell_of` of one finite point, in plain floats."""
        rows, cols = self.blocked.shape
        col = min(max(math.floor((x - float(self.origin_m[0])) / self.cell_m), 0), cols - 1)
        row = min(max(math.floor((y - float(self.origin_m[1])) / self.cell_m), 0), rows - 1)
        return row, col

    def _locate(self, x: np.ndarray | float, y: np.ndarray | float) -> tuple[np.ndarray, ...]:
        """Whether each point lies inside the map, and its (clipped) cell."""
        xmin, ymin, xmax, ymax = self.bounds_m
        x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        row, col = self.cell_of(x, y)
        return (x >= xmin) & (x <= xmax) & (y >= ymin) & (y <= ymax), row, col

    # cost and clearance along segments ------------------------------------------------------------
    def segments_cost(self, p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
        """Exact integral of `cost_per_m` along each segment p0[i] -> p1[i]: each piece between
        consecutive crossings of grid lines, its length times its cell's cost (`_walk_segments`)."""
        p0, p1 = _segment_ends(p0, p1)
        out = np.empty(len(p0))
        _walk_segments(p0, p1, *self._grid(), self.cost_per_m, self.blocked, False, out)
        return out

    def segment_cost_function(self):
        """A fast scalar `f(x0, y0, x1, y1) -> cost` for OMPL's per-motion callbacks: walks the cells
        in pure Python (Amanatides-Woo) for short segments, `segments_cost` for long ones."""
        rows, cols = self.shape
        inv = 1.0 / self.cell_m
        ox, oy = self.origin_m
        flat = array("d")
        flat.frombytes(np.ascontiguousarray(self.cost_per_m, dtype=np.float64).tobytes())
        rmax, cmax = rows - 1, cols - 1
        segments_cost = self.segments_cost
        inf = math.inf

        def cost(x0: float, y0: float, x1: float, y1: float) -> float:
            gx0, gy0, gx1, gy1 = (x0 - ox) * inv, (y0 - oy) * inv, (x1 - ox) * inv, (y1 - oy) * inv
            c, r = min(max(math.floor(gx0), 0), cmax), min(max(math.floor(gy0), 0), rmax)
            ce, re = min(max(math.floor(gx1), 0), cmax), min(max(math.floor(gy1), 0), rmax)
            length = math.hypot(x1 - x0, y1 - y0)
            if c == ce and r == re:
                return length * flat[r * cols + c]
            if abs(ce - c) + abs(re - r) > 160:
                return float(segments_cost(np.array([[x0, y0]]), np.array([[x1, y1]]))[0])
            dx, dy = gx1 - gx0, gy1 - gy0
            if dx > 0:
                sx, tx, dtx = 1, (c + 1 - gx0) / dx, 1.0 / dx
            elif dx < 0:
                sx, tx, dtx = -1, (c - gx0) / dx, -1.0 / dx
            else:
                sx, tx, dtx = 0, inf, inf
            if dy > 0:
                sy, ty, dty = 1, (r + 1 - gy0) / dy, 1.0 / dy
            elif dy < 0:
                sy, ty, dty = -1, (r - gy0) / dy, -1.0 / dy
            else:
                sy, ty, dty = 0, inf, inf
            t = acc = 0.0
            while True:
                step_x = tx <= ty
                tn = tx if step_x else ty
                here = flat[min(max(r, 0), rmax) * cols + min(max(c, 0), cmax)]
                if tn >= 1.0:
                    if t < 1.0:
                        acc += (1.0 - t) * here
                    break
                if tn > t:
                    acc += (tn - t) * here
                    t = tn
                if step_x:
                    c += sx
                    tx += dtx
                else:
                    r += sy
                    ty += dty
            return acc * length

        return cost

    def segments_free(self, p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
        """True for each segment that crosses only unblocked cells and stays inside the map."""
        p0, p1 = _segment_ends(p0, p1)
        crossed = np.empty(len(p0))
        _walk_segments(p0, p1, *self._grid(), self.cost_per_m, self.blocked, True, crossed)
        out = crossed == 0.0
        _ends_free(p0, p1, *self._grid(), *self.bounds_m, self.blocked, out)
        return out

    def _grid(self) -> tuple[float, float, float]:
        """The origin and cell size as `_walk_segments` takes them."""
        return float(self.origin_m[0]), float(self.origin_m[1]), float(self.cell_m)

    def path_cost(self, points: np.ndarray) -> float:
        points = np.asarray(points, dtype=np.float64)
        if len(points) < 2:
            return 0.0
        return float(self.segments_cost(points[:-1], points[1:]).sum())

    # endpoint checks ------------------------------------------------------------------------
    def _nearest_obstacle(self, x: float, y: float) -> tuple[float, str]:
        """Distance from a point to the nearest impassable cell or the map edge, and what it is."""
        xmin, ymin, xmax, ymax = self.bounds_m
        best, what = min(x - xmin, xmax - x, y - ymin, ymax - y), "the map edge"
        reach = math.ceil((self.inflation_m + self.brink_margin_m) / self.cell_m) + 2
        row, col = (int(v) for v in self.cell_of(x, y))
        r0, r1 = max(row - reach, 0), min(row + reach + 1, self.shape[0])
        c0, c1 = max(col - reach, 0), min(col + reach + 1, self.shape[1])
        rr, cc = np.nonzero(self.reason[r0:r1, c0:c1] != FREE)
        if len(rr):
            rr, cc = rr + r0, cc + c0
            cx, cy = self.center_of(rr, cc)
            h = self.cell_m / 2
            dist = np.hypot(np.maximum(np.abs(cx - x) - h, 0), np.maximum(np.abs(cy - y) - h, 0))
            k = int(np.argmin(dist))
            if dist[k] < best:
                best = float(dist[k])
                what = self.describe_cell(int(rr[k]), int(cc[k]))
        return best, what

    def describe_cell(self, row: int, col: int) -> str:
        """What makes an impassable cell impassable, in words."""
        cls = self.terrain_classes[int(self.terrain[row, col])]
        x, y = (float(v) for v in self.center_of(row, col))
        code = int(self.reason[row, col])
        if code == KEEP_OUT:
            names = [n for n, g in self.keep_out if g.distance(Point(x, y)) <= self.cell_m]
            return f"keep-out zone '{names[0]}'" if names else f"a keep-out zone near {format_point((x, y))}"
        if code == IMPASSABLE_TERRAIN:
            return f"{cls} (impassable) at {format_point((x, y))}"
        if code == NO_TRACTION:
            return f"{cls} (no traction) at {format_point((x, y))}"
        if code == TOO_STEEP:
            slope, limit = self.slope_deg[row, col], self.climb_limit_deg[self.terrain[row, col]]
            return f"{cls} on a {slope:.1f}° slope (it allows {limit:.1f}°) at {format_point((x, y))}"
        return f"{cls} at {format_point((x, y))}"

    def point_problem(self, x: float, y: float) -> str | None:
        """Why a robot cannot stand at (x, y), or None if it can."""
        xmin, ymin, xmax, ymax = self.bounds_m
        if not (math.isfinite(x) and math.isfinite(y)) or not self.contains(x, y):
            return f"is outside the map '{self.name}' (x {xmin:g}..{xmax:g} m, y {ymin:g}..{ymax:g} m)"
        for name, geom in self.keep_out:
            if geom.intersects(Point(x, y)):
                return f"is inside keep-out zone '{name}'"
        row, col = (int(v) for v in self.cell_of(x, y))
        cls = self.terrain_classes[int(self.terrain[row, col])]
        code = int(self.reason[row, col])
        if code == IMPASSABLE_TERRAIN:
            return f"is on {cls}, impassable terrain"
        if code == NO_TRACTION:
            i = self.speeds.names.index(cls)
            return (
                f"is in {cls}, where the robot makes no progress on the ground (no traction: "
                f"{self.speeds.speed_mps[i]:.2f} m/s at the nominal wheel speed); ground planning avoids it"
            )
        if code == TOO_STEEP:
            return (
                f"is on a {self.slope_deg[row, col]:.1f}° slope, steeper than the robot can climb on "
                f"{cls} ({self.climb_limit_deg[self.terrain[row, col]]:.1f}°)"
            )
        if self.blocked[row, col]:
            dist, what = self._nearest_obstacle(x, y)
            if self.on_brink(x, y):
                return (
                    f"is {dist:.2f} m from {what}: the planner keeps the centre "
                    f"{self.inflation_m + self.brink_margin_m:.2f} m from ground too steep to climb, "
                    f"{self.brink_margin_m:.2f} m more than from other obstacles, as a robot turning on "
                    "the slope above slides down onto it"
                )
            return (
                f"is too close to {what} for the robot's footprint: {dist:.2f} m away, the planner keeps "
                f"the centre {self.inflation_m:.2f} m clear (half-width {self.half_width_m:.2f} m + "
                f"{self.margin_m:.2f} m check margin)"
            )
        return None

    def check_endpoints(self, start: Sequence[float], goal: Sequence[float], who: str = "") -> None:
        """Raise `EndpointError` or `NoPathError` (one line: which point, why) unless a path can exist."""
        prefix = f"{who}: " if who else ""
        for label, p in (("start", start), ("goal", goal)):
            problem = self.point_problem(float(p[0]), float(p[1]))
            if problem is not None:
                raise EndpointError(f"{prefix}{label} {format_point(p)} {problem}")
        (rs, re), (cs, ce) = self.cell_of([start[0], goal[0]], [start[1], goal[1]])
        if self.component[rs, cs] != self.component[re, ce]:
            raise NoPathError(
                f"{prefix}no path from start {format_point(start)} to goal {format_point(goal)}: "
                "impassable ground (rocks, steep slopes, water without traction) or keep-out zones "
                f"separate them for a robot {2 * self.half_width_m:.2f} m wide"
            )


def _keep_out_cells(beach: BeachMap, geoms: Sequence[BaseGeometry]) -> np.ndarray:
    """Cells a keep-out geometry enters: an area's interior (an edge shared with a cell does not
    count), or any point of a line or point."""
    rows, cols = beach.shape
    out = np.zeros((rows, cols), dtype=bool)
    x0, y0, s = beach.origin_m[0], beach.origin_m[1], beach.cell_m
    for geom in geoms:
        gx0, gy0, gx1, gy1 = geom.bounds
        # the bounding box's cells and one more all round (a line along a grid line touches both sides)
        c0, c1 = max(math.floor((gx0 - x0) / s) - 1, 0), min(math.floor((gx1 - x0) / s) + 2, cols)
        r0, r1 = max(math.floor((gy0 - y0) / s) - 1, 0), min(math.floor((gy1 - y0) / s) + 2, rows)
        if c0 >= c1 or r0 >= r1:
            continue
        cc, rr = np.meshgrid(np.arange(c0, c1), np.arange(r0, r1))
        boxes = shapely.box(x0 + cc * s, y0 + rr * s, x0 + (cc + 1) * s, y0 + (rr + 1) * s)
        shapely.prepare(geom)
        hit = shapely.intersects(geom, boxes)
        if geom.area > 0:  # an area edge along a cell edge does not enter the cell; a fence line does
            hit &= ~shapely.touches(geom, boxes)
        out[r0:r1, c0:c1] |= hit
    return out


def build_costmap(
    beach: BeachMap,
    robot: RobotParams,
    library: TerrainLibrary | None = None,
    *,
    half_width_m: float | None = None,
    resolution_m: float | None = None,
    nominal_wheel_speed_mps: float = NOMINAL_WHEEL_SPEED_MPS,
    brink_margin_m: float = BRINK_MARGIN_M,
) -> CostMap:
    """The planner's view of `beach` for `robot` (see the module docstring).

    `half_width_m` defaults to `robot_half_width_m(robot)`; `resolution_m`, the spacing at which
    motions are checked, to half a cell.
    """
    from scipy import ndimage

    library = load_library() if library is None else library
    hw = robot_half_width_m(robot) if half_width_m is None else float(half_width_m)
    res = beach.cell_m / 2.0 if resolution_m is None else float(resolution_m)
    if not (hw >= 0 and res > 0 and brink_margin_m >= 0):
        raise ValueError("half_width_m and brink_margin_m must be >= 0 and resolution_m > 0")
    classes = beach.terrain_classes
    modes = [library[c] for c in classes]
    # every mode of the library, so the reference (cost 1.0 per metre) is the same on every map
    names = tuple(dict.fromkeys([*library, *classes]))
    speeds = mode_speeds(library, robot, names, nominal_wheel_speed_mps=nominal_wheel_speed_mps)
    class_cost = np.array([speeds.cost_per_m[names.index(c)] for c in classes])
    limit = np.array([m.max_climb_slope_deg for m in modes])
    passable = np.array([m.passable for m in modes])
    water = np.array([m.is_water for m in modes])
    moving = np.isfinite(class_cost)

    terrain = np.asarray(beach.terrain)
    slope = np.asarray(beach.slope_deg, dtype=np.float32)
    reason = np.zeros(beach.shape, dtype=np.int8)
    reason[slope > limit[terrain]] = TOO_STEEP
    reason[~moving[terrain]] = NO_TRACTION
    reason[~passable[terrain]] = IMPASSABLE_TERRAIN
    keep_out = tuple((r.name, r.geometry) for r in beach.regions_of_kind("keep_out"))
    reason[_keep_out_cells(beach, [g for _, g in keep_out])] = KEEP_OUT

    clearance = _clearance_from(reason != FREE, beach.cell_m, outside=True)
    blocked = clearance < hw + res / 2.0
    steep_land = (reason == TOO_STEEP) & ~water[terrain]
    if brink_margin_m > 0 and steep_land.any():
        near = _clearance_from(steep_land, beach.cell_m, outside=False) < hw + res / 2.0 + brink_margin_m
        _, (row, col) = ndimage.distance_transform_edt(~steep_land, return_indices=True)
        elevation = np.asarray(beach.elevation_m)
        blocked |= near & (elevation > elevation[row, col])  # above the face: a slide goes onto it
    component, _ = ndimage.label(~blocked)

    cost = class_cost[terrain].astype(np.float32)
    return CostMap(
        name=beach.name,
        cell_m=float(beach.cell_m),
        origin_m=(float(beach.origin_m[0]), float(beach.origin_m[1])),
        terrain_classes=tuple(classes),
        terrain=terrain.astype(np.int8, copy=False),
        slope_deg=slope,
        reason=reason,
        clearance_m=clearance.astype(np.float32),
        blocked=blocked,
        component=component.astype(np.int32),
        cost_per_m=cost,
        keep_out=keep_out,
        half_width_m=hw,
        resolution_m=res,
        speeds=speeds,
        climb_limit_deg=limit,
        brink_margin_m=float(brink_margin_m),
    )


def _clearance_from(cells: np.ndarray, cell_m: float, *, outside: bool) -> np.ndarray:
    """Distance (m) from every cell (any point of it) to the nearest of `cells`, and to the map's
    edge if `outside`. The gap between two cells' squares is the centre distance less one cell per
    axis, so it is the Euclidean distance transform of `cells` grown by one cell (Chebyshev)."""
    from scipy import ndimage

    pad = 2
    grown = ndimage.binary_dilation(
        np.pad(cells, pad, constant_values=outside), structure=np.ones((3, 3), bool)
    )
    if not grown.any():
        return np.full(cells.shape, np.inf)
    return ndimage.distance_transform_edt(~grown)[pad:-pad, pad:-pad] * cell_m


def _segment_ends(p0: np.ndarray, p1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return (
        np.ascontiguousarray(p0, dtype=np.float64).reshape(-1, 2),
        np.ascontiguousarray(p1, dtype=np.float64).reshape(-1, 2),
    )


@numba.njit(cache=True, error_model="numpy")
def _walk_segments(p0, p1, ox, oy, cell_m, cost, blocked, count_blocked, out):
    """Every segment p0[i] -> p1[i] cut where it crosses a grid line (the crossing parameters
    t = (line - g0) / d along it, with its ends 0 and 1, in order), each piece of positive length
    looked up at its midpoint's cell (clipped to the grid). `out[i]`: the pieces' lengths times
    their cells' `cost` added up in order; with `count_blocked`, how many pieces lie on `blocked`
    cells instead (a segment with a non-finite end: NaN, or one blocked piece). The arithmetic of
    the vectorized numpy it replaces, operation for operation (tested float for float)."""
    rows, cols = cost.shape
    ts, bx, by = np.empty(64), np.empty(64), np.empty(64)
    for i in range(p0.shape[0]):
        gx0, gy0 = (p0[i, 0] - ox) / cell_m, (p0[i, 1] - oy) / cell_m
        gx1, gy1 = (p1[i, 0] - ox) / cell_m, (p1[i, 1] - oy) / cell_m
        dx, dy = gx1 - gx0, gy1 - gy0
        if not (math.isfinite(dx) and math.isfinite(dy)):  # no grid walk from a point off every grid
            out[i] = 1.0 if count_blocked else np.nan
            continue
        lo_x, hi_x = math.floor(min(gx0, gx1)), math.ceil(max(gx0, gx1))
        lo_y, hi_y = math.floor(min(gy0, gy1)), math.ceil(max(gy0, gy1))
        nx, ny = max(hi_x - lo_x - 1, 0), max(hi_y - lo_y - 1, 0)
        if nx + ny + 2 > ts.shape[0]:
            ts = np.empty(2 * (nx + ny + 2))
        if nx > bx.shape[0]:
            bx = np.empty(2 * nx)
        if ny > by.shape[0]:
            by = np.empty(2 * ny)
        # each axis's crossings in increasing t (lines walked against the direction when it is
        # negative), then the two merged between the ends: the crossings sorted, without a sort
        for j in range(nx):
            line = lo_x + 1 + j if dx > 0 else hi_x - 1 - j
            bx[j] = min(max((float(line) - gx0) / dx, 0.0), 1.0)
        for j in range(ny):
            line = lo_y + 1 + j if dy > 0 else hi_y - 1 - j
            by[j] = min(max((float(line) - gy0) / dy, 0.0), 1.0)
        ts[0] = 0.0
        m, a, b = 1, 0, 0
        while a < nx or b < ny:
            if b >= ny or (a < nx and bx[a] <= by[b]):
                ts[m] = bx[a]
                a += 1
            else:
                ts[m] = by[b]
                b += 1
            m += 1
        ts[m] = 1.0
        m += 1
        hyp = np.hypot(dx, dy)
        acc = 0.0
        for q in range(m - 1):
            ta, tb = ts[q], ts[q + 1]
            length = (tb - ta) * hyp * cell_m
            if not length > 0.0:
                continue
            mid = 0.5 * (ta + tb)
            col = min(max(math.floor(gx0 + mid * dx), 0), cols - 1)
            row = min(max(math.floor(gy0 + mid * dy), 0), rows - 1)
            if count_blocked:
                acc += 1.0 if blocked[row, col] else 0.0
            else:
                acc += length * cost[row, col]
        out[i] = acc


@numba.njit(cache=True, error_model="numpy")
def _ends_free(p0, p1, ox, oy, cell_m, xmin, ymin, xmax, ymax, blocked, out):
    """`out[i] &=` both ends of segment i are free (`CostMap.is_free`'s test and arithmetic)."""
    rows, cols = blocked.shape
    for i in range(p0.shape[0]):
        for x, y in ((p0[i, 0], p0[i, 1]), (p1[i, 0], p1[i, 1])):
            inside = xmin <= x <= xmax and ymin <= y <= ymax
            if not inside or blocked[clamped_cell(y, oy, cell_m, rows), clamped_cell(x, ox, cell_m, cols)]:
                out[i] = False


@numba.njit(cache=True, inline="always")
def clamped_cell(v, v0, cell_m, count):
    """`CostMap.cell_of`'s index along one axis, in its arithmetic, for compiled loops: the cell of
    coordinate `v` on an axis starting at `v0`, clipped to 0 .. count - 1."""
    return min(max(math.floor((v - v0) / cell_m), 0), count - 1)
