"""Each robot's exposure along its planned route, for the plan's expected losses
(`swarm.mission.plan`, formulas in `swarm.mission.budget`): the way in through the surf, the ground
route until the task's window ends (as the robots drive it: stitched around blocked ground,
`drivable`), what the scripted policy will have it drive beyond the plan, and the way back to sea
(`WayOut`, the simulator's robots' way too)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import shapely
import shapely.ops
from scipy.spatial import cKDTree
from scipy.spatial.distance import cdist
from shapely.geometry import LineString

from swarm.mission import budget, surf_drive
from swarm.mission.schema import Mission
from swarm.mission.surf_speed import Crossing, SurfZone
from swarm.planning import CostMap
from swarm.planning.router import Router

if TYPE_CHECKING:
    from swarm.mission.plan import MissionPlan, RobotPlan, SearchPlan


def dry_ground(mission: Mission, cm: CostMap, surf: np.ndarray) -> np.ndarray:
    """(rows, cols) free land cells outside the surf zone `surf`: where a robot is ashore."""
    water = np.array([mission.terrain_library[c].is_water for c in cm.terrain_classes])
    return ~cm.blocked & ~surf & ~water[cm.terrain.astype(np.intp)]


def nearest_ashore(mission: Mission, cm: CostMap, surf: np.ndarray):
    """A function from a point to the segment from it to the centre of the nearest free land cell
    outside the surf zone (the point alone where there is none)."""
    rows, cols = np.nonzero(dry_ground(mission, cm, surf))
    if not len(rows):
        return lambda p: np.asarray(p, dtype=np.float64).reshape(1, 2)
    centres = np.column_stack(cm.center_of(rows, cols))
    tree = cKDTree(centres)
    return lambda p: np.vstack([p, centres[tree.query(p)[1]]])


@dataclass(frozen=True)
class Trips:
    """A search's expected trips off its tracks in a run (m), sensors on across the mine area."""

    to_pieces_m: float  # to the pieces of the lost searchers' tracks, from where the takers wait
    to_marks_m: float  # to the mines marked

    @property
    def total_m(self) -> float:
        return self.to_pieces_m + self.to_marks_m


#: A polyline that never crosses the surf zone.
NO_CROSSING = Crossing(0.0, 0.0, 0.0)


@dataclass
class WayIn:
    """One robot's planned exposure until its task's window ends, and where it is then."""

    exposure: budget.Exposure
    search: SearchPlan | None
    arrive_s: float  # at its entry (release and swim)
    ashore_s: float  # on its wheels (`SurfZone.landfall`), where the simulator's beach phase starts
    #: at work: ashore and driven to its track's start or its spot (`at_work_s`)
    at_work_s: float
    #: its own search track's drive at the search speed, turns included (`track_drive_s`); 0 without one
    track_s: float
    window_end_s: float
    last_m: np.ndarray  # where its planned route ends
    track_m: dict[str, float]  # metres of its search tracks on each class
    track_inside_m: float  # of which in the mine area, counted as `budget.Exposure.in_mine_area_m`
    #: its exposure ashore on the way to its track, and along the track (`track_left`)
    before_track: budget.Exposure | None = None
    on_track: budget.Exposure | None = None
    #: its track's way over the surf zone (the lanes run down to the waterline), at search speed
    track_wet: Crossing = NO_CROSSING


def at_work_s(ashore_s: float, approach_m: float, speed_mps: float) -> float:
    """When a robot ashore at `ashore_s` is at its track's start or its spot, `approach_m` of
    ground away at `speed_mps`: its time for a lost searcher's track starts there, not at its
    entry. Counting from the entry gave mine_clear's survivors at 2 m breakers their 230-410 s in
    the surf (and the drive to the track) as takeover time: the simulated survivors land when the
    plan's `ashore_s` says (within 40 s) and have that much less."""
    return ashore_s + approach_m / speed_mps


def as_driven_ashore(ground: np.ndarray, landed: np.ndarray) -> np.ndarray:
    """The ground route `ground` as a robot drives it from where its wheels grounded (`landed`:
    each wave phase's, the mean of those that landed): straight back to the route, to its nearest
    point, then on along it. The longshore current sets a robot down-current of its landfall
    (mine_clear at 4 m breakers: 70-135 m), and that drive back across the beach is wheel-borne
    exposure, and time, the planned route does not have."""
    ok = np.isfinite(landed).all(axis=1)
    if len(ground) < 2 or not ok.any():
        return ground
    at = shapely.Point(landed[ok].mean(axis=0))
    line = LineString(ground)
    rest = shapely.ops.substring(line, line.project(at), line.length)
    return np.vstack([[at.x, at.y], np.asarray(rest.coords).reshape(-1, 2)])


