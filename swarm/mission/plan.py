"""Building a `MissionPlan` from a loaded mission: who does what, by which route, arriving when.

```python
mission = load_mission("missions/landing.yaml")
plan = plan_mission(mission, seed=0)
write_plan(plan, "reports/landing")  # plan.json + plan.geojson
```

1. Launch. Robot i is released at launch point ``i mod n_points`` at ``i * launch.interval_s``;
   it swims `launch.release_offshore_m` to the launch point, then on to its *entry*: a plannable
   cell at the seaward edge of the ground it can drive on (deep water, and surf too steep for
   traction, are not ground: `CostMap.blocked`). The entry is the edge cell (free, next to
   blocked water) in the goal's connected region nearest the launch point, preferring, within
   `ENTRY_SLACK_M` of the nearest, the one that shortens the way to the goal.
2. Tasks become slots: each landing zone x robots_per_zone (points spread inside the zone), each
   relay position of `plan_relays`, each observation point and beacon x robots per point, then
   the searchers of each search task (``robots``, else the robots still free, shared among the
   search tasks that did not say), each starting at its share of the boustrophedon tracks
   (`split_tracks`). `assign` fills slots by straight-line distance from the launch points;
   robots left over are spares (they swim to their entry and wait there).
3. Ground routes: one OMPL path per robot from its entry to its slot, all planned seeded as
   `plan_many` plans them (the same per-pair seeds), with an optional progress callback.
4. ETA = release offset + swim (offshore + sea leg) at robot.swim_speed_mps + the path's
   terrain-speed time `PathResult.time_s`.

Nothing here draws from a global RNG or reads the clock: the same mission and seed give the same
plan, and `write_plan` the same bytes.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import shapely
import shapely.ops
from scipy import ndimage
from shapely.geometry import LineString, Polygon

from swarm.errors import SwarmError
from swarm.files import write_text_atomic
from swarm.mission import budget, exposure, surf_drive
from swarm.mission.schema import Mission
from swarm.mission.surf_speed import SurfZone
from swarm.planning import CostMap, PlanningError, build_costmap, detection
from swarm.planning.allocation import assign
from swarm.planning.batch import plan_many
from swarm.planning.coverage import boustrophedon, split_tracks, swath_coverage
from swarm.planning.detection import clip_tracks, drivable_segments
from swarm.planning.radio import RadioParams, comm_range_m, link_margin_db
from swarm.planning.relay import plan_relays, relayed_links, standable_grid
from swarm.planning.router import Router

#: Entry cells up to this much farther from the launch point than the nearest one may be chosen
#: to shorten the way to the goal, metres.
ENTRY_SLACK_M = 10.0
#: Search tracks keep this far from ground a robot cannot drive (m), beyond the footprint's own
#: inflation, and pieces of track shorter than `MIN_TRACK_M` are left out.
TRACK_MARGIN_M = 1.0
MIN_TRACK_M = 2.0
#: At most this many times the planner lays the tracks again at a tighter spacing to meet the
#: detection target (each time measures the expected detection of the tracks as laid).
MAX_TIGHTENINGS = 8
#: At most this many passes of the loss budget, each with the lost-track work and the marks done
#: as the pass before found them done; it stops once those shares move by at most
#: `DONE_TOLERANCE` (`_budget`).
BUDGET_PASSES = 6
DONE_TOLERANCE = 0.005
#: Decimal places of every float written to plan.json (1 mm; 1 ms).
ROUND = 3
ROLES = ("landing", "search", "relay", "surveillance", "beacon", "spare")

Progress = Callable[[int, int], None]


@dataclass
class RobotPlan:
    id: str
    role: str
    task: str | None
    launch_m: tuple[float, float]
    release_s: float
    sea_leg_m: np.ndarray  # (2, 2): launch point, entry
    ground_m: np.ndarray  # (k, 2) OMPL path from the entry to the goal (empty for spares)
    track_m: np.ndarray  # (t, 2) search tracks after the goal (searchers only)
    eta_s: float
    sea_time_s: float
    ground_time_s: float
    length_m: float

    @property
    def waypoints_m(self) -> np.ndarray:
        parts = [
            self.sea_leg_m[:1],
            self.ground_m if len(self.ground_m) else self.sea_leg_m[1:],
            self.track_m,
        ]
        return np.vstack([p.reshape(-1, 2) for p in parts])


@dataclass
class SearchPlan:
    task: str
    area: str
    area_m: list
    sweep_width_m: float
    spacing_m: float
    model: str
    tracks: list[list[LineString]]  # per searcher
    expected_detection: float
    swath_coverage: float
    area_m2: float
    #: the search design (`swarm.mission.budget.SearchDesign`) and what it should give after losses
    design: dict = field(default_factory=dict)

    def rings(self) -> list:
        """The area's outline as rings (`area_m` holds one ring, or a list of them for a
        multipolygon)."""
        return self.area_m if self.area_m and isinstance(self.area_m[0][0], list) else [self.area_m]

    def polygon(self):
        """The area as a shapely geometry (the rings' union)."""
        return shapely.union_all([Polygon(r) for r in self.rings() if len(r) >= 3])


@dataclass
class RelayPlanOut:
    task: str
    source_m: np.ndarray
    sinks_m: np.ndarray
    comm_range_m: float
    redundancy: int
    positions_m: np.ndarray
    edges: np.ndarray
    hop_lengths_m: np.ndarray
    radio: RadioParams | None = None  # the task's radio (robot antenna heights)
    fixed_height_m: float | None = None  # antenna height of the source and sinks

    @property
    def n_terminals(self) -> int:
        return 1 + len(self.sinks_m.reshape(-1, 2))

    def relay_hops_m(self) -> np.ndarray:
        """The lengths of the links with a relay robot at one end (not the terminals' direct links)."""
        return self.hop_lengths_m[relayed_links(self.edges, self.n_terminals)]

    @property
    def nodes_m(self) -> np.ndarray:
        """Every node `edges` index: the source, the sinks, then the relay robots."""
        return np.vstack(
            [self.source_m.reshape(1, 2), self.sinks_m.reshape(-1, 2), self.positions_m.reshape(-1, 2)]
        )

    def link_margins_db(self) -> np.ndarray | None:
        """Each edge's link margin (dB beyond sensitivity + fade margin), with the antenna heights the
        simulator uses: a robot's mast, or the source's for a source or sink end. None without a radio."""
        if self.radio is None or not len(self.edges):
            return None if self.radio is None else np.empty(0)
        fixed = self.n_terminals
        high = self.radio.tx_height_m if self.fixed_height_m is None else self.fixed_height_m
        out = []
        for (a, b), d in zip(self.edges, self.hop_lengths_m, strict=True):
            ha = high if a < fixed else self.radio.tx_height_m
            hb = high if b < fixed else self.radio.rx_height_m
            radio = dataclasses.replace(self.radio, tx_height_m=ha, rx_height_m=hb)
            out.append(float(link_margin_db(max(float(d), 1e-3), radio)))
        return np.array(out)


def detection_to_expect(search: dict) -> float:
    """What a run's share of a search's mines found should come to by the plan: its detection
    after the losses, or before them where the plan has no loss budget (a search's entry of the
    budget, or of the plan report's data: `expected_detection[_after_losses]`)."""
    after = search["expected_detection_after_losses"]
    return search["expected_detection"] if after is None else after


def success_chance(mission: Mission, plan: MissionPlan) -> float | None:
    """The plan's chance that a run meets every criterion it is judged by (`Mission.judged_by`),
    to set beside a study's success rate: its search's chance of meeting the detection criterion
    after its losses, where that is the only criterion. None where a run is also judged by a
    criterion the plan gives no chance for (landing, relay, surveillance, beacon, robots
    recovered), or by the mines of more than one search (the criterion pools them)."""
    if mission.judged_by != ["detection"]:
        return None
    searches = list((plan.budget.get("search") or {}).values())
    if len(searches) != 1:
        return None
    chance = searches[0].get("p_criterion_met_after_losses")
    return None if chance is None else float(chance)


@dataclass
class MissionPlan:
    mission: str
    map: str
    seed: int
    robots: list[RobotPlan]
    search: list[SearchPlan]
    relay: RelayPlanOut | None
    costmap: CostMap = field(repr=False)
    beach_map: object = field(repr=False)
    #: where the plan came from, so a report can find the map again: mission, map and terrain files
    source: dict = field(default_factory=dict)
    #: the mission's success criteria (`Success`), for the plan report's verdict
    criteria: dict = field(default_factory=dict)
    #: expected losses by phase and cause, and what the plan should achieve after them
    budget: dict = field(default_factory=dict)

    @property
    def expected_lost(self) -> float | None:
        """Robots the plan expects to lose (`budget`), None with the hazards off."""
        return float(self.budget["expected_lost"]) if self.budget.get("hazards") else None

    @property
    def expected_lost_by_cause(self) -> dict[str, float] | None:
        """Robots the plan expects to lose to each cause, over every phase (the way back too): the
        parts of `expected_lost`, as a study's runs count their losses; None with the hazards off."""
        if self.expected_lost is None:
            return None
        out: dict[str, float] = {}
        for causes in (self.budget.get("expected_losses") or {}).values():
            for cause, robots in causes.items():
                out[cause] = out.get(cause, 0.0) + float(robots)
        return out

    @property
    def expected_takeovers(self) -> float | None:
        """Lost robots' stations the plan expects its spares to take over a run (`budget`,
        `exposure.station_takeovers`); None with the hazards off, or from a plan before it."""
        if self.expected_lost is None or self.budget.get("station_takeovers") is None:
            return None
        return float(self.budget["station_takeovers"])

    @property
    def expected_detection(self) -> float | None:
        """The share of the mines the plan expects found after its losses (`budget`), over every
        search weighted by its expected mines (each search's own where none is expected), as a
        run's detection criterion counts them; None without a search."""
        found = self.budget.get("search") or {}
        values = [
            (detection_to_expect(d), s.design.get("mines_expected", 0.0))
            for s in self.search
            if (d := found.get(s.task)) is not None
        ]
        if not values:
            return None
        weights = np.array([w for _, w in values])
        if weights.sum() <= 0:
            weights = np.ones(len(values))
        return float(np.average([v for v, _ in values], weights=weights))

    @property
    def expected_recovered(self) -> tuple[float, float] | None:
        """Robots the plan expects back at sea (`budget`), at least and at most: the survivors
        less the markers the clearance expends (all the team can spare, or its reserves alone)
        and the losses on the way; None without a return to sea."""
        value = self.budget.get("expected_recovered")
        return None if value is None else (float(value[0]), float(value[1]))

    @property
    def expected_coverage(self) -> float | None:
        """Area-weighted expected detection fraction over the search tasks (None without search)."""
        if not self.search:
            return None
        total = sum(s.area_m2 for s in self.search)
        return sum(s.expected_detection * s.area_m2 for s in self.search) / total

    def summary(self) -> dict:
        roles = {r: sum(1 for b in self.robots if b.role == r) for r in ROLES}
        working = [b for b in self.robots if b.role != "spare"]
        return {
            "robots": len(self.robots),
            "roles": {k: v for k, v in roles.items() if v},
            # None where no robot has a station (all spares)
            "last_arrival_s": max((b.eta_s for b in working), default=None),
            "first_arrival_s": min((b.eta_s for b in working), default=None),
            "total_length_m": sum(b.length_m for b in self.robots),
            "relays": 0 if self.relay is None else len(self.relay.positions_m),
            "search_tracks_m": sum(sum(t.length for ts in s.tracks for t in ts) for s in self.search),
            "expected_coverage": self.expected_coverage,
        }

    @classmethod
    def from_dict(cls, d: dict, beach_map: object = None) -> MissionPlan:
        """The plan `as_dict` wrote (plan.json), for drawing and reports: routes, search tracks and
        the relay graph at plan.json's millimetre precision; no cost map."""
        robots = []
        for b in d["robots"]:
            sea = np.asarray(b["sea_leg_m"], dtype=float).reshape(-1, 2)
            ground = np.asarray(b["ground_m"], dtype=float).reshape(-1, 2)
            wp = np.asarray(b["waypoints_m"], dtype=float).reshape(-1, 2)
            track = wp[1 + (len(ground) if len(ground) else len(sea) - 1) :]
            robots.append(
                RobotPlan(
                    id=b["id"],
                    role=b["role"],
                    task=b.get("task"),
                    launch_m=(float(b["launch_m"][0]), float(b["launch_m"][1])),
                    release_s=float(b["release_s"]),
                    sea_leg_m=sea,
                    ground_m=ground,
                    track_m=track,
                    eta_s=float(b["eta_s"]),
                    sea_time_s=float(b["sea_time_s"]),
                    ground_time_s=float(b["ground_time_s"]),
                    length_m=float(b["length_m"]),
                )
            )
        search = []
        for s in d.get("search", []):
            sp = SearchPlan(
                task=s["task"],
                area=s.get("area", ""),
                area_m=s["area_m"],
                sweep_width_m=float(s["sweep_width_m"]),
                spacing_m=float(s["spacing_m"]),
                model=s["model"],
                tracks=[[LineString(t) for t in run if len(t) >= 2] for run in s.get("tracks_m", [])],
                expected_detection=float(s["expected_detection"]),
                swath_coverage=float(s["swath_coverage"]),
                area_m2=0.0,
                design=dict(s.get("design", {})),
            )
            sp.area_m2 = sum(Polygon(r).area for r in sp.rings() if len(r) >= 3)
            search.append(sp)
        relay = None
        if d.get("relay"):
            r = d["relay"]
            source = np.asarray(r["source_m"], dtype=float).reshape(2)
            sinks = np.asarray(r["sinks_m"], dtype=float).reshape(-1, 2)
            positions = np.asarray(r["positions_m"], dtype=float).reshape(-1, 2)
            edges = np.asarray(r["edges"], dtype=np.intp).reshape(-1, 2)
            nodes = np.vstack([source[None, :], sinks, positions])
            hops = np.hypot(*(nodes[edges[:, 0]] - nodes[edges[:, 1]]).T) if len(edges) else np.empty(0)
            radio = RadioParams(**r["radio"]) if r.get("radio") else None
            relay = RelayPlanOut(
                task=r["task"],
                source_m=source,
                sinks_m=sinks,
                comm_range_m=float(r["comm_range_m"]),
                redundancy=int(r["redundancy"]),
                positions_m=positions,
                edges=edges,
                hop_lengths_m=hops,
                radio=radio,
                fixed_height_m=r.get("fixed_height_m"),
            )
        return cls(
            mission=d["mission"],
            map=d["map"],
            seed=int(d["seed"]),
            robots=robots,
            search=search,
            relay=relay,
            costmap=None,  # type: ignore[arg-type]
            beach_map=beach_map,
            source=dict(d.get("source") or {}),
            criteria=dict(d.get("criteria") or {}),
            budget=dict(d.get("budget") or {}),
        )

    def as_dict(self) -> dict:
        relay = None
        if self.relay is not None:
            r = self.relay
            relay = {
                "task": r.task,
                "source_m": r.source_m.tolist(),
                "sinks_m": r.sinks_m.tolist(),
                "comm_range_m": r.comm_range_m,
                "redundancy": r.redundancy,
                "positions_m": r.positions_m.tolist(),
                "edges": r.edges.tolist(),
                # None with no relay (the terminals link directly)
                "max_hop_m": float(r.relay_hops_m().max()) if len(r.relay_hops_m()) else None,
            }
            margins = r.link_margins_db()
            if margins is not None:
                relay["link_margins_db"] = margins.tolist()
                relay["min_margin_db"] = float(margins.min()) if len(margins) else None
                relay["radio"] = dataclasses.asdict(r.radio)
                relay["fixed_height_m"] = r.fixed_height_m
        out = {
            "mission": self.mission,
            "map": self.map,
            "seed": self.seed,
            "robots": [
                {
                    "id": b.id,
                    "role": b.role,
                    "task": b.task,
                    "launch_m": list(b.launch_m),
                    "release_s": b.release_s,
                    "sea_leg_m": b.sea_leg_m.tolist(),
                    "ground_m": b.ground_m.tolist(),
                    "waypoints_m": b.waypoints_m.tolist(),
                    "eta_s": b.eta_s,
                    "sea_time_s": b.sea_time_s,
                    "ground_time_s": b.ground_time_s,
                    "length_m": b.length_m,
                }
                for b in self.robots
            ],
            "search": [
                {
                    "task": s.task,
                    "area": s.area,
                    "area_m": s.area_m,
                    "sweep_width_m": s.sweep_width_m,
                    "spacing_m": s.spacing_m,
                    "tracks_m": [[list(t.coords) for t in ts] for ts in s.tracks],
                    "model": s.model,
                    "expected_detection": s.expected_detection,
                    "swath_coverage": s.swath_coverage,
                    "design": s.design,
                }
                for s in self.search
            ],
            "relay": relay,
            "expected_coverage": self.expected_coverage,
            "summary": self.summary(),
        }
        if self.source:
            out["source"] = dict(self.source)
        if self.criteria:
            out["criteria"] = dict(self.criteria)
        if self.budget:
            out["budget"] = dict(self.budget)
        return _rounded(out)


def _rounded(value):
    if isinstance(value, float):
        r = round(value, ROUND)
        return 0.0 if r == 0 else r
    if isinstance(value, dict):
        return {k: _rounded(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_rounded(v) for v in value]
    if isinstance(value, np.floating):
        return _rounded(float(value))
    if isinstance(value, np.integer):
        return int(value)
    return value


# --- geometry helpers ------------------------------------------------------------------------------


def place_xy(beach_map, place) -> tuple[float, float]:
    """A mission `Place`: a region's point (a point region itself, else a point inside it) or [x, y]."""
    if isinstance(place, str):
        geom = beach_map.regions[place].geometry
        p = geom if geom.geom_type == "Point" else geom.representative_point()
        return float(p.x), float(p.y)
    return float(place[0]), float(place[1])


def pickup_points(mission: Mission, launch_m: np.ndarray) -> np.ndarray:
    """(k, 2) where survivors are picked up: the return's points, or the robots' launch points."""
    points = mission.phases.return_to_sea.points
    places = [place_xy(mission.beach_map, p) for p in points] if points else list(map(tuple, launch_m))
    return np.unique(np.array(places, dtype=np.float64).reshape(-1, 2), axis=0)


class _Free:
    """Free cells of the cost map, by connected region, with nearest-free-cell lookups."""

    def __init__(self, cm: CostMap, water_classes: np.ndarray) -> None:
        self.cm = cm
        free = ~cm.blocked
        _, (self.near_r, self.near_c) = ndimage.distance_transform_edt(~free, return_indices=True)
        rows, cols = np.nonzero(free)
        x, y = cm.center_of(rows, cols)
        self.xy = np.column_stack([x, y])
        self.comp = cm.component[rows, cols]
        # the seaward edge: free cells within the footprint inflation (and a cell) of blocked water
        water = cm.blocked & water_classes[cm.terrain.astype(np.intp)]
        reach = math.ceil(cm.inflation_m / cm.cell_m) + 1
        near_water = ndimage.binary_dilation(water, np.ones((3, 3), bool), iterations=reach)
        self.edge = near_water[rows, cols]

    def snap(self, xy: Sequence[float], component: int | None = None) -> np.ndarray:
        """(x, y) if a robot may stand there (in `component`), else the nearest free cell centre."""
        x, y = float(xy[0]), float(xy[1])
        cm = self.cm
        if bool(cm.is_free(x, y)):
            r, c = (int(v) for v in cm.cell_of(x, y))
            if component is None or cm.component[r, c] == component:
                return np.array([x, y])
        if component is None:
            r, c = (int(v) for v in cm.cell_of(x, y))
            r2, c2 = int(self.near_r[r, c]), int(self.near_c[r, c])
            return np.array([float(v) for v in cm.center_of(r2, c2)])
        pts = self.xy[self.comp == component]
        return pts[int(np.argmin(np.hypot(pts[:, 0] - x, pts[:, 1] - y)))].copy()

    def component_of(self, xy: np.ndarray) -> int:
        r, c = (int(v) for v in self.cm.cell_of(xy[0], xy[1]))
        return int(self.cm.component[r, c])

    def entry(self, launch: np.ndarray, goal: np.ndarray, component: int) -> np.ndarray:
        """The free cell of `component` where a robot swimming from `launch` comes ashore toward `goal`."""
        if bool(self.cm.is_free(*launch)) and self.component_of(launch) == component:
            return launch.copy()
        here = self.comp == component
        if (here & self.edge).any():
            here &= self.edge
        pts = self.xy[here]
        d_launch = np.hypot(pts[:, 0] - launch[0], pts[:, 1] - launch[1])
        near = d_launch <= d_launch.min() + ENTRY_SLACK_M
        score = np.where(near, d_launch + np.hypot(pts[:, 0] - goal[0], pts[:, 1] - goal[1]), np.inf)
        return pts[int(np.argmin(score))].copy()

    def spread(self, polygon, k: int, start: np.ndarray) -> list[np.ndarray]:
        """k free points inside `polygon`, far apart (farthest-point sampling from `start`)."""
        inside = shapely.contains_xy(polygon, self.xy[:, 0], self.xy[:, 1])
        pts = self.xy[inside]
        if not len(pts):
            return [self.snap(start) for _ in range(k)]
        first = pts[int(np.argmin(np.hypot(*(pts - start).T)))]
        chosen = [first]
        dist = np.hypot(*(pts - first).T)
        while len(chosen) < k:
            nxt = pts[int(np.argmax(dist))]
            chosen.append(nxt)
            dist = np.minimum(dist, np.hypot(*(pts - nxt).T))
        return [c.copy() for c in chosen]


@dataclass
class _Slot:
    role: str
    task: str
    goal: np.ndarray
    track: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))


