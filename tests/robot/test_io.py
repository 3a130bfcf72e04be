"""Tests for the thesis file readers/writers: exact errors, documented repairs, round trips."""

from __future__ import annotations

import dataclasses
import math
import os
import re
from importlib.resources import files
from pathlib import Path

import numpy as np
import pytest

from swarm.errors import InputError
from swarm.robot import io
from swarm.robot.io import (
    MAX_TICKS_PER_SAMPLE,
    EncoderLog,
    SimExport,
    Truth,
    read_encoders,
    read_ssv,
    read_truth,
    wheel_angles,
    wheel_speeds,
    write_encoders,
    write_ssv,
    write_truth,
)

RUNS = files("swarm") / "data" / "robot-runs"
TICKS_PER_REV = 98 * 20


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def assert_names(exc: pytest.ExceptionInfo[InputError], path: Path, line: int) -> InputError:
    """The message must name the file and the exact 1-based line."""
    err = exc.value
    message = str(err)
    assert str(path) in message
    assert re.search(rf"\bline {line}\b", message), message
    assert err.source == str(path)
    assert re.match(rf"line {line}\b", err.where), err.where
    return err


def enc_text(rows: list[tuple[float, int, int]]) -> str:
    return "".join(f"{t}\t{left}\t{right}\n" for t, left, right in rows)


# ---------------------------------------------------------------------------------------------
# Bundled samples


@pytest.mark.parametrize(
    ("name", "count"),
    [
        ("concrete_straight_encoders.txt", 212),
        ("hardsand_straight_encoders.txt", 212),
        ("softsand_straight_encoders.txt", 212),
        ("concrete_square_encoders.txt", 982),
        ("hardsand_square_encoders.txt", 982),
    ],
)
def test_bundled_encoders_counts(name: str, count: int) -> None:
    log = read_encoders(RUNS / name)
    assert len(log.t_s) == len(log.left_ticks) == len(log.right_ticks) == count
    assert log.t_s[0] == 0.0
    assert np.all(np.diff(log.t_s) > 0)
    assert log.source.endswith(name)


def test_bundled_encoder_values() -> None:
    log = read_encoders(RUNS / "concrete_straight_encoders.txt")
    assert log.t_s[-1] == pytest.approx(5.582)
    assert log.left_ticks[-1] == 7112 and log.right_ticks[-1] == 7112
    # A 16-bit declaration changes nothing on a log that never wraps.
    wide = read_encoders(RUNS / "concrete_square_encoders.txt", counter_bits=16)
    plain = read_encoders(RUNS / "concrete_square_encoders.txt")
    np.testing.assert_array_equal(wide.right_ticks, plain.right_ticks)
    assert plain.right_ticks[-1] == 52899


@pytest.mark.parametrize(
    ("stem", "count"),
    [
        ("concrete_straight", 561),
        ("hardsand_straight", 561),
        ("softsand_straight", 561),
        ("concrete_square", 2601),
        ("hardsand_square", 2601),
    ],
)
def test_bundled_truth_and_ssv_counts(stem: str, count: int) -> None:
    truth = read_truth(RUNS / f"{stem}_truth.txt")
    sim = read_ssv(RUNS / f"{stem}.ssv")
    assert len(truth.t_s) == len(truth.heading_rad) == count
    assert len(sim.t_s) == len(sim.y_m) == count
    assert truth.x_m[0] == 0.0 and truth.y_m[0] == 0.0
    assert np.max(np.abs(np.diff(truth.heading_rad))) < math.pi
    assert np.max(np.abs(np.diff(sim.heading_rad))) < math.pi


