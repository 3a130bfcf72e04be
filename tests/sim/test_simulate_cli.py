"""`swarm simulate`: the files it writes, the table it prints (the same numbers as outcome.json),
reproducible logs, the animation, bad input (one line, exit 2, nothing written), and the report's
own arithmetic (relay spans, robots per phase)."""

from __future__ import annotations

import contextlib
import io
import json
import os
import re

import numpy as np
import pytest
from PIL import Image
from tiny_missions import TINY

from swarm.cli import main
from swarm.report.sim_figures import phase_counts, relay_intervals
from swarm.report.sim_report import format_value
from swarm.sim.run import MissionLog

#: End-to-end: real reports, folders and processes (deselect with -m "not slow").
#: One core runs the module (`scripts/test`'s loadgroup), so `runs` simulates once.
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("simulate_cli")]


LOG_FILES = ("trajectories.npz", "events.jsonl", "outcome.json", "report.html", "report.md", "plan.json")


def _run(args: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(args)
    return code, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The tiny mission (4 robots, 270 s) run twice with the same seed and one override, the second
    time with a GIF."""
    base = tmp_path_factory.mktemp("sim")
    mission = base / "tiny.yaml"
    mission.write_text(TINY)
    common = ["simulate", str(mission), "--seed", "1", "--workers", "1", "--set", "swarm.count=5"]
    with pytest.MonkeyPatch.context() as mp:  # the bars at once: this run takes under their delay
        mp.setattr("swarm.cli.BAR_DELAY_S", 0.0)
        first = _run([*common, "--out", str(base / "a")])
    second = _run([*common, "--out", str(base / "b"), "--animate", str(base / "run.gif")])
    return base, first, second


def test_writes_the_log_and_the_report(runs):
    base, (code, _out, err), _ = runs
    assert code == 0, err
    for name in LOG_FILES:
        assert (base / "a" / name).is_file(), name
    assert "simulating" in err  # the progress bar, on stderr
    html = (base / "a" / "report.html").read_text()
    assert html.count("data:image/png;base64,") >= 3
    assert not re.search(r"(src|href)=['\"]https?:", html)  # self-contained
    outcome = json.loads((base / "a" / "outcome.json").read_text())
    assert outcome["robots"] == 5  # --set swarm.count=5
    verdict = "SUCCESS" if outcome["success"] else "FAILED"
    assert verdict in html and verdict in (base / "a" / "report.md").read_text()
    with np.load(base / "a" / "trajectories.npz") as npz:
        assert npz["xy_m"].shape[1:] == (5, 2)


def test_printed_table_agrees_with_outcome_json(runs):
    base, (_, out, _), _ = runs
    outcome = json.loads((base / "a" / "outcome.json").read_text())
    lines = out.splitlines()
    assert outcome["criteria"]  # landing and detection
    for name, c in outcome["criteria"].items():
        row = next(line.split() for line in lines if line.split()[:1] == [name])
        assert row[1:] == [
            format_value(name, c["value"]),
            format_value(name, c["target"]),
            "yes" if c["met"] else "NO",
        ]
    verdict = next(line for line in lines if line.startswith(("SUCCESS", "FAILED")))
    assert verdict.startswith("SUCCESS" if outcome["success"] else "FAILED")
    for cause, count in outcome["losses_by_cause"].items():
        row = next(line.split() for line in lines if line.split()[:1] == [cause])
        assert row[-1] == str(count)
    if not outcome["losses_by_cause"]:
        assert "no robots lost" in out
    if outcome["lost"]:
        total = next(line.split() for line in lines if line.split()[:1] == ["total"])
        assert total[-1] == str(outcome["lost"])
    mines = next(line for line in lines if line.startswith("mines:"))
    assert mines.startswith(
        f"mines: {outcome['mines_detected']} of {outcome['mines']} detected, "
        f"{outcome['mines_cleared']} cleared"
    )
    assert str(base / "a") in out


def test_same_seed_same_log_with_or_without_animation(runs):
    base, _, (code, _out, err) = runs
    assert code == 0, err
    for name in ("outcome.json", "events.jsonl", "trajectories.npz", "plan.json"):
        assert (base / "a" / name).read_bytes() == (base / "b" / name).read_bytes(), name


def test_gif_animation(runs):
    base, _, (_, out, _) = runs
    with Image.open(base / "run.gif") as gif:
        assert gif.format == "GIF" and gif.n_frames > 1
        assert gif.size[0] == 960 and gif.size[1] % 2 == 0
    assert f"{base / 'run.gif'}" in out
    assert not [p for p in base.iterdir() if p.name.startswith(".")]  # no temporary files left


@pytest.mark.parametrize(
    ("extra", "needle"),
    [
        (["--animate", "{tmp}/movie.avi"], "--animate"),
        (["--animate", "{tmp}/nowhere/movie.gif"], "existing folder"),
        (["--set", "swarm.cuont=3"], "swarm.cuont"),
        (["--set", "swarm.count"], "KEY=VALUE"),
        (["--set", "swarm.count=-3"], "--set"),
        (["--seed", "-1"], "--seed"),
    ],
)
def test_bad_input_is_one_line_exit_2_nothing_written(tmp_path, extra, needle):
    mission = tmp_path / "tiny.yaml"
    mission.write_text(TINY)
    out = tmp_path / "out"
    args = ["simulate", str(mission), "--out", str(out), *(a.format(tmp=tmp_path) for a in extra)]
    code, _stdout, err = _run(args)
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("swarm: error:"), err
    assert needle in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tiny.yaml"]


def test_unknown_mission_file(tmp_path):
    code, _, err = _run(["simulate", str(tmp_path / "nope.yaml"), "--out", str(tmp_path / "o")])
    assert code == 2 and err.count("\n") == 1 and "nope.yaml" in err
    assert list(tmp_path.iterdir()) == []


def test_out_that_is_a_file(tmp_path):
    (tmp_path / "tiny.yaml").write_text(TINY)
    (tmp_path / "taken").write_text("x")
    code, _, err = _run(["simulate", str(tmp_path / "tiny.yaml"), "--out", str(tmp_path / "taken")])
    assert code == 2 and "--out" in err and (tmp_path / "taken").read_text() == "x"


def test_mp4_without_ffmpeg_fails_before_simulating(tmp_path, monkeypatch):
    from matplotlib.animation import FFMpegWriter

    monkeypatch.setattr(FFMpegWriter, "isAvailable", classmethod(lambda cls: False))
    (tmp_path / "tiny.yaml").write_text(TINY)
    code, _, err = _run(
        [
            "simulate",
            str(tmp_path / "tiny.yaml"),
            "--out",
            str(tmp_path / "o"),
            "--animate",
            str(tmp_path / "m.mp4"),
        ]
    )
    assert code == 2 and "ffmpeg" in err and err.count("\n") == 1
    assert "simulating" not in err and "planning" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tiny.yaml"]


# --- the report's arithmetic ------------------------------------------------------------------------------
def _log(
    events: list[dict], alive: np.ndarray, phase: np.ndarray, ends: list, relay: float | None
) -> MissionLog:
    k, n = alive.shape
    crit = {} if relay is None else {"relay": {"value": relay, "target": 0.9, "met": relay >= 0.9}}
    return MissionLog(
        mission="m",
        map="x",
        seed=0,
        robots=[f"robot_{i}" for i in range(n)],
        times_s=np.arange(k) * 10.0,
        xy_m=np.full((k, n, 2), np.nan, np.float32),
        heading_rad=np.zeros((k, n), np.float32),
        alive=alive,
        phase=phase,
        events=events,
        outcome={"success": False, "criteria": crit},
        losses=[],
        mines_m=np.empty((0, 2)),
        mines_state={},
        objects_m=np.empty((0, 2)),
        object_mine=np.empty(0, np.int64),
        end_reasons=ends,
    )


def test_relay_spans_from_break_and_repair_events():
    alive = np.ones((11, 1), bool)
    phase = np.zeros((11, 1), np.int8)
    events = [
        {"t_s": 30.0, "kind": "relay_connected"},
        {"t_s": 60.0, "kind": "relay_break"},
        {"t_s": 80.0, "kind": "relay_repair"},
    ]
    spans = relay_intervals(_log(events, alive, phase, [None], relay=0.5))
    assert spans == [(0.0, 30.0, False), (30.0, 60.0, True), (60.0, 80.0, False), (80.0, 100.0, True)]
    # connected from the first step to the end
    first = [{"t_s": 0.5, "kind": "relay_connected"}]
    assert relay_intervals(_log(first, alive, phase, [None], relay=1.0)) == [
        (0.0, 0.5, False),
        (0.5, 100.0, True),
    ]
    # no events: up throughout when the criterion saw it up, else down
    assert relay_intervals(_log([], alive, phase, [None], relay=1.0)) == [(0.0, 100.0, True)]
    assert relay_intervals(_log([], alive, phase, [None], relay=0.0)) == [(0.0, 100.0, False)]


def test_phase_counts_split_live_robots_by_phase_and_the_rest_by_end():
    # three robots, four samples: robot 0 lost at sample 2, robot 1 recovered at 3, robot 2 expended at 3
    alive = np.array([[1, 1, 1], [1, 1, 1], [0, 1, 1], [0, 0, 0]], bool)
    phase = np.array([[1, 1, 0], [2, 3, 3], [2, 4, 3], [2, 5, 3]], np.int8)
    counts = phase_counts(_log([], alive, phase, ["wave_impact", "recovered", "expended"], None))
    assert counts["sea_transit"].tolist() == [2, 0, 0, 0]
    assert counts["waiting"].tolist() == [1, 0, 0, 0]
    assert counts["beach"].tolist() == [0, 2, 1, 0]
    assert counts["lost"].tolist() == [0, 0, 1, 1]
    assert counts["recovered"].tolist() == [0, 0, 0, 1]
    assert counts["expended"].tolist() == [0, 0, 0, 1]
    total = sum(c for c in counts.values())
    assert total.tolist() == [3, 3, 3, 3]


def test_a_full_disk_is_one_line_and_leaves_only_whole_files(tmp_path, monkeypatch):
    """The disk fills after plan.json, plan.geojson and trajectories.npz: exit 2, one line naming
    events.jsonl; what is there is whole, nothing temporary is left."""
    import errno

    from swarm import files

    fsync, synced = files.os.fsync, []

    def filling(fd: int) -> None:
        synced.append(fd)
        if len(synced) > 3:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        fsync(fd)

    mission = tmp_path / "tiny.yaml"
    mission.write_text(TINY)
    out = tmp_path / "out"
    monkeypatch.setattr(files.os, "fsync", filling)
    code, _stdout, err = _run(["simulate", str(mission), "--seed", "1", "--workers", "1", "--out", str(out)])
    assert code == 2
    assert err.splitlines()[-1] == (  # after the progress bars
        f"swarm: error: {out / 'events.jsonl'}: could not write it (No space left on device); "
        "nothing partial was left"
    )
    assert sorted(p.name for p in out.iterdir()) == ["plan.geojson", "plan.json", "trajectories.npz"]
    json.loads((out / "plan.json").read_text())
    json.loads((out / "plan.geojson").read_text())
    with np.load(out / "trajectories.npz") as npz:
        assert npz["xy_m"].shape[-1] == 2