def polyline_m(points: np.ndarray) -> float:
    """The length of the polyline `points` (m)."""
    return float(LineString(points).length) if len(points) >= 2 else 0.0


def track_drive_s(track_m: float, speed_mps: float, overhead: float) -> float:
    """One searcher's drive along its own track (`track_m` as stitched around blocked ground, as
    the simulator's robots drive it) at `speed_mps`, with the design's turn `overhead`. The design's
    run (`SearchDesign.run_time_s`, the area over the spacing shared evenly) is of the laid lanes,
    which stitching lengthens: mine_clear at 2 m breakers designs a 3988 s run, and its simulated
    searchers take 4450-4890 s from landing to their track's end (8 runs, their approach of 20-120
    s included)."""
    return track_m / speed_mps * overhead


def track_left(mission: Mission, cm: CostMap, way: WayIn, losses: dict[str, dict[str, float]]) -> float:
    """`budget.track_left` of the searcher of `way`, whose whole way's losses are `losses`."""
    if way.before_track is None or way.on_track is None:
        return budget.track_left(losses, {}, losses.get("beach", {}))
    before = budget.robot_losses(mission, cm, way.before_track)["beach"]
    on = budget.robot_losses(mission, cm, way.on_track)["beach"]
    return budget.track_left(losses, before, on)


def drivable(rp: RobotPlan, router: Router) -> RobotPlan:
    """Robot `rp` with its ground route and search track (from its first lane's start) as the
    simulator's robots drive them: stitched around the blocked ground they cross (`Router.stitch`,
    as `swarm.sim.setup` makes its initial routes: a track over a driftwood log or through a
    boulder ring goes round it). The laid tracks of mine_clear are 11.5% shorter than the
    stitched ones."""
    if not len(rp.track_m) and not len(rp.ground_m):
        return rp
    wp = rp.waypoints_m[1:]  # from the entry: the sea leg is open water
    land, where = router.stitch(wp)
    if not len(rp.track_m):
        return dataclasses.replace(rp, ground_m=land)
    # the track from its first lane's start, where the ground route ends (the plan's `track_m`
    # begins at that lane's end), as `swarm.sim.setup` has it
    t = int(where[len(wp) - len(rp.track_m) - 1])
    ground = land[: t + 1] if len(rp.ground_m) else rp.ground_m
    return dataclasses.replace(rp, ground_m=ground, track_m=land[t:])


def _dry(mission: Mission, by_class: dict[str, float]) -> dict[str, float]:
    """Metres by class, on the classes that are not water."""
    return {c: v for c, v in by_class.items() if not mission.terrain_library[c].is_water}


def _wet(mission: Mission, by_class: dict[str, float]) -> dict[str, float]:
    """Metres by class, on water whose bed the wheels touch (`budget.Exposure.wet_m`)."""
    lib = mission.terrain_library
    return {c: v for c, v in by_class.items() if lib[c].is_water and lib[c].buoyancy_fraction < 1.0}


def _mean_hazard(*crossings: Crossing) -> float:
    """One breaker's hazard over several crossings, averaged by their time."""
    seconds = sum(c.seconds for c in crossings)
    return sum(c.seconds * c.hazard_per_hit for c in crossings) / seconds if seconds > 0 else 0.0


def task_of(mission: Mission, search: SearchPlan):
    """The mission's search task that `search` plans."""
    return next(t for t in mission.tasks_of("search") if t.area == search.area)


def _found_before(mission: Mission, search: SearchPlan) -> float:
    """`budget.found_by_lanes_before` on the lanes of `search`."""
    curve = task_of(mission, search).sensor.lateral_range
    return budget.found_by_lanes_before(search.model, search.sweep_width_m, search.spacing_m, curve)


def route_in(rp: RobotPlan, ashore) -> np.ndarray:
    """Robot `rp`'s way in from its launch point: the sea leg and its ground path (a spare swims
    from its entry to the nearest dry ground, `ashore`, where the simulator's robots wait out of
    the breakers)."""
    sea_leg = rp.sea_leg_m.reshape(-1, 2)
    on = rp.ground_m.reshape(-1, 2) if len(rp.ground_m) else ashore(sea_leg[-1])
    return np.vstack([sea_leg, on])


