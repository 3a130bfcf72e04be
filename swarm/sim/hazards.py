"""Attrition as competing risks: which robots the hazards take in one environment step, and why.

The env calls `HazardModel.step` once per step (dt_s about 0.5 s) for the whole swarm; everything
is vectorized over robots, and the rare contact events (a mine, a hidden rock) are resolved only
for the few robots a precomputed occupancy grid says could be touching one.

Hazards, with their sources
---------------------------
Continuous hazards (a rate per second, `rates_per_s` columns, `RATE_CAUSES`):

- failure: constant rate 1 / (attrition.mtbf_h x 3600) for every alive robot, at sea or ashore.
  Random failures of field UGVs are close to exponential with a 6-20 h MTBF (Carlson & Murphy
  2005, "How UGVs physically fail in the field", IEEE T-RO 21(3)).
- immobilized: per metre driven, immobilization.per_km / 1000 x mode_factors.get(mode, 1) x
  (1 + (slip / 0.3)^2); rate per second = that x distance_m / dt_s. The slip factor is assumed:
  sinkage and digging-in grow with slip (Wong 2008, Theory of Ground Vehicles, ch. 2, slip
  sinkage). Only on the map, and only on modes whose wheels touch the ground (buoyancy_fraction
  < 1: not while swimming in deep water). Slip is clipped to [0, 1].
- rock: rocks.damage_per_km / 1000 per metre driven on cells of mode "rock" (schema default;
  assumed).
- radio dropout: comms.dropout_per_h / 3600 for every alive robot whose radio still works
  (assumed, mission key). The robot is lost as "cut_off" and `Losses.radio_dropped` is True.

Within a step the continuous hazards combine exactly as competing risks with constant
cause-specific hazards (Kalbfleisch & Prentice 2002, The Statistical Analysis of Failure Time
Data, 2nd ed., ch. 8): P(lost this step) = 1 - exp(-sum(lambda) dt), and the cause is c with
probability lambda_c / sum(lambda). Over a run, survival is exactly exp(-integral of sum(lambda)).

Discrete events:

- mine: a robot within minefield.trigger_radius_m of a mine that is active (not exploded, not
  cleared) and not marked sets it off, on its first contact with that mine only, with probability
  minefield.trigger_probability; the mine is then exploded (this model sets `minefield.exploded`).
  One trial per robot-mine pair for the whole run: a robot that rolled over a fuze without setting
  it off has the weight and track that will not set it off next time either (the trials would be
  strongly correlated; assumed). Several new mines under one robot: tried in index order, the first
  success is the one set off. Two robots setting off the same mine in one step: robots are resolved
  in index order, the lowest index sets it off and the mine is gone for the others.
- wave_impact: each breaker hit disables with surf.impact_damage_probability() (logistic in breaker
  height; schema SurfHazard, assumed).
- rock collision (cause "rock"): running into a cell of mode "boulder" (obstacle_hit), and the first
  contact of each robot-hidden-rock pair (within ROCK_CONTACT_M of a hidden rock), each disable with
  rocks.collision_damage_probability (schema; assumed); otherwise the robot just stops (the env's
  physics). Driftwood and other impassable classes do no damage. A boulder hit reported in
  consecutive steps is one collision (the robot pushing against it): only its onset is tried,
  because impact damage comes from the impact, not from the contact that follows it.
- immobilized (stuck rule): a robot `driving` with slip >= STUCK_SLIP for STUCK_AFTER_S in a row
  (wheels spinning, no progress: soft sand, a slope too steep) is immobilized. Only on land modes
  (not water: in the swash, surf and deep water spinning wheels mean swimming or surging, and the
  surf time limit is the surf's own stuck rule).
- battery: energy_wh <= 0.
- sea_timeout: at_sea and sea_time_s > phases.sea_transit.time_limit_s.
- surf_timeout: surf_time_s > phases.surf_crossing.time_limit_s (stranded, rolled in the surf).
- cut_off (isolation): not at sea and isolated_s >= comms.isolation_limit_s (when set).
- blast: the env's synchronized clearance; this model never assigns it.

Resolution order (the first that fires is the cause): mine, wave_impact, rock collision, the
continuous hazards, immobilized (stuck), battery, sea_timeout, surf_timeout, cut_off (isolation).
Events caused by the motion during the step come first (a mine going off is a world event and is
never pre-empted, so the mine field stays consistent); the continuous hazards act during the step;
the threshold rules are conditions on the state at the end of the step, so they come last.

Determinism: each step draws exactly `rng.random((n_robots, N_UNIFORMS))`, whoever is alive; a
robot's draws are its own row. The same seed and the same inputs give identical Losses, and the
generator stays aligned when robots are lost, so a robot's fate does not depend on how many others
are still alive (common random numbers across the variants of a study). Give this model its own
child generator (`SeedSequence.spawn`) so the other draws of the env do not shift it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numba
import numpy as np
from scipy.spatial import cKDTree
from shapely.geometry.base import BaseGeometry

from swarm.mission import schema
from swarm.robot.terrain import TerrainLibrary
from swarm.sim import draws
from swarm.sim.mines import MineField, sample_in

#: Why a robot was lost; `Losses.cause` indexes this tuple.
CAUSES: tuple[str, ...] = (
    "failure",
    "wave_impact",
    "immobilized",
    "rock",
    "mine",
    "battery",
    "cut_off",
    "sea_timeout",
    "surf_timeout",
    "blast",
)
CAUSE_DESCRIPTIONS: dict[str, str] = {
    "failure": "random failure (electronics, drive train, leaks): exponential with the robot's MTBF",
    "wave_impact": "disabled by a breaker hitting it in the surf zone",
    "immobilized": "stuck: sinkage, high-centring, tangled in wrack, or wheels spinning without progress",
    "rock": "disabled by driving over rock ground or running into a boulder or hidden rock",
    "mine": "set off a mine",
    "battery": "battery ran flat",
    "cut_off": "radio failed, or isolated from the network too long: alive but nobody can command it",
    "sea_timeout": "still at sea when the sea-transit time limit ran out",
    "surf_timeout": "still in the surf zone when the surf-crossing time limit ran out (stranded, rolled)",
    "blast": "caught in the synchronized clearance detonation",
}
NO_LOSS = -1
_CAUSE = {name: i for i, name in enumerate(CAUSES)}

#: The columns of `HazardModel.rates_per_s`, and the cause each one's loss is recorded as.
RATE_CAUSES: tuple[str, ...] = ("failure", "immobilized", "rock", "cut_off")
_RATE_CAUSE_INDEX = np.array([_CAUSE[c] for c in RATE_CAUSES], dtype=np.int64)
_DROPOUT_COLUMN = 3

#: Wheels spinning at this slip or more, while commanded, count toward the stuck rule.
STUCK_SLIP = 0.9
#: Seconds of continuous spinning after which a robot is immobilized (assumed: a stuck robot's
#: recovery behaviours, rocking and reversing, have had a fair chance by then).
STUCK_AFTER_S = 30.0
#: A hidden rock under this distance from a robot's centre is in contact (about half the skid4
#: body width, like the mine trigger radius).
ROCK_CONTACT_M = 0.25
#: Slip at which the immobilization rate has doubled (assumed; Wong 2008 slip sinkage).
SLIP_SCALE = 0.3
#: Uniforms drawn per robot per step: continuous (whether, which), wave, boulder, hidden rock, mine.
N_UNIFORMS = 6
_U_LOST, _U_WHICH, _U_WAVE, _U_BOULDER, _U_HIDDEN, _U_MINE = range(N_UNIFORMS)
#: Largest occupancy grid of a contact index, cells (bool, so at most 4 MB).
_MAX_GRID_CELLS = 1 << 22
#: Float slack when summing steps toward STUCK_AFTER_S (0.1 s steps do not add up to 30.0 exactly).
_TIME_EPS_S = 1e-9


@dataclass
class HazardInputs:
    """One step's state of the swarm, as the hazards need it; everything (n,) unless noted."""

    t_s: float  # mission time at the end of the step
    dt_s: float
    alive: np.ndarray  # bool: still in the mission (lost robots are ignored entirely)
    at_sea: np.ndarray  # bool: released but not yet on the map
    xy: np.ndarray  # (n, 2) positions at the end of the step
    terrain: np.ndarray  # int class index of the map cell under the robot (ignored where at_sea)
    distance_m: np.ndarray  # path length over the step
    slip: np.ndarray  # mean longitudinal slip in [0, 1]
    driving: np.ndarray  # bool: wheels commanded (|mean wheel speed| > 0.05 m/s)
    wave_hits: np.ndarray  # bool: a breaker hit the robot in the surf zone this step
    obstacle_hit: np.ndarray  # int class index of an impassable cell run into, -1 none
    energy_wh: np.ndarray  # battery energy left (<= 0: flat)
    sea_time_s: np.ndarray  # time since release spent at sea before reaching the surf
    surf_time_s: np.ndarray  # time spent in the surf zone so far
    isolated_s: np.ndarray  # time since the robot last had a radio link to anyone
    radio_ok: np.ndarray  # bool: its radio still works (False after a dropout)
    #: local breaker height of each hit (m); None: every breaker is hazards.surf.wave_height_m
    wave_height_m: np.ndarray | None = None


