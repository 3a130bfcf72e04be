"""Mission files: the shipped missions, the JSON Schema, one-line errors for each kind of mistake,
reference checks against the map, and overrides by dotted key path."""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import pytest
import yaml

from swarm.errors import InputError
from swarm.mission import (
    PLATFORM_OFFSHORE_M,
    TASK_TYPES,
    Mission,
    apply_overrides,
    load_mission,
    mission_from_dict,
    mission_json_schema,
    read_mission_yaml,
)
from swarm.mission.schema import LateralRange, Sensor
from swarm.world.beachmap import BeachMap

REPO = Path(__file__).resolve().parents[2]
MISSIONS = sorted((REPO / "missions").glob("*.yaml"))
SHIPPED = ("full_conops", "landing", "mine_clear", "recon", "relay")


def small_mission() -> dict:
    """A valid mission on test_small, as a mapping; paths relative to missions/ in the repository."""
    return {
        "map": "../maps/test_small.yaml",
        "planner": "../planners/fast.yaml",
        "swarm": {"count": 12},
        "launch": {"platform": "by_hand", "points": ["launch_1"]},
        "tasks": [
            {"type": "landing", "zones": ["landing_a", "landing_b"], "robots_per_zone": 2},
            {"type": "search", "area": "search_beach", "sensor": {"sweep_width_m": 2.0}},
        ],
    }


def error_of(raw: dict, monkeypatch, **kwargs) -> InputError:
    """The InputError for `raw` read as missions/x.yaml of the repository (cwd: the repository)."""
    monkeypatch.chdir(REPO)
    with pytest.raises(InputError) as info:
        mission_from_dict(raw, "missions/x.yaml", **kwargs)
    err = info.value
    assert "\n" not in str(err)
    return err


def assert_line(err: InputError, where: str, found: object, expected: str) -> None:
    """The one line names the file, the key path, what was found and what was expected."""
    line = str(err)
    assert line.startswith(f"{err.source}: {where}: found {found!r}, expected "), line
    assert "missions/x.yaml" in err.source
    assert err.where == where
    assert err.found == found
    assert expected in err.expected, line


# --- the shipped missions ----------------------------------------------------------------------------


def test_the_five_missions_are_shipped():
    assert tuple(p.stem for p in MISSIONS) == SHIPPED


@pytest.mark.parametrize("path", MISSIONS, ids=lambda p: p.stem)
def test_shipped_mission_loads(path):
    mission = load_mission(path)
    assert mission.name == path.stem
    assert mission.source == str(path)
    assert isinstance(mission.beach_map, BeachMap)
    # robots enough for every task's fixed demand (the rest search, wait in reserve or stand by)
    fixed = sum(
        t.robots_per_zone * len(t.zones) if t.type == "landing"
        else t.robots_per_point * len(t.points) if t.type in ("surveillance", "beacon")
        else (t.robots or 1) if t.type == "search" else 1
        for t in mission.tasks
    )  # fmt: skip
    assert mission.swarm.count >= fixed
    assert mission.tasks
    assert mission.resolved("map_path").is_file()
    assert mission.robot_params.mass_kg > 0
    assert mission.planner_profile.planner
    assert "deep_water" in mission.terrain_library


def test_shipped_missions_cover_every_task_type_platform_and_map():
    missions = [load_mission(p) for p in MISSIONS]
    assert {t.type for m in missions for t in m.tasks} == set(TASK_TYPES)
    full = load_mission(REPO / "missions" / "full_conops.yaml")
    assert [t.type for t in full.tasks] == list(TASK_TYPES)
    assert {m.beach_map.name for m in missions} == {"gentle_fine", "steep_coarse_river", "test_small"}
    by_name = {m.name: m for m in missions}
    assert by_name["mine_clear"].beach_map.name == "gentle_fine"
    assert by_name["relay"].tasks[0].redundancy == 2
    assert len({m.launch.platform for m in missions}) >= 4


