"""Mine detection by the searching robots, with the mission's sensor model, and false alarms.

Lateral-range curves (Koopman, *Search and Screening*, 1946/1980; Washburn, *Search and Detection*,
4th ed., 2002, ch. 2): p(x) is the chance of detecting an object passed at closest distance x.

- ``cookie_cutter``: p = 1 for |x| <= W/2, else 0 (definite range);
- ``inverse_cube``: p = 1 - exp(-W^2 / (4 pi x^2)) (`swarm.planning.coverage.inverse_cube_lateral_range`);
- ``random_search``: the cookie-cutter curve. Koopman's random-search formula is about tracks laid
  without pattern, not about the sensor, so the sensor itself sees to a definite range;
- a tabulated ``lateral_range`` (whatever the model): linear interpolation, 0 beyond the last range.

Passes. A pass of robot i by mine j starts when the robot's track comes within `max_range_m` of the
mine while the robot is sensing, and ends at the first step whose whole track segment stays beyond
that range. Its closest point of approach x is the least distance from the mine to the robot's
piecewise-linear track over the pass (each step's segment from the last position to the new one,
so a fast robot cannot step over a mine). When the pass ends the mine is detected with
probability p(x): one draw per pass. For a straight pass this is the lateral-range curve itself,
and since passes of different tracks draw independently, parallel tracks at spacing S give
``1 - prod_k (1 - p(x + kS))`` for a mine at offset x, whose average over x is the sweep-width
coverage of `swarm.planning.coverage.detection_probability`: min(1, W/S) for the cookie cutter and
erf(sqrt(pi) W / (2S)) for the inverse cube (exactly so there, since 1 - p is an exponential in
1/x^2 and the product becomes Koopman's sum). The inverse-cube curve is cut at `max_range_m`, where
p = `INVERSE_CUBE_FLOOR`: the cut tails hold W^2 / (2 pi R) = 1.8 % of W, so a lawnmower at S = W
finds about 0.4 percentage points fewer mines than the erf formula.

Inverse cube. Koopman derived the inverse-cube curve from a detection *rate* that falls with the
cube of range, gamma(r) = c h / r^3; so the simulator integrates that rate along each step's track
segment instead of drawing once per pass: a target mine within `max_range_m` of a sensing robot's
segment is detected with probability 1 - exp(-W^2 / (8 pi) * integral ds / r^3), where the
integral is along the segment (closed form). A whole straight pass at lateral distance x gives
exactly p(x) = 1 - exp(-W^2 / (4 pi x^2)); several passes multiply their misses however close
together they come (a single draw per pass would merge the look of two tracks 4 m apart into one
pass near the track ends); a parked robot looks no more. (The rate per metre of track fixes the
sweep width at the searcher's own speed, as Koopman's W is defined.) Tabulated curves, the
cookie cutter and random search draw once per pass, as follows.

Early decision. A mine that lies on a robot's track would be set off before a draw at the end of
the pass could find it, though any real sensor sees it coming: so a pass is decided (its one
draw made) as soon as the robot comes within `DECIDE_TRIGGER_RADII` trigger radii of the mine,
with x the lesser of the closest approach so far and the closest approach of the straight line
the robot is on. For a straight pass that is its closest approach exactly, so the lateral-range
curve is unchanged; the robot is then told in time to steer clear. A decided pass draws again
only when the robot comes closer than the x it was drawn at (a robot curving onto a mine it
passed undetected), with the part of p its earlier draws did not cover (`closer_look`), and at
its end if its closest approach beat that x: a pass still detects with p at its least x (as the
planner's `swarm.planning.detection` counts it), and a robot does not run undetected onto a mine
it is plainly closing on.

A pass also ends, without a draw, when the mine stops being a target (set off, cleared, or found by
another robot: a found mine is known to all and nobody searches for it again), and when the robot
stops sensing: a robot that is lost mid-pass cannot report. `update` takes ``alive``: a robot that
is alive but stops sensing (it left its tracks, it went to mark a mine) does draw, with the x of
the part of the pass it looked at. Without ``alive`` every robot that stops sensing is taken as
lost. A robot that stays within range of a mine for good (parked while sensing) never ends its
pass, so it never draws for that mine.

False alarms (clutter, debris: Washburn ch. 2 treats them as a Poisson process along the track):
each step a sensing robot that moved ``s`` metres raises Poisson(false_alarms_per_km * s / 1000)
of them, each at a point uniform in the disc of radius min(max_range_m, W) around it; with a
clutter area, points outside it are redrawn (up to `FALSE_ALARM_TRIES` times), and alarms of a
robot whose disc does not reach the area are skipped.

Determinism: passes are kept sorted by key robot * m + mine, and every draw is taken in key order
(then false alarms in robot order), so the same inputs and seed give the same detections.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from swarm.mission import schema
from swarm.planning.coverage import inverse_cube_lateral_range
from swarm.planning.detection import (
    LateralRangeCurve,
    inverse_cube_look,
    inverse_cube_range_m,
    segment_distance,
)
from swarm.sim import pair_kernels
from swarm.sim.mines import MineField

#: The screen for robots near a mine allows this much movement within a step (m).
SCREEN_MARGIN_M = 5.0
_NEIGHBOUR_BINS = np.array([(i, j) for i in (-1, 0, 1) for j in (-1, 0, 1)], dtype=np.int64)
_BIN_STRIDE = 1 << 31
#: Up to this many robot-mine pairs, a run's looks are found with the batch's (`sensor_batch`).
DENSE_PAIRS = 100_000
#: A pass is decided early when its robot comes within this many trigger radii of the mine (never
#: beyond the sensor's range): four radii is the 1 m the environment steers found mines clear by.
DECIDE_TRIGGER_RADII = 4.0
#: Rejection rounds for a false alarm inside the clutter area before it is dropped.
FALSE_ALARM_TRIES = 64


@dataclass
class Detection:
    """One report: a mine found (``mine`` its index in the MineField) or a false alarm (``mine`` -1)."""

    robot: int
    mine: int
    xy: tuple[float, float]  # where the robot believes the object is
    t_s: float

    @property
    def false_alarm(self) -> bool:
        return self.mine < 0


def lateral_range_curve(sensor: schema.Sensor) -> Callable[[np.ndarray], np.ndarray]:
    """The sensor's p(x): detection probability of an object passed at closest distance |x|
    (a partial of a module function, so an environment holding it pickles)."""
    if sensor.lateral_range is not None:
        return LateralRangeCurve.of(sensor.lateral_range)
    if sensor.model == "inverse_cube":
        return functools.partial(_inverse_cube_p, w=sensor.width_m)
    return functools.partial(_definite_range_p, w=sensor.width_m)


def _inverse_cube_p(x: np.ndarray, w: float) -> np.ndarray:
    return inverse_cube_lateral_range(np.abs(np.asarray(x, dtype=np.float64)), w)


def _definite_range_p(x: np.ndarray, w: float) -> np.ndarray:
    return (np.abs(np.asarray(x, dtype=np.float64)) <= w / 2.0).astype(np.float64)


def max_range_m(sensor: schema.Sensor) -> float:
    """The distance beyond which p(x) is 0 (below `INVERSE_CUBE_FLOOR` for the inverse cube, from
    1 - exp(-W^2 / (4 pi R^2)) = floor)."""
    if sensor.lateral_range is not None:
        return LateralRangeCurve.of(sensor.lateral_range).max_range_m
    w = sensor.width_m
    if sensor.model == "inverse_cube":
        return inverse_cube_range_m(w)
    return w / 2.0


class MineSensor:
    """The search sensors of `n_robots` robots over one mine field (module docstring: passes,
    closest approach, one draw per pass, false alarms)."""

    def __init__(
        self,
        sensor: schema.Sensor,
        minefield: MineField,
        n_robots: int,
        clutter_area: BaseGeometry | None = None,
    ) -> None:
        self.sensor = sensor
        self.minefield = minefield
        self.n = int(n_robots)
        self.curve = lateral_range_curve(sensor)
        self.range_m = max_range_m(sensor)
        self.false_alarm_radius_m = min(self.range_m, sensor.width_m)
        self.false_alarms_per_m = sensor.false_alarms_per_km / 1000.0
        self.clutter_area = clutter_area
        if clutter_area is not None:
            shapely.prepare(clutter_area)
        self._m = len(minefield)
        self._keys = np.empty(0, dtype=np.int64)  # robot * m + mine, sorted
        self._xmin = np.empty(0)  # closest approach so far, metres
        self._xdrawn = np.empty(0)  # the x a pass was last drawn at (inf: not yet; early decision)
        #: A pass is decided once its robot comes this close to the mine (module docstring).
        self.decide_m = min(self.range_m, DECIDE_TRIGGER_RADII * minefield.trigger_radius_m)
        self._last_xy = np.full((self.n, 2), np.nan)  # position at the last step while sensing
        self._screen_signature = -1
        self._screen_keys = np.empty(0, dtype=np.int64)
        #: Koopman's inverse-cube law is a detection *rate*: integrate it along the track instead
        #: of drawing once per pass (module docstring, "Inverse cube").
        self.continuous = sensor.model == "inverse_cube" and sensor.lateral_range is None

    def reset(self) -> None:
        """Forget passes in progress (a new episode)."""
        self._keys = np.empty(0, dtype=np.int64)
        self._xmin = np.empty(0)
        self._xdrawn = np.empty(0)
        self._last_xy[:] = np.nan
        self._screen_signature = -1

    @property
    def passes_in_progress(self) -> int:
        return len(self._keys)

    def update(
        self,
        xy: np.ndarray,
        sensing: np.ndarray,
        distance_m: np.ndarray,
        t_s: float,
        rng: np.random.Generator,
        *,
        alive: np.ndarray | None = None,
    ) -> list[Detection]:
        """Advance every pass to the robots' new positions `xy` (n, 2); `sensing` (n,) robots whose
        sensor is searching this step, `distance_m` (n,) how far each moved this step, `alive`
        (n,) robots still in the mission (default: `sensing`). Returns the reports of this step:
        mines found (robot, then mine order), then false alarms (robot order)."""
        n = self.n
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        sensing = np.asarray(sensing, dtype=bool).reshape(-1)
        distance_m = np.asarray(distance_m, dtype=np.float64).reshape(-1)
        if len(xy) != n or len(sensing) != n or len(distance_m) != n:
            raise ValueError(
                f"sensing: expected xy ({n}, 2), sensing ({n},), distance_m ({n},); "
                f"found {xy.shape}, {sensing.shape}, {distance_m.shape}"
            )
        sensing = sensing & np.all(np.isfinite(xy), axis=1)
        can_report = sensing if alive is None else np.asarray(alive, dtype=bool).reshape(-1)

        if self.continuous:
            found = self._looks(xy, sensing, float(t_s), rng)
        else:
            found = self._passes(xy, sensing, can_report, float(t_s), rng)
        self._last_xy[:] = np.nan
        self._last_xy[sensing] = xy[sensing]
        return found + self._false_alarms(xy, sensing, distance_m, float(t_s), rng)

    def _looks(
        self, xy: np.ndarray, sensing: np.ndarray, t_s: float, rng: np.random.Generator
    ) -> list[Detection]:
        """Inverse cube: each step, each target mine near a sensing robot's track segment is
        detected with probability 1 - exp(-W^2/(8 pi) * integral of ds / r^3 along the segment)."""
        m = self._m
        field = self.minefield
        target = field.active & ~field.detected
        robots = np.flatnonzero(sensing)
        if m == 0 or not len(robots) or not np.any(target):
            return []
        robots = robots[self._maybe_near(xy[robots], target)]
        if not len(robots):
            return []
        start, end, r, j = self._segments_near(xy, robots, target)
        if not len(r):
            return []
        order = np.lexsort((j, robots[r]))
        r, j = r[order], j[order]
        look = inverse_cube_look(start[r], end[r], field.positions_m[j])
        hazard = self.sensor.width_m**2 / (8.0 * math.pi) * look
        hit = rng.random(len(r)) < -np.expm1(-hazard)
        robot, mine = robots[r[hit]], j[hit]
        return self._found(robot, mine, t_s)

    def _found(self, robot: np.ndarray, mine: np.ndarray, t_s: float) -> list[Detection]:
        """Mark the mines detected and report each once: by the first robot in the given order
        (the lowest robot, or pass key)."""
        _, first = np.unique(mine, return_index=True)
        first.sort()
        robot, mine = robot[first], mine[first]
        self.minefield.detected[mine] = True
        pos = self.minefield.positions_m
        return [
            Detection(int(i), int(k), (float(pos[k, 0]), float(pos[k, 1])), t_s)
            for i, k in zip(robot, mine, strict=True)
        ]

    def _maybe_near(self, xy: np.ndarray, target: np.ndarray) -> np.ndarray:
        """A quick screen: robots in a square bin (`range_m` + `SCREEN_MARGIN_M` wide) next to a
        bin holding a target mine; only they can be within range (a step moves a robot far less
        than the margin)."""
        size = self.range_m + SCREEN_MARGIN_M
        signature = int(np.count_nonzero(target))  # targets only ever go: a count tells a change
        if self._screen_signature != signature:
            mines = np.floor(self.minefield.positions_m[target] / size).astype(np.int64)
            around = (mines[:, None, :] + _NEIGHBOUR_BINS[None, :, :]).reshape(-1, 2)
            self._screen_keys = np.unique(around[:, 0] * _BIN_STRIDE + around[:, 1])
            self._screen_signature = signature
        keys = self._screen_keys
        bins = np.floor(xy / size).astype(np.int64)
        robot_keys = bins[:, 0] * _BIN_STRIDE + bins[:, 1]
        at = np.minimum(np.searchsorted(keys, robot_keys), len(keys) - 1)
        return keys[at] == robot_keys

    def _segments_near(
        self, xy: np.ndarray, robots: np.ndarray, target: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """This step's track segment of each of `robots` (from its last sensing position, or a
        point where it just started) and the (segment, mine) pairs within range of a target mine."""
        end = xy[robots]
        start = self._last_xy[robots]
        start = np.where(np.isfinite(start), start, end)
        mid = 0.5 * (start + end)
        half = 0.5 * np.sqrt(np.sum((end - start) ** 2, axis=1))
        r, j = self._near_pairs(mid, self.range_m + float(half.max()))
        keep = target[j]
        return start, end, r[keep], j[keep]

    def _near_pairs(self, points: np.ndarray, radius_m: float) -> tuple[np.ndarray, np.ndarray]:
        """(point, mine) index pairs within `radius_m`, by point then mine: a compiled grid search
        (`pair_kernels.near_pairs`), as the dense distance check it replaces."""
        return pair_kernels.near_pairs(points, self.minefield.positions_m, radius_m)

    def _passes(
        self,
        xy: np.ndarray,
        sensing: np.ndarray,
        can_report: np.ndarray,
        t_s: float,
        rng: np.random.Generator,
    ) -> list[Detection]:
        m = self._m
        if m == 0:
            return []
        field = self.minefield
        target = field.active & ~field.detected

        # this step's track segments of the sensing robots and the target mines within range of them
        robots = np.flatnonzero(sensing)
        keys = np.empty(0, dtype=np.int64)
        dist, now_m, ray_m = np.empty(0), np.empty(0), np.empty(0)
        if len(robots) and np.any(target):
            start, end, r, j = self._segments_near(xy, robots, target)
            d = segment_distance(start[r], end[r], field.positions_m[j])
            keep = d <= self.range_m
            r, j = r[keep], j[keep]
            keys = robots[r].astype(np.int64) * m + j
            dist = d[keep]
            now_m, ray_m = _ahead(start[r], end[r], field.positions_m[j])
            order = np.argsort(keys)
            keys, dist, now_m, ray_m = keys[order], dist[order], now_m[order], ray_m[order]

        # merge with the passes in progress
        old_keys, old_x, old_drawn = self._keys, self._xmin, self._xdrawn
        drawn = np.full(len(keys), np.inf)
        if len(old_keys) and len(keys):
            where = np.minimum(np.searchsorted(old_keys, keys), len(old_keys) - 1)
            going_on = old_keys[where] == keys
            dist[going_on] = np.minimum(dist[going_on], old_x[where[going_on]])
            drawn[going_on] = old_drawn[where[going_on]]
            ended = np.ones(len(old_keys), dtype=bool)
            ended[where[going_on]] = False
        else:
            ended = np.ones(len(old_keys), dtype=bool)

        # passes that ended closer than they were drawn at (never drawn: at infinity), and passes
        # within the decision distance that are now closer than that (module docstring, "Early
        # decision"): each draws for the part of p(x) its earlier draws did not cover
        ended &= old_x < old_drawn
        end_keys, end_x, end_before = old_keys[ended], old_x[ended], old_drawn[ended]
        # first drawn at the closest approach the robot's line promises; later only as it gets closer
        x_now = np.where(np.isfinite(drawn), dist, np.minimum(dist, ray_m))
        early = (now_m <= self.decide_m) & can_report[keys // m] & (x_now < drawn)
        early_x, early_before = x_now[early], drawn[early]
        drawn[early] = early_x
        self._keys, self._xmin, self._xdrawn = keys, dist, drawn
        draw_keys = np.concatenate([end_keys, keys[early]])
        draw_x = np.concatenate([end_x, early_x])
        before = np.concatenate([end_before, early_before])
        robot, mine = draw_keys // m, draw_keys % m
        draws = target[mine] & can_report[robot]
        robot, mine, draw_x, before = robot[draws], mine[draws], draw_x[draws], before[draws]
        if not len(robot):
            return []
        hit = rng.random(len(robot)) < self.closer_look(draw_x, before)
        robot, mine = robot[hit], mine[hit]
        found = self._found(robot, mine, t_s)
        if len(self._keys):  # nobody keeps passing a mine that is now known
            keep = ~field.detected[self._keys % m]
            self._keys, self._xmin, self._xdrawn = self._keys[keep], self._xmin[keep], self._xdrawn[keep]
        return found

    def closer_look(self, x: np.ndarray, before: np.ndarray) -> np.ndarray:
        """Chance that a pass already drawn at `before` without a find finds the mine at the closer
        x: (p(x) - p(before)) / (1 - p(before)), p(x) itself when never drawn (`before` inf). Draws
        at x1 > x2 > ... then miss with prod (1 - p(x_k+1)) / (1 - p(x_k)) = 1 - p(x_last): the pass
        detects with p at its least x, however often it is looked at."""
        p = self.curve(x)
        p0 = np.where(np.isfinite(before), self.curve(np.where(np.isfinite(before), before, 0.0)), 0.0)
        left = 1.0 - p0
        return np.where(left > 0, (p - p0) / np.where(left > 0, left, 1.0), 0.0)

    def _false_alarms(
        self,
        xy: np.ndarray,
        sensing: np.ndarray,
        distance_m: np.ndarray,
        t_s: float,
        rng: np.random.Generator,
    ) -> list[Detection]:
        if self.false_alarms_per_m <= 0:
            return []
        robots = np.flatnonzero(sensing & (distance_m > 0))
        if not len(robots):
            return []
        counts = rng.poisson(self.false_alarms_per_m * distance_m[robots])
        who = np.repeat(robots, counts)
        if not len(who):
            return []
        centre = xy[who]
        radius = self.false_alarm_radius_m
        area = self.clutter_area
        if area is None:
            pts = centre + _in_disc(rng, len(who), radius)
        else:
            pts = np.full((len(who), 2), np.nan)
            pending = np.flatnonzero(shapely.distance(area, shapely.points(centre)) < radius)
            for _ in range(FALSE_ALARM_TRIES):
                if not len(pending):
                    break
                cand = centre[pending] + _in_disc(rng, len(pending), radius)
                inside = shapely.intersects_xy(area, cand[:, 0], cand[:, 1])
                pts[pending[inside]] = cand[inside]
                pending = pending[~inside]
        return [
            Detection(int(i), -1, (float(p[0]), float(p[1])), t_s)
            for i, p in zip(who, pts, strict=True)
            if np.isfinite(p[0])
        ]


def _ahead(start: np.ndarray, end: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each segment (start -> end) and point: the distance from the segment's end to the point,
    and the closest approach of the ray that carries the segment on from its end (that distance
    where the point lies behind, or the segment has no length)."""
    gap = points - end
    now = np.hypot(gap[:, 0], gap[:, 1])
    heading = end - start
    length = np.hypot(heading[:, 0], heading[:, 1])
    moving = length > 1e-12
    u = heading / np.where(moving, length, 1.0)[:, None]
    along = np.sum(gap * u, axis=1)
    across = np.abs(u[:, 0] * gap[:, 1] - u[:, 1] * gap[:, 0])
    return now, np.where(moving & (along > 0.0), across, now)


def _in_disc(rng: np.random.Generator, k: int, radius: float) -> np.ndarray:
    """k points uniform in the disc of `radius` around the origin (radius sqrt(U) for uniform area)."""
    u = rng.random((k, 2))
    rho = radius * np.sqrt(u[:, 0])
    theta = 2.0 * math.pi * u[:, 1]
    return np.column_stack([rho * np.cos(theta), rho * np.sin(theta)])
