"""`SwarmEnv`: the mission as a PettingZoo `ParallelEnv`, the adapter over one run of the batched
world core (`swarm.sim.world.World` with B = 1; or, for `swarm.sim.vector_env`, one run of a
shared batch, whose task hooks and agents it gives).

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
  sea. The built-in controller (`swarm.robot.driving`) turns commands into wheel and jet commands.
Every action of a step is checked before any is applied (`swarm.sim.actions`): a NaN, a wrong
shape, an unknown agent id or a target off the map is a `SwarmError` naming the agent, and the
step changes nothing. A robot in `agents` left out of the actions stands still (wheels) or keeps
its last command; actions for robots that have left are ignored.

A copy of an env (pickle, `copy.deepcopy`, as SuperSuit's vector wrappers make one) goes on
exactly as the original would; `copy.copy` is shallow and shares the original's world (stepping
either moves both).

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
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
from pettingzoo import ParallelEnv

from swarm.errors import SwarmError
from swarm.mission.load import load_mission
from swarm.mission.plan import MissionPlan, plan_mission
from swarm.mission.schema import Mission
from swarm.sim.actions import Commands, wheel_array, wheel_rows
from swarm.sim.layout import (
    GLOBAL_FIELDS,
    PHASES,
    ROLES,
    STATE_FIELDS,
    ObservationLayout,
    state_size,
)
from swarm.sim.observe import DENSE_NEAREST_PAIRS, Observer
from swarm.sim.runview import (
    AVOID_MINE_M,
    BEACH,
    COMMANDS,
    DONE,
    FOLLOW,
    GOTO,
    LOITER,
    MARK,
    RELAY,
    RETURN,
    RETURNING,
    ROBOT_ARRAYS,
    SEA,
    SURF,
    WAITING,
)
from swarm.sim.setup import MAX_WHEEL_SPEED_FACTOR, MUSTER_FROM_WATER_M, MissionSetup
from swarm.sim.world import (
    GROUND_SUBMERSION,
    MARK_RADIUS_M,
    PICKUP_SUBMERSION,
    STATION_KEEP_M,
    TRACK_SAMPLE_S,
    World,
    is_whole,
)

ACTION_MODES = ("wheels", "command")

__all__ = [
    "ACTION_MODES",
    "AVOID_MINE_M",
    "BEACH",
    "COMMANDS",
    "DENSE_NEAREST_PAIRS",
    "DONE",
    "FOLLOW",
    "GOTO",
    "GROUND_SUBMERSION",
    "LOITER",
    "MARK",
    "MARK_RADIUS_M",
    "MAX_WHEEL_SPEED_FACTOR",
    "MUSTER_FROM_WATER_M",
    "PICKUP_SUBMERSION",
    "RELAY",
    "RETURN",
    "RETURNING",
    "SEA",
    "STATION_KEEP_M",
    "SURF",
    "TRACK_SAMPLE_S",
    "WAITING",
    "SimConfig",
    "StepOutcome",
    "SwarmEnv",
]


@dataclass(frozen=True)
class StepOutcome:
    """What the world's step just did, handed to the task hooks (`reward`, `terminated`)."""

    score_change: float  # change of the mission score (`swarm.sim.criteria`): the default team reward
    ended: np.ndarray  # (n,) bool: robots the world took out of the mission this step (lost, expended,
    # recovered); a robot out of time is truncated instead (`time_up`)
    time_up: bool  # the time limit (or max_cycles) is reached: every robot still in is truncated


#: The longest env step: the controller steers once a step, and a robot at top speed must not
#: run past its waypoint, the map's edge or the observation's bounds in one.
MAX_STEP_S = 5.0