def test_bundled_square_heading_is_unwrapped() -> None:
    # The square starts at heading pi and turns four times ~90 degrees counter-clockwise: one full
    # turn. The file wraps the last heading to -3.09; unwrapped it is that plus two full turns.
    truth = read_truth(RUNS / "concrete_square_truth.txt")
    assert truth.heading_rad[0] == pytest.approx(3.1416)
    assert truth.heading_rad[-1] == pytest.approx(-3.0929 + 4 * math.pi)
    assert truth.heading_rad[-1] - truth.heading_rad[0] == pytest.approx(2 * math.pi, abs=0.1)
    sim = read_ssv(RUNS / "concrete_square.ssv")
    assert sim.heading_rad[-1] == pytest.approx(-3.09289 + 4 * math.pi)


def test_bundled_encoder_file_rewrites_byte_for_byte(tmp_path: Path) -> None:
    source = RUNS / "concrete_square_encoders.txt"
    log = read_encoders(source)
    out = tmp_path / "copy_encoders.txt"
    write_encoders(out, log.t_s, log.left_ticks, log.right_ticks)
    assert out.read_bytes() == source.read_bytes()


# ---------------------------------------------------------------------------------------------
# Wheel speeds and angles


def test_wheel_speeds_constant_rate_equals_two_pi_rate(tmp_path: Path) -> None:
    left_rate, right_rate = 2.0, -1.0  # rev/s: 98 and -49 ticks per 25 ms sample, exactly
    dt_ms = 25
    rows = [
        (
            k * dt_ms,
            round(left_rate * TICKS_PER_REV * k * dt_ms / 1000),
            round(right_rate * TICKS_PER_REV * k * dt_ms / 1000),
        )
        for k in range(200)
    ]
    log = read_encoders(write(tmp_path, "const.txt", enc_text(rows)))
    speeds = wheel_speeds(log, TICKS_PER_REV)
    assert speeds.left_radps[0] == 0.0 and speeds.right_radps[0] == 0.0
    np.testing.assert_allclose(speeds.left_radps[1:], 2 * math.pi * left_rate, rtol=1e-12)
    np.testing.assert_allclose(speeds.right_radps[1:], 2 * math.pi * right_rate, rtol=1e-12)
    np.testing.assert_array_equal(speeds.t_s, log.t_s)


def test_wheel_speeds_follow_fig_3_7_on_jittered_samples(tmp_path: Path) -> None:
    log = read_encoders(write(tmp_path, "jitter.txt", "0\t10\t0\n26\t59\t-20\n53\t110\t-20\n"))
    speeds = wheel_speeds(log, 1960)
    expected_left = [0.0, 2 * math.pi * (49 / 1960) / 0.026, 2 * math.pi * (51 / 1960) / 0.027]
    expected_right = [0.0, 2 * math.pi * (-20 / 1960) / 0.026, 0.0]
    np.testing.assert_allclose(speeds.left_radps, expected_left, rtol=1e-12)
    np.testing.assert_allclose(speeds.right_radps, expected_right, rtol=1e-12, atol=1e-12)


def test_wheel_angles_start_at_zero_and_match_speeds() -> None:
    log = read_encoders(RUNS / "concrete_square_encoders.txt")
    t, left, right = wheel_angles(log, TICKS_PER_REV)
    assert left[0] == 0.0 and right[0] == 0.0
    assert left[-1] == pytest.approx(2 * math.pi * 32076 / TICKS_PER_REV)
    assert right[-1] == pytest.approx(2 * math.pi * 52899 / TICKS_PER_REV)
    speeds = wheel_speeds(log, TICKS_PER_REV)
    np.testing.assert_allclose(np.diff(left) / np.diff(t), speeds.left_radps[1:], rtol=1e-9)
    np.testing.assert_allclose(np.diff(right) / np.diff(t), speeds.right_radps[1:], rtol=1e-9)


@pytest.mark.parametrize("bad", [0, -1960, 19.6, True, "1960"])
def test_wheel_speeds_reject_bad_ticks_per_rev(bad: object) -> None:
    log = EncoderLog([0.0, 0.1], [0, 10], [0, 10], source="mem")
    with pytest.raises(InputError, match="ticks_per_rev"):
        wheel_speeds(log, bad)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="ticks_per_rev"):
        wheel_angles(log, bad)  # type: ignore[arg-type]