@dataclass
class Losses:
    """Who was lost this step, and why."""

    cause: np.ndarray  # (n,) int index into CAUSES, NO_LOSS where not lost this step
    mine: np.ndarray  # (n,) int index of the mine set off, -1 none
    radio_dropped: np.ndarray  # (n,) bool: the radio failed this step (the robot is lost as "cut_off")
    #: (n,) when in the step a continuous hazard struck, as seconds before its end: the first event
    #: of its exponential clock, from the uniform that decided it (-log(1 - u) / rate); 0 where
    #: none did, None when none did for anyone
    early_s: np.ndarray | None = None

    @property
    def lost(self) -> np.ndarray:
        """Bool (n,): lost this step."""
        return self.cause != NO_LOSS


class _ContactIndex:
    """Fixed points (mines, hidden rocks) and which robots may be within `radius_m` of one.

    A cKDTree query costs about 0.2 us per robot, too much to pay for 1000 robots every step when
    contacts are rare; so a bool grid of the cells any point's disk touches screens the robots
    first (a superset: no contact is missed), and only those in flagged cells go to the tree.
    """

    def __init__(self, points: np.ndarray, radius_m: float) -> None:
        self.points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        self.radius_m = float(radius_m)
        self.tree = cKDTree(self.points) if len(self.points) else None
        if self.tree is None:
            return
        r = self.radius_m
        self.lo = self.points.min(axis=0) - r
        extent = self.points.max(axis=0) + r - self.lo
        cell = max(r, 1e-6)
        while (math.floor(extent[0] / cell) + 1) * (math.floor(extent[1] / cell) + 1) > _MAX_GRID_CELLS:
            cell *= 2.0
        self.cell_m = cell
        self.nx = math.floor(extent[0] / cell) + 1
        self.ny = math.floor(extent[1] / cell) + 1
        grid = np.zeros((self.ny, self.nx), dtype=bool)
        lo_ix = np.floor((self.points - r - self.lo) / cell).astype(np.intp)
        hi_ix = np.minimum(
            np.floor((self.points + r - self.lo) / cell).astype(np.intp), [self.nx - 1, self.ny - 1]
        )
        span = math.ceil(2 * r / cell) + 1  # a disk's bounding box covers at most this many cells a side
        for dx in range(span):
            ix = np.minimum(lo_ix[:, 0] + dx, hi_ix[:, 0])
            for dy in range(span):
                grid[np.minimum(lo_ix[:, 1] + dy, hi_ix[:, 1]), ix] = True
        self.grid = grid.ravel()

    def near(self, xy: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, list[list[int]]]:
        """Robots (indices where `mask`) with at least one point within radius_m, and those points."""
        if self.tree is None:
            return np.empty(0, dtype=np.intp), []
        return self.exact(xy, _ContactScreen([self]).screen(xy, mask, np.zeros(len(xy), np.intp)))

    def exact(self, xy: np.ndarray, sel: np.ndarray) -> tuple[np.ndarray, list[list[int]]]:
        """Of the screened robots `sel`, those with a point within radius_m, and those points."""
        if sel.size == 0 or self.tree is None:
            return sel[:0], []
        hits = self.tree.query_ball_point(xy[sel], self.radius_m)
        keep = [k for k, h in enumerate(hits) if h]
        return sel[keep], [sorted(hits[k]) for k in keep]


