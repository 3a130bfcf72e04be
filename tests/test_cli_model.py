"""`swarm model validate|calibrate` end to end, in a subprocess, on the bundled sample runs."""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
from collections.abc import Callable
from importlib.metadata import version
from pathlib import Path

import numpy as np
import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
RUNS = ROOT / "swarm" / "data" / "robot-runs"
ROBOT = ROOT / "swarm" / "data" / "robots" / "skid4.yaml"
SCORE_KEYS = ("model", "distance_m", "final_error_m", "path_rmse_m", "heading_rmse_deg")
MODELS = {"skid", "kinematic", "lagrangian"}


def swarm(
    *args: object, cwd: Path | None = None, exe: list[str] | None = None
) -> subprocess.CompletedProcess:
    env = os.environ | {"MPLBACKEND": "Agg"}
    command = (exe or [sys.executable, "-m", "swarm.cli"]) + [str(a) for a in args]
    return subprocess.run(command, capture_output=True, text=True, timeout=120, cwd=cwd, env=env)


def encoders(run: str) -> Path:
    return RUNS / f"{run}_encoders.txt"


def truth(run: str) -> Path:
    return RUNS / f"{run}_truth.txt"


def run_args(run: str) -> list[object]:
    return ["--robot", ROBOT, "--encoders", encoders(run), "--truth", truth(run)]


def validate_json(*args: object) -> dict:
    result = swarm("model", "validate", *args, "--json")
    assert result.returncode == 0, result.stderr
    out = json.loads(result.stdout)  # the whole of stdout is one JSON object
    assert isinstance(out, dict)
    return out


def path_length(x: np.ndarray, y: np.ndarray) -> float:
    return float(np.sum(np.sqrt(np.diff(x) ** 2 + np.diff(y) ** 2)))


def check_score(score: dict, model: str) -> None:
    assert score["model"] == model
    for key in SCORE_KEYS[1:]:
        assert isinstance(score[key], float | int), key
        assert math.isfinite(score[key]), key
        assert score[key] >= 0, key


# --- validate --------------------------------------------------------------------------------


def test_validate_json_kinematic_on_straight_run():
    out = validate_json(*run_args("concrete_straight"), "--model", "kinematic")
    assert set(SCORE_KEYS) <= set(out)
    check_score(out, "kinematic")
    assert "compare" not in out
    ref = np.loadtxt(truth("concrete_straight"))
    assert out["distance_m"] == pytest.approx(path_length(ref[:, 1], ref[:, 2]), abs=1e-5)
    # A straight 2.5 m run on concrete: dead reckoning from the encoders stays within 10 cm.
    assert out["final_error_m"] < 0.1
    assert out["path_rmse_m"] < 0.1
    # RMSE over the run cannot exceed the largest error seen.
    assert out["path_rmse_m"] <= out["max_error_m"] + 1e-9


def test_validate_from_ssv_export():
    ssv = RUNS / "concrete_straight.ssv"
    out = validate_json("--robot", ROBOT, "--ssv", ssv, "--model", "kinematic")
    check_score(out, "kinematic")
    cols = np.loadtxt(ssv)  # t left right heading X Y
    assert out["distance_m"] == pytest.approx(path_length(cols[:, 4], cols[:, 5]), abs=1e-5)
    assert out["final_error_m"] < 0.1
    assert out["duration_s"] == pytest.approx(cols[-1, 0] - cols[0, 0], abs=0.05)


def test_validate_scores_every_run_it_is_given(tmp_path):
    """Several runs (as calibrate takes them) are each scored, each the same as alone; a figure or
    a report is one run's, so with several runs it is refused in one line."""
    both = ["--ssv", RUNS / "concrete_straight.ssv", "--ssv", RUNS / "hardsand_square.ssv"]
    out = validate_json("--robot", ROBOT, *both, "--model", "kinematic")
    alone = [
        validate_json("--robot", ROBOT, "--ssv", RUNS / f"{r}.ssv", "--model", "kinematic")
        for r in ("concrete_straight", "hardsand_square")
    ]
    assert out["runs"] == alone
    refused = swarm("model", "validate", "--robot", ROBOT, *both, "--out", tmp_path / "v")
    assert refused.returncode == 2 and refused.stderr.count("\n") == 1, refused.stderr
    assert "--out: found '2 runs', expected one run for its report" in refused.stderr
    assert not (tmp_path / "v").exists()


