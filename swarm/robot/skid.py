"""The `skid` model: a planar rigid-body four-wheel skid-steer model with terrain-aware contacts.

State per robot `(x, y, heading, u, v, r)` (world pose; body-frame velocities and yaw rate), input
the left and right wheel angular velocities (velocity-controlled motors, as the encoders measure).

Each of the four wheel contacts (two per side, at +-wheelbase/2 and +-track/2 from the wheel
centre; the state's origin is the centre of mass, `RobotParams.com_x_m`/`com_y_m` from it) slips
relative to the ground. Its slip velocity is the contact-point velocity minus the wheel's surface
speed, plus a third component rho * r for the patch spinning with the body (rho =
turning_resistance_m / mu_lateral, an effective patch radius); the combined slip is that vector
over the contact's rolling speed: the longitudinal slip ratio, the tangent of the slip angle, and
the patch's turn slip rho r / V (Pacejka, Tyre and Vehicle Dynamics, 3rd ed., 2012, sec. 4.3:
phi = r / V). Friction follows Janosi-Hanamoto, mu N (1 - exp(-s / k)), shared along the slip
direction as a friction ellipsoid: `mu_peak` forward, `mu_lateral` sideways, and a spin (bore)
moment of up to turning_resistance_m * N per patch (the Howe & Cutkosky 1996 ellipsoidal limit
surface of a sliding patch), so a patch that slides sideways has less left to resist spinning.
N is each contact's own load (`params.wheel_loads`: centre of mass, load transfer).

How turning depends on radius and load comes out of this, as in Wong & Chiang's theory of skid
steering ("A general theory for skid steering of tracked vehicles on firm ground", Proc. IMechE
D 215, 2001): k = K / l is the patch's shear displacement modulus over its length, so in a wide
arc (small lateral slip and turn slip) the lateral and spin resistances are a fraction of mu N
and rise toward it as the turn tightens to a pivot, the dependence Steeds' empirical
mu_t = mu_max / (0.925 + 0.15 R / B) summarises [Wong08, ch. 7]; each contact resists in
proportion to its load. The ICR spread Mandow et al. (IROS 2007) fit as one constant per terrain
thus varies with the motion, as Rabiee & Biswas (ICRA 2019) found it does.

(Tried for issue 14 and not kept: a bore torque on its own budget, added to the lateral forces'
moment as the classical moment balance adds its turning-resistance moment. It matched MuJoCo's
torsional friction better on hard ground, but calibrated on a square it predicted MuJoCo's soft-
sand square-spiral-line with 6.1% path RMSE against the shared ellipsoid's 1.9%. Also tried for
the turning and not kept, each calibrated on the square and scored on the 12 held-out spirals and
square-spiral-lines of both reference engines (`bench_heldout.py`), path RMSE summed 32.2% with
this model, 3 runs within 1.5%: Wong's patch-integrated stress, mu N [1 - (k/s)(1 - exp(-s/k))],
31.1% and 2 runs (wide arcs then resist with half of Steeds' turning resistance on concrete,
`tests/robot/test_turning.py`); the normality rule of the limit surface, force along
(mu_x^2 s_x, mu_y^2 s_y, tau^2 r), 37.5% and 3 runs. What the turning misses on those engines
traces to them (docs/turning-accuracy.md): MuJoCo's rolling friction is a wheel torque where this model's
c_rr N opposes the hub's travel, as a pivot's rolling resistance does in Kozlowski & Pazderski
(AMCS 14(4), 2004), and Bullet's yaw lags and overshoots its commands. In steady turning this
model's efficiency, yaw rate over the kinematic, is nearly the same from wide arcs to a pivot once
its patches slide; MuJoCo's rises 10-27% from wide arcs to the pivot (bench_turning.py in
benchmarks/), which is why a fit on the square turns MuJoCo's hard-sand pivots short. The
calibration-side changes tried against that, each scored on 20 held-out runs of three engines and
robots and none kept, are listed in docs/turning-accuracy.md, with a second attempt's: fits
of short prediction windows, and distinct longitudinal and lateral shear moduli, which lower the
wide arcs' efficiency but not the pivot's. For skid4 on MuJoCo's hard sand the rise is mostly the
engine's contact softness (3% of its 10% left at a 0.004 s contact time constant); what is left of
the pivot's miss there is this model's rolling resistance, whose moment in a pivot the engines'
wheel-torque rolling friction does not have.)

Rolling resistance c_rr N opposes each contact's rolling. Water carries part of the weight
(`buoyancy_fraction`) and drags the hull quadratically. An external body-frame wrench (Fx, Fy,
Mz) and a normal-load scale per robot bring in slopes, jet thrust, currents and waves.
`turning_resistance_moment` gives the lateral forces' yaw moment (mu W l / 2 at full sliding for
point contacts).

[Wong08] J. Y. Wong, Theory of Ground Vehicles, 4th ed., Wiley, 2008.

Two integrators: `step` advances n robots by one fixed step with a linearly implicit scheme
(contact and drag forces frozen at their secant slope, then the 3x3 velocity system solved in
closed form), unconditionally stable for the dissipative contact forces, so swarms can use steps
of 10-20 ms; `simulate_adaptive` hands the exact right-hand side to scipy's LSODA for validation.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np
from scipy.integrate import solve_ivp

from swarm.robot import skid_run
from swarm.robot.params import GRAVITY_MPS2, RobotParams, wheel_loads
from swarm.robot.terrain import COEFFICIENTS, TerrainMode
from swarm.robot.wheels import WheelInput

Coeffs = Mapping[str, np.ndarray | float]

#: Speed below which slip and rolling direction are regularized (m/s): keeps forces smooth at rest.
REGULARIZATION_SPEED_MPS = 0.02

X, Y, HEADING, U, V, R = range(6)

#: Wheel surface speed below which `mean_wheel_slip` is 0, m/s.
SLIP_MIN_SPEED_MPS = 0.05


def mean_wheel_slip(w: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Longitudinal slip of the mean wheel, surface speed `w`, at body speed `u`: sign(w) (w - u) /
    max(|w|, |u|) clipped to [0, 1] (0 when the robot outruns its wheels, 1 when it moves against
    them; reversing counts like driving forward), 0 below `SLIP_MIN_SPEED_MPS`. What the hazards'
    immobilization rate grows with, so the simulator's physics and the plan's drive through the
    surf compute it alike."""
    aw = np.abs(w)
    ratio = np.sign(w)
    ratio *= u
    np.subtract(aw, ratio, out=ratio)
    ratio /= np.maximum(np.maximum(aw, np.abs(u)), SLIP_MIN_SPEED_MPS)
    np.minimum(ratio, 1.0, out=ratio)
    np.maximum(ratio, 0.0, out=ratio)
    ratio[aw < SLIP_MIN_SPEED_MPS] = 0.0
    return ratio