def test_yaml_exponent_floats_are_numbers():
    """`915e6` is a string to YAML 1.1 (PyYAML) but a number to YAML 1.2 and to editors: a number here."""
    relay = load_mission(REPO / "missions" / "relay.yaml")
    assert relay.tasks[0].radio.frequency_hz == 2.4e9


def test_defaults_fill_what_a_file_leaves_out(monkeypatch):
    monkeypatch.chdir(REPO)
    m = mission_from_dict(small_mission(), "missions/x.yaml")
    assert m.name == "x"
    assert m.launch.release_offshore_m == PLATFORM_OFFSHORE_M["by_hand"] == 100.0
    assert m.hazards.attrition.mtbf_h == 10.0
    assert m.hazards.surf.wave_height_m == 1.0
    assert m.hazards.battery.capacity_wh == 200.0
    assert m.hazards.mines.count is None
    assert m.success.min_detection_fraction == 0.8
    assert m.beach_end_s == 3600 + 900 + 3600  # the defaults' sea transit, surf crossing, beach
    search = m.tasks[1]
    assert search.sensor.model == "inverse_cube"
    assert search.spacing_m == 2.0  # the sweep width
    assert search.expected_detection == pytest.approx(math.erf(math.sqrt(math.pi) / 2))
    assert [m.task_label(i) for i in range(2)] == ["landing_1", "search_1"]
    assert m.robot.file == "skid4"
    assert m.planner_profile.name == "fast"


def test_detection_models_and_lateral_range_curve():
    curve = LateralRange(range_m=[0.0, 1.0, 2.0], probability=[1.0, 1.0, 0.0])
    assert curve.sweep_width_m == pytest.approx(2 * (1.0 + 0.5))
    for model, expected in (
        ("cookie_cutter", 0.5),
        ("inverse_cube", math.erf(math.sqrt(math.pi) / 4)),
        ("random_search", 1 - math.exp(-0.5)),
    ):
        sensor = Sensor(model=model, sweep_width_m=2.0)
        assert sensor.coverage_probability(4.0) == pytest.approx(expected)
    assert Sensor(model="cookie_cutter", lateral_range=curve).coverage_probability(2.0) == 1.0


# --- the JSON Schema -----------------------------------------------------------------------------------

_ANNOTATIONS = {"title", "description", "default", "discriminator", "$schema", "$defs", "examples"}


def _validate(instance: object, schema: dict | bool, root: dict, at: str = "$") -> list[str]:
    """A small JSON Schema (draft 2020-12) validator for the keywords pydantic emits; any other
    keyword fails the test, so the schema cannot use something this does not check."""
    if schema is True:
        return []
    if schema is False:
        return [f"{at}: not allowed"]
    unknown = set(schema) - _ANNOTATIONS - {
        "$ref", "anyOf", "oneOf", "type", "enum", "const", "minimum", "maximum", "exclusiveMinimum",
        "exclusiveMaximum", "minLength", "minItems", "maxItems", "items", "prefixItems", "properties",
        "required", "additionalProperties",
    }  # fmt: skip
    assert not unknown, f"schema keyword the test validator does not know: {unknown}"
    errors: list[str] = []
    if "$ref" in schema:
        assert schema["$ref"].startswith("#/$defs/")
        errors += _validate(instance, root["$defs"][schema["$ref"].split("/")[-1]], root, at)
    if "anyOf" in schema and all(_validate(instance, s, root, at) for s in schema["anyOf"]):
        errors.append(f"{at}: matches none of anyOf")
    if "oneOf" in schema and sum(not _validate(instance, s, root, at) for s in schema["oneOf"]) != 1:
        errors.append(f"{at}: does not match exactly one of oneOf")
    types = {
        "object": lambda v: isinstance(v, dict),
        "array": lambda v: isinstance(v, list),
        "string": lambda v: isinstance(v, str),
        "number": lambda v: isinstance(v, int | float) and not isinstance(v, bool),
        "integer": lambda v: isinstance(v, int) and not isinstance(v, bool),
        "boolean": lambda v: isinstance(v, bool),
        "null": lambda v: v is None,
    }
    if "type" in schema and not types[schema["type"]](instance):
        return [*errors, f"{at}: {instance!r} is not of type {schema['type']}"]
    if "enum" in schema and instance not in schema["enum"]:
        errors.append(f"{at}: {instance!r} not in {schema['enum']}")
    if "const" in schema and instance != schema["const"]:
        errors.append(f"{at}: {instance!r} is not {schema['const']!r}")
    if types["number"](instance):
        for key, ok in (
            ("minimum", lambda v, b: v >= b),
            ("maximum", lambda v, b: v <= b),
            ("exclusiveMinimum", lambda v, b: v > b),
            ("exclusiveMaximum", lambda v, b: v < b),
        ):
            if key in schema and not ok(instance, schema[key]):
                errors.append(f"{at}: {instance!r} fails {key} {schema[key]}")
    if isinstance(instance, str) and len(instance) < schema.get("minLength", 0):
        errors.append(f"{at}: too short")
    if isinstance(instance, list):
        if not schema.get("minItems", 0) <= len(instance) <= schema.get("maxItems", math.inf):
            errors.append(f"{at}: wrong number of items")
        prefix = schema.get("prefixItems", [])
        for i, item in enumerate(instance):
            sub = prefix[i] if i < len(prefix) else schema.get("items", True)
            errors += _validate(item, sub, root, f"{at}[{i}]")
    if isinstance(instance, dict):
        props = schema.get("properties", {})
        errors += [f"{at}: missing {k}" for k in schema.get("required", []) if k not in instance]
        for key, value in instance.items():
            sub = props.get(key, schema.get("additionalProperties", True))
            errors += _validate(value, sub, root, f"{at}.{key}")
    return errors


