"""Readers and writers for the thesis's robot-run files (section 3.3, Figs. 3.6-3.7).

Three plain-text formats, one sample per line, whitespace-separated (tabs or spaces):

- encoder log ``time_ms left_ticks right_ticks`` (~38 Hz), the robot's own record;
- motion-capture truth ``t_s X_m Y_m heading_rad`` (100 Hz), what the models are scored against;
- simulation export ``.ssv``: ``t_s left_radps right_radps heading_rad X_m Y_m``.

Why the care: every model and calibration downstream differentiates or integrates these
columns, so a silently wrong sample (a wrapped counter, a time going backwards, a NaN) turns
into a wrong coefficient rather than a crash. Each data problem therefore either raises
`swarm.errors.InputError` naming the file and the 1-based physical line, or is repaired by a
documented rule:

- blank lines and lines whose first non-blank character is ``#`` are skipped (trailing
  ``#`` comments after numbers are not: such a line has the wrong column count);
- a run of lines with the same timestamp is collapsed to its last line, but only if every
  value on those lines is identical (a logger that wrote the same sample twice); if any
  value differs the samples conflict and nothing can say which is right, so it is an error;
- encoder counter wrap-around is unwrapped only when the caller says how wide the counter is
  (``counter_bits``); otherwise a jump that no wheel could make in one sample is an error
  that suggests ``counter_bits`` (see `MAX_TICKS_PER_SAMPLE`).

Parsing uses numpy's C reader on the non-comment lines; only when that fails is the text
re-read line by line in Python, so errors still name the exact line.

Writers put the text in a temporary file beside the target and `os.replace` it into place,
so a reader never sees a half-written run.
"""

from __future__ import annotations

import operator
import os
from dataclasses import dataclass
from importlib.resources.abc import Traversable
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from swarm.errors import InputError
from swarm.files import write_text_atomic

__all__ = [
    "ENCODER_COLUMNS",
    "MAX_TICKS_PER_SAMPLE",
    "SSV_COLUMNS",
    "TRUTH_COLUMNS",
    "EncoderLog",
    "SimExport",
    "Truth",
    "WheelSpeeds",
    "read_encoders",
    "read_ssv",
    "read_truth",
    "wheel_angles",
    "wheel_speeds",
    "write_encoders",
    "write_ssv",
    "write_truth",
]

FloatArray = NDArray[np.float64]
PathIn = str | os.PathLike[str] | Traversable

ENCODER_COLUMNS = ("time_ms", "left_ticks", "right_ticks")
TRUTH_COLUMNS = ("t_s", "X_m", "Y_m", "heading_rad")
SSV_COLUMNS = ("t_s", "left_wheel_rad_per_s", "right_wheel_rad_per_s", "heading_rad", "X_m", "Y_m")

MAX_TICKS_PER_SAMPLE = 2048
#: The largest tick count a log may hold: 2**53, past which a float64 skips whole numbers.
MAX_TICK_COUNT = 2**53
"""Largest believable change of one wheel's tick count between consecutive encoder samples.

Why this number: at the thesis's 98 x 20 = 1960 ticks per wheel revolution and ~26 ms per
sample, 200 rad/s of wheel speed (22 m/s on a 0.11 m wheel, far beyond the robot) is about
1,620 ticks per sample; the bundled runs never exceed ~95. A counter of n bits that wraps shows
up as a jump of 2**n minus the true step, which is above 2048 for every counter of 12 bits or
more, so without ``counter_bits`` such a wrap is caught rather than read as a huge speed.
Narrower counters must be declared with ``counter_bits``. A long gap in a log of a fast-moving
robot can also trip this limit; the error message says so.
"""

_MAX_COUNTER_BITS = 53  # float64 holds every integer up to 2**53 exactly


def _as_column(name: str, value: ArrayLike) -> FloatArray:
    """A private, read-only float64 copy, so a frozen dataclass cannot change under its owner."""
    arr = np.array(value, dtype=np.float64)
    if arr.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {arr.shape}")
    arr.flags.writeable = False
    return arr


