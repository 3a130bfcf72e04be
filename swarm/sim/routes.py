"""Each robot's route as a waypoint list, followed by all robots at once.

Routes are ragged (a searcher's boustrophedon run has hundreds of points, a relay's a handful), so
they live in one growing flat array with a [start, end) slice and a cursor per robot; advancing
every cursor is a few vectorized passes. Replacing a robot's route appends the new points; the
old ones stay (routes are small next to the trajectories).
"""

from __future__ import annotations

import numpy as np

#: A waypoint counts as reached within this distance (m); the last one of a route, where the
#: robot stops, within `FINAL_CAPTURE_M` (inside the controller's stopping distance).
CAPTURE_M = 1.0
FINAL_CAPTURE_M = 0.3


class Routes:
    """Waypoint lists for n robots and how far along each robot is."""

    def __init__(self, n: int) -> None:
        self.points = np.empty((0, 2))
        self.start = np.zeros(n, dtype=np.intp)
        self.end = np.zeros(n, dtype=np.intp)
        self.cursor = np.zeros(n, dtype=np.intp)
        self.sensing_from = np.zeros(n, dtype=np.intp)  # searchers sense from this point index on

    def set(self, i: int, waypoints: np.ndarray, sensing_from: int | None = None) -> None:
        """Give robot i a new route (k, 2); `sensing_from`: index of the first search-track point."""
        pts = np.asarray(waypoints, dtype=np.float64).reshape(-1, 2)
        base = len(self.points)
        self.points = np.vstack([self.points, pts])
        self.start[i], self.end[i], self.cursor[i] = base, base + len(pts), base
        self.sensing_from[i] = base + (len(pts) if sensing_from is None else sensing_from)

    def clear(self, i: int) -> None:
        self.start[i] = self.end[i] = self.cursor[i] = self.sensing_from[i] = len(self.points)

    def done(self) -> np.ndarray:
        """(n,) True where the robot has passed its last waypoint (or has no route)."""
        return self.cursor >= self.end

    def remaining(self, i: int) -> np.ndarray:
        """The waypoints robot i still has to visit (k, 2)."""
        return self.points[self.cursor[i] : self.end[i]].copy()

    def remaining_track(self, i: int) -> np.ndarray:
        """What is left of robot i's search track (the part from `sensing_from`)."""
        return self.points[max(self.cursor[i], self.sensing_from[i]) : self.end[i]].copy()

    def in_track(self) -> np.ndarray:
        """(n,) True while the robot is on the search-track part of its route."""
        return (
            (self.cursor >= self.sensing_from) & (self.cursor < self.end) & (self.sensing_from > self.start)
        )

    def advance(self, xy: np.ndarray, mask: np.ndarray) -> None:
        """Move the cursors of robots in `mask` past every waypoint they have reached."""
        for _ in range(4):  # a robot passes at most a few waypoints per step
            live = mask & (self.cursor < self.end)
            if not live.any():
                return
            idx = np.flatnonzero(live)
            wp = self.points[self.cursor[idx]]
            radius = np.where(self.cursor[idx] == self.end[idx] - 1, FINAL_CAPTURE_M, CAPTURE_M)
            hit = np.hypot(*(wp - xy[idx]).T) < radius
            if not hit.any():
                return
            self.cursor[idx[hit]] += 1

    def targets(self, xy: np.ndarray) -> np.ndarray:
        """(n, 2) each robot's current waypoint (its own position when its route is done)."""
        out = xy.copy()
        live = self.cursor < self.end
        out[live] = self.points[self.cursor[live]]
        return out

    def progress(self) -> np.ndarray:
        """(n,) fraction of each route's waypoints passed (1 without a route)."""
        length = self.end - self.start
        return np.where(length > 0, (self.cursor - self.start) / np.maximum(length, 1), 1.0)
