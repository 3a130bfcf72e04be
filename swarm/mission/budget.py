"""What a plan budgets for: the robots a mission's hazards are expected to take, phase by phase, and
a search designed to meet its criterion after them.

Expected losses (`robot_losses`). Each robot's exposure (time at sea, in the surf, ashore; metres
driven on each terrain class and inside the mine area) meets the mission's hazard rates, the same
rates the simulator draws from (`swarm.sim.hazards`):

- failure: 1 - exp(-t / MTBF) over the time from release to the end of the task window (what
  the search's design counts on; the losses the plan reports run to the end of beach operations);
- wave impact: 1 - prod(1 - p_hit), one breaker a wave period T while in the surf zone, each
  disabling with `SurfHazard.damage_probability` at the local breaker height where it hits
  (`swarm.world.coastal.local_breaker_height`, as the simulator's hazards). On the way in, the
  breakers a robot meets until its wheels ground, its way in driven by the simulator's rules
  (`swarm.mission.surf_drive`: the longshore current sets a swimming robot along the beach, so a
  robot can be among the breakers far longer than its line's length says), averaged over the
  wave's phase as survival chances; elsewhere (the swash, the search tracks' surf-zone cells at
  the search speed, the way back) the time over surf-zone cells at the way a robot makes there
  among the breakers, the heights met in proportion to the time under them
  (`swarm.mission.surf_speed`);
- surf timeout: the share of the wave's phases at which that drive is still in the surf zone when
  `surf_crossing.time_limit_s` runs out, among those the breakers have not disabled first;
- immobilization: per_km x mode factor x (1 + (slip / 0.3)^2) per metre on each class whose
  wheels touch the ground (buoyancy below 1: the swash and the surf too, as the simulator), with
  each mode's steady slip at cruise (the cost map's mode speeds); on the way in, afloat among the
  breakers until the wheels ground, the metres and slips of that drive (`surf_drive`: the breakers
  surge a robot back and forth over the bed, its wheels spinning);
- rock: damage_per_km per metre on rock, and hidden rocks met per metre on land (hidden_per_ha x
  twice the contact radius, as mines) x collision_damage_probability;
- mine: mines met per metre (density x twice the trigger radius) x the chance the sensor has not
  found the mine while the robot can still keep off it x trigger_probability, the metres counted
  where mines can still be unfound (robots steer clear of those found): on a search lane, the share
  the lanes swept before it have not found (`found_by_lanes_before`); on a trip to mark a mine,
  after the search, the share it missed. Inverse cube: the miss exp(-W^2 / (8 pi) / (h (h + x)))
  of a mine at offset y within the trigger radius of the track, looked at from afar until the
  robot is x short of abreast of it (h = sqrt(x^2 + y^2); W^2 / (16 pi x^2) dead ahead), averaged
  over y. A find is reported at the end of a simulator step, and from the next the robot turns
  away in place (the side-step lies abreast: `turn_away_path`), so x is the last end of a step
  from which the turn keeps it off the mine: up to one step's travel (`REACTION_S`, averaged over
  where the steps end) beyond the least; a tabulated curve: 1 - p averaged over offsets within
  the trigger radius;
- radio dropout: 1 - exp(-rate x t).

Causes combine as independent competing risks: P(lost) = 1 - prod(1 - p_cause). A robot still
going when beach operations end drives back to the nearest pick-up point and swims out through the
surf (`return_losses`): the same rates over that way, weighted by its chance of getting that far.

Search design (`design_search`). The search must be over before its window closes: the synchronized
clearance less the time to clear the standoff and to bring markers onto the mines found, or the end
of beach operations. With `track_spacing_m` unset the spacing is the widest whose expected
detection gives the success criterion with the task's `detection_confidence` (0.95 by default; the
detected fraction of N mines is binomial; the detection of parallel tracks is Koopman's formula
for the sensor's model, or, for a tabulated lateral-range curve, that curve's own parallel sweep,
`parallel_sweep_detection`), unless the robots cannot drive that much track in the
window (less the searcher time the losses are expected to cost), in which case it is the tightest
they can. As many robots search
as that spacing needs; of the others, as many as the losses are expected to take wait as reserves
inside the search area (they take over a lost searcher's track and mark the mines the searchers
report: marking never takes a searcher off its track); any robot beyond both searches too. More
robots therefore tighten the spacing until the criterion holds, then cover the losses, then
shorten the search, and never idle.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np
import shapely
from scipy import optimize, stats
from scipy.special import erf
from scipy.stats import binom
from shapely.geometry.base import BaseGeometry

from swarm.mission.schema import DETECTION_CONFIDENCE, LateralRange, Mission
from swarm.planning import CostMap
from swarm.planning.detection import LateralRangeCurve
from swarm.robot.driving import CAPTURE_M, MAX_WHEEL_SPEED_FACTOR, DriveLimits, drive_toward
from swarm.robot.params import RobotParams
from swarm.robot.skid import SkidModel, coeffs_for
from swarm.world.coastal import local_breaker_height, surf_zone_mask

#: The detection criterion is designed to hold with this probability over the mine field's draw,
#: unless the search task says otherwise (`detection_confidence`).
DESIGN_CONFIDENCE = DETECTION_CONFIDENCE
#: The tightest spacing the planner chooses, as a fraction of the sweep width.
MIN_SPACING_FRACTION = 0.25
#: Time per track end: two pivots of 90 degrees at the controller's turn rate (s).
TURN_S = 6.0
#: Share of the window kept free of search at its end, for the unexpected (a detour, a takeover).
WINDOW_SLACK = 0.1
#: Standoff clearing: straight-line time at cruise x factor + allowance, and the margin past the
#: standoff (the scripted policy's own numbers: `swarm.sim.policy`).
RETREAT_FACTOR, RETREAT_ALLOWANCE_S, STANDOFF_MARGIN_M = 1.5, 30.0, 10.0
#: Mark, immobilization: slip scale of the immobilization rate (schema `Immobilization`).
SLIP_SCALE = 0.3
PHASE_NAMES = ("sea", "surf", "beach")
#: Causes that strike at the end of their phase, not at a rate along it: the surf timeout takes a
#: robot still among the breakers when the limit runs out, so the breakers and failures come first
#: (a way in that always times out still loses a robot a breaker took to the breakers).
AT_PHASE_END = ("surf_timeout",)
#: The losses on the way back to sea after the task window (`return_losses`), reported beside the
#: phases above but not counted against the tasks: the robots have done their work by then.
RETURN_PHASE = "return"
#: The scripted policy hands a lost searcher's track out in pieces of this length (m), a trip to
#: each (`swarm.sim.policy.TAKEOVER_PIECE_M`).
TAKEOVER_PIECE_M = 300.0
#: An undone lane's neighbours out to this many lanes a side decide what its strip keeps
#: (`undone_band_kept`; an inverse-cube sensor's farther lanes count as undone with the chance of
#: another band's lane, `_KeptBeside`).
BAND_REACH_LANES = 3
#: The simulator's trigger radius (`swarm.sim.mines.DEFAULT_TRIGGER_RADIUS_M`, m).
TRIGGER_RADIUS_M = 0.25
#: The simulator's hidden-rock contact radius (`swarm.sim.hazards.ROCK_CONTACT_M`, m).
ROCK_CONTACT_M = 0.25
#: The simulator's step (`swarm.sim.env.SimConfig.dt_s`, s): a find is heard at the end of a step,
#: and the scripted policy steers clear of it from the next.
REACTION_S = 0.5
#: The simulator's physics substep (`SimConfig.substep_s`, s).
SUBSTEP_S = 0.25
#: Where the steps end against a mine ahead, spread evenly over one step's travel.
STEP_PHASES = 16
#: Offsets of a mine from the track, spread evenly over the trigger radius.
OFFSETS = 32
#: How far abreast the side-step around a mine just found ahead begins (`swarm.sim.routes`
#: `SIDESTEP_CLEAR_M`, m): any point abreast turns the robot in place alike.
SIDESTEP_M = 1.25 * CAPTURE_M
#: How long the turn away is followed for its run-on (s); the robot has stopped closing long before.
TURN_AWAY_S = 2.0
#: How long a robot drives straight on before it is told (s): long enough to be at its steady speed.
STEADY_S = 5.0


def hazards_enabled(mission: Mission) -> bool:
    return mission.hazards.enabled


def mine_areas(mission: Mission) -> list[BaseGeometry]:
    """The regions mines lie in: hazards.mines.area, or every search task's area."""
    bm = mission.beach_map
    spec = mission.hazards.mines
    names = [spec.area] if spec.area is not None else [t.area for t in mission.tasks_of("search")]
    return [bm.regions[n].geometry for n in names]


