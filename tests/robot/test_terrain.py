"""Terrain modes and robot parameters: the bundled library, user overrides, errors, inertia."""

from __future__ import annotations

import math
import re
from importlib.resources import files
from pathlib import Path

import numpy as np
import pytest
import yaml

from swarm.errors import InputError
from swarm.robot.params import RobotParams, box_yaw_inertia, load_robot, parallel_axis
from swarm.robot.terrain import (
    TerrainLibrary,
    default_library,
    library_from_dict,
    load_library,
    mode_to_dict,
)

BUNDLED_MODES = (
    "concrete",
    "wet_hard_sand",
    "soft_sand",
    "dirt",
    "rock",
    "vegetation",
    "shallow_water",
    "surf",
    "deep_water",
)
#: Every mode must say where these come from; they have no dataclass default.
CORE = ("mu_peak", "mu_lateral", "shear_slip", "rolling_resistance")
ROBOT_YAML = Path(str(files("swarm") / "data" / "robots" / "skid4.yaml"))
MODES_YAML = files("swarm") / "data" / "terrain_modes.yaml"


def write_yaml(tmp_path: Path, name: str, data: object) -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def robot_dict() -> dict:
    return yaml.safe_load(ROBOT_YAML.read_text())


# --- the bundled library ------------------------------------------------------------------------


def test_bundled_library_has_the_beach_modes():
    library = default_library()
    missing = [m for m in BUNDLED_MODES if m not in list(library)]
    assert not missing
    for name in BUNDLED_MODES:
        assert library[name].name == name


def test_every_coefficient_a_mode_sets_has_a_source():
    raw = yaml.safe_load(MODES_YAML.read_text())["modes"]
    library = default_library()
    for name, spec in raw.items():
        mode = library[name]
        set_here = {k for k in spec if k not in ("description", "sources", "like", "uncertainty")}
        needed = set(CORE) | set_here
        missing = sorted(needed - set(mode.sources))
        assert not missing, f"{name}: no source for {missing}"
        assert all(isinstance(s, str) and s.strip() for s in mode.sources.values())
        # The coefficients the file sets are the ones the mode carries.
        for key in set_here:
            assert getattr(mode, key) == pytest.approx(float(spec[key]))


def test_water_modes_are_water_and_land_modes_are_not():
    library = default_library()
    for name in ("shallow_water", "surf", "deep_water"):
        assert library[name].is_water
    for name in ("concrete", "wet_hard_sand", "soft_sand", "dirt", "rock", "vegetation"):
        assert not library[name].is_water
    # Deeper water carries more of the weight.
    fractions = [library[n].buoyancy_fraction for n in ("shallow_water", "surf", "deep_water")]
    assert fractions == sorted(fractions)
    assert fractions[-1] == 1.0


# --- user YAML: overrides and additions -----------------------------------------------------------


def test_user_yaml_overrides_one_key_and_keeps_the_rest(tmp_path):
    path = write_yaml(tmp_path, "mine.yaml", {"modes": {"soft_sand": {"mu_peak": 0.42}}})
    default = default_library()
    library = load_library(path)
    mode = library["soft_sand"]
    assert mode.mu_peak == pytest.approx(0.42)
    assert default["soft_sand"].mu_peak != pytest.approx(0.42)
    for key, value in default["soft_sand"].coefficients().items():
        if key != "mu_peak":
            assert getattr(mode, key) == pytest.approx(value), key
    assert dict(mode.sources) == dict(default["soft_sand"].sources)
    assert mode.description == default["soft_sand"].description
    # The other modes are still there, untouched.
    assert set(library) == set(default)
    assert library["concrete"].coefficients() == default["concrete"].coefficients()


def test_new_mode_like_an_existing_one_inherits(tmp_path):
    spec = {"modes": {"beach_soft": {"like": "soft_sand", "rolling_resistance": 0.3}}}
    library = load_library(write_yaml(tmp_path, "new.yaml", spec))
    parent = default_library()["soft_sand"]
    mode = library["beach_soft"]
    assert mode.name == "beach_soft"
    assert mode.rolling_resistance == pytest.approx(0.3)
    for key in ("mu_peak", "mu_lateral", "shear_slip", "rolling_radius_scale", "buoyancy_fraction"):
        assert getattr(mode, key) == getattr(parent, key), key
    assert set(CORE) <= set(mode.sources)
    assert "soft_sand" in list(library)  # adding did not replace the parent


