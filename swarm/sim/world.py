"""`World`: B independent runs of one mission, advanced together on (B, n, ...) arrays.

```python
world = World(MissionSetup(mission, plan, dt_s=0.5, substep_s=0.25), runs=8, comms_period_s=5.0)
world.reset(seeds=[1, 2, 3, 4, 5, 6, 7, 8])
while world.in_agents.any():
    wheels, jet = world.controller_commands()      # or from actions, (B, n, 2) and (B, n)
    ended, time_up, score_change = world.advance(wheels, jet)
    world.finish(ended, time_up)
```

Every per-robot quantity is one array over the batch, (B, n, ...), run-major: pose and velocities,
liveness, phase, battery, role, command and target, timers. One `advance` moves every run that is
still going by one step of `dt_s`: release and sea transit, physics (`swarm.sim.physics`, all
robots of all runs in one vectorized call, each run with its own waves), energy, breakers turning
robots over, route following, phases, sensing (`swarm.sim.sensing`), marks, radio
(`swarm.sim.comms`), hazards (`swarm.sim.hazards`, one vectorized pass with each run's own draws),
the synchronized clearance, recovery and the success criteria (`swarm.sim.criteria`).

What is event-driven stays per run (`swarm.sim.runview.RunView`, one per run, whose arrays are
views of the batch's): the mine field, the sensor's passes, the radio graph, the score, the events
logged, the objects to mark, the random streams. Each run has its own seed and streams
(`reset`), drawn exactly as a lone run draws them, so a run's result is the same whether it runs
alone or in a batch of any size, bit for bit: every batch-wide operation is elementwise over robots
or reduces over one robot's row, never across runs.

The core knows nothing of agents as names, dicts or gymnasium: the adapters (`swarm.sim.env`,
`swarm.sim.vector`, `swarm.sim.run`) build those on top, and the scripted policy
(`swarm.sim.policy`) reads and commands each run through its `RunView`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numba
import numpy as np
from numba.typed import List
from scipy.spatial import cKDTree

from swarm.errors import SwarmError
from swarm.robot.driving import afloat, drive_toward, steer_point
from swarm.robot.terrain import GROUND_SUBMERSION
from swarm.sim import comms, draws, hazards, sensing
from swarm.sim.criteria import STATION_RADIUS_M, MissionScore
from swarm.sim.mines import lay_mines
from swarm.sim.routes import Routes
from swarm.sim.runview import (
    AVOID_MINE_M,
    BEACH,
    DONE,
    FOLLOW,
    LOITER,
    MARK,
    RELAY,
    RETURN,
    RETURNING,
    SEA,
    SURF,
    WAITING,
    RunView,
)
from swarm.sim.sensor_batch import SensorBatch
from swarm.sim.setup import MissionSetup

#: A marking robot marks the object it loiters by within this distance (m).
MARK_RADIUS_M = 1.0
#: Above this submersion a returning robot is afloat beyond the surf and picked up.
PICKUP_SUBMERSION = 0.99
#: A robot at the end of its route drives back to it once it has drifted this far (m): robots
#: creep down the beach's slope and are pushed by the swash, and a station (beacon, observation
#: point) counts only within `swarm.sim.criteria.STATION_RADIUS_M` (3 m).
STATION_KEEP_M = 1.0
#: Seconds between trajectory samples kept for rendering tracks.
TRACK_SAMPLE_S = 5.0
#: Batches of this many runs or more draw from a typed list of their generators (`stream_typed`).
TYPED_STREAMS_MIN_RUNS = 32
#: The streams a run's seed is spawned into, in this order (`reset`).
STREAMS = ("mines", "waves", "sensing", "radio", "hazards", "policy", "rocks")
#: The causes a continuous hazard's clock decides (`hazards.RATE_CAUSES`), as cause codes.
_RATE_CAUSE_CODES = np.array([hazards.CAUSES.index(c) for c in hazards.RATE_CAUSES])


def is_whole(value: object) -> bool:
    """An int (numpy's too), not a bool: a float or a string is refused, not rounded or parsed."""
    return isinstance(value, int | np.integer) and not isinstance(value, bool)


class World:
    """B runs of one mission on (B, n, ...) arrays (module docstring)."""

    def __init__(
        self,
        setup: MissionSetup,
        runs: int,
        *,
        comms_period_s: float = 5.0,
        max_cycles: int | None = None,
        sample_tracks: bool = False,
    ) -> None:
        if runs < 1:
            raise SwarmError(f"sim: a world needs at least one run, found {runs}")
        if max_cycles is not None and (not is_whole(max_cycles) or max_cycles < 1):
            raise SwarmError(f"sim: max_cycles {max_cycles!r}, expected None or a whole number >= 1")
        b, n = int(runs), setup.n
        self.setup = setup
        self.B, self.n = b, n
        self.dt_s = setup.dt_s
        self.comms_period_s = float(comms_period_s)
        steps = setup.steps_to_limit
        self.max_steps = steps if max_cycles is None else min(steps, int(max_cycles))
        self.sample_tracks = sample_tracks
        #: Whether `advance` computes the score change every step (the adapters' reward; a study
        #: needs only the final outcome).
        self.score_every_step = True
        self.possible_agents = [f"robot_{i}" for i in range(n)]
        self.agent_index = {a: i for i, a in enumerate(self.possible_agents)}
        self.run_of = np.repeat(np.arange(b, dtype=np.intp), n)

        self.robot_state = np.zeros((b, n, 6))
        self.alive = np.zeros((b, n), bool)  # in the mission: not lost, recovered or expended
        self.on_map = np.zeros((b, n), bool)
        self.phase = np.full((b, n), WAITING, dtype=np.int64)
        self.energy_wh = np.zeros((b, n))
        self.inverted = np.zeros((b, n), bool)
        self.radio_ok = np.ones((b, n), bool)
        self.sea_time_s = np.zeros((b, n))
        self.surf_time_s = np.zeros((b, n))
        self.isolated_s = np.zeros((b, n))
        self.slip = np.zeros((b, n))
        self.submersion = np.zeros((b, n))
        self.terrain_now = np.zeros((b, n), dtype=np.intp)
        self.distance_m = np.zeros((b, n))
        self.lost_at = np.full((b, n, 3), np.nan)  # t, x, y
        self.command = np.full((b, n), FOLLOW, dtype=np.int64)
        self.target_m = np.zeros((b, n, 2))
        self.marking = np.full((b, n), -1, dtype=np.int64)  # object index a robot marks
        # True: the robot has placed its mark on that object (the object's marker is the robot;
        # cleared whenever `marking` changes), so `_update_marks` passes it by
        self.mark_placed = np.zeros((b, n), bool)
        self.role = np.tile(setup.plan_role, (b, 1))
        self.link_degree = np.zeros((b, n), dtype=np.intp)
        self.source_hops = np.full((b, n), -1, dtype=np.intp)
        self.pending_terminated = np.zeros((b, n), bool)
        self.in_agents = np.zeros((b, n), bool)  # robots still in their episode
        self.t_s = np.zeros(b)
        self.steps = np.zeros(b, dtype=np.int64)
        self.wave_phase_s = np.zeros(b)
        self.next_comms_s = np.zeros(b)  # each run's next radio update (s)
        self.links_version = np.zeros(b, dtype=np.int64)  # each run's radio updates so far
        # runs whose score is looked at every step (timed criteria), and runs whose counts
        # (detections, recoveries) changed since it was last looked at, or that just began
        self.score_timed = np.zeros(b, bool)
        self.score_stale = np.ones(b, bool)
        #: (B,) the runs whose criteria `_score` looked at this step: only theirs may have changed
        self.scored = np.ones(b, bool)
        self.beach_started = np.zeros(b, bool)  # each run's `score.beach_start_s` is known
        self.object_count = np.zeros(b, dtype=np.int64)  # each run's objects found (`RunView`)
        #: (B,) changes so far to each run's objects and their markers (`RunView`; `Observer` reads it)
        self.objects_version = np.zeros(b, dtype=np.int64)
        self._streams: dict[str, list] = {}  # each run's generator of a stream, by stream
        self._typed_streams: dict[str, List] = {}  # the same, for compiled loops (`draws`)
        self.routes = Routes(b * n)
        self._sense_xy = np.full((b * n, 2), np.nan)  # each sensor's last positions (views)
        self._flat: dict[str, np.ndarray] = {}
        self.runs = [RunView(self, k) for k in range(b)]
        self.hazard_model: hazards.HazardModel | None = None
        self.sensors: SensorBatch | None = None

    def sense_rows(self, b: int) -> np.ndarray:
        """Run b's rows of the sensors' last positions, a view (its `MineSensor` keeps them)."""
        return self._sense_xy[b * self.n : (b + 1) * self.n]

    def __getstate__(self) -> dict:
        """A copy (pickle, `copy.deepcopy`: SuperSuit's `concat_vec_envs_v1` copies an env so)
        keeps every array; the caches of views and generator lists are made again as used."""
        state = self.__dict__.copy()
        state["_flat"], state["_streams"], state["_typed_streams"] = {}, {}, {}
        return state

    def __setstate__(self, state: dict) -> None:
        """The runs' views made again, of this copy's arrays: pickle copies a view as an array
        of its own, and a copy whose runs wrote to those would never move (`RunView.bind`)."""
        self.__dict__.update(state)
        for run in self.runs:
            run.bind()

    def flat(self, name: str) -> np.ndarray:
        """A per-robot array as (B * n, ...), a view (the arrays are never rebound, so the views
        are made once)."""
        view = self._flat.get(name)
        if view is None:
            a = getattr(self, name)
            view = self._flat[name] = a.reshape(self.B * self.n, *a.shape[2:])
        return view

    # reset ------------------------------------------------------------------------------------------
    def reset(self, seeds: Sequence[int | None], runs: Sequence[int] | None = None) -> None:
        """Start runs `runs` (all by default) anew, run `runs[k]` with seed `seeds[k]`. A None seed
        carries on the run's seeded stream (Gymnasium's rule), or draws fresh entropy the first time."""
        runs = list(range(self.B)) if runs is None else [int(b) for b in runs]
        if len(seeds) != len(runs):
            raise SwarmError(f"sim: {len(seeds)} seeds for {len(runs)} runs")
        for b, seed in zip(runs, seeds, strict=True):
            self._reset_run(b, seed)
        fields = [self.runs[b].minefield for b in runs]
        rocks = [self.runs[b].hidden_rocks_m for b in runs]
        if self.hazard_model is None:
            if runs != list(range(self.B)):
                raise SwarmError("sim: the first reset of a world starts every run")
            s, m = self.setup, self.setup.mission
            self.hazard_model = hazards.HazardModel(
                m.hazards, m.phases, s.beach.terrain_classes, s.library, fields, rocks, self.n
            )
            self.sensors = SensorBatch([r.sensor for r in self.runs], self.n)
        else:
            self.hazard_model.reset_runs(runs, fields, rocks)
            assert self.sensors is not None
            for b in runs:
                self.sensors.sensors[b] = self.runs[b].sensor
                self.sensors.dirty(b)
        for b in runs:
            run = self.runs[b]
            run.log_event("mission_start", seed=run.seed, robots=self.n, mines=len(run.minefield))
        self._release(np.isin(np.arange(self.B), runs))

    def _reset_run(self, b: int, seed: int | None) -> None:
        s, m, run, n = self.setup, self.setup.mission, self.runs[b], self.n
        prev = getattr(run, "seed_seq", None)
        # an unseeded reset after a seeded one carries on the seeded stream
        ss = np.random.SeedSequence(seed) if seed is not None or prev is None else prev.spawn(1)[0]
        run.seed_seq = ss
        run.rngs = dict(zip(STREAMS, (np.random.default_rng(c) for c in ss.spawn(len(STREAMS))), strict=True))
        for kept in (self._streams, self._typed_streams):
            for name, gens in kept.items():
                gens[b] = run.rngs.get(name)
        run.seed = seed
        run.router.calls = 0  # replanning seeds count from the episode's start
        self.t_s[b] = 0.0
        self.steps[b] = 0
        self.wave_phase_s[b] = float(run.rngs["waves"].uniform(0.0, s.sea.wave_period_s))
        run.minefield = lay_mines(m, run.rngs["mines"], s.plan.costmap)
        run.hidden_rocks_m = hazards.hidden_rocks_in_cells(
            m.hazards, s.dry_cells, s.beach.cell_m, run.rngs["rocks"]
        )
        run.sensor = (
            sensing.MineSensor(s.search_task.sensor, run.minefield, n, s.clutter)
            if s.search_task is not None
            else None
        )
        last = self.sense_rows(b)
        last[:] = np.nan
        if run.sensor is not None:
            run.sensor._last_xy = last
        run.radio_net = comms.RadioNet(
            s.radio,
            n,
            s.fixed_m,
            fixed_height_m=s.fixed_height_m,
            decorrelation_m=m.hazards.comms.decorrelation_m,
        )
        state = self.robot_state[b]
        state[:] = 0.0
        state[:, :2] = s.launch_m
        d = s.entry_m - s.launch_m
        state[:, 2] = np.arctan2(d[:, 1], d[:, 0])
        self.alive[b] = True
        self.on_map[b] = False
        self.phase[b] = WAITING
        self.energy_wh[b] = s.capacity_wh
        self.inverted[b] = False
        self.radio_ok[b] = True
        for name in ("sea_time_s", "surf_time_s", "isolated_s", "slip", "submersion", "distance_m"):
            getattr(self, name)[b] = 0.0
        self.terrain_now[b] = 0
        self.lost_at[b] = np.nan
        self.command[b] = FOLLOW
        self.target_m[b] = state[:, :2]
        self.marking[b] = -1
        self.mark_placed[b] = False
        self.role[b] = s.plan_role
        self.pending_terminated[b] = False
        self.in_agents[b] = True
        run.end_reason = [None] * n
        for i, (wp, track_from) in enumerate(s.initial_routes):
            run.routes.set(i, wp, track_from)
        if self.routes._used > 8 * max(1, int((self.routes.end - self.routes.start).sum())):
            self.routes.compact()
        run.objects_m = np.empty((0, 2))
        run.object_mine = np.empty(0, dtype=np.int64)
        run.object_marker = np.empty(0, dtype=np.int64)
        run.links = run.radio_net.update(state[:, :2], np.zeros(n, bool), run.rngs["radio"])
        self.link_degree[b] = run.links.degree
        self.source_hops[b] = run.links.source_hops
        self.next_comms_s[b] = 0.0
        self.links_version[b] = 0
        run.relay_up = None
        run.relay_was_up = False
        redundancy = s.relay_task.redundancy if s.relay_task is not None else None
        run.score = MissionScore(m, redundancy, len(run.minefield))
        run.score_prev = 0.0
        self.score_timed[b] = run.score.timed
        self.score_stale[b] = True
        self.beach_started[b] = False
        run.cleared = False
        run.events = []
        run.phase_seen = set()
        run.tracks = []
        run.next_track_s = 0.0

    # commands ---------------------------------------------------------------------------------------
    def controller_commands(self) -> tuple[np.ndarray, np.ndarray]:
        """Wheel (B, n, 2) and jet (B, n) commands for every robot from its command, route and
        target: the built-in controller (`swarm.robot.driving`) of command mode and the policy."""
        s = self.setup
        state = self.flat("robot_state")
        r = self.routes
        target, moving = np.empty((len(state), 2)), np.empty(len(state), bool)
        _command_targets(
            r.points, r.start, r.end, r.cursor, state, self.flat("command"), self.flat("target_m"),
            self.flat("alive"), self.flat("on_map"), afloat(self.flat("submersion")), target, moving,
        )  # fmt: skip
        wheels, jet, _ = drive_toward(
            state,
            target,
            s.limits.cruise_speed_mps,
            self.flat("submersion"),
            self.flat("inverted"),
            s.limits,
            moving,
        )
        return wheels.reshape(self.B, self.n, 2), jet.reshape(self.B, self.n)

    # the step ---------------------------------------------------------------------------------------
    def stream(self, name: str) -> list:
        """Each run's generator of stream `name` (None where a run has none), the list kept until
        a run is reset: the step asks for it every time."""
        gens = self._streams.get(name)
        if gens is None:
            gens = self._streams[name] = [run.rngs.get(name) for run in self.runs]
        return gens

    def stream_typed(self, name: str) -> List | list:
        """`stream(name)` for draws in compiled loops (`swarm.sim.draws`): a `numba.typed.List` in
        batches of `TYPED_STREAMS_MIN_RUNS` runs or more, else the plain list (a process's first
        typed list costs 0.4 s of compilation, more than a small batch's draws save). Every run
        has each of `STREAMS`."""
        if self.B < TYPED_STREAMS_MIN_RUNS:
            return self.stream(name)
        gens = self._typed_streams.get(name)
        if gens is None:
            gens = self._typed_streams[name] = List(self.stream(name))
        return gens

    def stream_of(self, name: str, runs: Sequence[int]) -> List | list:
        """The generators of stream `name` of `runs` (distinct, ascending), in order, for `draws`:
        `stream_typed` when they are every run."""
        if len(runs) == self.B:
            return self.stream_typed(name)
        gens = self.stream(name)
        return [gens[b] for b in runs]

    def advance(self, wheels: np.ndarray, jet: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One step of every run still going, with wheel (B, n, 2) rad/s and jet (B, n) N commands.
        Returns (B, n) robots the world took out of the mission this step (lost, expended,
        recovered), (B,) runs whose time is up, and (B,) the change of each run's score (0 unless
        `score_every_step`). Call `finish` with the first two to end the step."""
        going = self.in_agents.any(axis=1)
        if not going.any():
            raise SwarmError("sim: step() after the episode ended; call reset()")
        s, dt, n = self.setup, self.dt_s, self.n
        live = np.flatnonzero(going).tolist()
        self.steps[going] += 1
        self.t_s[going] = self.steps[going] * dt
        moving = self.alive & self.on_map & going[:, None]
        state = self.flat("robot_state")
        if self.B == 1:  # one run: its time and wave phase as scalars
            t0, phase, run_of = float(self.t_s[0]) - dt, float(self.wave_phase_s[0]), None
        else:
            t0, phase, run_of = self.t_s - dt, self.wave_phase_s, self.run_of
        res = s.physics.step(
            state,
            np.asarray(wheels, np.float64).reshape(-1, 2),
            np.asarray(jet, np.float64).reshape(-1),
            self.flat("inverted"),
            t0,
            dt,
            phase,
            active=moving.ravel(),
            run=run_of,
        )
        state[:] = res.state
        mv = moving.ravel()
        at_sea = np.empty((self.B, n), bool)
        _take_step(
            mv, self.flat("alive"), self.flat("on_map"), self.flat("phase"), res.slip, res.submersion,
            res.terrain, res.distance_m, res.power_w, float(s.swim_power_w), float(s.hotel_power_w), dt,
            self.flat("slip"), self.flat("submersion"), self.flat("terrain_now"), self.flat("distance_m"),
            self.flat("energy_wh"), at_sea.reshape(-1),
        )  # fmt: skip
        hits = res.wave_hits.reshape(self.B, n) & moving
        self._flip(hits, res.wave_height_m.reshape(self.B, n))
        self.routes.advance(state[:, :2], mv, afloat(self.flat("submersion")))
        self._update_phases(res.in_surf.reshape(self.B, n) & moving, live)
        self._release(going)
        self._sense(live)
        self._update_marks()
        self._update_comms(live)
        terminated = self._hazards(res, at_sea, going, live) | self.pending_terminated
        self.pending_terminated[going] = False
        self._clearance(terminated, live)
        self._recover(terminated)
        time_up = going & (self.steps >= self.max_steps)
        change = self._score(live, time_up)
        if self.sample_tracks:
            self._sample_tracks(live)
        return terminated, time_up, change

    def finish(self, terminated: np.ndarray, time_up: np.ndarray) -> None:
        """End the step: truncate every live robot of a run whose time is up, take the robots that
        left out of their episodes, and log the end of every run that has no robot left."""
        had = self.in_agents.any(axis=1)
        for b in np.flatnonzero(time_up).tolist():
            run = self.runs[b]
            for i in np.flatnonzero(self.alive[b]).tolist():
                self.alive[b, i] = False
                run.end_reason[i] = "time_limit"
            self.in_agents[b] = False
        self.in_agents &= ~terminated
        for b in np.flatnonzero(had & ~self.in_agents.any(axis=1)).tolist():
            run = self.runs[b]
            run.score.at_end = True
            run.log_event("mission_end", outcome=run.score.outcome())

    def off_map(self, runs: list[int]) -> list[int]:
        """The runs of `runs` still going with no robot on the map: the ones `fast_forward` may
        skip ahead (it returns 0 for every other run)."""
        runs_ = np.asarray(runs, dtype=np.intp)
        ashore = (self.alive[runs_] & self.on_map[runs_]).any(axis=1)
        return runs_[self.in_agents[runs_].any(axis=1) & ~ashore].tolist()

    def fast_forward(self, b: int) -> int:
        """Skip run b ahead while every robot is off the map (waiting on the platform or swimming in
        offshore), up to one step before the next release or arrival: one stride instead of many
        identical steps. Only memoryless hazards act at sea (random failure, radio dropout), so a
        stride of k steps draws losses with exactly the probability k steps would; a loss is
        logged when its hazard's clock struck within the stride (the robot leaves the mission at
        the stride's end). Returns the steps skipped (0 when a robot is on the map
        or the next event is within two steps). Runners use it (`simulate`); `step` never does."""
        s, run, dt = self.setup, self.runs[b], self.dt_s
        alive, phase, on_map = self.alive[b], self.phase[b], self.on_map[b]
        if not np.count_nonzero(self.in_agents[b]) or np.count_nonzero(alive & on_map):
            return 0
        waiting = alive & (phase == WAITING)
        swimming = alive & (phase != WAITING) & ~on_map
        events = [s.release_s[waiting], s.arrive_s[swimming]]
        if s.clearance is not None and not run.cleared:
            events.append(np.array([s.clearance.at_s]))
        upcoming = np.concatenate(events)
        if not len(upcoming):
            return 0
        t = float(self.t_s[b])
        steps = int(self.steps[b])
        k = math.floor((float(upcoming.min()) - t) / dt + 1e-9) - 1
        k = min(k, self.max_steps - steps - 1)
        if k < 2:
            return 0
        stride = k * dt
        at_sea = swimming & (phase == SEA)
        self.energy_wh[b] -= np.where(at_sea, s.swim_power_w + s.hotel_power_w, 0.0) * stride / 3600.0
        self.sea_time_s[b] += np.where(at_sea, stride, 0.0)
        self.steps[b] = steps + k
        self.t_s[b] = (steps + k) * dt
        n = self.n
        inp = hazards.HazardInputs(
            t_s=float(self.t_s[b]),
            dt_s=stride,
            alive=alive & (phase != WAITING),
            at_sea=at_sea,
            xy=self.robot_state[b, :, :2],
            terrain=self.terrain_now[b],
            distance_m=np.zeros(n),
            slip=np.zeros(n),
            driving=np.zeros(n, bool),
            wave_hits=np.zeros(n, bool),
            obstacle_hit=np.full(n, -1),
            energy_wh=self.energy_wh[b],
            sea_time_s=self.sea_time_s[b],
            surf_time_s=self.surf_time_s[b],
            isolated_s=np.zeros(n),
            radio_ok=self.radio_ok[b],
        )
        self.pending_terminated[b] |= self._apply_hazards(inp, [b], timed=True)
        return k

    # mission mechanics ------------------------------------------------------------------------------
    def _release(self, going: np.ndarray) -> None:
        """Robots leave the platform, and those that have swum in appear at their launch points."""
        s = self.setup
        t = (self.t_s + 1e-9)[:, None]
        ok = self.alive & going[:, None]
        leaving = ok & (self.phase == WAITING) & (s.release_s[None, :] <= t)
        for b, i in zip(*np.nonzero(leaving), strict=True):
            run = self.runs[b]
            self.phase[b, i] = BEACH if s.on_beach_launch else SEA
            run.log_event("release", int(i))
            run.global_phase("sea_transit" if not s.on_beach_launch else "beach_operations")
        off = ok & ~self.on_map
        arriving = off & (self.phase != WAITING) & (s.arrive_s[None, :] <= t)
        if s.on_beach_launch:
            arriving |= off & (self.phase == BEACH)
        for b, i in zip(*np.nonzero(arriving), strict=True):
            self.on_map[b, i] = True
            self.runs[b].log_event("arrive", int(i))

    def _update_phases(self, in_surf: np.ndarray, live: list[int]) -> None:
        s, dt = self.setup, self.dt_s
        # stranded in the surf: time in the surf zone before first getting ashore
        self.surf_time_s += np.where(in_surf & (self.phase <= SURF), dt, 0.0)
        self.sea_time_s += np.where(self.alive & (self.phase == SEA), dt, 0.0)
        to_surf = self.alive & (self.phase == SEA) & in_surf
        for b, i in zip(*np.nonzero(to_surf), strict=True):
            self.phase[b, i] = SURF
            self.runs[b].log_event("surf", int(i))
            self.runs[b].global_phase("surf_crossing")
        ground = (
            self.alive
            & self.on_map
            & (self.submersion < GROUND_SUBMERSION)
            & ((self.phase == SEA) | (self.phase == SURF))
        )
        for b, i in zip(*np.nonzero(ground), strict=True):
            self.phase[b, i] = BEACH
            self.runs[b].log_event("ashore", int(i))
            self.runs[b].global_phase("beach_operations")
        phases = s.mission.phases
        if phases.return_to_sea.enabled:
            late = (self.t_s >= s.mission.beach_end_s).tolist()
            for b in live:
                if late[b]:
                    self.runs[b].global_phase("return_to_sea")

    def _flip(self, hits: np.ndarray, height_m: np.ndarray) -> None:
        """Breakers turn robots over: flip_probability for a full breaker, in proportion to the
        local breaker height below it. With `hazards.enabled` false none does (a rolled robot can
        overstay the surf crossing); the draws are still made, to keep the stream."""
        runs = np.flatnonzero(hits.any(axis=1))
        if not len(runs):
            return
        surf = self.setup.mission.hazards.surf
        enabled = self.setup.mission.hazards.enabled
        n = self.n
        u = np.empty((len(runs), n))  # each run's n draws from its own wave stream, run after run
        draws.fill_uniform(self.stream_typed("waves"), runs, np.arange(len(runs) + 1) * n, u.reshape(-1))
        p = surf.flip_probability * np.minimum(1.0, height_m[runs] / max(surf.wave_height_m, 1e-9))
        flips = hits[runs] & (u < p) & enabled
        self.inverted[runs] ^= flips
        for k, i in zip(*np.nonzero(flips), strict=True):
            b = int(runs[k])
            self.runs[b].log_event("flip", int(i), inverted=bool(self.inverted[b, i]))

    def _sense(self, live: list[int]) -> None:
        if self.setup.search_task is None:
            return
        assert self.sensors is not None
        sensing_now = self.alive & self.on_map & (self.phase >= BEACH)
        xy = self.flat("robot_state")[:, :2]
        # column by column: numpy's all(axis=1) over pairs costs ten times more
        flat_sensing = sensing_now.ravel() & np.isfinite(xy[:, 0]) & np.isfinite(xy[:, 1])
        rngs = self.stream_typed("sensing")
        found = self.sensors.step(
            xy,
            self._sense_xy,
            flat_sensing,
            self.flat("alive"),
            self.flat("distance_m"),
            live,
            self.t_s,
            rngs,
        )
        for b in sorted(b for b, reports in found.items() if reports):  # most runs find nothing
            self.sensors.dirty(b)
            run = self.runs[b]
            run.score.detected = np.count_nonzero(run.minefield.detected)
            self.score_stale[b] = True
            for det in found[b]:
                self._report(run, det)

    def _report(self, run: RunView, det: sensing.Detection) -> None:
        b = run.b
        xy = np.asarray(det.xy, dtype=np.float64)
        # everyone on the move, those on their way to mark another find too: not a placed marker
        who = np.flatnonzero(self.alive[b] & self.on_map[b] & ~self.mark_placed[b])
        n = self.n
        for g in self.routes.may_pass(who + b * n, self.robot_state[b, who, :2], xy, AVOID_MINE_M).tolist():
            run.routes.steer_clear(g - b * n, self.robot_state[b, g - b * n, :2], xy[None], AVOID_MINE_M)
        run.objects_m = np.vstack([run.objects_m, xy[None]])
        run.object_mine = np.append(run.object_mine, det.mine)
        run.object_marker = np.append(run.object_marker, -1)
        kind = "detection" if det.mine >= 0 else "false_alarm"
        run.log_event(
            kind, det.robot, object=len(run.objects_m) - 1, mine=det.mine, at_m=[round(v, 2) for v in det.xy]
        )

    def _update_marks(self) -> None:
        """Each marking robot within `MARK_RADIUS_M` of its object marks it, if nobody has yet:
        the distances of every run's markers at once (a marker's target is its object,
        `RunView.set_command`), then the few marks, run by run."""
        # run-major, as the runs log; a robot on the mark it placed has nothing to do
        bs, who = np.nonzero(self.alive & (self.marking >= 0) & ~self.mark_placed)
        if not len(bs):
            return
        k = self.marking[bs, who]
        d = self.robot_state[bs, who, :2] - self.target_m[bs, who]
        near = np.flatnonzero(np.hypot(d[:, 0], d[:, 1]) <= MARK_RADIUS_M)
        for b, i, obj in zip(bs[near].tolist(), who[near].tolist(), k[near].tolist(), strict=True):
            run = self.runs[b]
            if run.object_marker[obj] < 0:
                run.set_marker(obj, i)
                run.mark_placed[i] = True
                if run.object_mine[obj] >= 0:
                    run.minefield.marked[run.object_mine[obj]] = True
                run.log_event("mark", i, object=obj, mine=int(run.object_mine[obj]))

    def _update_comms(self, live: list[int]) -> None:
        """Update the radio graphs of the live runs whose radio period is up, all in one batch
        (`comms.update_nets`: each run still draws from its own generator), then log relay
        changes."""
        s = self.setup
        cutoff = s.mission.hazards.comms.cutoff_s
        live_ = np.asarray(live, dtype=np.intp)
        due = live_[self.t_s[live_] + 1e-9 >= self.next_comms_s[live_]].tolist()
        if not due:
            return
        t = self.t_s[due]
        up = self.alive[due] & self.on_map[due] & self.radio_ok[due]
        if cutoff is not None:
            up &= (t < cutoff)[:, None]
        runs = [self.runs[b] for b in due]
        nets = [run.radio_net for run in runs]
        xy = self.robot_state[due, :, :2]
        links = comms.update_nets(nets, xy, up, self.stream_of("radio", due))
        self.link_degree[due] = [x.degree for x in links]
        self.source_hops[due] = [x.source_hops for x in links]
        self.next_comms_s[due] = t + self.comms_period_s
        self.links_version[due] += 1
        for run, run_links in zip(runs, links, strict=True):
            run.links = run_links
            if s.relay_task is not None:
                now = bool(run.links.fixed_linked(s.relay_task.redundancy))
                if now != bool(run.relay_up):
                    if now:
                        run.log_event("relay_repair" if run.relay_was_up else "relay_connected")
                    else:
                        run.log_event("relay_break")
                run.relay_was_up |= now
                run.relay_up = now

    def _hazards(self, res, at_sea: np.ndarray, going: np.ndarray, live: list[int]) -> np.ndarray:
        """Apply this step's losses; returns (B, n) the robots terminated by them."""
        dt, n = self.dt_s, self.n
        linked = self.link_degree > 0
        iso = np.where(linked | ~self.on_map, 0.0, self.isolated_s + dt)
        every = len(live) == self.B
        if every:
            self.isolated_s[...] = iso
        else:
            self.isolated_s[going] = iso[going]
        rows = None if every else np.repeat(going, n)
        on_map = self.flat("on_map")

        def pick(a: np.ndarray) -> np.ndarray:  # (B, n, ...) or already flat (B * n, ...)
            a = a.reshape(self.B * n, *a.shape[2:]) if a.shape[:2] == (self.B, n) else a
            return a if every else a[rows]

        inp = hazards.HazardInputs(
            t_s=float(self.t_s[live[0]]),
            dt_s=dt,
            alive=pick(self.alive & (self.phase != WAITING)),
            at_sea=pick(at_sea),
            xy=pick(self.flat("robot_state")[:, :2]),
            terrain=pick(self.flat("terrain_now")),
            distance_m=pick(self.flat("distance_m")),
            slip=pick(self.flat("slip")),
            driving=pick(np.abs(res.slip) > 0),  # the physics reports slip only while the wheels turn
            wave_hits=pick(res.wave_hits & on_map),
            wave_height_m=pick(res.wave_height_m),
            obstacle_hit=pick(np.where(on_map, res.obstacle_hit, -1)),
            energy_wh=pick(self.flat("energy_wh")),
            sea_time_s=pick(self.flat("sea_time_s")),
            surf_time_s=pick(self.flat("surf_time_s")),
            isolated_s=pick(self.flat("isolated_s")),
            radio_ok=pick(self.flat("radio_ok")),
        )
        lost = np.zeros((self.B, n), bool)
        lost[going] = self._apply_hazards(inp, live).reshape(len(live), n)
        return lost

    def _apply_hazards(self, inp: hazards.HazardInputs, runs: list[int], timed: bool = False) -> np.ndarray:
        """Draw this step's (or stride's) losses of runs `runs` and log them; returns who was lost
        (a row per robot of those runs). `timed`: a loss to a continuous hazard is logged when
        its clock struck within the stride (`Losses.early_s`), not at the stride's end."""
        assert self.hazard_model is not None
        n = self.n
        losses = self.hazard_model.step(inp, self.stream_of("hazards", runs), runs)
        radio_ok = self.radio_ok[runs].reshape(-1) & ~losses.radio_dropped
        self.radio_ok[runs] = radio_ok.reshape(len(runs), n)
        alive = self.alive[runs].reshape(-1)
        lost = losses.lost & alive
        order = np.flatnonzero(lost)
        early = None  # seconds before the stride's end each loss happened, when timed
        if timed and losses.early_s is not None:  # logged when, and in the order, they happened
            early = np.where(np.isin(losses.cause, _RATE_CAUSE_CODES), losses.early_s, 0.0)
            order = order[np.argsort(-early[order], kind="stable")]
        for k in order.tolist():
            b, i = runs[k // n], k % n
            cause = hazards.CAUSES[losses.cause[k]]
            extra = {"mine": int(losses.mine[k])} if losses.mine[k] >= 0 else {}
            if extra and self.sensors is not None:
                self.sensors.dirty(b)
            at = None if early is None or early[k] <= 0.0 else self.runs[b].t_s - float(early[k])
            self.runs[b].lose(i, cause, t_s=at, **extra)
        return lost

    def _clearance(self, terminated: np.ndarray, live: list[int]) -> None:
        c = self.setup.clearance
        if c is None:
            return
        for b in live:
            run = self.runs[b]
            if run.cleared or float(self.t_s[b]) + 1e-9 < c.at_s:
                continue
            run.cleared = True
            if self.sensors is not None:
                self.sensors.dirty(b)
            alive, marking = self.alive[b], self.marking[b]
            markers = [
                int(i) for i in np.flatnonzero(alive & (marking >= 0)) if run.object_marker[marking[i]] == i
            ]
            blasts = []
            for i in markers:
                k = marking[i]
                j = run.object_mine[k]
                if j >= 0 and run.minefield.active[j]:
                    run.minefield.cleared[j] = True
                blasts.append(run.objects_m[k])
                alive[i] = False
                run.end_reason[i] = "expended"
                terminated[b, i] = True
                run.log_event("expended", i, object=int(k), mine=int(j))
            run.log_event("clearance", markers=len(markers), mines_cleared=int(run.minefield.cleared.sum()))
            if blasts:
                tree = cKDTree(np.array(blasts))
                for i in np.flatnonzero(alive & self.on_map[b]):
                    if tree.query(self.robot_state[b, i, :2])[0] <= c.standoff_m:
                        run.lose(int(i), "blast")
                        terminated[b, i] = True

    def _recover(self, terminated: np.ndarray) -> None:
        returning = self.alive & (self.phase == RETURNING)
        back = returning & (self.submersion >= PICKUP_SUBMERSION)
        ashore = self.setup.dry_pickups_m  # picked up by hand where the robots were put down
        if len(ashore) and returning.any():
            gap = self.robot_state[:, :, None, :2] - ashore[None, None]
            back |= returning & (np.hypot(gap[..., 0], gap[..., 1]) <= STATION_RADIUS_M).any(axis=-1)
        for b, i in zip(*np.nonzero(back), strict=True):
            run = self.runs[b]
            self.alive[b, i] = False
            run.end_reason[i] = "recovered"
            self.phase[b, i] = DONE
            terminated[b, i] = True
            run.score.recovered += 1
            self.score_stale[b] = True
            run.log_event("recovered", int(i))

    def _score(self, live: list[int], time_up: np.ndarray) -> np.ndarray:
        """Advance the live runs' scores; (B,) each run's change of score this step. Only runs
        with something to do are visited: a run without timed criteria whose counts did not
        change, that is not ending and whose beach start is known, scores what it scored."""
        ashore = self.alive & self.on_map & (self.phase >= BEACH)
        has_ashore = ashore.any(axis=1)
        due = self.score_timed | self.score_stale | time_up | (has_ashore & ~self.beach_started)
        self.scored = due  # every other run's criteria have the values they had
        any_ashore = has_ashore.tolist()
        ended = time_up.tolist()
        times = self.t_s.tolist()
        change = np.zeros(self.B)
        dt = self.dt_s
        self.score_stale[live] = False
        for b in np.asarray(live)[due[live]].tolist():
            run = self.runs[b]
            score = run.score
            t = times[b]
            if score.beach_start_s is None and any_ashore[b]:
                score.beach_start_s = t
                self.beach_started[b] = True
            if score.timed:
                needs_xy = bool(score.zones or score.surveillance or score.beacons)
                xy = self.robot_state[b][ashore[b], :2] if needs_xy else _NO_XY
                score.update(t, dt, xy, run.relay_up)
            if ended[b]:
                score.at_end = True
            if self.score_every_step:
                now = score.score()
                change[b] = now - run.score_prev
                run.score_prev = now
        return change

    def _sample_tracks(self, live: list[int]) -> None:
        for b in live:
            run = self.runs[b]
            if float(self.t_s[b]) + 1e-9 < run.next_track_s:
                continue
            run.next_track_s = float(self.t_s[b]) + TRACK_SAMPLE_S
            on = self.alive[b] & self.on_map[b]
            run.tracks.append(np.where(on[:, None], self.robot_state[b, :, :2], np.nan).astype(np.float32))


_NO_XY = np.empty((0, 2))


@numba.njit(cache=True, error_model="numpy")
def _take_step(
    moving, alive, on_map, phase, slip, submersion, terrain, distance_m, power_w, swim_w, hotel_w, dt,
    slip_out, submersion_out, terrain_out, distance_out, energy_wh, at_sea,
):  # fmt: skip
    """What a step of the physics did, robot by robot, into the world's arrays: slip and distance
    of the robots that moved (0 for the rest), their terrain and submersion (the rest keep theirs),
    and every robot's energy: driving power, swimming at sea, the hotel load once launched (summed
    and scaled in numpy's order). `at_sea` (out): alive, at sea, not yet on the map."""
    for k in range(moving.shape[0]):
        mv = moving[k]
        slip_out[k] = slip[k] if mv else 0.0
        distance_out[k] = distance_m[k] if mv else 0.0
        if mv:
            submersion_out[k] = submersion[k]
            terrain_out[k] = terrain[k]
        sea = alive[k] and phase[k] == SEA and not on_map[k]
        at_sea[k] = sea
        power = (power_w[k] if mv else 0.0) + (swim_w if sea else 0.0)
        power = power + (hotel_w if alive[k] and phase[k] != WAITING else 0.0)
        energy_wh[k] -= power * dt / 3600.0


@numba.njit(cache=True, error_model="numpy")
def _command_targets(
    points, start, end, cursor, state, command, target_m, alive, on_map, afloat, target, moving
):
    """`controller_commands`' target and whether each robot drives, robot by robot: a robot
    following its route (or returning, or on its way to a mark) steers along it (`steer_point`,
    as a boat where `afloat`),
    a marker at its route's end closes in on its mine; one at the end of its route keeps station
    there, driving back once it has drifted `STATION_KEEP_M` off; loitering and relaying robots
    hold still."""
    for i in range(state.shape[0]):
        x, y, c = state[i, 0], state[i, 1], command[i]
        tx, ty = steer_point(points, start[i], end[i], cursor[i], x, y, afloat[i])
        done = cursor[i] >= end[i]
        follow = c in (FOLLOW, RETURN)
        if follow or (c == MARK and not done):
            target[i, 0], target[i, 1] = tx, ty
        else:
            target[i, 0], target[i, 1] = target_m[i, 0], target_m[i, 1]
        off_station = np.hypot(tx - x, ty - y) > STATION_KEEP_M
        hold = c in (LOITER, RELAY)
        moving[i] = alive[i] and on_map[i] and not hold and not (follow and done and not off_station)
