"""The built-in scripted coordination policy: follow the plan, and when robots are lost, hand their
work to the survivors that can hear about it.

It drives the environment in command mode. Each step it:

1. Reads the new events. A lost robot's work becomes an open *work item*: the rest of its search
   track (from where it stood, or all of it when lost before the track; in pieces of
   `TAKEOVER_PIECE_M`), its station (landing, relay, surveillance or beacon
   point; relays are how the chain heals; a landing zone only until it has held its robots, which
   is all its criterion asks), or the mine it was marking. A robot that found a mine
   makes a *mark* item. A lost robot that had taken work over hands on what it left of it: the
   station or mark, or the rest of the piece of track it was on; the pieces it finished stay done.
2. Spreads the news over the radio: an item is known first to the robots in the lost (or finding)
   robot's radio component at the time, then to every component that contains a robot that knows
   it, as links come and go. Jammed or isolated robots learn nothing.
3. Every `realloc_period_s`, assigns open items to idle robots that know of them (spares, and
   searchers whose track is done) with the forward auction of `swarm.planning.allocation`, cost the
   straight-line distance to the item; the winner gets a route there (`swarm.planning.router`). Lost
   stations go first (each is a whole criterion), then the pieces of lost tracks (each a sliver of
   the detection); marks wait until they are due (nobody is searching any more, or the clearance
   is near enough that the nearest free robot must set off).
   A searcher that finds a mine reports it and keeps searching: marking never consumes a
   searcher's track (the plan's detection counts on every track being driven). The mark goes to
   a reserve, or to a searcher once its track is done.
4. Before the synchronized clearance (`clearance_lead_s` ahead, or longer when the standoff is
   far to drive, or when a robot inside a found mine's standoff is far from safe ground), robots
   within a marked mine's standoff (plus a margin) move to the nearest free point clear of every
   marked mine's standoff (on dry ground, out of the breakers, where there is any), a robot still
   on its way to mark a mine turns back when it cannot get there in time, and everyone else holds
   until the detonation, then resumes: the rest of its route, or back to its station. Before that, a
   robot with nothing to do waits clear of every found mine's standoff; after it (or with no
   clearance), the nearest robot with nothing to do stands by at each point that must be held at
   the end (a beacon), so a loss in the last minutes leaves it held; in the last
   `STAND_BY_LEAD_S` of beach operations that stand-by comes before the lost tracks.
5. At the end of beach operations (with the return to sea enabled), and for any robot whose battery
   falls to the reserve, the command is "return to sea".
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Any

import numba
import numpy as np

from swarm.mission.schema import Mission
from swarm.planning.allocation import auction
from swarm.sim.criteria import STATION_RADIUS_M
from swarm.sim.layout import ROLES
from swarm.sim.routes import rest_of_route_m
from swarm.sim.runview import FOLLOW, LOITER, MARK, RETURN, RETURNING, SEA, RunView
from swarm.sim.standoff import SafeGround

#: Extra distance beyond the clearance standoff that robots retreat to (m).
STANDOFF_MARGIN_M = 10.0
#: Retreat time allowed per metre of standoff, as a multiple of the straight-line time at cruise
#: speed (pivots, detours), plus a fixed allowance (s): sets the clearance lead when the standoff
#: is too far to clear in `clearance_lead_s`.
RETREAT_TIME_FACTOR = 1.5
RETREAT_ALLOWANCE_S = 30.0
#: How long before the clearance the policy starts checking whether a robot inside a found mine's
#: standoff needs longer than the lead to get clear (s): 900 s is 290 m of retreat at 0.5 m/s.
HOLD_HORIZON_S = 900.0
#: A lost searcher's remaining track is offered in pieces of at most this length (m), so several
#: idle robots can share it instead of one driving it all.
TAKEOVER_PIECE_M = 300.0
#: A mark is handed out this long before the robot that takes it must set off to make the
#: clearance, so a search still running can use the robot meanwhile (s).
MARK_SLACK_S = 600.0
#: In this last stretch of beach operations (after any clearance) the stand-bys at points held at
#: the end come before the lost tracks (s): the time to drive 900 m of beach at 0.5 m/s, so a
#: stand-by sent from anywhere is in place before the end.
STAND_BY_LEAD_S = 1800.0
SPARE, SEARCH, RELAY_ROLE = ROLES.index("spare"), ROLES.index("search"), ROLES.index("relay")
STATIONS = tuple(ROLES.index(r) for r in ("landing", "relay", "surveillance", "beacon"))


@dataclass
class WorkItem:
    """Work that a robot gave up: a route to follow (from its first point) or an object to mark."""

    kind: str  # "route" | "mark"
    role: str
    start_m: np.ndarray
    waypoints_m: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    track: bool = False  # the waypoints are a search track (sense along them)
    obj: int = -1
    audience: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    created_s: float = 0.0
    taken_by: int = -1


def split_polyline(points: np.ndarray, piece_m: float) -> list[np.ndarray]:
    """`points` cut into consecutive polylines of at most `piece_m` each (cut at interpolated points,
    so the pieces join end to start and together are the whole line)."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if len(pts) < 2:
        return [pts] if len(pts) else []
    cum = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])
    total = float(cum[-1])
    k = max(1, math.ceil(total / piece_m - 1e-9))
    cuts = np.linspace(0.0, total, k + 1)
    out = []
    for a, b in itertools.pairwise(cuts):
        inner = (cum > a) & (cum < b)
        ends = np.array([[np.interp(v, cum, pts[:, 0]), np.interp(v, cum, pts[:, 1])] for v in (a, b)])
        out.append(np.vstack([ends[:1], pts[inner], ends[1:]]))
    return out


