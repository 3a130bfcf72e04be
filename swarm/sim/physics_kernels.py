"""Fused numba kernels for the swarm's physics substeps (`Physics.step`), bit for bit the numpy path.

The numpy path (`SkidModel.step` and the world terms around it) makes ~100 array passes per
substep with their temporaries: ~2 ms a substep at 10,000 robots, and mostly call overhead at 24.
These kernels do the same arithmetic robot by robot in one pass over the state.

Bit identity with the numpy path is by construction: every float operation is the same IEEE
operation in the same order and grouping as the numpy expression it replaces (no fastmath, so no
reassociation or fused multiply-add), np.maximum / np.minimum / np.sign keep their NaN semantics,
and cos, sin and sqrt are libm's (or IEEE) on both sides. numpy's expm1 is its own SIMD code, which
libm's differs from in the last bit for a few percent of arguments, so the Janosi-Hanamoto expm1
stays in numpy: `start` and each `substep` end with the (next) substep's combined slips and their
exponents slip / -k (`expo`, contact-major like the numpy path's (side, axle, robot) array), numpy
takes their expm1 in place, and the next `substep` goes on from there. `SkidModel.step` stays the
reference; the kernels cover its swarm case only (centre of mass centred, static loads), the one
`Physics` takes them for.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from swarm.robot.params import GRAVITY_MPS2
from swarm.robot.skid import SkidModel
from swarm.robot.terrain import COEFFICIENTS

# Columns of the per-class table: `COEFFICIENTS` in order, then buoyancy_fraction^1.5 (jet power).
MU_PEAK, MU_LATERAL, SHEAR_SLIP, ROLLING_RES, TURNING_M, RADIUS_SCALE, BUOY, DRAG, BUOY15 = range(9)
if tuple(COEFFICIENTS) != (
    "mu_peak",
    "mu_lateral",
    "shear_slip",
    "rolling_resistance",
    "turning_resistance_m",
    "rolling_radius_scale",
    "buoyancy_fraction",
    "drag_n_s2_per_m2",
):
    raise ImportError("physics_kernels: the terrain coefficients changed; update the kernels' columns")

# Columns of the per-cell table.
SLOPE_FX, SLOPE_FY, LOAD, CURRENT_X, WAVE_X, WAVE_Y, SURF = range(7)

# Rows of `substep`'s float results and bool flags.
OUT_DISTANCE, OUT_SLIP, OUT_JET, OUT_HIT_HEIGHT, OUT_POWER, OUT_SUBMERSION = range(6)
FLAG_HIT, FLAG_SURF = range(2)


#: Slip below which `SkidModel` holds the combined slip (keeps (1 - exp(-s/k)) / s finite).
_MIN_SLIP = 1e-12
#: Floor of mu_lateral in the patch spin radius, as `SkidModel._ground`.
_MIN_MU = 1e-9
#: Relative slack on crest times, as `SeaState.crests_by`.
CREST_EPS = 1e-9


class Robot(NamedTuple):
    """The robot's constants the kernels use, each computed as `SkidModel` computes it."""

    load_n: float  # static load of each contact, m g / 4
    wheel_radius_m: float
    y_left: float  # contact arms from the centre of mass
    y_right: float
    x_front: float
    x_rear: float
    reg: float  # the model's regularization speed
    mass_kg: float
    inertia: float
    yaw_drag: float  # L^3 / 32, the hull's yaw-drag strip integral

    @classmethod
    def of(cls, model: SkidModel) -> Robot:
        robot = model.robot
        (y_left, y_right), (x_front, x_rear) = robot.contact_y_m, robot.contact_x_m
        return cls(
            robot.mass_kg * GRAVITY_MPS2 / 4.0,
            robot.wheel_radius_m,
            y_left,
            y_right,
            x_front,
            x_rear,
            model.regularization_mps,
            robot.mass_kg,
            robot.yaw_inertia_kgm2,
            robot.length_m**3 / 32.0,
        )