@pytest.mark.slow
def test_validate_compare_scores_the_other_two_models():
    out = validate_json(*run_args("concrete_straight"), "--compare")  # default model: skid
    check_score(out, "skid")
    compare = out["compare"]
    assert isinstance(compare, list)
    assert len(compare) == 2
    assert {c["model"] for c in compare} == MODELS - {"skid"}
    for c in compare:
        check_score(c, c["model"])
        assert c["distance_m"] == out["distance_m"]  # same run, same reference
        assert c["final_error_m"] < 0.1  # every model should manage a straight line on concrete
    assert out["final_error_m"] < 0.1


@pytest.mark.slow
def test_validate_plot_writes_png_and_no_temp_files(tmp_path):
    import matplotlib.image as mpimg

    fig = tmp_path / "FIG.png"
    result = swarm(
        "model", "validate", *run_args("concrete_straight"), "--model", "lagrangian", "--plot", fig
    )
    assert result.returncode == 0, result.stderr
    assert str(fig) in result.stdout
    assert "lagrangian" in result.stdout
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    image = mpimg.imread(fig)
    assert image.ndim == 3
    assert image.shape[0] > 200
    assert image.shape[1] > 400
    assert image.shape[1] > image.shape[0]  # the overlay is landscape: path left, time series right
    assert np.ptp(image[..., :3]) > 0  # something was drawn
    assert sorted(p.name for p in tmp_path.iterdir()) == ["FIG.png"]


def test_validate_table_output():
    result = swarm("model", "validate", *run_args("concrete_straight"), "--model", "kinematic")
    assert result.returncode == 0, result.stderr
    assert "terrain mode: concrete" in result.stdout
    assert "concrete_straight" in result.stdout
    assert "path RMSE" in result.stdout


# --- bad input: one line on stderr, exit 2, no traceback ---------------------------------------


def _missing_encoders(tmp_path: Path) -> tuple[list[object], list[str]]:
    missing = tmp_path / "no_such_encoders.txt"
    return ["--robot", ROBOT, "--encoders", missing, "--truth", truth("concrete_straight")], [str(missing)]


def _malformed_encoder_line(tmp_path: Path) -> tuple[list[object], list[str]]:
    lines = encoders("concrete_straight").read_text().splitlines()
    lines[6] = lines[6].split()[0] + " 12 twelve"  # physical line 7
    bad = tmp_path / "bad_encoders.txt"
    bad.write_text("\n".join(lines) + "\n")
    return ["--robot", ROBOT, "--encoders", bad, "--truth", truth("concrete_straight")], [
        str(bad),
        "line 7",
    ]


def _negative_mass(tmp_path: Path) -> tuple[list[object], list[str]]:
    data = yaml.safe_load(ROBOT.read_text()) | {"mass_kg": -30.0}
    robot = tmp_path / "robot.yaml"
    robot.write_text(yaml.safe_dump(data))
    args = [
        "--robot",
        robot,
        "--encoders",
        encoders("concrete_straight"),
        "--truth",
        truth("concrete_straight"),
    ]
    return args, [str(robot), "mass_kg"]


def _track_wider_than_a_vehicle(tmp_path: Path) -> tuple[list[object], list[str]]:
    """1e30 m once reached the planner, whose footprint in cells overflowed a C long."""
    data = yaml.safe_load(ROBOT.read_text()) | {"track_width_m": 1e30}
    robot = tmp_path / "robot.yaml"
    robot.write_text(yaml.safe_dump(data))
    runs = ["--encoders", encoders("concrete_straight"), "--truth", truth("concrete_straight")]
    return ["--robot", robot, *runs], [str(robot), "track_width_m", "<= 20"]


