"""`RunView`: one run of a batch (`swarm.sim.world.World`), the interface the scripted policy, the
PettingZoo adapter and the log read and command a run through.

Its per-robot arrays (`robot_state`, `alive`, `on_map`, `phase`, `role`, `command`, `target_m`,
`marking`, `energy_wh`, ...) are views of the batch's (B, n, ...) arrays: write them in place,
never rebind them. Its own objects (mine field, sensor, radio net and links, score, events,
objects to mark, random streams, router) belong to the run alone. The event-driven mechanics of a
run (commands that plan a route, marks, losses) are its methods; the per-step physics and rules
run batch-wide in `World.advance`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from swarm.errors import SwarmError
from swarm.sim import hazards
from swarm.sim.layout import PHASES, ROLES

if TYPE_CHECKING:
    from swarm.sim.world import World

COMMANDS = ("follow", "goto", "loiter", "mark", "relay", "return")
FOLLOW, GOTO, LOITER, MARK, RELAY, RETURN = range(len(COMMANDS))
WAITING, SEA, SURF, BEACH, RETURNING, DONE = range(len(PHASES))
#: Robots keep this far from a mine that has been found and is not yet marked (m): four times the
#: trigger radius (`swarm.sim.mines.DEFAULT_TRIGGER_RADIUS_M`), room for the track-following error.
AVOID_MINE_M = 1.0

#: The per-robot arrays a run shares with its batch (views of `World`'s arrays of the same name).
ROBOT_ARRAYS = (
    "robot_state",
    "alive",
    "on_map",
    "phase",
    "energy_wh",
    "inverted",
    "radio_ok",
    "sea_time_s",
    "surf_time_s",
    "isolated_s",
    "slip",
    "submersion",
    "terrain_now",
    "distance_m",
    "lost_at",
    "command",
    "target_m",
    "marking",
    "mark_placed",
    "role",
)


class RunView:
    """Run `b` of a `World` (module docstring)."""

    def __init__(self, world: World, b: int) -> None:
        self.world = world
        self.b = b
        setup = world.setup
        self.setup = setup
        self.n = setup.n
        self.offset = b * setup.n
        self.bind()
        self.possible_agents = world.possible_agents
        self.agent_index = world.agent_index
        self.router = setup.router.fork()
        self.rngs: dict[str, np.random.Generator] = {}
        self.seed: int | None = None
        self.events: list[dict] = []
        self.end_reason: list[str | None] = [None] * self.n
        self._objects_m = np.empty((0, 2))
        self._object_marker = np.empty(0, dtype=np.int64)

    def bind(self) -> None:
        """Make this run's views of its world's arrays: the per-robot arrays, its routes and its
        sensor's last positions (again in a copy of the world: `World.__setstate__`)."""
        for name in ROBOT_ARRAYS:
            setattr(self, name, getattr(self.world, name)[self.b])
        self.routes = self.world.routes.view(self.offset, self.n)
        if getattr(self, "sensor", None) is not None:
            self.sensor._last_xy = self.world.sense_rows(self.b)

    def __getstate__(self) -> dict:
        """Without the views (`bind` makes them again): pickled, each would be an array of its own."""
        state = self.__dict__.copy()
        for name in (*ROBOT_ARRAYS, "routes"):
            state.pop(name, None)
        return state

    @property
    def objects_m(self) -> np.ndarray:
        """(objects, 2) where each object found is."""
        return self._objects_m

    @objects_m.setter
    def objects_m(self, xy: np.ndarray) -> None:
        self._objects_m = xy
        self.world.objects_version[self.b] += 1

    @property
    def object_marker(self) -> np.ndarray:
        """(objects,) the robot marking each object found (-1: none yet)."""
        return self._object_marker

    @object_marker.setter
    def object_marker(self, marker: np.ndarray) -> None:
        # the objects found change with it: the world keeps every run's count (`Observer` reads it)
        self._object_marker = marker
        self.world.object_count[self.b] = len(marker)
        self.world.objects_version[self.b] += 1

    def set_marker(self, k: int, i: int) -> None:
        """Object k's marker is now robot i (-1: none), as `Observer` learns from the world's count
        of changes."""
        self._object_marker[k] = i
        self.world.objects_version[self.b] += 1

    @property
    def links_version(self) -> int:
        """How many radio updates the run has had (the world keeps the count for every run)."""
        return int(self.world.links_version[self.b])

    # what the whole batch shares --------------------------------------------------------------------
    @property
    def mission(self):
        return self.setup.mission

    @property
    def plan(self):
        return self.setup.plan

    @property
    def beach(self):
        return self.setup.beach

    @property
    def limits(self):
        return self.setup.limits

    @property
    def clearance(self):
        return self.setup.clearance

    @property
    def search_task(self):
        return self.setup.search_task

    @property
    def relay_task(self):
        return self.setup.relay_task

    @property
    def fixed_m(self):
        return self.setup.fixed_m

    @property
    def time_limit_s(self) -> float:
        return self.setup.time_limit_s

    @property
    def dry_ground(self) -> np.ndarray:
        return self.setup.dry_ground

    # the run's clock ----------------------------------------------------------------------------------
    @property
    def t_s(self) -> float:
        return float(self.world.t_s[self.b])

    @t_s.setter
    def t_s(self, value: float) -> None:
        self.world.t_s[self.b] = value

    @property
    def steps(self) -> int:
        return int(self.world.steps[self.b])

    @steps.setter
    def steps(self, value: int) -> None:
        self.world.steps[self.b] = value

    @property
    def wave_phase_s(self) -> float:
        return float(self.world.wave_phase_s[self.b])

    @property
    def in_agents(self) -> np.ndarray:
        """(n,) bool: robots still in the episode (the adapters' `agents`)."""
        return self.world.in_agents[self.b]

    @property
    def running(self) -> bool:
        """Whether any robot of the run is still in its episode."""
        return bool(self.world.in_agents[self.b].any())

    # events ------------------------------------------------------------------------------------------
    def log_event(self, kind: str, robot: int | None = None, t_s: float | None = None, **data: Any) -> None:
        """Append an event at the run's time, or at `t_s` (with the robot's name and place when
        given)."""
        ev: dict[str, Any] = {"t_s": round(self.t_s if t_s is None else t_s, 3), "kind": kind}
        if robot is not None:
            ev["robot"] = self.possible_agents[robot]
            ev["x_m"] = round(float(self.robot_state[robot, 0]), 2)
            ev["y_m"] = round(float(self.robot_state[robot, 1]), 2)
        ev.update(data)
        self.events.append(ev)

    def global_phase(self, name: str) -> None:
        if name not in self.phase_seen:
            self.phase_seen.add(name)
            self.log_event("phase", phase=name)

    # commands and routes ---------------------------------------------------------------------------
    def set_command(self, i: int, command: int, target: np.ndarray | None = None) -> None:
        """Give robot i a high-level command (`COMMANDS`); used by command mode and the policy."""
        if not 0 <= command < len(COMMANDS):
            raise SwarmError(
                f"sim: command {command}, expected 0..{len(COMMANDS) - 1} ({', '.join(COMMANDS)})"
            )
        prev = self.command[i]
        self.command[i] = command
        if target is not None:
            self.target_m[i] = target
        if command == MARK and target is not None and len(self.objects_m):
            d = np.hypot(*(self.objects_m - target).T)
            k = int(np.argmin(d))
            if prev != MARK or self.marking[i] != k:
                # around obstacles, not into them: a robot pushing on a log spins until it is stuck
                self.routes.set(i, self.router.route(self.robot_state[i, :2], self.objects_m[k]))
                self._steer_clear_of_finds(i, marking=k)
            if self.marking[i] != k:
                self.mark_placed[i] = False
            self.marking[i] = k
            self.target_m[i] = self.objects_m[k]
        elif command != MARK and self.marking[i] >= 0:
            self.unmark(i)
        if command == RETURN and prev != RETURN and self.alive[i]:
            self.routes.set(i, self.setup.way_out.route(self.router, self.robot_state[i, :2]))
            self._steer_clear_of_finds(i)
            if self.on_map[i] and self.phase[i] >= BEACH:
                self.phase[i] = RETURNING
        if command in (LOITER, RELAY):
            self.target_m[i] = self.robot_state[i, :2]

    def set_route(
        self, i: int, waypoints: np.ndarray, role: str | None = None, track_from: int | None = None
    ) -> None:
        """Replace robot i's route (and role); it follows it under the `follow` command, clear of the
        objects found and not yet marked."""
        self.routes.set(i, waypoints, track_from)
        self._steer_clear_of_finds(i)
        if role is not None:
            self.role[i] = ROLES.index(role)
        self.command[i] = FOLLOW

    def _steer_clear_of_finds(self, i: int, marking: int = -1) -> None:
        """Side-step robot i's new route around the objects found and not yet marked, all but object
        `marking` (the one it is on its way to mark). Every route is laid this way: in mine_clear,
        robots driving to mark one mine set off others the swarm had found hours before."""
        open_ = self.object_marker < 0
        if marking >= 0:
            open_[marking] = False
        if open_.any():
            self.routes.steer_clear(i, self.robot_state[i, :2], self.objects_m[open_], AVOID_MINE_M)

    def route_goal(self) -> np.ndarray:
        """(n, 2) the last point of each robot's route (its own position without one)."""
        routes = self.routes
        end = np.maximum(routes.end - 1, 0)
        has = routes.end > routes.start
        goal = self.robot_state[:, :2].copy()
        if len(routes.points):
            goal[has] = routes.points[end[has]]
        return goal

    # marks and losses ----------------------------------------------------------------------------------
    def unmark(self, i: int) -> None:
        k = self.marking[i]
        self.marking[i] = -1
        self.mark_placed[i] = False
        if k >= 0 and self.object_marker[k] == i:
            self.set_marker(k, -1)
            if self.object_mine[k] >= 0:
                self.minefield.marked[self.object_mine[k]] = False
            self.log_event("unmark", int(i), object=int(k))

    def lose(self, i: int, cause: str, t_s: float | None = None, **data: Any) -> None:
        """Take robot i out of the mission now as lost to `cause`, and log it (at `t_s`: when
        within a stride skipped at sea it was lost, `World.fast_forward`)."""
        self.alive[i] = False
        self.end_reason[i] = cause
        at = self.t_s if t_s is None else t_s
        self.lost_at[i] = (at, self.robot_state[i, 0], self.robot_state[i, 1])
        if self.marking[i] >= 0:
            self.unmark(i)
        self.log_event("loss", i, t_s=t_s, cause=cause, phase=PHASES[self.phase[i]], **data)

    def lose_now(self, i: int, cause: str = "failure") -> None:
        """A what-if loss (`SwarmEnv.lose`): reported terminated on the next step, like any loss."""
        if cause not in hazards.CAUSES:
            raise SwarmError(f"sim: cause {cause!r}, expected one of {list(hazards.CAUSES)}")
        if not self.alive[i]:
            raise SwarmError(
                f"sim: {self.possible_agents[i]} is not in the mission any more ({self.end_reason[i]})"
            )
        self.lose(i, cause)
        self.world.pending_terminated[self.b, i] = True

    def outcome(self) -> dict:
        """The success criteria now (final after the last step)."""
        return self.score.outcome()
