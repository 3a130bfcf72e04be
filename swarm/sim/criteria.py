"""The mission's success criteria, measured as the simulation runs.

Each criterion of `swarm.mission.schema.Success` applies only when the mission has the task:

- landing: fraction of landing zones that at some moment held `robots_per_zone` live robots;
- detection: fraction of the real mines detected (1 when the field has none);
- relay: fraction of beach-operations time (from the first robot ashore to the end of beach
  operations) that the source reached every sink with `redundancy` node-disjoint paths;
- surveillance: fraction of observation points watched by `robots_per_point` robots for `dwell_s`
  in total;
- beacon: fraction of beacon points held by `robots_per_point` robots for `hold_s` (or, without it,
  at the end of beach operations);
- recovered: robots picked up (compared with `min_robots_recovered`).

`score()` is the mean over the criteria of min(1, value / target): the environment's team reward is
its change each step, so the rewards of an episode sum to the final score.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import shapely

from swarm.mission.plan import place_xy
from swarm.mission.schema import Mission

#: A robot watches an observation point, or holds a beacon point, within this distance (m).
STATION_RADIUS_M = 3.0


@dataclass
class _Stations:
    points_m: np.ndarray  # (k, 2)
    needed: int
    required_s: float | None  # dwell (surveillance) or hold time (beacon); None: held at the end
    watched_s: np.ndarray = field(default=None)  # type: ignore[assignment]
    held_now: np.ndarray = field(default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        self.watched_s = np.zeros(len(self.points_m))
        self.held_now = np.zeros(len(self.points_m), bool)

    def update(self, xy: np.ndarray, dt_s: float) -> None:
        if not len(xy) or not len(self.points_m):
            self.held_now[:] = False
            return
        d = np.hypot(xy[None, :, 0] - self.points_m[:, None, 0], xy[None, :, 1] - self.points_m[:, None, 1])
        self.held_now = (d <= STATION_RADIUS_M).sum(axis=1) >= self.needed
        self.watched_s += np.where(self.held_now, dt_s, 0.0)

    def fraction(self, at_end: bool) -> float:
        if not len(self.points_m):
            return 1.0
        if self.required_s is None:
            return float(self.held_now.mean()) if at_end else 0.0
        return float((self.watched_s >= self.required_s - 1e-9).mean())


class MissionScore:
    """Running values of the mission's success criteria."""

    def __init__(self, mission: Mission, relay_redundancy: int | None, n_mines: int) -> None:
        bm = mission.beach_map
        s = mission.success
        self.mission = mission
        self.zones = []
        for t in mission.tasks_of("landing"):
            for z in t.zones:
                geom = bm.regions[z].geometry
                shapely.prepare(geom)
                self.zones.append((geom, t.robots_per_zone))
        self.zone_reached = np.zeros(len(self.zones), bool)
        self.n_mines = n_mines
        self.has_search = bool(mission.tasks_of("search"))
        self.relay_redundancy = relay_redundancy
        self.relay_up_s = 0.0
        self.surveillance = [
            _Stations(np.array([place_xy(bm, p) for p in t.points]), t.robots_per_point, t.dwell_s)
            for t in mission.tasks_of("surveillance")
        ]
        self.beacons = [
            _Stations(np.array([place_xy(bm, p) for p in t.points]), t.robots_per_point, t.hold_s)
            for t in mission.tasks_of("beacon")
        ]
        self.targets = {
            "landing": s.min_landing_fraction,
            "detection": s.min_detection_fraction,
            "relay": s.min_relay_connected_fraction,
            "surveillance": s.min_surveillance_fraction,
            "beacon": s.min_beacon_fraction,
            "recovered": float(s.min_robots_recovered),
        }
        self.recovered = 0
        self.detected = 0
        self.beach_start_s: float | None = None
        self.beach_end_s = mission.beach_end_s
        self.at_end = False
        #: Without relay, surveillance or beacon criteria the score is a function of the counts
        #: alone, so `score()` keeps its last value with the counts it had.
        self._counts_only = relay_redundancy is None and not self.surveillance and not self.beacons
        #: Whether `update` has anything to do (zones to reach, time to count).
        self.timed = bool(self.zones) or not self._counts_only
        self._last: tuple[tuple[int, int, int], float] | None = None

    # updates -------------------------------------------------------------------------------------
    def update(self, t_s: float, dt_s: float, xy_ashore: np.ndarray, relay_up: bool | None) -> None:
        """One step: `xy_ashore` are the live robots on the beach, `relay_up` the relay's state."""
        in_ops = self.beach_start_s is not None and t_s <= self.beach_end_s + 1e-9
        if self.zones and len(xy_ashore):
            for k, (geom, needed) in enumerate(self.zones):
                if not self.zone_reached[k]:
                    inside = shapely.contains_xy(geom, xy_ashore[:, 0], xy_ashore[:, 1])
                    self.zone_reached[k] = int(inside.sum()) >= needed
        if in_ops:
            if relay_up:
                self.relay_up_s += dt_s
            for st in (*self.surveillance, *self.beacons):
                st.update(xy_ashore, dt_s)

    def zone_still_open(self, xy: np.ndarray) -> bool:
        """Whether a landing robot lost at its zone point `xy` leaves work undone: its zone has not
        yet held its robots (the criterion counts a zone once it has)."""
        for k, (geom, _) in enumerate(self.zones):
            if shapely.contains_xy(geom, float(xy[0]), float(xy[1])):
                return not bool(self.zone_reached[k])
        return True

    # values --------------------------------------------------------------------------------------
    def values(self) -> dict[str, float]:
        """Each applicable criterion's current value."""
        out: dict[str, float] = {}
        if self.zones:
            out["landing"] = float(self.zone_reached.mean())
        if self.has_search:
            out["detection"] = self.detected / self.n_mines if self.n_mines else 1.0
        if self.relay_redundancy is not None:
            start = self.beach_start_s if self.beach_start_s is not None else self.beach_end_s
            window = max(self.beach_end_s - start, 1e-9)
            out["relay"] = min(1.0, self.relay_up_s / window) if self.beach_start_s is not None else 0.0
        if self.surveillance:
            out["surveillance"] = float(np.mean([s.fraction(self.at_end) for s in self.surveillance]))
        if self.beacons:
            out["beacon"] = float(np.mean([s.fraction(self.at_end) for s in self.beacons]))
        if self.targets["recovered"] > 0:
            out["recovered"] = float(self.recovered)
        return out

    def score(self) -> float:
        if self._counts_only:
            counts = (self.detected, self.recovered, int(np.count_nonzero(self.zone_reached)))
            if self._last is None or self._last[0] != counts:
                self._last = (counts, self._score())
            return self._last[1]
        return self._score()

    def _score(self) -> float:
        vals = self.values()
        if not vals:
            return 0.0
        total = 0.0  # in order from 0, as numpy sums fewer than 8 numbers, without its call overhead
        for k, v in vals.items():
            total += 1.0 if self.targets[k] <= 0 else min(1.0, v / self.targets[k])
        return total / len(vals)

    def success(self) -> bool:
        """Whether every criterion is met now (`outcome()["success"]`, without building it)."""
        return all(v >= self.targets[k] - 1e-12 for k, v in self.values().items())

    def outcome(self) -> dict:
        """{criterion: {value, target, met}} and `success` (every criterion met)."""
        crit = {
            k: {"value": v, "target": self.targets[k], "met": bool(v >= self.targets[k] - 1e-12)}
            for k, v in self.values().items()
        }
        return {"success": all(c["met"] for c in crit.values()), "criteria": crit}