@njit(cache=True, error_model="numpy")
def _max(a: float, b: float) -> float:
    """np.maximum: NaN if either is."""
    return a if a >= b or a != a else b


@njit(cache=True, error_model="numpy")
def _min(a: float, b: float) -> float:
    """np.minimum: NaN if either is."""
    return a if a <= b or a != a else b


@njit(cache=True, error_model="numpy")
def _sign(a: float) -> float:
    """np.sign: 0 for either zero, NaN for NaN."""
    if a > 0.0:
        return 1.0
    if a < 0.0:
        return -1.0
    return 0.0 if a == 0.0 else a


@njit(cache=True, error_model="numpy")
def _cell(x: float, y: float, x0: float, y0: float, inv_cell: float, rows: int, cols: int) -> int:
    """`Physics._cells` of one point."""
    col = min(max(int((x - x0) * inv_cell), 0), cols - 1)
    row = min(max(int((y - y0) * inv_cell), 0), rows - 1)
    return row * cols + col


@njit(cache=True, error_model="numpy")
def wave_table(
    t_s: np.ndarray, phase_s: np.ndarray, period_s: float, skew: float, dt_s: float, n_sub: int
) -> tuple[np.ndarray, np.ndarray]:
    """Per substep and run: the wave shape at the substep's start (`SeaState.wave_shape`) and
    whether a crest passes in it (`SeaState.crests_by` grows), for runs at times `t_s`."""
    n_runs = t_s.shape[0]
    shapes = np.empty((n_sub, n_runs))
    crests = np.empty((n_sub, n_runs), dtype=np.bool_)
    for j in range(n_runs):
        before = math.floor(((t_s[j] + 0.0) - phase_s[j]) / period_s + CREST_EPS)
        for k in range(n_sub):
            phi = 2.0 * math.pi * ((t_s[j] + dt_s * k / n_sub) - phase_s[j]) / period_s
            shapes[k, j] = (math.cos(phi) + skew * math.cos(2.0 * phi)) / (1.0 + skew)
            after = math.floor(((t_s[j] + dt_s * (k + 1) / n_sub) - phase_s[j]) / period_s + CREST_EPS)
            crests[k, j] = after > before
            before = after
    return shapes, crests


@njit(cache=True, error_model="numpy")
def _spin_m(turning_m: float, mu_lateral: float) -> float:
    """The patch spin radius turning_resistance_m / mu_lateral, as `SkidModel._ground`."""
    return turning_m / _max(mu_lateral, _MIN_MU)


@njit(cache=True, error_model="numpy")
def _rolling(w: float, vx: float, reg: float) -> float:
    """A side's rolling speed, max(|w|, |vx|) + reg."""
    return _max(abs(w), abs(vx)) + reg


@njit(cache=True, error_model="numpy")
def _slips(
    i: int,
    u: float,
    v: float,
    r: float,
    w0: float,
    w1: float,
    spin_m: float,
    shear: float,
    rb: Robot,
    slip,
    expo,
) -> None:
    """`SkidModel._contacts` up to the combined slips: robot i's slip of each contact (side, axle)
    into `slip`, and its Janosi-Hanamoto exponent slip / -shear_slip into `expo`."""
    vx0, vx1 = u - rb.y_left * r, u - rb.y_right * r
    vy0, vy1 = v + rb.x_front * r, v + rb.x_rear * r
    roll0, roll1 = _rolling(w0, vx0, rb.reg), _rolling(w1, vx1, rb.reg)
    sx0, sx1 = vx0 - w0, vx1 - w1
    spin = spin_m * r
    a0, a1 = sx0 * sx0 + spin * spin, sx1 * sx1 + spin * spin
    b0, b1 = vy0 * vy0, vy1 * vy1
    k = -shear
    s = _max(math.sqrt(a0 + b0) / roll0, _MIN_SLIP)
    slip[0, i], expo[0, i] = s, s / k
    s = _max(math.sqrt(a0 + b1) / roll0, _MIN_SLIP)
    slip[1, i], expo[1, i] = s, s / k
    s = _max(math.sqrt(a1 + b0) / roll1, _MIN_SLIP)
    slip[2, i], expo[2, i] = s, s / k
    s = _max(math.sqrt(a1 + b1) / roll1, _MIN_SLIP)
    slip[3, i], expo[3, i] = s, s / k


