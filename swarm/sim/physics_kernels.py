"""Fused numba kernels for the swarm's physics substeps (`Physics.step`), bit for bit the numpy path.

The numpy path (`SkidModel.step` and the world terms around it) makes ~100 array passes per
substep with their temporaries: ~2 ms a substep at 10,000 robots, and mostly call overhead at 24.
These kernels do the same arithmetic robot by robot, in a few passes over the robots: the loops
that gather by cell and class, take cosines and branch (obstacles, inactive robots) hand their
rows to loops that only do arithmetic, which LLVM vectorizes (the divisions and square roots are
most of the work). Numpy's error model: a zero divisor gives inf or NaN, as in numpy.

Bit identity with the numpy path is by construction: every float operation is the same IEEE
operation in the same order and grouping as the numpy expression it replaces (no fastmath, so no
reassociation or fused multiply-add), np.maximum / np.minimum / np.sign keep their NaN semantics,
and cos, sin and sqrt are libm's (or IEEE) on both sides. numpy's expm1 is its own SIMD code, which
libm's differs from in the last bit for a few percent of arguments, so the Janosi-Hanamoto expm1
stays in numpy: `start` and each `substep` end with the (next) substep's combined slips and their
exponents slip / -k (rows `EXPONENTS` of `contacts`), numpy takes their expm1 in place, and the
next `substep` goes on from there. `SkidModel.step` stays the reference; the kernels cover its
swarm case only (centre of mass centred, static loads), the one `Physics` takes them for.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from swarm.robot.npmath import maximum, minimum, sign
from swarm.robot.params import GRAVITY_MPS2
from swarm.robot.skid import SkidModel
from swarm.robot.skid_run import implicit_velocities
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

# Rows of the scratch arrays the passes of a substep hand on, robots along the rows: `work` (each
# robot's inputs to the vectorized passes), `contacts` (the contacts' combined slips, then their
# exponents, expm1 in place between kernels; contact-major as the numpy path's (side, axle, robot)
# array) and `solved` (the new velocities and the sides' traction, then the move and the mean
# wheel surface speed).
_U, _V, _R, _W0, _W1, _TURNING, _MU_LAT, _SHEAR, _MU_PEAK, _LOAD_N, _ROLL, _DRAG, _FX, _FY = range(14)
WORK_ROWS = 14
EXPONENTS = slice(4, 8)  # after the four slips
CONTACT_ROWS = 8
_U_NEW, _V_NEW, _R_NEW, _TRACTION0, _TRACTION1, _DX, _DY, _MEAN_W = range(8)
SOLVED_ROWS = 8

# Rows of `substep`'s float results and bool flags.
OUT_DISTANCE, OUT_SLIP, OUT_JET, OUT_HIT_HEIGHT, OUT_POWER, OUT_SUBMERSION = range(6)
OUT_ROWS = 6
FLAG_HIT, FLAG_SURF = range(2)
FLAG_ROWS = 2


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
def cell_index(x: float, y: float, x0: float, y0: float, inv_cell: float, rows: int, cols: int) -> int:
    """`Physics._cells` of one point."""
    col = min(max(int((x - x0) * inv_cell), 0), cols - 1)
    row = min(max(int((y - y0) * inv_cell), 0), rows - 1)
    return row * cols + col


@njit(cache=True, error_model="numpy")
def cell_index_inside(x: float, y: float, x0: float, y0: float, inv_cell: float, cols: int) -> int:
    """`cell_index` of a point known to lie on the grid, where its clamps cannot bind."""
    return int((y - y0) * inv_cell) * cols + int((x - x0) * inv_cell)


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
    return turning_m / maximum(mu_lateral, _MIN_MU)


@njit(cache=True, error_model="numpy")
def _rolling(w: float, vx: float, reg: float) -> float:
    """A side's rolling speed, max(|w|, |vx|) + reg."""
    return maximum(abs(w), abs(vx)) + reg


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
def _inputs(
    i: int,
    heading: float,
    u: float,
    v: float,
    r: float,
    o0: float,
    o1: float,
    here: int,
    c: int,
    shape: float,
    thrust: float,
    coef: np.ndarray,
    props: np.ndarray,
    rb: Robot,
    work: np.ndarray,
) -> None:
    """Robot i's inputs to the vectorized passes of a substep it starts in cell `here` of class
    c: its velocities and wheel surface speeds, the coefficients, the contacts' load and rolling
    resistance, and the external force."""
    surface = rb.wheel_radius_m * coef[c, RADIUS_SCALE]
    buoy, drag = coef[c, BUOY], coef[c, DRAG]
    fx, fy = _wrench(u, v, math.cos(heading), math.sin(heading), shape, props, here, buoy, drag, thrust)
    load_n = rb.load_n * ((1.0 - buoy) * props[here, LOAD])
    work[_U, i], work[_V, i], work[_R, i] = u, v, r
    work[_W0, i], work[_W1, i] = o0 * surface, o1 * surface
    work[_TURNING, i], work[_MU_LAT, i], work[_SHEAR, i] = (
        coef[c, TURNING_M],
        coef[c, MU_LATERAL],
        coef[c, SHEAR_SLIP],
    )
    work[_FX, i], work[_FY, i], work[_DRAG, i] = fx, fy, drag
    work[_MU_PEAK, i], work[_LOAD_N, i], work[_ROLL, i] = (
        coef[c, MU_PEAK],
        load_n,
        2.0 * coef[c, ROLLING_RES] * load_n,
    )