def expected_mine_count(mission: Mission) -> float:
    """Mines expected in the mine area: the count, or density x area; 0 without either."""
    spec = mission.hazards.mines
    if spec.count is not None:
        return float(spec.count)
    areas = mine_areas(mission)
    if spec.density_per_ha is None or not areas:
        return 0.0
    return spec.density_per_ha * shapely.union_all(areas).area / 1e4


# --- exposure and losses -----------------------------------------------------------------------------


@dataclass
class Exposure:
    """What one robot goes through: seconds in each phase and metres driven on each terrain class."""

    sea_s: float
    surf_s: float
    beach_s: float
    driven_m: dict[str, float] = field(default_factory=dict)
    #: metres inside the mine area, each counted by the chance that the mines there are still
    #: unfound when the robot drives it (a lane beside lanes swept before: `found_by_lanes_before`;
    #: robots steer clear of the mines found)
    in_mine_area_m: float = 0.0
    #: -log(1 - p) of one breaker, averaged over the time in the surf (`surf_speed.SurfZone`);
    #: None: every breaker at the offshore height
    breaker_hazard: float | None = None
    #: ground speed in the mine area (m/s); None: the cruise wheel speed
    speed_mps: float | None = None
    #: seconds ashore on ground routes through the surf zone (tracks run down to the waterline),
    #: and -log(1 - p) of one breaker there, averaged as `breaker_hazard`
    beach_surf_s: float = 0.0
    beach_breaker_hazard: float = 0.0
    #: chance the way in is still among the breakers when the surf crossing's time limit runs out
    #: (`swarm.mission.surf_drive`), among those the breakers have not taken by then
    surf_timeout: float = 0.0
    #: metres ashore on wheels in water whose bed the wheels touch (the swash, shallow water), by
    #: class: no wheel-borne hazard but getting stuck counts them (`driven_m` is dry ground)
    wet_m: dict[str, float] = field(default_factory=dict)
    #: -log(1 - p) of getting stuck among the breakers on the way in (`surf_drive.WayIn.stuck`)
    surf_stuck_hazard: float = 0.0


def surf_cells(mission: Mission) -> np.ndarray:
    """The map's surf zone (`swarm.world.coastal.surf_zone_mask`, as the simulator's physics has it)."""
    bm = mission.beach_map
    lib = mission.terrain_library
    water = np.array([lib[c].is_water for c in bm.terrain_classes], dtype=bool)[bm.terrain.astype(np.intp)]
    mask = surf_zone_mask(bm.elevation_m, water, mission.hazards.surf.wave_height_m)
    if "surf" in bm.terrain_classes:
        mask |= bm.terrain == bm.class_index("surf")
    return mask


def surf_heights(mission: Mission) -> np.ndarray:
    """(rows, cols) the local breaker height over the map's surf zone (`surf_cells`), 0 elsewhere:
    the height the simulator's hazards take a hit at."""
    bm = mission.beach_map
    return local_breaker_height(bm.elevation_m, surf_cells(mission), mission.hazards.surf.wave_height_m)


def samples_along(cm: CostMap, polyline: np.ndarray) -> tuple[np.ndarray, ...]:
    """`polyline` cut into pieces of at most half a cell: their midpoints (k, 2), lengths (k,),
    cells (rows, cols) and headings (k,), rad; empty for fewer than two points."""
    pts = np.asarray(polyline, dtype=np.float64).reshape(-1, 2)
    if len(pts) < 2:
        empty = np.empty(0, np.intp)
        return np.empty((0, 2)), np.empty(0), empty, empty, np.empty(0)
    seg = np.diff(pts, axis=0)
    length = np.hypot(seg[:, 0], seg[:, 1])
    step = cm.cell_m / 2.0
    k = np.maximum(1, np.ceil(length / step).astype(np.int64))
    t = (np.arange(int(k.sum())) - np.repeat(np.cumsum(k) - k, k) + 0.5) / np.repeat(k, k)
    mid = np.repeat(pts[:-1], k, axis=0) + np.repeat(seg, k, axis=0) * t[:, None]
    piece = np.repeat(length / k, k)
    row, col = cm.cell_of(mid[:, 0], mid[:, 1])
    return mid, piece, row, col, np.repeat(np.arctan2(seg[:, 1], seg[:, 0]), k)


def driven_by_class(
    cm: CostMap, polyline: np.ndarray, mine_area: BaseGeometry | None
) -> tuple[dict[str, float], float]:
    """Metres of `polyline` on each terrain class, and inside `mine_area` (sampled at half a cell)."""
    mid, piece, row, col, _ = samples_along(cm, polyline)
    if not len(piece):
        return {}, 0.0
    cls = cm.terrain[row, col].astype(np.intp)
    per_class = np.bincount(cls, weights=piece, minlength=len(cm.terrain_classes))
    out = {cm.terrain_classes[c]: float(v) for c, v in enumerate(per_class) if v > 0}
    inside = 0.0
    if mine_area is not None:
        inside = float(piece[shapely.contains_xy(mine_area, mid[:, 0], mid[:, 1])].sum())
    return out, inside


def ground_speed(mission: Mission, speed_mps: float | None) -> float:
    """A robot's ground speed in the mine area: `speed_mps`, else the cruise wheel speed."""
    return mission.robot.wheel_speed_mps if speed_mps is None else speed_mps


def unseen_share(mission: Mission, speed_mps: float | None, ground: str | None = None) -> float:
    """Of the mines expected to go off under a robot driving at `speed_mps` on `ground`, the share
    that no sensor had found: most were found a moment before, too late to turn, and count as
    detected."""
    late = undetected_at_contact(mission, ground_speed(mission, speed_mps), ground)
    return undetected_at_contact(mission) / late if late > 0 else 1.0


