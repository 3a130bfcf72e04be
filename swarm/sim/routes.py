"""Each robot's route as a waypoint list, followed by all robots at once.

Routes are ragged (a searcher's boustrophedon run has hundreds of points, a relay's a handful), so
they live in one growing flat array with a [start, end) slice and a cursor per robot; advancing
every cursor is a few vectorized passes. Replacing a robot's route appends the new points (to
an array whose capacity doubles, so appending is amortized constant time); the old ones stay
(routes are small next to the trajectories).
"""

from __future__ import annotations

import numba
import numpy as np

from swarm.robot.driving import CAPTURE_M, advance_cursors, leg, steer_points
from swarm.robot.npmath import maximum, minimum

#: A side-step's first point lies at least this far from where it leaves the leg (`clear_of`).
SIDESTEP_CLEAR_M = 1.25 * CAPTURE_M


class Routes:
    """Waypoint lists for n robots and how far along each robot is."""

    def __init__(self, n: int) -> None:
        self._store = np.empty((256, 2))  # capacity doubles as routes are appended
        self._used = 0
        self.points = self._store[:0]
        self.start = np.zeros(n, dtype=np.intp)
        self.end = np.zeros(n, dtype=np.intp)
        self.cursor = np.zeros(n, dtype=np.intp)
        self.sensing_from = np.zeros(n, dtype=np.intp)  # the first point of a searcher's track

    def set(self, i: int, waypoints: np.ndarray, sensing_from: int | None = None) -> None:
        """Give robot i a new route (k, 2); `sensing_from`: index of the first search-track point."""
        pts = np.asarray(waypoints, dtype=np.float64).reshape(-1, 2)
        base = self._used
        if base + len(pts) > len(self._store):
            grown = np.empty((max(2 * len(self._store), base + len(pts)), 2))
            grown[:base] = self._store[:base]
            self._store = grown
        self._store[base : base + len(pts)] = pts
        self._used = base + len(pts)
        self.points = self._store[: self._used]
        self.start[i], self.end[i], self.cursor[i] = base, base + len(pts), base
        self.sensing_from[i] = base + (len(pts) if sensing_from is None else sensing_from)

    def steer_clear(self, i: int, xy: np.ndarray, avoid: np.ndarray, radius_m: float) -> None:
        """Re-lay what is left of robot i's route clear of `avoid` (`clear_of`), keeping the part
        that is search track marked as such. The new route starts on the leg the robot is driving,
        abreast of it (`leg_starts`), so the robot still follows that leg: started at the leg's far
        end, it steered straight for a point up to 900 m away, and a cross-slope carried it metres
        off its lane, off the ground it was to sweep and onto the obstacles the lane was laid clear of."""
        if self.cursor[i] >= self.end[i] or not len(avoid):
            return
        rest = self.points[self.cursor[i] : self.end[i]]
        if (rest == xy).all():
            return  # told to stay where it stands (a retreat from safe ground): no leg to side-step
        here = self.leg_starts(np.array([i]), np.asarray(xy, dtype=np.float64).reshape(1, 2))
        new, where = clear_of(np.vstack([here, rest]), avoid, radius_m)
        if len(new) == len(rest) + 1:
            return  # nothing in the way
        track = int(self.sensing_from[i]) - int(self.cursor[i])  # where the track starts in `rest`
        if track >= len(rest):
            self.set(i, new)
        else:  # on the track (`here` is on a leg of it), or on the way to it
            self.set(i, new, sensing_from=0 if track < 0 else int(where[track + 1]))

    def leg_starts(self, robots: np.ndarray, xy: np.ndarray) -> np.ndarray:
        """(k, 2) where each of `robots` (standing at `xy`) is along the leg it is driving: its
        closest point on the leg, or where it stands on a route's first waypoint (no leg yet)."""
        robots = np.asarray(robots, dtype=np.intp)
        out = np.array(xy, dtype=np.float64).reshape(-1, 2)
        _leg_starts(self.points, self.start[robots], self.end[robots], self.cursor[robots], out)
        return out

    def may_pass(self, robots: np.ndarray, xy: np.ndarray, point: np.ndarray, radius_m: float) -> np.ndarray:
        """Those of `robots` (standing at `xy`) whose rest of route might pass within `radius_m` of
        `point`: a leg's bounding box grown by 2 `radius_m` holds it. A superset of the robots
        `steer_clear` re-lays (its `clear_of` side-steps legs passing within a `radius_m` wide,
        `radius_m` overlong band, which lies within radius_m * sqrt(2) of the leg), found for all of
        them at once, so that only those need their own look."""
        cur, end = self.cursor[robots], self.end[robots]
        going = cur < end
        robots, xy, cur, end = robots[going], xy[going], cur[going], end[going]
        counts = end - cur
        if not len(robots):
            return robots
        first = np.cumsum(counts) - counts  # each robot's first leg in the flat list
        owner = np.repeat(np.arange(len(robots)), counts)
        to = np.arange(int(counts.sum())) - np.repeat(first, counts) + np.repeat(cur, counts)
        b = self.points.take(to, axis=0)
        a = self.points.take(np.maximum(to - 1, 0), axis=0)
        a[first] = self.leg_starts(robots, xy)  # each robot's first leg starts abreast of it
        reach = 2.0 * radius_m
        near = np.all(np.minimum(a, b) - reach <= point, axis=1)
        near &= np.all(np.maximum(a, b) + reach >= point, axis=1)
        return robots[np.unique(owner[near])]

    def clear(self, i: int) -> None:
        self.start[i] = self.end[i] = self.cursor[i] = self.sensing_from[i] = len(self.points)

    def done(self) -> np.ndarray:
        """(n,) True where the robot has passed its last waypoint (or has no route)."""
        return self.cursor >= self.end

    def remaining(self, i: int) -> np.ndarray:
        """The waypoints robot i still has to visit (k, 2)."""
        return self.points[self.cursor[i] : self.end[i]].copy()

    def remaining_track(self, i: int, xy: np.ndarray | None = None) -> np.ndarray:
        """What is left of robot i's search track `points[sensing_from:end]`: all of it until the
        robot is on it, then from where it stands on the leg it drives (`xy`; without it, from the
        leg's start) on. Taking the rest from the next waypoint dropped the leg the robot was on: a
        searcher of mine_clear lost on its first lane, 680 m long, left all of that lane to nobody.
        A route re-laid around a find on the track starts abreast of the robot, on the track."""
        cur, first, end = int(self.cursor[i]), int(self.sensing_from[i]), int(self.end[i])
        if cur >= end:  # driven to its end (or no track)
            return np.empty((0, 2))
        if cur <= first:
            return self.points[first:end].copy()
        if xy is None:
            return self.points[cur - 1 : end].copy()
        return np.vstack([np.asarray(xy, dtype=np.float64).reshape(1, 2), self.points[cur:end]])

    def remaining_m(self, robots: np.ndarray, xy: np.ndarray) -> np.ndarray:
        """(k,) how far each of `robots` (standing at `xy` (k, 2)) has still to drive along its
        route: from where it stands through the waypoints it still has to visit. Each the sum
        numpy's `np.hypot(legs[:, 0], legs[:, 1]).sum()` gives, float for float (`pairwise_sum`),
        in one compiled pass over the robots."""
        robots = np.asarray(robots, dtype=np.intp)
        out = np.empty(len(robots))
        _remaining_m(self.points, self.cursor, self.end, robots, np.ascontiguousarray(xy, np.float64), out)
        return out

    def in_track(self) -> np.ndarray:
        """(n,) True while the robot is on the search-track part of its route (its way to the
        track's first point included; a route without a track has `sensing_from` at its end). A
        route whose track starts at its first point counts too: a taker sent to a piece that starts
        where it stands used to count as off its track, and the route it resumed after a
        clearance as having none."""
        return (self.cursor >= self.sensing_from) & (self.cursor < self.end)

    def advance(self, xy: np.ndarray, mask: np.ndarray, afloat: np.ndarray | None = None) -> None:
        """Move the cursors of robots in `mask` past every waypoint they have reached (a few at
        most per step): within the capture radius of it, or past the end of its leg and close to
        the leg's line, or abeam of it at any distance where `afloat` (the final waypoint only by
        its radius; `swarm.robot.driving.advance_cursors`)."""
        afloat = np.zeros(len(xy), bool) if afloat is None else afloat
        advance_cursors(self.points, self.start, self.end, self.cursor, xy, mask, afloat)

    def steer_points(self, xy: np.ndarray, afloat: np.ndarray | None = None) -> np.ndarray:
        """(n, 2) where each robot steers: on its route, `LOOKAHEAD_M` ahead of its projection on
        its current leg, capped at the leg's end (the waypoint itself on a route's first point);
        done with its route, the route's last point, where it keeps station; without a route,
        its own position; where `afloat`, along the leg's line (`swarm.robot.driving.steer_point`).
        What the built-in controller steers for."""
        out = np.empty((len(xy), 2))
        afloat = np.zeros(len(xy), bool) if afloat is None else afloat
        steer_points(self.points, self.start, self.end, self.cursor, xy, afloat, out)
        return out

    def compact(self) -> None:
        """Drop the points no robot's route holds any more (replaced routes): a batch that resets
        its runs again and again (`swarm.sim.vector_env`) would otherwise grow without bound."""
        length = self.end - self.start
        base = np.concatenate([[0], np.cumsum(length)[:-1]]).astype(np.intp)
        keep = np.repeat(self.start - base, length) + np.arange(int(length.sum()))
        store = np.empty((max(256, 2 * len(keep)), 2))
        store[: len(keep)] = self._store[keep]
        shift = base - self.start
        self.cursor += shift
        self.sensing_from += shift
        self.start[:] = base
        self.end[:] = base + length
        self._store, self._used = store, len(keep)
        self.points = self._store[: self._used]

    def view(self, offset: int, n: int) -> RoutesView:
        """Robots offset .. offset + n - 1 as a `Routes` of their own (one run of a batch)."""
        return RoutesView(self, offset, n)

    def __setstate__(self, state: dict) -> None:
        """A copy's `points` a view of its own store again (pickle copies a view as an array)."""
        self.__dict__.update(state)
        self.points = self._store[: self._used]


