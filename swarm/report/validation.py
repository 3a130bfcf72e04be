"""The thesis-style validation overlay: predicted against reference path, and X, Y, heading in time."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from swarm.files import atomic_path
from swarm.report.style import LINESTYLES, SERIES, new_figure
from swarm.robot.predict import Trajectory
from swarm.robot.runs import Run
from swarm.robot.validate import Score


def plot_validation(
    run: Run, trajectories: Mapping[str, Trajectory], scores: Mapping[str, Score], path: str | Path
) -> None:
    """Write the overlay figure (PNG, SVG or PDF by suffix) for one run and one or more models."""
    fig, axes = new_figure(11.0, 6.2, ncols=2, gridspec_kw={"width_ratios": [1.25, 1]})
    ax_path, ax_right = axes
    ax_right.remove()
    sub = fig.add_gridspec(3, 2, width_ratios=[1.25, 1], hspace=0.12)
    ax_x = fig.add_subplot(sub[0, 1])
    ax_y = fig.add_subplot(sub[1, 1], sharex=ax_x)
    ax_h = fig.add_subplot(sub[2, 1], sharex=ax_x)

    ref = run.truth
    ax_path.plot(ref.x_m, ref.y_m, color=SERIES["truth"], lw=2.2, label="reference (motion capture)")
    ax_path.plot(ref.x_m[0], ref.y_m[0], "D", color=SERIES["truth"], ms=6)
    for name, traj in trajectories.items():
        s = scores[name]
        label = f"{name}: RMSE {s.path_rmse_m:.3f} m ({s.path_rmse_pct:.2f}%), final {s.final_error_m:.3f} m"
        ax_path.plot(
            traj.x_m, traj.y_m, LINESTYLES.get(name, "-"), color=SERIES.get(name), lw=1.4, label=label
        )
        ax_path.plot(traj.x_m[-1], traj.y_m[-1], "o", color=SERIES.get(name), ms=5)
    ax_path.set_aspect("equal", adjustable="datalim")
    ax_path.set_xlabel("X (m)")
    ax_path.set_ylabel("Y (m)")
    ax_path.set_title(f"{run.name}: {run.distance_m:.2f} m in {ref.t_s[-1]:.1f} s")
    ax_path.legend(loc="best", fontsize=7.5)

    for ax, ref_series, key, label in (
        (ax_x, ref.x_m, "x_m", "X (m)"),
        (ax_y, ref.y_m, "y_m", "Y (m)"),
        (ax_h, np.degrees(ref.heading_rad), "heading_rad", "heading (deg)"),
    ):
        ax.plot(ref.t_s, ref_series, color=SERIES["truth"], lw=2.0)
        for name, traj in trajectories.items():
            series = getattr(traj, key)
            if key == "heading_rad":
                series = np.degrees(series)
            ax.plot(traj.t_s, series, LINESTYLES.get(name, "-"), color=SERIES.get(name), lw=1.2)
        ax.set_ylabel(label)
    for ax in (ax_x, ax_y):
        ax.tick_params(labelbottom=False)
    ax_h.set_xlabel("time (s)")
    fig.subplots_adjust(left=0.07, right=0.98, top=0.94, bottom=0.09, wspace=0.25)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120)
    plt.close(fig)