def _centre_of_mass_off_the_wheels(tmp_path: Path) -> tuple[list[object], list[str]]:
    data = yaml.safe_load(ROBOT.read_text()) | {"com_x_m": -0.2}
    robot = tmp_path / "robot.yaml"
    robot.write_text(yaml.safe_dump(data))
    args = [
        "--robot",
        robot,
        "--encoders",
        encoders("concrete_straight"),
        "--truth",
        truth("concrete_straight"),
    ]
    return args, [str(robot), "com_x_m", "within +-0.15 m"]


def _zero_fixed_step(tmp_path: Path) -> tuple[list[object], list[str]]:
    return [*run_args("concrete_straight"), "--fixed-step", "0"], ["--fixed-step", "[0.0001, 0.1]"]


def _tiny_fixed_step(tmp_path: Path) -> tuple[list[object], list[str]]:
    """A step so fine its arrays would not fit in memory (1e-12 s asked numpy for 189 TiB)."""
    return [*run_args("concrete_straight"), "--fixed-step", "1e-12"], ["--fixed-step", "[0.0001, 0.1]"]


def _encoders_without_truth(tmp_path: Path) -> tuple[list[object], list[str]]:
    return ["--robot", ROBOT, "--encoders", encoders("concrete_straight")], ["--truth"]


def _unknown_mode(tmp_path: Path) -> tuple[list[object], list[str]]:
    return [*run_args("concrete_straight"), "--mode", "lava"], ["--mode", "lava"]


def _bad_terrain_value(tmp_path: Path) -> tuple[list[object], list[str]]:
    terrain = tmp_path / "terrain.yaml"
    terrain.write_text("modes:\n  concrete:\n    mu_peak: 7.5\n")
    return [*run_args("concrete_straight"), "--terrain", terrain], [str(terrain), "modes.concrete.mu_peak"]


def _ssv_with_encoders(tmp_path: Path) -> tuple[list[object], list[str]]:
    return [*run_args("concrete_straight"), "--ssv", RUNS / "concrete_straight.ssv"], ["--ssv"]


def _mismatched_runs(tmp_path: Path) -> tuple[list[object], list[str]]:
    args = [
        "--robot",
        ROBOT,
        "--encoders",
        encoders("concrete_straight"),
        "--truth",
        truth("concrete_square"),
    ]
    return args, [str(truth("concrete_square"))]


def _truth_in_millimetres(tmp_path: Path) -> tuple[list[object], list[str]]:
    """A reference in mm travels 1000 times what the wheels rolled: refused, not calibrated."""
    mm = tmp_path / "mm_truth.txt"
    rows = np.loadtxt(truth("concrete_straight"))
    rows[:, 1:3] *= 1000.0
    np.savetxt(mm, rows, fmt="%.4f")
    args = ["--robot", ROBOT, "--encoders", encoders("concrete_straight"), "--truth", mm]
    return args, [str(mm), "path length", "2495.66 m", "the 2.51 m the wheels rolled", "in metres?"]


def _step_without_the_skid_model(tmp_path: Path) -> tuple[list[object], list[str]]:
    """--fixed-step steers the skid model's integration: with the kinematic model alone it was
    silently ignored."""
    args = [*run_args("concrete_straight"), "--model", "kinematic", "--fixed-step", "0.01"]
    return args, ["--fixed-step", "--model kinematic", "with the skid model"]


def _truth_offset_not_a_number(tmp_path: Path) -> tuple[list[object], list[str]]:
    return [*run_args("concrete_straight"), "--truth-offset", "soon"], ["--truth-offset", "'soon'", "or auto"]