def main_ground(mission: Mission, exposure: Exposure) -> str | None:
    """The land class a robot drives the most metres on (None without any): the ground its mines
    are met on, for how it turns away from one (`turn_away_path`)."""
    lib = mission.terrain_library
    land = {c: m for c, m in exposure.driven_m.items() if c in lib and not lib[c].is_water}
    return max(land, key=land.__getitem__) if land else None


def undetected_at_contact(mission: Mission, speed_mps: float = 0.0, ground: str | None = None) -> float:
    """Chance the search sensor has not found a mine in time for a robot driving at it at
    `speed_mps` on terrain class `ground` (the mission's first land mode without one) to keep off
    it, over mines anywhere within the trigger radius of its track (module docstring)."""
    search = mission.tasks_of("search")
    if not search:
        return 1.0
    sensor = search[0].sensor
    r = TRIGGER_RADIUS_M
    if sensor.lateral_range is not None:
        # a pass that closes on a mine draws down to its least distance (`swarm.sim.sensing`), an
        # offset uniform over the trigger radius for a mine the robot meets
        x = np.linspace(0.0, r, 65)
        return float(1.0 - LateralRangeCurve.of(sensor.lateral_range)(x).mean())
    if sensor.model == "inverse_cube":
        y = (np.arange(OFFSETS) + 0.5) / OFFSETS * r  # the mine's offset from the track
        near = np.sqrt(r * r - y * y)  # told no farther ahead than this, the robot is on it
        if speed_mps > 0.0:
            # it turns away from the mine's side: met at a later step's end within the radius
            path = turn_away_path(mission, speed_mps, ground)
            gap = y[:, None] + path[None, :, 1]
            met = path[None, :, 0] + np.sqrt(np.maximum(r * r - gap * gap, 0.0))
            near = np.maximum(near, np.where(gap < r, met, 0.0).max(axis=1))
            # the steps end anywhere within one step's travel of the nearest safe end
            ends = (np.arange(STEP_PHASES) + 0.5) / STEP_PHASES
            ahead = near[:, None] + ends[None, :] * (REACTION_S * speed_mps)
        else:
            ahead = near[:, None]
        # the inverse-cube rate integrated along the approach from afar to `ahead` at offset y:
        # the integral of ds / (s^2 + y^2)^(3/2) from `ahead` on, 1 / (h (h + ahead)), h the distance
        h = np.hypot(ahead, y[:, None])
        look = sensor.width_m**2 / (8.0 * math.pi) / (h * (h + ahead))
        return float(np.mean(np.exp(-look)))
    return 0.0 if sensor.width_m / 2.0 > r else 1.0


def turn_away_path(mission: Mission, speed_mps: float, ground: str | None = None) -> np.ndarray:
    """(k, 2) where a robot driving at `speed_mps` on terrain class `ground` is at the ends of the
    simulator's steps after it is told of a mine just ahead (from where it was told: along its
    heading, and aside, away from the mine). The side-step the scripted policy lays around a find
    just ahead begins abreast of the robot, so the simulator's controller turns it in place
    (`drive_toward`: no forward command beyond `PIVOT_ERROR_RAD`), then drives it off to the side;
    it runs on only while its wheels, turning it, brake it. The robot model on that ground from
    steady driving, at the simulator's step and substep. (mine_clear at 0.54 m/s on wet hard sand
    runs on 0.13 m, 0.11 in the first step: 48 runs closed on the mines they found on their way by
    0.06 m on average, report to nearest approach, mines off their track's line closing less.)"""
    lib = mission.terrain_library
    land = [name for name in lib if not lib[name].is_water]
    if not land:  # no ground to drive on: told anywhere, the robot is where it was told
        return np.zeros((1, 2))
    mode = lib[ground if ground is not None and ground in land else land[0]]
    coef = tuple((name, float(value[0])) for name, value in coeffs_for(mode).items())
    robot = mission.robot_params
    cruise = mission.robot.wheel_speed_mps
    return np.array(_turn_away(robot, coef, float(speed_mps), cruise, MAX_WHEEL_SPEED_FACTOR * cruise))


@functools.lru_cache(maxsize=64)
def _turn_away(robot: RobotParams, coef: tuple, speed_mps: float, cruise_mps: float, top_mps: float) -> tuple:
    """`turn_away_path` for hashable inputs (the same robot, ground and speed each time a plan
    asks), as a tuple of (along, aside) pairs."""
    c = {name: np.array([value]) for name, value in coef}
    model = SkidModel(robot)
    limits = DriveLimits(robot.wheel_radius_m, robot.track_width_m, cruise_mps, top_mps, 0.0)
    steady = np.full((1, 2), speed_mps / robot.wheel_radius_m)  # as the controller drives straight on
    rest = model.state_at_rest(np.zeros((1, 3)))
    _, states = model.simulate_fixed(rest, lambda *_: steady, c, STEADY_S, SUBSTEP_S)
    state = states[-1].copy()
    state[0, :3] = 0.0  # told here, heading +x; the side-step's first point abreast
    target = np.array([[0.0, SIDESTEP_M]])
    dry, upright = np.zeros(1), np.zeros(1, bool)
    out = []
    for _ in range(round(TURN_AWAY_S / REACTION_S)):
        omega, _, _ = drive_toward(state, target, speed_mps, dry, upright, limits)
        _, states = model.simulate_fixed(state, lambda *_, w=omega: w, c, REACTION_S, SUBSTEP_S)
        state = states[-1].copy()
        out.append((float(state[0, 0]), abs(float(state[0, 1]))))
    return tuple(out)


def immobilization_per_m(mission: Mission, classes) -> np.ndarray:
    """The chance per metre of getting stuck on each of the terrain classes `classes` at no slip:
    per_km x mode factor where the wheels touch the ground (a mode's buoyancy below 1), 0 afloat
    (the simulator's rule, `swarm.sim.hazards`)."""
    imm, lib = mission.hazards.immobilization, mission.terrain_library
    return np.array(
        [
            imm.per_km / 1000.0 * imm.mode_factors.get(c, 1.0) if lib[c].buoyancy_fraction < 1.0 else 0.0
            for c in classes
        ]
    )


def slip_factor(slip: np.ndarray) -> np.ndarray:
    """How much slip multiplies the immobilization rate: 1 + (slip / `SLIP_SCALE`)^2, slip in [0, 1]."""
    s = np.clip(slip, 0.0, 1.0) / SLIP_SCALE
    return 1.0 + s * s


def timed_losses(mission: Mission, t_s: float) -> dict[str, float]:
    """The chance of each cause that strikes by the clock alone (random failure, a radio cut off
    for good) over `t_s` seconds, whatever the robot does."""
    hz = mission.hazards
    out = {"failure": -math.expm1(-t_s / (hz.attrition.mtbf_h * 3600.0))}
    dropout = hz.comms.dropout_per_h / 3600.0
    if dropout > 0:
        out["cut_off"] = -math.expm1(-dropout * t_s)
    return out