class _ContactScreen:
    """The occupancy grids of several runs' contact indexes, screened in one pass: each robot is
    looked up in its own run's grid (the same cells `_ContactIndex` flags, so the same superset)."""

    def __init__(self, indexes: Sequence[_ContactIndex]) -> None:
        k = len(indexes)
        self.lo = np.zeros((k, 2))
        self.inv_cell = np.ones(k)
        self.nx = np.zeros(k, dtype=np.intp)  # 0: a run without points screens nobody in
        self.ny = np.zeros(k, dtype=np.intp)
        self.offset = np.zeros(k, dtype=np.intp)
        grids, at = [], 0
        for b, ix in enumerate(indexes):
            if ix.tree is None:
                continue
            self.lo[b], self.inv_cell[b] = ix.lo, 1.0 / ix.cell_m
            self.nx[b], self.ny[b], self.offset[b] = ix.nx, ix.ny, at
            grids.append(ix.grid)
            at += len(ix.grid)
        self.grid = np.concatenate(grids) if grids else np.zeros(0, bool)
        self.empty = not grids
        for b, ix in enumerate(indexes):  # one copy of each grid: the index's is a view of ours
            if ix.tree is not None:
                ix.grid = self.grid[self.offset[b] : self.offset[b] + len(ix.grid)]

    def screen(self, xy: np.ndarray, mask: np.ndarray, run: np.ndarray | None) -> np.ndarray:
        """Indices where `mask` of the robots in a flagged cell of their run's grid (`run` (n,))."""
        if self.empty:
            return np.empty(0, dtype=np.intp)
        if run is None or len(self.nx) == 1:
            run = np.zeros(len(xy), np.intp)
        return _screen(xy, mask, run, self.lo, self.inv_cell, self.nx, self.ny, self.offset, self.grid)


