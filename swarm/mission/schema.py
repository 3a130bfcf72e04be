"""The mission schema (pydantic v2): what a `missions/*.yaml` file may say, with units and defaults.

A mission names the map it runs on, the planner profile, the robot type (a robot YAML and an
optional terrain YAML of calibrated modes), the swarm size, how the robots are launched, the time
limits of the four phases of the concept of operations (thesis section 1.2: sea transit, surf
crossing, beach operations, return to sea and recovery), the tasks, what counts as success, and the
hazards the simulator draws losses from. Every key that holds a quantity carries its unit
(`_m`, `_s`, `_h`, `_mps`, `_hz`, `_dbm`, `_dbi`, `_db`, `_wh`, `_w`, `_per_km`, `_per_h`,
`_per_ha`); values are plain numbers (`5`, never `"5 m"`).

Every model forbids unknown keys, takes values strictly as typed (a quoted `"5"` is not a number,
`12.0` is not a whole number) and refuses NaN and infinities. `mission_json_schema()` is the JSON
Schema editors validate mission files against as people type (`swarm schema`). Loading a file,
with its reference checks (files exist, regions exist with the right kind) and one-line errors,
is `swarm.mission.load`.
"""

from __future__ import annotations

import itertools
import math
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import (
    Field,
    PlainValidator,
    PrivateAttr,
    WithJsonSchema,
    model_validator,
)

from swarm.inputs import InputModel
from swarm.inputs import expected as _expected

#: Task types, the values of a task's `type:` key.
TASK_TYPES = ("landing", "search", "relay", "surveillance", "beacon")
#: How the robots are put in the water (or on the beach).
PLATFORMS = ("by_hand", "small_craft", "ship", "helicopter", "beach")
#: Distance offshore (m) each platform releases the robots at when `launch.offshore_m` is not given.
#: Thesis 1.2: "from ~100 m to a few nautical miles offshore", or placed directly on the beach.
PLATFORM_OFFSHORE_M = {
    "by_hand": 100.0,  # a swimmer or wader beyond the breakers
    "small_craft": 500.0,  # RHIB or raft, close in
    "ship": 3000.0,  # well deck or LCS, about 1.6 nautical miles out
    "helicopter": 1000.0,  # a drop line offshore
    "beach": 0.0,  # placed directly on the beach: no sea transit, no surf crossing
}
#: Search-theory detection models (Koopman 1946; Washburn, "Search and Detection").
SENSOR_MODELS = ("cookie_cutter", "inverse_cube", "random_search")

_POLYGON_KINDS = ("search_area", "landing_zone", "keep_out")


def _is_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _check_place(value: object) -> str | tuple[float, float]:
    if isinstance(value, str) and value.strip():
        return value
    if isinstance(value, list | tuple) and len(value) == 2 and all(_is_number(v) for v in value):
        return float(value[0]), float(value[1])
    raise _expected("a region name of the map or [x, y] coordinates in metres")


#: A region of the map, by name, or a point [x, y] in the map's metres (x east, y north).
Place = Annotated[
    str | tuple[float, float],
    PlainValidator(_check_place),
    WithJsonSchema(
        {
            "anyOf": [
                {"type": "string", "minLength": 1, "description": "a region name of the map"},
                {
                    "type": "array",
                    "items": {"type": "number"},
                    "minItems": 2,
                    "maxItems": 2,
                    "description": "[x, y] in the map's metres (x east, y north)",
                },
            ]
        }
    ),
]
RegionName = Annotated[str, Field(min_length=1)]
Fraction = Annotated[float, Field(ge=0.0, le=1.0)]


class _Model(InputModel):
    pass


# --- robot, swarm, launch, phases -----------------------------------------------------------------


