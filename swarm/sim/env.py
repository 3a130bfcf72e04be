"""`SwarmEnv`: the mission as a PettingZoo `ParallelEnv`.

```python
import swarm.sim
env = swarm.sim.parallel_env(mission="missions/mine_clear.yaml", overrides={"swarm.count": 100})
obs, infos = env.reset(seed=1)
while env.agents:
    actions = {a: env.action_space(a).sample() for a in env.agents}
    obs, rewards, terminations, truncations, infos = env.step(actions)
```

Agents are `robot_0 ... robot_{n-1}` in launch order; an id is never reused. Every step (`dt_s`,
0.5 s by default) all robots advance together:

1. Release and sea transit. Robot i leaves the platform at `i * launch.interval_s` and swims the
   `launch.release_offshore_m` to its launch point off the map (a straight swim at
   `robot.swim_speed_mps`, drawing jet power; random failure applies), then appears at the launch
   point and is driven by its actions (platform `beach`: placed there, ashore).
2. Physics (`swarm.sim.physics`): the `skid` model with the coefficients of the cell under each
   robot, slope forces, jet thrust, drag on the water's velocity (longshore current, breaking-wave
   surges), turning over in the surf, obstacles.
3. Energy: wheel and jet power plus the hotel load drain the battery.
4. Sensing (`swarm.sim.sensing`): every robot ashore carries the mission's mine sensor (the first
   search task's); detections and false alarms become objects every robot can be told to mark.
5. Radio (`swarm.sim.comms`), every `comms_period_s`: two-ray links with log-normal shadowing among
   robots and the relay's fixed source and sinks; a jammed mission (`hazards.comms.cutoff_s`) has
   no links.
6. Hazards (`swarm.sim.hazards`): competing risks; a lost robot's final observation comes with
   terminated=True and info["lost_reason"], then it leaves `agents`.
7. Synchronized clearance at the search task's `clearance.at_s`: robots marking mines set them off
   (expended); any other robot within `standoff_m` of one is lost ("blast").
8. Success criteria (`swarm.sim.criteria`) and the team reward (the change of the score).

At the mission's time limit (end of beach operations, plus the return to sea when enabled) every
live robot is truncated. Robots back in open water after the return are picked up (terminated,
info["end_reason"] "recovered").

Actions (`action_mode`):
- "wheels": Box(-1, 1, (3,)): left and right wheel speed as a fraction of the largest wheel speed,
  and the jet thrust as a fraction of the largest (pushes only where the jet is submerged).
- "command": Dict(command=Discrete(6), target=Box(2)): `COMMANDS` = follow the planned route, go to
  the target point (straight), loiter, mark the object nearest the target, hold as a relay, return to
  sea. The built-in controller (`swarm.sim.control`) turns commands into wheel and jet commands.

Observations are fixed-shape float32 Boxes (`swarm.sim.layout`); `state()` is the global state for
centralized critics. `step_arrays` is `step` on arrays over all robots (rows in `possible_agents`
order), for batched adapters (`swarm.sim.vector_env`).

The task (what a robot sees, what it is rewarded for, when its episode ends, what its info says) is
a few public hooks on arrays over all robots, called by `reset`/`step` after the world has moved, in
the manner of HighwayEnv's `_reward` and VMAS's scenario; change the task by subclassing:

```python
class Closer(SwarmEnv):
    def observation_box(self):                      # the space of one robot's row
        return gymnasium.spaces.Box(-1e3, 1e3, (2,), np.float32)

    def observe(self):                              # (n, 2): position only
        return self.robot_state[:, :2].astype(np.float32)

    def reward(self, step: StepOutcome):            # (n,): the team reward, less a cost for turning
        return step.score_change - 0.01 * np.abs(self.robot_state[:, 5])
```

`terminated(step)` (who leaves now: by default those the world lost, expended or recovered) and
`info(robots)` (one dict per robot) are the other two. Rows of robots that are not in `agents` are
ignored, so a hook need not mask them.

Randomness: `reset(seed)` seeds one `SeedSequence`, spawned into independent streams for the mine
field, waves, sensing, radio, hazards and the policy, so changing one part of the model does not
reshuffle another's draws.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
from pettingzoo import ParallelEnv
from scipy import ndimage
from scipy.spatial import cKDTree

from swarm.errors import SwarmError
from swarm.mission.load import load_mission
from swarm.mission.plan import MissionPlan, place_xy, plan_mission, radio_params
from swarm.mission.schema import Mission, Radio
from swarm.sim import comms, hazards, physics, sensing
from swarm.sim.control import DriveLimits, drive_toward, to_body
from swarm.sim.criteria import MissionScore
from swarm.sim.layout import (
    ELEVATION_CLIP_M,
    GLOBAL_FIELDS,
    PHASES,
    ROLES,
    STATE_FIELDS,
    ObservationLayout,
    state_size,
)
from swarm.sim.mines import lay_mines
from swarm.sim.router import Router
from swarm.sim.routes import Routes

ACTION_MODES = ("wheels", "command")
COMMANDS = ("follow", "goto", "loiter", "mark", "relay", "return")
FOLLOW, GOTO, LOITER, MARK, RELAY, RETURN = range(len(COMMANDS))
WAITING, SEA, SURF, BEACH, RETURNING, DONE = range(len(PHASES))
#: A marking robot marks the object it loiters by within this distance (m).
MARK_RADIUS_M = 1.0
#: Robots keep this far from a mine that has been found and is not yet marked (m): four times the
#: trigger radius (`swarm.sim.mines.DEFAULT_TRIGGER_RADIUS_M`), room for the track-following error.
AVOID_MINE_M = 1.0
#: Above this submersion a returning robot is afloat beyond the surf and picked up.
PICKUP_SUBMERSION = 0.99
#: The wheels find traction (terrain mode on) below this submersion.
GROUND_SUBMERSION = 0.3
#: The largest wheel surface speed, as a multiple of the cruise speed (robot.wheel_speed_mps).
MAX_WHEEL_SPEED_FACTOR = 1.5
#: Up to this many point pairs, nearest neighbours come from a dense distance matrix (faster
#: than building a k-d tree for a handful of objects).
DENSE_NEAREST_PAIRS = 200_000
#: Spares wait on dry ground at least this far from water (m).
MUSTER_FROM_WATER_M = 5.0
#: A robot at the end of its route drives back to it once it has drifted this far (m): robots
#: creep down the beach's slope and are pushed by the swash, and a station (beacon, observation
#: point) counts only within `swarm.sim.criteria.STATION_RADIUS_M` (3 m).
STATION_KEEP_M = 1.0
#: Seconds between trajectory samples kept for rendering tracks.
TRACK_SAMPLE_S = 5.0


@dataclass(frozen=True)
class StepOutcome:
    """What the world's step just did, handed to the task hooks (`reward`, `terminated`)."""

    score_change: float  # change of the mission score (`swarm.sim.criteria`): the default team reward
    ended: np.ndarray  # (n,) bool: robots the world took out of the mission this step (lost, expended,
    # recovered); a robot out of time is truncated instead (`time_up`)
    time_up: bool  # the time limit (or max_cycles) is reached: every robot still in is truncated


