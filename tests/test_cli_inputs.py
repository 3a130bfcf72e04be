"""Bad binary inputs through the commands that read them: one line naming the file, exit 2, and no
output folder left behind."""

from __future__ import annotations

import os
import socket
from pathlib import Path

import pytest
import yaml

from swarm.cli import main

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture()
def truncated_map(tmp_path) -> Path:
    """maps/test_small.yaml pointing at the first 3000 bytes of its grid (issue 15)."""
    doc = yaml.safe_load((REPO / "maps" / "test_small.yaml").read_text())
    grid = (REPO / "maps" / doc["grid"]).read_bytes()
    (tmp_path / "x.npz").write_bytes(grid[:3000])
    doc["grid"] = "x.npz"
    path = tmp_path / "x.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


@pytest.mark.parametrize("command", ["map info", "plan", "simulate"])
def test_a_truncated_grid_is_one_line_and_exit_2(truncated_map, tmp_path, command, capsys) -> None:
    out = tmp_path / "out"
    if command == "map info":
        argv = ["map", "info", str(truncated_map)]
    else:
        argv = [command, str(REPO / "missions" / "landing.yaml"), "--set", f"map={truncated_map}"]
        argv += ["--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err == (
        f"swarm: error: {truncated_map.parent / 'x.npz'}: (file): found '3000 bytes that are not a whole "
        "zip archive', expected an .npz grid (numpy.savez) holding arrays 'terrain' and 'elevation_m'\n"
    )
    assert not out.exists()


#: What each command's output folder holds (one file is enough to mark it).
HOLDS = {"plan": "plan.json", "simulation": "outcome.json", "study": "study.json"}


@pytest.mark.parametrize(
    ("command", "held"),
    [
        ("study", "plan"),
        ("plan", "study"),
        ("plan", "simulation"),
        ("simulate", "plan"),
        ("simulate", "study"),
    ],
)
def test_an_output_folder_of_another_command_is_refused_untouched(tmp_path, command, held, capsys) -> None:
    """A study written into a plan's folder once overwrote its report, and the folder then read as
    neither: now it is one line, before any work, and the folder is left as it was."""
    out = tmp_path / "out"
    out.mkdir()
    (out / HOLDS[held]).write_text("{}")
    (out / "report.html").write_text("the old report")
    argv = [command, str(REPO / "missions" / "landing.yaml"), "--out", str(out)]
    assert main([*argv, *(["--runs", "2"] if command == "study" else [])]) == 2
    kind = {"simulate": "simulation"}.get(command, command)
    assert capsys.readouterr().err == (
        f"swarm: error: command line: --out: found '{out}', "
        f"expected a new folder or a {kind} folder (this one holds a {held}'s output)\n"
    )
    assert sorted(p.name for p in out.iterdir()) == sorted([HOLDS[held], "report.html"])
    assert (out / "report.html").read_text() == "the old report"


def test_an_empty_path_and_a_bad_number_are_one_line(capsys) -> None:
    """argparse's own errors, without its usage block: `--out ''` once wrote into the current folder."""
    landing = str(REPO / "missions" / "landing.yaml")
    for argv, says in (
        (
            ["plan", landing, "--out", ""],
            "argument --out: found an empty path, expected a file or folder name",
        ),
        (["simulate", landing, "--seed", "abc"], "argument --seed: invalid int value: 'abc'"),
    ):
        with pytest.raises(SystemExit) as exit_:
            main(argv)
        assert exit_.value.code == 2
        err = capsys.readouterr().err
        assert err == f"swarm {argv[0]}: error: {says} (see swarm {argv[0]} --help)\n"


def test_a_refused_resume_is_one_line_without_a_progress_bar(tmp_path, capfd) -> None:
    """The study's bar once drew 'study: 0run' twice before the error: a bar waits a second."""
    landing = str(REPO / "missions" / "landing.yaml")
    out = tmp_path / "study"
    args = ["study", landing, "--workers", "1", "--batch", "1", "--out", str(out)]
    assert main([*args, "--runs", "1"]) == 0
    capfd.readouterr()
    assert main([*args, "--runs", "2"]) == 2
    err = capfd.readouterr().err
    assert len(err.splitlines()) == 1 and err.startswith("swarm: error: "), err
    assert "a different study" in err


