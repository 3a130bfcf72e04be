"""Loading a mission file: YAML, overrides, schema validation, then its references, with errors of
one line each (`InputError`: file, key path, what was found, what was expected).

```python
mission = load_mission("missions/landing.yaml")
mission = load_mission("missions/landing.yaml", {"swarm.count": 20, "hazards.surf.wave_height_m": 1.5})
```

1. The YAML is read (duplicate keys are errors; `2.4e9` is a number, as in YAML 1.2).
2. Overrides replace values at dotted key paths (`swarm.count`, `tasks.0.sensor.sweep_width_m`)
   before validation; a path must name a key of the schema (`apply_overrides`). The simulator and
   the studies use the same paths.
3. The schema (`swarm.mission.schema`) checks keys, types, units and ranges; the first problem is
   reported, e.g. `missions/x.yaml: tasks[1].sensor.sweep_width_m: found -2, expected a number in
   metres > 0`.
4. References: the robot YAML, the terrain YAML, the map and the planner profile must exist
   (relative to the mission file) and load; every region a mission names must exist in the map
   with the right kind; points must lie in the map (in the water for a sea launch, on passable
   ground for tasks); and the parts must agree (a clearance before beach operations end, enough
   robots for each task, a release point the robots can swim from in time, a dwell or hold robots
   placed on the beach can drive to in time).

The loaded `Mission` carries what it resolved: `mission.beach_map`, `mission.terrain_library`,
`mission.robot_params`, `mission.planner_profile`, `mission.resolved("map_path")`.
"""

from __future__ import annotations

import copy
import math
import os
import re
from collections.abc import Mapping, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

from pydantic import ValidationError
from shapely.geometry import Point

from swarm.errors import Infeasible, InputError
from swarm.files import read_yaml
from swarm.inputs import ABSENT, Parts, child_at, describe, first_error, key_path, kind_of, model_keys
from swarm.mission.schema import (
    TASK_CLASSES,
    Mission,
    SearchTask,
)

#: A robot watches an observation point or holds a beacon within this distance (m): the simulator's
#: `swarm.sim.criteria.STATION_RADIUS_M` (the mission layer sits above the simulator).
STATION_RADIUS_M = 3.0


# --- YAML ---------------------------------------------------------------------------------------------


def read_mission_yaml(path: str | Path) -> dict:
    """The mission file's YAML as a mapping (not yet validated)."""
    path = Path(path)
    data = read_yaml(path, "mission YAML file")
    if not isinstance(data, dict):
        found = "an empty file" if data is None else type(data).__name__
        raise InputError(path, "(top level)", found, "a mapping of mission keys (map, swarm, tasks, ...)")
    return data


# --- overrides ------------------------------------------------------------------------------------------


def _split(key: str) -> list[str]:
    """A key path's parts: `tasks.1.robots`, or `tasks[1].robots` as validation errors name it."""
    return re.sub(r"\[(\d+)\]", r".\1", key).split(".")