def _truth_offset_past_the_log(tmp_path: Path) -> tuple[list[object], list[str]]:
    """Shifted by more than the run lasts, the two logs share no time: nothing to score."""
    args = [*run_args("concrete_straight"), "--truth-offset", "-9"]
    return args, [str(truth("concrete_straight")), "truth offset", "-9 s", "logs overlap"]


@pytest.mark.parametrize(
    "case",
    [
        _truth_offset_not_a_number,
        _truth_offset_past_the_log,
        _step_without_the_skid_model,
        _truth_in_millimetres,
        _missing_encoders,
        _malformed_encoder_line,
        _negative_mass,
        _track_wider_than_a_vehicle,
        _centre_of_mass_off_the_wheels,
        _zero_fixed_step,
        _tiny_fixed_step,
        _encoders_without_truth,
        _unknown_mode,
        _bad_terrain_value,
        _ssv_with_encoders,
        _mismatched_runs,
    ],
    ids=lambda f: f.__name__.strip("_"),
)
def test_bad_input_is_one_line_and_exit_2(tmp_path, case: Callable):
    args, named = case(tmp_path)
    before = sorted(tmp_path.iterdir())
    result = swarm("model", "validate", *args, "--json", "--plot", tmp_path / "fig.png")
    assert result.returncode == 2, (result.stdout, result.stderr)
    assert "Traceback" not in result.stderr + result.stdout
    lines = result.stderr.splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("swarm: error:")
    for text in named:
        assert text in lines[0], (text, lines[0])
    assert result.stdout == ""
    assert sorted(tmp_path.iterdir()) == before  # no figure, nothing half-written


def test_a_reference_started_late_is_warned_about_and_aligned_with_auto(tmp_path):
    """A motion-capture log started 0.5 s after the encoder log: by default one warning naming it
    and the offset its speeds give (the logs are still taken to start together); with
    --truth-offset auto (or the offset in seconds) it scores as the run recorded together. A run
    recorded together gets no warning."""
    late = tmp_path / "late_truth.txt"
    rows = np.loadtxt(truth("concrete_straight"))
    rows = rows[rows[:, 0] >= 0.5]
    rows[:, 0] -= rows[0, 0]
    np.savetxt(late, rows, fmt="%.4f")
    terrain = ROOT / "swarm" / "data" / "terrain" / "skid4-concrete.yaml"
    args = ["model", "validate", "--robot", ROBOT, "--encoders", encoders("concrete_straight"), "--json"]
    args += ["--terrain", terrain]
    together = swarm(*args, "--truth", truth("concrete_straight"))
    assert together.returncode == 0 and together.stderr == "", together.stderr
    plain = swarm(*args, "--truth", late)
    warnings = [line for line in plain.stderr.splitlines() if line.startswith("warning:")]
    assert plain.returncode == 0 and len(warnings) == 1, plain.stderr
    assert str(late) in warnings[0] and "+0.49 s" in warnings[0] and "--truth-offset" in warnings[0]
    want = json.loads(together.stdout)["path_rmse_pct"]
    assert json.loads(plain.stdout)["path_rmse_pct"] > want + 5.0
    for offset in ("auto", "0.5"):
        aligned = swarm(*args, "--truth", late, "--truth-offset", offset)
        assert aligned.returncode == 0 and "warning" not in aligned.stderr, aligned.stderr
        assert json.loads(aligned.stdout)["path_rmse_pct"] == pytest.approx(want, abs=0.2)


def test_argparse_errors_exit_2_without_traceback():
    result = swarm("model", "validate", "--encoders", encoders("concrete_straight"))  # no --robot
    assert result.returncode == 2
    assert "--robot" in result.stderr
    assert "Traceback" not in result.stderr
    result = swarm("model", "validate", *run_args("concrete_straight"), "--model", "bicycle")
    assert result.returncode == 2
    assert "--model" in result.stderr
    assert "Traceback" not in result.stderr


# --- calibrate -> validate round trip -----------------------------------------------------------


