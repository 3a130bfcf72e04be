"""One input mechanism for every file: strict YAML (a repeated key is an error naming it and its
line; YAML 1.2 numbers), pydantic models, one-line errors."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from swarm.errors import InputError
from swarm.files import parse_yaml
from swarm.mission import read_mission_yaml
from swarm.planning.profiles import load_profile
from swarm.robot.params import load_robot
from swarm.robot.terrain import load_library
from swarm.world.io import load_map

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "swarm" / "data"
#: A shipped example of each kind of YAML input and the loader the commands call on it.
KINDS = {
    "mission": (REPO / "missions" / "landing.yaml", read_mission_yaml),
    "map": (REPO / "maps" / "test_small.yaml", load_map),
    "planner profile": (REPO / "planners" / "fast.yaml", load_profile),
    "robot": (DATA / "robots" / "skid4.yaml", load_robot),
    "terrain modes": (DATA / "terrain" / "skid4-concrete.yaml", load_library),
}


def _copy(src: Path, tmp: Path) -> Path:
    """The file in `tmp`, with a map's grid beside it."""
    if src.parent.name == "maps":
        shutil.copy(src.with_suffix(".npz"), tmp)
    return Path(shutil.copy(src, tmp))


@pytest.mark.parametrize("kind", list(KINDS))
def test_a_key_given_twice_is_an_error_naming_it_and_its_line(kind, tmp_path) -> None:
    src, load = KINDS[kind]
    path = _copy(src, tmp_path)
    lines = path.read_text().splitlines()
    first = next(line for line in lines if line and not line.startswith(("#", " ")))  # a top-level key
    path.write_text("\n".join([*lines, first]) + "\n")
    load(src)  # the shipped file loads
    with pytest.raises(InputError) as err:
        load(path)
    key = first.split(":")[0]
    expected = "expected each key once in a mapping"
    assert str(err.value) == f"{path}: line {len(lines) + 1}: found {key!r}, {expected}"


@pytest.mark.parametrize(
    ("text", "value"),
    [
        # YAML 1.2's core schema (spec 1.2.2, sec. 10.3.2); PyYAML's 1.1 reads the first six
        # as 1000, True, False, 15 (octal), 750 (base 60) and a date
        ("1_000", "1_000"),
        ("yes", "yes"),
        ("off", "off"),
        ("017", 17),
        ("12:30", "12:30"),
        ("2026-11-26", "2026-11-26"),
        ("0o17", 15),
        ("0x1F", 31),
        ("-3", -3),
        ("2.4e9", 2.4e9),
        ("1.", 1.0),
        ("-.inf", float("-inf")),
        ("True", True),
        ("~", None),
    ],
)
def test_plain_scalars_follow_the_yaml_1_2_core_schema(text, value) -> None:
    got = parse_yaml(f"key: {text}\n", "t.yaml")["key"]
    assert got == value and type(got) is type(value)


def test_yaml_1_2_numbers_and_integer_valued_floats_for_counts(tmp_path) -> None:
    """Issue 15: `iterations: 2e4` was the string '2e4' and refused."""
    path = tmp_path / "p.yaml"
    path.write_text("planner: RRTConnect\nbudget:\n  iterations: 2e4\n  time_s: 1.5e0\n")
    profile = load_profile(path)
    assert profile.iterations == 20000 and isinstance(profile.iterations, int)
    assert profile.time_s == 1.5
    path.write_text("planner: RRTConnect\nbudget:\n  iterations: 2.5e1\n")
    profile = load_profile(path)
    assert profile.iterations == 25
    path.write_text("planner: RRTConnect\nbudget:\n  iterations: 2.05e1\n")
    with pytest.raises(InputError) as err:
        load_profile(path)
    assert str(err.value) == f"{path}: budget.iterations: found 20.5, expected a whole number"
    path.write_text("planner: RRTConnect\nbudget:\n  iterations: .inf\n")
    with pytest.raises(InputError, match=r"budget\.iterations: found inf, expected a whole number"):
        load_profile(path)


