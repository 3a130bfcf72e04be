"""The three files of a reference run, in the bundled sample runs' formats (shared by the engines).

- ``<stem>.ssv``: t, measured wL, measured wR, heading, X, Y at 100 Hz (5 decimals);
- ``<stem>_truth.txt``: t X Y heading at 100 Hz (4 decimals), heading wrapped to (-pi, pi];
- ``<stem>_encoders.txt``: time_ms, left_ticks, right_ticks (tab-separated, ~38 Hz, 25-28 ms
  jitter from a seeded generator, cumulative ticks floored from the wheel angle).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np

RATE_HZ = 100
ENCODER_DT_MS = (25, 28)  # inclusive range of the sample logs' intervals (mean 26.5 ms, ~38 Hz)


def wrap(a: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * a))


def encoder_log(
    t_s: np.ndarray, left_rad: np.ndarray, right_rad: np.ndarray, ticks_per_rev: int, seed: int
) -> np.ndarray:
    """Rows (time_ms, left_ticks, right_ticks) at jittered ~38 Hz, ticks floored from wheel angle."""
    rng = np.random.default_rng(seed)
    end_ms = round(1000 * (t_s[-1] - t_s[0]))
    times = [0]
    while True:
        nxt = times[-1] + int(rng.integers(ENCODER_DT_MS[0], ENCODER_DT_MS[1] + 1))
        if nxt > end_ms:
            break
        times.append(nxt)
    tm = np.asarray(times)
    ts = t_s[0] + tm / 1000.0
    k = ticks_per_rev / (2 * math.pi)
    left = np.floor(np.interp(ts, t_s, left_rad) * k + 1e-9).astype(int)
    right = np.floor(np.interp(ts, t_s, right_rad) * k + 1e-9).astype(int)
    return np.column_stack([tm, left, right])


def write_run(
    stem: Path, t: np.ndarray, sim: Mapping[str, np.ndarray], ticks_per_rev: int, seed: int
) -> dict[str, Path]:
    """Write `sim` (arrays x_m, y_m, heading_rad, left/right_radps, left/right_rad on the 100 Hz
    grid `t`) as ``<stem>.ssv``, ``_truth.txt`` and ``_encoders.txt``; returns their paths."""
    stem.parent.mkdir(parents=True, exist_ok=True)
    heading = wrap(sim["heading_rad"])
    paths = {
        "ssv": stem.with_name(stem.name + ".ssv"),
        "truth": stem.with_name(stem.name + "_truth.txt"),
        "encoders": stem.with_name(stem.name + "_encoders.txt"),
    }
    ssv = np.column_stack([t, sim["left_radps"], sim["right_radps"], heading, sim["x_m"], sim["y_m"]])
    np.savetxt(paths["ssv"], ssv, fmt="%.5f", delimiter=" ")
    np.savetxt(
        paths["truth"], np.column_stack([t, sim["x_m"], sim["y_m"], heading]), fmt="%.4f", delimiter=" "
    )
    enc = encoder_log(t, sim["left_rad"], sim["right_rad"], ticks_per_rev, seed)
    np.savetxt(paths["encoders"], enc, fmt="%d", delimiter="\t")
    return paths