class RobotSpec(_Model):
    """The robot type: its geometry and mass, and the terrain-mode coefficients its dynamics use."""

    file: str = Field(
        "skid4",
        min_length=1,
        description="Robot YAML (mass, geometry, encoder ticks): a path relative to the mission file, "
        "or the name of a bundled robot (swarm/data/robots/NAME.yaml). Default: skid4, the thesis robot.",
    )
    terrain: str | None = Field(
        None,
        min_length=1,
        description="Terrain YAML of calibrated modes overriding or adding to the bundled ones (as "
        "`--terrain`): a path relative to the mission file, or the name of a bundled file "
        "(swarm/data/terrain/NAME.yaml, e.g. skid4-hardsand). Default: none, the bundled modes.",
    )
    wheel_speed_mps: float = Field(
        0.6,
        gt=0.0,
        le=5.0,
        description="Commanded wheel surface speed on land, m/s. Default 0.6: the thesis robot's cruise.",
    )
    swim_speed_mps: float = Field(
        0.5,
        gt=0.0,
        le=5.0,
        description="Speed through open water (jet drive or wheel paddling), m/s, for the sea transit "
        "from the release point to the map. Default 0.5 (about 1 knot; assumed).",
    )
    jet_thrust_n: float | None = Field(
        None,
        gt=0.0,
        le=1000.0,
        description="Largest water-jet thrust, newtons. Default: the thrust that holds 1.5 x swim_speed_mps "
        "against the hull's deep-water drag (margin for currents and surges).",
    )


#: The largest swarm a mission may launch: memory, not the schema, is the real limit
#: (`swarm.sim.memory`); this bound only keeps a typo (an extra zero or two) from being planned.
MAX_ROBOTS = 100_000


class SwarmSpec(_Model):
    """How many robots."""

    count: int = Field(
        ge=1,
        le=MAX_ROBOTS,
        description="Robots launched. Losing some is expected (thesis 1.2): size the swarm for the "
        "tasks plus the losses the hazards will take. A run that would not fit in memory is refused "
        "with an estimate before it starts.",
    )


class Launch(_Model):
    """How and where the robots are put in the water (or on the beach)."""

    platform: Literal["by_hand", "small_craft", "ship", "helicopter", "beach"] = Field(
        "small_craft",
        description="by_hand | small_craft (RHIB, raft) | ship (well deck, LCS) | helicopter (drop) "
        "| beach (placed directly on the beach: no sea transit or surf crossing). Default small_craft.",
    )
    points: list[Place] | None = Field(
        None,
        min_length=1,
        description="Where the robots enter the map: launch regions of the map by name, or [x, y] in "
        "metres; robots are spread over them in turn. For platform beach, points on land. Default: every "
        "launch region of the map.",
    )
    offshore_m: float | None = Field(
        None,
        ge=0.0,
        le=20000.0,
        description="Distance from a launch point out to where the platform releases the robots, metres; "
        "the robots swim it at robot.swim_speed_mps before they reach the map. Default: by platform, "
        "by_hand 100, small_craft 500, ship 3000, helicopter 1000, beach 0.",
    )
    interval_s: float = Field(
        5.0,
        ge=0.0,
        le=3600.0,
        description="Time between successive robots leaving the platform, seconds. Default 5.",
    )

    @property
    def release_offshore_m(self) -> float:
        """`offshore_m`, or the platform's default."""
        return PLATFORM_OFFSHORE_M[self.platform] if self.offshore_m is None else self.offshore_m


class SeaTransit(_Model):
    """From release to the seaward edge of the surf zone."""

    time_limit_s: float = Field(
        3600.0,
        gt=0.0,
        description="Longest a robot may take from release to the surf, seconds; one still at sea then "
        "is counted lost. Default 3600.",
    )
    submerged_depth_m: float = Field(
        0.0,
        ge=0.0,
        le=10.0,
        description="Transit depth, metres: 0 on the surface, 1-2 for covertness (thesis 1.2). Default 0.",
    )


class SurfCrossing(_Model):
    """Through the breakers to where the wheels find traction (terrain mode on)."""

    time_limit_s: float = Field(
        900.0,
        gt=0.0,
        description="Longest a robot may spend in the surf zone, seconds; one still in it then is "
        "counted lost (stranded, rolled). Default 900.",
    )


class BeachOperations(_Model):
    """The tasks, from the first robot ashore."""

    time_limit_s: float = Field(
        3600.0,
        gt=0.0,
        description="Time for the tasks, seconds, from the first robot ashore. Default 3600.",
    )