class RoutesView:
    """One run's robots of a batch's `Routes`: the same methods, robot indices local to the run."""

    def __init__(self, routes: Routes, offset: int, n: int) -> None:
        self.base = routes
        self.offset = offset
        s = slice(offset, offset + n)
        self.start, self.end = routes.start[s], routes.end[s]
        self.cursor, self.sensing_from = routes.cursor[s], routes.sensing_from[s]

    @property
    def points(self) -> np.ndarray:
        return self.base.points

    def set(self, i: int, waypoints: np.ndarray, sensing_from: int | None = None) -> None:
        self.base.set(self.offset + i, waypoints, sensing_from)

    def steer_clear(self, i: int, xy: np.ndarray, avoid: np.ndarray, radius_m: float) -> None:
        self.base.steer_clear(self.offset + i, xy, avoid, radius_m)

    def clear(self, i: int) -> None:
        self.base.clear(self.offset + i)

    # the whole-array predicates read only the view's own cursor, sensing_from and end
    done = Routes.done
    in_track = Routes.in_track

    def remaining(self, i: int) -> np.ndarray:
        return self.base.remaining(self.offset + i)

    def remaining_track(self, i: int, xy: np.ndarray | None = None) -> np.ndarray:
        return self.base.remaining_track(self.offset + i, xy)

    def remaining_m(self, robots: np.ndarray, xy: np.ndarray) -> np.ndarray:
        return self.base.remaining_m(np.asarray(robots, dtype=np.intp) + self.offset, xy)


