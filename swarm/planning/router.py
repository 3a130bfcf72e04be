"""Routes over a cost map as the robots drive them: a plan's routes stitched around the blocked
ground they cross (the simulator's initial routes, and the exposure a plan's expected losses
count), and routes planned while the mission runs (a spare taking over a lost robot's task, the way
back to sea): a straight line where the cost map allows it, else an OMPL path with the fast profile.

Endpoints that fall on blocked cells (a robot pushed into the footprint margin, a target in the
water) are moved to the nearest free cell first, and the original target is appended when it is
in the water (the robot swims the last stretch) or on a brink (`CostMap.on_brink`: the robot
drives the last stretch, as it must to mark a mine laid there). Paths are seeded per call from the
router's seed and a counter, so a run replays exactly.
"""

from __future__ import annotations

import copy

import numpy as np
import shapely
from scipy import ndimage

from swarm.planning.costmap import NO_TRACTION, CostMap, PlanningError
from swarm.planning.paths import plan_path
from swarm.planning.profiles import DEFAULT_PROFILE, PlannerProfile

#: Paths planned for each route, the cheapest kept (`Router._cheapest`).
ATTEMPTS = 3
#: Seeds of a route's attempts lie this far apart (the calls' seeds count up by one).
SEED_STRIDE = 1_000_003
#: A blocked stretch of a leg is driven round along its edge when free ground is this close to
#: every point of it (m); farther, OMPL routes round it (`Router._around`).
HUG_M = 10.0
#: Most a straightened edge path may stray from the cell centres it joins (m).
STRAIGHTEN_M = 0.3