def _subschemas(node: object):
    if isinstance(node, dict):
        yield node
        for value in node.values():
            yield from _subschemas(value)
    elif isinstance(node, list):
        for value in node:
            yield from _subschemas(value)


def test_json_schema_is_well_formed():
    schema = mission_json_schema()
    assert json.loads(json.dumps(schema)) == schema
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    assert schema["type"] == "object"
    assert set(schema["required"]) == {"map", "swarm", "tasks"}
    assert list(schema["properties"]) == list(Mission.model_fields)
    defs = schema["$defs"]
    for sub in _subschemas(schema):
        if "$ref" in sub:
            assert sub["$ref"].removeprefix("#/$defs/") in defs, sub["$ref"]
        if sub.get("type") == "object" and "properties" in sub:
            assert sub["additionalProperties"] is False  # unknown keys are errors in editors too
            for name, prop in sub["properties"].items():
                assert "description" in prop or "$ref" in prop, f"{name} has no description"
    tasks = schema["properties"]["tasks"]["items"]
    assert tasks["discriminator"]["propertyName"] == "type"
    assert sorted(tasks["discriminator"]["mapping"]) == sorted(TASK_TYPES)
    assert len(tasks["oneOf"]) == len(TASK_TYPES)
    width = defs["Sensor"]["properties"]["sweep_width_m"]
    assert {"type": "number", "minimum": 0.1, "maximum": 1000.0} in width["anyOf"]


@pytest.mark.parametrize("path", MISSIONS, ids=lambda p: p.stem)
def test_shipped_missions_validate_against_the_json_schema(path):
    schema = mission_json_schema()
    assert _validate(read_mission_yaml(path), schema, schema) == []


@pytest.mark.parametrize(
    ("path", "value"),
    [
        (("swarm", "colour"), "red"),  # unknown key
        (("hazards", "surf", "wave_height_m"), "1.5 m"),  # unit string
        (("launch", "platform"), "boat"),  # bad enum
        (("tasks", 0, "type"), "landin"),  # bad task type
        (("swarm", "count"), 0),  # out of range
        (("launch", "points", 0), [1.0, 2.0, 3.0]),  # not [x, y]
    ],
)
def test_json_schema_rejects_what_the_loader_rejects(path, value, monkeypatch):
    schema = mission_json_schema()
    raw = small_mission()
    node = raw
    for key in path[:-1]:
        node = node[key] if isinstance(key, int) else node.setdefault(key, {})
    node[path[-1]] = value
    assert _validate(raw, schema, schema)
    error_of(raw, monkeypatch)


