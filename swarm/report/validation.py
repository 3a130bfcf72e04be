"""The thesis-style validation overlay: predicted against reference path, and X, Y, heading in time;
and the position and heading errors over the run, per model."""

from __future__ import annotations

import io
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Protocol

import matplotlib.pyplot as plt
import numpy as np

from swarm.files import atomic_path
from swarm.report.style import LINESTYLES, SERIES, new_figure
from swarm.robot.predict import Trajectory
from swarm.robot.runs import Run
from swarm.robot.validate import Score, wrap_angle

PNG_DPI = 110


class Poses(Protocol):
    """Anything with pose arrays on one clock: a `Truth` or a `Trajectory`."""

    t_s: np.ndarray
    x_m: np.ndarray
    y_m: np.ndarray
    heading_rad: np.ndarray


def validation_figure(
    name: str,
    distance_m: float,
    ref: Poses,
    trajectories: Mapping[str, Trajectory],
    scores: Mapping[str, Score],
):
    """The overlay figure of run `name` (reference `ref`, `distance_m` travelled) for one or more
    models: the path on the left; X, Y and heading against time on the right."""
    fig, axes = new_figure(11.0, 6.2, ncols=2, gridspec_kw={"width_ratios": [1.25, 1]})
    ax_path, ax_right = axes
    ax_right.remove()
    sub = fig.add_gridspec(3, 2, width_ratios=[1.25, 1], hspace=0.12)
    ax_x = fig.add_subplot(sub[0, 1])
    ax_y = fig.add_subplot(sub[1, 1], sharex=ax_x)
    ax_h = fig.add_subplot(sub[2, 1], sharex=ax_x)

    ax_path.plot(ref.x_m, ref.y_m, color=SERIES["truth"], lw=2.2, label="reference (motion capture)")
    ax_path.plot(ref.x_m[0], ref.y_m[0], "D", color=SERIES["truth"], ms=6)
    for model, traj in trajectories.items():
        s = scores[model]
        share = f"{s.path_rmse_pct:.2f}%" if math.isfinite(s.path_rmse_pct) else "n/a: no distance"
        label = f"{model}: RMSE {s.path_rmse_m:.3f} m ({share}), final {s.final_error_m:.3f} m"
        ax_path.plot(
            traj.x_m, traj.y_m, LINESTYLES.get(model, "-"), color=SERIES.get(model), lw=1.4, label=label
        )
        ax_path.plot(traj.x_m[-1], traj.y_m[-1], "o", color=SERIES.get(model), ms=5)
    ax_path.set_aspect("equal", adjustable="datalim")
    ax_path.set_xlabel("X (m)")
    ax_path.set_ylabel("Y (m)")
    ax_path.set_title(f"{name}: {distance_m:.2f} m in {ref.t_s[-1]:.1f} s")
    ax_path.legend(loc="best", fontsize=7.5)

    for ax, ref_series, key, label in (
        (ax_x, ref.x_m, "x_m", "X (m)"),
        (ax_y, ref.y_m, "y_m", "Y (m)"),
        (ax_h, np.degrees(ref.heading_rad), "heading_rad", "heading (deg)"),
    ):
        ax.plot(ref.t_s, ref_series, color=SERIES["truth"], lw=2.0)
        for model, traj in trajectories.items():
            series = getattr(traj, key)
            if key == "heading_rad":
                series = np.degrees(series)
            ax.plot(traj.t_s, series, LINESTYLES.get(model, "-"), color=SERIES.get(model), lw=1.2)
        ax.set_ylabel(label)
    for ax in (ax_x, ax_y):
        ax.tick_params(labelbottom=False)
    ax_h.set_xlabel("time (s)")
    fig.subplots_adjust(left=0.07, right=0.98, top=0.94, bottom=0.09, wspace=0.25)
    return fig


def _png(fig) -> bytes:
    try:
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=PNG_DPI, metadata={"Software": None})
        return buf.getvalue()
    finally:
        plt.close(fig)


def validation_png(
    name: str,
    distance_m: float,
    ref: Poses,
    trajectories: Mapping[str, Trajectory],
    scores: Mapping[str, Score],
) -> bytes:
    """`validation_figure` as PNG bytes (no timestamp: the same run gives the same bytes)."""
    return _png(validation_figure(name, distance_m, ref, trajectories, scores))


def errors_png(ref: Poses, trajectories: Mapping[str, Trajectory], distance_m: float) -> bytes | None:
    """Position error (m, and % of the distance travelled on the right axis) and heading error (deg)
    of each model against the reference over time; None without a model."""
    if not trajectories:
        return None
    fig, (ax_p, ax_h) = new_figure(9.0, 5.0, nrows=2, sharex=True, layout="constrained")
    for model, traj in trajectories.items():
        keep = ref.t_s <= traj.t_s[-1] + 1e-9
        t = ref.t_s[keep]
        x, y, h = traj.at(t)
        err = np.hypot(x - ref.x_m[keep], y - ref.y_m[keep])
        dh = np.degrees(wrap_angle(h - ref.heading_rad[keep]))
        style = {"color": SERIES.get(model), "ls": LINESTYLES.get(model, "-"), "lw": 1.4, "label": model}
        ax_p.plot(t, err, **style)
        ax_h.plot(t, dh, **style)
    if distance_m > 0:
        pct = ax_p.secondary_yaxis(
            "right", functions=(lambda e: 100 * e / distance_m, lambda p: p * distance_m / 100)
        )
        pct.set_ylabel("% of distance")
        ax_p.axhline(
            0.03 * distance_m, color="#555555", ls=":", lw=1.0, label="3% of distance (the RMSE target)"
        )
    ax_p.set_ylabel("position error (m)")
    ax_h.set_ylabel("heading error (deg)")
    ax_h.set_xlabel("time (s)")
    ax_h.axhline(0.0, color="#999999", lw=0.6)
    ax_p.legend(fontsize=7.5, loc="upper left")
    ax_p.set_title("prediction error against the reference over the run", fontsize=9)
    return _png(fig)


def plot_validation(
    run: Run, trajectories: Mapping[str, Trajectory], scores: Mapping[str, Score], path: str | Path
) -> None:
    """Write the overlay figure (PNG, SVG or PDF by suffix) for one run and one or more models."""
    fig = validation_figure(run.name, run.distance_m, run.truth, trajectories, scores)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120)
    plt.close(fig)