def robot_losses(mission: Mission, cm: CostMap, exposure: Exposure) -> dict[str, dict[str, float]]:
    """Probability the robot is lost in each phase, by cause (module docstring)."""
    out: dict[str, dict[str, float]] = {p: {} for p in PHASE_NAMES}
    if not hazards_enabled(mission):
        return out
    hz = mission.hazards
    for phase, t in (("sea", exposure.sea_s), ("surf", exposure.surf_s), ("beach", exposure.beach_s)):
        out[phase].update(timed_losses(mission, t))
    hits = exposure.surf_s / hz.surf.wave_period_s
    per_hit = exposure.breaker_hazard
    if per_hit is None:
        per_hit = -math.log1p(-hz.surf.impact_damage_probability())
    out["surf"]["wave_impact"] = -math.expm1(-hits * per_hit)
    if exposure.surf_timeout > 0:
        out["surf"]["surf_timeout"] = min(exposure.surf_timeout, 1.0)
    ashore_hits = exposure.beach_surf_s / hz.surf.wave_period_s
    out["beach"]["wave_impact"] = -math.expm1(-ashore_hits * exposure.beach_breaker_hazard)
    names = cm.speeds.names
    nominal = cm.speeds.nominal_wheel_speed_mps
    slip = {n: 1.0 - float(v) / nominal for n, v in zip(names, cm.speeds.speed_mps, strict=True)}
    lib = mission.terrain_library
    stuck = 0.0
    rock = 0.0
    # hidden rocks lie on every passable land cell (`swarm.sim.hazards.hidden_rocks_in_cells`)
    hidden_per_m = hz.rocks.hidden_per_ha / 1e4 * 2 * ROCK_CONTACT_M * hz.rocks.collision_damage_probability
    for cls, metres in exposure.driven_m.items():
        if lib[cls].is_water:
            continue
        rock += hidden_per_m * metres
        if cls == "rock":
            rock += hz.rocks.damage_per_km / 1000.0 * metres
    wheeled = [*exposure.driven_m.items(), *exposure.wet_m.items()]  # dry ground and the swash
    if wheeled:
        classes, metres = zip(*wheeled, strict=True)
        slips = np.array([slip.get(c, 0.0) for c in classes])
        per_m = immobilization_per_m(mission, classes) * slip_factor(slips)
        stuck = sum(float(r) * m for r, m in zip(per_m, metres, strict=True))
    out["beach"]["immobilized"] = -math.expm1(-stuck)
    if exposure.surf_stuck_hazard > 0:
        out["surf"]["immobilized"] = -math.expm1(-exposure.surf_stuck_hazard)
    out["beach"]["rock"] = -math.expm1(-rock)
    areas = mine_areas(mission)
    n_mines = expected_mine_count(mission)
    if n_mines > 0 and areas:
        density = n_mines / shapely.union_all(areas).area
        met = density * 2 * TRIGGER_RADIUS_M * exposure.in_mine_area_m
        speed = ground_speed(mission, exposure.speed_mps)
        late = undetected_at_contact(mission, speed, main_ground(mission, exposure))
        rate = met * late * hz.mines.trigger_probability
        out["beach"]["mine"] = -math.expm1(-rate)
    return {p: {c: v for c, v in d.items() if v > 0} for p, d in out.items()}


def return_losses(mission: Mission, cm: CostMap, exposure: Exposure) -> dict[str, float]:
    """P(lost on the way back to sea) for a robot still going when beach operations end, shared
    among the causes as in `expected_by_cause`: the same formulas over the drive to the pick-up
    point (`exposure.beach_s`, `driven_m`) and the swim out through the surf (`surf_s`,
    `breaker_hazard`); {} without a return."""
    if not mission.phases.return_to_sea.enabled:
        return {}
    merged: dict[str, float] = {}
    for causes in robot_losses(mission, cm, exposure).values():
        for cause, p in causes.items():
            merged[cause] = 1.0 - (1.0 - merged.get(cause, 0.0)) * (1.0 - p)
    return expected_by_cause({RETURN_PHASE: merged}, (RETURN_PHASE,))[RETURN_PHASE]


def expected_by_cause(
    losses: dict[str, dict[str, float]], phases: tuple[str, ...] = PHASE_NAMES
) -> dict[str, dict[str, float]]:
    """One robot's chance of being lost in each phase to each cause, in phase order: a robot lost
    in one phase is not lost again in the next, and within a phase the causes share its loss in
    proportion to their hazards -log(1 - p) (constant-rate competing risks), but for a cause of
    `AT_PHASE_END`, which takes its share of those the others leave. The sum over phases and
    causes is `lost_probability`."""
    out: dict[str, dict[str, float]] = {}
    going = 1.0
    for phase in phases:
        causes = {c: p for c, p in losses.get(phase, {}).items() if c not in AT_PHASE_END}
        lost = going * (1.0 - math.prod(1.0 - p for p in causes.values()))
        certain = {c: 1.0 for c, p in causes.items() if p >= 1.0}  # an infinite hazard each
        weights = certain or {c: -math.log1p(-p) for c, p in causes.items()}
        total = sum(weights.values())
        out[phase] = {c: lost * w / total for c, w in weights.items()} if total > 0 else {}
        going -= lost
        for cause in AT_PHASE_END:  # what the others leave
            if (p := losses.get(phase, {}).get(cause, 0.0)) > 0:
                out[phase][cause] = going * p
                going -= going * p
    return out


def track_left(losses: dict[str, dict[str, float]], before: dict[str, float], on: dict[str, float]) -> float:
    """The share of a searcher's track it is expected to leave undriven. `losses`: its whole way's
    (`robot_losses`); `before`, `on`: the beach causes' probabilities on its way from the surf to
    its track and along the track. All of the track is left when it is lost at sea, in the surf or
    ashore before the track starts; 1 - `driven_share` of it when lost on the track; none when lost
    after it, in its slack (every loss ashore used to count as half a track left)."""
    by_phase = expected_by_cause(losses)
    early = sum(sum(by_phase[p].values()) for p in ("sea", "surf"))
    h_before, h_on = hazard(before), hazard(on)
    going = 1.0 - early
    lost_before = going * -math.expm1(-h_before)
    lost_on = going * math.exp(-h_before) * -math.expm1(-h_on)
    return early + lost_before + lost_on * (1.0 - driven_share(h_on))


def hazard(causes: dict[str, float]) -> float:
    """-log P(not lost to any of `causes`), the causes independent (inf when one is certain)."""
    return sum(-math.log1p(-p) if p < 1.0 else math.inf for p in causes.values())


def driven_share(h: float) -> float:
    """E[share of a stretch driven | lost on it] under a hazard spread evenly along it whose total
    is `h`: the truncated exponential's mean, 1/h - 1/(e^h - 1); 1/2 as h -> 0, 0 as h -> inf."""
    if h < 1e-6:
        return 0.5 - h / 12.0
    if math.isinf(h):
        return 0.0
    return 1.0 / h - 1.0 / math.expm1(h)