# --- one line per mistake --------------------------------------------------------------------------------


def test_unknown_key(monkeypatch):
    raw = small_mission()
    raw["tasks"][1]["sensor"]["sweep_width"] = 3.0
    err = error_of(raw, monkeypatch)
    assert_line(
        err, "tasks[1].sensor.sweep_width", "sweep_width", "no such key (known keys: model, sweep_width_m"
    )


def test_unknown_top_level_key(monkeypatch):
    raw = small_mission()
    raw["robots"] = 12
    assert_line(
        error_of(raw, monkeypatch), "robots", "robots", "no such key (known keys: name, description, map"
    )


def test_wrong_type(monkeypatch):
    raw = small_mission()
    raw["swarm"]["count"] = "twelve"
    assert_line(error_of(raw, monkeypatch), "swarm.count", "twelve", "a whole number")
    raw["swarm"]["count"] = 12.5
    assert_line(error_of(raw, monkeypatch), "swarm.count", 12.5, "a whole number")
    raw = small_mission()
    raw["tasks"][1]["sensor"] = 2.0
    assert_line(error_of(raw, monkeypatch), "tasks[1].sensor", 2.0, "a mapping (keys: model, sweep_width_m")


def test_negative_number(monkeypatch):
    raw = small_mission()
    raw["tasks"][1]["sensor"]["sweep_width_m"] = -2.0
    err = error_of(raw, monkeypatch)
    assert_line(err, "tasks[1].sensor.sweep_width_m", -2.0, "a number in metres >= 0.1")
    assert str(err) == (
        "missions/x.yaml: tasks[1].sensor.sweep_width_m: found -2.0, expected a number in metres >= 0.1"
    )


def test_unit_string(monkeypatch):
    raw = small_mission()
    raw["tasks"][1]["sensor"]["sweep_width_m"] = "5 m"
    err = error_of(raw, monkeypatch)
    assert_line(err, "tasks[1].sensor.sweep_width_m", "5 m", "a number in metres")
    raw = small_mission()
    raw["hazards"] = {"attrition": {"mtbf_h": "12 h"}}
    assert_line(error_of(raw, monkeypatch), "hazards.attrition.mtbf_h", "12 h", "a number in hours")


def test_bad_enum(monkeypatch):
    raw = small_mission()
    raw["tasks"][1]["sensor"]["model"] = "gaussian"
    err = error_of(raw, monkeypatch)
    assert_line(
        err, "tasks[1].sensor.model", "gaussian", "one of 'cookie_cutter', 'inverse_cube', 'random_search'"
    )
    raw = small_mission()
    raw["tasks"][0]["type"] = "landin"
    err = error_of(raw, monkeypatch)
    assert_line(
        err, "tasks[0].type", "landin", "one of 'landing', 'search', 'relay', 'surveillance', 'beacon'"
    )
    raw = small_mission()
    raw["tasks"].append({"type": "relay", "source": "relay_source", "sinks": ["relay_sink"], "redundancy": 3})
    assert_line(error_of(raw, monkeypatch), "tasks[2].redundancy", 3, "one of 1, 2")


def test_missing_required_key(monkeypatch):
    raw = small_mission()
    del raw["tasks"][0]["zones"]
    err = error_of(raw, monkeypatch)
    assert_line(err, "tasks[0].zones", "nothing", "the required key 'zones'")
    raw = small_mission()
    del raw["map"]
    assert_line(error_of(raw, monkeypatch), "map", "nothing", "the required key 'map'")


def test_unknown_region_reference(monkeypatch):
    raw = small_mission()
    raw["tasks"][0]["zones"] = ["landing_a", "landing_z"]
    err = error_of(raw, monkeypatch)
    assert str(err) == (
        "missions/x.yaml: tasks[0].zones[1]: found 'landing_z', expected a landing_zone region of "
        "maps/test_small.yaml (landing_a, landing_b)"
    )