class Router:
    """Plans ground routes over one cost map during a run."""

    def __init__(self, cm: CostMap, seed: int, profile: PlannerProfile = DEFAULT_PROFILE) -> None:
        self.cm = cm
        self.profile = profile
        self.seed = seed
        self.calls = 0
        _, (self._near_r, self._near_c) = ndimage.distance_transform_edt(cm.blocked, return_indices=True)

    def fork(self) -> Router:
        """A router sharing this one's map tables, with its own call counter from 0: one run's
        replanning seeds, whatever other runs of a batch plan."""
        other = copy.copy(self)
        other.calls = 0
        return other

    def snap(self, xy: np.ndarray) -> np.ndarray:
        """(x, y) if a robot may stand there, else the centre of the nearest free cell."""
        x, y = float(xy[0]), float(xy[1])
        if self.cm.free_at(x, y):
            return np.array([x, y])
        r, c = (int(v) for v in self.cm.cell_of(x, y))
        r2, c2 = int(self._near_r[r, c]), int(self._near_c[r, c])
        return np.array([float(v) for v in self.cm.center_of(r2, c2)])

    def snap_many(self, xy: np.ndarray) -> np.ndarray:
        """`snap` of each point of `xy` (k, 2), in one pass."""
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        out = xy.copy()
        free = np.asarray(self.cm.is_free(xy[:, 0], xy[:, 1]), bool)
        if not free.all():
            r, c = self.cm.cell_of(xy[~free, 0], xy[~free, 1])
            x, y = self.cm.center_of(self._near_r[r, c], self._near_c[r, c])
            out[~free, 0], out[~free, 1] = x, y
        return out

    def reachable(self, xy: np.ndarray) -> np.ndarray:
        """A target a robot can get to: itself if free, open water (it swims there) or on a brink
        (it drives in), else the nearest free cell (a track point on a driftwood log, in a
        boulder's footprint margin)."""
        if self.cm.free_at(float(xy[0]), float(xy[1])):
            return np.array([float(xy[0]), float(xy[1])])
        return self.reachable_many(np.asarray(xy, dtype=np.float64).reshape(1, 2))[0]

    def reachable_many(self, xy: np.ndarray) -> np.ndarray:
        """`reachable` of each point of `xy` (k, 2), in one pass."""
        out = np.asarray(xy, dtype=np.float64).reshape(-1, 2).copy()
        r, c = self.cm.cell_of(out[:, 0], out[:, 1])
        # open water and the brink stay: the robot swims or drives the last stretch there
        move = (self.cm.reason[r, c] != NO_TRACTION) & ~self.cm.on_brink(out[:, 0], out[:, 1])
        out[move] = self.snap_many(out[move])
        return out

    def _cheapest(self, a: np.ndarray, b: np.ndarray, seed: int) -> np.ndarray:
        """The cheapest of `ATTEMPTS` paths from `a` to `b`, each seeded apart (a straight line if
        there is none). RRT-Connect's path, shortcut and smoothed, is feasible, not short: now and
        then it goes round the far side of something (relay: one return in six drove 384 m where
        the others drove 178-185 m), and the best of a few is rarely off."""
        best, cost = np.vstack([a, b]), np.inf  # no route on this map: head straight for it
        for k in range(ATTEMPTS):
            try:
                pts = plan_path(self.cm, a, b, self.profile, seed=seed + k * SEED_STRIDE).waypoints_m
            except PlanningError:
                continue
            c = self.cm.path_cost(pts)
            if c < cost:
                best, cost = pts, c
        return best

    def stitch(self, waypoints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """`waypoints` with every stretch of a leg that crosses blocked ground (a search track over a
        driftwood log, a boulder ring) replaced by a route around that stretch only. Returns the
        points and, for each original waypoint, its index in the result.

        Only the blocked stretch is detoured, from the last free point before it to the first free
        point after it: routing the whole leg instead would replace a 900 m search track by an
        OMPL path that wanders metres off the track the plan counted on sweeping."""
        pts = self.reachable_many(waypoints)
        if len(pts) < 2:
            return pts, np.arange(len(pts))
        free = self.cm.segments_free(pts[:-1], pts[1:])
        if bool(np.all(free)):
            return pts, np.arange(len(pts))
        out, where, last = [pts[:1]], [0], pts[0]
        for k in range(1, len(pts)):
            # a detour to where the robot already is (a repeated point on a brink) adds nothing
            step = pts[k : k + 1] if free[k - 1] else self._detour(last, pts[k])[1:]
            if len(step):
                out.append(step)
                last = step[-1]
            where.append(where[-1] + len(step))
        return np.vstack(out), np.array(where)

    def _detour(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Points from `a` to `b` along the straight leg, routed around each blocked stretch of it."""
        length = float(np.hypot(*(b - a)))
        step = 0.5 * self.cm.cell_m
        k = max(2, int(np.ceil(length / step)) + 1)
        samples = a + (b - a) * np.linspace(0.0, 1.0, k)[:, None]
        ok = self.cm.is_free(samples[:, 0], samples[:, 1])
        ok[0] = ok[-1] = True  # the ends are reachable points already
        out = [a[None]]
        i = 0
        while i < k - 1:
            j = i + 1
            if ok[j]:
                while j + 1 < k and ok[j + 1]:
                    j += 1
                out.append(samples[j : j + 1])
            else:
                while not ok[j]:
                    j += 1
                out.append(self._around(samples[i], samples[i + 1 : j], samples[j])[1:])
            i = j
        return _without_repeats(np.vstack(out))

    def _around(self, a: np.ndarray, blocked: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Points from free `a` to free `b` round the `blocked` points of a leg between them: along
        the blocked ground's edge when every one of them has free ground within `HUG_M` (the
        nearest free cell of each), so the robot sweeps the lane's free ground right up to the
        edge, where mines on the blocked side are found from; OMPL where the edge path jumps
        blocked ground (or the points lie deep inside it, a lagoon). An OMPL path round the whole
        stretch is feasible, not close: on full_conops' top lanes, which graze the vegetation's
        margin for tens of metres, it drove 1-4 m inside the free ground, and 100 runs found
        97.4% of the mines against the plan's 98.7% (98.2% along the edge)."""
        edge = self.snap_many(blocked)
        if float(np.max(np.hypot(*(edge - blocked).T))) > HUG_M:
            return self.route(a, b)
        pts = _without_repeats(np.vstack([a, edge, b]))
        free = self.cm.segments_free(pts[:-1], pts[1:])
        out = [pts[:1]]
        for k in range(1, len(pts)):
            out.append(pts[k : k + 1] if free[k - 1] else self._step(pts[k - 1], pts[k]))
        return _straightened(self.cm, np.vstack(out))

    def _step(self, p: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Points after `p` to `q` where the straight step clips blocked ground: round the corner
        of the cell between (a diagonal step along a stair of edge cells), else by `route`."""
        for corner in (np.array([p[0], q[1]]), np.array([q[0], p[1]])):
            if bool(np.all(self.cm.segments_free(np.vstack([p, corner]), np.vstack([corner, q])))):
                return np.vstack([corner, q])
        return self.route(p, q)[1:]

    def route(self, start: np.ndarray, goal: np.ndarray) -> np.ndarray:
        """Waypoints (k, 2) from `start` to `goal` (or to the nearest point of it a robot can reach)."""
        goal = self.reachable(np.asarray(goal, dtype=np.float64))
        a, b = self.snap(start), self.snap(goal)
        if bool(self.cm.segments_free(a[None], b[None])[0]):
            pts = np.vstack([a, b])
        else:
            self.calls += 1
            pts = self._cheapest(a, b, self.seed * 100_003 + self.calls)
        if np.hypot(*(pts[-1] - goal)) > 1e-6:
            pts = np.vstack([pts, goal])
        return pts


def _without_repeats(pts: np.ndarray) -> np.ndarray:
    """`pts` without a point that repeats the one before it (edge cells several samples share)."""
    keep = np.ones(len(pts), bool)
    keep[1:] = np.hypot(*np.diff(pts, axis=0).T) > 1e-9
    return pts[keep]


def _straightened(cm: CostMap, pts: np.ndarray) -> np.ndarray:
    """`pts` with the cell-centre staircase of an edge path straightened (Douglas-Peucker within
    `STRAIGHTEN_M`, shapely), where every straightened segment stays on free cells; else as given."""
    if len(pts) < 3:
        return pts
    simple = np.asarray(shapely.LineString(pts).simplify(STRAIGHTEN_M, preserve_topology=False).coords)
    if len(simple) >= 2 and bool(np.all(cm.segments_free(simple[:-1], simple[1:]))):
        return simple
    return pts