def time_ashore(losses: dict[str, dict[str, float]]) -> float:
    """The expected share of its window ashore a robot is there to work: none of it when lost at sea
    or in the surf, half of it when lost ashore (a constant rate's loss falls on average halfway).
    Counting half for every loss wherever it fell had reserves lost at sea take over tracks: 72.9%
    expected detection for mine_clear with every robot expected lost on the swim."""
    afloat = lost_probability(losses, ("sea", "surf"))
    return (1.0 - afloat) * (1.0 - lost_probability(losses, ("beach",)) / 2.0)


def lost_probability(losses: dict[str, dict[str, float]], phases: tuple[str, ...] = PHASE_NAMES) -> float:
    """P(lost in any of `phases`), the causes independent."""
    survive = 1.0
    for p in phases:
        for v in losses.get(p, {}).values():
            survive *= 1.0 - v
    return 1.0 - survive


# --- search design ---------------------------------------------------------------------------------


@dataclass
class SearchDesign:
    """How many robots search and wait, at what spacing, and what that should achieve."""

    searchers: int
    reserves: int
    spacing_m: float
    spacing_from: str  # "mission" (track_spacing_m) or "planned"
    window_s: tuple[float, float]  # the search may run from, to (mission time)
    search_time_s: float  # one searcher's run, at the planning speed
    speed_mps: float
    target_detection: float  # what the design aims for: the criterion with the task's confidence
    mines_expected: float
    min_spacing_m: float  # the tightest spacing the planner may choose (time, or the sensor)
    overhead: float  # run time per metre of track over 1 / speed (turns at the track ends)
    note: str = ""
    robots: int = 0  # searchers + reserves
    reserves_wanted: int = 0  # the robots the losses are expected to take before the window closes
    time_kept: float = 1.0  # share of the searchers' time the losses leave

    def run_time_s(self, area_m2: float, spacing_m: float) -> float:
        """One searcher's run over its share of `area_m2` at `spacing_m`."""
        return area_m2 / spacing_m / self.searchers / self.speed_mps * self.overhead

    def staff(self, area_m2: float, spacing_m: float) -> None:
        """Search at `spacing_m`: as many searchers as it needs to finish in the window; of the
        rest, as many reserves as the losses are expected to take; any robot beyond both searches
        too (the runs get shorter). A spacing tighter than the searchers can sweep takes reserves
        back into the search: the criterion comes before the cover for losses."""
        span = max(self.window_s[1] - self.window_s[0], 1.0)
        sweep_s = area_m2 * self.overhead / (spacing_m * self.speed_mps)
        needed = math.ceil(sweep_s / (span * self.time_kept) - 1e-9)
        self.reserves = max(0, min(self.reserves_wanted, self.robots - max(needed, 1)))
        self.searchers = self.robots - self.reserves
        self.spacing_m = float(spacing_m)
        self.search_time_s = self.run_time_s(area_m2, spacing_m)

    def tighten(
        self,
        model: str,
        width_m: float,
        spacing_m: float,
        expected: float,
        before: tuple[float, float] | None = None,
        curve: LateralRange | None = None,
    ) -> float | None:
        """A tighter spacing when the tracks laid at `spacing_m` are expected to find `expected`,
        short of the target: the ground and the edges cost expected / nominal of Koopman's formula,
        so ask the formula for that much more. With `before` (the previous layout's spacing and
        expected detection) the secant through both layouts may ask for more still: near the
        target each ratio step gains less and less (full_conops needed a dozen). None when the
        spacing is the mission's, already the tightest allowed, or the target is met."""
        if self.spacing_from != "planned" or expected >= self.target_detection - 1e-3:
            return None
        if spacing_m <= self.min_spacing_m * 1.001:
            return None
        kept = expected / max(nominal_detection(model, width_m, spacing_m, curve), 1e-9)
        want = min(self.target_detection / max(kept, 1e-9), 1.0 - 1e-9)
        lo = self.min_spacing_m
        if nominal_detection(model, width_m, lo, curve) < want:
            return lo
        gap = lambda s: nominal_detection(model, width_m, s, curve) - want  # noqa: E731
        tighter = spacing_m if gap(spacing_m) >= 0 else float(optimize.brentq(gap, lo, spacing_m))
        # A definite-range sensor's formula saturates at S = W (it promises everything already), so
        # it cannot say how much tighter; the shortfall is at edges and blocked ground, and closing
        # the tracks in by the shortfall's ratio gains there.
        tighter = max(lo, min(tighter, spacing_m * expected / self.target_detection))
        if before is not None and before[0] > spacing_m and before[1] < expected:
            slope = (expected - before[1]) / (before[0] - spacing_m)  # detection per metre tighter
            tighter = max(lo, min(tighter, spacing_m - (self.target_detection - expected) / slope))
        return tighter if tighter < spacing_m * (1.0 - 1e-3) else None


def search_speed_mps(mission: Mission, cm: CostMap, polygon: BaseGeometry) -> float:
    """The robot's mean speed over the free ground of `polygon` at the mission's cruise wheel speed:
    the harmonic mean of the terrain speeds (time per metre averaged over the area's cells)."""
    rows, cols = np.nonzero(~cm.blocked)
    x, y = cm.center_of(rows, cols)
    inside = shapely.contains_xy(polygon, x, y)
    cost = cm.cost_per_m[rows[inside], cols[inside]]
    cost = cost[np.isfinite(cost)]
    per_m = float(cost.mean()) if len(cost) else 1.0
    scale = mission.robot.wheel_speed_mps / cm.speeds.nominal_wheel_speed_mps
    return cm.speeds.reference_speed_mps * scale / per_m


def search_window_s(mission: Mission, task, start_s: float) -> tuple[float, float]:
    """When the search must be done: `takeover_end_s` less `WINDOW_SLACK` of the window."""
    end = takeover_end_s(mission, task)
    end -= WINDOW_SLACK * max(end - start_s, 0.0)
    return start_s, end


def takeover_end_s(mission: Mission, task) -> float:
    """Until when the survivors can drive lost searchers' tracks: the clearance less the standoff
    retreat, else the end of beach operations. The search window ends `WINDOW_SLACK` earlier; the
    scripted policy's takeovers run on into that slack (the robots on a piece of track are not
    idle, so no mark calls them off it), the slack being kept for them."""
    if task.clearance is None:
        return mission.beach_end_s
    v = mission.robot.wheel_speed_mps
    retreat = RETREAT_FACTOR * (task.clearance.standoff_m + STANDOFF_MARGIN_M) / v + RETREAT_ALLOWANCE_S
    return task.clearance.at_s - retreat


def takeover_s(mission: Mission, task, from_s: float) -> float:
    """The time a robot at work from `from_s` has for its own track and lost searchers' tracks:
    until the clearance's retreat (`takeover_end_s`), and again from the blast until beach
    operations end, when the scripted policy's robots resume their routes and the lost tracks'
    pieces (`swarm.sim.policy`). mine_clear at 2 m breakers (16 runs): 26.4% of the tracks open at
    the retreat, 20.8% when beach operations end 600 s after the blast."""
    before = max(takeover_end_s(mission, task) - from_s, 0.0)
    if task.clearance is None:
        return before
    after = max(mission.beach_end_s - max(task.clearance.at_s, from_s), 0.0)
    return before + after


