"""Fitting a model's parameters to recorded runs with scipy's bounded least squares.

The residuals are the position error at the reference's sample times and the heading error (whole
turns counted) as an arc at half the track width, over every run at once: give several runs (a
square and a straight, any patterns you have) and they are fitted jointly.

Priors come from the terrain library: each coefficient is pulled toward the mode's default with a
weight set by that default's stated uncertainty (`TerrainMode.uncertainty`), so a one-sigma
departure costs as much as `PRIOR_M` of RMS path error over the runs. Data win where they have
something to say; where they do not, the model-resolution matrix of the fit (Aster, Borchers &
Thurber, Parameter Estimation and Inverse Problems, sec. 4.4) shows it, and those parameters are
reported as held by their prior. A fitted value outside its physical range (`PHYSICAL_RANGE`)
gives a warning line, whatever the fit says.

The skid model can also fit the robot's centre of mass (`com_x_m`, `com_y_m`) when the robot
file does not state it; the fitted offset is kept with the mode (`model_params["skid"]`).

For the `skid` model the finite-difference Jacobian is one vectorized simulation with one robot
per perturbed coefficient set (one more per centre-of-mass parameter), so a Jacobian costs about
what one run does.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import yaml
from scipy.optimize import least_squares

from swarm.files import write_text_atomic
from swarm.robot.kinematic import kinematic
from swarm.robot.lagrangian import lagrangian
from swarm.robot.params import RobotParams
from swarm.robot.predict import FIXED_STEP_S, Model, robot_for
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
#: Robot values the skid model can fit when the robot file does not state them.
COM_PARAMS = ("com_x_m", "com_y_m")

#: Where each skid parameter is physically plausible; a fit outside gives a warning line. Dry
#: rubber on concrete peaks near mu 1.0 [Wong08 Table 1.3]; a rolling radius grows by little
#: more than tyre deflection gives back; the centre of mass lies well inside the wheels.
PHYSICAL_RANGE: dict[str, tuple[float, float]] = {
    "mu_peak": (0.1, 1.2),
    "mu_lateral": (0.1, 1.2),
    "shear_slip": (0.005, 0.5),
    "rolling_resistance": (0.001, 0.4),
    "turning_resistance_m": (0.0, 0.3),
    "rolling_radius_scale": (0.8, 1.05),
}
#: Prior standard deviations where the terrain mode states none: about the spread of the
#: literature values the defaults come from (terrain_modes.yaml), relative where a fraction is
#: what the sources give.
DEFAULT_SIGMA: dict[str, float] = {
    "mu_peak": 0.15,
    "mu_lateral": 0.2,
    "shear_slip": 0.05,
    "rolling_resistance": 0.05,
    "turning_resistance_m": 0.1,
    "rolling_radius_scale": 0.03,
}
#: Prior standard deviation of an unknown centre of mass, as a fraction of half the wheelbase
#: (longitudinal) or half the track (lateral): loaded robots sit off centre by a few centimetres.
COM_SIGMA_FRACTION = 0.25
#: Resolution below which a parameter counts as set by its prior rather than by the data.
HELD_BY_PRIOR_BELOW = 0.5

#: Opening fractions of the runs a skid fit is grown through before it takes the whole runs.
HORIZONS = (0.25, 0.5)

#: Weight of the prior: a one-sigma departure costs as much as this RMS path error (m).
PRIOR_M = 0.01
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
    #: each parameter's prior (value, one sigma) and resolution: the share of its estimate the
    #: data determine (1: data alone, 0: prior alone)
    priors: dict[str, tuple[float, float]] = field(default_factory=dict)
    resolution: dict[str, float] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    @property
    def held_by_prior(self) -> list[str]:
        """Parameters the runs could not pin down: their value is mostly the prior's."""
        return [n for n, r in self.resolution.items() if r < HELD_BY_PRIOR_BELOW]


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
        # whole turns count: against the unwrapped reference heading, a model that turns 450
        # degrees too far is further off than one that turns 90 too far (wrapped, it looked
        # closer, and fits of robots that turn unlike the defaults fell into that basin)
        self.headings = [np.unwrap(r.truth.heading_rad) for r in runs]
        self.arc_m = robot.track_width_m / 2
        self.evaluations = 0
        bounds = {**MODEL_BOUNDS[model], **_com_bounds(robot)}
        self.lower = np.array([bounds[n][0] for n in names])
        self.upper = np.array([bounds[n][1] for n in names])
        self.start = np.clip([self._start_value(n) for n in names], self.lower, self.upper)
        self.sigma = np.array([self._prior_sigma(n, v) for n, v in zip(names, self.start, strict=True)])
        self.prior_m = prior_m
        self.all_samples = self.samples
        self.set_horizon(1.0)

    def set_horizon(self, fraction: float) -> None:
        """Fit only the first `fraction` of every run (simulated and scored), or all of it."""
        self.horizon = fraction
        self.samples = [
            idx[r.truth.t_s[idx] <= fraction * r.wheels.duration_s + 1e-9]
            for r, idx in zip(self.runs, self.all_samples, strict=True)
        ]
        n_samples = sum(len(s) for s in self.samples)
        # residual rows of 3 n_samples; a one-sigma departure adds prior_m^2 to their mean square
        self.prior_scale = self.prior_m * np.sqrt(3 * n_samples) / self.sigma
        self.n_data = 3 * n_samples
        self._last = None

    def _start_value(self, name: str) -> float:
        if self.model == "skid":
            if name in COM_PARAMS:
                fitted = self.base.model_params.get("skid", {})
                return float(fitted.get(name, getattr(self.robot, name)))
            return float(getattr(self.base, name))
        fitted = self.base.model_params.get(self.model, {})
        return float(fitted.get(name, MODEL_START[self.model][name]))

    def _prior_sigma(self, name: str, start: float) -> float:
        if name == "com_x_m":
            return COM_SIGMA_FRACTION * self.robot.wheelbase_m / 2
        if name == "com_y_m":
            return COM_SIGMA_FRACTION * self.robot.track_width_m / 2
        if self.model == "skid":
            return float(self.base.uncertainty.get(name, DEFAULT_SIGMA[name]))
        return max(0.5 * abs(start), 0.05)

    def mode_for(self, p: np.ndarray) -> TerrainMode:
        values = dict(zip(self.names, (float(v) for v in p), strict=True))
        if self.model == "skid":
            com = {n: values.pop(n) for n in COM_PARAMS if n in values}
            mode = replace(self.base, **values)
            if com:
                skid = {**self.base.model_params.get("skid", {}), **com}
                mode = replace(mode, model_params={**mode.model_params, "skid": skid})
            return mode
        model_params = {**self.base.model_params, self.model: values}
        return replace(self.base, model_params=model_params)

    def _pose_residuals(
        self, run: Run, idx: np.ndarray, heading: np.ndarray, t: np.ndarray, states: np.ndarray
    ) -> np.ndarray:
        """(k, 3 * len(idx)) residuals for k predicted pose histories (states: (len(t), k, 3))."""
        ref = run.truth
        tr = ref.t_s[idx]
        # the model's heading is continuous; start it on the reference's branch
        offset = heading[0] - states[0, :, 2]
        offset = (offset - wrap_angle(offset))[None, :]
        out = []
        for j in range(states.shape[1]):
            x = np.interp(tr, t, states[:, j, 0]) - ref.x_m[idx]
            y = np.interp(tr, t, states[:, j, 1]) - ref.y_m[idx]
            h = (np.interp(tr, t, states[:, j, 2] + offset[0, j]) - heading[idx]) * self.arc_m
            out.append(np.concatenate([x, y, h]))
        return np.array(out)

    def residuals_batch(self, ps: np.ndarray) -> np.ndarray:
        """Residual vectors (k, m) for k parameter vectors at once."""
        self.evaluations += len(ps)
        if self.progress is not None:
            self.progress(len(ps))
        blocks = []
        for run, idx, heading in zip(self.runs, self.samples, self.headings, strict=True):
            if self.model == "skid":
                t, states = self._skid_batch(run, ps)
            else:
                t, states = self._thesis_batch(run, ps)
            blocks.append(self._pose_residuals(run, idx, heading, t, states))
        data = np.concatenate(blocks, axis=1)
        prior = (ps - self.start) * self.prior_scale
        return np.concatenate([data, prior], axis=1)

    def _skid_batch(self, run: Run, ps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        modes = [self.mode_for(p) for p in ps]
        return predicted_poses(run, self.robot, modes, self.dt_s, self.horizon * run.wheels.duration_s)

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
    run: Run, robot: RobotParams, modes: Sequence[TerrainMode], dt_s: float, t_end_s: float | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The skid model's poses over `run` on each of `modes` at once, one robot per mode.

    Returns times (k,) and poses (k, len(modes), 3). The fixed-step integration that validation
    (`predict`) runs, vectorized over the modes that share a centre of mass (a mode may carry a
    fitted one) so a finite-difference Jacobian costs one run per centre of mass.
    """
    groups: dict[tuple[float, float], list[int]] = {}
    robots = [robot_for(robot, m) for m in modes]
    for i, r in enumerate(robots):
        groups.setdefault((r.com_x_m, r.com_y_m), []).append(i)
    t, poses = np.empty(0), np.empty(0)
    for members in groups.values():
        sim = SkidModel(robots[members[0]])
        k = len(members)
        state0 = sim.state_at_rest(np.broadcast_to(run.pose0, (k, 3)))
        t, states = sim.simulate_fixed(
            state0,
            run.wheels,
            coeffs_for([modes[i] for i in members]),
            run.wheels.duration_s if t_end_s is None else t_end_s,
            dt_s,
        )
        if poses.size == 0:
            poses = np.empty((len(t), len(modes), 3))
        poses[:, members] = sim.wheel_centre_pose(states)
    return t, poses


def _com_bounds(robot: RobotParams) -> dict[str, tuple[float, float]]:
    half_l, half_t = 0.6 * robot.wheelbase_m / 2, 0.6 * robot.track_width_m / 2
    return {"com_x_m": (-half_l, half_l), "com_y_m": (-half_t, half_t)}


def default_free(model: Model, robot: RobotParams) -> list[str]:
    """What calibration fits unless told: every coefficient of the model, and for `skid` the
    centre of mass too when the robot file does not state it."""
    names = list(MODEL_BOUNDS[model])
    if model == "skid" and not robot.com_stated:
        names += list(COM_PARAMS)
    return names


def physical_warnings(values: dict[str, float], robot: RobotParams) -> list[str]:
    """One line per fitted value outside where it is physically plausible."""
    ranges = {**PHYSICAL_RANGE, **{k: (0.8 * lo, 0.8 * hi) for k, (lo, hi) in _com_bounds(robot).items()}}
    out = []
    for name, value in values.items():
        lo, hi = ranges.get(name, (-np.inf, np.inf))
        if not lo <= value <= hi:
            out.append(
                f"fitted {name} = {value:.4g} is outside its physical range [{lo:.3g}, {hi:.3g}]: "
                "the model is making up for something it lacks (check the robot file's geometry, "
                "mass and centre of mass, and fit more runs)"
            )
    return out


def budget_warning(max_evaluations: int) -> str:
    """The line for a fit that ran out of evaluations (scipy's status 0): its values are wherever
    the budget stopped them, and nothing else would say that they are not a converged fit."""
    return (
        f"calibration stopped at --max-evaluations {max_evaluations} before converging; "
        "the fit may be poor: raise --max-evaluations"
    )


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
    `prior_m` weighs the pull toward the starting values (0: none). `max_evaluations` is the
    final fit's budget (`--max-evaluations`); a fit that runs out of it before converging says so
    in `warnings`.
    """
    names = list(free) if free is not None else default_free(model, robot)
    allowed = [*MODEL_BOUNDS[model], *(COM_PARAMS if model == "skid" else ())]
    unknown = [n for n in names if n not in allowed]
    if unknown:
        raise ValueError(f"cannot fit {unknown} for the {model} model; choose from {allowed}")
    problem = _Problem(runs, robot, model, base, names, dt_s, progress, prior_m)
    before = [validate(run, robot, base, model, adaptive=False, dt_s=dt_s)[0] for run in runs]
    x0 = problem.start
    if model == "skid":
        # a growing horizon: fitted first on the opening of each run (a turn or two, where the
        # error is still small and the least squares nearly convex), then on more, then on all.
        # From the terrain defaults straight to the whole run, a robot that turns 2.4 times less
        # than the defaults (the Bullet Husky) landed at mu 1.85 and 23% RMSE on its own square.
        for fraction in HORIZONS:
            problem.set_horizon(fraction)
            x0 = least_squares(
                problem.fun,
                x0,
                jac=problem.jac,
                bounds=(problem.lower, problem.upper),
                x_scale="jac",
                max_nfev=max(4, max_evaluations // 4),
                xtol=1e-4,
                ftol=1e-4,
            ).x
        problem.set_horizon(1.0)
    fit = least_squares(
        problem.fun,
        x0,
        jac=problem.jac,
        bounds=(problem.lower, problem.upper),
        x_scale="jac",
        max_nfev=max_evaluations,
        xtol=1e-6,
        ftol=1e-6,
    )
    notes = [] if fit.status != 0 else [budget_warning(max_evaluations)]
    fitted = problem.mode_for(fit.x)
    origin = f"fitted to {', '.join(r.name for r in runs)} by swarm model calibrate ({model} model)"
    if model == "skid":
        fitted = replace(fitted, sources={**fitted.sources, **dict.fromkeys(names, origin)})
    if name is not None:
        fitted = replace(fitted, name=name)
    after = [validate(run, robot, fitted, model, adaptive=False, dt_s=dt_s)[0] for run in runs]
    parameters = dict(zip(names, (float(v) for v in fit.x), strict=True))
    prior_sd = problem.sigma if prior_m > 0 else None
    std_errors, resolution = _uncertainty(fit.jac, fit.fun, problem.n_data, names, prior_sd)
    return Calibration(
        mode=fitted,
        model=model,
        parameters=parameters,
        std_errors=std_errors,
        before=before,
        after=after,
        evaluations=problem.evaluations,
        priors={
            n: (float(v), float(sd)) for n, v, sd in zip(names, problem.start, problem.sigma, strict=True)
        },
        resolution=resolution,
        warnings=notes + (physical_warnings(parameters, robot) if model == "skid" else []),
    )


def _uncertainty(
    jac: np.ndarray,
    residuals: np.ndarray,
    n_data: int,
    names: list[str],
    prior_sd: np.ndarray | None = None,
) -> tuple[dict[str, float], dict[str, float]]:
    """Standard errors and the diagonal of the model-resolution matrix (J'J)^-1 J_d'J_d: how much
    of each estimate the data make.

    The standard errors are the linearized posterior's: the data's information J_d'J_d / s^2 (s^2
    the data residuals' variance) and each prior's 1 / sd^2 (`prior_sd`; None: the data alone).
    Not the fit's own prior rows, whose weight is a regularization (`PRIOR_M`): scaled by s^2 they
    made a parameter the runs cannot see look known to a few per cent of its prior."""
    k = len(names)
    j_data = jac[:n_data]
    sigma2 = max(float(residuals[:n_data] @ residuals[:n_data]) / max(1, n_data - k), 1e-300)
    try:
        inv = np.linalg.pinv(jac.T @ jac)
        posterior = j_data.T @ j_data / sigma2
        if prior_sd is not None:
            posterior = posterior + np.diag(1.0 / np.asarray(prior_sd, np.float64) ** 2)
        cov = np.linalg.pinv(posterior)
    except np.linalg.LinAlgError:
        return dict.fromkeys(names, float("inf")), dict.fromkeys(names, 0.0)
    res = np.diag(inv @ (j_data.T @ j_data))
    std = {n: float(np.sqrt(max(cov[i, i], 0.0))) for i, n in enumerate(names)}
    return std, {n: float(np.clip(res[i], 0.0, 1.0)) for i, n in enumerate(names)}


def _pct(value: float) -> float | None:
    """A run's RMSE as % of distance for the YAML: null for a run that travelled no distance (its
    score is NaN, no share of anything; YAML's `.nan` reads back as a number, which it is not)."""
    return round(value, 3) if math.isfinite(value) else None


def write_calibration(path: str | Path, result: Calibration, robot: RobotParams, runs: Sequence[Run]) -> None:
    """Write the fitted mode as a terrain YAML that `--terrain` and the rest of the project read."""
    doc = {
        "fitted": {
            "model": result.model,
            "robot": robot.name,
            "runs": [r.name for r in runs],
            "parameters": {k: round(v, 6) for k, v in result.parameters.items()},
            "std_errors": {k: float(f"{v:.3g}") for k, v in result.std_errors.items()},
            "priors": {k: [round(v, 6), float(f"{sd:.3g}")] for k, (v, sd) in result.priors.items()},
            "resolution": {k: round(v, 3) for k, v in result.resolution.items()},
            "held_by_prior": result.held_by_prior,
            "warnings": result.warnings,
            "path_rmse_pct": {
                b.run: {"before": _pct(b.path_rmse_pct), "after": _pct(a.path_rmse_pct)}
                for b, a in zip(result.before, result.after, strict=True)
            },
        },
        "modes": {result.mode.name: mode_to_dict(result.mode)},
    }
    header = f"# Terrain mode fitted by surf-swarm `swarm model calibrate` ({result.model} model).\n"
    write_text_atomic(path, header + yaml.safe_dump(doc, sort_keys=False, width=100))