def coeffs_for(modes: TerrainMode | list[TerrainMode]) -> dict[str, np.ndarray]:
    """Coefficient arrays (n,) for one mode per robot (or one mode for a single robot)."""
    modes = [modes] if isinstance(modes, TerrainMode) else list(modes)
    return {c: np.array([getattr(m, c) for m in modes], dtype=np.float64) for c in COEFFICIENTS}


class _Ground(NamedTuple):
    """Per-robot ground terms (n,), derived once per call from the coefficients."""

    load_n: np.ndarray  # normal load per contact: (n,) when all four share it, else (side, axle, n)
    surface_m: np.ndarray  # effective rolling radius
    mu_peak: np.ndarray
    mu_lateral: np.ndarray
    shear_slip: np.ndarray
    roll_n: (
        np.ndarray
    )  # rolling-resistance force of each side's two contacts together, c_rr N, (n,) or (2, n)
    c_rr: np.ndarray
    spin_m: np.ndarray  # patch spin radius: turning_resistance_m / mu_lateral
    drag: np.ndarray  # 0.5 rho Cd A


class _Contacts(NamedTuple):
    """Contact kinematics and secant force slopes, exploiting the layout: the two contacts on a
    side share their rolling velocity and wheel speed, the two on an axle their sideways velocity.

    Arrays are (2, n): per side [left, right] or per axle [front, rear] (robots last, so every
    operation runs over contiguous memory). Fx on each of a side's contacts is
    -kx (vx - w) - k_roll vx, Fy on each of an axle's contacts is -ky vy.
    """

    vx: np.ndarray  # per side
    w: np.ndarray  # per side
    vy: np.ndarray  # per axle
    secant: np.ndarray  # (side, axle, n): slip-force slope per unit mu of each contact
    kx_side: np.ndarray  # sum over the side's two contacts of the slip slope along x
    ky_axle: np.ndarray  # sum over the axle's two contacts of the slip slope along y
    k_roll: np.ndarray  # rolling-resistance slope of each side's two contacts together
    k_spin: np.ndarray  # (n,) yaw-moment slope of the four patches' spin friction