@njit(cache=True, error_model="numpy")
def start(
    state: np.ndarray,
    cmd: np.ndarray,
    inverted: np.ndarray,
    active: np.ndarray,
    coef: np.ndarray,
    terrain: np.ndarray,
    grid: tuple[float, float, float, int, int],
    rb: Robot,
    omega: np.ndarray,
    cell: np.ndarray,
    cls: np.ndarray,
    slip: np.ndarray,
    expo: np.ndarray,
) -> None:
    """Before the first substep: the wheel speeds (an inverted robot's sides swapped and reversed),
    each robot's cell and class (-1 inactive), and the first substep's slips and exponents (0
    inactive). `grid` is (x0, y0, 1 / cell size, rows, cols)."""
    for i in range(state.shape[0]):
        if not active[i]:
            cls[i] = -1
            expo[0, i] = expo[1, i] = expo[2, i] = expo[3, i] = 0.0
            continue
        if inverted[i]:
            omega[i, 0], omega[i, 1] = -cmd[i, 1], -cmd[i, 0]
        else:
            omega[i, 0], omega[i, 1] = cmd[i, 0], cmd[i, 1]
        here = _cell(state[i, 0], state[i, 1], *grid)
        c = terrain[here]
        cell[i], cls[i] = here, c
        surface = rb.wheel_radius_m * coef[c, RADIUS_SCALE]
        w0, w1 = omega[i, 0] * surface, omega[i, 1] * surface
        spin_m = _spin_m(coef[c, TURNING_M], coef[c, MU_LATERAL])
        _slips(i, state[i, 3], state[i, 4], state[i, 5], w0, w1, spin_m, coef[c, SHEAR_SLIP], rb, slip, expo)


@njit(cache=True, error_model="numpy")
def _velocities(
    i: int,
    u: float,
    v: float,
    r: float,
    w0: float,
    w1: float,
    coef: np.ndarray,
    c: int,
    load_scale: float,
    force_x: float,
    force_y: float,
    slip: np.ndarray,
    expm1: np.ndarray,
    h: float,
    rb: Robot,
) -> tuple[float, float, float, float, float]:
    """`SkidModel.step`'s new velocities (u, v, r) and the sides' slip traction for robot i on
    class c, from its contacts' slips and their expm1(slip / -shear_slip), under the external
    force (Fx, Fy, 0)."""
    mu_peak, mu_lat, buoy, drag = coef[c, MU_PEAK], coef[c, MU_LATERAL], coef[c, BUOY], coef[c, DRAG]
    spin_m = _spin_m(coef[c, TURNING_M], mu_lat)
    load_n = rb.load_n * ((1.0 - buoy) * load_scale)
    roll = 2.0 * coef[c, ROLLING_RES] * load_n
    vx0, vx1 = u - rb.y_left * r, u - rb.y_right * r
    # secant slopes of the contacts (side, axle): expm1(-s/k) / s times -load / rolling speed
    q0, q1 = -load_n / _rolling(w0, vx0, rb.reg), -load_n / _rolling(w1, vx1, rb.reg)
    sec00, sec01 = expm1[0, i] / slip[0, i] * q0, expm1[1, i] / slip[1, i] * q0
    sec10, sec11 = expm1[2, i] / slip[2, i] * q1, expm1[3, i] / slip[3, i] * q1
    axle0, axle1 = sec00 + sec10, sec01 + sec11
    kx_side0, kx_side1 = mu_peak * (sec00 + sec01), mu_peak * (sec10 + sec11)
    ky0, ky1 = mu_lat * axle0, mu_lat * axle1
    k_spin = mu_lat * spin_m * spin_m * (axle0 + axle1)
    lin = drag * math.sqrt(u * u + v * v)
    yaw = drag * rb.yaw_drag * abs(r)
    reg = rb.reg
    kx0 = kx_side0 + roll / math.sqrt(vx0 * vx0 + reg * reg)
    kx1 = kx_side1 + roll / math.sqrt(vx1 * vx1 + reg * reg)
    d0, d1 = kx_side0 * w0, kx_side1 * w1
    # the 3x3 system of the linearly implicit step, eliminated in closed form
    y_left, y_right, x_front, x_rear = rb.y_left, rb.y_right, rb.x_front, rb.x_rear
    m, m_h, i_h = rb.mass_kg, rb.mass_kg / h, rb.inertia / h
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
    b1 = m * (u / h + v * r) + d0 + d1 + force_x
    b2 = m * (v / h - u * r) + force_y
    b3 = i_h * r - (y_left * d0 + y_right * d1) + 0.0
    e1, e2 = a13 / a11, a23 / a22
    r_new = (b3 - e1 * b1 - e2 * b2) / (a33 - e1 * a13 - e2 * a23)
    u_new = (b1 - a13 * r_new) / a11
    v_new = (b2 - a23 * r_new) / a22
    traction0 = kx_side0 * (w0 - (u_new - y_left * r_new))
    traction1 = kx_side1 * (w1 - (u_new - y_right * r_new))
    return u_new, v_new, r_new, traction0, traction1