def surf_terms(drive: surf_drive.WayIn, period_s: float) -> tuple[float, float, float]:
    """A way in's time in the surf (s), one breaker's hazard and the chance of a surf timeout as
    `budget.Exposure` counts them, from its drive at each wave phase: the breakers' survival and
    the timeouts among the survivors averaged over the phases, so the surf's losses are the mean
    of the phases' (a phase that times out has met more breakers than the mean)."""
    seconds = float(drive.surf_s.mean())
    survive = np.exp(-drive.hazard)
    kept = float(survive.mean())
    per_hit = -math.log(kept) * period_s / seconds if seconds > 0 and kept < 1.0 else 0.0
    timeout = 1.0 - float((survive * ~drive.timed_out).mean()) / kept if kept > 0 else 0.0
    return seconds, per_hit, timeout


def losses_to_the_end(
    mission: Mission, cm: CostMap, way: WayIn, exposed: budget.Exposure
) -> dict[str, dict[str, float]]:
    """`exposed`'s losses with its time ashore running from `way`'s landing to the end of beach
    operations, not only its task's window: every loss a study counts."""
    until_end = max(mission.beach_end_s - way.ashore_s, 0.0)
    return budget.robot_losses(mission, cm, dataclasses.replace(exposed, beach_s=until_end))


def way_in(
    mission: Mission,
    cm: CostMap,
    rp: RobotPlan,
    zone: SurfZone,
    ashore,
    mine_area,
    by_task,
    drive: surf_drive.WayIn,
) -> WayIn:
    """Robot `rp`'s exposure along its planned route: the swim, the surf on the way in as the
    simulator's robots drive it (`drive`, of `route_in`: `surf_drive.drive_in`), the swash beyond
    where the wheels ground at the way a robot makes there (`SurfZone.crossing`), and its ground
    route until its task's window ends."""
    swim = mission.robot.swim_speed_mps
    sea_leg = rp.sea_leg_m.reshape(-1, 2)
    leg = zone.crossing(sea_leg)
    # afloat until the wheels ground (the simulator's surf phase), then wading out of the breakers
    way = route_in(rp, ashore)
    _, wading = zone.landfall(way)
    swash = zone.crossing(wading)
    surf_s, per_hit, timeout = surf_terms(drive, mission.hazards.surf.wave_period_s)
    # stuck among the breakers, as a survival chance over the wave's phases
    surf_stuck = -math.log(float(np.exp(-drive.stuck).mean()))
    landed = drive.surf_s[drive.ashore]
    arrive = rp.release_s + rp.sea_time_s  # the schedule swims the sea leg at swim speed
    ashore_s = arrive + max((float(landed.mean()) if len(landed) else surf_s) - leg.seconds, 0.0)
    search = by_task.get(rp.task or "")
    end = search.design["window_s"][1] if search is not None else mission.beach_end_s
    land = np.vstack([p.reshape(-1, 2) for p in (rp.ground_m, rp.track_m)])
    # the ground route ends where the track starts (`drivable`): the land is the two, end to end
    ground = as_driven_ashore(rp.ground_m.reshape(-1, 2), drive.landed_m)
    approach, approach_inside = budget.driven_by_class(cm, ground, mine_area)
    track, track_inside = budget.driven_by_class(cm, rp.track_m, mine_area)
    if search is not None:  # the lanes before have found some of the mines under the track
        track_inside *= 1.0 - _found_before(mission, search)
    wet_approach, wet_track = _wet(mission, approach), _wet(mission, track)
    approach, track = _dry(mission, approach), _dry(mission, track)
    speed = search.design.get("speed_mps") if search is not None else None
    wet = zone.crossing(rp.track_m, budget.ground_speed(mission, speed))
    exposure = budget.Exposure(
        sea_s=max(rp.sea_time_s - leg.metres / swim, 0.0),
        surf_s=surf_s,
        beach_s=max(end - ashore_s, 0.0),
        driven_m=add_metres(approach, track),
        in_mine_area_m=approach_inside + track_inside,
        breaker_hazard=per_hit,
        speed_mps=speed,
        beach_surf_s=wet.seconds + swash.seconds,
        beach_breaker_hazard=_mean_hazard(wet, swash),
        surf_timeout=timeout,
        wet_m=add_metres(wet_approach, wet_track),
        surf_stuck_hazard=surf_stuck,
    )
    last = (land if len(land) else way)[-1]
    before, on_track = None, None
    v = budget.ground_speed(mission, speed)
    overhead = search.design.get("overhead", 1.0) if search is not None else 1.0
    at_work = at_work_s(ashore_s, sum(approach.values()), v)
    # the whole track: its metres in shallow water (mine_clear's tracks run into the lagoon) take
    # time too, though no wheel-borne hazard counts them
    drive_s = track_drive_s(polyline_m(rp.track_m), v, overhead) if len(rp.track_m) else 0.0
    if len(rp.track_m):
        before_s = min(sum(approach.values()) / v, exposure.beach_s)
        track_s = min(sum(track.values()) / v, exposure.beach_s - before_s)
        before = budget.Exposure(
            0.0, 0.0, before_s, approach, approach_inside, speed_mps=speed, wet_m=wet_approach
        )
        on_track = dataclasses.replace(
            exposure,
            sea_s=0.0,
            surf_s=0.0,
            beach_s=track_s,
            driven_m=track,
            in_mine_area_m=track_inside,
            surf_timeout=0.0,
            wet_m=wet_track,
            surf_stuck_hazard=0.0,
        )
    return WayIn(
        exposure=exposure,
        search=search,
        arrive_s=arrive,
        ashore_s=ashore_s,
        at_work_s=at_work,
        track_s=drive_s,
        window_end_s=end,
        last_m=last,
        track_m=track,
        track_inside_m=track_inside,
        before_track=before,
        on_track=on_track,
        track_wet=wet,
    )