def _freeze_columns(obj: object, names: tuple[str, ...]) -> None:
    """Convert, check and freeze the array fields the readers would also insist on."""
    for name in names:
        object.__setattr__(obj, name, _as_column(name, getattr(obj, name)))
    columns = [getattr(obj, name) for name in names]
    n = len(columns[0])
    for name, col in zip(names, columns, strict=True):
        if len(col) != n:
            raise ValueError(f"{name} has {len(col)} samples but {names[0]} has {n}")
        if not np.all(np.isfinite(col)):
            raise ValueError(f"{name} has NaN or infinite values")
    if n < 2:
        raise ValueError(f"need at least 2 samples, got {n}")
    if not np.all(np.diff(columns[0]) > 0):
        raise ValueError(f"{names[0]} must strictly increase")


@dataclass(frozen=True, eq=False)
class EncoderLog:
    """Encoder ticks per wheel against time: the robot's only record of what its wheels did.

    ``t_s`` is the log's ``time_ms`` / 1000, not rebased to zero. Ticks are whole numbers stored
    as float64, already unwrapped if the counter wrapped, so only differences are meaningful.
    """

    t_s: FloatArray
    left_ticks: FloatArray
    right_ticks: FloatArray
    source: str = "<memory>"

    def __post_init__(self) -> None:
        _freeze_columns(self, ("t_s", "left_ticks", "right_ticks"))
        for name in ("left_ticks", "right_ticks"):
            col = getattr(self, name)
            if not np.array_equal(col, np.round(col)):
                raise ValueError(f"{name} must be whole numbers of ticks")


@dataclass(frozen=True, eq=False)
class WheelSpeeds:
    """Wheel angular velocities as the thesis derives them (Fig. 3.7); first sample is zero."""

    t_s: FloatArray
    left_radps: FloatArray
    right_radps: FloatArray

    def __post_init__(self) -> None:
        _freeze_columns(self, ("t_s", "left_radps", "right_radps"))


@dataclass(frozen=True, eq=False)
class Truth:
    """Motion-capture pose, the reference every model is scored against (section 3.3.2).

    ``heading_rad`` as returned by `read_truth` is unwrapped (`numpy.unwrap`): it keeps the
    file's first value and then never jumps by 2 pi, so finite differences give the turn rate.
    """

    t_s: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    heading_rad: FloatArray
    source: str = "<memory>"

    def __post_init__(self) -> None:
        _freeze_columns(self, ("t_s", "x_m", "y_m", "heading_rad"))


@dataclass(frozen=True, eq=False)
class SimExport:
    """A simulation run in the thesis's ``.ssv`` export layout (section 3.2.6).

    ``heading_rad`` as returned by `read_ssv` is unwrapped like `Truth`'s, so the two compare
    without 2 pi jumps.
    """

    t_s: FloatArray
    left_radps: FloatArray
    right_radps: FloatArray
    heading_rad: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    source: str = "<memory>"

    def __post_init__(self) -> None:
        _freeze_columns(self, ("t_s", "left_radps", "right_radps", "heading_rad", "x_m", "y_m"))


# ---------------------------------------------------------------------------------------------
# Parsing


@dataclass(frozen=True, eq=False)
class _Table:
    """Parsed numbers with the physical line each row came from, for exact error messages."""

    source: str
    values: FloatArray  # (n, ncol)
    lines: NDArray[np.int64]  # 1-based line numbers
    n_lines: int  # lines in the file, for errors about the file as a whole


def _where(line: int, col: int | None = None, columns: tuple[str, ...] = ()) -> str:
    if col is None:
        return f"line {line}"
    return f"line {line}, column {col + 1} ({columns[col]})"