def test_a_ray_address_without_a_cluster_is_one_line_and_writes_nothing(tmp_path, monkeypatch, capfd) -> None:
    """It was Ray's ConnectionError traceback, exit 1, after study.json was written."""
    ray = pytest.importorskip("ray")  # the `ray` extra; CI installs it

    def refused(*args, **kwargs):
        os.write(2, b"gcs_client.cc:210: Failed to get cluster ID\n")  # Ray's core logs its retries so
        raise ConnectionError("Failed to connect to Ray cluster at 10.255.255.1:6379")

    monkeypatch.setattr(ray, "init", refused)
    monkeypatch.setattr("swarm.studies.backends._unreachable", lambda address: None)  # a port answers
    out = tmp_path / "study"
    argv = ["study", str(REPO / "missions" / "landing.yaml"), "--runs", "2", "--backend", "ray"]
    assert main([*argv, "--address", "10.255.255.1:6379", "--out", str(out)]) == 2
    assert capfd.readouterr().err == (
        "swarm: error: command line: --address: found '10.255.255.1:6379', expected a running Ray"
        " cluster ('auto' on one of its nodes, or ray://HOST:10001): Failed to connect to Ray cluster"
        " at 10.255.255.1:6379\n"
    )
    assert not out.exists()


def test_a_ray_address_where_nothing_answers_is_refused_at_once(tmp_path, capfd) -> None:
    """Ray waited for ever on a closed port of this machine; the port is tried first."""
    pytest.importorskip("ray")
    with socket.socket() as sock:  # a port nothing listens on: bound, then let go
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    out = tmp_path / "study"
    argv = ["study", str(REPO / "missions" / "landing.yaml"), "--runs", "2", "--backend", "ray"]
    assert main([*argv, "--address", f"127.0.0.1:{port}", "--out", str(out)]) == 2
    err = capfd.readouterr().err
    assert err.startswith(
        f"swarm: error: command line: --address: found '127.0.0.1:{port}', expected a running"
    )
    assert err.endswith(f"nothing answers at 127.0.0.1:{port} (Connection refused)\n")
    assert not out.exists()


def test_a_ray_address_where_a_web_server_listens_is_refused_at_once(tmp_path, capfd) -> None:
    """Ray waited for ever, silently, on a port where something other than a gRPC server answers;
    the port is asked for an HTTP/2 SETTINGS frame first (a Ray head answers it: checked by hand
    with `ray start --head`)."""
    import http.server
    import threading

    pytest.importorskip("ray")

    class Quiet(http.server.BaseHTTPRequestHandler):
        def log_message(self, *args: object) -> None:  # its log is on this process's stderr
            pass

    server = http.server.HTTPServer(("127.0.0.1", 0), Quiet)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    port = server.server_address[1]
    out = tmp_path / "study"
    argv = ["study", str(REPO / "missions" / "landing.yaml"), "--runs", "2", "--backend", "ray"]
    try:
        assert main([*argv, "--address", f"127.0.0.1:{port}", "--out", str(out)]) == 2
    finally:
        server.shutdown()
        server.server_close()
    err = capfd.readouterr().err
    assert len(err.splitlines()) == 1
    assert err.endswith(f"what listens at 127.0.0.1:{port} is not a gRPC server (a Ray port is one)\n")
    assert not out.exists()


