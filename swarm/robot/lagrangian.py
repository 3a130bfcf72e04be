"""The thesis's Lagrangian dynamic model exactly as written (eqs. 2.17-2.22, 2.27-2.28).

m dv/dt = F_x, I_R d2(theta)/dt2 = tau, with the wheel forces taken from the wheels' angular
acceleration, F_L = (d omega_L/dt) I_w / r and F_R likewise, F_x = F_L + F_R along the body x
axis, F_y = 0, tau = (b / 2)(F_R - F_L), b the body width. I_R is the whole mass as a box
(eq. 2.13), I_w the wheel's m_w r^2 moved to the robot axis (I_w + m_w h^2). The thesis fitted
I_R x 1.7 and I_w x 0.97 to motion capture (section 4.2.2); those are the defaults here.

As in the thesis's MATLAB, the encoder speeds (Fig. 3.7) are differenced into accelerations, the
forces are held constant over each encoder interval, and each interval is integrated by
Dormand-Prince 4(5) (scipy's RK45, MATLAB's ode45) from where the previous one ended.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from swarm.robot.params import RobotParams
from swarm.robot.wheels import WheelInput

THESIS_ROBOT_INERTIA_SCALE = 1.7
THESIS_WHEEL_INERTIA_SCALE = 0.97


def wheel_forces(
    wheels: WheelInput, robot: RobotParams, wheel_inertia_scale: float = THESIS_WHEEL_INERTIA_SCALE
) -> tuple[np.ndarray, np.ndarray]:
    """F_L, F_R on each encoder interval (eqs. 2.27-2.28): omega-dot * I_w / r."""
    omega_left, omega_right = wheels.thesis_speeds()
    dt = np.diff(wheels.t_s)
    i_w = robot.wheel_inertia_about_robot_kgm2 * wheel_inertia_scale
    f_left = np.diff(omega_left) / dt * i_w / robot.wheel_radius_m
    f_right = np.diff(omega_right) / dt * i_w / robot.wheel_radius_m
    return f_left, f_right


def lagrangian(
    wheels: WheelInput,
    robot: RobotParams,
    *,
    heading0_rad: float = 0.0,
    robot_inertia_scale: float = THESIS_ROBOT_INERTIA_SCALE,
    wheel_inertia_scale: float = THESIS_WHEEL_INERTIA_SCALE,
    rtol: float = 1e-6,
    atol: float = 1e-9,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x, y, heading) at each wheel sample time, integrated interval by interval with RK45."""
    f_left, f_right = wheel_forces(wheels, robot, wheel_inertia_scale)
    force_x = f_left + f_right
    torque = robot.width_m / 2.0 * (f_right - f_left)
    mass = robot.mass_kg
    inertia = robot.thesis_yaw_inertia_kgm2 * robot_inertia_scale

    out = np.empty((len(wheels.t_s), 5))  # x, y, heading, forward speed, yaw rate
    out[0] = (0.0, 0.0, heading0_rad, 0.0, 0.0)
    for k in range(len(wheels.t_s) - 1):
        fx, tau = force_x[k], torque[k]

        def rhs(_t: float, s: np.ndarray, fx: float = fx, tau: float = tau) -> np.ndarray:
            return np.array([s[3] * np.cos(s[2]), s[3] * np.sin(s[2]), s[4], fx / mass, tau / inertia])

        sol = solve_ivp(rhs, (wheels.t_s[k], wheels.t_s[k + 1]), out[k], method="RK45", rtol=rtol, atol=atol)
        out[k + 1] = sol.y[:, -1]
    return out[:, 0], out[:, 1], out[:, 2]