@pytest.mark.slow
def test_calibrate_then_validate_round_trip(tmp_path):
    from swarm.robot.terrain import load_library

    out = tmp_path / "c.yaml"
    result = swarm("model", "calibrate", "--model", "kinematic", *run_args("concrete_square"), "--out", out)
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.yaml"]  # no temp file left behind
    # with no --mode, the mode it starts from is said, and why, in the output and on stderr
    assert "fitted from terrain mode 'concrete' (the default: no --mode given" in result.stdout
    assert "starting from terrain mode 'concrete' (the default" in result.stderr

    doc = yaml.safe_load(out.read_text())
    (name,) = doc["modes"]
    assert name == "concrete"
    fitted = doc["modes"][name]["kinematic"]
    assert set(fitted) == {"alpha", "chi"}
    assert all(isinstance(v, float) and math.isfinite(v) and v > 0 for v in fitted.values())
    # Skid steering turns less than the two-wheel geometry says: the effective track is wider.
    assert fitted["chi"] > 1.0

    library = load_library(out)
    assert {k: pytest.approx(v) for k, v in library[name].model_params["kinematic"].items()} == fitted
    assert "soft_sand" in list(library)  # the defaults are still there beside the fitted mode

    plain = validate_json(*run_args("concrete_square"), "--model", "kinematic")
    tuned = validate_json(*run_args("concrete_square"), "--model", "kinematic", "--terrain", out)
    assert tuned["distance_m"] == plain["distance_m"]
    assert tuned["path_rmse_m"] < plain["path_rmse_m"]
    assert tuned["heading_rmse_deg"] < plain["heading_rmse_deg"]


def test_calibrate_rejects_unknown_free_parameter_and_writes_nothing(tmp_path):
    out = tmp_path / "c.yaml"
    result = swarm(
        "model",
        "calibrate",
        "--model",
        "kinematic",
        *run_args("concrete_straight"),
        "--free",
        "alpha,beta",
        "--out",
        out,
    )
    assert result.returncode == 2
    lines = result.stderr.splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("swarm: error:")
    assert "--free" in lines[0]
    assert "beta" in lines[0]
    assert not any(tmp_path.iterdir())


# --- version and help ----------------------------------------------------------------------------


def test_console_script_version():
    script = shutil.which("swarm") or str(Path(sys.executable).with_name("swarm"))
    assert Path(script).exists()
    result = swarm("--version", exe=[script])
    assert result.returncode == 0
    assert version("surf-swarm") in result.stdout
    assert result.stdout.startswith("surf-swarm ")


def test_module_version_and_help():
    result = swarm("--version")
    assert result.returncode == 0
    assert result.stdout.strip() == f"surf-swarm {version('surf-swarm')}"
    result = swarm("model", "validate", "--help")
    assert result.returncode == 0
    for option in ("--robot", "--encoders", "--truth", "--ssv", "--model", "--compare", "--json", "--plot"):
        assert option in result.stdout


def test_calibrate_into_a_folder_it_cannot_write_is_refused_before_the_fit(tmp_path):
    """The write was tried after the fit (a minute of it); a trial file is made first now."""
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        try:
            (locked / "probe").touch()  # root may: then /proc, where nobody makes a file
            (locked / "probe").unlink()
            target = Path("/proc/fit.yaml")
        except PermissionError:
            target = locked / "fit.yaml"
        result = swarm("model", "calibrate", *run_args("concrete_square"), "--out", target)
    finally:
        locked.chmod(0o700)
    assert result.returncode == 2
    assert result.stderr.startswith(
        f"swarm: error: command line: --out: found '{target}', expected a file in a"
    )
    assert "fitting" not in result.stderr  # it never started


def test_calibrate_refuses_an_empty_mode_name(tmp_path):
    """A mode named '' could not be chosen again: validate took its file's only mode as concrete."""
    out = tmp_path / "fit.yaml"
    args = [*run_args("concrete_straight"), "--model", "kinematic", "--name", "", "--out", out]
    result = swarm("model", "calibrate", *args)
    assert result.returncode == 2 and len(result.stderr.splitlines()) == 1, result.stderr
    assert "--name: found '', expected a non-empty terrain mode name" in result.stderr
    assert not out.exists()