def test_like_an_unknown_mode_is_rejected(tmp_path):
    path = write_yaml(tmp_path, "new.yaml", {"modes": {"x": {"like": "quicksand"}}})
    with pytest.raises(InputError) as err:
        load_library(path)
    assert str(path) in str(err.value)
    assert "modes.x.like" in str(err.value)
    assert "quicksand" in str(err.value)


def test_new_mode_missing_a_coefficient_names_file_and_key(tmp_path):
    spec = {"modes": {"gravel": {"mu_peak": 0.6, "mu_lateral": 0.5, "rolling_resistance": 0.05}}}
    path = write_yaml(tmp_path, "gravel.yaml", spec)
    with pytest.raises(InputError) as err:
        load_library(path)
    message = str(err.value)
    assert message.startswith(str(path))
    assert "modes.gravel.shear_slip" in message
    assert "like" in message  # says how to fix it


def test_new_mode_without_base_library_needs_every_coefficient():
    with pytest.raises(InputError) as err:
        library_from_dict({"modes": {"gravel": {"mu_peak": 0.6}}}, "g.yaml")
    assert "g.yaml" in str(err.value)
    assert "modes.gravel.mu_lateral" in str(err.value)


@pytest.mark.parametrize(
    ("key", "bad"),
    [
        ("mu_peak", 7.5),
        ("mu_peak", -0.1),
        ("shear_slip", 0.0),
        ("rolling_resistance", -0.01),
        ("buoyancy_fraction", 1.5),
        ("rolling_radius_scale", 0.0),
        ("drag_n_s2_per_m2", -1.0),
    ],
)
def test_out_of_range_value_names_key_and_range(tmp_path, key, bad):
    path = write_yaml(tmp_path, "t.yaml", {"modes": {"concrete": {key: bad}}})
    with pytest.raises(InputError) as err:
        load_library(path)
    message = str(err.value)
    assert str(path) in message
    assert f"modes.concrete.{key}" in message
    bounds = re.search(r"\[\s*([-+0-9.e]+)\s*,\s*([-+0-9.e]+)\s*\]", message)
    assert bounds, message
    lo, hi = float(bounds.group(1)), float(bounds.group(2))
    assert not lo <= bad <= hi  # the stated range really excludes what was given ...
    assert lo <= getattr(default_library()["concrete"], key) <= hi  # ... and admits the default
    if key == "buoyancy_fraction":  # a fraction of the weight
        assert (lo, hi) == (0.0, 1.0)


@pytest.mark.parametrize("bad", ["slippery", True, None, [0.5], {"value": 0.5}, float("nan"), float("inf")])
def test_non_numeric_value_names_key(tmp_path, bad):
    path = write_yaml(tmp_path, "t.yaml", {"modes": {"soft_sand": {"mu_lateral": bad}}})
    with pytest.raises(InputError) as err:
        load_library(path)
    message = str(err.value)
    assert str(path) in message
    assert "modes.soft_sand.mu_lateral" in message
    assert "number" in message


def test_unknown_mode_key_is_rejected(tmp_path):
    path = write_yaml(tmp_path, "t.yaml", {"modes": {"concrete": {"mu_peek": 0.9}}})
    with pytest.raises(InputError) as err:
        load_library(path)
    assert str(path) in str(err.value)
    assert "modes.concrete.mu_peek" in str(err.value)
    assert "mu_peak" in str(err.value)  # lists what is allowed


def test_unknown_top_level_key_is_rejected():
    with pytest.raises(InputError) as err:
        library_from_dict({"modes": {"concrete": {"mu_peak": 0.9}}, "mdoes": {}}, "t.yaml", default_library())
    assert "t.yaml" in str(err.value)
    assert "mdoes" in str(err.value)


@pytest.mark.parametrize("data", [None, [], {"modes": []}, {"modes": None}, {"mode": {"concrete": {}}}])
def test_wrong_shape_is_rejected(data):
    with pytest.raises(InputError) as err:
        library_from_dict(data, "t.yaml", default_library())
    assert str(err.value).startswith("t.yaml: ")
    assert "modes" in str(err.value)


def test_mode_spec_must_be_a_mapping():
    with pytest.raises(InputError) as err:
        library_from_dict({"modes": {"concrete": 0.9}}, "t.yaml", default_library())
    assert "modes.concrete" in str(err.value)