class ReturnToSea(_Model):
    """Survivors drive back into the sea and are picked up; recovering all of them is optional."""

    enabled: bool = Field(True, description="Whether survivors return to sea. Default true.")
    time_limit_s: float = Field(
        1800.0,
        gt=0.0,
        description="Time from the end of beach operations until pick-up ends, seconds. Default 1800.",
    )
    points: list[Place] | None = Field(
        None,
        min_length=1,
        description="Pick-up points: launch regions of the map, or [x, y] in the water, metres; survivors "
        "cross the surf in front of the nearest and are picked up afloat beyond it (on dry ground, a beach "
        "launch's: on reaching it). Default: the launch points.",
    )


class Phases(_Model):
    """The four phases of the concept of operations, in order, with their time limits."""

    sea_transit: SeaTransit = Field(default_factory=SeaTransit)
    surf_crossing: SurfCrossing = Field(default_factory=SurfCrossing)
    beach_operations: BeachOperations = Field(default_factory=BeachOperations)
    return_to_sea: ReturnToSea = Field(default_factory=ReturnToSea)


# --- tasks ------------------------------------------------------------------------------------------


class _Task(_Model):
    name: str | None = Field(
        None, min_length=1, description="A label for reports and logs. Default: TYPE_INDEX, e.g. search_1."
    )


class LandingTask(_Task):
    """Reach landing zones and hold them: `robots_per_zone` robots inside each zone."""

    type: Literal["landing"] = Field(description="The task type: landing.")
    zones: list[RegionName] = Field(min_length=1, description="landing_zone regions of the map, by name.")
    robots_per_zone: int = Field(1, ge=1, description="Robots each zone needs. Default 1.")


#: The narrowest sweep width a sensor may have (m): a mine detector's head is wider, and lanes
#: laid that close (a search's spacing follows W) number thousands and take the planner minutes.
MIN_SWEEP_WIDTH_M = 0.1


class LateralRange(_Model):
    """A tabulated lateral-range curve: detection probability of an object passed at each distance
    abeam (symmetric, zero beyond the last range). Its sweep width is W = 2 ∫ p(x) dx."""

    range_m: list[float] = Field(
        min_length=2, description="Distances abeam, metres: starting at 0, increasing."
    )
    probability: list[Fraction] = Field(
        min_length=2, description="Detection probability at each distance, 0..1."
    )

    @model_validator(mode="after")
    def _check(self) -> LateralRange:
        r = self.range_m
        if r[0] != 0.0:
            raise _expected("a list of distances starting at 0", found=r[0], key="range_m")
        if any(b <= a for a, b in itertools.pairwise(r)):
            raise _expected("increasing distances (metres)", found=r, key="range_m")
        if len(self.probability) != len(r):
            raise _expected(
                f"one probability per distance in range_m ({len(r)})",
                found=f"{len(self.probability)} probabilities",
                key="probability",
            )
        if self.sweep_width_m < MIN_SWEEP_WIDTH_M:
            raise _expected(
                f"a curve whose sweep width 2 ∫ p dx is at least {MIN_SWEEP_WIDTH_M:g} m",
                found=f"{self.sweep_width_m:g} m",
                key="probability",
            )
        return self

    @property
    def sweep_width_m(self) -> float:
        """W = 2 ∫ p(x) dx over the table (trapezoid rule)."""
        r, p = self.range_m, self.probability
        return 2.0 * sum((r[i + 1] - r[i]) * (p[i] + p[i + 1]) / 2.0 for i in range(len(r) - 1))