@dataclass(frozen=True)
class SimConfig:
    """Simulation settings that are not part of the mission, each checked (`SwarmError` naming it)."""

    dt_s: float = 0.5  # one env step
    substep_s: float = 0.25  # physics substep (the skid step is stable at any step; 0.25 s is within
    # a few cm over a 20 s manoeuvre of 0.01 s steps)
    comms_period_s: float = 5.0  # radio graph update (a mesh's neighbour tables refresh in seconds)
    patch_size: int = 5
    patch_spacing_m: float = 1.0
    neighbours: int = 4

    def __post_init__(self) -> None:
        def number(value: object) -> bool:
            return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)

        for name, top in (("dt_s", MAX_STEP_S), ("substep_s", self.dt_s), ("comms_period_s", math.inf)):
            value = getattr(self, name)
            if not (number(value) and 0 < value <= top):
                bound = f" and at most {top:g} s" if math.isfinite(top) else ""
                raise SwarmError(f"sim: SimConfig.{name} {value!r}, expected seconds > 0{bound}")
        if not (number(self.patch_spacing_m) and self.patch_spacing_m > 0):
            raise SwarmError(f"sim: SimConfig.patch_spacing_m {self.patch_spacing_m!r}, expected metres > 0")
        for name, least in (("patch_size", 1), ("neighbours", 0)):
            value = getattr(self, name)
            if not (isinstance(value, int | np.integer) and not isinstance(value, bool) and value >= least):
                raise SwarmError(f"sim: SimConfig.{name} {value!r}, expected a whole number >= {least}")


def check_seed(seed: object) -> int | None:
    """A reset's seed: None (fresh entropy) or a whole number >= 0, as `numpy.random.SeedSequence`
    takes it."""
    if seed is None:
        return None
    if not is_whole(seed) or seed < 0:  # type: ignore[operator]
        raise SwarmError(f"sim: seed {seed!r}, expected None or a whole number >= 0")
    return int(seed)  # type: ignore[call-overload]


def _as_mission(mission: str | Path | Mission, overrides: dict[str, Any] | None) -> Mission:
    if not isinstance(mission, str | os.PathLike | Mission):
        raise SwarmError(f"sim: mission {mission!r}, expected a mission file's path or a Mission")
    if overrides is not None and (
        not isinstance(overrides, Mapping) or not all(isinstance(k, str) for k in overrides)
    ):
        expected = "a dict of dotted keys to values, e.g. {'swarm.count': 20}"
        raise SwarmError(f"sim: overrides {overrides!r}, expected {expected}")
    if isinstance(mission, Mission):
        if overrides:
            source = mission.source
            if source is None:
                raise SwarmError("sim: overrides need a mission loaded from a file (pass its path)")
            return load_mission(source, overrides)
        return mission
    return load_mission(mission, overrides)