def test_unreadable_and_invalid_terrain_files(tmp_path):
    missing = tmp_path / "nope.yaml"
    with pytest.raises(InputError) as err:
        load_library(missing)
    assert str(missing) in str(err.value)
    broken = tmp_path / "broken.yaml"
    broken.write_text("modes:\n  concrete:\n    mu_peak: [0.9\n")
    with pytest.raises(InputError) as err:
        load_library(broken)
    assert str(broken) in str(err.value)
    assert "line" in str(err.value)


# --- gathering coefficients for many robots ---------------------------------------------------


def test_gather_returns_per_robot_arrays_for_the_classes():
    library = default_library()
    names = ("deep_water", "concrete", "soft_sand", "surf")
    table = library.table(names)
    assert table.names == names
    classes = np.array([2, 0, 1, 1, 3, 2, 0])
    got = table.gather(classes)
    assert set(got) >= {*CORE, "buoyancy_fraction", "drag_n_s2_per_m2", "rolling_radius_scale"}
    for key, column in got.items():
        assert column.shape == classes.shape
        expected = [getattr(library[names[c]], key) for c in classes]
        np.testing.assert_array_equal(column, expected, err_msg=key)
    assert table.index("soft_sand") == 2
    # Default order is the library's own.
    assert library.table().names == tuple(library)


def test_gather_accepts_a_2d_class_grid():
    library = default_library()
    table = library.table(["concrete", "shallow_water"])
    grid = np.array([[0, 1], [1, 1]])
    got = table.gather(grid)["buoyancy_fraction"]
    assert got.shape == (2, 2)
    assert got[0, 0] == library["concrete"].buoyancy_fraction
    assert got[1, 0] == library["shallow_water"].buoyancy_fraction


# --- climbing ------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["concrete", "soft_sand", "shallow_water", "surf"])
def test_max_climb_slope_from_traction_balance(name):
    """Buoyancy lightens both the grip and the downslope pull, so it cancels: tan a = mu - c_rr."""
    raw = yaml.safe_load(MODES_YAML.read_text())["modes"][name]
    mu, crr = raw["mu_peak"], raw["rolling_resistance"]
    expected = math.degrees(math.atan(mu - crr))
    assert default_library()[name].max_climb_slope_deg == pytest.approx(expected, rel=1e-12)


def test_climb_ordering_and_deep_water():
    library = default_library()
    assert library["deep_water"].max_climb_slope_deg == 0.0  # no contact, no climbing
    # Firm ground climbs steeper than loose sand: more grip, less rolling resistance.
    assert library["concrete"].max_climb_slope_deg > library["soft_sand"].max_climb_slope_deg > 0
    for mode in library.values():
        assert 0.0 <= mode.max_climb_slope_deg < 90.0


# --- YAML round trip -------------------------------------------------------------------------


def test_library_yaml_round_trip(tmp_path):
    library = default_library()
    path = tmp_path / "all.yaml"
    path.write_text(yaml.safe_dump(library.to_yaml_dict(), sort_keys=False))
    again = library_from_dict(yaml.safe_load(path.read_text()), path)
    assert list(again) == list(library)
    for name, mode in library.items():
        back = again[name]
        for key, value in mode.coefficients().items():
            assert getattr(back, key) == pytest.approx(value, abs=1e-6), (name, key)
        assert dict(back.sources) == dict(mode.sources)
        assert back.description == mode.description
        assert back.max_climb_slope_deg == pytest.approx(mode.max_climb_slope_deg, abs=1e-4)


def test_model_params_round_trip():
    base = default_library()
    spec = {
        "modes": {
            "concrete": {
                "kinematic": {"alpha": 0.97, "chi": 1.9},
                "lagrangian": {"robot_inertia_scale": 1.7, "wheel_inertia_scale": 0.97},
            }
        }
    }
    lib = library_from_dict(spec, "fit.yaml", base)
    mode = lib["concrete"]
    assert dict(mode.model_params["kinematic"]) == {"alpha": 0.97, "chi": 1.9}
    assert dict(mode.model_params["lagrangian"]) == {"robot_inertia_scale": 1.7, "wheel_inertia_scale": 0.97}
    assert mode.coefficients() == base["concrete"].coefficients()  # coefficients kept

    text = yaml.safe_dump(lib.to_yaml_dict())
    back = library_from_dict(yaml.safe_load(text), "rt.yaml")["concrete"]
    assert {k: dict(v) for k, v in back.model_params.items()} == {
        k: dict(v) for k, v in mode.model_params.items()
    }

    # A mode made like a fitted one inherits the fitted model parameters too.
    child = library_from_dict({"modes": {"c2": {"like": "concrete"}}}, "c2.yaml", lib)["c2"]
    assert dict(child.model_params["kinematic"]) == {"alpha": 0.97, "chi": 1.9}