# ---------------------------------------------------------------------------------------------
# Malformed input: each names the file and the physical line


@pytest.mark.parametrize(
    ("reader", "text", "line", "fragment"),
    [
        (read_encoders, "0\t0\t0\n26\t1\n52\t2\t2\n", 2, "3 whitespace-separated numbers"),
        (read_encoders, "0\t0\t0\n26\t1\t1\t7\n", 2, "got 4 fields"),
        (read_encoders, "0\t0\t0\n26\t1\t1\n52\tx\t2\n", 3, "column 2 (left_ticks)"),
        (read_encoders, "0\t0\t0\n26\t1\t1 # trailing\n", 2, "got 5 fields"),
        (read_truth, "0 0 0 0\n0.01 0 0\n", 2, "4 whitespace-separated numbers"),
        (read_truth, "0 0 0 0\n0.01 0 zero 0\n", 2, "column 3 (Y_m)"),
        (read_ssv, "0 0 0 0 0 0\n0.01 0 0 0 0 0\n0.02 0 0 0 0\n", 3, "6 whitespace-separated numbers"),
        (read_ssv, "0 0 0 0 0 0\n0.01 0 0 0,5 0 0\n", 2, "column 4 (heading_rad)"),
    ],
)
def test_malformed_line_names_file_and_line(
    tmp_path: Path, reader, text: str, line: int, fragment: str
) -> None:
    path = write(tmp_path, "bad.txt", text)
    with pytest.raises(InputError) as exc:
        reader(path)
    assert_names(exc, path, line)
    assert fragment in str(exc.value)


@pytest.mark.parametrize("token", ["nan", "NaN", "inf", "-inf", "1e400"])
def test_non_finite_values_name_line_and_column(tmp_path: Path, token: str) -> None:
    path = write(tmp_path, "nan.txt", f"0 0 0 0\n0.01 0 0 0\n0.02 0 {token} 0\n")
    with pytest.raises(InputError) as exc:
        read_truth(path)
    err = assert_names(exc, path, 3)
    assert err.where == "line 3, column 3 (Y_m)"
    assert err.found == token
    assert "finite" in err.expected


def test_non_finite_encoder_tick(tmp_path: Path) -> None:
    path = write(tmp_path, "nan_enc.txt", "0\t0\t0\n26\t1\tnan\n")
    with pytest.raises(InputError) as exc:
        read_encoders(path)
    assert assert_names(exc, path, 2).where == "line 2, column 3 (right_ticks)"


def test_blank_and_comment_lines_are_skipped_and_line_numbers_stay_physical(tmp_path: Path) -> None:
    text = "# encoder log\n\n0\t0\t0\n   \n  # halfway note\n26\t5\t6\n\n52\t10\t12\n"
    path = write(tmp_path, "comments.txt", text)
    log = read_encoders(path)
    np.testing.assert_array_equal(log.t_s, [0.0, 0.026, 0.052])
    np.testing.assert_array_equal(log.left_ticks, [0, 5, 10])
    np.testing.assert_array_equal(log.right_ticks, [0, 6, 12])
    # The same file with a bad line after the comments reports the line as an editor counts it.
    bad = write(tmp_path, "comments_bad.txt", text + "# more\n\n78\t15\n")
    with pytest.raises(InputError) as exc:
        read_encoders(bad)
    assert_names(exc, bad, 11)


def test_crlf_and_spaces_are_accepted(tmp_path: Path) -> None:
    path = tmp_path / "crlf.txt"
    path.write_bytes(b"0.0 1.0 2.0 0.5\r\n0.01  1.5\t2.5 0.6\r\n")
    truth = read_truth(path)
    np.testing.assert_array_equal(truth.x_m, [1.0, 1.5])