@njit(cache=True, error_model="numpy")
def _slips_pass(work: np.ndarray, rb: Robot, contacts: np.ndarray) -> None:
    """`SkidModel._contacts` up to the combined slips, for every row of `work` (no gathers, no
    branches: the loop vectorizes): each contact's slip (side, axle) and its Janosi-Hanamoto
    exponent slip / -shear_slip into `contacts`."""
    y_left, y_right, x_front, x_rear, reg = rb.y_left, rb.y_right, rb.x_front, rb.x_rear, rb.reg
    for i in range(work.shape[1]):
        u, v, r, w0, w1 = work[_U, i], work[_V, i], work[_R, i], work[_W0, i], work[_W1, i]
        vx0, vx1 = u - y_left * r, u - y_right * r
        vy0, vy1 = v + x_front * r, v + x_rear * r
        roll0, roll1 = _rolling(w0, vx0, reg), _rolling(w1, vx1, reg)
        sx0, sx1 = vx0 - w0, vx1 - w1
        spin = _spin_m(work[_TURNING, i], work[_MU_LAT, i]) * r
        a0, a1 = sx0 * sx0 + spin * spin, sx1 * sx1 + spin * spin
        b0, b1 = vy0 * vy0, vy1 * vy1
        s00 = maximum(math.sqrt(a0 + b0) / roll0, _MIN_SLIP)
        s01 = maximum(math.sqrt(a0 + b1) / roll0, _MIN_SLIP)
        s10 = maximum(math.sqrt(a1 + b0) / roll1, _MIN_SLIP)
        s11 = maximum(math.sqrt(a1 + b1) / roll1, _MIN_SLIP)
        k = -work[_SHEAR, i]
        contacts[0, i], contacts[1, i], contacts[2, i], contacts[3, i] = s00, s01, s10, s11
        contacts[4, i], contacts[5, i], contacts[6, i], contacts[7, i] = s00 / k, s01 / k, s10 / k, s11 / k


@njit(cache=True, error_model="numpy")
def start(
    state: np.ndarray,
    cmd: np.ndarray,
    inverted: np.ndarray,
    active: np.ndarray,
    run: np.ndarray,
    thrust: np.ndarray,
    coef: np.ndarray,
    props: np.ndarray,
    terrain: np.ndarray,
    grid: tuple[float, float, float, int, int],
    rb: Robot,
    shapes: np.ndarray,
    omega: np.ndarray,
    cell: np.ndarray,
    cls: np.ndarray,
    work: np.ndarray,
    contacts: np.ndarray,
) -> None:
    """Before the first substep: the wheel speeds (an inverted robot's sides swapped and reversed),
    each robot's cell and class (-1 inactive), and the first substep's inputs, slips and exponents (for
    the inactive, those of a robot at rest with zero coefficients: finite). `grid` is (x0, y0,
    1 / cell size, rows, cols)."""
    for i in range(state.shape[0]):
        if not active[i]:
            cls[i] = -1
            for row in range(WORK_ROWS):
                work[row, i] = 0.0
            work[_SHEAR, i] = 1.0
            continue
        if inverted[i]:
            omega[i, 0], omega[i, 1] = -cmd[i, 1], -cmd[i, 0]
        else:
            omega[i, 0], omega[i, 1] = cmd[i, 0], cmd[i, 1]
        here = cell_index(state[i, 0], state[i, 1], *grid)
        c = terrain[here]
        cell[i], cls[i] = here, c
        heading, u, v, r = state[i, 2], state[i, 3], state[i, 4], state[i, 5]
        shape = shapes[0, run[i]]
        _inputs(
            i, heading, u, v, r, omega[i, 0], omega[i, 1], here, c, shape, thrust[i], coef, props, rb, work
        )
    _slips_pass(work, rb, contacts)


