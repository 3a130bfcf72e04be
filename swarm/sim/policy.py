"""The built-in scripted coordination policy: follow the plan, and when robots are lost, hand their
work to the survivors that can hear about it.

It drives the environment in command mode. Each step it:

1. Reads the new events. A lost robot's work becomes an open *work item*: the rest of its search
   track, its station (landing, relay, surveillance or beacon point; relays are how the chain heals),
   or the mine it was marking. A robot that found a mine makes a *mark* item.
2. Spreads the news over the radio: an item is known first to the robots in the lost (or finding)
   robot's radio component at the time, then to every component that contains a robot that knows
   it, as links come and go. Jammed or isolated robots learn nothing.
3. Every `realloc_period_s`, assigns open items to idle robots that know of them (spares, and
   searchers whose track is done) with the forward auction of `swarm.planning.allocation`, cost the
   straight-line distance to the item; the winner gets a route there (`swarm.sim.router`).
   A mine found with no idle robot within `MARK_HELP_M` is marked by its finder, whose remaining
   track becomes an item.
4. Before the synchronized clearance (`clearance_lead_s` ahead), robots inside a marked mine's
   standoff (plus a margin) move out and everyone else holds until the detonation, then resumes.
5. At the end of beach operations (with the return to sea enabled), and for any robot whose battery
   falls to the reserve, the command is "return to sea".
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from swarm.planning.allocation import auction
from swarm.sim.env import FOLLOW, LOITER, MARK, RETURN, RETURNING, SEA, SwarmEnv
from swarm.sim.layout import ROLES

#: A mine's finder asks an idle robot within this distance to mark it, else marks it itself (m).
MARK_HELP_M = 60.0
#: Extra distance beyond the clearance standoff that robots retreat to (m).
STANDOFF_MARGIN_M = 10.0
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


class ScriptedPolicy:
    """Coordination by script over an environment made with action_mode="command"."""

    def __init__(
        self, env: SwarmEnv, *, realloc_period_s: float = 5.0, clearance_lead_s: float = 120.0
    ) -> None:
        if env.action_mode != "command":
            raise ValueError("ScriptedPolicy needs an environment with action_mode='command'")
        self.env = env
        self.realloc_period_s = realloc_period_s
        self.clearance_lead_s = clearance_lead_s
        self.reset()

    def reset(self) -> None:
        self.items: list[WorkItem] = []
        self._seen = 0
        self._next_alloc_s = 0.0
        self._held: dict[int, tuple[np.ndarray, bool]] = {}
        self._clearance_state = "before"
        self._returning = False
        self._links_seen = -1

    # the step ------------------------------------------------------------------------------------
    def act(self) -> dict[str, dict]:
        """This step's command for every live agent (the environment's command action space)."""
        self.update()
        env = self.env
        return {
            a: {"command": int(env.command[i]), "target": env.target_m[i].astype(np.float32)}
            for a in env.agents
            for i in (env.agent_index[a],)
        }

    def update(self) -> None:
        """Coordinate: set the environment's commands and routes for this step directly (a runner
        then calls `env.advance({})`)."""
        env = self.env
        if env.steps == 0 and self._seen > len(env.events):
            self.reset()
        self._read_events()
        self._spread()
        self._battery()
        self._clearance()
        self._return()
        if env.t_s + 1e-9 >= self._next_alloc_s:
            self._next_alloc_s = env.t_s + self.realloc_period_s
            self._allocate()

    # events -> work items ----------------------------------------------------------------------------
    def _read_events(self) -> None:
        env = self.env
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
        reopened = False
        for it in self.items:  # work it had taken over from others is open again
            if it.taken_by != i:
                continue
            it.taken_by, it.audience, reopened = -1, audience.copy(), True
            if it.track:
                rest = env.routes.remaining_track(i)
                if len(rest):
                    it.start_m, it.waypoints_m = rest[0].copy(), rest
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
            goal = env._route_goal()[i]
            self.items.append(WorkItem("route", ROLES[role], goal.copy(), goal[None].copy(),
                                       audience=audience, created_s=t))  # fmt: skip
        elif role == SEARCH:
            rest = env.routes.remaining_track(i)
            if len(rest):
                self.items.append(WorkItem("route", "search", rest[0].copy(), rest, track=True,
                                           audience=audience, created_s=t))  # fmt: skip

    def _on_loss(self, i: int) -> None:
        self._release_work(i, self._hearers(i))

    def _on_find(self, finder: int, k: int) -> None:
        env = self.env
        search = env.search_task
        if search is None or not search.mark or not env.alive[finder]:
            return
        hear = self._hearers(finder)
        idle = self._idle() & hear
        obj = env.objects_m[k]
        if idle.any():
            cand = np.flatnonzero(idle)
            d = np.hypot(*(env.robot_state[cand, :2] - obj).T)
            if d.min() <= MARK_HELP_M:
                j = int(cand[int(np.argmin(d))])
                env.set_command(j, MARK, obj)
                return
        # the finder marks it; the rest of its track goes to whoever can take it
        self._release_work(finder, hear)
        env.set_command(finder, MARK, obj)

    def _spread(self) -> None:
        env = self.env
        if env.links_version == self._links_seen:
            return  # news travels only when the radio graph is updated
        self._links_seen = env.links_version
        comp = env.links.component[: env.n]
        alive = env.alive
        for it in self.items:
            if it.taken_by >= 0 or not it.audience.any():
                continue
            known = np.unique(comp[it.audience & alive])
            it.audience = (it.audience | np.isin(comp, known)) & alive

    # who is free ----------------------------------------------------------------------------------------
    def _idle(self) -> np.ndarray:
        env = self.env
        free_role = (env.role == SPARE) | (env.role == SEARCH)
        return (
            env.alive
            & env.on_map
            & free_role
            & (env.command == FOLLOW)
            & env.routes.done()
            & (env.marking < 0)
            & (env.phase != RETURNING)
            & (env.phase >= SEA)
        )

    def _allocate(self) -> None:
        env = self.env
        open_items = [it for it in self.items if it.taken_by < 0 and it.kind in ("route", "mark")]
        open_items = [it for it in open_items if not (it.kind == "mark" and env.object_marker[it.obj] >= 0)]
        if not open_items:
            return
        idle = self._idle()
        if not idle.any():
            return
        xy = env.robot_state[:, :2]
        starts = np.array([it.start_m for it in open_items])
        cost = np.hypot(xy[:, None, 0] - starts[None, :, 0], xy[:, None, 1] - starts[None, :, 1])
        audience = np.array([it.audience for it in open_items]).T  # (n, items)
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
        env._event("takeover", i, item=it.kind, role=it.role, obj=it.obj)
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
        if not env.mission.phases.return_to_sea.enabled:
            return
        b = env.mission.hazards.battery
        low = env.alive & env.on_map & (env.energy_wh <= b.reserve_fraction * b.capacity_wh)
        low &= (env.command != RETURN) & (env.marking < 0)
        for i in np.flatnonzero(low):
            self._release_work(int(i), self._hearers(int(i)))
            env.set_command(int(i), RETURN)
            env._event("battery_reserve", int(i))

    def _clearance(self) -> None:
        env = self.env
        c = env.clearance
        if c is None or self._clearance_state == "done":
            return
        if self._clearance_state == "before" and env.t_s + 1e-9 >= c.at_s - self.clearance_lead_s:
            self._clearance_state = "holding"
            marked = env.object_marker >= 0
            objs = env.objects_m[marked]
            for i in np.flatnonzero(env.alive & env.on_map & (env.marking < 0)):
                xy = env.robot_state[i, :2]
                rest = env.routes.remaining(i)
                in_track = bool(env.routes.in_track()[i])
                self._held[int(i)] = (rest, in_track)
                if len(objs):
                    d = np.hypot(*(objs - xy).T)
                    j = int(np.argmin(d))
                    if d[j] < c.standoff_m + STANDOFF_MARGIN_M:
                        away = xy - objs[j]
                        norm = float(np.hypot(*away)) or 1.0
                        goal = objs[j] + away / norm * (c.standoff_m + STANDOFF_MARGIN_M)
                        env.set_route(int(i), env.router.route(xy, goal))
                        continue
                env.set_command(int(i), LOITER)
        elif self._clearance_state == "holding" and env.cleared:
            self._clearance_state = "done"
            for i, (rest, in_track) in self._held.items():
                if not env.alive[i]:
                    continue
                if len(rest):
                    path = env.router.route(env.robot_state[i, :2], rest[0])
                    more, _ = env.router.stitch(np.vstack([path[-1:], rest[1:]]))
                    wp = np.vstack([path, more[1:]])
                    env.set_route(i, wp, track_from=len(path) - 1 if in_track else None)
                else:
                    env.set_route(i, env.robot_state[i, :2][None])
            self._held.clear()

    def _return(self) -> None:
        env = self.env
        rts = env.mission.phases.return_to_sea
        if self._returning or not rts.enabled or env.t_s + 1e-9 < env.mission.phases.beach_end_s:
            return
        self._returning = True
        for i in np.flatnonzero(env.alive & env.on_map & (env.marking < 0)):
            env.set_command(int(i), RETURN)