@pytest.mark.parametrize(
    ("text", "line", "found"),
    [
        ("", 1, "0 samples"),
        ("# only a comment\n\n", 2, "0 samples"),
        ("0\t0\t0\n", 1, "1 sample"),
        ("# header\n0\t0\t0\n\n", 3, "1 sample"),
        ("0\t0\t0\n0\t0\t0\n", 2, "1 sample"),  # identical repeats collapse to one sample
    ],
)
def test_too_few_samples(tmp_path: Path, text: str, line: int, found: str) -> None:
    path = write(tmp_path, "short.txt", text)
    with pytest.raises(InputError) as exc:
        read_encoders(path)
    err = assert_names(exc, path, line)
    assert err.found == found
    assert "end of file" in err.where


@pytest.mark.parametrize("reader", [read_truth, read_ssv])
def test_too_few_samples_truth_and_ssv(tmp_path: Path, reader) -> None:
    path = write(tmp_path, "empty.txt", "")
    with pytest.raises(InputError) as exc:
        reader(path)
    assert_names(exc, path, 1)


def test_missing_file_and_bad_encoding(tmp_path: Path) -> None:
    missing = tmp_path / "nope.txt"
    with pytest.raises(InputError) as exc:
        read_truth(missing)
    assert str(missing) in str(exc.value) and exc.value.where == "(file)"
    binary = tmp_path / "binary.txt"
    binary.write_bytes(b"0 0 0 0\n0.01 0 0 0\n\xff\xfe 0 0 0\n")
    with pytest.raises(InputError) as exc2:
        read_truth(binary)
    assert_names(exc2, binary, 3)


# ---------------------------------------------------------------------------------------------
# Time order and repeated timestamps


def test_repeated_identical_samples_collapse_to_last(tmp_path: Path) -> None:
    path = write(tmp_path, "dup.txt", "0\t0\t0\n26\t4\t5\n26\t4\t5\n26\t4\t5\n52\t8\t10\n")
    log = read_encoders(path)
    np.testing.assert_array_equal(log.t_s, [0.0, 0.026, 0.052])
    np.testing.assert_array_equal(log.left_ticks, [0, 4, 8])
    speeds = wheel_speeds(log, TICKS_PER_REV)
    assert np.all(np.isfinite(speeds.left_radps))


def test_repeated_timestamp_with_conflicting_ticks(tmp_path: Path) -> None:
    path = write(tmp_path, "conflict.txt", "0\t0\t0\n26\t4\t5\n26\t4\t5\n26\t4\t6\n52\t8\t10\n")
    with pytest.raises(InputError) as exc:
        read_encoders(path)
    err = assert_names(exc, path, 4)
    assert "conflicting" in err.expected and "line 3" in err.expected


@pytest.mark.parametrize("reader", [read_truth, read_ssv])
def test_truth_and_ssv_repeated_timestamps(tmp_path: Path, reader) -> None:
    ncol = 4 if reader is read_truth else 6
    zeros = " 0" * (ncol - 2)
    same = write(tmp_path, "same.txt", f"0 0{zeros}\n0.01 1{zeros}\n0.01 1{zeros}\n0.02 2{zeros}\n")
    assert len(reader(same).t_s) == 3
    clash = write(tmp_path, "clash.txt", f"0 0{zeros}\n0.01 1{zeros}\n0.01 1.5{zeros}\n0.02 2{zeros}\n")
    with pytest.raises(InputError) as exc:
        reader(clash)
    assert "conflicting" in assert_names(exc, clash, 3).expected


@pytest.mark.parametrize(
    ("reader", "text", "line"),
    [
        (read_encoders, "0\t0\t0\n26\t1\t1\n25\t2\t2\n52\t3\t3\n", 3),
        (read_truth, "0 0 0 0\n0.02 0 0 0\n0.01 0 0 0\n", 3),
        (read_ssv, "0 0 0 0 0 0\n0.01 0 0 0 0 0\n0.02 0 0 0 0 0\n0.015 0 0 0 0 0\n", 4),
    ],
)
def test_backwards_time(tmp_path: Path, reader, text: str, line: int) -> None:
    path = write(tmp_path, "back.txt", text)
    with pytest.raises(InputError) as exc:
        reader(path)
    err = assert_names(exc, path, line)
    assert "backwards" in err.expected and f"line {line - 1}" in err.expected


