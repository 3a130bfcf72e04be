"""Fitting a model's terrain coefficients to recorded runs with scipy's bounded least squares.

The residuals are the position error at the reference's sample times (and the heading error as an
arc at half the track width), over every run at once. Coefficients the runs cannot tell apart are
held near their literature defaults by a weak prior: a one-sigma departure costs as much as
`PRIOR_M` of path error at every sample, so data win wherever they have something to say.

For the `skid` model the finite-difference Jacobian is one vectorized simulation with one robot
per perturbed coefficient set, so a Jacobian costs about what one run does.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import yaml
from scipy.optimize import least_squares

from swarm.files import write_text_atomic
from swarm.robot.kinematic import kinematic
from swarm.robot.lagrangian import lagrangian
from swarm.robot.params import RobotParams
from swarm.robot.predict import FIXED_STEP_S, Model
from swarm.robot.runs import Run
from swarm.robot.skid import SkidModel, coeffs_for
from swarm.robot.terrain import TerrainMode, mode_to_dict
from swarm.robot.validate import Score, validate, wrap_angle

#: Bounds of the skid coefficients calibration may move, and which it moves by default.
SKID_BOUNDS: dict[str, tuple[float, float]] = {
    "mu_peak": (0.05, 3.0),
    "mu_lateral": (0.02, 3.0),
    "shear_slip": (0.02, 1.0),
    "rolling_resistance": (0.0, 0.6),
    "turning_resistance_m": (0.0, 0.5),
    "rolling_radius_scale": (0.6, 1.1),
}
MODEL_BOUNDS: dict[str, dict[str, tuple[float, float]]] = {
    "skid": SKID_BOUNDS,
    "kinematic": {"alpha": (0.3, 1.5), "chi": (0.5, 5.0)},
    "lagrangian": {"robot_inertia_scale": (0.05, 20.0), "wheel_inertia_scale": (0.05, 20.0)},
}
MODEL_START: dict[str, dict[str, float]] = {
    "kinematic": {"alpha": 1.0, "chi": 1.0},
    "lagrangian": {"robot_inertia_scale": 1.7, "wheel_inertia_scale": 0.97},
}

#: Weight of the prior toward the defaults, as metres of path error per sample per sigma.
PRIOR_M = 0.005
#: Most reference samples a run contributes to the residuals (evenly spaced).
MAX_SAMPLES_PER_RUN = 400


@dataclass(frozen=True)
class Calibration:
    """A fitted terrain mode and how well it explains each run, before and after."""

    mode: TerrainMode
    model: str
    parameters: dict[str, float]
    std_errors: dict[str, float]
    before: list[Score]
    after: list[Score]
    evaluations: int


def _stride(run: Run) -> np.ndarray:
    n = len(run.truth.t_s)
    return np.unique(np.linspace(0, n - 1, min(n, MAX_SAMPLES_PER_RUN)).round().astype(int))


class _Problem:
    """Residuals for one model over several runs; caches the last evaluation for the Jacobian."""

    def __init__(
        self,
        runs: Sequence[Run],
        robot: RobotParams,
        model: Model,
        base: TerrainMode,
        names: list[str],
        dt_s: float,
        progress: Callable[[int], None] | None,
        prior_m: float = PRIOR_M,
    ) -> None:
        self.runs, self.robot, self.model, self.base, self.names = runs, robot, model, base, names
        self.dt_s = dt_s
        self.progress = progress
        self.samples = [_stride(r) for r in runs]
        self.arc_m = robot.track_width_m / 2
        self.evaluations = 0
        bounds = MODEL_BOUNDS[model]
        self.lower = np.array([bounds[n][0] for n in names])
        self.upper = np.array([bounds[n][1] for n in names])
        self.start = np.clip([self._start_value(n) for n in names], self.lower, self.upper)
        prior_sigma = np.maximum(0.5 * np.abs(self.start), 0.05)
        n_samples = sum(len(s) for s in self.samples)
        self.prior_scale = prior_m * np.sqrt(3 * n_samples) / prior_sigma

    def _start_value(self, name: str) -> float:
        if self.model == "skid":
            return float(getattr(self.base, name))
        fitted = self.base.model_params.get(self.model, {})
        return float(fitted.get(name, MODEL_START[self.model][name]))

    def mode_for(self, p: np.ndarray) -> TerrainMode:
        values = dict(zip(self.names, (float(v) for v in p), strict=True))
        if self.model == "skid":
            return replace(self.base, **values)
        model_params = {**self.base.model_params, self.model: values}
        return replace(self.base, model_params=model_params)

    def _pose_residuals(self, run: Run, idx: np.ndarray, t: np.ndarray, states: np.ndarray) -> np.ndarray:
        """(k, 3 * len(idx)) residuals for k predicted pose histories (states: (len(t), k, 3))."""
        ref = run.truth
        tr = ref.t_s[idx]
        out = []
        for j in range(states.shape[1]):
            x = np.interp(tr, t, states[:, j, 0]) - ref.x_m[idx]
            y = np.interp(tr, t, states[:, j, 1]) - ref.y_m[idx]
            h = wrap_angle(np.interp(tr, t, states[:, j, 2]) - ref.heading_rad[idx]) * self.arc_m
            out.append(np.concatenate([x, y, h]))
        return np.array(out)

    def residuals_batch(self, ps: np.ndarray) -> np.ndarray:
        """Residual vectors (k, m) for k parameter vectors at once."""
        self.evaluations += len(ps)
        if self.progress is not None:
            self.progress(len(ps))
        blocks = []
        for run, idx in zip(self.runs, self.samples, strict=True):
            if self.model == "skid":
                t, states = self._skid_batch(run, ps)
            else:
                t, states = self._thesis_batch(run, ps)
            blocks.append(self._pose_residuals(run, idx, t, states))
        data = np.concatenate(blocks, axis=1)
        prior = (ps - self.start) * self.prior_scale
        return np.concatenate([data, prior], axis=1)

    def _skid_batch(self, run: Run, ps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return predicted_poses(run, self.robot, [self.mode_for(p) for p in ps], self.dt_s)

    def _thesis_batch(self, run: Run, ps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        fn = kinematic if self.model == "kinematic" else lagrangian
        poses = []
        for p in ps:
            params = dict(zip(self.names, p, strict=True))
            x, y, h = fn(run.wheels, self.robot, heading0_rad=run.pose0[2], **params)
            poses.append(np.stack([x + run.pose0[0], y + run.pose0[1], h], -1))
        return run.wheels.t_s, np.stack(poses, axis=1)

    # scipy's interface -------------------------------------------------------------------
    def fun(self, p: np.ndarray) -> np.ndarray:
        self._last = (p.copy(), self.residuals_batch(p[None])[0])
        return self._last[1]

    def jac(self, p: np.ndarray) -> np.ndarray:
        """Forward differences (backward at an upper bound), all perturbations in one batch."""
        steps = 1e-4 * np.maximum(np.abs(p), 0.05)
        steps = np.where(p + steps > self.upper, -steps, steps)
        batch = p[None, :] + np.diag(steps)
        if getattr(self, "_last", None) is not None and np.array_equal(self._last[0], p):
            base = self._last[1]
            rows = self.residuals_batch(batch)
        else:
            rows_all = self.residuals_batch(np.vstack([p[None], batch]))
            base, rows = rows_all[0], rows_all[1:]
        return ((rows - base[None, :]) / steps[:, None]).T


def predicted_poses(
    run: Run, robot: RobotParams, modes: Sequence[TerrainMode], dt_s: float
) -> tuple[np.ndarray, np.ndarray]:
    """The skid model's poses over `run` on each of `modes` at once, one robot per mode.

    Returns times (k,) and poses (k, len(modes), 3). The fixed-step integration that validation
    (`predict`) runs, vectorized over the modes so a finite-difference Jacobian costs one run.
    """
    sim = SkidModel(robot)
    k = len(modes)
    state0 = sim.state_at_rest(np.broadcast_to(run.pose0, (k, 3)))
    t, states = sim.simulate_fixed(
        state0,
        lambda a, b: np.broadcast_to(run.wheels.mean_speeds(a, b), (k, 2)),
        coeffs_for(list(modes)),
        run.wheels.duration_s,
        dt_s,
    )
    return t, sim.wheel_centre_pose(states)


def calibrate(
    runs: Sequence[Run],
    robot: RobotParams,
    base: TerrainMode,
    model: Model = "skid",
    *,
    free: Sequence[str] | None = None,
    name: str | None = None,
    dt_s: float = FIXED_STEP_S,
    max_evaluations: int = 60,
    prior_m: float = PRIOR_M,
    progress: Callable[[int], None] | None = None,
) -> Calibration:
    """Fit `model`'s parameters on `base` ground to `runs`; returns the fitted mode and scores.

    For `skid` the free parameters are terrain coefficients (default: all in `SKID_BOUNDS`); for
    `kinematic` the ICR speed and track factors; for `lagrangian` the two inertia scales.
    `prior_m` weighs the pull toward the starting values (0: none).
    """
    names = list(free) if free is not None else list(MODEL_BOUNDS[model])
    unknown = [n for n in names if n not in MODEL_BOUNDS[model]]
    if unknown:
        raise ValueError(
            f"cannot fit {unknown} for the {model} model; choose from {list(MODEL_BOUNDS[model])}"
        )
    problem = _Problem(runs, robot, model, base, names, dt_s, progress, prior_m)
    before = [validate(run, robot, base, model, adaptive=False, dt_s=dt_s)[0] for run in runs]
    fit = least_squares(
        problem.fun,
        problem.start,
        jac=problem.jac,
        bounds=(problem.lower, problem.upper),
        x_scale="jac",
        max_nfev=max_evaluations,
        xtol=1e-6,
        ftol=1e-6,
    )
    fitted = problem.mode_for(fit.x)
    origin = f"fitted to {', '.join(r.name for r in runs)} by swarm model calibrate ({model} model)"
    if model == "skid":
        fitted = replace(fitted, sources={**fitted.sources, **dict.fromkeys(names, origin)})
    if name is not None:
        fitted = replace(fitted, name=name)
    after = [validate(run, robot, fitted, model, adaptive=False, dt_s=dt_s)[0] for run in runs]
    return Calibration(
        mode=fitted,
        model=model,
        parameters=dict(zip(names, (float(v) for v in fit.x), strict=True)),
        std_errors=_std_errors(fit, names),
        before=before,
        after=after,
        evaluations=problem.evaluations,
    )


def _std_errors(fit: object, names: list[str]) -> dict[str, float]:
    """Approximate standard errors from the Jacobian at the optimum (Gauss-Newton covariance)."""
    jac = fit.jac  # type: ignore[attr-defined]
    dof = max(1, jac.shape[0] - jac.shape[1])
    sigma2 = 2 * fit.cost / dof  # type: ignore[attr-defined]
    try:
        cov = np.linalg.pinv(jac.T @ jac) * sigma2
    except np.linalg.LinAlgError:
        return dict.fromkeys(names, float("inf"))
    return {n: float(np.sqrt(max(cov[i, i], 0.0))) for i, n in enumerate(names)}


def write_calibration(path: str | Path, result: Calibration, robot: RobotParams, runs: Sequence[Run]) -> None:
    """Write the fitted mode as a terrain YAML that `--terrain` and the rest of the project read."""
    doc = {
        "fitted": {
            "model": result.model,
            "robot": robot.name,
            "runs": [r.name for r in runs],
            "parameters": {k: round(v, 6) for k, v in result.parameters.items()},
            "std_errors": {k: float(f"{v:.3g}") for k, v in result.std_errors.items()},
            "path_rmse_pct": {
                b.run: {"before": round(b.path_rmse_pct, 3), "after": round(a.path_rmse_pct, 3)}
                for b, a in zip(result.before, result.after, strict=True)
            },
        },
        "modes": {result.mode.name: mode_to_dict(result.mode)},
    }
    header = f"# Terrain mode fitted by surf-swarm `swarm model calibrate` ({result.model} model).\n"
    write_text_atomic(path, header + yaml.safe_dump(doc, sort_keys=False, width=100))
