"""One `--set KEY=VALUE` grammar for every command that reads a mission: the same key paths, the
same one-line errors, nothing written on bad input."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from swarm.cli import main

REPO = Path(__file__).resolve().parents[1]
LANDING = REPO / "missions" / "landing.yaml"
COMMANDS = (["plan"], ["simulate"], ["study", "--runs", "2"])


@pytest.mark.slow
def test_plan_takes_set_and_plans_that_many_robots(tmp_path, capsys) -> None:
    out = tmp_path / "plan"
    assert main(["plan", str(LANDING), "--set", "swarm.count=60", "--workers", "1", "--out", str(out)]) == 0
    plan = json.loads((out / "plan.json").read_text())
    assert len(plan["robots"]) == 60
    assert [line.split() for line in capsys.readouterr().out.splitlines()][1] == ["robots", "60"]


@pytest.mark.parametrize(
    ("pair", "says"),
    [
        ("swarm.cont=60", "--set: swarm.cont: found 'cont', expected a key of swarm (known keys: count)"),
        ("swarm.count=abc", "swarm.count: found 'abc', expected a whole number"),
        ("swarm.count", "--set: found 'swarm.count', expected KEY=VALUE"),
        # the file's own key is what breaks, but the --set is why: the line says both
        (
            "swarm.count=3",
            "landing.yaml (with --set swarm.count=3): tasks[0].robots_per_zone: found 4, expected at most 1",
        ),
    ],
)
def test_a_bad_set_is_the_same_one_line_in_every_command(tmp_path, capsys, pair, says) -> None:
    lines = []
    for command in COMMANDS:
        out = tmp_path / command[0]
        assert main([*command, str(LANDING), "--set", pair, "--out", str(out)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and says in err[0] and "Traceback" not in err[0]
        lines.append(err[0])
        assert not out.exists()
    assert len(set(lines)) == 1


def test_study_refuses_a_key_both_set_and_swept(tmp_path, capsys) -> None:
    args = ["study", str(LANDING), "--runs", "2", "--set", "swarm.count=8", "--sweep", "swarm.count=8,10"]
    assert main([*args, "--out", str(tmp_path / "s")]) == 2
    assert "--set: found 'swarm.count', expected a key given once" in capsys.readouterr().err