def test_first_problem_in_file_order_is_reported(tmp_path: Path) -> None:
    # A conflict at line 3 comes before a backwards step at line 5.
    path = write(tmp_path, "both.txt", "0 0 0 0\n0.01 0 0 0\n0.01 1 0 0\n0.02 0 0 0\n0.0 0 0 0\n")
    with pytest.raises(InputError) as exc:
        read_truth(path)
    assert "conflicting" in assert_names(exc, path, 3).expected


def test_fractional_ticks_rejected(tmp_path: Path) -> None:
    path = write(tmp_path, "frac.txt", "0\t0\t0\n26\t1.5\t1\n")
    with pytest.raises(InputError) as exc:
        read_encoders(path)
    assert assert_names(exc, path, 2).where == "line 2, column 2 (left_ticks)"


def test_tick_count_past_exact_floats_rejected(tmp_path: Path) -> None:
    """1e30 is a whole float, but no int64: the cast once wrapped it to a jump of 9.2e18 ticks."""
    path = write(tmp_path, "huge.txt", "0\t0\t0\n26\t1\t1\n52\t0\t1e30\n")
    with pytest.raises(InputError) as exc:
        read_encoders(path)
    assert assert_names(exc, path, 3).where == "line 3, column 3 (right_ticks)"
    assert exc.value.found == 1e30


# ---------------------------------------------------------------------------------------------
# Counter wrap-around