def test_wrong_region_kind(monkeypatch):
    raw = small_mission()
    raw["tasks"][1]["area"] = "landing_a"
    err = error_of(raw, monkeypatch)
    assert_line(
        err, "tasks[1].area", "landing_a", "a search_area region of maps/test_small.yaml (search_beach)"
    )
    assert "'landing_a' is a landing_zone region" in err.expected
    raw = small_mission()
    raw["launch"]["points"] = ["rally"]
    assert_line(
        error_of(raw, monkeypatch), "launch.points[0]", "rally", "a launch region of maps/test_small.yaml"
    )


def test_points_outside_the_map_or_on_the_wrong_ground(monkeypatch):
    raw = small_mission()
    raw["tasks"].append({"type": "beacon", "points": [[500.0, 50.0]]})
    err = error_of(raw, monkeypatch)
    assert_line(err, "tasks[2].points[0]", [500.0, 50.0], "a point inside maps/test_small.yaml (x 0..120")
    raw["tasks"][2]["points"] = [[50.0, 5.0]]
    assert_line(
        error_of(raw, monkeypatch), "tasks[2].points[0]", [50.0, 5.0], "a point on passable dry ground"
    )
    raw = small_mission()
    raw["launch"] = {"platform": "beach"}
    assert_line(error_of(raw, monkeypatch), "launch.points", "nothing", "points on the beach")
    raw["launch"]["points"] = ["launch_1"]
    assert_line(error_of(raw, monkeypatch), "launch.points[0]", "launch_1", "a point on passable dry ground")


def test_a_point_in_a_keep_out_region_is_refused_not_moved(monkeypatch):
    """The planner once moved a beacon inside keep_out_dunes 7.5 m to its edge, without a word."""
    inside = [110.0, 62.0]  # test_small's keep_out_dunes spans x 103-118, y 57-69 there
    raw = small_mission()
    raw["tasks"].append({"type": "beacon", "points": [[40.0, 62.0], inside]})
    err = error_of(raw, monkeypatch)
    assert_line(err, "tasks[2].points[1]", inside, "a point outside the map's keep_out regions (a beacon)")
    assert err.expected.endswith("; it is in keep_out_dunes")
    raw = small_mission()
    raw["launch"] = {"platform": "beach", "points": [inside]}
    assert_line(error_of(raw, monkeypatch), "launch.points[0]", inside, "outside the map's keep_out regions")


@pytest.mark.parametrize("name", ["../../evil", "a/b", "a\\b", " padded", "tab\there"])
def test_a_mission_name_that_is_no_file_name_is_refused(name, monkeypatch):
    """The default output folder is reports/<name>-<time>: '../../evil' wrote two folders up."""
    raw = {**small_mission(), "name": name}
    assert_line(error_of(raw, monkeypatch), "name", name, "a name usable as a file name")


def test_region_kind_the_map_does_not_have(monkeypatch):
    raw = small_mission()
    raw["tasks"].append({"type": "beacon", "points": ["exit"]})
    err = error_of(raw, monkeypatch)
    assert_line(
        err, "tasks[2].points[0]", "exit", "a beacon region of maps/test_small.yaml (it has none; give [x, y]"
    )


def test_missing_map_file(monkeypatch):
    raw = small_mission()
    raw["map"] = "../maps/nowhere.yaml"
    err = error_of(raw, monkeypatch)
    assert_line(err, "map", "../maps/nowhere.yaml", "an existing map YAML (maps/nowhere.yaml does not exist")


def test_a_map_that_is_a_folder_says_so(monkeypatch):
    raw = {**small_mission(), "map": "../maps"}
    assert_line(error_of(raw, monkeypatch), "map", "../maps", "a map YAML, not a folder (maps is one)")


def test_missing_planner_and_robot_files(monkeypatch):
    raw = small_mission()
    raw["planner"] = "../planners/quick.yaml"
    assert_line(
        error_of(raw, monkeypatch), "planner", "../planners/quick.yaml", "an existing planner profile"
    )
    raw = small_mission()
    raw["robot"] = {"file": "skid9"}
    assert_line(error_of(raw, monkeypatch), "robot.file", "skid9", "a bundled robot YAML (skid4)")
    raw["robot"] = {"terrain": "../terrain/none.yaml"}
    assert_line(
        error_of(raw, monkeypatch), "robot.terrain", "../terrain/none.yaml", "an existing terrain YAML"
    )