def ways_in(
    mission: Mission, cm: CostMap, robots: list, zone: SurfZone, ashore, mine_area, by_task
) -> list[WayIn]:
    """`way_in` of each robot of `robots`, their ways in through the surf driven together
    (`surf_drive.drive_in` of their `route_in`)."""
    drives = surf_drive.drive_in(mission, zone, [route_in(rp, ashore) for rp in robots])
    return [
        way_in(mission, cm, rp, zone, ashore, mine_area, by_task, drive)
        for rp, drive in zip(robots, drives, strict=True)
    ]


class OffPlan(NamedTuple):
    """What one robot drives beyond its planned route (`off_plan_driving`)."""

    metres: dict[str, float]  # by terrain class
    inside_m: float  # in the mine area, counted as `budget.Exposure.in_mine_area_m`
    swash_s: float  # seconds among the breakers ashore, where the tracks run to the waterline
    swash_hits: float  # those seconds times one breaker's hazard (`budget.Exposure.beach_breaker_hazard`)

    def plus(self, other: OffPlan) -> OffPlan:
        """This driving and `other`'s."""
        return OffPlan(
            add_metres(self.metres, other.metres),
            self.inside_m + other.inside_m,
            self.swash_s + other.swash_s,
            self.swash_hits + other.swash_hits,
        )

    def added_to(self, exposure: budget.Exposure) -> budget.Exposure:
        """`exposure` with this driving too."""
        seconds = exposure.beach_surf_s + self.swash_s
        hits = exposure.beach_surf_s * exposure.beach_breaker_hazard + self.swash_hits
        return dataclasses.replace(
            exposure,
            driven_m=add_metres(exposure.driven_m, self.metres),
            in_mine_area_m=exposure.in_mine_area_m + self.inside_m,
            beach_surf_s=seconds,
            beach_breaker_hazard=hits / seconds if seconds > 0 else 0.0,
        )


#: The roles whose robot holds a point the scripted policy hands to a spare when the robot is lost
#: (`swarm.sim.policy.STATIONS`); a landing zone only while it has not yet held its robots.
STATION_ROLES = ("landing", "relay", "surveillance", "beacon")


class Takeovers(NamedTuple):
    """The spares' drives to the stations of lost robots (`station_takeovers`), robot by robot."""

    driving: list[OffPlan]  # each robot's drives there (a spare's, given it gets ashore)
    #: each robot's ways back from the stations it ends up holding: (chance, way back)
    returns: list[list[tuple[float, budget.Exposure]]]
    expected: float = 0.0  # takeovers a run