class Sensor(_Model):
    """The mine and obstacle sensor: a sweep width, or the lateral-range curve it comes from, and
    the detection model that turns sweep width W and track spacing S into the expected fraction of
    mines found."""

    model: Literal["cookie_cutter", "inverse_cube", "random_search"] = Field(
        "inverse_cube",
        description="Detection model: cookie_cutter (definite range W/2: P = min(1, W/S)); "
        "inverse_cube (Koopman's law for a sensor whose detection rate falls with the cube of "
        "range: P = erf(√π W / (2 S))); random_search (Koopman's random search, tracks without "
        "pattern: P = 1 - exp(-W / S)). Default inverse_cube.",
    )
    sweep_width_m: float | None = Field(
        None,
        ge=MIN_SWEEP_WIDTH_M,
        le=1000.0,
        description="Effective sweep width W, metres, at least 0.1. Give this or lateral_range.",
    )
    lateral_range: LateralRange | None = Field(
        None, description="A tabulated lateral-range curve instead of sweep_width_m."
    )

    false_alarms_per_km: float = Field(
        0.0,
        ge=0.0,
        le=1000.0,
        description="False alarms per kilometre of track searched (clutter, debris): each is marked like a "
        "mine. Default 0.",
    )

    @model_validator(mode="after")
    def _one_width(self) -> Sensor:
        given = (self.sweep_width_m is not None) + (self.lateral_range is not None)
        if given != 1:
            found = "both" if given == 2 else "neither"
            raise _expected("exactly one of sweep_width_m or lateral_range", found=found)
        if self.lateral_range is not None and self.lateral_range.sweep_width_m <= 0:
            raise _expected("a curve with some detection probability > 0", key="lateral_range")
        return self

    @property
    def width_m(self) -> float:
        """The sweep width W, metres (given, or integrated from the lateral-range curve)."""
        if self.sweep_width_m is not None:
            return self.sweep_width_m
        assert self.lateral_range is not None
        return self.lateral_range.sweep_width_m

    def coverage_probability(self, track_spacing_m: float) -> float:
        """Expected fraction of the mines in an area swept by parallel tracks `track_spacing_m` apart."""
        ratio = self.width_m / track_spacing_m
        if self.model == "cookie_cutter":
            return min(1.0, ratio)
        if self.model == "inverse_cube":
            return math.erf(math.sqrt(math.pi) / 2.0 * ratio)
        return 1.0 - math.exp(-ratio)


class Clearance(_Model):
    """Synchronized clearance: the robots loitering on the marked mines set them off together."""

    at_s: float = Field(
        ge=0.0,
        description="Mission time of the simultaneous detonation, seconds from the first release; "
        "before the end of beach operations.",
    )
    standoff_m: float = Field(
        50.0,
        ge=0.0,
        description="Distance every other robot keeps from a marked mine at that time, metres. Default 50.",
    )


#: The search's default design confidence (`SearchTask.detection_confidence`).
DETECTION_CONFIDENCE = 0.95


class SearchTask(_Task):
    """Mine and obstacle search over an area, marking what is found: a robot loiters on each mine."""

    type: Literal["search"] = Field(description="The task type: search.")
    area: RegionName = Field(description="A search_area region of the map, by name.")
    sensor: Sensor
    track_spacing_m: float | None = Field(
        None,
        gt=0.0,
        description="Distance between parallel search tracks, metres. Default: the planner's, the widest "
        "whose tracks meet the detection criterion with detection_confidence.",
    )
    detection_confidence: float = Field(
        DETECTION_CONFIDENCE,
        gt=0.5,
        lt=1.0,
        description="Probability, over the mine field's draw, with which the planned tracks are to meet "
        "success.min_detection_fraction. Default 0.95. A mission with several other criteria that can "
        "fail asks more of the search, so that P(every criterion) still reaches its target.",
    )
    robots: int | None = Field(
        None,
        ge=1,
        description="Robots searching. Default: every robot no other task holds. With fewer "
        "robots than this and the other tasks' stations, the stations come first and the search "
        "is planned for the robots left.",
    )
    mark: bool = Field(True, description="A robot loiters on each mine found to mark it. Default true.")
    clearance: Clearance | None = Field(
        None, description="Synchronized clearance of the marked mines (needs mark: true). Default: none."
    )

    @property
    def spacing_m(self) -> float:
        return self.sensor.width_m if self.track_spacing_m is None else self.track_spacing_m

    @property
    def expected_detection(self) -> float:
        """Expected fraction of the area's mines detected by one pass at `spacing_m`."""
        return self.sensor.coverage_probability(self.spacing_m)