def _read_text(path: PathIn, what: str) -> tuple[str, str]:
    """Whole file as text; unreadable or non-UTF-8 files are input errors, not tracebacks."""
    source = str(path)
    try:
        data = Path(path).read_bytes() if isinstance(path, str | os.PathLike) else path.read_bytes()
    except OSError as exc:
        raise InputError(source, "(file)", exc.strerror or str(exc), f"a readable {what}") from None
    try:
        return source, data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        found = data[exc.start : exc.end]
        raise InputError(source, f"line {line}", found, f"UTF-8 text ({what})") from None


def _parse(source: str, text: str, columns: tuple[str, ...]) -> _Table:
    """Numbers from the non-blank, non-comment lines; errors name the physical line."""
    rows: list[str] = []
    line_nos: list[int] = []
    all_lines = text.splitlines()
    for number, raw in enumerate(all_lines, start=1):
        stripped = raw.strip()
        if stripped and not stripped.startswith("#"):
            rows.append(stripped)
            line_nos.append(number)
    lines = np.array(line_nos, dtype=np.int64)
    ncol = len(columns)
    if not rows:
        return _Table(source, np.empty((0, ncol)), lines, len(all_lines))
    try:
        values = np.loadtxt(rows, dtype=np.float64, comments=None, ndmin=2)
    except ValueError:
        values = None
    if values is None or values.shape != (len(rows), ncol):
        values = _parse_slow(source, rows, line_nos, columns)
    bad = ~np.isfinite(values)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        token = rows[row].split()[col]
        raise InputError(source, _where(line_nos[row], int(col), columns), token, "a finite number")
    return _Table(source, values, lines, len(all_lines))


def _parse_slow(source: str, rows: list[str], line_nos: list[int], columns: tuple[str, ...]) -> FloatArray:
    """Line-by-line parse, used only when the fast path fails, to find the offending line."""
    ncol = len(columns)
    expected = f"{ncol} whitespace-separated numbers: {' '.join(columns)}"
    out = np.empty((len(rows), ncol))
    for i, (row, line) in enumerate(zip(rows, line_nos, strict=True)):
        tokens = row.split()
        if len(tokens) != ncol:
            shown = row if len(row) <= 80 else row[:77] + "..."
            raise InputError(source, _where(line), shown, f"{expected} (got {len(tokens)} fields)")
        for j, token in enumerate(tokens):
            try:
                out[i, j] = float(token)
            except ValueError:
                raise InputError(source, _where(line, j, columns), token, "a number") from None
    return out


def _order_in_time(table: _Table, columns: tuple[str, ...], time_unit: str) -> _Table:
    """Enforce strictly increasing time after collapsing identical repeated samples.

    A run of equal timestamps keeps its last line only if all its lines carry identical values;
    otherwise the first line that differs from its predecessor is reported as conflicting.
    Whichever problem (backwards time or conflict) comes first in the file is the one reported.
    """
    values, lines = table.values, table.lines
    if len(values) >= 2:
        t = values[:, 0]
        dt = np.diff(t)
        backwards = np.flatnonzero(dt < 0)
        repeated = np.flatnonzero(dt == 0)
        conflicts = repeated[np.any(values[repeated] != values[repeated + 1], axis=1)]
        first_back = int(backwards[0]) if backwards.size else len(values)
        first_conflict = int(conflicts[0]) if conflicts.size else len(values)
        if first_back < first_conflict:
            i = first_back
            raise InputError(
                table.source,
                _where(int(lines[i + 1])),
                float(t[i + 1]),
                f"{columns[0]} after {t[i]:g} {time_unit} (line {lines[i]}): time must not go backwards",
            )
        if first_conflict < len(values):
            i = first_conflict
            raise InputError(
                table.source,
                _where(int(lines[i + 1])),
                " ".join(f"{v:g}" for v in values[i + 1]),
                f"the same values as line {lines[i]}, which has the same {columns[0]} "
                f"({' '.join(f'{v:g}' for v in values[i])}): conflicting samples",
            )
        keep = np.ones(len(values), dtype=bool)
        keep[repeated] = False  # drop the earlier of each identical pair: the run's last line stays
        values, lines = values[keep], lines[keep]
    if len(values) < 2:
        raise InputError(
            table.source,
            f"line {max(table.n_lines, 1)} (end of file)",
            f"{len(values)} sample{'s' if len(values) != 1 else ''}",
            f"at least 2 samples with distinct {columns[0]}",
        )
    return _Table(table.source, values, lines, table.n_lines)