def detection_needed(
    criterion: float, mines: float, confidence: float = DESIGN_CONFIDENCE, *, poisson: bool = False
) -> float:
    """The least per-mine detection probability p with P(detected fraction >= criterion) >=
    `confidence` (`p_criterion_met`); the criterion itself without mines."""
    if mines <= 0 or (not poisson and round(mines) <= 0):
        return criterion

    def short(p: float) -> float:
        return p_criterion_met(criterion, mines, p, poisson=poisson) - confidence

    if short(1.0 - 1e-12) < 0:
        return 1.0
    return float(optimize.brentq(short, 1e-9, 1.0 - 1e-12, xtol=1e-6))


def p_criterion_met(criterion: float, mines: float, p: float, *, poisson: bool = False) -> float:
    """P(detected fraction >= criterion) when each mine is found with probability p: binomial for
    round(`mines`) mines, or, with `poisson` (a mine density: the count of a run is Poisson with
    mean `mines`), the binomial averaged over that count. A field with few mines asks for more: at
    a 0.9 criterion, 7 mines must all be found, 14 may miss one (no mines: met)."""
    p = min(max(p, 0.0), 1.0)
    if not poisson:
        n = round(mines)
        if n <= 0:
            return 1.0 if p >= criterion else 0.0
        return float(binom.sf(math.ceil(criterion * n - 1e-9) - 1, n, p))
    counts = np.arange(int(mines + 10.0 * math.sqrt(mines) + 10.0) + 1)
    need = np.ceil(criterion * counts - 1e-9)
    met = np.where(counts > 0, binom.sf(need - 1, counts, p), 1.0)
    return float(np.sum(stats.poisson.pmf(counts, mines) * met))


def expected_markers(mines: float, p: float, lasting: np.ndarray, *, poisson: bool = False) -> float:
    """E[min(found, lasting)]: the mines a team marks when each robot that lasts marks one found
    mine. Found is binomial (round(`mines`), p), or Poisson with mean `mines` p for a density (a
    Poisson count thinned by p); lasting is the Poisson binomial of each robot's probability of
    lasting, `lasting`. Independent, so E[min(X, Y)] = sum over k >= 1 of P(X >= k) P(Y >= k): below
    min(E[X], E[Y]) wherever either can fall short of the other (Jensen)."""
    p = min(max(p, 0.0), 1.0)
    at_least_lasting = poisson_binomial_tail(lasting)  # P(Y >= k), k = 1 .. robots
    k = np.arange(1, len(at_least_lasting) + 1)
    if not len(k):
        return 0.0
    found_sf = stats.poisson.sf(k - 1, mines * p) if poisson else binom.sf(k - 1, round(mines), p)
    return float(np.sum(found_sf * at_least_lasting))


def expected_fewer(chances_a: np.ndarray, chances_b: np.ndarray) -> float:
    """E[min(A, B)] of two independent counts, each of independent events with their own chances
    (Poisson binomials): sum over k >= 1 of P(A >= k) P(B >= k), as `expected_markers`."""
    tails = [poisson_binomial_tail(c) for c in (chances_a, chances_b)]
    k = min(len(t) for t in tails)
    return float(np.sum(tails[0][:k] * tails[1][:k]))


def poisson_binomial_pmf(chances: np.ndarray) -> np.ndarray:
    """P(exactly k of independent events with probabilities `chances` happen), k = 0 .. len."""
    pmf = np.ones(1)
    for q in np.clip(np.asarray(chances, np.float64), 0.0, 1.0):
        pmf = np.convolve(pmf, [1.0 - q, q])
    return pmf


def poisson_binomial_tail(chances: np.ndarray) -> np.ndarray:
    """P(at least k of independent events with probabilities `chances` happen), k = 1 .. len."""
    return poisson_binomial_pmf(chances)[::-1].cumsum()[::-1][1:]


def p_at_least(chances: np.ndarray, k: int) -> float:
    """P(at least `k` of independent events with probabilities `chances` happen): the Poisson
    binomial's tail. 1 for k <= 0."""
    if k <= 0:
        return 1.0
    return float(min(poisson_binomial_pmf(chances)[k:].sum(), 1.0))


def expected_excess(mean: float, sd: float) -> float:
    """E[max(D, 0)] for D normal with `mean` and `sd`: mean Phi(mean/sd) + sd phi(mean/sd) (the
    normal's partial expectation); max(mean, 0) when sd is 0. A sum over many robots, each lost
    or not, is near normal; the mean of its positive part is above the positive part of its mean."""
    if sd <= 0.0:
        return max(mean, 0.0)
    z = mean / sd
    return float(mean * stats.norm.cdf(z) + sd * stats.norm.pdf(z))


def p_no_excess(mean: float, sd: float) -> float:
    """P(D <= 0) for D normal with `mean` and `sd` (`expected_excess`'s D): the chance a run's
    lost-track work is all taken over in time. The scripted policy hands a mark only to a robot
    that knows of no open piece of lost track (`swarm.sim.policy`: the detection first), so the
    trips to mark, and the markers the clearance expends, happen in such runs: mine_clear at 2 m
    breakers, where the survivors never finish the lost tracks, expends 0.56 robots a run in 32
    runs (none at 3 and 4 m) where the plan counted 2.2 to 6.9 marks, and their trips' sensors."""
    if sd <= 0.0:
        return 1.0 if mean <= 0.0 else 0.0
    return float(stats.norm.cdf(-mean / sd))


def mine_count_is_random(mission: Mission) -> bool:
    """Whether each run draws its own mine count (a density; `swarm.sim.mines.lay_mines`)."""
    return mission.hazards.mines.count is None


def with_trips(detection: float, reachable: float, width_m: float, trips_m: float, area_m2: float) -> float:
    """`detection` once trips of `trips_m` across an area of `area_m2` (to lost tracks' pieces, to
    the mines to mark), sensors on, are counted: a random search (Koopman's 1 - exp(-W L / A)) of
    what the tracks left that a robot can reach. `reachable`, the dense lanes' detection over the
    same ground, bounds what any driving finds: the rest lies where no route goes (a boulder's
    footprint margin, the foot of a dune face). full_conops, 100 runs: of the 16 mines its tracks
    leave at p < 0.5, every one next to blocked ground, the trips found none."""
    if trips_m <= 0 or area_m2 <= 0:
        return detection
    return detection + max(reachable - detection, 0.0) * -math.expm1(-width_m * trips_m / area_m2)


def nominal_detection(
    model: str, width_m: float, spacing_m: float, curve: LateralRange | None = None
) -> float:
    """Koopman's detection for parallel tracks (`coverage.detection_probability`'s formulas); with
    a tabulated lateral-range `curve`, that curve's parallel sweep (`parallel_sweep_detection`):
    the cookie cutter's min(1, W/S) at the curve's W promises everything from S = W on, where the
    curve's tails still leave mines between the tracks."""
    if curve is not None:
        return parallel_sweep_detection(curve, spacing_m)
    r = width_m / spacing_m
    if model == "cookie_cutter":
        return min(1.0, r)
    if model == "inverse_cube":
        return float(erf(math.sqrt(math.pi) / 2.0 * r))
    return -math.expm1(-r)