class Radio(_Model):
    """Radio and link budget: two-ray ground-reflection path loss between antennas at their heights.
    A link works while received power, tx_power + gains - path loss, stays above the receiver
    sensitivity plus the fade margin."""

    frequency_hz: float = Field(
        2.4e9, gt=0.0, description="Carrier frequency, Hz. Default 2.4e9 (2.4 GHz ISM)."
    )
    tx_power_dbm: float = Field(20.0, le=60.0, description="Transmit power, dBm. Default 20 (100 mW).")
    tx_gain_dbi: float = Field(2.0, description="Transmit antenna gain, dBi. Default 2 (a dipole).")
    rx_gain_dbi: float = Field(2.0, description="Receive antenna gain, dBi. Default 2 (a dipole).")
    antenna_height_m: float = Field(
        0.5, gt=0.0, le=10.0, description="Robot antenna height above the ground, metres. Default 0.5."
    )
    source_antenna_height_m: float = Field(
        2.0,
        gt=0.0,
        le=100.0,
        description="Antenna height of the offshore source (craft or buoy) and of the sinks, metres: "
        "they link each other directly when their masts reach. Default 2.",
    )
    rx_sensitivity_dbm: float = Field(-95.0, le=0.0, description="Receiver sensitivity, dBm. Default -95.")
    fade_margin_db: float = Field(10.0, ge=0.0, description="Fade margin kept in reserve, dB. Default 10.")


class RelayTask(_Task):
    """A shore-to-sea communications relay: static robots forming a chain (or two) of radio links
    from an offshore source to one or more sinks inland."""

    type: Literal["relay"] = Field(description="The task type: relay.")
    source: Place = Field(description="A relay_source region of the map, or [x, y] offshore in metres.")
    sinks: list[Place] = Field(
        min_length=1, description="relay_sink regions of the map, or [x, y] inland in metres."
    )
    radio: Radio = Field(default_factory=Radio)
    redundancy: Literal[1, 2] = Field(
        1,
        description="Independent relay paths from the source to each sink: 2 survives the loss of any "
        "one relay robot. Default 1.",
    )


class SurveillanceTask(_Task):
    """Watch observation points: a robot dwells at each."""

    type: Literal["surveillance"] = Field(description="The task type: surveillance.")
    points: list[Place] = Field(
        min_length=1, description="observation_point regions of the map, or [x, y] in metres."
    )
    dwell_s: float = Field(600.0, gt=0.0, description="Time to watch from each point, seconds. Default 600.")
    robots_per_point: int = Field(1, ge=1, description="Robots at each point. Default 1.")


class BeaconTask(_Task):
    """Mark locations: a robot drives to each point and holds there as a beacon."""

    type: Literal["beacon"] = Field(description="The task type: beacon.")
    points: list[Place] = Field(min_length=1, description="beacon regions of the map, or [x, y] in metres.")
    robots_per_point: int = Field(1, ge=1, description="Robots at each point. Default 1.")
    hold_s: float | None = Field(
        None, gt=0.0, description="How long to hold, seconds. Default: until beach operations end."
    )


Task = Annotated[
    LandingTask | SearchTask | RelayTask | SurveillanceTask | BeaconTask, Field(discriminator="type")
]
TASK_CLASSES: dict[str, type[_Task]] = {
    "landing": LandingTask,
    "search": SearchTask,
    "relay": RelayTask,
    "surveillance": SurveillanceTask,
    "beacon": BeaconTask,
}


# --- success and hazards ----------------------------------------------------------------------------


class Success(_Model):
    """What the mission must achieve. Each criterion applies only when the mission has the task."""

    min_landing_fraction: Fraction = Field(
        1.0,
        description="Fraction of landing zones reached by their robots_per_zone robots. Default 1.0.",
    )
    min_detection_fraction: Fraction = Field(
        0.8,
        description="Expected fraction of the mines in each search area detected. Default 0.8.",
    )
    min_relay_connected_fraction: Fraction = Field(
        0.9,
        description="Fraction of beach-operations time the source is linked to every sink (with the asked "
        "redundancy). Default 0.9.",
    )
    min_surveillance_fraction: Fraction = Field(
        1.0, description="Fraction of observation points watched for their whole dwell. Default 1.0."
    )
    min_beacon_fraction: Fraction = Field(1.0, description="Fraction of beacon points held. Default 1.0.")
    min_robots_recovered: int = Field(
        0,
        ge=0,
        description="Robots picked up at the end (recovering all is optional, thesis 1.2). Default 0.",
    )


class Attrition(_Model):
    """Random failures: each robot fails after an exponential time with this mean, any phase."""

    mtbf_h: float = Field(
        10.0,
        gt=0.0,
        description="Mean time between failures per robot, hours. Default 10: field UGVs fail every 6-20 h "
        "(Carlson & Murphy 2005, 'How UGVs physically fail in the field').",
    )