def wrapped(true_ticks: np.ndarray, bits: int, signed: bool) -> np.ndarray:
    modulus = 1 << bits
    if signed:
        return (true_ticks + modulus // 2) % modulus - modulus // 2
    return true_ticks % modulus


def synthetic_run(n: int = 3000, seed: int = 7) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Forward-then-reverse wheels with varying steps, long enough to wrap a 16-bit counter."""
    rng = np.random.default_rng(seed)
    t_ms = np.cumsum(rng.integers(24, 29, size=n)) - 24
    left_steps = rng.integers(60, 95, size=n - 1)
    right_steps = rng.integers(-95, 40, size=n - 1)
    left = np.concatenate(([0], np.cumsum(left_steps)))
    right = np.concatenate(([0], np.cumsum(right_steps)))
    return t_ms, left, right


@pytest.mark.parametrize("signed", [False, True])
@pytest.mark.parametrize("bits", [8, 12, 16])
def test_counter_wrap_repair_recovers_true_ticks_exactly(tmp_path: Path, bits: int, signed: bool) -> None:
    t_ms, left, right = synthetic_run()
    raw_left, raw_right = wrapped(left, bits, signed), wrapped(right, bits, signed)
    assert np.any(np.abs(np.diff(raw_left)) > (1 << bits) // 2)  # the log really wraps
    rows = list(zip(t_ms.tolist(), raw_left.tolist(), raw_right.tolist(), strict=True))
    path = write(tmp_path, "wrapped.txt", enc_text(rows))
    log = read_encoders(path, counter_bits=bits)
    np.testing.assert_array_equal(log.left_ticks, left)
    np.testing.assert_array_equal(log.right_ticks, right)
    np.testing.assert_array_equal(log.t_s, t_ms / 1000)


def test_counter_wrap_without_counter_bits_is_an_error_suggesting_it(tmp_path: Path) -> None:
    t_ms, left, right = synthetic_run()
    raw_left = wrapped(left, 16, signed=False)
    first_wrap = int(np.flatnonzero(np.diff(raw_left) < 0)[0]) + 1  # 0-based sample = line - 1
    rows = list(zip(t_ms.tolist(), raw_left.tolist(), right.tolist(), strict=True))
    path = write(tmp_path, "wrapped16.txt", enc_text(rows))
    with pytest.raises(InputError) as exc:
        read_encoders(path)
    err = assert_names(exc, path, first_wrap + 1)
    assert err.where.endswith("column 2 (left_ticks)")
    assert "counter_bits" in str(err)


def test_implausible_jump_even_after_unwrapping(tmp_path: Path) -> None:
    path = write(tmp_path, "jump.txt", "0\t0\t0\n26\t10\t10\n52\t5010\t20\n78\t5020\t30\n")
    for bits in (None, 32):
        with pytest.raises(InputError) as exc:
            read_encoders(path, counter_bits=bits)
        err = assert_names(exc, path, 3)
        assert str(MAX_TICKS_PER_SAMPLE) in err.expected
        assert "5000" in str(err.found)


def test_step_at_the_plausibility_limit_is_accepted(tmp_path: Path) -> None:
    step = MAX_TICKS_PER_SAMPLE
    path = write(tmp_path, "limit.txt", f"0\t0\t0\n26\t{step}\t{-step}\n")
    log = read_encoders(path)
    assert log.left_ticks[1] == step and log.right_ticks[1] == -step


def test_value_outside_declared_counter_range(tmp_path: Path) -> None:
    path = write(tmp_path, "range.txt", "0\t0\t0\n26\t10\t10\n52\t20\t70000\n")
    with pytest.raises(InputError) as exc:
        read_encoders(path, counter_bits=16)
    err = assert_names(exc, path, 3)
    assert err.where == "line 3, column 3 (right_ticks)"
    assert "-32768" in err.expected and "65535" in err.expected


@pytest.mark.parametrize("bits", [0, 1, 54, True, 16.0, "16"])
def test_bad_counter_bits_argument(tmp_path: Path, bits: object) -> None:
    path = write(tmp_path, "ok.txt", "0\t0\t0\n26\t1\t1\n")
    with pytest.raises(InputError, match="counter_bits"):
        read_encoders(path, counter_bits=bits)  # type: ignore[arg-type]


# ---------------------------------------------------------------------------------------------
# Writers and round trips


def test_encoder_round_trip(tmp_path: Path) -> None:
    t_ms, left, right = synthetic_run(n=500)
    path = tmp_path / "rt_encoders.txt"
    write_encoders(path, t_ms / 1000, left, right)
    assert path.read_text().splitlines()[1].count("\t") == 2
    log = read_encoders(path)
    np.testing.assert_array_equal(log.t_s, t_ms / 1000)
    np.testing.assert_array_equal(log.left_ticks, left)
    np.testing.assert_array_equal(log.right_ticks, right)


def test_encoder_round_trip_sub_millisecond_times(tmp_path: Path) -> None:
    t_s = np.array([0.0, 0.0261, 0.05235])
    path = tmp_path / "sub_ms.txt"
    write_encoders(path, t_s, [0, 3, 7], [0, -3, -7])
    np.testing.assert_allclose(read_encoders(path).t_s, t_s, rtol=0, atol=1e-15)


def test_truth_round_trip_exact(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    t = np.arange(300) * 0.01
    truth = Truth(t, rng.normal(size=300), rng.normal(size=300), np.cumsum(rng.normal(0, 0.3, 300)), "mem")
    assert np.max(np.abs(truth.heading_rad)) > math.pi  # unwrapped headings must survive too
    path = tmp_path / "rt_truth.txt"
    write_truth(path, truth)
    back = read_truth(path)
    for field in ("t_s", "x_m", "y_m", "heading_rad"):
        np.testing.assert_array_equal(getattr(back, field), getattr(truth, field))
    assert back.source == str(path)


def test_ssv_round_trip_exact_from_bundled(tmp_path: Path) -> None:
    sim = read_ssv(RUNS / "hardsand_square.ssv")
    path = tmp_path / "rt.ssv"
    write_ssv(path, sim)
    back = read_ssv(path)
    for field in ("t_s", "left_radps", "right_radps", "heading_rad", "x_m", "y_m"):
        np.testing.assert_array_equal(getattr(back, field), getattr(sim, field))
    assert len(path.read_text().splitlines()[0].split(" ")) == 6


def test_write_replaces_atomically_and_leaves_no_temp_files(tmp_path: Path) -> None:
    path = tmp_path / "truth.txt"
    first = Truth([0.0, 0.01], [0.0, 1.0], [0.0, 0.0], [0.0, 0.0])
    second = Truth([0.0, 0.01, 0.02], [0.0, 2.0, 3.0], [0.0, 0.0, 0.0], [0.0, 0.1, 0.2])
    write_truth(path, first)
    write_truth(path, second)
    assert os.listdir(tmp_path) == ["truth.txt"]
    np.testing.assert_array_equal(read_truth(path).x_m, [0.0, 2.0, 3.0])


def test_failed_write_keeps_old_file_and_cleans_up(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "run.ssv"
    sim = SimExport([0.0, 0.01], [1.0, 1.0], [1.0, 1.0], [0.0, 0.0], [0.0, 0.01], [0.0, 0.0])
    write_ssv(path, sim)
    before = path.read_bytes()

    def broken_replace(src: object, dst: object) -> None:
        raise OSError("disk full")

    monkeypatch.setattr(io.os, "replace", broken_replace)
    bigger = SimExport([0.0, 0.01, 0.02], [2.0] * 3, [2.0] * 3, [0.0] * 3, [0.0, 0.02, 0.04], [0.0] * 3)
    with pytest.raises(OSError, match="disk full"):
        write_ssv(path, bigger)
    assert path.read_bytes() == before
    assert os.listdir(tmp_path) == ["run.ssv"]


@pytest.mark.parametrize(
    ("t_s", "left", "right", "message"),
    [
        ([0.0, 0.0], [0, 1], [0, 1], "strictly increase"),
        ([0.0, 0.02, 0.01], [0, 1, 2], [0, 1, 2], "strictly increase"),
        ([0.0, 0.01], [0, 1.5], [0, 1], "whole numbers"),
        ([0.0, 0.01], [0, 1], [0, 1, 2], "samples"),
        ([0.0], [0], [0], "at least 2"),
        ([0.0, float("nan")], [0, 1], [0, 1], "NaN"),
        ([0.0, 1e-10], [0, 1], [0, 1], "same millisecond"),
    ],
)
def test_write_encoders_rejects_what_the_reader_would(
    tmp_path: Path, t_s: list[float], left: list[float], right: list[float], message: str
) -> None:
    path = tmp_path / "never.txt"
    with pytest.raises(ValueError, match=message):
        write_encoders(path, t_s, left, right)
    assert not path.exists()
    assert os.listdir(tmp_path) == []


# ---------------------------------------------------------------------------------------------
# Dataclasses


def test_dataclasses_are_frozen_float64_and_read_only() -> None:
    source_array = np.array([0.0, 1.0])
    truth = Truth(source_array, [0, 1], [0, 1], [0, 1])
    assert truth.y_m.dtype == np.float64
    with pytest.raises(dataclasses.FrozenInstanceError):
        truth.x_m = np.zeros(2)  # type: ignore[misc]
    with pytest.raises(ValueError):
        truth.x_m[0] = 5.0
    source_array[0] = -1.0  # the dataclass holds its own copy
    assert truth.t_s[0] == 0.0
    log = read_encoders(RUNS / "concrete_straight_encoders.txt")
    assert not log.left_ticks.flags.writeable and log.t_s.dtype == np.float64


def test_dataclass_rejects_mismatched_lengths() -> None:
    with pytest.raises(ValueError, match="samples"):
        SimExport([0.0, 1.0], [0, 0], [0, 0], [0, 0], [0, 0], [0, 0, 0])