def apply_overrides(
    raw: Mapping[str, Any], overrides: Mapping[str, object], source: str | Path = "overrides"
) -> dict:
    """A copy of the mission mapping `raw` with each dotted key path in `overrides` set to its value.

    Paths follow the schema: `swarm.count`, `hazards.surf.wave_height_m`,
    `tasks.0.sensor.sweep_width_m` (list items by index, also written `tasks[0]` as errors name
    them; a task's keys are those of its type).
    Sections the file leaves out are created (`hazards.mines.count` on a mission without hazards);
    a key the schema does not have, an index past the end of a list, or a path into a value is an
    `InputError(source, KEY_PATH, found, expected)` naming the key. Values are not checked here:
    validation does that, and reports an overridden value against `source`.
    """
    out = copy.deepcopy(dict(raw))
    for path, value in overrides.items():
        if not isinstance(path, str) or not path:
            raise InputError(source, str(path), path, "a dotted key path of the mission, e.g. swarm.count")
        parts = _split(path)
        node: Any = out
        ann: Any = Mission
        for i, part in enumerate(parts):
            last = i == len(parts) - 1
            kind, inner = kind_of(ann)
            here = ".".join(parts[:i]) or "the mission"
            if kind == "tagged":  # a task: its keys are those of its type
                tag = node.get("type") if isinstance(node, dict) else None
                if tag not in TASK_CLASSES:
                    raise InputError(
                        source,
                        path,
                        tag,
                        f"a task with a valid type at {here} (one of {', '.join(TASK_CLASSES)})",
                    )
                kind, inner = "model", TASK_CLASSES[tag]
            if kind == "model":
                if part not in inner.model_fields:
                    raise InputError(source, path, part, f"a key of {here} (known keys: {model_keys(inner)})")
                ann, key = inner.model_fields[part].annotation, part
            elif kind == "dict":
                ann, key = inner, part
            elif kind == "list":
                size = len(node) if isinstance(node, list) else 0
                if not part.isdigit() or int(part) >= size:
                    span = f"0..{size - 1}" if size else "none: the list is empty"
                    raise InputError(source, path, part, f"an index of an item of {here} ({span})")
                ann, key = inner, int(part)
            else:  # pragma: no cover - a leaf is refused one step earlier
                raise InputError(source, path, part, f"a path ending at {here} (it holds a value, not keys)")
            if last:
                node[key] = copy.deepcopy(value)
                break
            child = child_at(node, key)
            next_kind = kind_of(ann)[0]
            inside = f"{here}.{part}" if i else part
            if next_kind == "leaf":
                raise InputError(
                    source, path, parts[i + 1], f"a path ending at {inside} (it holds a value, not keys)"
                )
            if child is ABSENT or child is None:
                if next_kind == "list":
                    raise InputError(
                        source, path, parts[i + 1], f"an index of an item of {inside} (the mission has none)"
                    )
                child = node[key] = {}
            elif not isinstance(child, dict | list):
                raise InputError(source, path, child, f"a mapping at {here}.{part} in the mission")
            node = child
    return out


def value_at(mission: Mission, path: str) -> object:
    """The value at a dotted key path (as `apply_overrides` takes) of a validated mission: what the
    schema made of the value given there (`swarm.count` 10.0 is the integer 10)."""
    node: Any = mission
    for part in _split(path):
        if isinstance(node, Mapping):
            node = node[part]
        elif isinstance(node, list | tuple):
            node = node[int(part)]
        else:
            node = getattr(node, part)
    return node


# --- validation and references --------------------------------------------------------------------------


class _Report:
    """Raises InputError against the mission file, or against the overrides for overridden keys."""

    def __init__(self, source: str, overrides: Mapping[str, object], overrides_source: str) -> None:
        self.source = source
        self.overrides = dict(overrides)
        self.override_paths = [_split(k) for k in overrides]
        self.overrides_source = overrides_source

    def error(self, parts: Sequence[str | int], found: object, expected: str) -> InputError:
        """An error in an overridden key blames the override; one elsewhere still names the
        overrides, which may be what made the file's own value wrong (a smaller swarm.count)."""
        text = [str(p) for p in parts]
        overridden = any(text[: len(o)] == o for o in self.override_paths)
        source = self.source
        if overridden:
            source = f"{self.overrides_source} (over {self.source})"
        elif self.overrides:
            given = ", ".join(f"{k}={v}" for k, v in self.overrides.items())
            source = f"{self.source} (with {self.overrides_source} {given})"
        return InputError(source, key_path(parts), found, expected)

    def infeasible(self, parts: Sequence[str | int], found: object, expected: str) -> Infeasible:
        """`error` for values that are each valid but do not fit together (`Infeasible`)."""
        e = self.error(parts, found, expected)
        return Infeasible(e.source, e.where, e.found, e.expected)


def _display(path: Path) -> str:
    return os.path.normpath(path)


def _bundled(kind: str) -> Path:
    return Path(str(resources.files("swarm") / "data" / kind))


def _resolve(value: str, base_dir: Path, bundled: str | None = None) -> Path:
    """A path relative to the mission file, or a bundled data file named without suffix or folder."""
    p = Path(value)
    if bundled is not None and len(p.parts) == 1 and p.suffix not in (".yaml", ".yml"):
        return _bundled(bundled) / f"{value}.yaml"
    return Path(_display(p if p.is_absolute() else base_dir / p))