def test_an_empty_file_and_a_union_name_what_was_meant(tmp_path) -> None:
    empty = tmp_path / "empty.yaml"
    empty.write_text("# nothing\n")
    with pytest.raises(InputError) as err:
        load_profile(empty)
    found = "found 'an empty file', expected a mapping (keys: "
    assert str(err.value).startswith(f"{empty}: (top level): {found}")
    # regions: a mapping is reported against the mapping form, not as 'expected a string'
    src = _copy(REPO / "maps" / "test_small.yaml", tmp_path)
    src.write_text(src.read_text().replace("    kind: launch\n", "    kind: launchpad\n", 1))
    with pytest.raises(InputError) as err:
        load_map(src)
    assert ".kind: found 'launchpad', expected one of 'launch'," in str(err.value)


ROBOT_YAML = DATA / "robots" / "skid4.yaml"


@pytest.mark.parametrize(
    ("key", "name", "text", "expected"),
    [
        (
            "robot.file",
            "robot.yaml",
            ROBOT_YAML.read_text().replace("mass_kg: 30.0", "mass_kg: -30.0"),
            "mass_kg: found -30.0, expected a number in kilograms > 0",
        ),
        (
            "robot.terrain",
            "terrain.yaml",
            "modes:\n  wet_hard_sand:\n    mu_peak: 7\n",
            "modes.wet_hard_sand.mu_peak: found 7, expected a number in [0, 5]: peak longitudinal traction"
            " coefficient (traction / normal load), >= 0",
        ),
    ],
)
def test_a_bad_robot_or_terrain_file_is_one_line_and_exit_2_in_swarm_plan(
    key, name, text, expected, tmp_path, capsys
) -> None:
    from swarm.cli import main

    path = tmp_path / name
    path.write_text(text)
    out = tmp_path / "out"
    argv = ["plan", str(REPO / "missions" / "landing.yaml"), "--set", f"{key}={path}", "--out", str(out)]
    assert main(argv) == 2
    assert capsys.readouterr().err == f"swarm: error: {path}: {expected}\n"
    assert not out.exists()


def test_robot_counts_take_integer_valued_floats(tmp_path) -> None:
    path = tmp_path / "robot.yaml"
    text = ROBOT_YAML.read_text()
    path.write_text(
        text.replace("encoder_ticks_per_wheel_rev: 1960", "encoder_ticks_per_wheel_rev: 2e3\nn_wheels: 4.0")
    )
    robot = load_robot(path)
    assert robot.encoder_ticks_per_wheel_rev == 2000 and type(robot.encoder_ticks_per_wheel_rev) is int
    assert robot.n_wheels == 4 and type(robot.n_wheels) is int
    for value, expected in (("1960.5", "a whole number"), ("3", "2 or 4")):
        key = "n_wheels" if value == "3" else "encoder_ticks_per_wheel_rev"
        path.write_text(text.replace("encoder_ticks_per_wheel_rev: 1960", f"{key}: {value}"))
        with pytest.raises(InputError) as err:
            load_robot(path)
        assert str(err.value) == f"{path}: {key}: found {value}, expected {expected}"


@pytest.mark.parametrize(
    ("spec", "where", "found", "expected"),
    [
        ("kinematic: {alpha: 0}", "kinematic.alpha", "0", "a number in (0, 1000)"),
        ("skid: {com_x_m: 12.5}", "skid.com_x_m", "12.5", "an offset in metres, within +-10"),
        ("uncertainty: {mu_peak: -0.1}", "uncertainty.mu_peak", "-0.1", "a number in (0, 1000)"),
        ("mu_lateral: null", "mu_lateral", "None", "a number"),  # null is not "inherit"
        ("passable: 'no'", "passable", "'no'", "true or false"),
        ("sources: {mu_peak: 3}", "sources.mu_peak", "3", "a string"),
    ],
)
def test_terrain_mode_keys_one_line(spec, where, found, expected, tmp_path) -> None:
    path = tmp_path / "t.yaml"
    path.write_text(f"modes:\n  concrete:\n    {spec}\n")
    with pytest.raises(InputError) as err:
        load_library(path)
    assert str(err.value) == f"{path}: modes.concrete.{where}: found {found}, expected {expected}"


def test_terrain_unknown_keys_list_the_known_ones(tmp_path) -> None:
    path = tmp_path / "t.yaml"
    path.write_text("modes:\n  concrete:\n    uncertainty: {mu_peek: 0.1}\n")
    with pytest.raises(InputError) as err:
        load_library(path)
    known = "mu_peak, mu_lateral, shear_slip, rolling_resistance, turning_resistance_m"
    where = "modes.concrete.uncertainty.mu_peek"
    assert str(err.value).startswith(
        f"{path}: {where}: found 'mu_peek', expected no such key (known keys: {known}"
    )