def radio_params(radio, shadowing_sigma_db: float | None = None) -> RadioParams:
    """The planner's and simulator's radio model for a mission's `Radio` section."""
    extra = {} if shadowing_sigma_db is None else {"shadowing_sigma_db": shadowing_sigma_db}
    return RadioParams(
        **extra,
        frequency_hz=radio.frequency_hz,
        tx_power_dbm=radio.tx_power_dbm,
        tx_gain_dbi=radio.tx_gain_dbi,
        rx_gain_dbi=radio.rx_gain_dbi,
        tx_height_m=radio.antenna_height_m,
        rx_height_m=radio.antenna_height_m,
        sensitivity_dbm=radio.rx_sensitivity_dbm,
        fade_margin_db=radio.fade_margin_db,
    )


def _track_points(tracks: list[LineString]) -> np.ndarray:
    if not tracks:
        return np.empty((0, 2))
    return np.vstack([np.asarray(t.coords) for t in tracks])


# --- planning ---------------------------------------------------------------------------------------


def _slots(
    mission: Mission, free: _Free, launches: np.ndarray
) -> tuple[list[_Slot], list[SearchPlan], RelayPlanOut | None]:
    bm = mission.beach_map
    count = mission.swarm.count
    slots: list[_Slot] = []
    relay_out: RelayPlanOut | None = None
    for t, task in enumerate(mission.tasks):
        label = mission.task_label(t)
        if task.type == "landing":
            for zone in task.zones:
                geom = bm.regions[zone].geometry
                rep = np.array(place_xy(bm, zone))
                for p in free.spread(geom, task.robots_per_zone, rep):
                    slots.append(_Slot("landing", label, p))
        elif task.type == "relay":
            if relay_out is not None:
                raise SwarmError(f"plan: {label}: one relay task per mission is supported")
            radio = radio_params(task.radio)
            range_m = comm_range_m(radio)
            mast = task.radio.source_antenna_height_m
            source = np.array(place_xy(bm, task.source))
            sinks = np.array([place_xy(bm, s) for s in task.sinks])
            rp = plan_relays(
                source,
                sinks,
                range_m=range_m,
                # the source and sinks link each other on their own masts, as in the simulator
                terminal_range_m=comm_range_m(dataclasses.replace(radio, tx_height_m=mast, rx_height_m=mast)),
                grid=standable_grid(bm, mission.terrain_library),
                redundancy=task.redundancy,
            )
            relay_out = RelayPlanOut(
                label,
                source,
                sinks,
                range_m,
                task.redundancy,
                rp.positions_m,
                rp.edges,
                rp.hop_lengths_m,
                radio=radio,
                fixed_height_m=mast,
            )
            for p in rp.positions_m:
                slots.append(_Slot("relay", label, free.snap(p)))
        elif task.type in ("surveillance", "beacon"):
            for point in task.points:
                p = free.snap(place_xy(bm, point))
                slots.extend(_Slot(task.type, label, p.copy()) for _ in range(task.robots_per_point))

    searches = [(t, task) for t, task in enumerate(mission.tasks) if task.type == "search"]
    # the stations come first (each is a whole criterion); a search whose robots the rest cannot
    # give is designed for the robots there are (more slots than robots would leave some of its
    # tracks, or a station, unstaffed by the launch-to-slot assignment's distances)
    left = max(0, count - len(slots))
    given: dict[int, int] = {}
    for t, task in searches:
        if task.robots is not None:
            given[t] = min(task.robots, left - sum(given.values()))
    open_tasks = [t for t, task in searches if task.robots is None]
    share = max(0, left - sum(given.values()))
    search_out: list[SearchPlan] = []
    for t, task in searches:
        label = mission.task_label(t)
        if task.robots is not None:
            n = given[t]
        else:
            i = open_tasks.index(t)
            n = share // len(open_tasks) + (1 if i < share % len(open_tasks) else 0)
        n = max(n, 1)
        # robots never sweep inside a keep-out zone: search what is left of the area
        keep_out = [r.geometry for r in bm.regions_of_kind("keep_out")]
        polygon = bm.regions[task.area].geometry
        if keep_out:
            polygon = polygon.difference(shapely.union_all(keep_out))
        plan_out, search_slots = _plan_search(mission, task, label, polygon, n, free, launches)
        if task.robots is not None and n < task.robots:
            short = f"{n} of the {task.robots} robots asked: the rest hold the other tasks' stations"
            plan_out.design["note"] = "; ".join(filter(None, [short, plan_out.design.get("note", "")]))
        search_out.append(plan_out)
        slots.extend(search_slots)
    return slots, search_out, relay_out