class SurfHazard(_Model):
    """Wave impact damage: every breaker that hits a robot in the surf zone (one a wave period)
    disables it with probability 1 / (1 + exp(-(H - damage_h50_m) / damage_spread_m))."""

    wave_height_m: float = Field(
        1.0,
        ge=0.0,
        le=10.0,
        description="Breaker height H, metres. Default 1.0 (the maps: gentle_fine 1.0, "
        "steep_coarse_river 1.5, test_small 0.6).",
    )
    wave_period_s: float = Field(8.0, gt=0.0, le=30.0, description="Wave period, seconds. Default 8.")
    damage_h50_m: float = Field(
        3.0,
        gt=0.0,
        description="Breaker height at which one impact disables half the robots it hits, metres. "
        "Default 3.0 (assumed: the robot works upright or inverted in the surf, thesis 1.2).",
    )
    damage_spread_m: float = Field(
        0.4, gt=0.0, description="Width of the logistic damage curve, metres. Default 0.4 (assumed)."
    )
    wave_angle_deg: float = Field(
        5.0,
        ge=-60.0,
        le=60.0,
        description="Angle between the breaking wave crests and the shoreline, degrees (positive drives "
        "the longshore current toward +x). Default 5.",
    )
    longshore_current_mps: float | None = Field(
        None,
        ge=-5.0,
        le=5.0,
        description="Longshore current in the surf zone, m/s along +x. Default: Longuet-Higgins (1970), "
        "V = 1.17 sqrt(g H) sin(a) cos(a) from wave_height_m and wave_angle_deg.",
    )
    flip_probability: Fraction = Field(
        0.2,
        description="Chance one breaker impact turns a robot over; it works inverted (thesis 1.2). "
        "Default 0.2 (assumed).",
    )

    def longshore_current(self) -> float:
        """The surf zone's longshore current, m/s along +x (given, or Longuet-Higgins 1970)."""
        if self.longshore_current_mps is not None:
            return self.longshore_current_mps
        a = math.radians(self.wave_angle_deg)
        return 1.17 * math.sqrt(9.80665 * self.wave_height_m) * math.sin(a) * math.cos(a)

    def impact_damage_probability(self) -> float:
        """Probability one breaker impact disables a robot."""
        return 1.0 / (1.0 + math.exp(-(self.wave_height_m - self.damage_h50_m) / self.damage_spread_m))

    def damage_probability(self, height_m: np.ndarray) -> np.ndarray:
        """Probability one breaker of each local height (m) disables a robot: inside the surf zone
        the breakers lose height with the depth (`swarm.world.coastal.local_breaker_height`)."""
        return 1.0 / (1.0 + np.exp(-(np.asarray(height_m) - self.damage_h50_m) / self.damage_spread_m))


def _default_mode_factors() -> dict[str, float]:
    return {"soft_sand": 5.0, "kelp_wrack": 3.0, "vegetation": 3.0, "dirt": 1.5}


class Immobilization(_Model):
    """Getting stuck (sinkage, high-centring, tangled in wrack): a chance per kilometre driven."""

    per_km: float = Field(
        0.02,
        ge=0.0,
        description="Chance of getting stuck per km driven on firm ground. Default 0.02 (assumed).",
    )
    mode_factors: dict[str, Annotated[float, Field(ge=0.0)]] = Field(
        default_factory=_default_mode_factors,
        description="Multipliers of per_km by terrain mode (modes not listed: 1). Default soft_sand 5, "
        "kelp_wrack 3, vegetation 3, dirt 1.5 (assumed; soft sand is where the thesis model fails).",
    )


class Rocks(_Model):
    """Rocks: damage driving over rock ground, and rocks too small for the map that stop a robot."""

    damage_per_km: float = Field(
        0.05, ge=0.0, description="Chance of disabling damage per km driven on rock ground. Default 0.05."
    )
    hidden_per_ha: float = Field(
        0.0,
        ge=0.0,
        description="Unmapped rocks that stop a robot, per hectare of beach. Default 0 (only the map's).",
    )
    collision_damage_probability: Fraction = Field(
        0.2,
        description="Chance that running into a boulder (a mapped one, or a hidden rock) disables the "
        "robot; otherwise it stops against it. Default 0.2 (assumed).",
    )