@njit(cache=True, error_model="numpy")
def _wrench(
    u: float,
    v: float,
    cos_h: float,
    sin_h: float,
    shape: float,
    props: np.ndarray,
    here: int,
    buoy: float,
    drag: float,
    thrust: float,
) -> tuple[float, float]:
    """Body-frame external force (Fx, Fy) in cell `here`: hull drag corrected to the water's
    relative velocity, the jet, and the slope's pull on the weight the water leaves."""
    wx = props[here, CURRENT_X] + shape * props[here, WAVE_X]
    wy = shape * props[here, WAVE_Y]
    ru = u - (wx * cos_h + wy * sin_h)
    rv = v - (wy * cos_h - wx * sin_h)
    speed = math.sqrt(u * u + v * v)
    rel = math.sqrt(ru * ru + rv * rv)
    support = 1.0 - buoy
    gx, gy = support * props[here, SLOPE_FX], support * props[here, SLOPE_FY]
    force_x = drag * (speed * u - rel * ru) + thrust * buoy + (gx * cos_h + gy * sin_h)
    force_y = drag * (speed * v - rel * rv) + (gy * cos_h - gx * sin_h)
    return force_x, force_y


@njit(cache=True, error_model="numpy")
def _slip_ratio(w: float, u: float, min_speed: float) -> float:
    """Longitudinal slip of the mean wheel (surface speed w) at body speed u, in [0, 1]."""
    aw = abs(w)
    ratio = (aw - _sign(w) * u) / _max(_max(aw, abs(u)), min_speed)
    ratio = _max(_min(ratio, 1.0), 0.0)
    return 0.0 if aw < min_speed else ratio