def station_takeovers(
    mission: Mission,
    cm: CostMap,
    plan: MissionPlan,
    ways: list[WayIn],
    router: Router,
    mine_area,
    way_back_from: Callable[[np.ndarray], budget.Exposure] | None = None,
) -> Takeovers:
    """What the mission's spares drive to take the stations of lost robots (`STATION_ROLES`), and
    where they go back to sea from.

    The scripted policy hands a lost robot's station to an idle spare ashore, which drives there
    from where it waits and holds it (`swarm.sim.policy`); at the end it goes back to sea from the
    station, not from its spot. relay at 16 robots, 48 runs: 3.8 takeovers a run, 250 m of soft
    sand and vegetation there and 190 m back, where the takers' getting stuck integrates to 0.05
    robots a run; the plan, counting none of it, expected 0.08 robots stuck a run against the 0.14
    the runs' hazard integrates (0.12 with it).

    A station is open when its robot is lost before beach operations end (a landing robot's only
    before it lands: after that its zone has held it); the spares ashore take as many as there are
    of them (E[min(open, spares ashore)] of the two Poisson binomials), and a taker lost while
    holding opens it again (its beach loss, half of it on average still to come). Each station's
    takeovers are shared among the spares in proportion to their chances of getting ashore, and
    each spare's drive is counted given it gets there, as its own beach losses are."""
    n = len(ways)
    none = Takeovers([OffPlan({}, 0.0, 0.0, 0.0) for _ in range(n)], [[] for _ in range(n)])
    spares = [k for k, rp in enumerate(plan.robots) if rp.role == "spare"]
    stations = [k for k, rp in enumerate(plan.robots) if rp.role in STATION_ROLES]
    if not spares or not stations or not budget.hazards_enabled(mission):
        return none
    whole = {k: losses_to_the_end(mission, cm, ways[k], ways[k].exposure) for k in (*stations, *spares)}
    afloat = ("sea", "surf")
    phases = {k: afloat if plan.robots[k].role == "landing" else budget.PHASE_NAMES for k in stations}
    opened = np.array([budget.lost_probability(whole[k], phases[k]) for k in stations])
    ashore = np.array([1.0 - budget.lost_probability(whole[k], afloat) for k in spares])
    if opened.sum() <= 0 or ashore.sum() <= 0:
        return none
    taken = budget.expected_fewer(opened, ashore)
    again = float(np.mean([budget.lost_probability(whole[k], ("beach",)) for k in spares])) / 2.0
    per_station = opened / opened.sum() * taken * (1.0 + again)  # takeovers a run, station by station
    share = per_station / ashore.sum()  # of a spare that gets ashore
    metres: dict[str, float] = {}
    inside, returns = 0.0, []
    spots = np.array([ways[j].last_m for j in spares])
    routes = router.fork()  # its own seeds: the plan's other routes stay as they were
    for k, each in zip(stations, share, strict=True):
        goal = ways[k].last_m
        # the auction's choice: the idle spare nearest the station in a straight line
        route = routes.route(spots[int(np.argmin(np.hypot(*(spots - goal).T)))], goal)
        by_class, within = budget.driven_by_class(cm, route, mine_area)
        metres = add_metres(metres, {c: each * v for c, v in by_class.items()})
        inside += each * within
        if way_back_from is not None:
            returns.append((float(each), way_back_from(goal)))
    held = sum(chance for chance, _ in returns)
    if held > 1.0:  # a spare goes back to sea once, from the last station it held
        returns = [(chance / held, home) for chance, home in returns]
    taker = set(spares)
    driving = [OffPlan(metres, inside, 0.0, 0.0) if k in taker else d for k, d in enumerate(none.driving)]
    back = [returns if k in taker else [] for k in range(n)]
    return Takeovers(driving, back, float(per_station.sum()))