def _plan_search(
    mission: Mission, task, label: str, polygon, n: int, free: _Free, launches: np.ndarray
) -> tuple[SearchPlan, list[_Slot]]:
    """Design one search for `n` robots (`swarm.mission.budget`), lay and split its tracks, and
    work out what they should find: the searchers' slots (each the start of its run) and the
    reserves' (spread over the area)."""
    cm = free.cm
    model = "random" if task.sensor.model == "random_search" else task.sensor.model
    width = task.sensor.width_m
    areas = budget.mine_areas(mission)
    mine_area = shapely.union_all(areas) if areas else polygon
    table = _lateral_range(task.sensor)
    speed = budget.search_speed_mps(mission, cm, polygon)
    start = _arrival_estimate_s(mission, launches, polygon)
    row_m = _row_length_m(polygon)
    dense = drivable_segments(boustrophedon(polygon, budget.MIN_SPACING_FRACTION * width), cm)
    reach = detection.expected_detection(mine_area, dense, model, width, table, ground=cm)
    fractions = _class_fractions(cm, polygon)
    approach = float(shapely.distance(shapely.Point(*launches.mean(axis=0)), polygon))
    swim = _swim_times(mission, cm, launches, polygon)

    def found_before(spacing: float) -> float:
        return budget.found_by_lanes_before(model, width, spacing, task.sensor.lateral_range)

    def typical_losses(spacing: float, searchers: int) -> dict:
        run_m = polygon.area / spacing / max(searchers, 1) + approach
        window = budget.search_window_s(mission, task, start)
        sea_s, surf_s, per_hit, timeout = swim
        exposed = budget.Exposure(
            sea_s=sea_s,
            surf_s=surf_s,
            beach_s=max(window[1] - start, 0.0),
            driven_m={c: f * run_m for c, f in fractions.items()},
            in_mine_area_m=(run_m - approach) * (1.0 - found_before(spacing)),
            breaker_hazard=per_hit,
            speed_mps=speed,
            surf_timeout=timeout,
        )
        return budget.robot_losses(mission, cm, exposed)

    design = budget.design_search(
        mission,
        task,
        robots=n,
        area_m2=polygon.area,
        speed_mps=speed,
        start_s=start,
        loss_before_end=budget.lost_probability(typical_losses(width, n)),
        reach=reach,
        row_m=row_m,
    )
    # driving losses depend on the spacing: design once more with the spacing now known
    design = budget.design_search(
        mission,
        task,
        robots=n,
        area_m2=polygon.area,
        speed_mps=speed,
        start_s=start,
        loss_before_end=budget.lost_probability(typical_losses(design.spacing_m, design.searchers)),
        reach=reach,
        row_m=row_m,
    )
    spacing: float | None = design.spacing_m
    before: tuple[float, float] | None = None
    for _ in range(MAX_TIGHTENINGS):
        if spacing is None:
            break
        design.staff(polygon.area, spacing)
        tracks = clip_tracks(boustrophedon(polygon, spacing), cm, TRACK_MARGIN_M, MIN_TRACK_M)
        runs = [r for r in split_tracks(tracks, design.searchers) if r]
        driven = [LineString(_track_points(r)) for r in runs if len(_track_points(r)) >= 2]
        expected = detection.expected_detection(
            mine_area, drivable_segments(driven, cm), model, width, table, ground=cm
        )
        laid = (spacing, expected)
        spacing = design.tighten(model, width, spacing, expected, before, task.sensor.lateral_range)
        before = laid
    spacing = design.spacing_m
    run_s = design.run_time_s(polygon.area, spacing)
    design_out = dataclasses.asdict(design)
    design_out.update(
        spacing_m=spacing,
        search_time_s=run_s,
        nominal_detection=budget.nominal_detection(model, width, spacing, task.sensor.lateral_range),
        reachable_detection=reach,
        p_criterion_met=budget.p_criterion_met(
            mission.success.min_detection_fraction,
            design.mines_expected,
            expected,
            poisson=budget.mine_count_is_random(mission),
        ),
    )
    out = SearchPlan(
        task=label,
        area=task.area,
        area_m=_outline(polygon),
        sweep_width_m=width,
        spacing_m=spacing,
        model=task.sensor.model,
        tracks=runs,
        expected_detection=expected,
        swath_coverage=swath_coverage(polygon, tracks, width),
        area_m2=polygon.area,
        design=design_out,
    )
    slots = [_Slot("search", label, free.snap(_track_points(r)[0]), _track_points(r)) for r in runs]
    if design.reserves:
        centre = np.array(polygon.representative_point().coords[0])
        slots.extend(_Slot("spare", label, p) for p in free.spread(polygon, design.reserves, centre))
    return out, slots