def _flat(c: Coeffs, name: str) -> np.ndarray:
    value = c[name]
    if type(value) is np.ndarray and value.ndim == 1 and value.dtype == np.float64:
        return value  # the simulator's per-robot columns: no conversion
    return np.asarray(value, dtype=np.float64).reshape(-1)


@dataclass(frozen=True)
class SkidModel:
    """Vectorized skid-steer dynamics for one robot type; every robot has its own terrain."""

    robot: RobotParams
    regularization_mps: float = REGULARIZATION_SPEED_MPS

    @cached_property
    def centred(self) -> bool:
        """Centre of mass over the wheel centre: all four contacts carry the same static load."""
        return self.robot.com_x_m == 0.0 and self.robot.com_y_m == 0.0

    @cached_property
    def _arms(self) -> tuple[float, float, float, float]:
        """Contact arms from the centre of mass: y of the left and right sides, x of the front
        and rear axles (looked up once: the swarm steps call this thousands of times)."""
        (y_left, y_right), (x_front, x_rear) = self.robot.contact_y_m, self.robot.contact_x_m
        return y_left, y_right, x_front, x_rear

    @property
    def contact_x_m(self) -> np.ndarray:
        """Body x of the contacts from the centre of mass: front-left, rear-left, front-right, rear-right."""
        f, r = self.robot.contact_x_m
        return np.array([f, r, f, r])

    @property
    def contact_y_m(self) -> np.ndarray:
        left, right = self.robot.contact_y_m
        return np.array([left, left, right, right])

    def _ground(
        self, c: Coeffs, load_scale: np.ndarray | None, ground_accel: np.ndarray | None = None
    ) -> _Ground:
        support = 1.0 - _flat(c, "buoyancy_fraction")
        if load_scale is not None:
            support = support * np.reshape(load_scale, -1)
        c_rr = _flat(c, "rolling_resistance")
        if self.centred and ground_accel is None:
            load = (self.robot.mass_kg * GRAVITY_MPS2 / 4.0) * support  # the swarm's fast path
            roll = 2.0 * c_rr * load
        else:
            n_accel = 0 if ground_accel is None else np.reshape(ground_accel, (-1, 2)).shape[0]
            support = np.broadcast_to(support, (max(c_rr.shape[0], support.shape[0], n_accel),))
            load = wheel_loads(self.robot, self.robot.mass_kg * GRAVITY_MPS2 * support, ground_accel)
            roll = c_rr * (load[:, 0] + load[:, 1])
        return _Ground(
            load_n=load,
            surface_m=self.robot.wheel_radius_m * _flat(c, "rolling_radius_scale"),
            mu_peak=_flat(c, "mu_peak"),
            mu_lateral=_flat(c, "mu_lateral"),
            shear_slip=_flat(c, "shear_slip"),
            roll_n=roll,
            c_rr=c_rr,
            spin_m=_flat(c, "turning_resistance_m") / np.maximum(_flat(c, "mu_lateral"), 1e-9),
            drag=_flat(c, "drag_n_s2_per_m2"),
        )

    def _contacts(self, state: np.ndarray, omega: np.ndarray, g: _Ground) -> _Contacts:
        y_left, y_right, x_front, x_rear = self._arms
        reg = self.regularization_mps
        u, v, r = state[:, U], state[:, V], state[:, R]
        # (side, n) and (axle, n), filled in place: np.stack costs more than the arithmetic here
        vx = np.empty((2, len(u)))
        np.subtract(u, y_left * r, out=vx[0])
        np.subtract(u, y_right * r, out=vx[1])
        vy = np.empty((2, len(v)))
        np.add(v, x_front * r, out=vy[0])
        np.add(v, x_rear * r, out=vy[1])
        w = omega.T * g.surface_m
        sx = vx - w
        rolling = np.maximum(np.abs(w), np.abs(vx))
        rolling += reg
        # combined slip of each contact (side, axle, n): the slip velocity, with the patch's spin
        # r * rho as a third component sharing the same friction budget, over the rolling speed
        spin = g.spin_m * r
        slip = np.sqrt((sx * sx + spin * spin)[:, None, :] + (vy * vy)[None, :, :])
        slip /= rolling[:, None, :]
        np.maximum(slip, 1e-12, out=slip)
        # Janosi-Hanamoto traction over slip, (1 - exp(-s/k)) / s, times the load over rolling speed
        secant = np.expm1(slip / -g.shear_slip)
        secant /= slip
        secant *= -g.load_n / rolling[:, None, :]
        axle_sum = secant[0] + secant[1]
        return _Contacts(
            vx=vx,
            w=w,
            vy=vy,
            secant=secant,
            kx_side=g.mu_peak * (secant[:, 0] + secant[:, 1]),
            ky_axle=g.mu_lateral * axle_sum,
            k_roll=g.roll_n / np.sqrt(vx * vx + reg * reg),
            k_spin=g.mu_lateral * g.spin_m * g.spin_m * (axle_sum[0] + axle_sum[1]),
        )

    def _damping(self, state: np.ndarray, g: _Ground) -> tuple[np.ndarray, np.ndarray]:
        """Secant slopes of the body-level resistances: translation (n,) and yaw (n,).

        Quadratic hull drag in water; for yaw, strip theory over the hull length L gives
        c L^3/32 |r| r.
        """
        u, v, r = state[:, U], state[:, V], state[:, R]
        lin = g.drag * np.sqrt(u * u + v * v)
        yaw = g.drag * (self.robot.length_m**3 / 32.0) * np.abs(r)
        return lin, yaw

    def contact_forces(
        self, state: np.ndarray, omega: np.ndarray, c: Coeffs, load_scale: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Body-frame ground forces (Fx, Fy) at each contact (n, 4): FL, RL, FR, RR."""
        state, omega = _as_batch(state, omega)
        g = self._ground(c, load_scale)
        k = self._contacts(state, omega, g)
        reg = self.regularization_mps
        load = np.broadcast_to(g.load_n, k.secant.shape)
        roll = g.c_rr * load * (k.vx / np.sqrt(k.vx * k.vx + reg * reg))[:, None, :]
        fx = -g.mu_peak * k.secant * (k.vx - k.w)[:, None, :] - roll
        fy = -g.mu_lateral * k.secant * k.vy[None, :, :]
        return fx.reshape(4, -1).T, fy.reshape(4, -1).T

    def turning_resistance_moment(self, state: np.ndarray, omega: np.ndarray, c: Coeffs) -> np.ndarray:
        """Yaw moment of the lateral contact forces about the centre of mass (n,): what resists turning."""
        _, fy = self.contact_forces(state, omega, c)
        return fy @ self.contact_x_m

    def derivatives(
        self,
        state: np.ndarray,
        omega: np.ndarray,
        c: Coeffs,
        wrench: np.ndarray | None = None,
        load_scale: np.ndarray | None = None,
        ground_accel_mps2: np.ndarray | None = None,
    ) -> np.ndarray:
        """Time derivative of the state (n, 6): Newton-Euler at the centre of mass, body frame.

        `ground_accel_mps2` (n, 2), if given, shifts the wheels' loads (`params.wheel_loads`).
        """
        state, omega = _as_batch(state, omega)
        g = self._ground(c, load_scale, ground_accel_mps2)
        k = self._contacts(state, omega, g)
        lin, yaw = self._damping(state, g)
        y_left, y_right, x_front, x_rear = self._arms
        m, inertia = self.robot.mass_kg, self.robot.yaw_inertia_kgm2
        u, v, r, th = state[:, U], state[:, V], state[:, R], state[:, HEADING]
        fx_side = -k.kx_side * (k.vx - k.w) - k.k_roll * k.vx  # (2, n) left, right
        fy_axle = -k.ky_axle * k.vy  # (2, n) front, rear
        force_x = fx_side[0] + fx_side[1] - lin * u
        force_y = fy_axle[0] + fy_axle[1] - lin * v
        moment = (
            x_front * fy_axle[0]
            + x_rear * fy_axle[1]
            - y_left * fx_side[0]
            - y_right * fx_side[1]
            - (yaw + k.k_spin) * r
        )
        if wrench is not None:
            ext = np.broadcast_to(wrench, (state.shape[0], 3))
            force_x, force_y, moment = force_x + ext[:, 0], force_y + ext[:, 1], moment + ext[:, 2]
        out = np.empty_like(state)
        out[:, X] = u * np.cos(th) - v * np.sin(th)
        out[:, Y] = u * np.sin(th) + v * np.cos(th)
        out[:, HEADING] = r
        out[:, U] = force_x / m + v * r
        out[:, V] = force_y / m - u * r
        out[:, R] = moment / inertia
        return out

    def step(
        self,
        state: np.ndarray,
        omega: np.ndarray,
        c: Coeffs,
        dt_s: float,
        wrench: np.ndarray | None = None,
        load_scale: np.ndarray | None = None,
        traction_out: np.ndarray | None = None,
        ground_accel_mps2: np.ndarray | None = None,
    ) -> np.ndarray:
        """Advance n robots by `dt_s`: linearly implicit in the velocities, then the pose.

        `ground_accel_mps2` (n, 2), if given, is the in-plane ground force per unit mass (body
        frame) that shifts load between the wheels (`params.wheel_loads`); without it the loads
        are static (still shared by where the centre of mass is).

        `traction_out` (n, 2), if given, receives each side's slip traction at the new velocities
        (the longitudinal contact force without rolling resistance, N): what the motors push with,
        for the power they draw.

        `wrench` (n, 3) is an external body-frame force and moment (Fx, Fy, Mz): gravity along a
        slope, jet thrust, current and wave forces. `load_scale` (n,) multiplies the wheels'
        normal load (cos of the slope, wave lift).

        The contact forces are linear in (u, v, r) once their secant slopes are frozen, so the new
        velocities solve a symmetric positive-definite 3x3 system per robot, eliminated in closed
        form. Dissipation can then never overshoot, whatever the step.
        """
        state, omega = _as_batch(state, omega)
        g = self._ground(c, load_scale, ground_accel_mps2)
        k = self._contacts(state, omega, g)
        lin, yaw = self._damping(state, g)
        y_left, y_right, x_front, x_rear = self._arms
        m, inertia = self.robot.mass_kg, self.robot.yaw_inertia_kgm2
        u, v, r = state[:, U], state[:, V], state[:, R]
        kx = k.kx_side + k.k_roll  # (2, n) per side, slip and rolling together
        drive = k.kx_side * k.w
        kx_sum, ky_sum = kx[0] + kx[1], k.ky_axle[0] + k.ky_axle[1]
        a11 = m / dt_s + kx_sum + lin
        a22 = m / dt_s + ky_sum + lin
        a13 = -(y_left * kx[0] + y_right * kx[1])
        a23 = x_front * k.ky_axle[0] + x_rear * k.ky_axle[1]
        a33 = (
            inertia / dt_s
            + x_front * x_front * k.ky_axle[0]
            + x_rear * x_rear * k.ky_axle[1]
            + y_left * y_left * kx[0]
            + y_right * y_right * kx[1]
            + yaw
            + k.k_spin
        )
        b1 = m * (u / dt_s + v * r) + drive[0] + drive[1]
        b2 = m * (v / dt_s - u * r)
        b3 = inertia / dt_s * r - (y_left * drive[0] + y_right * drive[1])
        if wrench is not None:
            ext = (
                wrench
                if np.shape(wrench) == (state.shape[0], 3)
                else np.broadcast_to(wrench, (state.shape[0], 3))
            )
            b1, b2, b3 = b1 + ext[:, 0], b2 + ext[:, 1], b3 + ext[:, 2]
        e1, e2 = a13 / a11, a23 / a22
        r_new = (b3 - e1 * b1 - e2 * b2) / (a33 - e1 * a13 - e2 * a23)
        u_new = (b1 - a13 * r_new) / a11
        v_new = (b2 - a23 * r_new) / a22
        if traction_out is not None:
            traction_out[:, 0] = k.kx_side[0] * (k.w[0] - (u_new - y_left * r_new))
            traction_out[:, 1] = k.kx_side[1] * (k.w[1] - (u_new - y_right * r_new))
        out = np.empty_like(state)
        heading_mid = state[:, HEADING] + 0.5 * dt_s * r_new
        cos_h, sin_h = np.cos(heading_mid), np.sin(heading_mid)
        out[:, X] = state[:, X] + dt_s * (u_new * cos_h - v_new * sin_h)
        out[:, Y] = state[:, Y] + dt_s * (u_new * sin_h + v_new * cos_h)
        out[:, HEADING] = state[:, HEADING] + dt_s * r_new
        out[:, U] = u_new
        out[:, V] = v_new
        out[:, R] = r_new
        return out

    def state_at_rest(self, pose: np.ndarray) -> np.ndarray:
        """States (n, 6) at rest for poses (n, 3) of the wheel centre, where runs measure the pose:
        the state's position is the centre of mass's, `com_x_m` ahead and `com_y_m` left of it."""
        pose = np.atleast_2d(np.asarray(pose, dtype=np.float64))
        state = np.zeros((pose.shape[0], 6))
        state[:, :3] = pose
        xc, yc = self.robot.com_x_m, self.robot.com_y_m
        cos_h, sin_h = np.cos(pose[:, 2]), np.sin(pose[:, 2])
        state[:, X] += xc * cos_h - yc * sin_h
        state[:, Y] += xc * sin_h + yc * cos_h
        return state

    def wheel_centre_pose(self, states: np.ndarray) -> np.ndarray:
        """Poses (..., 3) of the wheel centre for states (..., 6): the inverse of `state_at_rest`."""
        pose = np.array(states[..., :3], dtype=np.float64)
        xc, yc = self.robot.com_x_m, self.robot.com_y_m
        cos_h, sin_h = np.cos(pose[..., 2]), np.sin(pose[..., 2])
        pose[..., 0] -= xc * cos_h - yc * sin_h
        pose[..., 1] -= xc * sin_h + yc * cos_h
        return pose

    def ground_accel(
        self, before: np.ndarray, after: np.ndarray, dt_s: float, wrench: np.ndarray | None = None
    ) -> np.ndarray:
        """In-plane ground force per unit mass (n, 2) over a step from the state change: the
        centre of mass's body-frame acceleration (du/dt - v r, dv/dt + u r) less the external
        force per mass. What shifts load between the wheels (`params.wheel_loads`)."""
        u, v, r = after[:, U], after[:, V], after[:, R]
        acc = np.stack([(u - before[:, U]) / dt_s - v * r, (v - before[:, V]) / dt_s + u * r], -1)
        if wrench is not None:
            acc -= np.broadcast_to(wrench, (after.shape[0], 3))[:, :2] / self.robot.mass_kg
        return acc

    def simulate_fixed(
        self,
        state0: np.ndarray,
        omega_of_t: Callable[[float, float], np.ndarray] | WheelInput,
        c: Coeffs,
        t_end_s: float,
        dt_s: float,
        wrench: np.ndarray | None = None,
        load_transfer: bool = True,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Fixed-step run from 0 to `t_end_s` of `step` after `step`, in one compiled loop
        (`skid_run.run_fixed`, the same floats); `omega_of_t(t0, t1)` gives the mean wheel speed
        on a step, or a `WheelInput` its exact travel over each step (`WheelInput.step_speeds`,
        every step's at once).

        With `load_transfer`, each step's wheel loads follow the previous step's acceleration.
        Returns times (k+1,) and states (k+1, n, 6).
        """
        n_steps = int(np.ceil(t_end_s / dt_s - 1e-9))
        times = np.minimum(np.arange(n_steps + 1) * dt_s, t_end_s)
        state = np.atleast_2d(np.asarray(state0, dtype=np.float64))
        n = state.shape[0]
        states = np.empty((n_steps + 1, n, 6))
        states[0] = state
        if isinstance(omega_of_t, WheelInput):
            table = omega_of_t.step_speeds(times)[:, None, :]
        else:
            each = [np.reshape(omega_of_t(times[k], times[k + 1]), (-1, 2)) for k in range(n_steps)]
            table = np.array(each).reshape(n_steps, -1, 2) if each else np.zeros((0, n, 2))
        omega = np.ascontiguousarray(np.broadcast_to(table, (n_steps, n, 2)), dtype=np.float64)
        coef = np.array([np.broadcast_to(_flat(c, name), (n,)) for name in skid_run.COEFFICIENT_NAMES])
        ext = np.zeros((n, 3)) if wrench is None else np.array(np.broadcast_to(wrench, (n, 3)), float)
        skid_run.run_fixed(
            states, omega, times, coef, skid_run.constants(self), ext, wrench is not None, load_transfer
        )
        return times, states

    def simulate_adaptive(
        self,
        state0: np.ndarray,
        omega_at: Callable[[float], np.ndarray],
        c: Coeffs,
        t_eval_s: np.ndarray,
        wrench: np.ndarray | None = None,
        rtol: float = 1e-6,
        atol: float = 1e-8,
        max_step_s: float = np.inf,
        load_transfer: bool = True,
    ) -> np.ndarray:
        """Adaptive run (scipy LSODA: switches to a stiff method where contacts stiffen).

        Returns states at `t_eval_s`, shape (len(t_eval_s), n, 6).
        """
        state0 = np.atleast_2d(np.asarray(state0, dtype=np.float64))
        n = state0.shape[0]

        def rhs(t: float, flat: np.ndarray) -> np.ndarray:
            state, omega = flat.reshape(n, 6), omega_at(t)
            d = self.derivatives(state, omega, c, wrench)
            if load_transfer:  # one fixed-point pass: loads from the acceleration they give
                acc = np.stack([d[:, U] - state[:, V] * state[:, R], d[:, V] + state[:, U] * state[:, R]], -1)
                if wrench is not None:
                    acc -= np.broadcast_to(wrench, (n, 3))[:, :2] / self.robot.mass_kg
                d = self.derivatives(state, omega, c, wrench, ground_accel_mps2=acc)
            return d.ravel()

        sol = solve_ivp(
            rhs,
            (float(t_eval_s[0]), float(t_eval_s[-1])),
            state0.ravel(),
            method="LSODA",
            t_eval=t_eval_s,
            rtol=rtol,
            atol=atol,
            max_step=max_step_s,
        )
        if not sol.success:
            raise RuntimeError(f"adaptive integration failed: {sol.message}")
        return sol.y.T.reshape(len(t_eval_s), n, 6)


def _as_batch(state: np.ndarray, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    state = np.asarray(state, dtype=np.float64)
    omega = np.asarray(omega, dtype=np.float64)
    if state.ndim == 1:
        state = state[None, :]
    if omega.ndim == 1:
        omega = np.broadcast_to(omega, (state.shape[0], 2))
    return state, omega