def _read_table(path: PathIn, columns: tuple[str, ...], what: str, time_unit: str) -> _Table:
    source, text = _read_text(path, what)
    return _order_in_time(_parse(source, text, columns), columns, time_unit)


# ---------------------------------------------------------------------------------------------
# Encoders


def _check_counter_bits(source: str, counter_bits: object) -> int:
    try:
        bits = operator.index(counter_bits)  # type: ignore[call-overload]
    except TypeError:
        bits = None
    if isinstance(counter_bits, bool) or bits is None or not 2 <= bits <= _MAX_COUNTER_BITS:
        raise InputError(
            source, "counter_bits", counter_bits, f"a counter width from 2 to {_MAX_COUNTER_BITS} bits"
        )
    return bits


def _unwrap_counter(table: _Table, col: int, bits: int) -> NDArray[np.int64]:
    """Undo wrap-around of an n-bit counter, signed or unsigned: both are the count modulo 2**n.

    Each step is taken as the representative of (raw step mod 2**n) in [-2**(n-1), 2**(n-1)),
    i.e. the smallest movement consistent with the counter, and summed from the first raw value.
    """
    raw = table.values[:, col]
    modulus = 1 << bits
    low, high = -(modulus >> 1), modulus - 1  # signed minimum .. unsigned maximum
    outside = np.flatnonzero((raw < low) | (raw > high))
    if outside.size:
        i = int(outside[0])
        raise InputError(
            table.source,
            _where(int(table.lines[i]), col, ENCODER_COLUMNS),
            float(raw[i]),
            f"a {bits}-bit counter value between {low} and {high}: is counter_bits right?",
        )
    ticks = raw.astype(np.int64)
    half = modulus >> 1
    steps = (np.diff(ticks) + half) % modulus - half
    return np.concatenate(([ticks[0]], ticks[0] + np.cumsum(steps)))


def read_encoders(path: PathIn, *, counter_bits: int | None = None) -> EncoderLog:
    """Read an encoder log ``time_ms left_ticks right_ticks`` (thesis section 3.3.1).

    Ticks must be whole numbers. Repeated timestamps: identical samples are collapsed to the
    last one, differing ones raise (see module docstring). Backwards time raises.

    Counter wrap-around, the encoder-specific hazard: pass ``counter_bits`` (e.g. 16) if the
    logger's counter is that wide; values may be unsigned (0 .. 2**n - 1) or two's-complement
    (-2**(n-1) .. 2**(n-1) - 1), and any step larger than half the range is taken as a wrap.
    Without it, ticks are used as logged. Either way, a remaining step of more than
    `MAX_TICKS_PER_SAMPLE` ticks between consecutive samples is an InputError naming the line,
    because it would otherwise be read as an impossible wheel speed.
    """
    table = _read_table(path, ENCODER_COLUMNS, "encoder log (time_ms left_ticks right_ticks)", "ms")
    values = table.values
    for col in (1, 2):
        # past 2**53 a float holds no whole number exactly, and an int64 cast wraps
        bad = (values[:, col] != np.round(values[:, col])) | (np.abs(values[:, col]) > MAX_TICK_COUNT)
        if bad.any():
            i = int(np.argmax(bad))
            raise InputError(
                table.source,
                _where(int(table.lines[i]), col, ENCODER_COLUMNS),
                float(values[i, col]),
                f"a whole number of encoder ticks, at most {MAX_TICK_COUNT:.0e} either way",
            )
    if counter_bits is None:
        bits = None
        left = values[:, 1].astype(np.int64)
        right = values[:, 2].astype(np.int64)
    else:
        bits = _check_counter_bits(table.source, counter_bits)
        left = _unwrap_counter(table, 1, bits)
        right = _unwrap_counter(table, 2, bits)
    _check_plausible_steps(table, left, right, bits)
    return EncoderLog(
        t_s=values[:, 0] / 1000.0,
        left_ticks=left.astype(np.float64),
        right_ticks=right.astype(np.float64),
        source=table.source,
    )