def test_parts_must_agree(monkeypatch):
    raw = small_mission()
    raw["tasks"][1]["clearance"] = {"at_s": 1e6}
    err = error_of(raw, monkeypatch)
    assert_line(err, "tasks[1].clearance.at_s", 1e6, "a time before beach operations end, at most 8100 s")
    raw["tasks"][1]["clearance"] = {"at_s": 100.0}
    raw["tasks"][1]["mark"] = False
    assert_line(error_of(raw, monkeypatch), "tasks[1].mark", False, "true with a clearance")
    raw = small_mission()
    raw["tasks"][0]["robots_per_zone"] = 7
    assert_line(error_of(raw, monkeypatch), "tasks[0].robots_per_zone", 7, "at most 6")
    raw = small_mission()  # each landing task fits the 12 robots alone (8), not both together (16)
    raw["tasks"][0]["robots_per_zone"] = 4
    raw["tasks"].append({**raw["tasks"][0], "name": "second_wave"})
    err = error_of(raw, monkeypatch)
    together = "at least 16, the robots the stations hold together (tasks[0] 8 (2 zones x 4), tasks[2] 8 ("
    assert_line(err, "swarm.count", 12, together)
    raw = small_mission()
    raw["launch"]["offshore_m"] = 5000.0
    assert_line(error_of(raw, monkeypatch), "launch.offshore_m", 5000.0, "at most 1800 m offshore")
    raw = small_mission()
    raw["hazards"] = {"immobilization": {"mode_factors": {"quicksand": 2.0}}}
    err = error_of(raw, monkeypatch)
    assert_line(err, "hazards.immobilization.mode_factors.quicksand", "quicksand", "a terrain mode, one of")
    raw = small_mission()
    raw["tasks"][1]["sensor"]["lateral_range"] = {"range_m": [0.0, 1.0], "probability": [1.0, 0.0]}
    assert_line(
        error_of(raw, monkeypatch), "tasks[1].sensor", "both", "exactly one of sweep_width_m or lateral_range"
    )


def test_a_swarm_too_small_for_its_stations_says_what_they_hold(monkeypatch):
    """recon at 2 robots was told 'tasks[1].robots_per_point: found 1, expected at most 0': with
    not even a robot for each point beside the other stations, the count is what is short, and the
    line says what each station task holds. Robots per point are blamed only when fewer would fit,
    less what the other stations hold. Both are infeasible, not malformed (a study runs on)."""
    from swarm.errors import Infeasible

    recon = REPO / "missions" / "recon.yaml"
    for count in (1, 2, 4):
        with pytest.raises(Infeasible) as info:
            load_mission(recon, {"swarm.count": count}, overrides_source="--set")
        err = info.value
        assert err.where == "swarm.count" and err.found == count
        assert err.expected == (
            "at least 5, the robots the stations hold together "
            "(tasks[0] 2 (1 point x 2), tasks[1] 3 (3 points x 1))"
        )
    load_mission(recon, {"swarm.count": 5})
    with pytest.raises(Infeasible) as info:
        load_mission(recon, {"swarm.count": 8, "tasks.0.robots_per_point": 10})
    err = info.value
    assert err.where == "tasks[0].robots_per_point" and err.found == 10
    assert err.expected.startswith(
        "at most 5: 1 point x 10 robots is 10, more than swarm.count (8) less the 3"
    )
    load_mission(recon, {"swarm.count": 8, "tasks.0.robots_per_point": 5})


def test_file_errors(tmp_path):
    bad = tmp_path / "dup.yaml"
    bad.write_text("map: a.yaml\nswarm: {count: 3}\nmap: b.yaml\n")
    with pytest.raises(InputError, match=r"dup.yaml: line 3: found 'map', expected each key once"):
        load_mission(bad)
    bad.write_text("- just\n- a list\n")
    with pytest.raises(InputError, match=r"dup.yaml: \(top level\): found 'list', expected a mapping"):
        load_mission(bad)
    with pytest.raises(InputError, match=r"nothing.yaml: \(file\)"):
        load_mission(tmp_path / "nothing.yaml")