@numba.njit(cache=True, error_model="numpy")
def _screen(xy, mask, run, lo, inv_cell, nx, ny, offset, grid):
    """`_ContactScreen.screen`, robot by robot: the grid cell is (xy - lo) * inv_cell floored (the
    cast floors the non-negative), NaN positions (robots at sea, if the env leaves them so)
    compare False, so never inside."""
    out = np.empty(xy.shape[0], np.intp)
    count = 0
    for i in range(xy.shape[0]):
        if not mask[i]:
            continue
        b = run[i]
        x = (xy[i, 0] - lo[b, 0]) * inv_cell[b]
        y = (xy[i, 1] - lo[b, 1]) * inv_cell[b]
        if x >= 0.0 and x < nx[b] and y >= 0.0 and y < ny[b] and grid[offset[b] + int(y) * nx[b] + int(x)]:
            out[count] = i
            count += 1
    return out[:count]


class HazardModel:
    """The mission's hazards for a swarm of `n_robots`; keeps the per-robot state the rules need
    (stuck timers, boulder contact, which mines and hidden rocks each robot has already touched).

    One model serves a batch of `runs` independent runs of the mission (`swarm.sim.world`): give
    it a list of mine fields and one of hidden rocks, a run each, inputs with a row per robot of
    every run (run-major), and one generator per run. Each run draws from its own generator
    exactly what it would alone, so a run's losses do not depend on the batch it is in."""

    def __init__(
        self,
        hazards: schema.Hazards,
        phases: schema.Phases,
        terrain_classes: Sequence[str],
        library: TerrainLibrary,
        minefield: MineField | Sequence[MineField],
        hidden_rocks_m: np.ndarray | Sequence[np.ndarray],
        n_robots: int,
    ) -> None:
        self.hazards = hazards
        self.phases = phases
        self.terrain_classes = tuple(terrain_classes)
        self.batched = not isinstance(minefield, MineField)
        fields = list(minefield) if self.batched else [minefield]
        rocks = list(hidden_rocks_m) if self.batched else [hidden_rocks_m]
        if len(rocks) != len(fields):
            raise ValueError(f"hazards: {len(fields)} mine fields and {len(rocks)} sets of hidden rocks")
        self.runs = len(fields)
        self.n = int(n_robots)
        modes = [library[name] for name in self.terrain_classes]  # every map class names a mode

        imm = hazards.immobilization
        factors = imm.mode_factors
        # per-class rates per metre driven; the slip factor multiplies the immobilization one
        self._immob_per_m = np.array(
            [
                imm.per_km / 1000.0 * factors.get(m.name, 1.0) if m.buoyancy_fraction < 1.0 else 0.0
                for m in modes
            ]
        )
        self._rock_per_m = np.array(
            [hazards.rocks.damage_per_km / 1000.0 if m.name == "rock" else 0.0 for m in modes]
        )
        self._can_stick = np.array([not m.is_water for m in modes], dtype=bool)
        # one extra False at the end, so obstacle_hit == -1 indexes "no boulder"
        self._is_boulder = np.array([m.name == "boulder" for m in modes] + [False], dtype=bool)
        self._failure_per_s = 1.0 / (hazards.attrition.mtbf_h * 3600.0)
        self._dropout_per_s = hazards.comms.dropout_per_h / 3600.0
        self._p_wave = hazards.surf.impact_damage_probability()
        self._surf = hazards.surf
        self._p_collision = hazards.rocks.collision_damage_probability
        self._isolation_s = hazards.comms.isolation_limit_s
        self._sea_limit_s = phases.sea_transit.time_limit_s
        self._surf_limit_s = phases.surf_crossing.time_limit_s

        self.minefields: list[MineField] = [None] * self.runs  # type: ignore[list-item]
        self._mines: list[_ContactIndex] = [None] * self.runs  # type: ignore[list-item]
        self._rocks: list[_ContactIndex] = [None] * self.runs  # type: ignore[list-item]
        self._mine_seen: list[set[tuple[int, int]]] = [set() for _ in range(self.runs)]
        self._rock_seen: list[set[tuple[int, int]]] = [set() for _ in range(self.runs)]
        self._stuck_s = np.zeros(self.runs * self.n)
        self._on_boulder = np.zeros(self.runs * self.n, dtype=bool)
        self._run_of = np.repeat(np.arange(self.runs, dtype=np.intp), self.n)
        # every run's mine positions and flags, padded to the largest field with NaN positions,
        # which no robot is ever near (`_bind_mine_flags`)
        self._mine_xy = np.full((self.runs, 0, 2), np.nan)
        self._mine_flags = np.zeros((3, self.runs, 0), dtype=bool)  # exploded, cleared, marked
        self._mine_reach2 = np.zeros(self.runs)
        for b in range(self.runs):
            self._set_run(b, fields[b], rocks[b])
        self._screens()
        self._bind_mine_flags(range(self.runs))

    @property
    def minefield(self) -> MineField:
        """The mine field (of the first run of a batch)."""
        return self.minefields[0]

    def _set_run(self, b: int, minefield: MineField, hidden_rocks_m: np.ndarray) -> None:
        self.minefields[b] = minefield
        self._mines[b] = _ContactIndex(minefield.positions_m, minefield.trigger_radius_m)
        self._rocks[b] = _ContactIndex(hidden_rocks_m, ROCK_CONTACT_M)
        self._mine_seen[b] = set()
        self._rock_seen[b] = set()
        rows = slice(b * self.n, (b + 1) * self.n)
        self._stuck_s[rows] = 0.0
        self._on_boulder[rows] = False

    def _screens(self) -> None:
        self._mine_screen = _ContactScreen(self._mines)
        self._rock_screen = _ContactScreen(self._rocks)

    def reset_runs(
        self, runs: Sequence[int], minefields: Sequence[MineField], rocks: Sequence[np.ndarray]
    ) -> None:
        """Start runs `runs` of the batch anew, with their new mine fields and hidden rocks."""
        for b, mf, r in zip(runs, minefields, rocks, strict=True):
            self._set_run(int(b), mf, r)
        self._screens()
        self._bind_mine_flags(runs)

    def _bind_mine_flags(self, runs: Sequence[int]) -> None:
        """Make the exploded, cleared and marked flags of the mine fields of `runs` views of one
        (3, runs, widest field) array (every run's when the widest field grows), so which mines
        can still go off is one expression for the whole batch (`_trigger_mines`). The fields'
        owners write the flags in place, as before."""
        width = max(len(mf) for mf in self.minefields)
        if width > self._mine_flags.shape[2]:
            self._mine_xy = np.full((self.runs, width, 2), np.nan)
            self._mine_flags = np.zeros((3, self.runs, width), dtype=bool)
            runs = range(self.runs)
        for b in runs:
            mf = self.minefields[b]
            m = len(mf)
            self._mine_xy[b] = np.nan
            self._mine_xy[b, :m] = mf.positions_m
            self._mine_reach2[b] = contact_reach2(mf.trigger_radius_m)
            for row, name in zip(self._mine_flags, ("exploded", "cleared", "marked"), strict=True):
                row[b] = False
                row[b, :m] = getattr(mf, name)
                setattr(mf, name, row[b, :m])

    @property
    def stuck_s(self) -> np.ndarray:
        """Seconds each robot has been spinning its wheels in a row (read-only view)."""
        view = self._stuck_s.view()
        view.flags.writeable = False
        return view

    def wave_damage_probability(self, inp: HazardInputs) -> np.ndarray | float:
        """Chance one hit disables a robot: the logistic of `SurfHazard` at the local breaker
        height where the physics reports it (smaller in the swash), else at the offshore one."""
        if inp.wave_height_m is None:
            return self._p_wave
        return self._surf.damage_probability(inp.wave_height_m)

    def rates_per_s(self, inp: HazardInputs) -> np.ndarray:
        """(n, 4) continuous hazard rates, per second, columns `RATE_CAUSES`: failure, immobilized,
        rock, radio dropout; zero for robots not alive."""
        self._check(inp, len(inp.alive))
        on_map = inp.alive & ~inp.at_sea
        return self._rates(inp, on_map, np.where(on_map, inp.terrain, 0))

    def _rates(self, inp: HazardInputs, on_map: np.ndarray, cls: np.ndarray) -> np.ndarray:
        per_s = inp.distance_m * (on_map / inp.dt_s)
        slip = np.minimum(np.maximum(inp.slip, 0.0), 1.0) * (1.0 / SLIP_SCALE)  # np.clip, less overhead
        rates = np.empty((len(on_map), 4))
        rates[:, 0] = inp.alive * self._failure_per_s
        rates[:, 1] = self._immob_per_m[cls] * (1.0 + slip * slip) * per_s
        rates[:, 2] = self._rock_per_m[cls] * per_s
        rates[:, 3] = (inp.alive & inp.radio_ok) * self._dropout_per_s
        return rates

    def step(
        self,
        inp: HazardInputs,
        rng: np.random.Generator | Sequence[np.random.Generator],
        runs: Sequence[int] | None = None,
    ) -> Losses:
        """Decide which robots are lost this step and why (see the module docstring for the order).
        With `hazards.enabled` false nobody is (the draws are still made, to keep the stream).

        In a batch, `rng` is one generator per run and `runs` the runs stepped (all by default):
        the inputs hold their robots' rows, run after run."""
        runs = list(range(self.runs)) if runs is None else [int(b) for b in runs]
        gens = [rng] if isinstance(rng, np.random.Generator) else rng
        if len(gens) != len(runs):
            raise ValueError(f"hazards: {len(gens)} generators for {len(runs)} runs")
        n = self.n
        size = n * len(runs)
        self._check(inp, size)
        # fixed shape per run: see "Determinism" above
        u = np.empty((size, N_UNIFORMS))
        each = n * N_UNIFORMS
        draws.fill_uniform(gens, np.arange(len(runs)), np.arange(len(runs) + 1) * each, u.reshape(-1))
        if not self.hazards.enabled:
            none = np.full(size, NO_LOSS, dtype=np.int64)
            return Losses(cause=none, mine=np.full(size, -1, dtype=np.int64), radio_dropped=none >= 0)
        every = len(runs) == self.runs  # runs are distinct: all of them, in order
        rows = slice(None) if every else np.concatenate([np.arange(b * n, (b + 1) * n) for b in runs])
        run_of = self._run_of[rows]
        alive = inp.alive
        on_map = alive & ~inp.at_sea
        cls = np.where(on_map, inp.terrain, 0)  # the terrain is not looked at where at sea
        rates = self._rates(inp, on_map, cls)
        cause = np.full(size, NO_LOSS, dtype=np.int64)
        mine = np.full(size, -1, dtype=np.int64)

        # the state-keeping rules run for every robot, whatever else takes it this step
        stuck = self._update_stuck(inp, on_map, cls, rows)
        boulder = self._is_boulder[inp.obstacle_hit] & alive
        new_boulder = boulder & ~self._on_boulder[rows]
        self._on_boulder[rows] = boulder
        hidden = self._hidden_rock_hits(inp.xy, on_map, u[:, _U_HIDDEN], run_of)
        self._trigger_mines(inp.xy, on_map, u[:, _U_MINE], mine, run_of)

        # continuous: P(lost) = 1 - exp(-sum(lambda) dt); cause by lambda_c / sum(lambda)
        total = rates[:, 0] + rates[:, 1] + rates[:, 2] + rates[:, 3]  # as rates.sum(axis=1), faster
        cont = u[:, _U_LOST] < -np.expm1(-total * inp.dt_s)
        which = np.zeros(size, dtype=np.intp)
        if cont.any():
            cum = np.cumsum(rates[cont], axis=1)
            # cum[:, -1] rather than total: the pick stays < 4 whatever the rounding
            which[cont] = (cum <= u[cont, _U_WHICH][:, None] * cum[:, -1:]).sum(axis=1)

        # lowest priority first, so higher ones overwrite (`_causes`, one pass)
        p_wave = np.broadcast_to(np.asarray(self.wave_damage_probability(inp), np.float64), (size,))
        dropped = np.empty(size, bool)
        _causes(
            on_map, alive, inp.at_sea, inp.isolated_s, self._isolation_s is not None,
            math.inf if self._isolation_s is None else float(self._isolation_s),
            inp.surf_time_s, float(self._surf_limit_s), inp.sea_time_s, float(self._sea_limit_s),
            inp.energy_wh, stuck, cont, which, new_boulder, u, float(self._p_collision), hidden,
            inp.wave_hits, p_wave, mine, _RATE_CAUSE_INDEX, cause, dropped,
        )  # fmt: skip
        early = None
        if cont.any():  # u < 1 - exp(-rate dt) <=> the clock's first event -log(1 - u) / rate < dt
            early = np.zeros(size)
            early[cont] = np.maximum(inp.dt_s + np.log1p(-u[cont, _U_LOST]) / total[cont], 0.0)
        return Losses(cause=cause, mine=mine, radio_dropped=dropped, early_s=early)

    # --- the rules with state ------------------------------------------------------------------

    def _update_stuck(self, inp: HazardInputs, on_map: np.ndarray, cls: np.ndarray, rows) -> np.ndarray:
        """Advance the stuck timers; True where a robot has spun its wheels for STUCK_AFTER_S."""
        spinning = on_map & inp.driving & (inp.slip >= STUCK_SLIP) & self._can_stick[cls]
        stuck_s = np.where(spinning, self._stuck_s[rows] + inp.dt_s, 0.0)
        self._stuck_s[rows] = stuck_s
        return stuck_s >= STUCK_AFTER_S - _TIME_EPS_S

    def _by_run(self, screen: _ContactScreen, indexes, xy, mask, run_of, keep=None):
        """(run, local row, points) of every robot touching a point of its run's index, in row order.
        `keep(sel, runs)`, if given, says which runs' screened robots (`sel`, of runs `runs`) are
        worth the exact look: the others' contacts could do nothing."""
        sel = screen.screen(xy, mask, run_of)
        if sel.size == 0:
            return
        runs = np.zeros(len(sel), np.intp) if self.runs == 1 else run_of[sel]
        wanted = None if keep is None else keep(sel, runs)
        cuts = [] if self.runs == 1 else (np.flatnonzero(runs[1:] != runs[:-1]) + 1).tolist()
        for lo, hi in zip([0, *cuts], [*cuts, len(sel)], strict=True):
            b, part = int(runs[lo]), sel[lo:hi]
            if wanted is not None and b not in wanted:
                continue
            robots, near = indexes[b].exact(xy, part)
            for k, pts in zip(robots.tolist(), near, strict=True):
                yield b, k, pts

    def _hidden_rock_hits(self, xy: np.ndarray, on_map: np.ndarray, u: np.ndarray, run_of) -> np.ndarray:
        """True where first contacts with hidden rocks disable a robot: 1 - (1 - p)^k for k new rocks."""
        hit = np.zeros(len(on_map), dtype=bool)
        for b, k, rocks in self._by_run(self._rock_screen, self._rocks, xy, on_map, run_of):
            i = k % self.n  # the robot within its run
            seen = self._rock_seen[b]
            new = [r for r in rocks if (i, r) not in seen]
            seen.update((i, r) for r in new)
            if new and u[k] < 1.0 - (1.0 - self._p_collision) ** len(new):
                hit[k] = True
        return hit

    def _trigger_mines(
        self, xy: np.ndarray, on_map: np.ndarray, u: np.ndarray, mine: np.ndarray, run_of
    ) -> None:
        """Try every first robot-mine contact; set `mine[i]` and mark the mine exploded where one goes off.

        Robots in index order; with k new mines under one robot, the first success of k Bernoulli(p)
        trials in mine-index order is the geometric J = floor(log(1 - u) / log(1 - p)) from one uniform.
        """
        armed: dict[int, list[bool]] = {}  # each run's mines that can still go off

        def keep(sel: np.ndarray, runs: np.ndarray) -> set[int]:
            """The runs with a screened robot that may touch a mine that can still go off (not
            exploded, cleared or marked): contacts with the others do nothing (the usual case is
            a marker on its marked mine). A dense check with a margin far above rounding, so never
            leaving out a run where the exact look would find such a contact."""
            flags = self._mine_flags
            live = ~(flags[0] | flags[1] | flags[2])  # padding too, but NaN is never near
            wanted = set(runs[_armed_near(xy, sel, runs, self._mine_xy, live, self._mine_reach2)].tolist())
            for b in wanted:
                armed[b] = live[b, : len(self.minefields[b])].tolist()
            return wanted

        for b, k, mines in self._by_run(self._mine_screen, self._mines, xy, on_map, run_of, keep):
            mf = self.minefields[b]
            p = mf.trigger_probability
            i = k % self.n
            seen = self._mine_seen[b]
            new = [m for m in mines if armed[b][m] and (i, m) not in seen]
            if not new:
                continue
            seen.update((i, m) for m in new)
            if p <= 0.0:
                continue
            j = 0 if p >= 1.0 else math.floor(math.log1p(-u[k]) / math.log1p(-p))
            if j < len(new):
                mine[k] = new[j]
                mf.exploded[new[j]] = True
                armed[b][new[j]] = False

    def _check(self, inp: HazardInputs, size: int) -> None:
        if inp.alive.shape != (size,) or inp.xy.shape != (size, 2):
            raise ValueError(f"hazard inputs for {inp.alive.shape} robots, the model has {size}")
        if not inp.dt_s > 0.0:
            raise ValueError(f"dt_s must be > 0, got {inp.dt_s}")