def _check_plausible_steps(
    table: _Table, left: NDArray[np.int64], right: NDArray[np.int64], bits: int | None
) -> None:
    steps = np.abs(np.diff(np.column_stack((left, right)), axis=0))
    too_big = np.argwhere(steps > MAX_TICKS_PER_SAMPLE)
    if not too_big.size:
        return
    i, wheel = (int(v) for v in too_big[0])  # argwhere is row-major: first in file order
    if bits is None:
        hint = "a counter wrap-around (pass counter_bits, e.g. 16 or 32) or a gap in the log"
    else:
        hint = f"even after unwrapping a {bits}-bit counter: a wrong counter_bits, a corrupt log or a gap"
    raise InputError(
        table.source,
        _where(int(table.lines[i + 1]), wheel + 1, ENCODER_COLUMNS),
        f"a jump of {int(steps[i, wheel])} ticks since line {table.lines[i]}",
        f"at most {MAX_TICKS_PER_SAMPLE} ticks per sample (about 200 rad/s at 1960 ticks/rev); "
        f"this looks like {hint}",
    )


def _check_ticks_per_rev(source: str, ticks_per_rev: object) -> int:
    try:
        value = operator.index(ticks_per_rev)  # type: ignore[call-overload]
    except TypeError:
        value = None
    if isinstance(ticks_per_rev, bool) or value is None or value <= 0:
        raise InputError(
            source, "ticks_per_rev", ticks_per_rev, "a positive whole number of ticks per wheel rev"
        )
    return value


def wheel_speeds(log: EncoderLog, ticks_per_rev: int) -> WheelSpeeds:
    """Wheel angular velocity exactly as the thesis computes it (Fig. 3.7).

    revolutions = ticks / ticks_per_rev; omega = 2 pi diff(revolutions) / diff(t); the first
    sample is 0. Kept literal (a backward difference placed at the later sample) so results
    compare with the thesis's; use `wheel_angles` when a model integrates positions instead.
    """
    tpr = _check_ticks_per_rev(log.source, ticks_per_rev)
    dt = np.diff(log.t_s)
    speeds = []
    for ticks in (log.left_ticks, log.right_ticks):
        revolutions = ticks / tpr
        omega = np.zeros_like(revolutions)
        omega[1:] = 2.0 * np.pi * np.diff(revolutions) / dt
        speeds.append(omega)
    return WheelSpeeds(t_s=log.t_s, left_radps=speeds[0], right_radps=speeds[1])