def _row_length_m(polygon) -> float:
    """A boustrophedon's lane length over `polygon`: the long side of its minimum rotated rectangle
    (the lanes run along it)."""
    rect = shapely.minimum_rotated_rectangle(polygon)
    corners = np.asarray(rect.exterior.coords) if rect.geom_type == "Polygon" else np.zeros((2, 2))
    return float(np.hypot(*np.diff(corners, axis=0).T).max())


def _lanes_per_searcher(search: SearchPlan) -> float:
    """How many lanes a searcher's band holds: its tracks' mean length over the lane length."""
    lengths = [sum(line.length for line in run) for run in search.tracks if run]
    row = _row_length_m(search.polygon())
    return float(np.mean(lengths)) / row if lengths and row > 0 else 1.0


def _lateral_range(sensor):
    """The sensor's tabulated lateral-range curve as p(d), or None (the model's own curve)."""
    curve = sensor.lateral_range
    return None if curve is None else detection.LateralRangeCurve.of(curve)


def _class_fractions(cm: CostMap, polygon) -> dict[str, float]:
    """Share of the free ground of `polygon` on each terrain class."""
    rows, cols = np.nonzero(~cm.blocked)
    x, y = cm.center_of(rows, cols)
    inside = shapely.contains_xy(polygon, x, y)
    cls = cm.terrain[rows[inside], cols[inside]].astype(np.intp)
    if not len(cls):
        return {}
    counts = np.bincount(cls, minlength=len(cm.terrain_classes)) / len(cls)
    return {cm.terrain_classes[c]: float(v) for c, v in enumerate(counts) if v > 0}