def contact_reach2(radius_m: float) -> float:
    """The squared contact radius for dense checks: `radius_m` with a relative and absolute margin
    far above rounding, so a check against it is True wherever an exact (k-d tree) look finds a
    pair within `radius_m`."""
    reach = radius_m * (1.0 + 1e-9) + 1e-9
    return reach * reach


@numba.njit(cache=True, error_model="numpy")
def _armed_near(xy, sel, runs, mine_xy, live, reach2):
    """For each screened robot sel[q] of run runs[q]: whether a mine of its run that can still go
    off (`live`) lies within sqrt(reach2[run]) of it (`contact_reach2` of the trigger radius); a
    padding mine's NaN position is never within it."""
    out = np.zeros(sel.shape[0], np.bool_)
    for q in range(sel.shape[0]):
        i, b = sel[q], runs[q]
        for j in range(live.shape[1]):
            if live[b, j]:
                dx, dy = xy[i, 0] - mine_xy[b, j, 0], xy[i, 1] - mine_xy[b, j, 1]
                if dx * dx + dy * dy <= reach2[b]:
                    out[q] = True
                    break
    return out


def hidden_rocks(
    hazards: schema.Hazards, land_polygon_or_none: BaseGeometry | None, rng: np.random.Generator
) -> np.ndarray:
    """(k, 2) unmapped rocks of one run: Poisson(hidden_per_ha x area_ha), uniform over the beach's
    land area (a Poisson point process, the usual model of scattered obstacles; assumed)."""
    per_ha = hazards.rocks.hidden_per_ha
    if land_polygon_or_none is None or per_ha <= 0.0 or land_polygon_or_none.is_empty:
        return np.empty((0, 2))
    count = int(rng.poisson(per_ha * land_polygon_or_none.area / 1e4))
    return sample_in([land_polygon_or_none], count, rng)


