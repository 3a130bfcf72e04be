"""`SkidModel.simulate_fixed` compiled: a whole fixed-step run of a few robots in one call.

Calibration and validation integrate short batches of robots (one per finite-difference column)
over thousands of steps, and `SkidModel.step` on arrays of a few robots is some eighty numpy calls
a step, about 300 us, nearly all of it per-call cost. This loop does the same arithmetic robot by
robot, operation for operation in numpy's order (no fast math, so no fused multiply-adds), with
libm's expm1, cos and sin where numpy calls them, so a run gives the floats `step` gives
(`tests/robot/test_models.py` pins it). The simulator's `physics_kernels` solves the same 3x3
system (`implicit_velocities`) for its swarm, without load transfer, in a loop of its own that LLVM
vectorizes.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from swarm.robot.params import GRAVITY_MPS2

#: Rows of the per-robot coefficient array `run_fixed` reads.
BUOYANCY, ROLLING_RESISTANCE, RADIUS_SCALE, MU_PEAK, MU_LATERAL, SHEAR_SLIP, TURNING_M, DRAG = range(8)
COEFFICIENT_NAMES = (
    "buoyancy_fraction",
    "rolling_resistance",
    "rolling_radius_scale",
    "mu_peak",
    "mu_lateral",
    "shear_slip",
    "turning_resistance_m",
    "drag_n_s2_per_m2",
)


@njit(cache=True, error_model="numpy")
def run_fixed(
    states: np.ndarray,
    omega: np.ndarray,
    times: np.ndarray,
    coef: np.ndarray,
    robot: tuple,
    wrench: np.ndarray,
    has_wrench: bool,
    load_transfer: bool,
) -> None:
    """Fill `states` (k + 1, n, 6) from its first row, step j from `times[j]` to `times[j + 1]` with
    wheel speeds `omega[j]` (n, 2), as `SkidModel.simulate_fixed` does with `SkidModel.step`.

    `coef` (8, n): the rows named above. `robot` (`constants`): mass, yaw inertia, the contacts'
    arms, wheel radius, hull yaw-drag arm, regularization speed, centred, mass x centre-of-mass
    height, wheelbase, track width, the static load shares and gravity."""
    (m, inertia, y_left, y_right, x_front, x_rear, radius, yaw_arm, reg, centred, mh, wheelbase, track,
     front, rear, left, right, gravity) = robot  # fmt: skip
    load = np.empty((2, 2))
    secant = np.empty((2, 2))
    for i in range(states.shape[1]):
        support = 1.0 - coef[BUOYANCY, i]
        c_rr = coef[ROLLING_RESISTANCE, i]
        surface = radius * coef[RADIUS_SCALE, i]
        mu_peak, mu_lat, k_shear = coef[MU_PEAK, i], coef[MU_LATERAL, i], coef[SHEAR_SLIP, i]
        spin_m = coef[TURNING_M, i] / max(mu_lat, 1e-9)
        drag = coef[DRAG, i]
        acc_x, acc_y, shifted = 0.0, 0.0, False
        for j in range(times.shape[0] - 1):
            dt = times[j + 1] - times[j]
            x, y, th = states[j, i, 0], states[j, i, 1], states[j, i, 2]
            u, v, r = states[j, i, 3], states[j, i, 4], states[j, i, 5]
            # `SkidModel._ground`: the contacts' loads and each side's rolling resistance
            if centred and not shifted:
                each = (m * gravity / 4.0) * support
                for s in range(2):
                    load[s, 0] = each
                    load[s, 1] = each
                roll0 = 2.0 * c_rr * each
                roll1 = roll0
            else:
                carried = m * gravity * support
                load[0, 0], load[0, 1] = carried * (left * front), carried * (left * rear)
                load[1, 0], load[1, 1] = carried * (right * front), carried * (right * rear)
                if shifted:  # `params.wheel_loads` with the last step's acceleration
                    to_rear = mh * acc_x / wheelbase
                    to_right = mh * acc_y / track
                    load[0, 0] += to_rear * -left
                    load[0, 1] += to_rear * left
                    load[1, 0] += to_rear * -right
                    load[1, 1] += to_rear * right
                    load[0, 0] += to_right * -front
                    load[0, 1] += to_right * -rear
                    load[1, 0] += to_right * front
                    load[1, 1] += to_right * rear
                    for s in range(2):
                        for a in range(2):
                            load[s, a] = max(load[s, a], 0.0)
                roll0 = c_rr * (load[0, 0] + load[0, 1])
                roll1 = c_rr * (load[1, 0] + load[1, 1])
            # `SkidModel._contacts`
            vx0, vx1 = u - y_left * r, u - y_right * r
            vy0, vy1 = v + x_front * r, v + x_rear * r
            w0, w1 = omega[j, i, 0] * surface, omega[j, i, 1] * surface
            sx0, sx1 = vx0 - w0, vx1 - w1
            rolling0 = max(abs(w0), abs(vx0)) + reg
            rolling1 = max(abs(w1), abs(vx1)) + reg
            spin = spin_m * r
            for s in range(2):
                sx = sx0 if s == 0 else sx1
                rolling = rolling0 if s == 0 else rolling1
                for a in range(2):
                    vy = vy0 if a == 0 else vy1
                    slip = math.sqrt((sx * sx + spin * spin) + vy * vy) / rolling
                    slip = max(slip, 1e-12)
                    sec = math.expm1(slip / -k_shear) / slip
                    secant[s, a] = sec * (-load[s, a] / rolling)
            axle0, axle1 = secant[0, 0] + secant[1, 0], secant[0, 1] + secant[1, 1]
            kx_side0 = mu_peak * (secant[0, 0] + secant[0, 1])
            kx_side1 = mu_peak * (secant[1, 0] + secant[1, 1])
            ky0, ky1 = mu_lat * axle0, mu_lat * axle1
            k_roll0 = roll0 / math.sqrt(vx0 * vx0 + reg * reg)
            k_roll1 = roll1 / math.sqrt(vx1 * vx1 + reg * reg)
            k_spin = mu_lat * spin_m * spin_m * (axle0 + axle1)
            # `SkidModel._damping`
            lin = drag * math.sqrt(u * u + v * v)
            yaw = drag * yaw_arm * abs(r)
            # `SkidModel.step`: the 3x3 linearly implicit velocity update, then the pose
            kx0, kx1 = kx_side0 + k_roll0, kx_side1 + k_roll1
            drive0, drive1 = kx_side0 * w0, kx_side1 * w1
            b1 = m * (u / dt + v * r) + drive0 + drive1
            b2 = m * (v / dt - u * r)
            b3 = inertia / dt * r - (y_left * drive0 + y_right * drive1)
            if has_wrench:
                b1, b2, b3 = b1 + wrench[i, 0], b2 + wrench[i, 1], b3 + wrench[i, 2]
            u_new, v_new, r_new = implicit_velocities(
                m / dt, inertia / dt, kx0, kx1, ky0, ky1, lin, yaw, k_spin,
                y_left, y_right, x_front, x_rear, b1, b2, b3,
            )  # fmt: skip
            mid = th + 0.5 * dt * r_new
            cos_h, sin_h = math.cos(mid), math.sin(mid)
            states[j + 1, i, 0] = x + dt * (u_new * cos_h - v_new * sin_h)
            states[j + 1, i, 1] = y + dt * (u_new * sin_h + v_new * cos_h)
            states[j + 1, i, 2] = th + dt * r_new
            states[j + 1, i, 3] = u_new
            states[j + 1, i, 4] = v_new
            states[j + 1, i, 5] = r_new
            if load_transfer:  # `SkidModel.ground_accel`
                acc_x = (u_new - u) / dt - v_new * r_new
                acc_y = (v_new - v) / dt + u_new * r_new
                if has_wrench:
                    acc_x -= wrench[i, 0] / m
                    acc_y -= wrench[i, 1] / m
                shifted = True


@njit(cache=True, error_model="numpy")
def implicit_velocities(
    m_h: float,
    i_h: float,
    kx0: float,
    kx1: float,
    ky0: float,
    ky1: float,
    lin: float,
    yaw: float,
    k_spin: float,
    y_left: float,
    y_right: float,
    x_front: float,
    x_rear: float,
    b1: float,
    b2: float,
    b3: float,
) -> tuple[float, float, float]:
    """(u, v, r) after a linearly implicit step of `SkidModel.step`: the 3x3 system of mass over
    the step `m_h` and yaw inertia over it `i_h`, the sides' longitudinal and the axles' lateral
    slopes (kx, ky), the hull's linear and yaw drag (`lin`, `yaw`) and the patches' spin `k_spin`, with
    right-hand side b, eliminated in closed form in `step`'s order (so the same floats). Shared
    with the simulator's `physics_kernels`, whose pass LLVM still vectorizes with it inlined."""
    a11 = m_h + (kx0 + kx1) + lin
    a22 = m_h + (ky0 + ky1) + lin
    a13 = -(y_left * kx0 + y_right * kx1)
    a23 = x_front * ky0 + x_rear * ky1
    a33 = (
        i_h
        + x_front * x_front * ky0
        + x_rear * x_rear * ky1
        + y_left * y_left * kx0
        + y_right * y_right * kx1
        + yaw
        + k_spin
    )
    e1, e2 = a13 / a11, a23 / a22
    r_new = (b3 - e1 * b1 - e2 * b2) / (a33 - e1 * a13 - e2 * a23)
    return (b1 - a13 * r_new) / a11, (b2 - a23 * r_new) / a22, r_new


def constants(model) -> tuple:
    """`run_fixed`'s robot tuple for a `SkidModel`, each number computed as `SkidModel` does."""
    rb = model.robot
    (y_left, y_right), (x_front, x_rear) = rb.contact_y_m, rb.contact_x_m
    (front, rear), (left, right) = rb.static_load_shares
    return (
        float(rb.mass_kg), float(rb.yaw_inertia_kgm2), y_left, y_right, x_front, x_rear,
        float(rb.wheel_radius_m), rb.length_m**3 / 32.0, float(model.regularization_mps), bool(model.centred),
        rb.mass_kg * rb.com_height_or_axle_m, float(rb.wheelbase_m), float(rb.track_width_m),
        front, rear, left, right, GRAVITY_MPS2,
    )  # fmt: skip