@njit(cache=True, error_model="numpy")
def _velocities_pass(h: float, work: np.ndarray, contacts: np.ndarray, rb: Robot, solved: np.ndarray) -> None:
    """`SkidModel.step`'s new velocities (u, v, r) and the sides' slip traction, from the
    contacts' slips and their expm1(slip / -shear_slip), for every row (vectorizes). LLVM checks
    at run time that the rows it reads and writes do not overlap, and gives up vectorizing past a
    few dozen rows: three more `work` rows read here (the external force's terms) made this pass
    scalar and the step 40% slower, so check the assembly for vdivpd after adding any."""
    y_left, y_right, x_front, x_rear, reg = rb.y_left, rb.y_right, rb.x_front, rb.x_rear, rb.reg
    m, m_h, i_h = rb.mass_kg, rb.mass_kg / h, rb.inertia / h
    for i in range(work.shape[1]):
        u, v, r, w0, w1 = work[_U, i], work[_V, i], work[_R, i], work[_W0, i], work[_W1, i]
        mu_peak, mu_lat, drag, load_n = work[_MU_PEAK, i], work[_MU_LAT, i], work[_DRAG, i], work[_LOAD_N, i]
        spin_m = _spin_m(work[_TURNING, i], mu_lat)
        vx0, vx1 = u - y_left * r, u - y_right * r
        # secant slopes of the contacts (side, axle): expm1(-s/k) / s times -load / rolling speed
        q0, q1 = -load_n / _rolling(w0, vx0, reg), -load_n / _rolling(w1, vx1, reg)
        sec00, sec01 = contacts[4, i] / contacts[0, i] * q0, contacts[5, i] / contacts[1, i] * q0
        sec10, sec11 = contacts[6, i] / contacts[2, i] * q1, contacts[7, i] / contacts[3, i] * q1
        axle0, axle1 = sec00 + sec10, sec01 + sec11
        kx_side0, kx_side1 = mu_peak * (sec00 + sec01), mu_peak * (sec10 + sec11)
        ky0, ky1 = mu_lat * axle0, mu_lat * axle1
        k_spin = mu_lat * spin_m * spin_m * (axle0 + axle1)
        lin = drag * math.sqrt(u * u + v * v)
        yaw = drag * rb.yaw_drag * abs(r)
        kx0 = kx_side0 + work[_ROLL, i] / math.sqrt(vx0 * vx0 + reg * reg)
        kx1 = kx_side1 + work[_ROLL, i] / math.sqrt(vx1 * vx1 + reg * reg)
        d0, d1 = kx_side0 * w0, kx_side1 * w1
        b1 = m * (u / h + v * r) + d0 + d1 + work[_FX, i]
        b2 = m * (v / h - u * r) + work[_FY, i]
        b3 = i_h * r - (y_left * d0 + y_right * d1) + 0.0
        u_new, v_new, r_new = implicit_velocities(
            m_h, i_h, kx0, kx1, ky0, ky1, lin, yaw, k_spin, y_left, y_right, x_front, x_rear, b1, b2, b3
        )
        solved[_U_NEW, i], solved[_V_NEW, i], solved[_R_NEW, i] = u_new, v_new, r_new
        solved[_TRACTION0, i] = kx_side0 * (w0 - (u_new - y_left * r_new))
        solved[_TRACTION1, i] = kx_side1 * (w1 - (u_new - y_right * r_new))


@njit(cache=True, error_model="numpy")
def _slip_ratio(w: float, u: float, min_speed: float) -> float:
    """Longitudinal slip of the mean wheel (surface speed w) at body speed u, in [0, 1]."""
    aw = abs(w)
    ratio = (aw - sign(w) * u) / maximum(maximum(aw, abs(u)), min_speed)
    ratio = maximum(minimum(ratio, 1.0), 0.0)
    return 0.0 if aw < min_speed else ratio