def _swim_times(
    mission: Mission, cm: CostMap, launches: np.ndarray, polygon
) -> tuple[float, float, float, float]:
    """A robot's time at sea (at swim speed) and in the surf on its way from a launch point
    straight toward `polygon`, one breaker's hazard on the way and the chance it times out in the
    surf, as `budget.Exposure` counts them, over the launch points: the way in driven by the
    simulator's rules (`surf_drive.drive_in`, `exposure.surf_terms`)."""
    swim = mission.robot.swim_speed_mps
    zone = SurfZone(mission, cm)
    sea, lines = [], []
    for p in launches:
        q = np.array(shapely.ops.nearest_points(polygon, shapely.Point(*p))[0].coords[0])
        by_class, _ = budget.driven_by_class(cm, np.vstack([p, q]), None)
        crossing = zone.crossing(np.vstack([p, q]))
        water_m = sum(v for c, v in by_class.items() if mission.terrain_library[c].is_water)
        sea.append((mission.launch.release_offshore_m + max(water_m - crossing.metres, 0.0)) / swim)
        lines.append(np.vstack([p, q]))
    drives = surf_drive.drive_in(mission, zone, lines)
    every = surf_drive.WayIn(*(np.concatenate(parts) for parts in zip(*drives, strict=True)))
    surf_s, per_hit, timeout = exposure.surf_terms(every, mission.hazards.surf.wave_period_s)
    return float(np.mean(sea)), surf_s, per_hit, timeout


def _arrival_estimate_s(mission: Mission, launches: np.ndarray, polygon) -> float:
    """When the last robot could be at the search area: its release, and the swim to the launch
    point and on to the area's edge."""
    last = (mission.swarm.count - 1) * mission.launch.interval_s
    d = max(float(shapely.distance(shapely.Point(*p), polygon)) for p in launches)
    swim = mission.robot.swim_speed_mps
    return last + (mission.launch.release_offshore_m + d) / swim


def _outline(polygon) -> list:
    """Exterior ring coordinates of a polygon, or a list of rings for a multipolygon."""
    if polygon.geom_type == "Polygon":
        return [list(c) for c in polygon.exterior.coords]
    return [[list(c) for c in part.exterior.coords] for part in polygon.geoms]


def _plan_routes(cm, pairs: np.ndarray, profile, seed: int, workers: int | None, progress: Progress | None):
    """Every robot's ground route: `plan_many` with the mission's seed (per-pair seeds from it)."""
    if len(pairs) == 0:
        return []
    return plan_many(cm, pairs, profile, seed=seed, workers=workers, progress=progress, label="robot route")


def plan_mission(
    mission: Mission,
    *,
    seed: int = 0,
    progress: Progress | None = None,
    workers: int | None = None,
) -> MissionPlan:
    """Allocate the mission's tasks to its robots and plan every route (module docstring).

    `progress(done, total)` is called as ground routes finish. `workers`: planning processes
    (default: the CPU count; 1 plans in this process). Raises `SwarmError` subclasses."""
    bm = mission.beach_map
    cm = build_costmap(bm, mission.robot_params, mission.terrain_library)
    lib = mission.terrain_library
    water = np.array([lib[c].is_water for c in bm.terrain_classes], dtype=bool)
    free = _Free(cm, water)
    if not len(free.xy):
        raise SwarmError(f"plan: no ground on map '{bm.name}' a robot can drive on")
    points = mission.launch.points
    if points is None:
        launches = [place_xy(bm, r.name) for r in bm.regions_of_kind("launch")]
    else:
        launches = [place_xy(bm, p) for p in points]
    slots, searches, relay = _slots(mission, free, np.array(launches, dtype=np.float64))
    n = mission.swarm.count
    launch = np.array([launches[i % len(launches)] for i in range(n)])

    if slots:
        goals = np.array([s.goal for s in slots])
        cost = np.hypot(launch[:, None, 0] - goals[None, :, 0], launch[:, None, 1] - goals[None, :, 1])
        # ties (robots sharing a launch point): earlier robots take the nearer slots
        cost = cost + np.arange(n)[:, None] * 1e-9 * np.arange(len(slots))[None, :]
        who = assign(cost)
    else:
        who = np.full(n, -1)

    # a spare waits at the entry nearest its launch point, on the largest ground region
    sizes = np.bincount(free.comp)
    main_comp = int(np.argmax(sizes))
    entries, goal_pts, routed = [], [], []
    for i in range(n):
        if who[i] >= 0:
            goal = slots[who[i]].goal
            comp = free.component_of(goal)
        else:
            goal, comp = launch[i], main_comp
        entry = free.entry(launch[i], goal, comp)
        entries.append(entry)
        goal_pts.append(goal)
        if who[i] >= 0:
            routed.append(i)
    pairs = np.array([[entries[i], goal_pts[i]] for i in routed]).reshape(-1, 2, 2)
    try:
        results = _plan_routes(cm, pairs, mission.planner_profile, seed, workers, progress)
    except PlanningError as exc:
        raise SwarmError(f"plan: {mission.name}: {exc}") from None
    by_robot = dict(zip(routed, results, strict=True))

    swim = mission.robot.swim_speed_mps
    offshore = mission.launch.release_offshore_m
    interval = mission.launch.interval_s
    robots: list[RobotPlan] = []
    for i in range(n):
        slot = slots[who[i]] if who[i] >= 0 else None
        sea = np.array([launch[i], entries[i]])
        sea_len = float(np.hypot(*(sea[1] - sea[0])))
        sea_time = (offshore + sea_len) / swim
        res = by_robot.get(i)
        ground = res.waypoints_m if res is not None else np.empty((0, 2))
        ground_time = res.time_s if res is not None else 0.0
        track = slot.track[1:] if slot is not None and len(slot.track) else np.empty((0, 2))
        if slot is not None and len(slot.track):
            track = (
                np.vstack([slot.track[:1], track]) if not np.allclose(ground[-1], slot.track[0]) else track
            )
        rp = RobotPlan(
            id=f"robot_{i}",
            role=slot.role if slot is not None else "spare",
            task=slot.task if slot is not None else None,
            launch_m=(float(launch[i, 0]), float(launch[i, 1])),
            release_s=i * interval,
            sea_leg_m=sea,
            ground_m=ground,
            track_m=track,
            eta_s=i * interval + sea_time + ground_time,
            sea_time_s=sea_time,
            ground_time_s=ground_time,
            length_m=0.0,
        )
        wp = rp.waypoints_m
        rp.length_m = offshore + float(np.hypot(*np.diff(wp, axis=0).T).sum()) if len(wp) > 1 else offshore
        robots.append(rp)
    name = mission.name or "mission"
    plan = MissionPlan(
        name, bm.name, seed, robots, searches, relay, cm, bm, _source(mission), mission.success.model_dump()
    )
    plan.budget = _budget(mission, plan)
    plan.budget["stations"] = _station_times(mission, robots, slots, who)
    return plan