def off_plan_driving(
    mission: Mission,
    cm: CostMap,
    plan: MissionPlan,
    ways: list[WayIn],
    done: Mapping[str, tuple[float, float]] | None = None,
) -> tuple[list[OffPlan], dict[str, Trips]]:
    """What the scripted policy has robots drive beyond their planned routes, for each robot: the
    metres on each class and in the mine area, and its time among the breakers where the lost
    tracks run to the waterline (mine_clear at 2 m breakers, 32 runs: 0.16 robots a run lost to
    breakers on lost track and 0.06 on the way to a mark, which the plan did not count, beside
    0.22 on their own routes); and for each search, the metres of its trips
    across the mine area (their sensors on, off the tracks). A reserve takes over what a lost
    searcher left of its track (`track_left`) in pieces of `budget.TAKEOVER_PIECE_M`, driving to
    each piece from where it waits: its spot, or before a clearance outside every found mine's
    standoff and margin. Each mine marked takes one robot there (a marker stays on its mine: a
    robot of the team that lasts to each mine found, `budget.expected_markers`), and the marks
    come due late, when the robots are spread over the tracks: a mark's trip is the mean distance
    between two points of the tracks (mine_clear, 48 runs: 251 m a mark, against 296 m from this
    and the 60 m of the standoff the plan used to count). The work goes to the task's reserves,
    else to the mission's spares, else to its searchers, in equal shares.

    `done[task]`: the share of the lost-track work the takers get done in time and the chance the
    marks are made (the budget's own answer, from a first pass without it): the takers drive only
    that. The returned trips are the whole work's, which is what its time is weighed from."""
    out = [OffPlan({}, 0.0, 0.0, 0.0) for _ in ways]
    trips_by_task: dict[str, Trips] = {}
    for s in plan.search:
        task = task_of(mission, s)
        team = [k for k, w in enumerate(ways) if w.search is s]
        searchers = [k for k in team if plan.robots[k].role == "search"]
        takers = [k for k in team if plan.robots[k].role == "spare"]
        takers = takers or [k for k, rp in enumerate(plan.robots) if rp.role == "spare"] or searchers
        if not searchers or not takers:
            continue
        share, marking = (done or {}).get(s.task, (1.0, 1.0))
        track_total = sum(sum(ways[k].track_m.values()) for k in searchers)
        if track_total <= 0:
            continue
        # a trip from a taker's spot to a point of the tracks, over the ground the tracks cover
        points = np.vstack([plan.robots[k].track_m.reshape(-1, 2) for k in searchers])
        spots = np.array([ways[k].last_m for k in takers])
        wait_m = 0.0 if task.clearance is None else task.clearance.standoff_m + budget.STANDOFF_MARGIN_M
        reach = max(float(cKDTree(spots).query(points)[0].mean()), wait_m)
        trips = 0.0  # metres of trips, each at least the reach
        metres: dict[str, float] = {}
        inside = 0.0
        swash_s, swash_hits = 0.0, 0.0
        losses_of = {k: budget.robot_losses(mission, cm, ways[k].exposure) for k in team}
        for k in searchers:
            losses = losses_of[k]
            left = track_left(mission, cm, ways[k], losses)
            for c, v in ways[k].track_m.items():
                metres[c] = metres.get(c, 0.0) + share * left * v
            inside += share * left * ways[k].track_inside_m
            wet = ways[k].track_wet
            swash_s += share * left * wet.seconds
            swash_hits += share * left * wet.seconds * wet.hazard_per_hit
            # a trip to each piece of what is left: ceil(left / piece), about half a piece more
            left_m = left * sum(ways[k].track_m.values())
            pieces = left_m / budget.TAKEOVER_PIECE_M + 0.5 * budget.lost_probability(losses)
            trips += pieces * reach
        inside += share * trips
        to_pieces = trips
        driven = share * trips  # of the trips, those the takers make
        if task.mark:
            lasting = [1.0 - budget.lost_probability(losses_of[k]) for k in team]
            random_count = budget.mine_count_is_random(mission)
            marks = budget.expected_markers(
                s.design["mines_expected"], s.expected_detection, lasting, poisson=random_count
            )
            to_mark = marks * max(mean_distance_apart([plan.robots[k].track_m for k in searchers]), reach)
            trips += to_mark
            driven += marking * to_mark
            # over searched ground, clear of the mines found: only those the search missed are left
            inside += marking * to_mark * (1.0 - s.expected_detection)
        # only the takers ashore drive to the pieces (each taker's share of trips is what it drives
        # while there; the marks count only the robots that last already)
        ashore = [budget.time_ashore(budget.robot_losses(mission, cm, ways[k].exposure)) for k in takers]
        trips_by_task[s.task] = Trips(to_pieces * float(np.mean(ashore)), trips - to_pieces)
        # the trips cross the ground the tracks cover, the waterline as often as they do
        for k in searchers:
            for c, v in ways[k].track_m.items():
                metres[c] = metres.get(c, 0.0) + driven * v / track_total
            wet = ways[k].track_wet
            swash_s += driven * wet.seconds / track_total
            swash_hits += driven * wet.seconds * wet.hazard_per_hit / track_total
        each = {c: v / len(takers) for c, v in metres.items()}
        for k in takers:
            mine = out[k]
            out[k] = OffPlan(
                add_metres(mine.metres, each),
                mine.inside_m + inside / len(takers),
                mine.swash_s + swash_s / len(takers),
                mine.swash_hits + swash_hits / len(takers),
            )
    return out, trips_by_task