def hidden_rocks_in_cells(
    hazards: schema.Hazards, centers_m: np.ndarray, cell_m: float, rng: np.random.Generator
) -> np.ndarray:
    """(k, 2) unmapped rocks over land given as grid cells (their centres, `cell_m` square): the
    same Poisson process as `hidden_rocks`, drawn cell-wise so no land polygon has to be built."""
    per_ha = hazards.rocks.hidden_per_ha
    centers = np.asarray(centers_m, dtype=np.float64).reshape(-1, 2)
    if per_ha <= 0.0 or not len(centers):
        return np.empty((0, 2))
    count = int(rng.poisson(per_ha * len(centers) * cell_m * cell_m / 1e4))
    cells = centers[rng.integers(0, len(centers), size=count)]
    return cells + rng.uniform(-cell_m / 2, cell_m / 2, size=(count, 2))


_CUT_OFF, _SURF_TIMEOUT, _SEA_TIMEOUT = _CAUSE["cut_off"], _CAUSE["surf_timeout"], _CAUSE["sea_timeout"]
_BATTERY, _IMMOBILIZED, _ROCK = _CAUSE["battery"], _CAUSE["immobilized"], _CAUSE["rock"]
_WAVE_IMPACT, _MINE = _CAUSE["wave_impact"], _CAUSE["mine"]


