"""The `skid` model: a planar rigid-body four-wheel skid-steer model with terrain-aware contacts.

State per robot `(x, y, heading, u, v, r)` (world pose; body-frame velocities and yaw rate), input
the left and right wheel angular velocities (velocity-controlled motors, as the encoders measure).

Each of the four wheel contacts (two per side, at +-wheelbase/2 and +-track/2) slips relative to
the ground. Its slip velocity is the contact-point velocity minus the wheel's surface speed, plus a
third component rho * r for the patch spinning with the body (rho = turning_resistance_m /
mu_lateral, an effective patch radius); the combined slip is that vector over the contact's
rolling speed (the longitudinal slip ratio, the tangent of the slip angle, and the turn slip).
Friction follows Janosi-Hanamoto, mu N (1 - exp(-s / k)), shared along the slip direction as a
friction ellipsoid: `mu_peak` forward, `mu_lateral` sideways, and a spin (bore) moment of up to
turning_resistance_m * N per patch, so a patch that slides sideways has less left to resist
spinning, as in tyre turn-slip models and MuJoCo's elliptic friction cones. Rolling resistance
c_rr N opposes each contact's rolling. The lateral forces at the front and rear contacts and the
patches' spin friction together resist turning (`turning_resistance_moment` gives the former:
mu W l / 2 at full sliding for point contacts). Water carries part of the weight
(`buoyancy_fraction`) and drags the hull quadratically. An external body-frame wrench
(Fx, Fy, Mz) and a normal-load scale per robot bring in slopes, jet thrust, currents and waves.

Two integrators: `step` advances n robots by one fixed step with a linearly implicit scheme
(contact and drag forces frozen at their secant slope, then the 3x3 velocity system solved in
closed form), unconditionally stable for the dissipative contact forces, so swarms can use steps
of 10-20 ms; `simulate_adaptive` hands the exact right-hand side to scipy's LSODA for validation.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy.integrate import solve_ivp

from swarm.robot.params import GRAVITY_MPS2, RobotParams
from swarm.robot.terrain import COEFFICIENTS, TerrainMode

Coeffs = Mapping[str, np.ndarray | float]

#: Speed below which slip and rolling direction are regularized (m/s): keeps forces smooth at rest.
REGULARIZATION_SPEED_MPS = 0.02

X, Y, HEADING, U, V, R = range(6)


def coeffs_for(modes: TerrainMode | list[TerrainMode]) -> dict[str, np.ndarray]:
    """Coefficient arrays (n,) for one mode per robot (or one mode for a single robot)."""
    modes = [modes] if isinstance(modes, TerrainMode) else list(modes)
    return {c: np.array([getattr(m, c) for m in modes], dtype=np.float64) for c in COEFFICIENTS}


class _Ground(NamedTuple):
    """Per-robot ground terms (n,), derived once per call from the coefficients."""

    load_n: np.ndarray  # normal load per contact
    surface_m: np.ndarray  # effective rolling radius
    mu_peak: np.ndarray
    mu_lateral: np.ndarray
    shear_slip: np.ndarray
    roll_n: np.ndarray  # rolling-resistance force per contact, c_rr N
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
    k_roll: np.ndarray  # per contact on each side
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

    @property
    def half_track_m(self) -> float:
        return self.robot.track_width_m / 2

    @property
    def half_base_m(self) -> float:
        return self.robot.wheelbase_m / 2

    @property
    def contact_x_m(self) -> np.ndarray:
        """Body x of the contacts: front-left, rear-left, front-right, rear-right."""
        b = self.half_base_m
        return np.array([b, -b, b, -b])

    @property
    def contact_y_m(self) -> np.ndarray:
        a = self.half_track_m
        return np.array([a, a, -a, -a])

    def _ground(self, c: Coeffs, load_scale: np.ndarray | None) -> _Ground:
        support = 1.0 - _flat(c, "buoyancy_fraction")
        if load_scale is not None:
            support = support * np.reshape(load_scale, -1)
        load = (self.robot.mass_kg * GRAVITY_MPS2 / 4.0) * support
        return _Ground(
            load_n=load,
            surface_m=self.robot.wheel_radius_m * _flat(c, "rolling_radius_scale"),
            mu_peak=_flat(c, "mu_peak"),
            mu_lateral=_flat(c, "mu_lateral"),
            shear_slip=_flat(c, "shear_slip"),
            roll_n=_flat(c, "rolling_resistance") * load,
            spin_m=_flat(c, "turning_resistance_m") / np.maximum(_flat(c, "mu_lateral"), 1e-9),
            drag=_flat(c, "drag_n_s2_per_m2"),
        )

    def _contacts(self, state: np.ndarray, omega: np.ndarray, g: _Ground) -> _Contacts:
        a, b, reg = self.half_track_m, self.half_base_m, self.regularization_mps
        u, v, r = state[:, U], state[:, V], state[:, R]
        # (side, n) and (axle, n), filled in place: np.stack costs more than the arithmetic here
        ar, br = a * r, b * r
        vx = np.empty((2, len(u)))
        np.subtract(u, ar, out=vx[0])
        np.add(u, ar, out=vx[1])
        vy = np.empty((2, len(v)))
        np.add(v, br, out=vy[0])
        np.subtract(v, br, out=vy[1])
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
        fx = -g.mu_peak * k.secant * (k.vx - k.w)[:, None, :] - (k.k_roll * k.vx)[:, None, :]
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
    ) -> np.ndarray:
        """Time derivative of the state (n, 6): Newton-Euler in the body frame."""
        state, omega = _as_batch(state, omega)
        g = self._ground(c, load_scale)
        k = self._contacts(state, omega, g)
        lin, yaw = self._damping(state, g)
        a, b = self.half_track_m, self.half_base_m
        m, inertia = self.robot.mass_kg, self.robot.yaw_inertia_kgm2
        u, v, r, th = state[:, U], state[:, V], state[:, R], state[:, HEADING]
        fx_side = -k.kx_side * (k.vx - k.w) - 2.0 * k.k_roll * k.vx  # (2, n) left, right
        fy_axle = -k.ky_axle * k.vy  # (2, n) front, rear
        force_x = fx_side[0] + fx_side[1] - lin * u
        force_y = fy_axle[0] + fy_axle[1] - lin * v
        moment = b * (fy_axle[0] - fy_axle[1]) - a * (fx_side[0] - fx_side[1]) - (yaw + k.k_spin) * r
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
    ) -> np.ndarray:
        """Advance n robots by `dt_s`: linearly implicit in the velocities, then the pose.

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
        g = self._ground(c, load_scale)
        k = self._contacts(state, omega, g)
        lin, yaw = self._damping(state, g)
        a, b = self.half_track_m, self.half_base_m
        m, inertia = self.robot.mass_kg, self.robot.yaw_inertia_kgm2
        u, v, r = state[:, U], state[:, V], state[:, R]
        kx = k.kx_side + 2.0 * k.k_roll  # (2, n) per side, slip and rolling together
        drive = k.kx_side * k.w
        kx_sum, ky_sum = kx[0] + kx[1], k.ky_axle[0] + k.ky_axle[1]
        a11 = m / dt_s + kx_sum + lin
        a22 = m / dt_s + ky_sum + lin
        a13 = -a * (kx[0] - kx[1])
        a23 = b * (k.ky_axle[0] - k.ky_axle[1])
        a33 = inertia / dt_s + b * b * ky_sum + a * a * kx_sum + yaw + k.k_spin
        b1 = m * (u / dt_s + v * r) + drive[0] + drive[1]
        b2 = m * (v / dt_s - u * r)
        b3 = inertia / dt_s * r - a * (drive[0] - drive[1])
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
            traction_out[:, 0] = k.kx_side[0] * (k.w[0] - (u_new - a * r_new))
            traction_out[:, 1] = k.kx_side[1] * (k.w[1] - (u_new + a * r_new))
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

    def simulate_fixed(
        self,
        state0: np.ndarray,
        omega_of_t: Callable[[float, float], np.ndarray],
        c: Coeffs,
        t_end_s: float,
        dt_s: float,
        wrench: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Fixed-step run from 0 to `t_end_s`; `omega_of_t(t0, t1)` gives the mean wheel speed on a step.

        Returns times (k+1,) and states (k+1, n, 6).
        """
        n_steps = int(np.ceil(t_end_s / dt_s - 1e-9))
        times = np.minimum(np.arange(n_steps + 1) * dt_s, t_end_s)
        state = np.atleast_2d(np.asarray(state0, dtype=np.float64)).copy()
        states = np.empty((n_steps + 1, *state.shape))
        states[0] = state
        for k in range(n_steps):
            h = times[k + 1] - times[k]
            state = self.step(state, omega_of_t(times[k], times[k + 1]), c, h, wrench)
            states[k + 1] = state
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
    ) -> np.ndarray:
        """Adaptive run (scipy LSODA: switches to a stiff method where contacts stiffen).

        Returns states at `t_eval_s`, shape (len(t_eval_s), n, 6).
        """
        state0 = np.atleast_2d(np.asarray(state0, dtype=np.float64))
        n = state0.shape[0]

        def rhs(t: float, flat: np.ndarray) -> np.ndarray:
            return self.derivatives(flat.reshape(n, 6), omega_at(t), c, wrench).ravel()

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