def clear_of(points: np.ndarray, avoid: np.ndarray, radius_m: float) -> tuple[np.ndarray, np.ndarray]:
    """`points` (a polyline) with a side-step around every point of `avoid` that a leg passes within
    `radius_m` of: two waypoints abreast of it, `radius_m` out on the leg's far side from it. Returns
    the new polyline and, for each original point, its index in it. Every leg is screened against
    every point at once; only the legs with something in the way are looped over."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    avoid = np.asarray(avoid, dtype=np.float64).reshape(-1, 2)
    if len(pts) < 2 or not len(avoid):
        return pts.copy(), np.arange(len(pts))
    a = pts[:-1]
    leg = pts[1:] - a
    length = np.hypot(leg[:, 0], leg[:, 1])
    moving = length > 1e-9
    if not moving.any():  # a robot told to stay where it stands (a retreat from safe ground)
        return pts.copy(), np.arange(len(pts))
    u = leg / np.where(moving, length, 1.0)[:, None]
    rel = avoid[None, :, :] - a[:, None, :]  # (legs, points, 2)
    along = rel[..., 0] * u[:, None, 0] + rel[..., 1] * u[:, None, 1]
    across = rel[..., 1] * u[:, None, 0] - rel[..., 0] * u[:, None, 1]
    near = moving[:, None] & (np.abs(across) < radius_m)
    near &= (along > -radius_m) & (along < length[:, None] + radius_m)
    per_leg = near.sum(axis=1)
    if not per_leg.any():
        return pts.copy(), np.arange(len(pts))
    where = np.concatenate([[0], np.cumsum(1 + 2 * per_leg)])
    out = np.empty((where[-1] + 1, 2))
    out[where] = pts
    for k in np.flatnonzero(per_leg):
        js = np.flatnonzero(near[k])
        js = js[np.argsort(along[k, js], kind="stable")]
        side = across[k, js] - np.where(across[k, js] >= 0, radius_m, -radius_m)
        s0 = np.clip(along[k, js] - radius_m, 0.0, length[k])
        s1 = np.clip(along[k, js] + radius_m, 0.0, length[k])
        normal = np.array([-u[k, 1], u[k, 0]])
        # a side-step that begins within the capture radius of the leg's start (a mine found just
        # ahead) is pushed out beyond it: captured at once, its first point was skipped and the
        # robot cut the corner from its heading straight at the mine onto it
        short = np.hypot(s0, side) < SIDESTEP_CLEAR_M
        out_m = np.sqrt(np.maximum(SIDESTEP_CLEAR_M**2 - s0**2, side**2))
        side = np.where(short, np.sign(side) * out_m, side)
        steps = np.empty((len(js), 2, 2))
        steps[:, 0] = a[k] + s0[:, None] * u[k] + side[:, None] * normal
        steps[:, 1] = a[k] + s1[:, None] * u[k] + side[:, None] * normal
        out[where[k] + 1 : where[k + 1]] = steps.reshape(-1, 2)
    return out, where


@numba.njit(cache=True, error_model="numpy")
def _leg_starts(points, start, end, cursor, xy):
    """`Routes.leg_starts`, robot by robot, in place on `xy`: each robot's closest point on its
    leg (`leg`), where it has one."""
    for i in range(xy.shape[0]):
        if cursor[i] >= end[i] or cursor[i] == start[i]:
            continue
        px, py, lx, ly, _, _, _ = leg(points, start[i], cursor[i], xy[i, 0], xy[i, 1])
        ll = lx * lx + ly * ly
        if ll > 0:
            t = minimum(maximum(((xy[i, 0] - px) * lx + (xy[i, 1] - py) * ly) / ll, 0.0), 1.0)
            xy[i, 0], xy[i, 1] = px + t * lx, py + t * ly


@numba.njit(cache=True, error_model="numpy")
def _remaining_m(points, cursor, end, robots, xy, out):
    """`Routes.remaining_m`: each robot's legs' lengths, then their sum as numpy sums them."""
    longest = 0
    for k in range(robots.shape[0]):
        longest = max(longest, end[robots[k]] - cursor[robots[k]])
    legs = np.empty(longest)
    for k in range(robots.shape[0]):
        i = robots[k]
        out[k] = rest_of_route_m(points, cursor[i], end[i], xy[k, 0], xy[k, 1], legs)


@numba.njit(cache=True, error_model="numpy", inline="always")
def rest_of_route_m(points, cur, end, x, y, legs):
    """How far a robot at (x, y) has still to drive through its route's points cur .. end - 1,
    as numpy sums the legs' lengths (`pairwise_sum`); `legs`: scratch of at least end - cur."""
    m = max(end - cur, 0)
    if m:
        legs[0] = np.hypot(points[cur, 0] - x, points[cur, 1] - y)
        for j in range(1, m):
            a, b = cur + j - 1, cur + j
            legs[j] = np.hypot(points[b, 0] - points[a, 0], points[b, 1] - points[a, 1])
    return 0.0 + pairwise_sum(legs, 0, m)


