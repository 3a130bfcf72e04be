"""Planner profiles: the shipped ones load, the default is planners/fast.yaml, bad input is one line."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from swarm.errors import InputError
from swarm.planning.profiles import DEFAULT_PROFILE, load_profile, profile_from_dict, setter_name

PLANNERS_DIR = Path(__file__).resolve().parents[2] / "planners"


def test_shipped_profiles_load():
    fast = load_profile(PLANNERS_DIR / "fast.yaml")
    optimal = load_profile(PLANNERS_DIR / "optimal.yaml")
    roadmap = load_profile(PLANNERS_DIR / "roadmap.yaml")
    assert (fast.planner, fast.objective) == ("RRTConnect", "length")
    assert optimal.planner in ("RRTstar", "BITstar") and optimal.objective == "terrain_cost"
    assert roadmap.planner in ("PRM", "PRMstar") and roadmap.roadmap is not None
    for p in (fast, optimal, roadmap):
        assert p.reproducible, p.name


def test_default_profile_is_planners_fast_yaml():
    fast = load_profile(PLANNERS_DIR / "fast.yaml")
    assert fast.as_dict() == DEFAULT_PROFILE.as_dict()


def test_setter_names():
    assert setter_name("range") == "setRange"
    assert setter_name("samples_per_batch") == "setSamplesPerBatch"


GOOD = {"planner": "RRTConnect", "objective": "length", "budget": {"iterations": 100}}


@pytest.mark.parametrize(
    ("change", "where", "expected"),
    [
        ({"planer": "RRT"}, "planer", "no such key (known keys: name, description, planner,"),
        ({"planner": "AStar"}, "planner", "one of 'RRTConnect', 'RRT', 'RRTstar'"),
        ({"objective": "time"}, "objective", "one of 'length', 'terrain_cost'"),
        (
            {"params": {"rnage": 5.0}},
            "params.rnage",
            "a RRTConnect setting, one of ['intermediate_states', 'range']",
        ),
        ({"params": {"range": "far"}}, "params.range", "a number or true/false"),
        ({"params": {"range": -5.0}}, "params.range", "metres >= 0"),
        ({"budget": {"iterations": 0}}, "budget.iterations", "a whole number >= 1"),
        ({"budget": {"iterations": 1.5}}, "budget.iterations", "a whole number"),
        ({"budget": {"seconds": 1}}, "budget.seconds", "known keys: iterations, time_s"),
        ({"budget": {}}, "budget", "a mapping with 'iterations:'"),
        ({"simplify": "yes"}, "simplify", "true or false"),
        ({"interpolate_m": -1}, "interpolate_m", "a number in metres >= 0.01"),
        ({"roadmap": {"grow_iterations": 10}}, "roadmap", "planner PRM or PRMstar"),
        ({"planner": "PRM", "roadmap": {"grow": 10}}, "roadmap.grow", "known keys: grow_iterations"),
    ],
)
def test_bad_profiles_name_the_key(tmp_path, change, where, expected):
    data = {**GOOD, **change}
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(InputError) as err:
        load_profile(path)
    message = str(err.value)
    assert err.value.where == where
    assert message.startswith(f"{path}: {where}: found ")
    assert expected in message
    assert "\n" not in message


def test_unreadable_and_invalid_yaml(tmp_path):
    with pytest.raises(InputError, match="a readable planner profile YAML file"):
        load_profile(tmp_path / "missing.yaml")
    bad = tmp_path / "broken.yaml"
    bad.write_text("planner: [RRT\n")
    with pytest.raises(InputError, match="line"):
        load_profile(bad)


def test_prm_gets_roadmap_defaults_and_time_budget_is_not_reproducible():
    prm = profile_from_dict({"planner": "PRMstar", "objective": "terrain_cost"}, "x.yaml")
    assert prm.roadmap is not None and prm.roadmap.grow_iterations > 0
    timed = profile_from_dict({"planner": "RRTstar", "budget": {"time_s": 0.5}}, "t.yaml")
    assert not timed.reproducible and timed.iterations is None
    assert timed.name == "t"