class SwarmEnv(ParallelEnv):
    """The surf-swarm mission as a PettingZoo parallel environment (module docstring): one run of
    the world core (`swarm.sim.world.World` with B = 1), its agents and the task hooks."""

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
        setup: MissionSetup | None = None,
        world: World | None = None,
        run: int = 0,
    ) -> None:
        if action_mode not in ACTION_MODES:
            raise SwarmError(f"sim: action_mode {action_mode!r}, expected one of {list(ACTION_MODES)}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise SwarmError(
                f"sim: render_mode {render_mode!r}, expected one of {self.metadata['render_modes']}"
            )
        if config is not None and not isinstance(config, SimConfig):
            raise SwarmError(f"sim: config {config!r}, expected a SimConfig (or None)")
        self.config = config or SimConfig()
        self.action_mode = action_mode
        self.render_mode = render_mode
        if setup is None:
            m = _as_mission(mission, overrides)
            plan = plan if plan is not None else plan_mission(m, seed=m.seed, workers=plan_workers)
            setup = MissionSetup(m, plan, dt_s=self.config.dt_s, substep_s=self.config.substep_s)
        self.setup = setup
        self.mission = setup.mission
        #: Whether this environment steps its own world (B = 1); one bound to run `run` of a shared
        #: batch (`swarm.sim.vector_env`) gives the batch's adapter its task hooks and agents only.
        self.owns_world = world is None
        if world is None:
            world = World(
                setup,
                1,
                comms_period_s=self.config.comms_period_s,
                max_cycles=max_cycles,
                sample_tracks=render_mode is not None,
            )
        self.world = world
        self.b = run
        self.run = world.runs[run]
        self.library = setup.library
        self.robot = setup.robot
        self.n = setup.n
        self.possible_agents = list(self.world.possible_agents)
        self.agent_index = self.world.agent_index
        self.max_steps = self.world.max_steps

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
        self._command_check = Commands(self.beach.bounds_m)
        self.state_space = gymnasium.spaces.Box(-np.inf, np.inf, (state_size(self.n),), np.float32)
        self.observer = Observer(setup, self.layout, world.B)
        self._renderer = None
        self.agents: list[str] = []
        self._was_reset = False  # step() before reset() is an error, as in Gymnasium's checker
        if self.owns_world:
            self._reset_state(0)  # arrays exist before the first reset (spaces, render)
            self.run.seed_seq = None  # ...but an unseeded first reset() draws fresh entropy

    # spaces -----------------------------------------------------------------------------------------
    def observation_space(self, agent: str) -> gymnasium.spaces.Space:
        """The space of `agent`'s observations: one object every robot shares."""
        self._check_agent(agent)
        return self._observation_box

    @functools.cached_property
    def _observation_box(self) -> gymnasium.spaces.Box:
        return self.observation_box()

    def task_observe(self) -> np.ndarray:
        """`observe()` held to `observation_box()` (cast to its dtype): a subclass whose hook gives
        another shape is told so here, not by a space check that fails later or never."""
        box = self._observation_box
        obs = np.asarray(self.observe())
        shape = (self.n, *box.shape)
        if obs.shape != shape:
            raise SwarmError(
                f"sim: {type(self).__name__}.observe() gave shape {obs.shape}, expected {shape}"
                " (a row per robot, as observation_box() says)"
            )
        return obs if obs.dtype == box.dtype else obs.astype(box.dtype)

    def task_rows(self, hook: str, step: StepOutcome) -> np.ndarray:
        """`reward(step)` as float64 or `terminated(step)` as bool, one value per robot, checked."""
        rows = np.asarray(getattr(self, hook)(step))
        if rows.shape != (self.n,):
            raise SwarmError(
                f"sim: {type(self).__name__}.{hook}() gave shape {rows.shape}, expected ({self.n},):"
                " a value per robot"
            )
        return rows.astype(np.float64 if hook == "reward" else bool, copy=False)

    def action_space(self, agent: str) -> gymnasium.spaces.Space:
        """The space of `agent`'s actions: one object every robot shares."""
        self._check_agent(agent)
        return self._act_space

    def _check_agent(self, agent: object) -> None:
        if not isinstance(agent, str) or agent not in self.agent_index:
            raise SwarmError(f"sim: agent {agent!r}, expected one of robot_0 .. robot_{self.n - 1}")

    # reset ------------------------------------------------------------------------------------------
    def _reset_state(self, seed: int | None) -> None:
        """Reset the run with `seed`; an env bound to a batch's run is reset by its batch (which
        has just reset the run with that seed) and only starts its agents over."""
        if self.owns_world:
            self.world.reset([seed], runs=[self.b])
        self.started()

    def started(self) -> None:
        """The run has just been reset (by this env, or by the batch it is bound to)."""
        self.observer.reset_run(self.b)
        self.agents = list(self.possible_agents)
        self._agent_idx = np.arange(self.n, dtype=np.intp)  # self.agents as indices, in the same order

    def synced(self) -> None:
        """The batch this env is bound to has stepped: take the agents that left out."""
        inside = self.world.in_agents[self.b]
        if not inside[self._agent_idx].all():
            self._agent_idx = np.flatnonzero(inside)
            self.agents = [self.possible_agents[i] for i in self._agent_idx.tolist()]

    def reset(self, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        obs = self.reset_arrays(seed)
        agents, idx = self.agents, self._agent_idx
        return dict(zip(agents, obs[idx], strict=True)), dict(zip(agents, self.info(idx), strict=True))

    def reset_arrays(self, seed: int | None = None) -> np.ndarray:
        """`reset` on arrays: (n, obs_dim) every robot's observation, rows in `possible_agents`
        order (infos: `info(robots)`)."""
        self._reset_state(check_seed(seed))
        self._was_reset = True
        return self.task_observe()

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
        obs = self.task_observe()
        obs[~was_in] = 0.0
        rew = np.where(was_in, self.task_rows("reward", outcome), 0.0)
        term = self.task_rows("terminated", outcome) & was_in
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
        the mission "end_reason" (and "lost_reason" if it was lost). Each robot's dict is its own
        (copied from one per (phase, role)): a caller may add to it."""
        shared = self._shared_infos
        out = [shared[k].copy() for k in (self.phase[robots] * len(ROLES) + self.role[robots]).tolist()]
        for k in np.flatnonzero(~self.alive[robots]).tolist():  # those leaving now get their own
            out[k] = self._info(int(robots[k]))
        return out

    def advance(self, actions: dict[str, Any]) -> None:
        """`step` without building observations, rewards and infos: for runners that read the
        environment's arrays directly (the scripted policy, `swarm.sim.run.simulate`)."""
        terminated, truncate, _ = self._advance(actions)
        self._finish(terminated, truncate)

    def _advance(self, actions: dict[str, Any] | np.ndarray) -> tuple[np.ndarray, bool, float]:
        """One step of the world; returns who the world ended, whether time ran out, the reward."""
        if not self._was_reset:
            raise SwarmError("sim: step() before reset()")
        if not self.agents:
            raise SwarmError("sim: step() after the episode ended; call reset()")
        if not self.owns_world:
            raise SwarmError("sim: an env bound to a batch's run is stepped by its batch")
        wheels, jet = self._commands(actions)
        ended, time_up, change = self.world.advance(wheels[None], jet[None])
        return ended[0], bool(time_up[0]), float(change[0])

    def fast_forward(self) -> int:
        """Skip ahead while every robot is off the map (`World.fast_forward`): runners use it
        (`simulate`); `step` never does. Returns the steps skipped."""
        return self.world.fast_forward(self.b)

    def _finish(self, terminated: np.ndarray, truncate: bool) -> None:
        """End the step: truncate everyone at the time limit, drop finished agents for good."""
        self.world.finish(terminated[None], np.array([truncate]))
        self.synced()

    # actions --------------------------------------------------------------------------------------
    def _commands(self, actions: dict[str, Any] | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Wheel and jet commands from the step's actions, every one checked before any is
        applied (`swarm.sim.actions`)."""
        n = self.n
        wheels = np.zeros((n, 2))
        jet = np.zeros(n)
        limits = self.limits
        if isinstance(actions, np.ndarray):  # every robot's row; only those in `agents` count
            if actions.shape != (n, 3):
                raise SwarmError(f"sim: actions of shape {actions.shape}, expected ({n}, 3)")
            idx = self._agent_idx
            if self.action_mode == "command":
                for i, cmd, target in self._command_check.from_rows(actions, idx):
                    self.set_command(i, cmd, target)
                return self.controller_commands()
            live = np.zeros(n, bool)
            live[idx] = True
            act = wheel_array(actions, live)[idx]
        elif not isinstance(actions, Mapping):
            raise SwarmError(
                f"sim: actions of type {type(actions).__name__}, expected a dict of agent id to action"
                f" (or step_arrays with an ({n}, 3) array)"
            )
        else:
            if len(self._agent_idx) < n:  # robots that have left may be given anything: ignored
                index, inside = self.agent_index, self.world.in_agents[self.b]
                actions = {a: v for a, v in actions.items() if a not in index or inside[index[a]]}
            if self.action_mode == "command":
                for i, cmd, target in self._command_check.from_dict(actions, self.agent_index):
                    self.set_command(i, cmd, target)
                return self.controller_commands()
            idx, act = wheel_rows(actions, self.agent_index)
        wheels[idx] = act[:, :2] * (limits.max_wheel_speed_mps / limits.wheel_radius_m)
        jet[idx] = act[:, 2] * limits.jet_thrust_max_n
        return wheels, jet

    def check_action(self, agent: str, action: Any) -> None:
        """`agent`'s action as a step checks it (`swarm.sim.actions`): a `SwarmError` if it is bad.
        The AEC form checks each action as its agent gives it."""
        if self.action_mode == "wheels":
            wheel_rows({agent: action}, self.agent_index)
        else:
            self._command_check.from_dict({agent: action}, self.agent_index)

    def set_command(self, i: int, command: int, target: np.ndarray | None = None) -> None:
        """Give robot i a high-level command (`COMMANDS`); used by command mode and the policy."""
        self.run.set_command(i, command, target)

    def set_route(
        self, i: int, waypoints: np.ndarray, role: str | None = None, track_from: int | None = None
    ) -> None:
        """Replace robot i's route (and role); it follows it under the `follow` command, clear of the
        objects found and not yet marked."""
        self.run.set_route(i, waypoints, role, track_from)

    def controller_commands(self) -> tuple[np.ndarray, np.ndarray]:
        """Wheel and jet commands for every robot from its command, route and target."""
        wheels, jet = self.world.controller_commands()
        return wheels[self.b], jet[self.b]

    def route_goal(self) -> np.ndarray:
        """(n, 2) the last point of each robot's route (its own position without one)."""
        return self.run.route_goal()

    _route_goal = route_goal

    def lose(self, agent: str, cause: str = "failure") -> None:
        """Take a robot out of the mission now, as if `cause` had struck it: for what-if
        experiments (how does the swarm cope without this relay?) and tests. It is reported
        terminated on the next step, like any loss."""
        self._check_agent(agent)
        self.run.lose_now(self.agent_index[agent], cause)

    def _event(self, kind: str, robot: int | None = None, **data: Any) -> None:
        self.run.log_event(kind, robot, **data)

    # observations ------------------------------------------------------------------------------------
    def _observe(self) -> np.ndarray:
        """The default observation (`swarm.sim.observe`), (n, obs_dim)."""
        return self.observer.observe(self.world, [self.b])[0]

    @functools.cached_property
    def _shared_infos(self) -> list[dict]:
        """One info dict per (phase, role) for robots still working, which `info` copies."""
        return [{"phase": p, "role": r} for p in PHASES for r in ROLES]

    def _info(self, i: int) -> dict:
        """Robot i's default info (`info`)."""
        reason = self.end_reason[i]
        if reason is None:
            return self._shared_infos[int(self.phase[i]) * len(ROLES) + int(self.role[i])].copy()
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
        return self.run.outcome()


def _delegate_run(name: str, robot_array: bool) -> property:
    def get(self: SwarmEnv) -> Any:
        return getattr(self.run, name)

    def put(self: SwarmEnv, value: Any) -> None:
        if robot_array:  # a view of the world's arrays: written in place, never rebound
            getattr(self.run, name)[...] = value
        else:
            setattr(self.run, name, value)

    return property(get, put, doc=f"The run's `{name}` (`swarm.sim.runview.RunView`).")


def _delegate_setup(name: str) -> property:
    return property(lambda self: getattr(self.setup, name), doc=f"`MissionSetup.{name}`.")


for _name in ROBOT_ARRAYS:
    setattr(SwarmEnv, _name, _delegate_run(_name, True))
for _name in (
    "t_s", "steps", "events", "minefield", "objects_m", "object_mine", "object_marker", "links",
    "links_version", "relay_up", "score", "cleared", "tracks", "end_reason", "rngs", "seed",
    "sensor", "radio_net", "hidden_rocks_m", "router",
):  # fmt: skip
    setattr(SwarmEnv, _name, _delegate_run(_name, False))
for _name in (
    "plan", "beach", "limits", "radio", "fixed_m", "fixed_height_m", "search_task", "clearance",
    "relay_task", "release_s", "arrive_s", "launch_m", "entry_m", "plan_role", "on_beach_launch",
    "swim_power_w", "pickup_m", "physics", "sea", "time_limit_s", "dry_ground",
):  # fmt: skip
    setattr(SwarmEnv, _name, _delegate_setup(_name))
SwarmEnv.wave_phase_s = property(lambda self: self.run.wave_phase_s)  # type: ignore[attr-defined]
SwarmEnv.routes = property(  # type: ignore[attr-defined]
    lambda self: self.world.routes if self.owns_world else self.run.routes
)
SwarmEnv.hazard_model = property(lambda self: self.world.hazard_model)  # type: ignore[attr-defined]