def _need_file(report: _Report, parts: Parts, value: str, path: Path, what: str, bundled: str | None) -> None:
    if path.is_file():
        return
    if bundled is not None and len(Path(value).parts) == 1 and Path(value).suffix not in (".yaml", ".yml"):
        names = ", ".join(sorted(p.stem for p in _bundled(bundled).glob("*.yaml")))
        expected = f"a bundled {what} ({names}) or the path of a {what} relative to the mission file"
    elif path.is_dir():
        expected = f"a {what}, not a folder ({_display(path)} is one)"
    else:
        expected = (
            f"an existing {what} ({_display(path)} does not exist; paths are relative to the mission file)"
        )
    raise report.error(parts, value, expected)


class _References:
    def __init__(self, mission: Mission, report: _Report, base_dir: Path) -> None:
        from swarm.planning.profiles import DEFAULT_PROFILE, load_profile
        from swarm.robot.params import load_robot
        from swarm.robot.terrain import load_library
        from swarm.world.io import load_map

        self.mission, self.report = mission, report
        r: dict[str, Any] = {}
        r["robot_path"] = _resolve(mission.robot.file, base_dir, "robots")
        _need_file(report, ["robot", "file"], mission.robot.file, r["robot_path"], "robot YAML", "robots")
        r["terrain_path"] = None
        if mission.robot.terrain is not None:
            r["terrain_path"] = _resolve(mission.robot.terrain, base_dir, "terrain")
            _need_file(
                report,
                ["robot", "terrain"],
                mission.robot.terrain,
                r["terrain_path"],
                "terrain YAML",
                "terrain",
            )
        r["map_path"] = _resolve(mission.map, base_dir)
        _need_file(report, ["map"], mission.map, r["map_path"], "map YAML", None)
        r["planner_path"] = None
        if mission.planner is not None:
            r["planner_path"] = _resolve(mission.planner, base_dir)
            _need_file(report, ["planner"], mission.planner, r["planner_path"], "planner profile YAML", None)

        r["robot_params"] = load_robot(r["robot_path"])
        r["terrain_library"] = load_library(r["terrain_path"])
        r["beach_map"] = load_map(r["map_path"], r["terrain_library"])
        r["planner_profile"] = load_profile(r["planner_path"]) if r["planner_path"] else DEFAULT_PROFILE
        self.resolved = r
        self.map = r["beach_map"]
        self.library = r["terrain_library"]
        self.map_name = _display(r["map_path"])

    # one reference -------------------------------------------------------------------------------
    def place(
        self,
        parts: Parts,
        value: str | tuple[float, float],
        kinds: tuple[str, ...],
        ground: str | None = None,
        why: str = "",
        points_ok: bool = True,
    ):
        """Check a region name (of one of `kinds`) or a point; `ground`: 'water', 'land' or None."""
        bm = self.map
        kind_words = " or ".join(kinds)
        if isinstance(value, str):
            region = bm.regions.get(value)
            if region is None or region.kind not in kinds:
                names = sorted(r.name for r in bm.regions.values() if r.kind in kinds)
                instead = "; give [x, y] in metres instead" if points_ok else ""
                listed = f"({', '.join(names)})" if names else f"(it has none{instead})"
                expected = f"a {kind_words} region of {self.map_name} {listed}"
                if region is not None:
                    expected += f"; '{value}' is a {region.kind} region"
                raise self.report.error(parts, value, expected)
            geom = region.geometry
            point = geom if geom.geom_type == "Point" else geom.representative_point()
            x, y = point.x, point.y
            found: object = value
        else:
            x, y = value
            found = [x, y]
            xmin, ymin, xmax, ymax = bm.bounds_m
            if not bool(bm.contains(x, y)):
                raise self.report.error(
                    parts,
                    found,
                    f"a point inside {self.map_name} (x {xmin:g}..{xmax:g}, y {ymin:g}..{ymax:g} m)",
                )
        if ground is not None:
            mode_name = bm.terrain_classes[int(bm.terrain_at(x, y))]
            mode = self.library[mode_name]
            if ground == "water" and not mode.is_water:
                raise self.report.error(parts, found, f"a point in the water{why}; it is on {mode_name}")
            if ground == "land" and (mode.is_water or not mode.passable):
                raise self.report.error(
                    parts, found, f"a point on passable dry ground{why}; it is on {mode_name}"
                )
        if ground == "land":  # no robot may drive there: the planner would quietly move the point
            here = Point(x, y)
            for r in bm.regions.values():
                if r.kind == "keep_out" and r.geometry.covers(here):
                    raise self.report.error(
                        parts, found, f"a point outside the map's keep_out regions{why}; it is in {r.name}"
                    )
        return x, y

    def region(self, parts: Parts, name: str, kinds: tuple[str, ...]) -> None:
        self.place(parts, name, kinds, points_ok=False)

    # the whole mission --------------------------------------------------------------------------------
    def check(self) -> None:
        m, err = self.mission, self.report.error
        count = m.swarm.count
        beach_limit = m.phases.beach_operations.time_limit_s

        # launch
        launch = m.launch
        sea = launch.platform != "beach"
        if not sea and launch.offshore_m not in (None, 0.0):
            raise err(["launch", "offshore_m"], launch.offshore_m, "0 (or no value) for platform 'beach'")
        ground = "water" if sea else "land"
        why = f" for platform '{launch.platform}'"
        if launch.points is None:
            if not sea:
                raise err(
                    ["launch", "points"],
                    "nothing",
                    "points on the beach, [x, y] in metres, for platform 'beach'",
                )
            if not self.map.regions_of_kind("launch"):
                raise err(
                    ["launch", "points"], "nothing", f"launch points: {self.map_name} has no launch region"
                )
            for region in self.map.regions_of_kind("launch"):
                self.place(["launch", "points"], region.name, ("launch",), ground, why)
        for i, p in enumerate(launch.points or []):
            self.place(["launch", "points", i], p, ("launch",), ground, why)
        reach_m = m.phases.sea_transit.time_limit_s * m.robot.swim_speed_mps
        if sea and launch.release_offshore_m > reach_m:
            raise self.report.infeasible(
                ["launch", "offshore_m"] if launch.offshore_m is not None else ["launch", "platform"],
                launch.offshore_m if launch.offshore_m is not None else launch.platform,
                f"a release point the robots can swim from in time: at most {reach_m:g} m offshore "
                f"(phases.sea_transit.time_limit_s {m.phases.sea_transit.time_limit_s:g} s at "
                f"robot.swim_speed_mps {m.robot.swim_speed_mps:g}); platform '{launch.platform}' releases "
                f"{launch.release_offshore_m:g} m out",
            )
        back = m.phases.return_to_sea
        for i, p in enumerate(back.points or []):
            self.place(
                ["phases", "return_to_sea", "points", i], p, ("launch",), "water", " (a pick-up point)"
            )

        # tasks
        held = _stations(m)
        names: dict[str, int] = {}
        for t, task in enumerate(m.tasks):
            at: Parts = ["tasks", t]
            label = m.task_label(t)
            if label in names:
                raise err([*at, "name"], label, f"a name no other task has (tasks[{names[label]}] has it)")
            names[label] = t
            if task.type == "landing":
                for i, zone in enumerate(task.zones):
                    self.region([*at, "zones", i], zone, ("landing_zone",))
                    if task.zones.index(zone) != i:
                        raise err([*at, "zones", i], zone, "each landing zone once")
                self._robots([*at, "robots_per_zone"], t, held, count)
            elif task.type == "search":
                self._search(at, task, count, m.beach_end_s)
            elif task.type == "relay":
                self.place([*at, "source"], task.source, ("relay_source",))
                for i, sink in enumerate(task.sinks):
                    self.place([*at, "sinks", i], sink, ("relay_sink",), "land", " (a relay sink)")
            elif task.type == "surveillance":
                xy = [
                    self.place(
                        [*at, "points", i], point, ("observation_point",), "land", " (an observation point)"
                    )
                    for i, point in enumerate(task.points)
                ]
                self._robots([*at, "robots_per_point"], t, held, count)
                if task.dwell_s > beach_limit:
                    raise self.report.infeasible(
                        [*at, "dwell_s"],
                        task.dwell_s,
                        f"at most phases.beach_operations.time_limit_s ({beach_limit:g} s)",
                    )
                self._time_at(at, "dwell_s", task.dwell_s, task.points, xy)
            elif task.type == "beacon":
                xy = [
                    self.place([*at, "points", i], point, ("beacon",), "land", " (a beacon)")
                    for i, point in enumerate(task.points)
                ]
                self._robots([*at, "robots_per_point"], t, held, count)
                if task.hold_s is not None and task.hold_s > beach_limit:
                    raise self.report.infeasible(
                        [*at, "hold_s"],
                        task.hold_s,
                        f"at most phases.beach_operations.time_limit_s ({beach_limit:g} s)",
                    )
                if task.hold_s is not None:
                    self._time_at(at, "hold_s", task.hold_s, task.points, xy)

        # every station at once: each task fits alone (above), and together they must too
        if _total(held) > count:
            raise self.report.infeasible(
                ["swarm", "count"],
                count,
                f"at least {_total(held)}, the robots the stations hold together ({_each(held)})",
            )

        # hazards
        hz = m.hazards
        for mode in hz.immobilization.mode_factors:
            if mode not in self.library:
                raise err(
                    ["hazards", "immobilization", "mode_factors", mode],
                    mode,
                    f"a terrain mode, one of {', '.join(sorted(self.library))}",
                )
        mines = hz.mines
        if mines.area is not None:
            self.region(["hazards", "mines", "area"], mines.area, ("search_area", "landing_zone", "keep_out"))
        elif (mines.count or mines.density_per_ha) and not m.tasks_of("search"):
            raise err(
                ["hazards", "mines", "area"],
                "nothing",
                "a region to lay the mines in (by default the search areas; this mission has none)",
            )

        # success
        rec = m.success.min_robots_recovered
        if rec > count:
            raise self.report.infeasible(
                ["success", "min_robots_recovered"], rec, f"at most swarm.count ({count})"
            )
        if rec > 0 and not back.enabled:
            raise err(
                ["success", "min_robots_recovered"], rec, "0 when phases.return_to_sea.enabled is false"
            )

    def _time_at(self, at: Parts, key: str, required_s: float, names: Sequence, xy: list) -> None:
        """A beach launch's robots start ashore when beach operations start, and no robot drives
        faster than its wheels turn: a point farther from every launch point than its station
        radius leaves at most the time limit less that straight drive for its dwell or hold. (A
        sea launch's way in is the plan's to judge: `swarm.mission.plan`'s station times.) recon
        at a 1800 s limit passed with a 1800 s dwell, and none of its runs could succeed."""
        m = self.mission
        if m.launch.platform != "beach" or not m.launch.points:
            return
        limit = m.phases.beach_operations.time_limit_s
        v = m.robot.wheel_speed_mps
        launches = [
            self.place(["launch", "points", i], p, ("launch",)) for i, p in enumerate(m.launch.points)
        ]
        for name, (x, y) in zip(names, xy, strict=True):
            near = min(math.hypot(x - lx, y - ly) for lx, ly in launches)
            drive_s = max(near - STATION_RADIUS_M, 0.0) / v
            if required_s > limit - drive_s:
                where = name if isinstance(name, str) else f"[{x:g}, {y:g}]"
                raise self.report.infeasible(
                    [*at, key],
                    required_s,
                    f"at most {math.floor(limit - drive_s):d} s: phases.beach_operations.time_limit_s "
                    f"({limit:g} s) less the {math.ceil(drive_s):d} s drive from the nearest launch point "
                    f"to within {STATION_RADIUS_M:g} m of {where} "
                    f"({near:.0f} m at robot.wheel_speed_mps {v:g})",
                )

    def _robots(self, parts: Parts, t: int, held: dict, count: int) -> None:
        """Task `t`'s stations alone within the swarm. When one robot a point would fit beside
        the other stations, its robots per point are too many; when not even that, the swarm is
        too small, said with what every station holds (recon at 2 robots was told
        'tasks[1].robots_per_point: found 1, expected at most 0')."""
        n, per, what = held[t]
        if per * n <= count:
            return
        others = _total(held) - per * n
        if count - others < n:
            raise self.report.infeasible(
                ["swarm", "count"],
                count,
                f"at least {_total(held)}, the robots the stations hold together ({_each(held)})",
            )
        besides = f" less the {others} the other stations hold" if others else ""
        raise self.report.infeasible(
            parts,
            per,
            f"at most {(count - others) // n}: {_plural(n, what)} x {per} robots is {per * n}, more than "
            f"swarm.count ({count}){besides}",
        )

    def _search(self, at: Parts, task: SearchTask, count: int, beach_end_s: float) -> None:
        err = self.report.error
        self.region([*at, "area"], task.area, ("search_area",))
        if task.robots is not None and task.robots > count:
            raise self.report.infeasible([*at, "robots"], task.robots, f"at most swarm.count ({count})")
        if task.clearance is not None:
            if not task.mark:
                raise err(
                    [*at, "mark"],
                    task.mark,
                    "true with a clearance (the robots loitering on the marked mines set them off)",
                )
            if task.clearance.at_s > beach_end_s:
                raise self.report.infeasible(
                    [*at, "clearance", "at_s"],
                    task.clearance.at_s,
                    f"a time before beach operations end, at most {beach_end_s:g} s (the sum of the "
                    "sea_transit, surf_crossing and beach_operations time limits; a beach launch's "
                    "beach_operations alone)",
                )