def _station_times(mission: Mission, robots: list[RobotPlan], slots: list, who: np.ndarray) -> dict:
    """Each timed station task's points (a surveillance's dwell, a beacon's hold): the time its
    `robots_per_point` robots are planned to be there (None: never), the time required, and when
    beach operations end, the simulator's last moment to count it (`swarm.sim.criteria`). recon at
    a 1800 s limit planned a 1800 s dwell from 24 s on; every run failed it."""
    out = {}
    for t, task in enumerate(mission.tasks):
        required = getattr(task, "dwell_s" if task.type == "surveillance" else "hold_s", None)
        if task.type not in ("surveillance", "beacon") or required is None:
            continue
        label = mission.task_label(t)
        mine = [j for j, slot in enumerate(slots) if slot.role == task.type and slot.task == label]
        k = task.robots_per_point
        etas: list[list[float]] = [[] for _ in task.points]  # `_slots` lays k slots a point, in order
        for rp, j in zip(robots, who, strict=True):
            if j in mine:
                etas[mine.index(j) // k].append(rp.eta_s)
        out[label] = {
            "kind": "dwell" if task.type == "surveillance" else "hold",
            "required_s": float(required),
            "end_s": float(mission.beach_end_s),
            "arrivals_s": [sorted(e)[k - 1] if len(e) >= k else None for e in etas],
        }
    return out


def _budget(mission: Mission, plan: MissionPlan) -> dict:
    """Expected losses by phase and cause over the planned routes, and each search's expected
    detection once the routes into the area are counted too and after the losses
    (`swarm.mission.budget`).

    The lost searchers' tracks and the marks are driven only as far as the survivors get them done
    in time: a first pass counts all of that work, and while the work it leaves undone changes,
    the next counts what the pass before says gets done (`BUDGET_PASSES`). mine_clear at 15 robots
    planned 13.2 km of driving beyond the routes where 16 runs drove 7.9 km, and lost 3.18 robots
    to getting stuck where 100 runs lost 2.70."""
    cm = plan.costmap
    areas = budget.mine_areas(mission)
    mine_area = shapely.union_all(areas) if areas else None
    by_task = {s.task: s for s in plan.search}
    zone = SurfZone(mission, cm)
    ashore = exposure.nearest_ashore(mission, cm, zone.heights > 0)
    # the routes as the robots drive them: stitched around blocked ground, with the simulator's seed
    router = Router(cm, seed=mission.seed)
    driven = dataclasses.replace(plan, robots=[exposure.drivable(rp, router) for rp in plan.robots])
    way_out = None
    if mission.phases.return_to_sea.enabled:
        launches = np.array([rp.launch_m for rp in plan.robots])
        way_out = exposure.WayOut(mission, cm, pickup_points(mission, launches))
    ways = exposure.ways_in(mission, cm, driven.robots, zone, ashore, mine_area, by_task)
    seen = _routes_detection(mission, plan, mine_area)
    back_from = None
    if way_out is not None:  # on routes of their own: the plan's other ways back stay as they were
        back_from = functools.partial(
            exposure.way_back, mission, cm, way_out=way_out, router=router.fork(), zone=zone
        )
    takeovers = exposure.station_takeovers(mission, cm, driven, ways, router, mine_area, back_from)
    done: dict[str, tuple[float, float]] = {}
    for _ in range(BUDGET_PASSES):
        out, now = _budget_pass(
            mission, plan, driven, ways, takeovers, way_out, router, zone, mine_area, seen, done
        )
        moved = [np.abs(np.subtract(shares, done.get(t, (1.0, 1.0)))).max() for t, shares in now.items()]
        if max(moved, default=0.0) <= DONE_TOLERANCE:
            break
        done = now
    return out


def _routes_detection(mission: Mission, plan: MissionPlan, mine_area: shapely.Geometry | None) -> dict:
    """Each search's expected detection with every robot's planned route across the mine area
    counted too: every robot's sensor is on ashore, so landers', spares' and observers' routes
    search as well (the trips off the plan count in the budget, after the losses). None of a
    search without routes or mine area."""
    lines = [
        LineString(w)
        for rp in plan.robots
        if len(w := np.vstack([rp.ground_m.reshape(-1, 2), rp.track_m])) >= 2
    ]
    if not lines or mine_area is None:
        return {}
    cm = plan.costmap
    segments = drivable_segments(lines, cm)
    out = {}
    for s in plan.search:
        task = exposure.task_of(mission, s)
        model = "random" if s.model == "random_search" else s.model
        out[s.task] = detection.expected_detection(
            mine_area, segments, model, s.sweep_width_m, _lateral_range(task.sensor), ground=cm
        )
    return out


def _budget_pass(
    mission: Mission,
    plan: MissionPlan,
    driven: MissionPlan,
    ways: list[exposure.WayIn],
    takeovers: exposure.Takeovers,
    way_out: exposure.WayOut | None,
    router: Router,
    zone: SurfZone,
    mine_area: shapely.Geometry | None,
    seen: dict[str, float],
    done: dict[str, tuple[float, float]],
) -> tuple[dict, dict[str, tuple[float, float]]]:
    """One pass of `_budget` with the takers driving the shares `done` of their work
    (`exposure.off_plan_driving`), each search's detection that of the planned routes `seen`
    (`_routes_detection`, set after the takers' driving, which counts the tracks' own); returns
    the budget and each search's shares of it done by its losses: the lost-track work's, and the
    chance its marks are made."""
    cm = plan.costmap
    per_phase: dict[str, dict[str, float]] = {p: {} for p in budget.PHASE_NAMES}
    back = mission.phases.return_to_sea
    way_back: dict[str, float] = {}
    returning = 0.0  # robots expected to last the beach: who sets off back, but for the markers
    lost_by_task: dict[str, float] = {}
    lasting: dict[str, list[float]] = {}  # each search team's robots' chances of lasting beach operations
    reserves_lasting: dict[str, list[float]] = {}  # the same of its reserves alone
    orphaned_s: dict[str, float] = {}  # search time lost searchers leave undone
    need_s: dict[str, float] = {}  # the searchers' own tracks' drive time, every searcher's
    lost_run_s: dict[str, float] = {}  # the searchers' run time, each weighted by its chance of loss
    lost_left_s: dict[str, float] = {}  # of which the lost searchers leave undriven
    spare_s: dict[str, float] = {}  # time the others have for it: reserves, searchers done early
    swing_s2: dict[str, float] = {}  # the variance of the difference, robot by robot
    pool_s, pool_s2 = 0.0, 0.0  # the mission's spares' time for any search, and its variance
    unseen_blasts = 0.0  # mines expected to go off before any sensor found them
    holders: list[float] = []  # the relay and spare robots' shares of the window ashore
    extra, trips_m = exposure.off_plan_driving(mission, cm, driven, ways, done)
    for rp, way, more, taking, stations in zip(
        driven.robots, ways, extra, takeovers.driving, takeovers.returns, strict=True
    ):
        exposed = more.plus(taking).added_to(way.exposure)
        losses = budget.robot_losses(mission, cm, exposed)
        whole = exposure.losses_to_the_end(mission, cm, way, exposed)
        expected = budget.expected_by_cause(whole)
        for phase, causes in expected.items():
            for cause, p in causes.items():
                per_phase[phase][cause] = per_phase[phase].get(cause, 0.0) + p
        still = 1.0 - budget.lost_probability(whole)
        if back.enabled:
            returning += still
            home = exposure.way_back(mission, cm, way.last_m, way_out, router, zone)
            # from its own spot, or from the stations it has taken over
            held = sum(chance for chance, _ in stations)
            for chance, start in [(1.0 - held, home), *stations]:
                for cause, p in budget.return_losses(mission, cm, start).items():
                    way_back[cause] = way_back.get(cause, 0.0) + still * chance * p
        unseen_blasts += expected["beach"].get("mine", 0.0) * budget.unseen_share(
            mission, exposed.speed_mps, budget.main_ground(mission, exposed)
        )
        if rp.role in ("relay", "spare"):  # a spare takes a lost relay's position (`swarm.sim.policy`)
            holders.append(budget.time_ashore(whole))
        if way.search is not None:
            lost = budget.lost_probability(losses)
            task = way.search.task
            lost_by_task[task] = lost_by_task.get(task, 0.0) + lost
            lasting.setdefault(task, []).append(still)
            if rp.role != "search":
                reserves_lasting.setdefault(task, []).append(still)
            # the takeovers run into the window's slack (`budget.takeover_end_s`) and on after
            # the blast (`budget.takeover_s`), from when the robot is ashore at its track or spot
            # (`exposure.at_work_s`)
            span = budget.takeover_s(mission, exposure.task_of(mission, way.search), way.at_work_s)
            if rp.role == "search":  # its track left undone if it is lost, its slack if it is not
                run_s = way.track_s  # its own track as driven (`exposure.track_drive_s`)
                need_s[task] = need_s.get(task, 0.0) + run_s
                left = exposure.track_left(mission, cm, way, losses)
                slack = max(span - run_s, 0.0)
                # a searcher that lasts but lands too late to drive all of its track leaves the rest
                cut = max(run_s - span, 0.0)
                orphaned_s[task] = orphaned_s.get(task, 0.0) + left * run_s + (1.0 - lost) * cut
                lost_run_s[task] = lost_run_s.get(task, 0.0) + lost * run_s
                lost_left_s[task] = lost_left_s.get(task, 0.0) + left * run_s
                spare_s[task] = spare_s.get(task, 0.0) + (1.0 - lost) * slack
                swing = (left / lost * run_s if lost > 0 else 0.0) + slack - cut  # lost against not
            else:  # a reserve, while it lasts
                spare_s[task] = spare_s.get(task, 0.0) + span * budget.time_ashore(losses)
                swing = span / 2.0
            swing_s2[task] = swing_s2.get(task, 0.0) + lost * (1.0 - lost) * swing**2
        elif plan.search and rp.role in ("spare", "relay", "surveillance", "beacon"):
            # the scripted policy sends the mission's spares to lost stations first, then to lost
            # tracks; a lost station takes one of them from about halfway on
            lost = budget.lost_probability(losses)
            span = min(
                budget.takeover_s(mission, exposure.task_of(mission, s), way.at_work_s) for s in plan.search
            )
            pool_s += span * budget.time_ashore(losses) if rp.role == "spare" else -lost * span / 2.0
            pool_s2 += lost * (1.0 - lost) * (span / 2.0) ** 2
    # the spares' time goes to the searches in proportion to the work their losses leave
    orphaned_total = sum(orphaned_s.values())
    for task, left_s in orphaned_s.items():
        share = left_s / orphaned_total if orphaned_total > 0 else 1.0 / len(orphaned_s)
        spare_s[task] = spare_s.get(task, 0.0) + share * pool_s
        swing_s2[task] = swing_s2.get(task, 0.0) + share**2 * pool_s2
    criterion = mission.success.min_detection_fraction
    searches = {}
    got_done: dict[str, tuple[float, float]] = {}
    expended_after: dict[str, float] = {}  # losses by the clock the markers would have had after the blast
    markers = [0.0, 0.0]  # robots the clearances expend: at least, at most
    for s in plan.search:
        if s.task in seen:
            s.expected_detection = seen[s.task]
        task = exposure.task_of(mission, s)
        model = "random" if s.model == "random_search" else s.model
        need = need_s.get(s.task, 0.0)
        # the work left over in a run, not in the mean run: losses vary from run to run; the
        # drives to the lost tracks' pieces take their time out of the slack
        trips = trips_m.get(s.task, exposure.Trips(0.0, 0.0))
        travel_s = trips.to_pieces_m / mission.robot.wheel_speed_mps
        left_over = orphaned_s.get(s.task, 0.0) + travel_s - spare_s.get(s.task, 0.0)
        left_over_sd = math.sqrt(swing_s2.get(s.task, 0.0))
        undone = budget.expected_excess(left_over, left_over_sd)
        # nobody marks while a piece of lost track is open: the marks are made in the runs whose
        # lost tracks are all taken over (`budget.p_no_excess`)
        marking = budget.p_no_excess(left_over, left_over_sd)
        work_s = orphaned_s.get(s.task, 0.0) + travel_s
        got_done[s.task] = (1.0 - min(undone / work_s, 1.0) if work_s > 0 else 1.0, marking)
        share = min(undone / need, 1.0) if need > 0 else 0.0
        # a strip whose track is left undone keeps what its neighbours' sensors reach into it: the
        # driven ones', fewer where the lost searchers' bands are left undone around it
        lattice = "cookie_cutter" if model == "random" else model  # the sensor sees to a definite range
        orphaned = orphaned_s.get(s.task, 0.0)
        lost_run = lost_run_s.get(s.task, 0.0)
        kept = budget.undone_band_kept(
            lattice,
            s.sweep_width_m,
            s.spacing_m,
            task.sensor.lateral_range,
            lanes=_lanes_per_searcher(s),
            left=lost_left_s.get(s.task, 0.0) / lost_run if lost_run > 0 else 1.0,
            undone=min(undone / orphaned, 1.0) if orphaned > 0 else 0.0,
            lost=lost_run / need if need > 0 else 0.0,
        )
        mines = s.design["mines_expected"]
        after = s.expected_detection * (1.0 - share * (1.0 - kept))
        if mine_area is not None:  # the trips off the tracks search what the ground lets them
            reachable = s.design.get("reachable_detection", 1.0)
            trips_made_m = trips.to_pieces_m + marking * trips.to_marks_m
            after = budget.with_trips(after, reachable, s.sweep_width_m, trips_made_m, mine_area.area)
        if mines > 0:
            after = max(0.0, after - unseen_blasts / mines)
        random_count = budget.mine_count_is_random(mission)
        as_planned = budget.p_criterion_met(criterion, mines, s.expected_detection, poisson=random_count)
        after_losses = budget.p_criterion_met(criterion, mines, after, poisson=random_count)
        s.design["p_criterion_met"] = as_planned
        if task.mark and task.clearance is not None:
            # a robot of the team marks each mine found and the clearance expends it: a reserve
            # that lasts, surely once the lost tracks are all taken over (`marking`); a searcher
            # only once its track and the lost tracks it can take are done (`swarm.sim.policy`),
            # so at most every robot of the team that lasts; the mines found and the robots that
            # last both vary from run to run (`expected_markers`)
            made = [
                budget.expected_markers(mines, after, team.get(s.task, []), poisson=random_count)
                * (marking if end == 0 else 1.0)
                for end, team in enumerate((reserves_lasting, lasting))
            ]
            markers = [markers[0] + made[0], markers[1] + made[1]]
            # a marker leaves the mission at the blast: nothing strikes it by the clock after it,
            # where every robot's losses above ran on to the end of beach operations (mine_clear
            # at 24 robots expended 13.3 a run 600 s before the end); as many as halfway between
            after_s = max(mission.beach_end_s - task.clearance.at_s, 0.0)
            for cause, p in budget.timed_losses(mission, after_s).items():
                expended_after[cause] = expended_after.get(cause, 0.0) + p * (made[0] + made[1]) / 2.0
        searches[s.task] = {
            "criterion": criterion,
            "expected_detection": s.expected_detection,
            "expected_detection_after_losses": after,
            "p_criterion_met": as_planned,
            "p_criterion_met_after_losses": after_losses,
            # the probability the tracks were designed to meet the criterion with (the verdict's)
            "confidence": task.detection_confidence,
            "expected_team_losses": lost_by_task.get(s.task, 0.0),
            "reserves": s.design["reserves"],
        }
    if budget.hazards_enabled(mission):
        beach = per_phase["beach"]
        for cause, p in expended_after.items():
            spared = min(p, beach.get(cause, 0.0))
            beach[cause] = beach.get(cause, 0.0) - spared
            returning += spared  # to the end of beach operations, where the markers come off
    recovered = None
    if back.enabled:  # none back when none is expected to last (no robot sets off: 0, not unknown)
        # the markers the clearance expends do not go back: back at sea as few as when every
        # robot of the team that lasts marks a mine, as many as when only the reserves do. Which
        # of them marks is the policy's call, so the losses on the way (a robot each, at the same
        # rate) are those of as many as set off halfway between: the expected losses, the markers
        # and the robots back at sea, each the middle of its range, add up to the swarm (counting
        # the most that set off put full_conops's return at 3.19 a run where 100 runs lose 2.46)
        per_returner = sum(way_back.values()) / returning if returning > 0 else 0.0
        least, most = markers
        fewest_off, most_off = max(returning - most, 0.0), max(returning - least, 0.0)
        set_off = (fewest_off + most_off) / 2.0
        scale = set_off / returning if returning > 0 else 0.0
        per_phase[budget.RETURN_PHASE] = {c: v * scale for c, v in way_back.items()}
        recovered = [fewest_off * (1.0 - per_returner), most_off * (1.0 - per_returner)]
    relay = None
    if plan.relay is not None and len(plan.relay.positions_m):
        # the link holds while all but redundancy - 1 of its positions are held, by relay robots or
        # the spares that take a lost one's place; each robot is ashore at a moment of the window
        # with the chance `time_ashore` (16 robots of relay.yaml: 0.9999; all lost at sea: 0)
        k = len(plan.relay.positions_m)
        needed = max(k - (plan.relay.redundancy - 1), 1)
        relay = {"task": plan.relay.task, "positions": k, "needed": needed}
        relay["p_held"] = budget.p_at_least(np.array(holders), needed)
    total = sum(sum(c.values()) for c in per_phase.values())
    out = {
        "relay": relay,
        "hazards": budget.hazards_enabled(mission),
        "expected_losses": {p: dict(sorted(c.items())) for p, c in per_phase.items()},
        "expected_lost": total,
        "expected_expended": markers,
        "expected_recovered": recovered,
        # lost robots' stations the spares take over a run (`exposure.station_takeovers`)
        "station_takeovers": takeovers.expected,
        "search": searches,
        # the robots whose way in is still among the breakers when the surf crossing's time limit
        # runs out at every phase of the wave: this plan cannot land them (`surf_drive`)
        "stranded_in_surf": [
            rp.id for rp, w in zip(plan.robots, ways, strict=True) if w.exposure.surf_timeout >= 1.0
        ],
    }
    return out, got_done


def _source(mission: Mission) -> dict:
    """The mission, map and terrain files (absolute), when the mission was loaded from a file."""
    out: dict[str, str | None] = {}
    if mission.source is not None:
        out["mission_file"] = str(Path(mission.source).resolve())
    try:
        out["map_file"] = str(Path(mission.resolved("map_path")).resolve())
        terrain = mission.resolved("terrain_path")
        out["terrain_file"] = None if terrain is None else str(Path(terrain).resolve())
    except KeyError:
        pass
    return out


# --- output -------------------------------------------------------------------------------------------


def plan_json(plan: MissionPlan) -> str:
    return json.dumps(plan.as_dict(), sort_keys=True, indent=1) + "\n"


def plan_geojson(plan: MissionPlan) -> dict:
    from swarm.world.io import regions_to_geojson

    features = []
    for f in regions_to_geojson(plan.beach_map)["features"]:
        features.append({**f, "properties": {**f["properties"], "layer": "region"}})
    for b in plan.robots:
        wp = b.waypoints_m
        if len(wp) < 2:
            continue
        features.append(
            {
                "type": "Feature",
                "geometry": {"type": "LineString", "coordinates": wp.tolist()},
                "properties": {
                    "layer": "route",
                    "id": b.id,
                    "role": b.role,
                    "task": b.task,
                    "eta_s": b.eta_s,
                },
            }
        )
    for s in plan.search:
        for k, run in enumerate(s.tracks):
            features.append(
                {
                    "type": "Feature",
                    "geometry": {"type": "MultiLineString", "coordinates": [list(t.coords) for t in run]},
                    "properties": {"layer": "search_tracks", "task": s.task, "searcher": k},
                }
            )
    if plan.relay is not None:
        r = plan.relay
        nodes = np.vstack([r.source_m[None, :], r.sinks_m, r.positions_m.reshape(-1, 2)])
        for a, b in r.edges:
            features.append(
                {
                    "type": "Feature",
                    "geometry": {"type": "LineString", "coordinates": [nodes[a].tolist(), nodes[b].tolist()]},
                    "properties": {"layer": "relay_link", "task": r.task, "nodes": [int(a), int(b)]},
                }
            )
    bm = plan.beach_map
    if getattr(bm, "crs", None) is None:
        note = {
            "coordinates": "map metres (x east, y north in the map's own frame), not longitude and "
            "latitude: the map has no crs",
            "map": plan.map,
        }
        return _rounded(
            {"type": "FeatureCollection", "name": plan.mission, "properties": note, "features": features}
        )
    from swarm.world.crs import to_lonlat

    for f in features:
        f["geometry"] = _mapped(f["geometry"], lambda xy: to_lonlat(bm, xy))
    note = {
        "coordinates": "WGS84 longitude, latitude (RFC 7946)",
        "map": plan.map,
        "map_crs": f"EPSG:{bm.crs}",
    }
    # degrees to 1e-8 (about a millimetre), the metres' own precision
    return _degrees(
        {"type": "FeatureCollection", "name": plan.mission, "properties": note, "features": features}
    )


def _mapped(geometry: dict, transform) -> dict:
    """A GeoJSON geometry with every position passed through `transform` ((n, 2) -> (n, 2))."""

    def walk(c):
        arr = np.asarray(c, dtype=np.float64)
        if arr.ndim == 1:
            return transform(arr[None])[0].tolist()
        if arr.ndim == 2 and arr.shape[1] == 2:
            return transform(arr).tolist()
        return [walk(x) for x in c]

    if geometry["type"] == "GeometryCollection":
        return {**geometry, "geometries": [_mapped(g, transform) for g in geometry["geometries"]]}
    return {**geometry, "coordinates": walk(geometry["coordinates"])}


def _degrees(value):
    """`_rounded`, but positions (lists of two floats in a geometry) to 1e-8 degrees."""
    if isinstance(value, dict):
        return {
            k: (_round_positions(v) if k == "coordinates" and isinstance(v, list) else _degrees(v))
            for k, v in value.items()
        }
    if isinstance(value, list):
        return [_degrees(v) for v in value]
    return _rounded(value)


def _round_positions(value):
    if isinstance(value, int | float):
        return round(float(value), 8)
    return [_round_positions(v) for v in value]


def write_plan(plan: MissionPlan, out_dir: str | Path) -> dict[str, Path]:
    """Write plan.json and plan.geojson into `out_dir` (created), atomically; returns the paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"plan.json": out / "plan.json", "plan.geojson": out / "plan.geojson"}
    write_text_atomic(paths["plan.json"], plan_json(plan))
    write_text_atomic(paths["plan.geojson"], json.dumps(plan_geojson(plan), sort_keys=True) + "\n")
    return paths


__all__ = ["MissionPlan", "RobotPlan", "plan_geojson", "plan_json", "plan_mission", "write_plan"]