def test_a_mission_file_anywhere_resolves_paths_against_itself(tmp_path):
    raw = small_mission()
    raw["map"] = str(REPO / "maps" / "test_small.yaml")  # absolute
    raw["planner"] = None  # the built-in profile
    path = tmp_path / "mine.yaml"
    path.write_text(yaml.safe_dump(raw))
    mission = load_mission(path)
    assert mission.name == "mine"
    assert mission.planner_profile.name == "fast"
    raw["map"] = "test_small.yaml"  # beside the mission: not there
    path.write_text(yaml.safe_dump(raw))
    with pytest.raises(InputError) as info:
        load_mission(path)
    assert info.value.source == str(path)
    assert str(tmp_path / "test_small.yaml") in info.value.expected


# --- overrides ---------------------------------------------------------------------------------------------


def test_overrides_change_the_value():
    path = REPO / "missions" / "mine_clear.yaml"
    before = load_mission(path)
    after = load_mission(
        path,
        {
            "swarm.count": 20,
            "hazards.surf.wave_height_m": 1.5,
            "tasks.0.sensor.sweep_width_m": 4.0,
            "tasks.0.track_spacing_m": 2.5,
            "hazards.comms.cutoff_s": 3000,  # a section the file leaves out
            "phases.return_to_sea.enabled": True,
        },
    )
    assert (before.swarm.count, after.swarm.count) == (24, 20)
    assert (before.hazards.surf.wave_height_m, after.hazards.surf.wave_height_m) == (1.0, 1.5)
    assert after.tasks[0].sensor.sweep_width_m == 4.0
    assert after.tasks[0].sensor.model == before.tasks[0].sensor.model  # the rest stays
    assert after.hazards.comms.cutoff_s == 3000
    assert after.phases.return_to_sea.enabled
    assert after.tasks[0].expected_detection > before.tasks[0].expected_detection


def test_apply_overrides_copies_and_creates_sections():
    raw = small_mission()
    kept = copy.deepcopy(raw)
    out = apply_overrides(raw, {"hazards.mines.count": 5, "tasks.1.robots": 4, "launch.points.0": [10, 5]})
    assert raw == kept
    assert out["hazards"] == {"mines": {"count": 5}}
    assert out["tasks"][1]["robots"] == 4
    assert out["launch"]["points"] == [[10, 5]]
    out = apply_overrides(raw, {"hazards.immobilization.mode_factors.soft_sand": 8.0})
    assert out["hazards"]["immobilization"]["mode_factors"] == {"soft_sand": 8.0}
    # a list item as validation errors name it (`tasks[1].robots`) is the same key
    assert apply_overrides(raw, {"tasks[1].robots": 4, "launch.points[0]": [10, 5]}) == apply_overrides(
        raw, {"tasks.1.robots": 4, "launch.points.0": [10, 5]}
    )


@pytest.mark.parametrize(
    ("key", "found", "expected"),
    [
        ("swarm.cnt", "cnt", "a key of swarm (known keys: count)"),
        ("hazard.surf.wave_height_m", "hazard", "a key of the mission (known keys: name, description, map"),
        ("hazards.surf.wave_heigth_m", "wave_heigth_m", "a key of hazards.surf (known keys: wave_height_m"),
        ("tasks.5.zones", "5", "an index of an item of tasks (0..1)"),
        ("tasks.one.zones", "one", "an index of an item of tasks (0..1)"),
        ("tasks[5].zones", "5", "an index of an item of tasks (0..1)"),
        ("tasks.0.area", "area", "a key of tasks.0 (known keys: name, type, zones, robots_per_zone)"),
        ("swarm.count.max", "max", "a path ending at swarm.count (it holds a value, not keys)"),
    ],
)
def test_bad_override_path(key, found, expected):
    with pytest.raises(InputError) as info:
        apply_overrides(small_mission(), {key: 1}, "--set")
    err = info.value
    assert str(err).startswith(f"--set: {key}: found {found!r}, expected {expected}")
    assert (err.source, err.where, err.found) == ("--set", key, found)
    assert err.expected.startswith(expected)