class ScriptedPolicy:
    """Coordination by script of one run: a `RunView` of a batch (`swarm.sim.world`), or a
    `SwarmEnv` made with action_mode="command" (its run).

    Everything it reads and commands goes through the run's interface (`swarm.sim.runview`):
    the per-robot arrays, `routes`, `router`, `links`, `score`, `events`, `objects_m`,
    `set_command`, `set_route`, `route_goal` and `log_event`."""

    def __init__(
        self, env: RunView | Any, *, realloc_period_s: float = 5.0, clearance_lead_s: float = 120.0
    ) -> None:
        if not isinstance(env, RunView):
            if getattr(env, "action_mode", None) != "command":
                raise ValueError("ScriptedPolicy needs an environment with action_mode='command'")
            self.agent_env = env
            env = env.run
        self.env: RunView = env
        self.realloc_period_s = realloc_period_s
        self.clearance_lead_s = clearance_lead_s
        # fixed by the mission and the settings above: worked out once, not on every step
        self._lead_s = self._clearance_lead_s()
        # how long before the detonation `_clearance` starts checking (`_drop_late_markers` from
        # `HOLD_HORIZON_S`, `_hold_due` from then or from the lead if that is longer)
        self._watch_s = max(HOLD_HORIZON_S, self._lead_s + 1e-9)
        self._reserve_wh = battery_reserve_wh(env.mission)
        self.reset()

    def reset(self) -> None:
        self.items: list[WorkItem] = []
        self._seen = 0
        self._next_alloc_s = 0.0
        self._held: dict[int, tuple[np.ndarray, bool]] = {}
        #: robot -> the piece of track it took over last: the only one of its pieces that a loss
        #: can leave unfinished (a robot takes work only once it has finished its route)
        self._doing: dict[int, WorkItem] = {}
        self._waiting: dict[int, np.ndarray] = {}  # stand-by waiting out a clearance -> its point
        self._clearance_state = "before"
        self._gave_up: set[tuple[int, int]] = set()  # (robot, object): marks given up as too far
        self._returning = False
        self._links_seen = -1
        # what the last spread saw (the bytes of the radio components and of who was alive), and
        # whether an item has been opened or given a new audience since: with neither changed, a
        # spread changes nothing
        self._spread_seen: tuple[bytes, bytes] | None = None
        self._news = False
        self._safe_cache: tuple[tuple[bytes, float], SafeGround, np.ndarray] | None = None
        self._found_cache: tuple[tuple[int, int, int], np.ndarray] | None = None

    # the step ------------------------------------------------------------------------------------
    def act(self) -> dict[str, dict]:
        """This step's command for every live agent (the environment's command action space)."""
        self.update()
        env = self.env
        return {
            env.possible_agents[i]: {
                "command": int(env.command[i]),
                "target": env.target_m[i].astype(np.float32),
            }
            for i in np.flatnonzero(env.in_agents).tolist()
        }

    def update(self, battery_low: bool = True) -> None:
        """Coordinate: set the environment's commands and routes for this step directly (a runner
        then calls `env.advance({})`). `battery_low` False: the caller has checked that no robot
        is at its battery reserve (`BatchPolicy`, for every run at once)."""
        env = self.env
        if self._seen > len(env.events) and env.steps == 0:
            self.reset()
        self._read_events()
        self._spread()
        if battery_low:
            self._battery()
        self._clearance()
        self._return()
        if env.t_s + 1e-9 >= self._next_alloc_s and self._clearance_state != "holding":
            self._next_alloc_s = env.t_s + self.realloc_period_s
            self._allocate()

    def quiet_until_s(self) -> float:
        """Until this time, with no new event, no new radio graph and no battery at its reserve,
        `update` changes nothing: the next allocation, the start of the clearance's watch, the end
        of beach operations (-inf while holding for a clearance: it checks every step)."""
        env = self.env
        c = env.clearance
        if c is not None and self._clearance_state == "holding":
            return -math.inf
        until = self._next_alloc_s
        if c is not None and self._clearance_state == "before":
            until = min(until, c.at_s - self._watch_s)
        phases = env.mission.phases
        if phases.return_to_sea.enabled and not self._returning:
            until = min(until, env.mission.beach_end_s)
        return until

    @property
    def events_read(self) -> int:
        """How many of the run's events `update` has read."""
        return self._seen

    @property
    def links_read(self) -> int:
        """The run's radio graph version `update` last spread news over."""
        return self._links_seen

    # events -> work items ----------------------------------------------------------------------------
    def _read_events(self) -> None:
        env = self.env
        if self._seen == len(env.events):
            return
        new = env.events[self._seen :]
        self._seen = len(env.events)
        for ev in new:
            kind = ev["kind"]
            if kind == "loss":
                self._on_loss(env.agent_index[ev["robot"]])
            elif kind in ("detection", "false_alarm"):
                self._on_find(env.agent_index[ev["robot"]], int(ev["object"]))

    def _hearers(self, i: int) -> np.ndarray:
        """Robots in robot i's radio component (not i itself)."""
        env = self.env
        comp = env.links.component[: env.n]
        out = (comp == comp[i]) & env.alive
        out[i] = False
        return out

    def _release_work(self, i: int, audience: np.ndarray) -> None:
        """Turn what robot i was doing into open work items."""
        env = self.env
        t = env.t_s
        self._news = True
        reopened = False
        doing = self._doing.pop(i, None)
        for it in self.items:  # work it had taken over from others is open again
            if it.taken_by != i:
                continue
            if it.track:  # a piece of track: only the one it is on, and only what is left of it
                rest = self._rest_of_piece(i, it) if it is doing else np.empty((0, 2))
                if not len(rest):
                    continue  # driven to its end: done
                it.start_m, it.waypoints_m = rest[0].copy(), rest
            elif self._zone_held(it.role, it.start_m):
                continue  # done, as for the zone's own robots
            it.taken_by, it.audience, reopened = -1, audience.copy(), True
        k = int(env.marking[i])
        if k >= 0:
            if not any(it.kind == "mark" and it.obj == k for it in self.items):
                self.items.append(WorkItem("mark", ROLES[env.role[i]], env.objects_m[k].copy(), obj=k,
                                           audience=audience, created_s=t))  # fmt: skip
            return
        if reopened:
            return
        role = int(env.role[i])
        if role in STATIONS:
            goal = self._station_of(i)
            if self._zone_held(ROLES[role], goal):
                return  # the spares are wanted elsewhere
            self.items.append(WorkItem("route", ROLES[role], goal.copy(), goal[None].copy(),
                                       audience=audience, created_s=t))  # fmt: skip
        elif role == SEARCH:
            rest = env.routes.remaining_track(i, env.robot_state[i, :2])
            for piece in split_polyline(rest, TAKEOVER_PIECE_M):
                self.items.append(WorkItem("route", "search", piece[0].copy(), piece, track=True,
                                           audience=audience, created_s=t))  # fmt: skip

    def _zone_held(self, role: str, point: np.ndarray) -> bool:
        """Whether `point` is a landing station whose zone has held its robots: done for good,
        whoever was on it (the criterion counts a zone once it has, and so does the plan)."""
        return role == "landing" and not self.env.score.zone_still_open(point)

    def _rest_of_piece(self, i: int, it: WorkItem) -> np.ndarray:
        """What is left of the piece of track `it` that robot i took over: all of it before the
        robot gets there, then from where it stands, nothing once driven to its end. While the
        robot waits out a clearance, of the route it will resume (`_held`: its rest of route when
        it was on the track; else one point where it had finished, the way there and the piece
        where it had not)."""
        held = self._held.get(i)
        if held is None:
            env = self.env
            return env.routes.remaining_track(i, env.robot_state[i, :2])
        rest, on_track = held
        if on_track:
            return rest
        return it.waypoints_m if len(rest) > 1 else np.empty((0, 2))

    def _station_of(self, i: int) -> np.ndarray:
        """Where robot i's station is: the end of its route, or, while it is away for the
        clearance, the end of the route it will resume (a beacon robot lost while clear of the
        blast used to hand its retreat point, not its beacon, to the robot taking over)."""
        held = self._held.get(i)
        return held[0][-1].copy() if held is not None else self.env.route_goal()[i]

    def _on_loss(self, i: int) -> None:
        """Ashore, a loss is known to the robot's radio component. A robot lost before it reached
        the beach is known to everyone: the launch platform tracks its robots on the way in (they
        surface for fixes) and tells the swarm at its first contact, so its whole task is reopened."""
        env = self.env
        if env.on_map[i]:
            self._release_work(i, self._hearers(i))
        else:
            self._release_work(i, env.alive.copy())

    def _on_find(self, finder: int, k: int) -> None:
        """A find becomes a mark item, known to the finder's radio component; the finder searches on."""
        env = self.env
        search = env.search_task
        if search is None or not search.mark or not env.alive[finder]:
            return
        if any(it.kind == "mark" and it.obj == k for it in self.items):
            return
        audience = self._hearers(finder)
        audience[finder] = True
        self._news = True
        self.items.append(WorkItem("mark", ROLES[env.role[finder]], env.objects_m[k].copy(), obj=k,
                                   audience=audience, created_s=env.t_s))  # fmt: skip

    def spread(self) -> None:
        """Pass news of open work over the radio graph when it has been updated (all `update` does
        on a step with a new graph and nothing else due)."""
        self._spread()

    def _spread(self) -> None:
        env = self.env
        if env.links_version == self._links_seen:
            return  # news travels only when the radio graph is updated
        self._links_seen = env.links_version
        comp = env.links.component[: env.n]
        alive = env.alive
        seen = (comp.tobytes(), alive.tobytes())
        if not self._news and seen == self._spread_seen:
            return  # a spread is idempotent: the same components and robots reach no one new
        self._spread_seen = seen
        self._news = False
        open_items = [it for it in self.items if it.taken_by < 0 and it.audience.any()]
        if not open_items:
            return
        # every open item at once: the components its audience reaches (+1: -1 is none), then all of
        # each reached component's robots
        heard = np.array([it.audience for it in open_items]) & alive
        reached = np.zeros((len(open_items), int(comp.max(initial=-1)) + 2), bool)
        item, robot = np.nonzero(heard)
        reached[item, comp[robot] + 1] = True
        for it, audience in zip(open_items, (heard | reached[:, comp + 1]) & alive, strict=True):
            it.audience = audience

    # who is free ----------------------------------------------------------------------------------------
    def _idle(self) -> np.ndarray:
        """Robots free for work: alive ashore, spares or searchers, following a route they have
        finished, marking nothing, not on their way back to sea."""
        e = self.env
        cursor, end = e.routes.cursor, e.routes.end
        return _idle_robots(e.alive, e.on_map, e.role, e.command, cursor, end, e.marking, e.phase)

    def _allocate(self) -> None:
        """Hand open items to idle robots that know of them, most valuable first: stations (a lost
        landing, relay, surveillance or beacon robot's point: each a whole criterion), then the
        pieces of lost tracks (each a sliver of the detection), then marks, and marks only when
        they are due (`_marks_due`): a robot loitering on a mine early can neither finish a lost
        searcher's track nor dodge the hazards while it waits. In the last `STAND_BY_LEAD_S` of
        beach operations the stand-bys at end-held beacons (`_stand_by`) come before the tracks
        too, and stay out of their auctions.

        Who is idle is worked out again after each step that may send robots off (a stand-by, an
        auction, parking), and only then."""
        env = self.env
        idle = self._idle()
        if not idle.any():
            return  # every step below waits for an idle robot, and none becomes idle meanwhile
        late = self._stand_by_first()
        if late:
            self._stand_by(idle)
            idle = self._idle()
        open_items = [it for it in self.items if it.taken_by < 0]  # no item is opened meanwhile
        routes = [it for it in open_items if it.kind == "route"]
        stations = [it for it in routes if not it.track]
        if stations and idle.any():
            self._auction(stations, idle)
            idle = self._idle()
        kept = self._standing_by(idle) if late else np.zeros(env.n, bool)
        idle = idle & ~kept
        tracks = [it for it in routes if it.track and it.taken_by < 0]
        if tracks and idle.any():
            self._auction(tracks, idle)
            idle = self._idle() & ~kept
        marks = [it for it in open_items if it.kind == "mark" and env.object_marker[it.obj] < 0]
        if marks and idle.any():
            knows_route = np.zeros(env.n, bool)
            for it in routes:
                if it.taken_by < 0:  # still open after the auctions
                    knows_route |= it.audience
            free = idle & ~knows_route
            due = self._marks_due(marks, free)
            if due and free.any():
                c = env.clearance
                self._auction(due, free, arrive_by_s=None if c is None else c.at_s)
        self._park(self._idle())
        if not late:
            self._stand_by(self._idle())

    def _stand_by_first(self) -> bool:
        """Whether the stand-bys come before the tracks: in the last `STAND_BY_LEAD_S` of beach
        operations."""
        env = self.env
        return env.t_s + STAND_BY_LEAD_S >= env.mission.beach_end_s

    def _end_held_points(self) -> list[tuple[np.ndarray, int]]:
        """The points that must be held when beach operations end (beacons without `hold_s`), each
        with the robots it needs."""
        return [
            (point, st.needed)
            for st in self.env.score.beacons
            if st.required_s is None
            for point in st.points_m
        ]

    def _standing_by(self, idle: np.ndarray) -> np.ndarray:
        """The robots of `idle` whose route ends at a point that must be held at the end."""
        env = self.env
        goals = self._station_goals()
        out = np.zeros(env.n, bool)
        for point, _ in self._end_held_points():
            out |= np.hypot(*(goals - point).T) <= STATION_RADIUS_M
        return out & idle

    def _stand_by(self, idle: np.ndarray) -> None:
        """Once no clearance is pending, a point that must be held at the end of beach operations
        (a beacon without `hold_s`) gets one robot more than it needs, the nearest idle one: a
        beacon robot lost in the last minutes cannot be replaced from across the beach in time
        (full_conops failed its beacon criterion that way). In the last `STAND_BY_LEAD_S` it does
        not wait for a clearance still to come: it goes to the point, or, when the point lies in a
        found mine's standoff, waits on the nearest safe ground and moves in once the mines are
        cleared (waiting for the clearance left full_conops's stand-bys 440 m away, still
        driving, when a beacon robot failed 50 s before the end). A stand-by stays idle: it takes
        over like any other, and another comes when it leaves."""
        env = self.env
        if self._returning or not idle.any():
            return
        pending = env.clearance is not None and self._clearance_state != "done"
        if pending and not self._stand_by_first():
            return
        objs, safe_m, _ = self._inside_standoff(np.empty(0, dtype=np.intp)) if pending else (None, 0.0, None)
        goals = self._station_goals()
        here = env.alive & env.on_map
        points = self._end_held_points()
        # a robot already holding or standing by at one of the points is never moved to another
        at_a_point = np.zeros(env.n, bool)
        for point, _ in points:
            at_a_point |= np.hypot(*(goals - point).T) <= STATION_RADIUS_M
        idle = idle & ~at_a_point
        for point, needed in points:
            near = here & (np.hypot(*(goals - point).T) <= STATION_RADIUS_M)
            if np.count_nonzero(near) > needed or not idle.any():
                continue
            cand = np.flatnonzero(idle)
            i = int(cand[np.argmin(np.hypot(*(env.robot_state[cand, :2] - point).T))])
            goal = point
            if objs is not None and len(objs) and float(np.min(np.hypot(*(objs - point).T))) < safe_m:
                goal = self._safe_ground(objs, safe_m).path(env.router.snap(point))[-1]
                self._waiting[i] = point.copy()
            env.set_route(i, env.router.route(env.robot_state[i, :2], goal))
            idle[i] = False

    def _station_goals(self) -> np.ndarray:
        """Where each robot's route ends, or, for a stand-by waiting out a clearance, the point
        it waits to hold."""
        goals = self.env.route_goal().copy()
        for i, point in self._waiting.items():
            goals[i] = point
        return goals

    def _park(self, idle: np.ndarray) -> None:
        """Idle robots wait clear of the standoff of every mine found so far while a clearance is
        pending: one left waiting beside a marked mine may not get clear in the clearance lead (a
        detour around blocked ground), and parking early costs nothing when it has no work."""
        if self.env.clearance is None or self._clearance_state != "before" or not idle.any():
            return
        objs, safe_m, near = self._inside_standoff(np.flatnonzero(idle))
        for i in near:
            self._retreat(int(i), objs, safe_m)

    def _inside_standoff(self, who: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
        """The mines found so far, how far to keep from them (the clearance standoff and the
        margin), and which of the robots `who` are closer than that to one: every pair (a few
        robots and at most a few hundred finds; a k-d tree's query costs more), each distance
        the square root of dx^2 + dy^2, as a k-d tree's."""
        env = self.env
        objs = self._found_mines()
        safe_m = env.clearance.standoff_m + STANDOFF_MARGIN_M
        if not len(objs) or not len(who):
            return objs, safe_m, who[:0]
        xy = env.robot_state[who, :2]
        dx = xy[:, None, 0] - objs[None, :, 0]
        dy = xy[:, None, 1] - objs[None, :, 1]
        return objs, safe_m, who[np.sqrt((dx * dx + dy * dy).min(axis=1)) < safe_m]

    def _found_mines(self) -> np.ndarray:
        """Where the objects of the mark items are, in object order (kept while the items and the
        objects stay the same)."""
        env = self.env
        key = (len(self.items), len(env.objects_m), id(env.objects_m))
        if self._found_cache is None or self._found_cache[0] != key:
            found = sorted({it.obj for it in self.items if it.kind == "mark"})
            self._found_cache = (key, env.objects_m[found])
        return self._found_cache[1]

    def _marks_due(self, marks: list[WorkItem], free: np.ndarray) -> list[WorkItem]:
        """The marks that are due: all once nobody is searching any more, else those whose nearest
        robot free to take it (and knowing of it) must set off to be on the mine before the
        clearance (with the retreat factor's slack and `MARK_SLACK_S` to spare); with no
        clearance, all at once."""
        env = self.env
        c = env.clearance
        if c is None or not (env.routes.in_track() & env.alive).any():
            return marks
        cand = np.array([it.audience for it in marks]) & free  # (marks, n)
        starts = np.array([it.start_m for it in marks])
        xy = env.robot_state[:, :2]
        dist = np.hypot(xy[None, :, 0] - starts[:, None, 0], xy[None, :, 1] - starts[:, None, 1])
        gap = np.where(cand, dist, np.inf).min(axis=1)
        travel = RETREAT_TIME_FACTOR * gap / env.limits.cruise_speed_mps
        due = cand.any(axis=1) & (env.t_s + travel + MARK_SLACK_S >= c.at_s - self.lead_s())
        return [it for it, d in zip(marks, due.tolist(), strict=True) if d]

    def _auction(
        self, open_items: list[WorkItem], idle: np.ndarray, arrive_by_s: float | None = None
    ) -> None:
        """Assign `open_items` to `idle` robots that know of them, cost the straight-line distance.
        With `arrive_by_s` (a mark before the clearance), a robot that cannot be there by then (at
        cruise speed, with the retreat factor's slack and allowance) is not sent: the trip would
        end with the mark given up deep among the other marked mines as the blast goes off."""
        env = self.env
        xy = env.robot_state[:, :2]
        starts = np.array([it.start_m for it in open_items])
        cost = np.hypot(xy[:, None, 0] - starts[None, :, 0], xy[:, None, 1] - starts[None, :, 1])
        audience = np.array([it.audience for it in open_items]).T  # (n, items)
        if arrive_by_s is not None:
            travel_s = RETREAT_TIME_FACTOR * cost / env.limits.cruise_speed_mps + RETREAT_ALLOWANCE_S
            audience = audience & (env.t_s + travel_s < arrive_by_s)
            for i, k in self._gave_up:  # its route there was longer than the straight line
                audience[i, [j for j, it in enumerate(open_items) if it.obj == k]] = False
        cost = np.where(audience, cost, np.inf)
        able = idle & np.isfinite(cost).any(axis=1)
        if not able.any():
            return
        result = auction(cost, active_robots=able, active_tasks=np.isfinite(cost[able]).any(axis=0))
        for i in np.flatnonzero(result.assignment >= 0):
            it = open_items[int(result.assignment[i])]
            self._take(int(i), it)

    def _take(self, i: int, it: WorkItem) -> None:
        env = self.env
        it.taken_by = i
        self._waiting.pop(i, None)
        if it.track:
            self._doing[i] = it
        else:
            self._doing.pop(i, None)
        env.log_event("takeover", i, item=it.kind, role=it.role, obj=it.obj)
        if it.kind == "mark":
            env.set_command(i, MARK, env.objects_m[it.obj])
            return
        path = env.router.route(env.robot_state[i, :2], it.start_m)
        rest, _ = env.router.stitch(np.vstack([path[-1:], it.waypoints_m[1:]]))
        env.set_route(
            i, np.vstack([path, rest[1:]]), role=it.role, track_from=len(path) - 1 if it.track else None
        )

    # battery, clearance, return --------------------------------------------------------------------------
    def _battery(self) -> None:
        env = self.env
        low = env.energy_wh <= self._reserve_wh
        if not low.any():
            return  # the usual step (and always without a return to sea): nobody is low
        low &= env.alive & env.on_map & (env.command != RETURN) & (env.marking < 0)
        for i in np.flatnonzero(low):
            self._release_work(int(i), self._hearers(int(i)))
            env.set_command(int(i), RETURN)
            env.log_event("battery_reserve", int(i))

    def lead_s(self) -> float:
        """How long before the detonation robots start clearing the standoff."""
        return self._lead_s

    def _clearance_lead_s(self) -> float:
        """`lead_s`: `clearance_lead_s`, or longer when the standoff is far to drive."""
        c = self.env.clearance
        if c is None:
            return self.clearance_lead_s
        drive_s = (c.standoff_m + STANDOFF_MARGIN_M) / self.env.limits.cruise_speed_mps
        return max(self.clearance_lead_s, RETREAT_TIME_FACTOR * drive_s + RETREAT_ALLOWANCE_S)

    def _clearance(self) -> None:
        env = self.env
        c = env.clearance
        if c is None or self._clearance_state == "done":
            return
        left = c.at_s - env.t_s
        if self._clearance_state == "before" and left > self._watch_s:
            return  # too early for either check below
        if self._clearance_state == "before" and left <= HOLD_HORIZON_S and len(self._late_markers(left)):
            self._drop_late_markers(left)  # the allocation parks them clear
        if self._clearance_state == "before" and self._hold_due():
            self._clearance_state = "holding"
            self._hold(left, c.standoff_m + STANDOFF_MARGIN_M)
        elif self._clearance_state == "holding" and not env.cleared:
            self._recheck_markers(left, c.standoff_m + STANDOFF_MARGIN_M)
        elif self._clearance_state == "holding" and env.cleared:
            self._clearance_state = "done"
            for i, (rest, in_track) in self._held.items():
                if not env.alive[i]:
                    continue
                path = env.router.route(env.robot_state[i, :2], rest[0])
                more, _ = env.router.stitch(np.vstack([path[-1:], rest[1:]]))
                wp = np.vstack([path, more[1:]])
                env.set_route(i, wp, track_from=len(path) - 1 if in_track else None)
            self._held.clear()
            for i, point in self._waiting.items():
                if env.alive[i] and env.marking[i] < 0:
                    env.set_route(i, env.router.route(env.robot_state[i, :2], point))
            self._waiting.clear()

    def _hold_due(self) -> bool:
        """Time to hold: `lead_s` before the detonation, or earlier when a robot within a found
        mine's standoff is so far from the nearest safe point that it needs longer to get there
        (at cruise speed, with the retreat factor and allowance): several marked mines close
        together can leave a robot on a takeover track 100 m from safe ground."""
        env = self.env
        c = env.clearance
        left = c.at_s - env.t_s
        if left <= self.lead_s() + 1e-9:
            return True
        if left > HOLD_HORIZON_S:
            return False
        safe_m = c.standoff_m + STANDOFF_MARGIN_M
        ground = self._safe_cached(self._found_mines(), safe_m)
        if ground is not None and self._retreat_s(ground.reach_m) < left:
            return False  # not even the farthest cell from safe ground is that far
        objs, safe_m, near = self._inside_standoff(np.flatnonzero(env.alive & env.on_map & (env.marking < 0)))
        if not len(near):
            return False
        starts = env.router.snap_many(env.robot_state[near, :2])
        far = self._safe_ground(objs, safe_m).farthest_m(starts)
        return far >= 0.0 and self._retreat_s(far) >= left

    def _retreat_s(self, distance_m: float | np.ndarray) -> float | np.ndarray:
        """The time allowed to retreat `distance_m` over free ground (at cruise speed, with the
        retreat factor and allowance)."""
        return RETREAT_TIME_FACTOR * distance_m / self.env.limits.cruise_speed_mps + RETREAT_ALLOWANCE_S

    def _hold(self, time_left_s: float, safe_m: float) -> None:
        """Everyone but the markers stops; those within `safe_m` of a marked mine move clear first.

        A robot on its way to mark a mine keeps going if it can get there in `time_left_s`
        (`_arrivals_s`), else it gives the mark up and retreats; `_recheck_markers` keeps asking."""
        env = self.env
        objs = env.objects_m[self._drop_late_markers(time_left_s)]
        for i in np.flatnonzero(env.alive & env.on_map & (env.marking < 0)):
            xy = env.robot_state[i, :2]
            rest = env.routes.remaining(i)
            # a robot on station (route done) comes back to where it stands once the blast is over
            self._held[int(i)] = (rest if len(rest) else xy[None].copy(), bool(env.routes.in_track()[i]))
            if len(objs) and float(np.min(np.hypot(*(objs - xy).T))) < safe_m:
                self._retreat(int(i), objs, safe_m)
                continue
            env.set_command(int(i), LOITER)

    def _arrivals_s(self, who: np.ndarray) -> np.ndarray:
        """The time each marker of `who` needs to reach its object: the rest of its route (at
        least the straight line) at cruise speed, with the retreat factor's slack and allowance."""
        env = self.env
        xy = env.robot_state[who, :2]
        straight = env.objects_m[env.marking[who]] - xy
        length = np.maximum(env.routes.remaining_m(who, xy), np.hypot(straight[:, 0], straight[:, 1]))
        return self._retreat_s(length)

    def _drop_late_markers(self, time_left_s: float) -> np.ndarray:
        """Robots on their way to mark a mine that can no longer get there before the detonation
        give the mark up (the mine stays unmarked). The objects that will be marked: those with
        their marker on them, and those a marker is still on its way to."""
        env = self.env
        marked = env.object_marker >= 0
        who = self._markers_on_the_way()  # one on its mine goes with it
        on_time = (self._arrivals_s(who) < time_left_s).tolist()
        for i, in_time in zip(who.tolist(), on_time, strict=True):
            k = int(env.marking[i])
            if in_time:
                marked[k] = True  # it will be there: keep clear of that mine too
                continue
            for it in self.items:
                if it.kind == "mark" and it.obj == k and it.taken_by == i:
                    it.taken_by = -1
                    self._news = True
            self._gave_up.add((i, k))
            env.set_command(i, LOITER)  # drops the mark
        return marked

    def _late_markers(self, time_left_s: float) -> np.ndarray:
        """The markers on their way (`_markers_on_the_way`) that can no longer reach their mine in
        `time_left_s` (`_arrivals_s`), in index order: one compiled pass in the same arithmetic
        (the clearance asks at every step of its watch, and almost always nobody is late)."""
        env = self.env
        routes = env.routes
        late = np.empty(env.n, np.intp)
        count = _late_markers(
            env.alive, env.on_map, env.marking, env.object_marker, env.robot_state, env.objects_m,
            routes.points, routes.cursor, routes.end, RETREAT_TIME_FACTOR,
            float(env.limits.cruise_speed_mps), RETREAT_ALLOWANCE_S, float(time_left_s), late,
        )  # fmt: skip
        return late[:count]

    def _markers_on_the_way(self) -> np.ndarray:
        """The robots marking a mine that are not on it yet, in index order."""
        env = self.env
        who = np.flatnonzero(env.alive & env.on_map & (env.marking >= 0))
        return who[env.object_marker[env.marking[who]] != who]

    def _recheck_markers(self, time_left_s: float, safe_m: float) -> None:
        """During the hold, a marker that falls behind (detours, soft ground, a roll-over) gives
        the mark up as soon as it can no longer make it, and gets clear like everyone else (before
        the hold, `_clearance` drops it and the allocation parks it clear)."""
        env = self.env
        late = self._late_markers(time_left_s).tolist()
        if not late:
            return
        objs = env.objects_m[self._drop_late_markers(time_left_s)]
        for i in late:
            xy = env.robot_state[i, :2]
            self._held[i] = (xy[None].copy(), False)
            if len(objs) and float(np.min(np.hypot(*(objs - xy).T))) < safe_m:
                self._retreat(i, objs, safe_m)

    def _retreat(self, i: int, objs: np.ndarray, safe_m: float) -> None:
        """Route robot i over free ground to the nearest point `safe_m` clear of every point of
        `objs` (`swarm.sim.standoff`)."""
        env = self.env
        xy = env.robot_state[i, :2]
        path = self._safe_ground(objs, safe_m).path(env.router.snap(xy))
        env.set_route(i, np.vstack([xy[None], path]))

    def _safe_cached(self, objs: np.ndarray, safe_m: float) -> SafeGround | None:
        """`_safe_ground` of these objects if it has been built already, else None."""
        cache = self._safe_cache
        if cache is None:
            return None
        if (cache[2] is objs and cache[0][1] == safe_m) or cache[0] == (objs.tobytes(), safe_m):
            return cache[1]  # the first test: `_found_mines` hands out the same array until they change
        return None

    def _safe_ground(self, objs: np.ndarray, safe_m: float) -> SafeGround:
        """Distances to safe ground from everywhere (kept until the objects change: robots park
        and hold against the same finds many times)."""
        ground = self._safe_cached(objs, safe_m)
        if ground is None:
            ground = SafeGround(self.env.plan.costmap, objs, safe_m, dry=self.env.dry_ground)
            self._safe_cache = ((objs.tobytes(), safe_m), ground, objs)
        return ground

    def _return(self) -> None:
        if self._returning:
            return
        env = self.env
        phases = env.mission.phases
        if not phases.return_to_sea.enabled or env.t_s + 1e-9 < env.mission.beach_end_s:
            return
        self._returning = True
        for i in np.flatnonzero(env.alive & env.on_map & (env.marking < 0)):
            env.set_command(int(i), RETURN)


def battery_reserve_wh(mission: Mission) -> float:
    """The charge at which a robot heads back to sea (-inf without a return to sea: never)."""
    if not mission.phases.return_to_sea.enabled:
        return -math.inf
    battery = mission.hazards.battery
    return battery.reserve_fraction * battery.capacity_wh


class BatchPolicy:
    """The scripted policies of a batch's runs (`swarm.sim.world`), each run's `update` called only
    when it may do something (`ScriptedPolicy.quiet_until_s`, new events, a new radio graph, a
    battery at its reserve): most steps of most runs it would change nothing, and the calls were a
    third of a batch's policy time. The same commands and routes as updating every run every step."""

    def __init__(self, runs: list[RunView]) -> None:
        self.runs = runs
        self.policies = [ScriptedPolicy(run) for run in runs]
        self.world = runs[0].world
        self._reserve_wh = battery_reserve_wh(runs[0].mission)
        b = len(runs)
        self._quiet_until_s = np.full(b, -math.inf)
        self._links_read = np.full(b, -1, dtype=np.int64)

    def update(self, live: list[int]) -> None:
        """Update the policies of the runs `live` that may act this step."""
        world = self.world
        # waking early is harmless (`update` finds nothing to do), so the times compare with slack
        low = (world.energy_wh <= self._reserve_wh).any(axis=1)
        due = ((world.t_s + 1e-6 >= self._quiet_until_s) | low).tolist()
        heard = (world.links_version != self._links_read).tolist()
        low = low.tolist()
        runs, policies = self.runs, self.policies
        for b in live:
            policy = policies[b]
            if due[b] or policy.events_read != len(runs[b].events):
                policy.update(battery_low=low[b])
                self._quiet_until_s[b] = policy.quiet_until_s()
                self._links_read[b] = policy.links_read
            elif heard[b]:  # a new radio graph alone: of all `update` does, only news can travel
                policy.spread()
                self._links_read[b] = policy.links_read


@numba.njit(cache=True)
def _idle_robots(alive, on_map, role, command, cursor, end, marking, phase):
    """`ScriptedPolicy._idle` robot by robot (an allocation asks up to six times: one pass instead
    of a dozen numpy calls on a few dozen robots)."""
    out = np.empty(alive.shape[0], np.bool_)
    for i in range(alive.shape[0]):
        out[i] = (
            alive[i]
            and on_map[i]
            and (role[i] == SPARE or role[i] == SEARCH)
            and command[i] == FOLLOW
            and cursor[i] >= end[i]
            and marking[i] < 0
            and phase[i] != RETURNING
            and phase[i] >= SEA
        )
    return out


@numba.njit(cache=True, error_model="numpy")
def _late_markers(
    alive, on_map, marking, object_marker, state, objects_m, points, cursor, end, factor, cruise_mps,
    allowance_s, time_left_s, late,
):  # fmt: skip
    """`ScriptedPolicy._late_markers` robot by robot, writing the late ones' indices to `late`
    and returning how many: a marker on its way (alive, ashore, its object not marked by it) whose
    route's rest (`rest_of_route_m`), at least the straight line to its object, takes
    `factor * length / cruise_mps + allowance_s` or longer."""
    count = 0
    legs = np.empty(0)
    for i in range(alive.shape[0]):
        k = marking[i]
        if not (alive[i] and on_map[i] and k >= 0) or object_marker[k] == i:
            continue
        x, y = state[i, 0], state[i, 1]
        if end[i] - cursor[i] > legs.shape[0]:
            legs = np.empty(2 * (end[i] - cursor[i]))
        rest = rest_of_route_m(points, cursor[i], end[i], x, y, legs)
        straight = np.hypot(objects_m[k, 0] - x, objects_m[k, 1] - y)
        if math.isnan(rest) or math.isnan(straight):
            length = math.nan
        else:
            length = rest if rest >= straight else straight  # np.maximum's pick
        if factor * length / cruise_mps + allowance_s >= time_left_s:
            late[count] = i
            count += 1
    return count