def parallel_sweep_detection(curve: LateralRange, spacing_m: float, samples: int = 2048) -> float:
    """Detection by infinitely many parallel tracks `spacing_m` apart of a sensor with the lateral-
    range curve p (Washburn, Search and Detection, ch. 2): the mean over a mine's offset x from a
    track of 1 - prod_k (1 - p(|x + kS|)), one independent draw per track passed, as the simulator
    draws once per pass (`swarm.sim.sensing`). Midpoint rule over x in [0, S)."""
    reach = math.ceil(float(curve.range_m[-1]) / spacing_m) + 1
    x = (np.arange(samples) + 0.5) / samples * spacing_m
    offsets = x[:, None] + spacing_m * np.arange(-reach, reach + 1)[None, :]
    return float(_lattice_detection("cookie_cutter", 0.0, offsets, curve).mean())


def _lattice_detection(model: str, width_m: float, d: np.ndarray, curve: LateralRange | None) -> np.ndarray:
    """Detection of a mine at each row of `d`, its distances (m) to the tracks passed, each law as
    the simulator draws it: inverse-cube rates add, a curve draws once per pass, a definite range
    sees to W/2."""
    return _combined(*_per_track(model, width_m, d, curve))


def _per_track(
    model: str, width_m: float, d: np.ndarray, curve: LateralRange | None
) -> tuple[bool, np.ndarray]:
    """What each track passed at distances `d` does to a mine: (True, its inverse-cube rate), which
    adds, or (False, its chance of missing the mine), which multiplies (`_combined`)."""
    if model == "inverse_cube" and curve is None:
        return True, width_m**2 / (4.0 * math.pi) / np.maximum(np.abs(d), 1e-6) ** 2
    if curve is not None:
        return False, 1.0 - LateralRangeCurve.of(curve)(d)
    return False, 1.0 - (np.abs(d) <= width_m / 2.0).astype(np.float64)


def _combined(rates: bool, terms: np.ndarray) -> np.ndarray:
    """Each row's detection from its tracks' `_per_track` terms."""
    return -np.expm1(-terms.sum(axis=1)) if rates else 1.0 - np.prod(terms, axis=1)


def found_by_lanes_before(
    model: str, width_m: float, spacing_m: float, curve: LateralRange | None = None
) -> float:
    """Chance a mine under a lane of a boustrophedon has been found before its searcher gets there,
    by the lanes it swept before: they lie on one side, S, 2S, ... away (each law as the simulator
    draws it, `_lattice_detection`). Robots steer clear of what has been found, so only the rest
    can go off under them (mine_clear's lanes, 1.92 m apart for a 3 m inverse-cube sweep width:
    27%). 0 for random search, whose tracks are not lanes."""
    if model in ("random", "random_search") or spacing_m <= 0.0:
        return 0.0
    if model == "inverse_cube" and curve is None:
        lanes = 60  # the rate falls as 1/x^2: beyond 60 lanes it adds under W^2 / (240 pi S^2)
    else:
        reach = float(curve.range_m[-1]) if curve is not None else width_m / 2.0
        lanes = math.ceil(reach / spacing_m) + 1
    d = spacing_m * np.arange(1, lanes + 1, dtype=np.float64)[None, :]
    return float(_lattice_detection(model, width_m, d, curve)[0])


def undone_lane_kept(
    model: str, width_m: float, spacing_m: float, curve: LateralRange | None = None, samples: int = 64
) -> float:
    """Of what a lane's strip is expected to find in an endless lattice of tracks `spacing_m` apart,
    the share kept when that lane's track is never driven: the neighbours' sensors reach in from
    both sides, and the neighbours' strips lose the undone track's help, which counts against it
    too. The lattice with and without the lane (`_lattice_detection`), integrated across the
    lane's reach. (`nominal_detection(2S) / nominal(S)` is the average over the swept
    and the unswept strips of every other lane undone: it keeps half of a cookie cutter's strip at
    W = S, where an undone lane keeps none.)"""
    return _KeptBeside(model, width_m, spacing_m, curve, 0, samples)(frozenset())


def _lanes_reached(model: str, width_m: float, spacing_m: float, curve: LateralRange | None) -> int:
    """How many lanes to each side a track's sensor reaches into (inverse cube: 60, beyond which
    the rate adds at most W^2 / (120 pi S^2))."""
    if model == "inverse_cube" and curve is None:
        return 60
    reach = float(curve.range_m[-1]) if curve is not None else width_m / 2.0
    return math.ceil(reach / spacing_m) + 1


class _KeptBeside:
    """`undone_lane_kept` of lane 0 when the lanes at some offsets (up to `near` a side) are undone
    too: what its strip finds without them all, less what the driven strips lose by lane 0's
    absence alone (the loss in the other undone strips is theirs), over what its strip finds in
    the full lattice. The lattice's misses are worked out once; each set of lanes undone then
    takes out only its own columns. The lanes beyond `near` are each undone with probability
    `far_undone`, independently: their terms become their expectations, exact for both laws
    (a miss 1 - (1 - q) p; a rate -log(q + (1 - q) e^-r)). Counting them as driven left 10% of a
    lane's strip to mine_clear's lanes when every searcher was lost at sea."""

    def __init__(
        self,
        model: str,
        width_m: float,
        spacing_m: float,
        curve: LateralRange | None,
        near: int,
        samples: int,
        far_undone: float = 0.0,
    ) -> None:
        far = _lanes_reached(model, width_m, spacing_m, curve) + near
        self.k = np.arange(-far - 1, far + 2)
        y = (np.arange((2 * far + 1) * samples) + 0.5) / samples * spacing_m - (far + 0.5) * spacing_m
        self.rates, self.terms = _per_track(model, width_m, y[:, None] - self.k[None, :] * spacing_m, curve)
        self.lane = np.rint(y / spacing_m).astype(int)
        self.samples = samples
        self.full = self._detection(np.ones(len(self.k), bool))
        q = min(max(far_undone, 0.0), 1.0)
        # a far strip is driven (and loses lane 0's help) only when its own lane is
        self.driven_weight = np.where(np.abs(self.lane) > near, 1.0 - q, 1.0)
        if q > 0.0:
            beyond = np.abs(self.k) > near
            t = self.terms[:, beyond]
            self.terms = self.terms.copy()
            if self.rates:
                self.terms[:, beyond] = -np.log(q + (1.0 - q) * np.exp(-t))
            else:
                self.terms[:, beyond] = q + (1.0 - q) * t
        self.own = self.lane == 0
        self.nominal = float(self.full[self.own].mean())

    def _detection(self, tracks: np.ndarray) -> np.ndarray:
        return _combined(self.rates, self.terms[:, tracks])

    def __call__(self, others: frozenset) -> float:
        if self.nominal <= 0.0:
            return 1.0
        gone = np.isin(self.k, list(others))
        with_others = self._detection(~gone)
        without = self._detection(~gone & (self.k != 0))
        driven = ~self.own & ~np.isin(self.lane, list(others))
        help_lost = (with_others - without) * self.driven_weight
        lost = float((self.full - without)[self.own].sum() + help_lost[driven].sum())
        return float(min(max(1.0 - lost / self.samples / self.nominal, 0.0), 1.0))