@pytest.mark.parametrize(
    ("given", "where"),
    [
        ({"alpha": 0.9, "beta": 2.0}, "modes.concrete.kinematic"),
        ({"robot_inertia_scale": 1.0}, "modes.concrete.kinematic"),
        (1.5, "modes.concrete.kinematic"),
        ({"alpha": -1.0}, "modes.concrete.kinematic.alpha"),
        ({"alpha": 0.0}, "modes.concrete.kinematic.alpha"),
        ({"chi": "wide"}, "modes.concrete.kinematic.chi"),
        ({"chi": True}, "modes.concrete.kinematic.chi"),
    ],
)
def test_bad_model_params_are_rejected(tmp_path, given, where):
    path = write_yaml(tmp_path, "fit.yaml", {"modes": {"concrete": {"kinematic": given}}})
    with pytest.raises(InputError) as err:
        load_library(path)
    assert str(path) in str(err.value)
    assert where in str(err.value)


def test_library_lookup_of_unknown_mode_is_an_input_error():
    library = default_library()
    assert isinstance(library, TerrainLibrary)
    with pytest.raises(InputError) as err:
        library["lava"]
    assert "lava" in str(err.value)
    assert "concrete" in str(err.value)  # lists the known modes


def test_membership_test_does_not_raise():
    """`name in library` is a question, not an error (Mapping.__contains__ relies on KeyError)."""
    library = default_library()
    assert "concrete" in library
    assert "lava" not in library


# --- robot YAML ------------------------------------------------------------------------------------


def test_bundled_robot_loads():
    robot = load_robot(ROBOT_YAML)
    data = robot_dict()
    assert robot.name == data["name"]
    assert robot.mass_kg == data["mass_kg"]
    assert robot.track_width_m == data["track_width_m"]
    assert robot.encoder_ticks_per_wheel_rev == data["encoder_ticks_per_wheel_rev"]
    assert robot.body_mass_kg == pytest.approx(data["mass_kg"] - 4 * data["wheel_mass_kg"])


def _robot_error(tmp_path: Path, data: object) -> tuple[Path, str]:
    path = write_yaml(tmp_path, "robot.yaml", data)
    with pytest.raises(InputError) as err:
        load_robot(path)
    return path, str(err.value)


@pytest.mark.parametrize("key", ["mass_kg", "wheel_radius_m", "track_width_m", "height_m"])
def test_robot_missing_key(tmp_path, key):
    data = robot_dict()
    del data[key]
    path, message = _robot_error(tmp_path, data)
    assert message.startswith(f"{path}: {key}:")


@pytest.mark.parametrize("mass", [-30.0, 0, -1])
def test_robot_negative_mass(tmp_path, mass):
    data = robot_dict() | {"mass_kg": mass}
    path, message = _robot_error(tmp_path, data)
    assert message == f"{path}: mass_kg: found {mass!r}, expected a number in kilograms > 0"


@pytest.mark.parametrize(("key", "bad"), [("mass_kg", "thirty"), ("wheelbase_m", True), ("width_m", [0.4])])
def test_robot_non_number(tmp_path, key, bad):
    data = robot_dict() | {key: bad}
    path, message = _robot_error(tmp_path, data)
    assert message.startswith(f"{path}: {key}:")
    assert "number" in message


def test_robot_unknown_key(tmp_path):
    data = robot_dict() | {"colour": "yellow"}
    path, message = _robot_error(tmp_path, data)
    assert message.startswith(f"{path}: colour:")
    assert "mass_kg" in message  # lists the known keys


@pytest.mark.parametrize(
    ("key", "bad"),
    [("encoder_ticks_per_wheel_rev", 0), ("encoder_ticks_per_wheel_rev", 1960.5), ("n_wheels", 3)],
)
def test_robot_bad_integer(tmp_path, key, bad):
    path, message = _robot_error(tmp_path, robot_dict() | {key: bad})
    assert message.startswith(f"{path}: {key}:")


def test_robot_wheels_heavier_than_robot(tmp_path):
    path, message = _robot_error(tmp_path, robot_dict() | {"wheel_mass_kg": 8.0})
    assert message.startswith(f"{path}: wheel_mass_kg:")