def wheel_angles(log: EncoderLog, ticks_per_rev: int) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Cumulative wheel angle (rad) since the first sample: ``(t_s, left_rad, right_rad)``.

    Models that integrate positions prefer this to `wheel_speeds`: no differencing noise, and
    summing increments reproduces the encoder count exactly. Zero at the first sample because
    the counter's origin is arbitrary.
    """
    tpr = _check_ticks_per_rev(log.source, ticks_per_rev)
    scale = 2.0 * np.pi / tpr
    left = (log.left_ticks - log.left_ticks[0]) * scale
    right = (log.right_ticks - log.right_ticks[0]) * scale
    return log.t_s.copy(), left, right


# ---------------------------------------------------------------------------------------------
# Truth and simulation export


def read_truth(path: PathIn) -> Truth:
    """Read motion-capture truth ``t_s X_m Y_m heading_rad`` (thesis section 3.3.2).

    Time must strictly increase after collapsing identical repeated samples (conflicting ones
    raise). The heading is returned unwrapped with `numpy.unwrap`, starting at the file's first
    value, so differences are continuous turn angles rather than 2 pi jumps at +-pi.
    """
    table = _read_table(path, TRUTH_COLUMNS, "motion-capture truth file (t_s X_m Y_m heading_rad)", "s")
    v = table.values
    return Truth(t_s=v[:, 0], x_m=v[:, 1], y_m=v[:, 2], heading_rad=np.unwrap(v[:, 3]), source=table.source)


def read_ssv(path: PathIn) -> SimExport:
    """Read a simulation export ``t_s left_radps right_radps heading_rad X_m Y_m`` (section 3.2.6).

    Same time rules as `read_truth`; the heading is unwrapped the same way so simulated and
    measured headings compare without 2 pi jumps.
    """
    table = _read_table(path, SSV_COLUMNS, "simulation export (.ssv, 6 columns)", "s")
    v = table.values
    return SimExport(
        t_s=v[:, 0],
        left_radps=v[:, 1],
        right_radps=v[:, 2],
        heading_rad=np.unwrap(v[:, 3]),
        x_m=v[:, 4],
        y_m=v[:, 5],
        source=table.source,
    )


# ---------------------------------------------------------------------------------------------
# Writers


def _format_rows(columns: list[FloatArray], sep: str) -> str:
    """Shortest repr of each float, which reads back to the identical float64."""
    rows = np.column_stack(columns).tolist()
    return "".join(sep.join(map(repr, row)) + "\n" for row in rows)


def write_encoders(
    path: str | os.PathLike[str], t_s: ArrayLike, left_ticks: ArrayLike, right_ticks: ArrayLike
) -> None:
    """Write an encoder log in the thesis's tab-separated ``time_ms left_ticks right_ticks`` form.

    Times are written as whole milliseconds when they are (to 1e-6 ms), as the thesis logs them,
    otherwise as decimal milliseconds. Inputs are validated like an `EncoderLog` (ValueError),
    so the file written is always one `read_encoders` accepts (ticks beyond the plausibility
    limit excepted, which need ``counter_bits`` or are not a real log).
    """
    log = EncoderLog(t_s, left_ticks, right_ticks, source=str(path))
    time_ms = log.t_s * 1000.0
    whole_ms = np.round(time_ms)
    if np.all(np.abs(time_ms - whole_ms) <= 1e-6):
        if not np.all(np.diff(whole_ms) > 0):
            raise ValueError("t_s samples collapse to the same millisecond")
        time_text = [str(int(v)) for v in whole_ms.tolist()]
    else:
        time_text = [repr(v) for v in time_ms.tolist()]
    left = log.left_ticks.astype(np.int64).tolist()
    right = log.right_ticks.astype(np.int64).tolist()
    text = "".join(f"{t}\t{lt}\t{rt}\n" for t, lt, rt in zip(time_text, left, right, strict=True))
    write_text_atomic(path, text)


def write_truth(path: str | os.PathLike[str], truth: Truth) -> None:
    """Write motion-capture truth as space-separated ``t_s X_m Y_m heading_rad``.

    The heading is written as stored (possibly unwrapped beyond +-pi) so that reading the file
    back gives the same `Truth` exactly; readers that expect wrapped angles still work.
    """
    write_text_atomic(path, _format_rows([truth.t_s, truth.x_m, truth.y_m, truth.heading_rad], " "))


def write_ssv(path: str | os.PathLike[str], export: SimExport) -> None:
    """Write a simulation run in the thesis's space-separated ``.ssv`` layout (section 3.2.6)."""
    cols = [export.t_s, export.left_radps, export.right_radps, export.heading_rad, export.x_m, export.y_m]
    write_text_atomic(path, _format_rows(cols, " "))
