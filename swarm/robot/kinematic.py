"""The thesis's dead-reckoning model (eqs. 2.23-2.26) and its ICR generalization (Mandow et al. 2007).

Per encoder step the wheels turn by d_phi_L, d_phi_R; the heading changes by
    d_theta = heading_scale * alpha * r (d_phi_R - d_phi_L) / (chi * d)
and the position by alpha * r (d_phi_L + d_phi_R) / 2 along the heading before the step. With
alpha = chi = heading_scale = 1 this is the thesis's two-wheel model (with the R - L sign that a
counter-clockwise heading needs); heading_scale = 0.73 is the thesis's four-wheel correction;
alpha (speed factor) and chi (effective track factor) are the ICR model's two parameters.
"""

from __future__ import annotations

import numpy as np

from swarm.robot.params import RobotParams
from swarm.robot.wheels import WheelInput

THESIS_HEADING_SCALE = 0.73


def kinematic(
    wheels: WheelInput,
    robot: RobotParams,
    *,
    heading0_rad: float = 0.0,
    heading_scale: float = 1.0,
    alpha: float = 1.0,
    chi: float = 1.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Dead-reckoned (x, y, heading) at each wheel sample time, starting at the origin."""
    d_left = np.diff(wheels.left_rad)
    d_right = np.diff(wheels.right_rad)
    r = robot.wheel_radius_m
    d_heading = heading_scale * alpha * r * (d_right - d_left) / (chi * robot.track_width_m)
    d_forward = alpha * r * (d_left + d_right) / 2.0
    heading = heading0_rad + np.concatenate([[0.0], np.cumsum(d_heading)])
    x = np.concatenate([[0.0], np.cumsum(d_forward * np.cos(heading[:-1]))])
    y = np.concatenate([[0.0], np.cumsum(d_forward * np.sin(heading[:-1]))])
    return x, y, heading