def _still_run(tmp_path: Path) -> list[object]:
    """A run that stands still for 5 s: it travels no distance."""
    enc, ref = tmp_path / "still_encoders.txt", tmp_path / "still_truth.txt"
    enc.write_text("".join(f"{ms}\t0\t0\n" for ms in range(0, 5000, 25)))
    ref.write_text("".join(f"{t / 100:.4f} 1.0000 2.0000 0.5000\n" for t in range(500)))
    return ["--encoders", enc, "--truth", ref]


def test_a_run_that_goes_nowhere_has_no_verdict_and_valid_json(tmp_path):
    """Standing still (or a pivot in place) travels no distance: its RMSE is no share of one. The
    JSON says null (bare NaN is not JSON), the report says there is no verdict."""
    args = ["--robot", ROBOT, *_still_run(tmp_path)]
    result = swarm("model", "validate", *args, "--json")
    assert result.returncode == 0, result.stderr
    out = json.loads(result.stdout, parse_constant=lambda c: pytest.fail(f"bare {c} in the JSON"))
    assert out["distance_m"] == 0.0 and out["path_rmse_pct"] is None
    result = swarm("model", "validate", *args, "--out", tmp_path / "v")
    assert result.returncode == 0, result.stderr
    report = (tmp_path / "v" / "report.md").read_text()
    assert "NO VERDICT on the accuracy target" in report and "nan" not in report.lower()


def test_calibrate_with_a_run_that_goes_nowhere_writes_null_and_says_no_verdict(tmp_path):
    """Calibrate scored such a run as validate does, but wrote `.nan` into its YAML and printed
    "nan": the YAML says null, the table "n/a" and a line says there is no verdict for that run."""
    out = tmp_path / "fit.yaml"
    args = [*run_args("concrete_straight"), *_still_run(tmp_path), "--model", "kinematic", "--out", out]
    result = swarm("model", "calibrate", *args)
    assert result.returncode == 0, result.stderr
    assert "nan" not in out.read_text().lower()
    scores = yaml.safe_load(out.read_text())["fitted"]["path_rmse_pct"]
    assert scores["still"] == {"before": None, "after": None}
    assert all(isinstance(v, float) for v in scores["concrete_straight"].values())
    assert "nan" not in result.stdout.lower()
    still_rows = [line.split() for line in result.stdout.splitlines() if line.split()[2:3] == ["still"]]
    assert len(still_rows) == 2 and all(row[-2] == "n/a" for row in still_rows)
    assert "still: no verdict (RMSE % dist n/a)" in result.stdout


def test_calibrate_that_runs_out_of_evaluations_says_so(tmp_path):
    """A fit stopped by --max-evaluations (scipy's status 0) was reported as if it had converged:
    one warning line names the flag and the budget, and the YAML's warnings keep it."""
    out = tmp_path / "fit.yaml"
    args = [*run_args("concrete_straight"), "--model", "kinematic", "--out", out]
    result = swarm("model", "calibrate", *args, "--max-evaluations", "2")
    assert result.returncode == 0, result.stderr
    expected = "calibration stopped at --max-evaluations 2 before converging; the fit may be poor"
    warnings = [line for line in result.stderr.splitlines() if line.startswith("warning:")]
    assert len(warnings) == 1 and expected in warnings[0], result.stderr
    assert [w for w in yaml.safe_load(out.read_text())["fitted"]["warnings"] if expected in w]
    converged = swarm("model", "calibrate", *args)  # the default budget: it converges, no warning
    assert converged.returncode == 0 and "warning:" not in converged.stderr, converged.stderr
    assert yaml.safe_load(out.read_text())["fitted"]["warnings"] == []