def test_robot_top_level_not_a_mapping(tmp_path):
    path, message = _robot_error(tmp_path, [1, 2, 3])
    assert message.startswith(f"{path}: ")


def test_robot_unreadable_file(tmp_path):
    missing = tmp_path / "no_such_robot.yaml"
    with pytest.raises(InputError) as err:
        load_robot(missing)
    assert str(err.value).startswith(f"{missing}: (file):")
    with pytest.raises(InputError) as err:  # a directory is not a file either
        load_robot(tmp_path)
    assert str(err.value).startswith(f"{tmp_path}: (file):")


def test_robot_invalid_yaml(tmp_path):
    path = tmp_path / "robot.yaml"
    path.write_text("name: skid4\nmass_kg: 30.0\nwheel_radius_m: [0.11\n")
    with pytest.raises(InputError) as err:
        load_robot(path)
    assert re.match(rf"{re.escape(str(path))}: line \d+:", str(err.value))


# --- inertia -------------------------------------------------------------------------------------


def test_box_yaw_inertia():
    assert box_yaw_inertia(30, 0.6, 0.44) == pytest.approx(30 / 12 * (0.36 + 0.1936), rel=1e-12)
    assert box_yaw_inertia(12, 1.0, 0.0) == pytest.approx(1.0)


def test_parallel_axis():
    assert parallel_axis(0.5, 2.0, 0.3) == pytest.approx(0.5 + 2.0 * 0.09, rel=1e-12)
    assert parallel_axis(0.5, 2.0, 0.0) == 0.5


def test_robot_inertia_matches_thesis_formulas():
    data = robot_dict()
    robot = load_robot(ROBOT_YAML)
    assert isinstance(robot, RobotParams)
    m, mw, r = data["mass_kg"], data["wheel_mass_kg"], data["wheel_radius_m"]
    a, b = data["length_m"], data["width_m"]
    h = math.hypot(data["track_width_m"] / 2, data["wheelbase_m"] / 2)

    thesis_robot = m * (a * a + b * b) / 12
    wheel_about_axis = mw * r * r + mw * h * h
    assert robot.thesis_yaw_inertia_kgm2 == pytest.approx(thesis_robot, rel=1e-12)
    assert robot.wheel_spin_inertia_kgm2 == pytest.approx(mw * r * r, rel=1e-12)
    assert robot.wheel_offset_m == pytest.approx(h, rel=1e-12)
    assert robot.wheel_inertia_about_robot_kgm2 == pytest.approx(wheel_about_axis, rel=1e-12)
    # The skid model's inertia boxes only the body and adds the four wheels about the axis.
    body = (m - 4 * mw) * (a * a + b * b) / 12
    assert robot.yaw_inertia_kgm2 == pytest.approx(body + 4 * wheel_about_axis, rel=1e-12)


def test_uncertainty_and_a_fitted_centre_of_mass_read_back_and_are_checked(tmp_path):
    """A mode's prior uncertainty and a skid fit's centre of mass survive a YAML round trip; a
    bad value names the file and key."""
    base = default_library()
    spec = {
        "modes": {
            "beach": {
                "like": "wet_hard_sand",
                "uncertainty": {"mu_peak": 0.05},
                "skid": {"com_x_m": -0.067, "com_y_m": 0.0},
            }
        }
    }
    mode = library_from_dict(spec, "fit.yaml", base)["beach"]
    assert mode.uncertainty["mu_peak"] == 0.05
    assert mode.uncertainty["rolling_resistance"] == base["wet_hard_sand"].uncertainty["rolling_resistance"]
    assert mode.model_params["skid"] == {"com_x_m": -0.067, "com_y_m": 0.0}
    again = library_from_dict({"modes": {"beach": mode_to_dict(mode)}}, "again.yaml")["beach"]
    assert again.uncertainty == mode.uncertainty
    assert again.model_params == mode.model_params
    for key, bad in (
        ("uncertainty", {"mu_peak": -1}),
        ("uncertainty", {"grip": 0.1}),
        ("skid", {"com_x_m": "aft"}),
    ):
        with pytest.raises(InputError) as exc:
            library_from_dict({"modes": {"beach": {"like": "concrete", key: bad}}}, "bad.yaml", base)
        assert exc.value.source == "bad.yaml"
        assert exc.value.where.startswith(f"modes.beach.{key}")