class Mines(_Model):
    """Mines laid in an area: robots that drive over one may set it off and are lost."""

    count: int | None = Field(None, ge=0, description="Mines in the area. Give count or density_per_ha.")
    density_per_ha: float | None = Field(None, ge=0.0, description="Mines per hectare of the area.")
    area: RegionName | None = Field(
        None,
        description="A search_area, landing_zone or keep_out region of the map. Default: the areas of the "
        "mission's search tasks.",
    )
    trigger_probability: Fraction = Field(
        0.5,
        description="Chance a robot driving over a mine sets it off, 0..1. Default 0.5 (a 30 kg robot "
        "triggers anti-personnel but rarely anti-tank fuzes).",
    )

    @model_validator(mode="after")
    def _count_or_density(self) -> Mines:
        if self.count is not None and self.density_per_ha is not None:
            raise _expected("count or density_per_ha, not both", found="both")
        return self


class Battery(_Model):
    """Energy: a robot that runs flat stops where it is."""

    capacity_wh: float = Field(
        200.0, gt=0.0, description="Usable battery energy, watt-hours. Default 200 (about 24 V x 8 Ah)."
    )
    hotel_power_w: float = Field(
        15.0, ge=0.0, description="Electronics, sensors and radio, watts, on top of driving. Default 15."
    )
    reserve_fraction: float = Field(
        0.15,
        ge=0.0,
        lt=1.0,
        description="State of charge at which a robot stops its task and heads back to sea. Default 0.15.",
    )


class Comms(_Model):
    """Communications losses."""

    cutoff_s: float | None = Field(
        None,
        ge=0.0,
        description="Mission time at which all radio links are cut (jamming), seconds. Default: never.",
    )
    dropout_per_h: float = Field(
        0.0,
        ge=0.0,
        description="Rate of single robots losing their radio for good, per hour: such a robot is alive "
        "but cut off, and counted lost. Default 0.",
    )
    isolation_limit_s: float | None = Field(
        None,
        gt=0.0,
        description="A robot with no radio link to any other robot or the source for this long is counted "
        "lost, cut off from the network, seconds. Default: never.",
    )
    shadowing_sigma_db: float = Field(
        6.0,
        ge=0.0,
        le=20.0,
        description="Log-normal shadowing of every link, dB (standard deviation). Default 6 (open ground).",
    )
    decorrelation_m: float = Field(
        20.0,
        gt=0.0,
        description="Distance over which a link's shadowing decorrelates as its ends move, metres "
        "(Gudmundson 1991). Default 20.",
    )


class Hazards(_Model):
    """What the simulator draws losses from. Every section and key has a default."""

    enabled: bool = Field(
        True,
        description="false turns every hazard off (failure, waves, immobilization, rocks, mines, battery, "
        "radio, sea and surf time limits), to see what a plan achieves with no losses. The planned "
        "clearance still expends its markers. Default true.",
    )
    attrition: Attrition = Field(default_factory=Attrition)
    surf: SurfHazard = Field(default_factory=SurfHazard)
    immobilization: Immobilization = Field(default_factory=Immobilization)
    rocks: Rocks = Field(default_factory=Rocks)
    mines: Mines = Field(default_factory=Mines)
    battery: Battery = Field(default_factory=Battery)
    comms: Comms = Field(default_factory=Comms)


# --- the mission ------------------------------------------------------------------------------------