def _stations(m: Mission) -> dict[int, tuple[int, int, str]]:
    """Each station task's (points, robots per point, what a point is), by task index."""
    out = {}
    for t, task in enumerate(m.tasks):
        if task.type == "landing":
            out[t] = (len(task.zones), task.robots_per_zone, "zone")
        elif task.type in ("surveillance", "beacon"):
            out[t] = (len(task.points), task.robots_per_point, "point")
    return out


def _total(held: dict[int, tuple[int, int, str]]) -> int:
    return sum(n * per for n, per, _ in held.values())


def _each(held: dict[int, tuple[int, int, str]]) -> str:
    """'tasks[0] 2 (1 point x 2), tasks[1] 3 (3 points x 1)'."""
    return ", ".join(
        f"tasks[{t}] {n * per} ({_plural(n, what)} x {per})" for t, (n, per, what) in held.items()
    )


def _plural(n: int, noun: str) -> str:
    return f"{n} {noun}{'' if n == 1 else 's'}"


def mission_from_dict(
    raw: Mapping[str, Any],
    source: str | Path = "<mission>",
    base_dir: str | Path | None = None,
    overrides: Mapping[str, object] | None = None,
    overrides_source: str = "overrides",
    check_references: bool = True,
) -> Mission:
    """Validate a mission mapping (as read from YAML); `base_dir` is where its paths are relative to
    (default: the folder of `source`). See `load_mission`."""
    source = str(source)
    overrides = dict(overrides or {})
    report = _Report(source, overrides, overrides_source)
    data = apply_overrides(raw, overrides, overrides_source) if overrides else dict(raw)
    try:
        mission = Mission.model_validate(data)
    except ValidationError as exc:
        parts, found, expected = describe(first_error(exc, data, Mission), data, Mission, "a task type")
        raise report.error(parts, found, expected) from None
    if mission.name is None:
        mission = mission.model_copy(update={"name": Path(source).stem})
    mission._source = source
    if check_references:
        base = Path(base_dir) if base_dir is not None else Path(source).parent
        refs = _References(mission, report, base)
        refs.check()
        mission._resolved = refs.resolved
    return mission


def load_mission(
    path: str | Path,
    overrides: Mapping[str, object] | None = None,
    overrides_source: str = "overrides",
) -> Mission:
    """Read, override, validate and check a mission file; bad input raises one `InputError`:
    `missions/x.yaml: tasks[1].sensor.sweep_width_m: found -2, expected a number in metres > 0`.
    Errors in an overridden key name `overrides_source` (e.g. "--set" or a study file) instead."""
    raw = read_mission_yaml(path)
    return mission_from_dict(raw, path, overrides=overrides, overrides_source=overrides_source)