@numba.njit(cache=True, error_model="numpy")
def pairwise_sum(a, lo, n):
    """The sum of a[lo:lo + n] in numpy's order (`pairwise_sum` of its add reduction: blocks of up
    to 128 summed by `_block_sum`, halved above that), so a compiled pass adds up to the same
    float. The halving walks an explicit stack: numba's cache cannot hold a recursive function."""
    if n <= 128:
        return _block_sum(a, lo, n)
    frames = np.empty((192, 3), np.int64)  # (lo, n, halved already): depth 3 per halving, at most
    values = np.empty(64)
    frames[0, 0], frames[0, 1], frames[0, 2] = lo, n, 0
    top, held = 1, 0
    while top:
        top -= 1
        f_lo, f_n, halved = frames[top, 0], frames[top, 1], frames[top, 2]
        if f_n <= 128:
            values[held] = _block_sum(a, f_lo, f_n)
            held += 1
        elif halved:
            held -= 1
            values[held - 1] = values[held - 1] + values[held]  # the first half plus the second
        else:
            half = f_n // 2
            half -= half % 8
            frames[top, 2] = 1
            frames[top + 1, 0], frames[top + 1, 1], frames[top + 1, 2] = f_lo + half, f_n - half, 0
            frames[top + 2, 0], frames[top + 2, 1], frames[top + 2, 2] = f_lo, half, 0
            top += 3
    return values[0]


@numba.njit(cache=True, error_model="numpy", inline="always")
def _block_sum(a, lo, n):
    """numpy's sum of a block of up to 128: one by one under 8, else eight running sums."""
    if n < 8:
        res = 0.0
        for i in range(n):
            res += a[lo + i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    i = 8
    while i < n - n % 8:
        b = lo + i
        r0, r1, r2, r3 = r0 + a[b], r1 + a[b + 1], r2 + a[b + 2], r3 + a[b + 3]
        r4, r5, r6, r7 = r4 + a[b + 4], r5 + a[b + 5], r6 + a[b + 6], r7 + a[b + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[lo + i]
        i += 1
    return res