def undone_band_kept(
    model: str,
    width_m: float,
    spacing_m: float,
    curve: LateralRange | None = None,
    *,
    lanes: float,
    left: float,
    undone: float,
    lost: float = 0.0,
    samples: int = 16,
) -> float:
    """Of what the strips of the lost searchers' undone track are expected to find, the share kept.
    A searcher drives a boustrophedon across its own band of `lanes` adjacent lanes, so a lost one
    leaves the rest of its band. `left`: the mean share of its track a lost searcher leaves: all
    of it when lost before the track, a uniform share when lost on it, mixed to give that mean.
    The survivors take that rest over in pieces, nearest first (`swarm.sim.policy` auctions them),
    and leave `undone` of it; what nobody reaches in time lies together, so where a lane of the
    rest is undone, the band's other lanes of the rest are undone there too. A neighbouring band's
    lane is undone when its searcher was lost (probability `lost`), had not driven it (`left`)
    and nobody took it over (`undone`), a draw of its own. (Each lane of the rest undone on its own
    kept 95% of the strips of mine_clear's 1.1 m lanes laid for 24 searchers with no reserves,
    where the runs' sensors covered 84% of the track left undone, and 86% at 18 searchers, 1.46 m
    apart, where they covered 72%.) A lane whose neighbours are driven keeps `undone_lane_kept`,
    the limit of one-lane bands with nothing lost beside them; with undone neighbours less (an
    interior lane of a wide undone band, nothing but what the lanes beyond reach). The neighbours
    out to `BAND_REACH_LANES` to a side count."""
    m = max(1, round(lanes))
    reach = min(_lanes_reached(model, width_m, spacing_m, curve) - 1, BAND_REACH_LANES)
    offsets = [o for o in range(-reach, reach + 1) if o != 0]
    q = 32
    share = (np.arange(q) + 0.5) / q
    if left >= 0.5:  # lost before its track with weight a, on it (a uniform share) otherwise
        a = min(2.0 * left - 1.0, 1.0)
        rest, weight = np.append(share, 1.0), np.append(np.full(q, (1.0 - a) / q), a)
    else:
        rest, weight = 2.0 * max(left, 0.0) * share, np.full(q, 1.0 / q)
    xi = (np.arange(samples) + 0.5) / samples
    lane = np.arange(m)

    def at(j: np.ndarray) -> np.ndarray:  # (lanes, samples) each lane's point abreast, in lanes driven
        return j[:, None] + np.where(j[:, None] % 2 == 0, xi[None, :], 1.0 - xi[None, :])

    first = m * (1.0 - rest)[:, None, None]  # where each rest begins
    here = at(lane)[None] >= first  # (rests, lanes, samples) the point is in the rest
    # each neighbour's state, a base-3 digit: 0 driven, 1 in the rest of this band, 2 another band's
    keys = np.zeros(here.shape, np.int64)
    for digit, o in enumerate(offsets):
        j = lane + o
        inside = ((j >= 0) & (j < m))[:, None]
        state = np.where(inside, at(np.clip(j, 0, m - 1))[None] >= first, 2)
        keys += state.astype(np.int64) * 3**digit
    totals = np.bincount(keys.ravel(), weights=(weight[:, None, None] * here).ravel(), minlength=1)
    if totals.sum() <= 0.0:
        return undone_lane_kept(model, width_m, spacing_m, curve)
    chance = (0.0, 1.0, min(lost * left * undone, 1.0))  # undone, by state
    kept = 0.0
    beside = _KeptBeside(model, width_m, spacing_m, curve, reach, 64, far_undone=chance[2])
    cache: dict[frozenset, float] = {}
    for key in np.flatnonzero(totals):
        p_of = [chance[key // 3**digit % 3] for digit in range(len(offsets))]
        maybe = [(o, p) for o, p in zip(offsets, p_of, strict=True) if p > 0.0]
        for pick in range(1 << len(maybe)):
            gone = frozenset(o for b, (o, _) in enumerate(maybe) if pick >> b & 1)
            p = math.prod(pp if pick >> b & 1 else 1.0 - pp for b, (_, pp) in enumerate(maybe))
            if gone not in cache:
                cache[gone] = beside(gone)
            kept += totals[key] * p * cache[gone]
    return float(kept / totals.sum())


def design_search(
    mission: Mission,
    task,
    *,
    robots: int,
    area_m2: float,
    speed_mps: float,
    start_s: float,
    loss_before_end: float,
    reach: float,
    row_m: float,
) -> SearchDesign:
    """Searchers, reserves and spacing for `robots` robots (module docstring).

    `loss_before_end`: one robot's chance of being lost before the search window closes; `reach`:
    the detection perfect coverage of the drivable ground would give (mines on ground no robot can
    reach are found only from its edge)."""
    window = search_window_s(mission, task, start_s)
    span = max(window[1] - window[0], 1.0)
    mines = expected_mine_count(mission)
    target = detection_needed(
        mission.success.min_detection_fraction,
        mines,
        task.detection_confidence,
        poisson=mine_count_is_random(mission),
    )
    model = "random" if task.sensor.model == "random_search" else task.sensor.model
    w = task.sensor.width_m
    curve = task.sensor.lateral_range
    overhead = 1.0 + TURN_S * speed_mps / max(row_m, 1.0)
    # searcher time the losses are expected to cost (a lost searcher has driven half its run)
    kept = 1.0 - loss_before_end / 2.0

    def fits(searchers: int) -> float:
        """The tightest spacing `searchers` can sweep in the window."""
        return area_m2 / (searchers * speed_mps * span * kept) * overhead

    note = ""
    if task.track_spacing_m is not None:
        spacing, source = task.track_spacing_m, "mission"
    else:
        source = "planned"
        if nominal_detection(model, w, MIN_SPACING_FRACTION * w, curve) * reach < target:
            wanted = MIN_SPACING_FRACTION * w
            note = f"no spacing reaches the {target:.1%} the criterion needs: the ground allows {reach:.1%}"
        elif nominal_detection(model, w, 2 * w, curve) * reach >= target:
            wanted = 2 * w
        else:
            wanted = optimize.brentq(
                lambda s: nominal_detection(model, w, s, curve) * reach - target,
                MIN_SPACING_FRACTION * w,
                2 * w,
            )
        spacing = max(wanted, fits(robots))
        if spacing > wanted:
            late = f"{robots} searchers cannot sweep at {wanted:.2f} m before {window[1]:.0f} s"
            note = "; ".join(filter(None, [note, f"{late}: spacing {spacing:.2f} m"]))
    design = SearchDesign(
        searchers=robots,
        reserves=0,
        spacing_m=float(spacing),
        spacing_from=source,
        window_s=window,
        search_time_s=0.0,
        speed_mps=speed_mps,
        target_detection=target,
        mines_expected=mines,
        min_spacing_m=float(max(MIN_SPACING_FRACTION * w, fits(robots))),
        overhead=overhead,
        note=note,
        robots=robots,
        reserves_wanted=math.ceil(robots * loss_before_end - 1e-9),
        time_kept=kept,
    )
    design.staff(area_m2, spacing)
    return design