@pytest.mark.parametrize(
    ("text", "key", "line"),
    [
        ('{\n "a": {"b": 1, "c": [{"b": 2}]},\n "x": {\n  "b": 3,\n  "b": 4\n }\n}\n', "b", 5),
        # the same key in a nested object, on an earlier line, is no repeat; the top level's is
        (
            '{"mission": "m",\n "points": [{"mission": 1, "x": {"mission": 2}}],\n "mission": "n"}',
            "mission",
            3,
        ),
        ('[{"k": 1}, {"k": 2, "j": 0,\n\n"k": 3}]', "k", 3),
    ],
)
def test_a_json_key_given_twice_is_an_error_naming_it_and_its_line(text, key, line, tmp_path) -> None:
    from swarm.files import read_json

    path = tmp_path / "x.json"
    path.write_text(text)
    with pytest.raises(InputError) as err:
        read_json(path, "study.json")
    assert str(err.value) == f"{path}: line {line}: found {key!r}, expected each key once in an object"


def _report(folder: Path, capsys) -> tuple[int, str]:
    from swarm.cli import main

    code = main(["report", str(folder), "-o", str(folder / "report.md")])
    return code, capsys.readouterr().err


def test_swarm_report_refuses_a_json_key_given_twice(tmp_path, capsys) -> None:
    """plan.json, summary.json: the key and the line of its second appearance, exit 2."""
    (tmp_path / "plan.json").write_text('{\n "mission": "a",\n "seed": 1,\n "mission": "b"\n}\n')
    code, err = _report(tmp_path, capsys)
    assert code == 2
    twice = "expected each key once in an object"
    assert err == f"swarm: error: {tmp_path / 'plan.json'}: line 4: found 'mission', {twice}\n"
    (tmp_path / "plan.json").unlink()
    (tmp_path / "results.parquet").write_bytes(b"")
    (tmp_path / "summary.json").write_text('{"runs": 3,\n "points": [],\n "runs": 4}')
    code, err = _report(tmp_path, capsys)
    assert code == 2
    assert err == f"swarm: error: {tmp_path / 'summary.json'}: line 3: found 'runs', {twice}\n"
    assert not (tmp_path / "report.md").exists()


@pytest.mark.parametrize(
    ("change", "where", "found", "expected"),
    [
        ({"runs": "3"}, "points[0].runs", "'3'", "a whole number"),
        ({"runs": -1}, "points[0].runs", "-1", "a whole number >= 0"),
        ({"success_rate": None}, "points[0].success_rate", "None", "a number"),
        ({"wilson_low": "0.4"}, "points[0].wilson_low", "'0.4'", "a number"),
        ({"losses_by_cause": {"surf": 1.5}}, "points[0].losses_by_cause.surf", "1.5", "a whole number"),
    ],
)
def test_swarm_report_checks_a_study_summary(change, where, found, expected, tmp_path, capsys) -> None:
    """summary.json goes through `SummaryFile`: a bad value is one line naming its key, exit 2."""
    import json

    point = {"index": 0, "params": {"swarm.count": 3}, "runs": 3, "successes": 2, "success_rate": 0.667}
    point |= {"wilson_low": 0.21, "wilson_high": 0.94} | change
    (tmp_path / "summary.json").write_text(json.dumps({"mission": "m", "runs": 3, "points": [point]}))
    (tmp_path / "results.parquet").write_bytes(b"")
    code, err = _report(tmp_path, capsys)
    assert code == 2
    assert err == f"swarm: error: {tmp_path / 'summary.json'}: {where}: found {found}, expected {expected}\n"
    assert not (tmp_path / "report.md").exists()


def test_a_json_lines_record_counts_lines_from_its_place_in_the_file() -> None:
    """events.jsonl is parsed a line at a time: the error names the file's line, not the record's."""
    from swarm.files import parse_json

    with pytest.raises(InputError) as err:
        parse_json('{"kind": "loss",\n "kind": "expended"}', "events.jsonl", "events.jsonl", first_line=7)
    assert str(err.value) == "events.jsonl: line 8: found 'kind', expected each key once in an object"
    with pytest.raises(InputError, match=r"^events\.jsonl: line 7: found 'Expecting"):
        parse_json('{"kind": }', "events.jsonl", "events.jsonl", first_line=7)