@numba.njit(cache=True, error_model="numpy")
def _causes(
    on_map, alive, at_sea, isolated_s, isolating, isolation_s, surf_time_s, surf_limit_s, sea_time_s,
    sea_limit_s, energy_wh, stuck, cont, which, new_boulder, u, p_collision, hidden, wave_hits, p_wave,
    mine, rate_cause, cause, dropped,
):  # fmt: skip
    """`HazardModel.step`'s cause of each robot's loss, robot by robot, lowest priority first so
    higher ones overwrite: cut off, surf and sea timeouts, battery, immobilized, a continuous
    hazard (`rate_cause[which]`), rock, wave impact, mine. `dropped`: a radio dropout that cut
    the robot off."""
    for i in range(cause.shape[0]):
        c = cause[i]
        if isolating and on_map[i] and isolated_s[i] >= isolation_s:
            c = _CUT_OFF
        if alive[i] and surf_time_s[i] > surf_limit_s:
            c = _SURF_TIMEOUT
        if alive[i] and at_sea[i] and sea_time_s[i] > sea_limit_s:
            c = _SEA_TIMEOUT
        if alive[i] and energy_wh[i] <= 0.0:
            c = _BATTERY
        if stuck[i]:
            c = _IMMOBILIZED
        if cont[i]:
            c = rate_cause[which[i]]
        if (new_boulder[i] and u[i, _U_BOULDER] < p_collision) or hidden[i]:
            c = _ROCK
        if alive[i] and wave_hits[i] and u[i, _U_WAVE] < p_wave[i]:
            c = _WAVE_IMPACT
        if mine[i] >= 0:
            c = _MINE
        cause[i] = c
        dropped[i] = cont[i] and which[i] == _DROPOUT_COLUMN and c == _CUT_OFF