@dataclass(frozen=True)
class SimConfig:
    """Simulation settings that are not part of the mission."""

    dt_s: float = 0.5  # one env step
    substep_s: float = 0.25  # physics substep (the skid step is stable at any step; 0.25 s is within
    # a few cm over a 20 s manoeuvre of 0.01 s steps)
    comms_period_s: float = 5.0  # radio graph update (a mesh's neighbour tables refresh in seconds)
    patch_size: int = 5
    patch_spacing_m: float = 1.0
    neighbours: int = 4

    def __post_init__(self) -> None:
        if not (self.dt_s > 0 and self.substep_s > 0 and self.comms_period_s > 0):
            raise SwarmError("sim: dt_s, substep_s and comms_period_s must be > 0")
        if self.patch_size < 1 or self.neighbours < 0:
            raise SwarmError("sim: patch_size must be >= 1 and neighbours >= 0")


def _as_mission(mission: str | Path | Mission, overrides: dict[str, Any] | None) -> Mission:
    if isinstance(mission, Mission):
        if overrides:
            source = mission.source
            if source is None:
                raise SwarmError("sim: overrides need a mission loaded from a file (pass its path)")
            return load_mission(source, overrides)
        return mission
    return load_mission(mission, overrides)


class SwarmEnv(ParallelEnv):
    """The surf-swarm mission as a PettingZoo parallel environment (module docstring)."""

    metadata = {  # noqa: RUF012 (PettingZoo reads it from the class)
        "name": "surf_swarm_v0",
        "render_modes": ["rgb_array", "human"],
        "render_fps": 10,
        "is_parallelizable": True,
    }

    def __init__(
        self,
        mission: str | Path | Mission,
        overrides: dict[str, Any] | None = None,
        *,
        action_mode: str = "wheels",
        render_mode: str | None = None,
        config: SimConfig | None = None,
        plan: MissionPlan | None = None,
        max_cycles: int | None = None,
        plan_workers: int | None = 1,
    ) -> None:
        if action_mode not in ACTION_MODES:
            raise SwarmError(f"sim: action_mode {action_mode!r}, expected one of {list(ACTION_MODES)}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise SwarmError(
                f"sim: render_mode {render_mode!r}, expected one of {self.metadata['render_modes']}"
            )
        self.mission = _as_mission(mission, overrides)
        self.config = config or SimConfig()
        self.action_mode = action_mode
        self.render_mode = render_mode
        m = self.mission
        self.plan = plan if plan is not None else plan_mission(m, seed=m.seed, workers=plan_workers)
        self.beach = m.beach_map
        self.library = m.terrain_library
        self.robot = m.robot_params
        n = m.swarm.count
        if len(self.plan.robots) != n:
            raise SwarmError(f"sim: the plan has {len(self.plan.robots)} robots, the mission {n}")
        self.n = n
        self.possible_agents = [f"robot_{i}" for i in range(n)]
        self.agent_index = {a: i for i, a in enumerate(self.possible_agents)}
        self.time_limit_s = m.phases.beach_end_s + (
            m.phases.return_to_sea.time_limit_s if m.phases.return_to_sea.enabled else 0.0
        )
        steps = math.ceil(self.time_limit_s / self.config.dt_s - 1e-9)
        self.max_steps = steps if max_cycles is None else min(steps, int(max_cycles))

        # the world: physics, radio, sensor -------------------------------------------------------
        self.sea = physics.SeaState.from_mission(m)
        swim = m.robot.swim_speed_mps
        jet = m.robot.jet_thrust_n or physics.Physics.default_jet_thrust_n(self.library, swim)
        self.physics = physics.Physics(
            self.beach,
            self.library,
            self.robot,
            self.sea,
            jet_thrust_max_n=jet,
            substep_s=self.config.substep_s,
        )
        self.limits = DriveLimits(
            wheel_radius_m=self.robot.wheel_radius_m,
            track_width_m=self.robot.track_width_m,
            cruise_speed_mps=m.robot.wheel_speed_mps,
            max_wheel_speed_mps=MAX_WHEEL_SPEED_FACTOR * m.robot.wheel_speed_mps,
            jet_thrust_max_n=jet,
        )
        relay_tasks = m.tasks_of("relay")
        self.relay_task = relay_tasks[0] if relay_tasks else None
        radio = self.relay_task.radio if self.relay_task is not None else Radio()
        self.radio = radio_params(radio, m.hazards.comms.shadowing_sigma_db)
        fixed = None
        if self.relay_task is not None:
            pts = [place_xy(self.beach, self.relay_task.source)]
            pts += [place_xy(self.beach, s) for s in self.relay_task.sinks]
            fixed = np.array(pts)
        self.fixed_m = fixed
        self.fixed_height_m = radio.source_antenna_height_m
        searches = m.tasks_of("search")
        self.search_task = searches[0] if searches else None
        self.clearance = self.search_task.clearance if self.search_task is not None else None

        # static per-robot facts from the plan ---------------------------------------------------------
        plan_robots = self.plan.robots
        self.release_s = np.array([r.release_s for r in plan_robots])
        offshore = m.launch.release_offshore_m
        self.arrive_s = self.release_s + offshore / swim
        self.launch_m = np.array([r.launch_m for r in plan_robots])
        self.entry_m = np.array([r.sea_leg_m[-1] for r in plan_robots])
        self.role = np.array([ROLES.index(r.role) for r in plan_robots], dtype=np.int64)
        self.plan_role = self.role.copy()
        self.on_beach_launch = m.launch.platform == "beach"
        # jet power for the sea leg offshore, at the thrust that holds swim speed in deep water
        drag = self.library["deep_water"].drag_n_s2_per_m2
        self.swim_power_w = float(physics.jet_power_w(drag * swim * swim))
        pickup = m.phases.return_to_sea.points
        pickups = [place_xy(self.beach, p) for p in pickup] if pickup else list(map(tuple, self.launch_m))
        self.pickup_m = np.unique(np.array(pickups), axis=0)

        # spaces ------------------------------------------------------------------------------------------
        self.layout = ObservationLayout(
            self.config.patch_size, self.config.patch_spacing_m, self.config.neighbours
        )
        extent = float(max(self.beach.width_m, self.beach.height_m))
        self._obs_bounds = self.layout.bounds(extent, self.time_limit_s)
        if action_mode == "wheels":
            self._act_space: gymnasium.spaces.Space = gymnasium.spaces.Box(-1.0, 1.0, (3,), np.float32)
        else:
            x0, y0, x1, y1 = self.beach.bounds_m
            self._act_space = gymnasium.spaces.Dict(
                {
                    "command": gymnasium.spaces.Discrete(len(COMMANDS)),
                    "target": gymnasium.spaces.Box(
                        np.array([x0, y0], np.float32), np.array([x1, y1], np.float32), dtype=np.float32
                    ),
                }
            )
        self.state_space = gymnasium.spaces.Box(-np.inf, np.inf, (state_size(n),), np.float32)
        self._speed_grid = self._speed_fraction_grid()
        self.router = Router(self.plan.costmap, seed=m.seed)
        self._initial_routes = [self._initial_route(rp) for rp in self.plan.robots]
        self._renderer = None
        self._seed_seq: np.random.SeedSequence | None = None
        self.agents: list[str] = []
        self._reset_state(0)  # arrays exist before the first reset (spaces, render)
        self._seed_seq = None  # ...but an unseeded first reset() draws fresh entropy

    # spaces -----------------------------------------------------------------------------------------
    @functools.cache  # noqa: B019 (one space object per agent, as PettingZoo expects)
    def observation_space(self, agent: str) -> gymnasium.spaces.Space:
        return self._observation_box

    @functools.cached_property
    def _observation_box(self) -> gymnasium.spaces.Box:
        return self.observation_box()

    @functools.cache  # noqa: B019
    def action_space(self, agent: str) -> gymnasium.spaces.Space:
        return self._act_space

    # reset ------------------------------------------------------------------------------------------
    def _speed_fraction_grid(self) -> np.ndarray:
        """Per cell: the mode's steady speed over the fastest mode's (0: impassable or no progress)."""
        speeds = self.plan.costmap.speeds
        table = speeds.as_dict() if hasattr(speeds, "as_dict") else {}
        per_class = []
        for name in self.beach.terrain_classes:
            mode = self.library[name]
            entry = table.get(name, {})
            v = entry.get("speed_mps") if isinstance(entry, dict) else None
            ref = max((e.get("speed_mps") or 0.0) for e in table.values()) if table else 1.0
            frac = 0.0 if (not mode.passable or not v) else float(v) / max(ref, 1e-9)
            per_class.append(frac)
        return np.asarray(per_class, np.float32)[self.beach.terrain.astype(np.intp)]

    def _reset_state(self, seed: int | None) -> None:
        n = self.n
        if seed is not None or self._seed_seq is None:
            ss = np.random.SeedSequence(seed)
        else:  # an unseeded reset after a seeded one carries on the seeded stream (Gymnasium's rule)
            ss = self._seed_seq.spawn(1)[0]
        self._seed_seq = ss
        names = ("mines", "waves", "sensing", "radio", "hazards", "policy", "rocks")
        self.rngs = dict(zip(names, (np.random.default_rng(s) for s in ss.spawn(len(names))), strict=True))
        self.seed = seed
        self.router.calls = 0  # replanning seeds count from the episode's start
        self.t_s = 0.0
        self.steps = 0
        self.wave_phase_s = float(self.rngs["waves"].uniform(0.0, self.sea.wave_period_s))
        self.minefield = lay_mines(self.mission, self.rngs["mines"], self.plan.costmap)
        self.hidden_rocks_m = hazards.hidden_rocks_in_cells(
            self.mission.hazards, self._dry_cells, self.beach.cell_m, self.rngs["rocks"]
        )
        self.hazard_model = hazards.HazardModel(
            self.mission.hazards,
            self.mission.phases,
            self.beach.terrain_classes,
            self.library,
            self.minefield,
            self.hidden_rocks_m,
            n,
        )
        clutter = None
        if self.search_task is not None:
            clutter = self.beach.regions[self.search_task.area].geometry
        self.sensor = (
            sensing.MineSensor(self.search_task.sensor, self.minefield, n, clutter)
            if self.search_task is not None
            else None
        )
        self.radio_net = comms.RadioNet(
            self.radio,
            n,
            self.fixed_m,
            fixed_height_m=self.fixed_height_m,
            decorrelation_m=self.mission.hazards.comms.decorrelation_m,
        )
        self.robot_state = np.zeros((n, 6))
        self.robot_state[:, :2] = self.launch_m
        d = self.entry_m - self.launch_m
        self.robot_state[:, 2] = np.arctan2(d[:, 1], d[:, 0])
        self.alive = np.ones(n, bool)  # in the mission: not lost, recovered or expended
        self.on_map = np.zeros(n, bool)
        self.phase = np.full(n, WAITING, dtype=np.int64)
        self.energy_wh = np.full(n, self.mission.hazards.battery.capacity_wh)
        self.inverted = np.zeros(n, bool)
        self.radio_ok = np.ones(n, bool)
        self.sea_time_s = np.zeros(n)
        self.surf_time_s = np.zeros(n)
        self.isolated_s = np.zeros(n)
        self.slip = np.zeros(n)
        self.submersion = np.zeros(n)
        self.terrain_now = np.zeros(n, dtype=np.intp)
        self.distance_m = np.zeros(n)
        self.end_reason: list[str | None] = [None] * n
        self._pending_terminated = np.zeros(n, bool)
        self.lost_at = np.full((n, 3), np.nan)  # t, x, y
        self.command = np.full(n, FOLLOW, dtype=np.int64)
        self.target_m = self.robot_state[:, :2].copy()
        self.marking = np.full(n, -1, dtype=np.int64)  # object index a robot marks
        self.routes = Routes(n)
        for i, (wp, track_from) in enumerate(self._initial_routes):
            self.routes.set(i, wp, track_from)
        # objects to mark: detected mines and false alarms
        self.objects_m = np.empty((0, 2))
        self.object_mine = np.empty(0, dtype=np.int64)
        self.object_marker = np.empty(0, dtype=np.int64)
        self.links = self.radio_net.update(self.robot_state[:, :2], np.zeros(n, bool), self.rngs["radio"])
        self._next_comms_s = 0.0
        self.links_version = 0
        self._link_keys_version = -1
        self._nb_signature: tuple[int, int] | None = None
        self._nb_table = np.full((n, self.layout.neighbours), -1, dtype=np.intp)
        self._nb_linked = np.zeros((n, self.layout.neighbours), bool)
        self._link_keys_cache = np.empty(0, dtype=np.int64)
        self.relay_up: bool | None = None
        self._relay_was_up = False
        redundancy = self.relay_task.redundancy if self.relay_task is not None else None
        self.score = MissionScore(self.mission, redundancy, len(self.minefield))
        self._score_prev = 0.0
        self.cleared = False
        self.events: list[dict] = []
        self._phase_seen: set[str] = set()
        self.tracks: list[np.ndarray] = []
        self._next_track_s = 0.0
        self.agents = list(self.possible_agents)
        self._agent_idx = np.arange(n, dtype=np.intp)  # self.agents as indices, in the same order

    def reset(self, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        self.reset_arrays(seed)
        obs = self.observe()
        agents, idx = self.agents, self._agent_idx
        return dict(zip(agents, obs[idx], strict=True)), dict(zip(agents, self.info(idx), strict=True))

    def reset_arrays(self, seed: int | None = None) -> np.ndarray:
        """`reset` on arrays: (n, obs_dim) every robot's observation, rows in `possible_agents`
        order (infos: `info(robots)`)."""
        self._reset_state(seed)
        self._event("mission_start", seed=seed, robots=self.n, mines=len(self.minefield))
        self._release()
        return self.observe()

    # events ------------------------------------------------------------------------------------------
    def _event(self, kind: str, robot: int | None = None, **data: Any) -> None:
        ev: dict[str, Any] = {"t_s": round(self.t_s, 3), "kind": kind}
        if robot is not None:
            ev["robot"] = self.possible_agents[robot]
            ev["x_m"] = round(float(self.robot_state[robot, 0]), 2)
            ev["y_m"] = round(float(self.robot_state[robot, 1]), 2)
        ev.update(data)
        self.events.append(ev)

    def _global_phase(self, name: str) -> None:
        if name not in self._phase_seen:
            self._phase_seen.add(name)
            self._event("phase", phase=name)

    # step ---------------------------------------------------------------------------------------------
    def step(self, actions: dict[str, Any]) -> tuple[dict, dict, dict, dict, dict]:
        if not self.agents:  # as PettingZoo's own parallel envs do once everyone is done
            return {}, {}, {}, {}, {}
        agents, idx = self.agents, self._agent_idx
        obs_all, rew, term, trunc = self._step_task(actions)
        obs = dict(zip(agents, obs_all[idx], strict=True))
        rewards = dict(zip(agents, rew[idx].tolist(), strict=True))
        terms = dict(zip(agents, term[idx].tolist(), strict=True))
        truncs = dict(zip(agents, trunc[idx].tolist(), strict=True))
        infos = dict(zip(agents, self.info(idx), strict=True))
        if self.render_mode == "human":
            self.render()
        return obs, rewards, terms, truncs, infos

    def step_arrays(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """`step` on arrays over all robots, rows in `possible_agents` order: `actions` (n, 3) (wheels:
        left, right, jet; command: command index, target x, y), of which only the rows of robots in
        `agents` are used. Returns observations (n, obs_dim) float32, rewards (n,) float64,
        terminated and truncated (n,) bool; the rows of robots that were not in `agents` before the
        step are zero (False). Infos: `info(robots)`. Raises once every agent is done."""
        if not self.agents:
            raise SwarmError("sim: step_arrays() after the episode ended; call reset()")
        obs, rew, term, trunc = self._step_task(np.asarray(actions))
        if self.render_mode == "human":
            self.render()
        return obs, rew, term, trunc

    def _step_task(self, actions: dict[str, Any] | np.ndarray) -> tuple[np.ndarray, ...]:
        """The world's step, then the task hooks; rows of robots not in `agents` before it zeroed."""
        was_in = np.zeros(self.n, bool)
        was_in[self._agent_idx] = True
        ended, time_up, score_change = self._advance(actions)
        outcome = StepOutcome(score_change, ended, time_up)
        obs = self.observe()
        obs[~was_in] = 0.0
        rew = np.where(was_in, np.asarray(self.reward(outcome), np.float64), 0.0)
        term = np.asarray(self.terminated(outcome), bool) & was_in
        trunc = (was_in & ~term) if time_up else np.zeros(self.n, bool)
        self._finish(term, time_up)
        return obs, rew, term, trunc

    # the task hooks (module docstring): override these to change the task ----------------------------------
    def observation_box(self) -> gymnasium.spaces.Box:
        """The space of one robot's observation (every robot shares it); asked once, lazily."""
        low, high = self._obs_bounds
        return gymnasium.spaces.Box(low, high, dtype=np.float32)

    def observe(self) -> np.ndarray:
        """(n, obs_dim) float32: every robot's observation now (`swarm.sim.layout`), a row each in
        `possible_agents` order; a fresh array the caller may change."""
        return self._observe()

    def reward(self, step: StepOutcome) -> np.ndarray:
        """(n,) each robot's reward for the step just taken: by default the team reward, the change
        of the mission score, the same for every robot."""
        return np.full(self.n, step.score_change)

    def terminated(self, step: StepOutcome) -> np.ndarray:
        """(n,) bool: robots whose episode ends now; they leave `agents`. By default those the world
        took out of the mission (lost, expended, recovered). A robot the task ends while the world
        has not stays in the world where it is, with its wheels stopped."""
        return step.ended

    def info(self, robots: np.ndarray) -> list[dict]:
        """One info dict for each robot index in `robots`: {"phase", "role"}, and once it has left
        the mission "end_reason" (and "lost_reason" if it was lost). Robots still working share one
        dict per (phase, role): treat infos as read-only."""
        shared = self._shared_infos
        out = [shared[k] for k in (self.phase[robots] * len(ROLES) + self.role[robots]).tolist()]
        for k in np.flatnonzero(~self.alive[robots]).tolist():  # those leaving now get their own
            out[k] = self._info(int(robots[k]))
        return out

    def advance(self, actions: dict[str, Any]) -> None:
        """`step` without building observations, rewards and infos: for runners that read the
        environment's arrays directly (the scripted policy, `swarm.sim.run.simulate`)."""
        terminated, truncate, _ = self._advance(actions)
        self._finish(terminated, truncate)

    def _advance(self, actions: dict[str, Any] | np.ndarray) -> tuple[np.ndarray, bool, float]:
        """One step of the world; returns who was terminated, whether time ran out, the reward."""
        if not self.agents:
            raise SwarmError("sim: step() after the episode ended; call reset()")
        dt = self.config.dt_s
        wheels, jet = self._commands(actions)
        self.t_s = (self.steps + 1) * dt
        self.steps += 1
        moving = self.alive & self.on_map
        res = self.physics.step(
            self.robot_state, wheels, jet, self.inverted, self.t_s - dt, dt, self.wave_phase_s, active=moving
        )
        self.robot_state = res.state
        self.slip = np.where(moving, res.slip, 0.0)
        self.submersion = np.where(moving, res.submersion, self.submersion)
        self.terrain_now = np.where(moving, res.terrain, self.terrain_now)
        self.distance_m = np.where(moving, res.distance_m, 0.0)
        hotel = self.mission.hazards.battery.hotel_power_w
        at_sea = self.alive & (self.phase == SEA) & ~self.on_map
        power = np.where(moving, res.power_w, 0.0) + np.where(at_sea, self.swim_power_w, 0.0)
        power = power + np.where(self.alive & (self.phase != WAITING), hotel, 0.0)
        self.energy_wh -= power * dt / 3600.0
        self._flip(res.wave_hits & moving, res.wave_height_m)
        self.routes.advance(self.robot_state[:, :2], moving)
        self._update_phases(res.in_surf & moving)
        self._release()
        self._sense()
        self._update_marks()
        self._update_comms()
        terminated = self._hazards(res, at_sea) | self._pending_terminated
        self._pending_terminated[:] = False
        self._clearance(terminated)
        self._recover(terminated)
        ashore = self.alive & self.on_map & (self.phase >= BEACH)
        self.score.detected = int(self.minefield.detected.sum())
        if self.score.beach_start_s is None and ashore.any():
            self.score.beach_start_s = self.t_s
        self.score.update(self.t_s, dt, self.robot_state[ashore, :2], self.relay_up)
        truncate = self.steps >= self.max_steps
        if truncate:
            self.score.at_end = True
        score = self.score.score()
        reward = score - self._score_prev
        self._score_prev = score
        self._sample_tracks()
        return terminated, truncate, float(reward)

    def fast_forward(self) -> int:
        """Skip ahead while every robot is off the map (waiting on the platform or swimming in
        offshore), up to one step before the next release or arrival: one stride instead of many
        identical steps. Only memoryless hazards act at sea (random failure, radio dropout), so a
        stride of k steps draws losses with exactly the probability k steps would; a loss is
        logged at the end of the stride. Returns the steps skipped (0 when a robot is on the map
        or the next event is within two steps). Runners use it (`simulate`); `step` never does."""
        if not self.agents or (self.alive & self.on_map).any():
            return 0
        dt = self.config.dt_s
        waiting = self.alive & (self.phase == WAITING)
        swimming = self.alive & (self.phase != WAITING) & ~self.on_map
        events = [self.release_s[waiting], self.arrive_s[swimming]]
        if self.clearance is not None and not self.cleared:
            events.append(np.array([self.clearance.at_s]))
        upcoming = np.concatenate(events)
        if not len(upcoming):
            return 0
        k = math.floor((float(upcoming.min()) - self.t_s) / dt + 1e-9) - 1
        k = min(k, self.max_steps - self.steps - 1)
        if k < 2:
            return 0
        stride = k * dt
        hotel = self.mission.hazards.battery.hotel_power_w
        at_sea = swimming & (self.phase == SEA)
        self.energy_wh -= np.where(at_sea, self.swim_power_w + hotel, 0.0) * stride / 3600.0
        self.sea_time_s += np.where(at_sea, stride, 0.0)
        self.steps += k
        self.t_s = self.steps * dt
        n = self.n
        inp = hazards.HazardInputs(
            t_s=self.t_s,
            dt_s=stride,
            alive=self.alive & (self.phase != WAITING),
            at_sea=at_sea,
            xy=self.robot_state[:, :2],
            terrain=self.terrain_now,
            distance_m=np.zeros(n),
            slip=np.zeros(n),
            driving=np.zeros(n, bool),
            wave_hits=np.zeros(n, bool),
            obstacle_hit=np.full(n, -1),
            energy_wh=self.energy_wh,
            sea_time_s=self.sea_time_s,
            surf_time_s=self.surf_time_s,
            isolated_s=np.zeros(n),
            radio_ok=self.radio_ok,
        )
        self._pending_terminated |= self._apply_hazards(inp)
        return k

    def _finish(self, terminated: np.ndarray, truncate: bool) -> None:
        """End the step: truncate everyone at the time limit, drop finished agents for good."""
        if truncate:
            for i in np.flatnonzero(self.alive):
                self.alive[i] = False
                self.end_reason[i] = "time_limit"
        keep = np.zeros(len(self._agent_idx), bool) if truncate else ~terminated[self._agent_idx]
        if not keep.all():
            self.agents = [a for a, k in zip(self.agents, keep.tolist(), strict=True) if k]
            self._agent_idx = self._agent_idx[keep]
        if not self.agents:
            self.score.at_end = True
            self._event("mission_end", outcome=self.score.outcome())

    # actions --------------------------------------------------------------------------------------
    def _commands(self, actions: dict[str, Any] | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n = self.n
        wheels = np.zeros((n, 2))
        jet = np.zeros(n)
        if isinstance(actions, np.ndarray):  # every robot's row; only those in `agents` count
            if actions.shape != (n, 3):
                raise SwarmError(f"sim: actions of shape {actions.shape}, expected ({n}, 3)")
            idx = self._agent_idx
            if self.action_mode == "command":
                for i, (cmd, tx, ty) in zip(idx.tolist(), actions[idx].tolist(), strict=True):
                    self.set_command(i, int(cmd), np.array([tx, ty]))
                return self.controller_commands()
            act = np.clip(actions[idx].astype(np.float64), -1.0, 1.0)
            wheels[idx] = act[:, :2] * (self.limits.max_wheel_speed_mps / self.limits.wheel_radius_m)
            jet[idx] = act[:, 2] * self.limits.jet_thrust_max_n
            return wheels, jet
        if self.action_mode == "wheels":
            if actions:
                names = list(actions)
                if names == self.agents:  # the usual case: every live agent, in order
                    idx = self._agent_idx
                else:
                    idx = np.fromiter((self.agent_index[a] for a in names), np.intp, len(names))
                act = np.clip(np.array(list(actions.values()), dtype=np.float64).reshape(-1, 3), -1.0, 1.0)
                wheels[idx] = act[:, :2] * (self.limits.max_wheel_speed_mps / self.limits.wheel_radius_m)
                jet[idx] = act[:, 2] * self.limits.jet_thrust_max_n
            return wheels, jet
        for a, act in actions.items():
            i = self.agent_index[a]
            self.set_command(i, int(act["command"]), np.asarray(act["target"], dtype=np.float64))
        return self.controller_commands()

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
            self.marking[i] = k
            self.target_m[i] = self.objects_m[k]
        elif command != MARK and self.marking[i] >= 0:
            self._unmark(i)
        if command == RETURN and prev != RETURN and self.alive[i]:
            self.routes.set(
                i, self.router.route(self.robot_state[i, :2], self._nearest_pickup(self.robot_state[i, :2]))
            )
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
        known = self.objects_m[self.object_marker < 0]
        if len(known):
            self.routes.steer_clear(i, self.robot_state[i, :2], known, AVOID_MINE_M)
        if role is not None:
            self.role[i] = ROLES.index(role)
        self.command[i] = FOLLOW

    def controller_commands(self) -> tuple[np.ndarray, np.ndarray]:
        """Wheel and jet commands for every robot from its command, route and target."""
        xy = self.robot_state[:, :2]
        done = self.routes.done()
        # a robot at the end of its route keeps station there: back when it has drifted off
        route_targets = np.where(done[:, None], self._route_goal(), self.routes.targets(xy))
        off_station = np.hypot(*(route_targets - xy).T) > STATION_KEEP_M
        follow = (self.command == FOLLOW) | (self.command == RETURN)
        # a marker follows its route to the mine, then closes in on the mine itself
        routed = follow | ((self.command == MARK) & ~done)
        target = np.where(routed[:, None], route_targets, self.target_m)
        hold = (self.command == LOITER) | (self.command == RELAY)
        moving = self.alive & self.on_map & ~hold & ~(follow & done & ~off_station)
        speed = self.limits.cruise_speed_mps
        wheels, jet, _ = drive_toward(
            self.robot_state, target, speed, self.submersion, self.inverted, self.limits, moving
        )
        return wheels, jet

    # mission mechanics -----------------------------------------------------------------------------
    def _release(self) -> None:
        """Robots leave the platform, and those that have swum in appear at their launch points."""
        t = self.t_s
        leaving = self.alive & (self.phase == WAITING) & (self.release_s <= t + 1e-9)
        for i in np.flatnonzero(leaving):
            self.phase[i] = BEACH if self.on_beach_launch else SEA
            self._event("release", int(i))
            self._global_phase("sea_transit" if not self.on_beach_launch else "beach_operations")
        arriving = self.alive & ~self.on_map & (self.phase != WAITING) & (self.arrive_s <= t + 1e-9)
        arriving |= self.alive & ~self.on_map & self.on_beach_launch & (self.phase == BEACH)
        for i in np.flatnonzero(arriving):
            self.on_map[i] = True
            self._event("arrive", int(i))

    def _update_phases(self, in_surf: np.ndarray) -> None:
        # stranded in the surf: time in the surf zone before first getting ashore
        self.surf_time_s += np.where(in_surf & (self.phase <= SURF), self.config.dt_s, 0.0)
        self.sea_time_s += np.where(self.alive & (self.phase == SEA), self.config.dt_s, 0.0)
        to_surf = self.alive & (self.phase == SEA) & in_surf
        for i in np.flatnonzero(to_surf):
            self.phase[i] = SURF
            self._event("surf", int(i))
            self._global_phase("surf_crossing")
        ground = (
            self.alive
            & self.on_map
            & (self.submersion < GROUND_SUBMERSION)
            & ((self.phase == SEA) | (self.phase == SURF))
        )
        for i in np.flatnonzero(ground):
            self.phase[i] = BEACH
            self._event("ashore", int(i))
            self._global_phase("beach_operations")
        if self.t_s >= self.mission.phases.beach_end_s and self.mission.phases.return_to_sea.enabled:
            self._global_phase("return_to_sea")

    def _flip(self, hits: np.ndarray, height_m: np.ndarray) -> None:
        """Breakers turn robots over: flip_probability for a full breaker, in proportion to the
        local breaker height below it. With `hazards.enabled` false none does (a rolled robot can
        overstay the surf crossing); the draws are still made, to keep the stream."""
        if not hits.any():
            return
        surf = self.mission.hazards.surf
        p = surf.flip_probability * np.minimum(1.0, height_m / max(surf.wave_height_m, 1e-9))
        draws = self.rngs["waves"].random(self.n)
        flips = hits & (draws < p) & self.mission.hazards.enabled
        self.inverted ^= flips
        for i in np.flatnonzero(flips):
            self._event("flip", int(i), inverted=bool(self.inverted[i]))

    def _sense(self) -> None:
        if self.sensor is None:
            return
        sensing_now = self.alive & self.on_map & (self.phase >= BEACH)
        found = self.sensor.update(
            self.robot_state[:, :2],
            sensing_now,
            self.distance_m,
            self.t_s,
            self.rngs["sensing"],
            alive=self.alive,
        )
        for det in found:
            xy = np.asarray(det.xy, dtype=np.float64)
            for i in np.flatnonzero(self.alive & self.on_map & (self.marking < 0)):
                self.routes.steer_clear(int(i), self.robot_state[i, :2], xy[None], AVOID_MINE_M)
            self.objects_m = np.vstack([self.objects_m, xy[None]])
            self.object_mine = np.append(self.object_mine, det.mine)
            self.object_marker = np.append(self.object_marker, -1)
            kind = "detection" if det.mine >= 0 else "false_alarm"
            self._event(
                kind,
                det.robot,
                object=len(self.objects_m) - 1,
                mine=det.mine,
                at_m=[round(v, 2) for v in det.xy],
            )

    def _update_marks(self) -> None:
        for i in np.flatnonzero(self.alive & (self.marking >= 0)):
            k = self.marking[i]
            near = np.hypot(*(self.robot_state[i, :2] - self.objects_m[k])) <= MARK_RADIUS_M
            if near and self.object_marker[k] < 0:
                self.object_marker[k] = i
                if self.object_mine[k] >= 0:
                    self.minefield.marked[self.object_mine[k]] = True
                self._event("mark", int(i), object=int(k), mine=int(self.object_mine[k]))

    def _unmark(self, i: int) -> None:
        k = self.marking[i]
        self.marking[i] = -1
        if k >= 0 and self.object_marker[k] == i:
            self.object_marker[k] = -1
            if self.object_mine[k] >= 0:
                self.minefield.marked[self.object_mine[k]] = False
            self._event("unmark", int(i), object=int(k))

    def _update_comms(self) -> None:
        if self.t_s + 1e-9 < self._next_comms_s:
            return
        self._next_comms_s = self.t_s + self.config.comms_period_s
        cutoff = self.mission.hazards.comms.cutoff_s
        jammed = cutoff is not None and self.t_s >= cutoff
        up = self.alive & self.on_map & self.radio_ok & (not jammed)
        self.links = self.radio_net.update(self.robot_state[:, :2], up, self.rngs["radio"])
        self.links_version += 1
        if self.relay_task is not None:
            now = bool(self.links.fixed_linked(self.relay_task.redundancy))
            if now != bool(self.relay_up):
                if now:
                    self._event("relay_repair" if self._relay_was_up else "relay_connected")
                else:
                    self._event("relay_break")
            self._relay_was_up |= now
            self.relay_up = now

    def _hazards(self, res: Any, at_sea: np.ndarray) -> np.ndarray:
        """Apply this step's losses; returns the robots terminated by them."""
        dt = self.config.dt_s
        linked = self.links.degree > 0
        self.isolated_s = np.where(linked | ~self.on_map, 0.0, self.isolated_s + dt)
        driving = np.abs(res.slip) > 0  # the physics reports slip only while the wheels turn
        inp = hazards.HazardInputs(
            t_s=self.t_s,
            dt_s=dt,
            alive=self.alive & (self.phase != WAITING),
            at_sea=at_sea,
            xy=self.robot_state[:, :2],
            terrain=self.terrain_now,
            distance_m=self.distance_m,
            slip=self.slip,
            driving=driving,
            wave_hits=res.wave_hits & self.on_map,
            wave_height_m=res.wave_height_m,
            obstacle_hit=np.where(self.on_map, res.obstacle_hit, -1),
            energy_wh=self.energy_wh,
            sea_time_s=self.sea_time_s,
            surf_time_s=self.surf_time_s,
            isolated_s=self.isolated_s,
            radio_ok=self.radio_ok,
        )
        return self._apply_hazards(inp)

    def _apply_hazards(self, inp: hazards.HazardInputs) -> np.ndarray:
        """Draw this step's (or stride's) losses and log them; returns who was lost."""
        losses = self.hazard_model.step(inp, self.rngs["hazards"])
        self.radio_ok &= ~losses.radio_dropped
        lost = losses.lost & self.alive
        for i in np.flatnonzero(lost):
            cause = hazards.CAUSES[losses.cause[i]]
            extra = {"mine": int(losses.mine[i])} if losses.mine[i] >= 0 else {}
            self._lose(int(i), cause, **extra)
        return lost

    def lose(self, agent: str, cause: str = "failure") -> None:
        """Take a robot out of the mission now, as if `cause` had struck it: for what-if
        experiments (how does the swarm cope without this relay?) and tests. It is reported
        terminated on the next step, like any loss."""
        i = self.agent_index[agent]
        if cause not in hazards.CAUSES:
            raise SwarmError(f"sim: cause {cause!r}, expected one of {list(hazards.CAUSES)}")
        if not self.alive[i]:
            raise SwarmError(f"sim: {agent} is not in the mission any more ({self.end_reason[i]})")
        self._lose(i, cause)
        self._pending_terminated[i] = True

    def _lose(self, i: int, cause: str, **data: Any) -> None:
        self.alive[i] = False
        self.end_reason[i] = cause
        self.lost_at[i] = (self.t_s, self.robot_state[i, 0], self.robot_state[i, 1])
        if self.marking[i] >= 0:
            self._unmark(i)
        phase = PHASES[self.phase[i]]
        self._event("loss", i, cause=cause, phase=phase, **data)

    def _clearance(self, terminated: np.ndarray) -> None:
        c = self.clearance
        if c is None or self.cleared or self.t_s + 1e-9 < c.at_s:
            return
        self.cleared = True
        markers = [
            int(i)
            for i in np.flatnonzero(self.alive & (self.marking >= 0))
            if self.object_marker[self.marking[i]] == i
        ]
        blasts = []
        for i in markers:
            k = self.marking[i]
            j = self.object_mine[k]
            if j >= 0 and self.minefield.active[j]:
                self.minefield.cleared[j] = True
            blasts.append(self.objects_m[k])
            self.alive[i] = False
            self.end_reason[i] = "expended"
            terminated[i] = True
            self._event("expended", i, object=int(k), mine=int(j))
        self._event("clearance", markers=len(markers), mines_cleared=int(self.minefield.cleared.sum()))
        if blasts:
            tree = cKDTree(np.array(blasts))
            for i in np.flatnonzero(self.alive & self.on_map):
                if tree.query(self.robot_state[i, :2])[0] <= c.standoff_m:
                    self._lose(int(i), "blast")
                    terminated[i] = True

    def _recover(self, terminated: np.ndarray) -> None:
        back = self.alive & (self.phase == RETURNING) & (self.submersion >= PICKUP_SUBMERSION)
        for i in np.flatnonzero(back):
            self.alive[i] = False
            self.end_reason[i] = "recovered"
            self.phase[i] = DONE
            terminated[i] = True
            self.score.recovered += 1
            self._event("recovered", int(i))

    def _initial_route(self, rp: Any) -> tuple[np.ndarray, int | None]:
        """A robot's planned waypoints (and where its search track starts); spares go on from
        their entry to wait on dry ground, out of the surf."""
        wp = rp.waypoints_m
        if rp.role == "spare":
            wp = np.vstack([wp, self.router.route(wp[-1], self._muster_point(wp[-1]))])
        track_from = len(wp) - len(rp.track_m) if len(rp.track_m) else None
        ground = len(rp.sea_leg_m) - 1  # the sea leg is open water: nothing to route around
        land, where = self.router.stitch(wp[ground:])
        wp = np.vstack([wp[:ground], land])
        if track_from is not None:
            track_from = ground + int(where[track_from - ground])
        return wp, track_from

    @functools.cached_property
    def dry_ground(self) -> np.ndarray:
        """(rows, cols) bool: free cells at least `MUSTER_FROM_WATER_M` from any water, where robots
        wait out of the surf (a robot waiting in the breakers is rolled over again and again)."""
        water = np.array([self.library[c].is_water for c in self.beach.terrain_classes])
        wet = water[self.beach.terrain.astype(np.intp)]
        far = ndimage.distance_transform_edt(~wet) * self.beach.cell_m >= MUSTER_FROM_WATER_M
        return far & ~self.plan.costmap.blocked

    @functools.cached_property
    def _muster_cells(self) -> tuple[cKDTree, np.ndarray]:
        """Free cells on dry ground (`dry_ground`), or any free cells on a map without."""
        cm = self.plan.costmap
        rows, cols = np.nonzero(self.dry_ground)
        if not len(rows):
            rows, cols = np.nonzero(~cm.blocked)
        pts = np.column_stack(cm.center_of(rows, cols))
        return cKDTree(pts), pts

    @functools.cached_property
    def _dry_cells(self) -> np.ndarray:
        """Centres of the passable land cells (no water): where hidden rocks can lie."""
        ok = np.array(
            [self.library[c].passable and not self.library[c].is_water for c in self.beach.terrain_classes]
        )
        rows, cols = np.nonzero(ok[self.beach.terrain.astype(np.intp)])
        return np.column_stack(self.beach.center_of(rows, cols))

    def _muster_point(self, xy: np.ndarray) -> np.ndarray:
        """Where a spare waits: the nearest free, dry cell clear of the water."""
        tree, pts = self._muster_cells
        return pts[int(tree.query(xy)[1])]

    def _nearest_pickup(self, xy: np.ndarray) -> np.ndarray:
        d = np.hypot(*(self.pickup_m - xy).T)
        return self.pickup_m[int(np.argmin(d))]

    def _sample_tracks(self) -> None:
        if self.render_mode is None or self.t_s + 1e-9 < self._next_track_s:
            return
        self._next_track_s = self.t_s + TRACK_SAMPLE_S
        xy = np.where((self.alive & self.on_map)[:, None], self.robot_state[:, :2], np.nan)
        self.tracks.append(xy.astype(np.float32))

    # observations ------------------------------------------------------------------------------------
    def _observe(self) -> np.ndarray:
        n, lay = self.n, self.layout
        out = np.zeros((n, lay.size), np.float32)
        sl = lay.slices
        s = self.robot_state
        heading = s[:, 2]
        c, si = np.cos(heading), np.sin(heading)
        own = out[:, sl["own"]]
        own[:, 0:2] = s[:, :2]
        own[:, 2] = c
        own[:, 3] = si
        own[:, 4:7] = s[:, 3:6]
        own[:, 7] = self.energy_wh
        own[:, 8] = self.inverted
        own[:, 9] = self.submersion
        own[:, 10] = self.slip
        np.clip(own[:, 7:8], 0.0, self.mission.hazards.battery.capacity_wh, out=own[:, 7:8])
        own[:, 7] /= self.mission.hazards.battery.capacity_wh
        np.clip(own[:, 10], 0.0, 1.0, out=own[:, 10])
        own[np.arange(n), 11 + self.phase] = 1.0
        # terrain patch in the body frame: one gather of (speed, elevation) per sample
        fx, fy = self._patch_offsets
        c, si = c[:, None], si[:, None]
        px = s[:, 0:1] + c * fx - si * fy
        py = s[:, 1:2] + si * fx + c * fy
        patch = self._patch_grid[self._flat_cell(px, py)]  # (n, k*k, 2)
        k = lay.patch_size
        # the middle sample of an odd patch is the robot's own cell
        mid = patch[:, (k * k) // 2, 1] if k % 2 else None
        here = mid if mid is not None else self._patch_grid[self._flat_cell(s[:, 0], s[:, 1]), 1]
        out[:, sl["patch_speed"]] = patch[:, :, 0]
        np.clip(
            patch[:, :, 1] - here[:, None],
            -ELEVATION_CLIP_M,
            ELEVATION_CLIP_M,
            out=out[:, sl["patch_elevation"]],
        )
        self._observe_neighbours(out[:, sl["neighbours"]])
        links = out[:, sl["links"]]
        links[:, 0] = self.links.degree
        links[:, 1] = self.links.source_hops >= 0
        links[:, 2] = self.links.source_hops
        links[:, 3] = self.isolated_s
        task = out[:, sl["task"]]
        task[np.arange(n), self.role] = 1.0
        nr = len(ROLES)
        goal = np.where(
            ((self.command == FOLLOW) | (self.command == RETURN))[:, None],
            self._route_goal(),
            self.target_m,
        )
        gb = to_body(goal - s[:, :2], heading)
        task[:, nr : nr + 2] = gb
        task[:, nr + 2] = np.hypot(gb[:, 0], gb[:, 1])
        task[:, nr + 3] = self.routes.progress()
        task[:, nr + 4] = self.marking >= 0
        unmarked = self.object_marker < 0
        if unmarked.any():
            objs = self.objects_m[unmarked]
            j = _nearest(objs, s[:, :2])
            task[:, nr + 5 : nr + 7] = to_body(objs[j] - s[:, :2], heading)
        task[:, nr + 7] = min(1.0, self.t_s / self.time_limit_s)
        if self.clearance is not None and not self.cleared:
            task[:, nr + 8] = max(0.0, self.clearance.at_s - self.t_s)
        return out

    @functools.cached_property
    def _patch_offsets(self) -> tuple[np.ndarray, np.ndarray]:
        """Body-frame sample offsets of the terrain patch (rows forward, columns left), flattened."""
        k, h = self.layout.patch_size, self.layout.patch_spacing_m
        offs = (np.arange(k) - (k - 1) / 2) * h
        fx, fy = np.meshgrid(offs, offs, indexing="ij")
        return fx.ravel(), fy.ravel()

    @functools.cached_property
    def _patch_grid(self) -> np.ndarray:
        """(cells, 2) float32: speed fraction and elevation of every cell, row-major."""
        return np.column_stack([self._speed_grid.ravel(), self.beach.elevation_m.ravel()]).astype(np.float32)

    def _flat_cell(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Row-major index of the cell under each point (the nearest edge cell outside the map)."""
        bm = self.beach
        rows, cols = bm.shape
        c = np.clip(((x - bm.origin_m[0]) / bm.cell_m).astype(np.intp), 0, cols - 1)
        r = np.clip(((y - bm.origin_m[1]) / bm.cell_m).astype(np.intp), 0, rows - 1)
        return r * cols + c

    def _route_goal(self) -> np.ndarray:
        """(n, 2) the last point of each robot's route (its own position without one)."""
        end = np.maximum(self.routes.end - 1, 0)
        has = self.routes.end > self.routes.start
        goal = self.robot_state[:, :2].copy()
        if len(self.routes.points):
            goal[has] = self.routes.points[end[has]]
        return goal

    def _neighbour_table(self) -> np.ndarray:
        """(n, k) ids of each robot's k nearest live robots (-1: none), as of the last radio
        update or change in who is on the map: the neighbour table its radio keeps."""
        on = self.alive & self.on_map
        signature = (self.links_version, int(np.count_nonzero(on)))
        if self._nb_signature != signature:
            self._nb_signature = signature
            live = np.flatnonzero(on)
            k = self.layout.neighbours
            table = np.full((self.n, k), -1, dtype=np.intp)
            q = min(k + 1, len(live))
            if k and q >= 2:
                xy = self.robot_state[live, :2]
                _, idx = cKDTree(xy, balanced_tree=False, compact_nodes=False).query(xy, k=q)
                table[live, : q - 1] = live[idx[:, 1:]]  # the first is itself
            self._nb_table = table
            # which of those links work: fixed until the next radio update, which refreshes the table
            keys = self._link_keys()
            query = np.repeat(np.arange(self.n), k).astype(np.int64) * self.links.adjacency.shape[0]
            query += np.maximum(table, 0).ravel()
            at = np.minimum(np.searchsorted(keys, query), max(len(keys) - 1, 0))
            hit = keys[at] == query if len(keys) else np.zeros(len(query), bool)
            self._nb_linked = hit.reshape(self.n, k) & (table >= 0)
        return self._nb_table

    def _observe_neighbours(self, block: np.ndarray) -> None:
        """Each robot's table neighbours at their current positions: present, body-frame offset,
        distance, radio link working."""
        k = self.layout.neighbours
        if k == 0:
            return
        table = self._neighbour_table()
        me = np.flatnonzero((table >= 0).any(axis=1) & self.alive & self.on_map)
        if not len(me):
            return
        other = table[me]
        present = (other >= 0) & (self.alive & self.on_map)[np.maximum(other, 0)]
        xy = self.robot_state[me, :2]
        rel = to_body(self.robot_state[np.maximum(other, 0), :2] - xy[:, None, :], self.robot_state[me, 2])
        dist = np.hypot(rel[..., 0], rel[..., 1])
        linked = self._nb_linked[me]
        view = np.zeros((len(me), k, 5), np.float32)
        view[..., 0] = present
        view[..., 1:3] = rel
        view[..., 3] = dist
        view[..., 4] = linked
        view[~present] = 0.0
        block[me] = view.reshape(len(me), 5 * k)

    def _link_keys(self) -> np.ndarray:
        """Working links as sorted keys row * N + col (both directions), once per radio update."""
        if self._link_keys_version != self.links_version:
            adj = self.links.adjacency.tocsr()
            adj.sort_indices()
            rows = np.repeat(np.arange(adj.shape[0], dtype=np.int64), np.diff(adj.indptr))
            self._link_keys_cache = rows * adj.shape[0] + adj.indices
            self._link_keys_version = self.links_version
        return self._link_keys_cache

    @functools.cached_property
    def _shared_infos(self) -> list[dict]:
        """One info dict per (phase, role) for robots still working (read-only by convention)."""
        return [{"phase": p, "role": r} for p in PHASES for r in ROLES]

    def _info(self, i: int) -> dict:
        """Robot i's default info (`info`)."""
        reason = self.end_reason[i]
        if reason is None:
            return self._shared_infos[int(self.phase[i]) * len(ROLES) + int(self.role[i])]
        info = {"phase": PHASES[self.phase[i]], "role": ROLES[self.role[i]], "end_reason": reason}
        if reason not in ("recovered", "expended", "time_limit"):
            info["lost_reason"] = reason
        return info

    # global state ------------------------------------------------------------------------------------
    def state(self) -> np.ndarray:  # type: ignore[override]
        """Global state (`swarm.sim.layout.STATE_FIELDS` per robot, then `GLOBAL_FIELDS`)."""
        n = self.n
        per = np.zeros((n, len(STATE_FIELDS)), np.float32)
        s = self.robot_state
        per[:, 0] = self.alive
        per[:, 1:3] = s[:, :2]
        per[:, 3] = np.cos(s[:, 2])
        per[:, 4] = np.sin(s[:, 2])
        per[:, 5:8] = s[:, 3:6]
        per[:, 8] = np.clip(self.energy_wh / self.mission.hazards.battery.capacity_wh, 0.0, 1.0)
        per[:, 9] = self.inverted
        per[:, 10] = self.phase
        per[:, 11] = self.role
        mf = self.minefield
        g = np.array(
            [
                min(1.0, self.t_s / self.time_limit_s),
                mf.detected.sum(),
                mf.marked.sum(),
                mf.exploded.sum(),
                self.score.score(),
            ],
            np.float32,
        )
        assert len(g) == len(GLOBAL_FIELDS)
        return np.concatenate([per.ravel(), g])

    # rendering --------------------------------------------------------------------------------------
    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gymnasium.logger.warn("render() called without a render_mode")
            return None
        from swarm.sim.render import Renderer

        if self._renderer is None:
            self._renderer = Renderer(self)
        frame = self._renderer.frame()
        if self.render_mode == "human":
            self._renderer.show(frame)
            return None
        return frame

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def outcome(self) -> dict:
        """The success criteria now (final after the last step)."""
        return self.score.outcome()


def _nearest(points: np.ndarray, queries: np.ndarray) -> np.ndarray:
    """Index of the nearest of `points` to each query: dense for small sets, a k-d tree beyond."""
    if len(points) * len(queries) <= DENSE_NEAREST_PAIRS:
        d2 = (queries[:, None, 0] - points[None, :, 0]) ** 2 + (queries[:, None, 1] - points[None, :, 1]) ** 2
        return np.argmin(d2, axis=1)
    return cKDTree(points).query(queries)[1]