def mean_distance_apart(tracks: list[np.ndarray], step_m: float = 5.0, most: int = 1500) -> float:
    """The mean distance between two points drawn uniformly along the polylines `tracks`: over
    every pair of the midpoints of pieces at most `step_m` long (`shapely.segmentize`), each
    weighted by its length (at most `most` pieces, evenly taken)."""
    ends = [
        shapely.get_coordinates(shapely.segmentize(LineString(t.reshape(-1, 2)), step_m))
        for t in tracks
        if t.size >= 4
    ]
    if not ends:
        return 0.0
    a = np.vstack([e[:-1] for e in ends])
    b = np.vstack([e[1:] for e in ends])
    take = slice(None, None, max(1, math.ceil(len(a) / most)))
    mid, w = ((a + b) / 2.0)[take], np.hypot(*(b - a).T)[take]
    total = float(w.sum())
    return float(w @ cdist(mid, mid) @ w) / total**2 if total > 0.0 else 0.0


def add_metres(a: dict[str, float], b: dict[str, float]) -> dict[str, float]:
    """Metres by class, summed."""
    return {c: a.get(c, 0.0) + b.get(c, 0.0) for c in {*a, *b}}


class WayOut:
    """How survivors go back to sea, for the plan (`way_back`) and the simulator's robots alike:
    over land to the dry ground nearest their pick-up point (`nearest_ashore`: where a landing
    from it comes ashore), then straight out through the surf to it. Heading for the pick-up point
    itself, the cheapest route runs along the surf zone (its cost per metre is near dry sand's),
    so relay's robots met the breakers 35% longer than the plan counted for its straight line:
    driven along the beach they meet them only on the way out, where they are crossed shortest."""

    def __init__(self, mission: Mission, cm: CostMap, pickups: np.ndarray) -> None:
        self.pickups = np.asarray(pickups, dtype=np.float64).reshape(-1, 2)
        surf = budget.surf_heights(mission) > 0
        ashore = nearest_ashore(mission, cm, surf)
        r, c = cm.cell_of(self.pickups[:, 0], self.pickups[:, 1])
        #: (k,) the pick-up points on dry ground (a beach launch's), each its own exit
        self.on_land = dry_ground(mission, cm, surf)[r, c]
        self.exits = np.array(
            [p if d else ashore(p)[-1] for p, d in zip(self.pickups, self.on_land, strict=True)]
        )

    def nearest(self, xy: np.ndarray) -> int:
        """The pick-up point nearest `xy`."""
        return int(np.argmin(np.hypot(*(self.pickups - np.asarray(xy)).T)))

    def route(self, router: Router, start: np.ndarray) -> np.ndarray:
        """Waypoints from `start` to its nearest pick-up point: routed by `router` to the point's
        exit, then out."""
        k = self.nearest(start)
        land = router.route(np.asarray(start, dtype=np.float64), self.exits[k])
        if self.on_land[k]:
            return land
        return np.vstack([land, self.pickups[k]])


def way_back(
    mission: Mission, cm: CostMap, start: np.ndarray, way_out: WayOut, router: Router, zone: SurfZone
) -> budget.Exposure:
    """The way back to sea from `start` (`WayOut`), through the surf at the way a robot makes there
    (`SurfZone.crossing`)."""
    way = way_out.route(router, start)
    surf = zone.crossing(way)
    by_class = budget.driven_by_class(cm, way, None)[0]
    dry = _dry(mission, by_class)
    return budget.Exposure(
        sea_s=0.0,
        surf_s=surf.seconds,
        beach_s=sum(dry.values()) / mission.robot.wheel_speed_mps,
        driven_m=dry,
        breaker_hazard=surf.hazard_per_hit,
        wet_m=_wet(mission, by_class),
    )