def test_bad_override_value_names_the_override(monkeypatch):
    err = error_of(small_mission(), monkeypatch, overrides={"swarm.count": -1}, overrides_source="--set")
    assert str(err) == "--set (over missions/x.yaml): swarm.count: found -1, expected a whole number >= 1"
    err = error_of(small_mission(), monkeypatch, overrides={"tasks.0.zones.1": "landing_z"})
    assert err.source == "overrides (over missions/x.yaml)"
    assert err.where == "tasks[0].zones[1]"


def test_ten_thousand_robots_are_a_valid_swarm_and_a_typo_is_not(monkeypatch):
    """The schema no longer stops at 1,000 robots (memory decides, `swarm.sim.memory`); it still
    refuses a count no machine could run, as one line naming the bound."""
    from swarm.mission.schema import MAX_ROBOTS

    monkeypatch.chdir(REPO)
    mission = mission_from_dict(small_mission(), "missions/x.yaml", overrides={"swarm.count": 10_000})
    assert mission.swarm.count == 10_000
    typo = 10 * MAX_ROBOTS
    err = error_of(small_mission(), monkeypatch, overrides={"swarm.count": typo}, overrides_source="--set")
    assert (
        str(err)
        == f"--set (over missions/x.yaml): swarm.count: found {typo}, expected a whole number <= {MAX_ROBOTS}"
    )


def test_a_breaker_s_damage_follows_the_logistic_at_its_local_height() -> None:
    """`SurfHazard.damage_probability` is 1 / (1 + exp(-(H - H50) / spread)) at each height: the
    offshore height gives `impact_damage_probability`, H50 gives one half, lower breakers less."""
    from swarm.mission.schema import SurfHazard

    s = SurfHazard(wave_height_m=1.2, damage_h50_m=2.0, damage_spread_m=0.5)
    p = s.damage_probability([1.2, 2.0, 0.3])
    assert p[0] == pytest.approx(s.impact_damage_probability(), rel=1e-12)
    assert p[1] == pytest.approx(0.5)
    assert p[2] == pytest.approx(1 / (1 + math.exp(1.7 / 0.5)))
    assert p[2] < p[0] < p[1]


def test_a_beach_launch_s_beach_operations_run_from_0_to_their_own_limit() -> None:
    """A beach launch has no sea transit and no surf crossing: their (default) limits do not delay
    the end of its beach operations, and a run of it ends there (recon used to run 6900 s, its
    2400 s plus the unused defaults' 3600 and 900)."""
    from swarm.mission.load import load_mission
    from swarm.sim.run import simulate

    recon = load_mission(Path(__file__).resolve().parents[2] / "missions" / "recon.yaml")
    assert recon.launch.platform == "beach" and recon.phases.beach_operations.time_limit_s == 2400
    assert recon.beach_end_s == 2400
    log = simulate(recon, seed=3)
    assert 2400 - 0.5 <= log.times_s[-1] <= 2400 + 0.5
    assert all(x["t_s"] <= 2400 + 0.5 for x in log.losses)


def test_a_sweep_narrower_than_a_detector_is_refused(monkeypatch):
    """Found by auditing: sweep_width_m 0.001 laid lanes a millimetre apart and planned for ever."""
    raw = small_mission()
    raw["tasks"][1]["sensor"] = {"sweep_width_m": 0.001}
    assert_line(
        error_of(raw, monkeypatch), "tasks[1].sensor.sweep_width_m", 0.001, "a number in metres >= 0.1"
    )
    raw["tasks"][1]["sensor"] = {"lateral_range": {"range_m": [0.0, 0.02], "probability": [1.0, 0.0]}}
    err = error_of(raw, monkeypatch)  # W = 2 * 0.02 / 2 = 0.02 m
    assert err.where == "tasks[1].sensor.lateral_range.probability" and err.found == "0.02 m"
