"""One entry point for the three motion models, so validation and calibration treat them alike."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from swarm.robot.kinematic import kinematic
from swarm.robot.lagrangian import lagrangian
from swarm.robot.params import RobotParams
from swarm.robot.skid import SkidModel, coeffs_for
from swarm.robot.terrain import TerrainMode
from swarm.robot.wheels import WheelInput

MODELS = ("skid", "kinematic", "lagrangian")
Model = Literal["skid", "kinematic", "lagrangian"]

#: Step of the skid model (s), in validation and calibration alike; first-order, ~0.25% of
#: distance from the converged answer on the sample square. The adaptive integrator never steps
#: further than this either: unbounded, LSODA strode over whole turns (issue 14).
FIXED_STEP_S = 0.005


@dataclass(frozen=True, eq=False)
class Trajectory:
    t_s: np.ndarray
    x_m: np.ndarray
    y_m: np.ndarray
    heading_rad: np.ndarray

    def at(self, t_s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pose interpolated at other times (held at the ends)."""
        return (
            np.interp(t_s, self.t_s, self.x_m),
            np.interp(t_s, self.t_s, self.y_m),
            np.interp(t_s, self.t_s, self.heading_rad),
        )


def robot_for(robot: RobotParams, mode: TerrainMode) -> RobotParams:
    """The robot with what a skid fit on `mode` found about it (a centre of mass the robot file
    did not state); the robot itself otherwise."""
    fitted = mode.model_params.get("skid", {})
    return replace(robot, **fitted) if fitted and not robot.com_stated else robot


def predict(
    model: Model,
    wheels: WheelInput,
    robot: RobotParams,
    mode: TerrainMode,
    pose0: tuple[float, float, float] = (0.0, 0.0, 0.0),
    *,
    adaptive: bool = False,
    dt_s: float = FIXED_STEP_S,
) -> Trajectory:
    """Where `model` says the robot goes on `mode` ground, driven by `wheels` from `pose0`.

    The skid model integrates with the fixed step `dt_s`, exactly as calibration does, so a fitted
    mode scores in validation what it scored in the fit; `adaptive=True` uses LSODA with its step
    bounded by `dt_s` instead.

    The kinematic and Lagrangian models take their parameters from the mode's fitted values for
    them (`mode.model_params`), falling back to the thesis's.
    """
    x0, y0, h0 = pose0
    if model == "skid":
        return _skid(wheels, robot, mode, pose0, adaptive=adaptive, dt_s=dt_s)
    params = dict(mode.model_params.get(model, {}))
    if model == "kinematic":
        x, y, h = kinematic(wheels, robot, heading0_rad=h0, **params)
    elif model == "lagrangian":
        x, y, h = lagrangian(wheels, robot, heading0_rad=h0, **params)
    else:
        raise ValueError(f"unknown model {model!r}; expected one of {MODELS}")
    return Trajectory(wheels.t_s, x + x0, y + y0, h)


def _skid(
    wheels: WheelInput,
    robot: RobotParams,
    mode: TerrainMode,
    pose0: tuple[float, float, float],
    *,
    adaptive: bool,
    dt_s: float,
) -> Trajectory:
    sim = SkidModel(robot_for(robot, mode))
    state0 = sim.state_at_rest(np.array([pose0]))
    coeffs = coeffs_for(mode)
    if adaptive:
        n_out = max(2, int(np.ceil(wheels.duration_s / 0.01)) + 1)
        t = np.linspace(0.0, wheels.duration_s, n_out)
        states = sim.simulate_adaptive(
            state0, wheels.smooth_speed_at, coeffs, t, rtol=1e-5, atol=1e-7, max_step_s=dt_s
        )
    else:
        t, states = sim.simulate_fixed(state0, wheels, coeffs, wheels.duration_s, dt_s)
    pose = sim.wheel_centre_pose(states[:, 0])
    return Trajectory(t, pose[:, 0], pose[:, 1], pose[:, 2])