@njit(cache=True, error_model="numpy")
def _move_pass(
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
    coef: np.ndarray,
    props: np.ndarray,
    terrain: np.ndarray,
    impassable: np.ndarray,
    grid: tuple[float, float, float, int, int],
    rb: Robot,
    shapes: np.ndarray,
    crests: np.ndarray,
    jet_w: np.ndarray,
    drive_scale: float,
    solved: np.ndarray,
    work: np.ndarray,
    out: np.ndarray,
    flags: np.ndarray,
    obstacle: np.ndarray,
) -> None:
    """The pose update from the new velocities, the obstacle check, and what the substep adds to
    the results but distance and slip (`_tally_pass`); then the next substep's inputs (the last
    substep ends the results)."""
    last = k == n_sub - 1
    for i in range(state.shape[0]):
        if not active[i]:  # no move, no wheel speed: nothing for `_tally_pass` to add
            solved[_U_NEW, i] = solved[_DX, i] = solved[_DY, i] = solved[_MEAN_W, i] = 0.0
            continue
        x, y, heading = state[i, 0], state[i, 1], state[i, 2]
        u_new, v_new, r_new = solved[_U_NEW, i], solved[_V_NEW, i], solved[_R_NEW, i]
        here, c = cell[i], cls[i]
        scale, surf = coef[c, RADIUS_SCALE], props[here, SURF]
        mid = heading + 0.5 * h * r_new
        cos_m, sin_m = math.cos(mid), math.sin(mid)
        x_new = x + h * (u_new * cos_m - v_new * sin_m)
        y_new = y + h * (u_new * sin_m + v_new * cos_m)
        to = cell_index(x_new, y_new, *grid)
        to_cls = terrain[to]
        if impassable[to_cls] and to != here:  # undo the move into an obstacle, keep the turn
            x_new, y_new, u_new, v_new = x, y, 0.0, 0.0
            obstacle[i] = to_cls
            to, to_cls = here, c
        heading_new = heading + h * r_new
        state[i, 0], state[i, 1], state[i, 2] = x_new, y_new, heading_new
        state[i, 3], state[i, 4], state[i, 5] = u_new, v_new, r_new
        cell[i], cls[i] = to, to_cls
        o0, o1 = omega[i, 0], omega[i, 1]
        solved[_U_NEW, i], solved[_DX, i], solved[_DY, i] = u_new, x_new - x, y_new - y
        solved[_MEAN_W, i] = 0.5 * (o0 + o1) * scale * rb.wheel_radius_m
        out[OUT_JET, i] += coef[c, BUOY15]
        if crests[k, run[i]]:
            flags[FLAG_HIT, i] |= surf > 0.0
            out[OUT_HIT_HEIGHT, i] = maximum(out[OUT_HIT_HEIGHT, i], surf)
        if last:  # wheel power from the last substep's slip traction (rolling resistance left out)
            surface = rb.wheel_radius_m * scale
            left = maximum(solved[_TRACTION0, i] * (o0 * surface), 0.0)
            wheel = left + maximum(solved[_TRACTION1, i] * (o1 * surface), 0.0)
            out[OUT_POWER, i] = wheel * drive_scale + jet_w[i] * out[OUT_JET, i] * (1.0 / n_sub)
            out[OUT_SUBMERSION, i] = coef[c, BUOY]
            flags[FLAG_SURF, i] = surf > 0.0
        else:
            shape = shapes[k + 1, run[i]]
            _inputs(
                i,
                heading_new,
                u_new,
                v_new,
                r_new,
                o0,
                o1,
                to,
                to_cls,
                shape,
                thrust[i],
                coef,
                props,
                rb,
                work,
            )


@njit(cache=True, error_model="numpy")
def _tally_pass(last: bool, n_sub: int, solved: np.ndarray, min_speed: float, out: np.ndarray) -> None:
    """Each robot's distance and mean-wheel slip over the substep, added to the results (the last
    substep makes the slip a mean); for every row, so the loop vectorizes."""
    for i in range(solved.shape[1]):
        dx, dy = solved[_DX, i], solved[_DY, i]
        out[OUT_DISTANCE, i] += math.sqrt(dx * dx + dy * dy)
        slip = out[OUT_SLIP, i] + _slip_ratio(solved[_MEAN_W, i], solved[_U_NEW, i], min_speed)
        out[OUT_SLIP, i] = slip / n_sub if last else slip


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
    work: np.ndarray,
    contacts: np.ndarray,
    solved: np.ndarray,
    out: np.ndarray,
    flags: np.ndarray,
    obstacle: np.ndarray,
) -> None:
    """Substep k of `h` seconds for every active robot, in place: `state`, `cell`, `cls`, the
    results in `out` (rows `OUT_*`, sums until the last substep ends them), `flags` (`FLAG_*`)
    and `obstacle`. `contacts` comes in with the substep's slips and the expm1 of their exponents
    and goes out with the next substep's (`work` and `solved` are scratch). `jet_w` is the jet's
    power at full submersion, `drive_scale` 1 / drive efficiency. In passes, so that the gathers,
    cosines and branches stay out of the loops that do the divisions and square roots."""
    _velocities_pass(h, work, contacts, rb, solved)
    _move_pass(
        k,
        n_sub,
        h,
        state,
        omega,
        thrust,
        active,
        run,
        cell,
        cls,
        coef,
        props,
        terrain,
        impassable,
        grid,
        rb,
        shapes,
        crests,
        jet_w,
        drive_scale,
        solved,
        work,
        out,
        flags,
        obstacle,
    )
    _tally_pass(k == n_sub - 1, n_sub, solved, slip_min_speed, out)
    if k < n_sub - 1:
        _slips_pass(work, rb, contacts)