@njit(cache=True, error_model="numpy")
def substep(
    k: int,
    n_sub: int,
    h: float,
    state: np.ndarray,
    omega: np.ndarray,
    thrust: np.ndarray,
    active: np.ndarray,
    run: np.ndarray,
    cell: np.ndarray,
    cls: np.ndarray,
    slip: np.ndarray,
    expo: np.ndarray,
    coef: np.ndarray,
    props: np.ndarray,
    terrain: np.ndarray,
    impassable: np.ndarray,
    grid: tuple[float, float, float, int, int],
    rb: Robot,
    shapes: np.ndarray,
    crests: np.ndarray,
    slip_min_speed: float,
    jet_w: np.ndarray,
    drive_scale: float,
    out: np.ndarray,
    flags: np.ndarray,
    obstacle: np.ndarray,
) -> None:
    """Substep k of `h` seconds for every active robot, in place: `state`, `cell`, `cls`, the
    results in `out` (rows `OUT_*`, sums until the last substep ends them), `flags` (`FLAG_*`)
    and `obstacle`. `slip` and `expo` come in as the substep's slips and their expm1 and go out as
    the next substep's slips and exponents. `jet_w` is the jet's power at full submersion,
    `drive_scale` 1 / drive efficiency."""
    last = k == n_sub - 1
    for i in range(state.shape[0]):
        if not active[i]:
            continue
        x, y, heading, u, v, r = state[i, 0], state[i, 1], state[i, 2], state[i, 3], state[i, 4], state[i, 5]
        here, c = cell[i], cls[i]
        buoy, scale = coef[c, BUOY], coef[c, RADIUS_SCALE]
        cos_h, sin_h = math.cos(heading), math.sin(heading)
        shape = shapes[k, run[i]]
        force_x, force_y = _wrench(u, v, cos_h, sin_h, shape, props, here, buoy, coef[c, DRAG], thrust[i])
        surface = rb.wheel_radius_m * scale
        o0, o1 = omega[i, 0], omega[i, 1]
        w0, w1 = o0 * surface, o1 * surface
        u_new, v_new, r_new, traction0, traction1 = _velocities(
            i, u, v, r, w0, w1, coef, c, props[here, LOAD], force_x, force_y, slip, expo, h, rb
        )
        mid = heading + 0.5 * h * r_new
        cos_m, sin_m = math.cos(mid), math.sin(mid)
        x_new = x + h * (u_new * cos_m - v_new * sin_m)
        y_new = y + h * (u_new * sin_m + v_new * cos_m)
        to = _cell(x_new, y_new, *grid)
        to_cls = terrain[to]
        if impassable[to_cls] and to != here:  # undo the move into an obstacle, keep the turn
            x_new, y_new, u_new, v_new = x, y, 0.0, 0.0
            obstacle[i] = to_cls
            to, to_cls = here, c
        state[i, 0], state[i, 1], state[i, 2] = x_new, y_new, heading + h * r_new
        state[i, 3], state[i, 4], state[i, 5] = u_new, v_new, r_new
        cell[i], cls[i] = to, to_cls
        dx, dy = x_new - x, y_new - y
        out[OUT_DISTANCE, i] += math.sqrt(dx * dx + dy * dy)
        mean_w = 0.5 * (o0 + o1) * scale * rb.wheel_radius_m
        out[OUT_SLIP, i] += _slip_ratio(mean_w, u_new, slip_min_speed)
        out[OUT_JET, i] += coef[c, BUOY15]
        surf = props[here, SURF]
        if crests[k, run[i]]:
            flags[FLAG_HIT, i] |= surf > 0.0
            out[OUT_HIT_HEIGHT, i] = _max(out[OUT_HIT_HEIGHT, i], surf)
        if last:  # wheel power from the last substep's slip traction (rolling resistance left out)
            left = _max(traction0 * (o0 * surface), 0.0)
            wheel = left + _max(traction1 * (o1 * surface), 0.0)
            out[OUT_POWER, i] = wheel * drive_scale + jet_w[i] * out[OUT_JET, i] * (1.0 / n_sub)
            out[OUT_SLIP, i] /= n_sub
            out[OUT_SUBMERSION, i] = buoy
            flags[FLAG_SURF, i] = surf > 0.0
        else:
            surface = rb.wheel_radius_m * coef[to_cls, RADIUS_SCALE]
            spin_m = _spin_m(coef[to_cls, TURNING_M], coef[to_cls, MU_LATERAL])
            shear = coef[to_cls, SHEAR_SLIP]
            _slips(i, u_new, v_new, r_new, o0 * surface, o1 * surface, spin_m, shear, rb, slip, expo)