def test_a_study_of_more_than_a_million_runs_is_refused_before_any_work(tmp_path, capsys) -> None:
    """`--runs 100000000` spent minutes building its list of runs, and memory with it."""
    landing = str(REPO / "missions" / "landing.yaml")
    out = tmp_path / "big"
    cases = (
        (
            ["study", landing, "--runs", "2000", "--sweep", "swarm.count=8:600:1"],
            "--runs: found 2000",
            "593 points x 2,000",
        ),
        (["plan", landing, "--evaluate", "2000000"], "--evaluate: found 2000000", "1 point x 2,000,000"),
    )
    for argv, found, each in cases:
        assert main([*argv, "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert (
            err == f"swarm: error: command line: {found}, expected at most 1,000,000 runs in all ({each})\n"
        )
        assert not out.exists()


def test_output_into_a_closed_pipe_is_no_traceback() -> None:
    """`swarm schema | head -1` printed a BrokenPipeError traceback."""
    import subprocess
    import sys

    reader = subprocess.Popen(["head", "-c", "1"], stdin=subprocess.PIPE, stdout=subprocess.DEVNULL)
    writer = subprocess.run(
        [sys.executable, "-m", "swarm.cli", "schema"], stdout=reader.stdin, stderr=subprocess.PIPE, text=True
    )
    reader.stdin.close()
    reader.wait()
    assert "Traceback" not in writer.stderr and "BrokenPipeError" not in writer.stderr, writer.stderr


def test_a_bar_of_runs_never_goes_back_and_shows_a_share_to_one_decimal() -> None:
    """A batch's share is taken back a moment before its rows count (`backends._run_shared`): the
    bar holds where it was; a share of a run reads 1.3/6, a whole count 2/6."""
    import io

    from tqdm import tqdm

    from swarm.cli import _count_runs

    bar = tqdm(file=io.StringIO(), unit="run")
    _count_runs(bar, 1.26, 6)
    assert (bar.n, bar.total) == (1.3, 6) and "1.3/6" in str(bar)
    _count_runs(bar, 1.0, 6)
    assert bar.n == 1.3
    _count_runs(bar, 2.0, 6)
    assert bar.n == 2 and isinstance(bar.n, int) and "2/6" in str(bar)
    bar.close()


@pytest.mark.parametrize(
    "argv",
    [
        ["plan", "MISSION", "--seed", str(2**64)],
        ["simulate", "MISSION", "--plan-seed", str(2**64)],
        ["study", "MISSION", "--runs", "1", "--seed", str(2**64)],
        ["map", "generate", "--seed", "-1", "-o", "OUT/m.yaml"],
    ],
    ids=["plan", "simulate", "study", "map generate"],
)
def test_every_command_takes_the_same_seeds(argv, tmp_path, capsys) -> None:
    """`plan --seed` took any integer and a study's table then failed on 2**64 with a traceback."""
    mission = str(REPO / "missions" / "landing.yaml")
    argv = [a.replace("MISSION", mission).replace("OUT", str(tmp_path)) for a in argv]
    assert main(argv) == 2
    option = argv[argv.index("--seed" if "--seed" in argv else "--plan-seed")]
    value = argv[argv.index(option) + 1]
    assert capsys.readouterr().err == (
        f"swarm: error: command line: {option}: found {int(value)}, expected a seed from 0 to 2**64 - 1\n"
    )
    assert list(tmp_path.iterdir()) == []


def test_an_output_never_replaces_an_input_of_another_kind(tmp_path, capsys) -> None:
    """`map generate -o` replaced a mission with a map, `model calibrate --out` the robot file it
    read with a terrain file; both now refuse a file that is not what they write."""
    mission = tmp_path / "mission.yaml"
    mission.write_text((REPO / "missions" / "recon.yaml").read_text())
    robot = tmp_path / "robot.yaml"
    robot.write_text((REPO / "swarm" / "data" / "robots" / "skid4.yaml").read_text())
    runs = REPO / "swarm" / "data" / "robot-runs"
    calibrate = ["model", "calibrate", "--robot", str(robot), "--mode", "wet_hard_sand", "--out", str(robot)]
    calibrate += ["--encoders", str(runs / "hardsand_straight_encoders.txt")]
    calibrate += ["--truth", str(runs / "hardsand_straight_truth.txt")]
    for argv, out, what in (
        (
            ["map", "generate", "--length-m", "60", "--width-m", "120", "-o", str(mission)],
            mission,
            "a map YAML",
        ),
        (calibrate, robot, "a terrain YAML"),
    ):
        before = out.read_bytes()
        assert main(argv) == 2
        assert capsys.readouterr().err == (
            f"swarm: error: command line: --out: found '{out}', expected a new file or {what} to replace"
            " (this is not one)\n"
        )
        assert out.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mission.yaml", "robot.yaml"]


def test_a_report_is_written_only_as_a_report(tmp_path, capsys) -> None:
    """`swarm report DIR -o DIR/plan.json` replaced the plan it reported, `-o x.pdf` wrote HTML."""
    out = tmp_path / "plan"
    assert main(["plan", str(REPO / "missions" / "landing.yaml"), "--out", str(out)]) == 0
    capsys.readouterr()
    plan = (out / "plan.json").read_bytes()
    for target, expected in (
        (out / "plan.json", "a new file or report.json, not the folder's plan.json"),
        (tmp_path / "r.pdf", "a file name ending in .html, .htm, .md, .markdown or .json"),
        (tmp_path / "mission.yaml", "a file name ending in .html, .htm, .md, .markdown or .json"),
    ):
        assert main(["report", str(out), "-o", str(target)]) == 2
        assert (
            capsys.readouterr().err
            == f"swarm: error: command line: -o: found '{target}', expected {expected}\n"
        )
    assert (out / "plan.json").read_bytes() == plan
    assert not (tmp_path / "r.pdf").exists() and not (tmp_path / "mission.yaml").exists()
    assert main(["report", str(out), "-o", str(out / "report.json")]) == 0  # its own report, again
    assert main(["report", str(out), "-o", str(out / "landing.md")]) == 0
    assert (out / "landing.md").read_text().startswith("# ")


def test_a_benchmark_option_without_a_benchmark_is_refused(capsys) -> None:
    """`swarm path MAP --from --to --runs 5` planned once and ignored --runs."""
    argv = ["path", str(REPO / "maps" / "test_small.yaml"), "--from", "20,52", "--to", "55,52", "--runs", "5"]
    assert main(argv) == 2
    assert capsys.readouterr().err == (
        "swarm: error: command line: --runs: found '5', expected --benchmark P1.yaml,P2.yaml with it\n"
    )