class Mission(_Model):
    """A surf-swarm mission: map, planner profile, robot type, swarm, launch, phases, tasks,
    success criteria and hazards. Paths are relative to the mission file."""

    name: str | None = Field(
        None, min_length=1, description="The mission's name. Default: the file name without .yaml."
    )
    description: str = Field("", description="What the mission is for, in a sentence or two.")
    map: str = Field(min_length=1, description="Map YAML (maps/NAME.yaml), relative to the mission file.")
    planner: str | None = Field(
        None,
        min_length=1,
        description="Planner profile YAML (planners/NAME.yaml), relative to the mission file. "
        "Default: the built-in profile, the same as planners/fast.yaml.",
    )
    robot: RobotSpec = Field(default_factory=RobotSpec)
    swarm: SwarmSpec = Field(description="The swarm: {count: N} robots.")
    launch: Launch = Field(default_factory=Launch)
    phases: Phases = Field(default_factory=Phases)
    tasks: list[Task] = Field(min_length=1, description="What the swarm does on the beach.")
    success: Success = Field(default_factory=Success)
    hazards: Hazards = Field(default_factory=Hazards)
    seed: int = Field(
        0,
        ge=0,
        le=2**64 - 1,
        description="Random seed: the same seed gives the same plan and run. Default 0.",
    )

    # set by swarm.mission.load: where the file was, and what its references resolved to
    _source: str | None = PrivateAttr(None)
    _resolved: dict[str, Any] = PrivateAttr(default_factory=dict)

    @model_validator(mode="after")
    def _name_is_a_file_name(self) -> Mission:
        # the default output folders are reports/<name>-...: a name with a separator would write
        # them elsewhere
        name = self.name
        if name is not None and (any(c in "/\\" or ord(c) < 32 for c in name) or name.strip() != name):
            raise _expected(
                "a name usable as a file name (no / or \\, control characters, or spaces at the ends)",
                found=name,
                key="name",
            )
        return self

    @property
    def source(self) -> str | None:
        """The mission file this came from (None if built in code)."""
        return self._source

    def task_label(self, index: int) -> str:
        """A task's name, or TYPE_INDEX (index counts from 1 among tasks of that type)."""
        task = self.tasks[index]
        if task.name:
            return task.name
        same = [i for i, t in enumerate(self.tasks) if t.type == task.type]
        return f"{task.type}_{same.index(index) + 1}"

    @property
    def beach_end_s(self) -> float:
        """Latest mission time (from the first release) beach operations can run to: the sea
        transit's and the surf crossing's limits, then beach operations'. A beach launch has
        neither phase: its robots start ashore, and its beach operations run from 0."""
        p = self.phases
        if self.launch.platform == "beach":
            return p.beach_operations.time_limit_s
        return p.sea_transit.time_limit_s + p.surf_crossing.time_limit_s + p.beach_operations.time_limit_s

    def tasks_of(self, task_type: str) -> list:
        return [t for t in self.tasks if t.type == task_type]

    @property
    def judged_by(self) -> list[str]:
        """The success criteria a run is judged by (`swarm.sim.criteria`): each applies only
        when the mission has its task, robots recovered only when some are asked for."""
        applies = {
            "landing": any(t.zones for t in self.tasks_of("landing")),
            "detection": bool(self.tasks_of("search")),
            "relay": bool(self.tasks_of("relay")),
            "surveillance": bool(self.tasks_of("surveillance")),
            "beacon": bool(self.tasks_of("beacon")),
            "recovered": self.success.min_robots_recovered > 0,
        }
        return [c for c, on in applies.items() if on]

    # what `load_mission` resolved and loaded (paths, map, terrain library, robot, planner profile)
    def resolved(self, what: str) -> Any:
        """One of 'map_path', 'planner_path', 'robot_path', 'terrain_path', 'beach_map',
        'terrain_library', 'robot_params', 'planner_profile': set by `load_mission`."""
        if what not in self._resolved:
            raise KeyError(
                f"{what!r} is set by swarm.mission.load_mission; this mission was not loaded by it"
            )
        return self._resolved[what]

    @property
    def beach_map(self):
        """The map (`swarm.world.BeachMap`), loaded and checked by `load_mission`."""
        return self.resolved("beach_map")

    @property
    def terrain_library(self):
        """Bundled terrain modes merged with robot.terrain (`swarm.robot.terrain.TerrainLibrary`)."""
        return self.resolved("terrain_library")

    @property
    def robot_params(self):
        """The robot (`swarm.robot.params.RobotParams`)."""
        return self.resolved("robot_params")

    @property
    def planner_profile(self):
        """The planner profile (`swarm.planning.PlannerProfile`)."""
        return self.resolved("planner_profile")


def mission_json_schema() -> dict:
    """The mission JSON Schema (draft 2020-12), for editors and `swarm schema`."""
    schema = Mission.model_json_schema()
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        **schema,
        "title": "surf-swarm mission",
    }
