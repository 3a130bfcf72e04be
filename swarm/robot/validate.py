"""Scoring a model's prediction against a pose reference, in the thesis's terms and more."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from swarm.robot.params import RobotParams
from swarm.robot.predict import Model, Trajectory, predict
from swarm.robot.runs import Run
from swarm.robot.terrain import TerrainMode


@dataclass(frozen=True)
class Score:
    """How far a prediction is from the reference over a run."""

    model: str
    run: str
    terrain: str
    distance_m: float
    duration_s: float
    final_error_m: float
    path_rmse_m: float
    path_rmse_pct: float
    max_error_m: float
    heading_rmse_deg: float
    final_heading_error_deg: float

    def as_dict(self) -> dict[str, float | str]:
        return {k: (round(v, 6) if isinstance(v, float) else v) for k, v in asdict(self).items()}


def wrap_angle(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


def score(run: Run, trajectory: Trajectory, model: str, terrain: str) -> Score:
    """Errors at the reference's own sample times within the prediction's span.

    Path RMSE is the root mean square of the position error over time; as a percentage it is
    relative to the distance the reference travelled (the acceptance measure).
    """
    ref = run.truth
    keep = ref.t_s <= trajectory.t_s[-1] + 1e-9
    t = ref.t_s[keep]
    x, y, h = trajectory.at(t)
    err = np.hypot(x - ref.x_m[keep], y - ref.y_m[keep])
    dh = np.degrees(wrap_angle(h - ref.heading_rad[keep]))
    dist = run.distance_m
    rmse = float(np.sqrt(np.mean(err**2)))
    return Score(
        model=model,
        run=run.name,
        terrain=terrain,
        distance_m=dist,
        duration_s=float(t[-1]),
        final_error_m=float(err[-1]),
        path_rmse_m=rmse,
        path_rmse_pct=100.0 * rmse / dist if dist > 0 else float("nan"),
        max_error_m=float(err.max()),
        heading_rmse_deg=float(np.sqrt(np.mean(dh**2))),
        final_heading_error_deg=float(dh[-1]),
    )


def validate(
    run: Run, robot: RobotParams, mode: TerrainMode, model: Model, **kwargs
) -> tuple[Score, Trajectory]:
    """Predict the run with `model` on `mode` ground and score it."""
    traj = predict(model, run.wheels, robot, mode, run.pose0, **kwargs)
    return score(run, traj, model, mode.name), traj
