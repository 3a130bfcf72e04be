"""Physics of the three motion models: closed forms, invariants, and the integrators against each other."""

from __future__ import annotations

import itertools
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from swarm.robot.kinematic import kinematic
from swarm.robot.lagrangian import lagrangian
from swarm.robot.params import GRAVITY_MPS2, load_robot
from swarm.robot.skid import SkidModel, coeffs_for
from swarm.robot.terrain import TerrainMode, load_library
from swarm.robot.wheels import WheelInput

ROOT = Path(__file__).resolve().parents[2]
ROBOT = load_robot(ROOT / "swarm" / "data" / "robots" / "skid4.yaml")
LIB = load_library()


def ground(**kw: float) -> TerrainMode:
    """A dry test surface: concrete's coefficients with some replaced."""
    return replace(LIB["concrete"], **kw)


def steady(
    model: SkidModel, omega: tuple[float, float], mode: TerrainMode, t_s: float = 6.0, dt: float = 0.002
):
    state = np.zeros((1, 6))
    c = coeffs_for(mode)
    for _ in range(int(t_s / dt)):
        state = model.step(state, np.array([omega]), c, dt)
    return state[0]


# ---------------------------------------------------------------------------------------------
# kinematic


def test_kinematic_hand_computed_arc() -> None:
    """One step of wheel rotation: heading and position by hand from eqs. 2.24-2.26 (R - L sign)."""
    wheels = WheelInput(np.array([0.0, 1.0]), np.array([0.0, 2.0]), np.array([0.0, 4.0]))
    x, y, h = kinematic(wheels, ROBOT, heading0_rad=0.3)
    r, d = ROBOT.wheel_radius_m, ROBOT.track_width_m
    assert h[-1] == pytest.approx(0.3 + r * (4.0 - 2.0) / d)
    assert x[-1] == pytest.approx(r * 3.0 * math.cos(0.3))
    assert y[-1] == pytest.approx(r * 3.0 * math.sin(0.3))


def test_kinematic_heading_scale_and_icr_factors() -> None:
    """heading_scale 0.73 is the thesis's d / 0.73 effective track, and chi does the same."""
    t = np.linspace(0, 2, 21)
    wheels = WheelInput(t, 1.0 * t, 3.0 * t)
    _, _, h_scaled = kinematic(wheels, ROBOT, heading_scale=0.73)
    _, _, h_chi = kinematic(wheels, ROBOT, chi=1 / 0.73)
    assert h_scaled[-1] == pytest.approx(h_chi[-1])
    assert h_scaled[-1] == pytest.approx(0.73 * ROBOT.wheel_radius_m * (6.0 - 2.0) / ROBOT.track_width_m)
    x_a, _, _ = kinematic(WheelInput(t, 2 * t, 2 * t), ROBOT, alpha=0.8)
    assert x_a[-1] == pytest.approx(0.8 * ROBOT.wheel_radius_m * 4.0)


def test_straight_commands_keep_heading_in_every_model() -> None:
    t = np.linspace(0, 4, 401)
    angle = 5.0 * t - 2.0 * np.maximum(t - 2.0, 0.0) ** 2  # accelerating, then slowing
    wheels = WheelInput(t, angle, angle.copy())
    for fn in (kinematic, lagrangian):
        _, y, h = fn(wheels, ROBOT, heading0_rad=0.0)
        assert np.max(np.abs(h)) < 1e-12
        assert np.max(np.abs(y)) < 1e-12
    model = SkidModel(ROBOT)
    _, states = model.simulate_fixed(
        np.zeros((1, 6)), lambda a, b: wheels.mean_speeds(a, b)[None], coeffs_for(LIB["soft_sand"]), 4.0, 0.01
    )
    assert np.max(np.abs(states[:, 0, 2])) < 1e-12
    assert np.max(np.abs(states[:, 0, 1])) < 1e-12


# ---------------------------------------------------------------------------------------------
# Lagrangian: the thesis's equations


def test_lagrangian_matches_closed_form_of_eqs_2_20_and_2_22() -> None:
    """Constant wheel accelerations give constant F and tau, so x = F t^2 / 2m and theta = tau t^2 / 2 I_R."""
    t = np.linspace(0.0, 2.0, 201)
    a_left, a_right = 1.0, 3.0  # rad/s^2
    wheels = WheelInput(t, 0.5 * a_left * t**2, 0.5 * a_right * t**2)
    x, y, h = lagrangian(wheels, ROBOT, robot_inertia_scale=1.0, wheel_inertia_scale=1.0)
    # the thesis's per-sample omega lags the true one by one sample: it starts after the first step
    i_w = ROBOT.wheel_mass_kg * ROBOT.wheel_radius_m**2 + ROBOT.wheel_mass_kg * ROBOT.wheel_offset_m**2
    force = (a_left + a_right) * i_w / ROBOT.wheel_radius_m
    torque = ROBOT.width_m / 2 * (a_right - a_left) * i_w / ROBOT.wheel_radius_m
    i_r = ROBOT.mass_kg / 12 * (ROBOT.length_m**2 + ROBOT.width_m**2)
    # The thesis's omega_k is the mean over the interval ending at t_k and omega_0 = 0, so the
    # first interval sees half the acceleration and the rate lags by dt/2 afterwards:
    # theta(T) = tau/I_R (T^2/2 - dt T/2 + dt^2/4), v(t) = F/m (t - dt/2).
    dt, end = t[1] - t[0], t[-1]
    assert h[-1] == pytest.approx(torque / i_r * (end**2 / 2 - dt * end / 2 + dt**2 / 4), rel=1e-6)
    chord = np.hypot(x[-1] - x[-2], y[-1] - y[-2]) / dt  # mean speed over the last interval
    assert chord == pytest.approx(force / ROBOT.mass_kg * (end - dt), rel=1e-4)


def test_lagrangian_inertia_scales_act_as_the_thesis_says() -> None:
    """I_R x 1.7 turns 1/1.7 as much; I_w x 0.97 scales both force and torque by 0.97."""
    t = np.linspace(0.0, 1.0, 101)
    wheels = WheelInput(t, 0.5 * t**2, 2.0 * t**2)
    _, _, h1 = lagrangian(wheels, ROBOT, robot_inertia_scale=1.0, wheel_inertia_scale=1.0)
    _, _, h17 = lagrangian(wheels, ROBOT, robot_inertia_scale=1.7, wheel_inertia_scale=1.0)
    _, _, h97 = lagrangian(wheels, ROBOT, robot_inertia_scale=1.0, wheel_inertia_scale=0.97)
    assert h17[-1] == pytest.approx(h1[-1] / 1.7, rel=1e-6)
    assert h97[-1] == pytest.approx(h1[-1] * 0.97, rel=1e-6)


# ---------------------------------------------------------------------------------------------
# skid: invariants and closed forms


def test_steady_slip_matches_janosi_hanamoto_balance() -> None:
    """Driving straight at constant speed, traction balances rolling resistance on every wheel:
    mu (1 - exp(-i / k)) = c_rr, so the slip ratio is i = -k ln(1 - c_rr / mu)."""
    mu, k, crr = 0.6, 0.1, 0.15
    mode = ground(mu_peak=mu, mu_lateral=0.5, shear_slip=k, rolling_resistance=crr, turning_resistance_m=0.0)
    omega = 8.0
    s = steady(SkidModel(ROBOT, regularization_mps=1e-4), (omega, omega), mode)
    wheel_speed = omega * ROBOT.wheel_radius_m
    slip = (wheel_speed - s[3]) / wheel_speed
    assert slip == pytest.approx(-k * math.log(1 - crr / mu), rel=2e-3)


def test_pivot_turn_rate_of_isotropic_coulomb_contacts() -> None:
    """Equal and opposite wheels, isotropic friction near Coulomb, no spin friction: the yaw
    moment balance of four point contacts at (+-l/2, +-t/2) gives r = W a / (a^2 + b^2), with
    W the wheel surface speed, a = t/2, b = l/2 (the kinematic model's W / a times a^2/(a^2+b^2))."""
    mode = ground(
        mu_peak=0.8, mu_lateral=0.8, shear_slip=0.002, rolling_resistance=0.0, turning_resistance_m=0.0
    )
    s = steady(SkidModel(ROBOT, regularization_mps=1e-4), (-4.0, 4.0), mode, dt=0.0005, t_s=3.0)
    a, b = ROBOT.track_width_m / 2, ROBOT.wheelbase_m / 2
    w = 4.0 * ROBOT.wheel_radius_m
    assert s[5] == pytest.approx(w * a / (a**2 + b**2), rel=0.01)
    assert abs(s[3]) < 1e-6 and abs(s[4]) < 1e-6  # a pivot stays in place


def test_symmetric_commands_keep_heading_and_mirror_turns() -> None:
    model = SkidModel(ROBOT)
    mode = LIB["wet_hard_sand"]
    straight = steady(model, (6.0, 6.0), mode, t_s=2.0)
    assert abs(straight[2]) < 1e-12 and abs(straight[5]) < 1e-12 and abs(straight[1]) < 1e-12
    left = steady(model, (3.0, 7.0), mode, t_s=2.0)
    right = steady(model, (7.0, 3.0), mode, t_s=2.0)
    assert left[2] > 0
    np.testing.assert_allclose(left[[0, 3]], right[[0, 3]], rtol=1e-12)
    np.testing.assert_allclose(left[[1, 2, 4, 5]], -right[[1, 2, 4, 5]], rtol=1e-12)


@pytest.mark.parametrize("key", ["mu_lateral", "turning_resistance_m"])
def test_more_lateral_traction_turns_less(key: str) -> None:
    """Same wheel commands: more sideways grip (or spin friction) resists the skid that turning
    needs, so the robot turns less; always less than the no-slip kinematic rate."""
    model = SkidModel(ROBOT)
    base = ground(mu_lateral=0.3, turning_resistance_m=0.02)
    rates = [
        steady(model, (2.0, 8.0), replace(base, **{key: getattr(base, key) * f}), t_s=3.0)[5]
        for f in (0.5, 1.0, 2.0, 4.0)
    ]
    assert all(a > b for a, b in itertools.pairwise(rates))
    assert rates[0] < ROBOT.wheel_radius_m * 6.0 / ROBOT.track_width_m


def test_zero_input_decays_to_rest_without_gaining_energy() -> None:
    """Wheels held still: contacts and rolling resistance only dissipate, so kinetic energy
    never rises, and the robot stops."""
    model = SkidModel(ROBOT)
    c = coeffs_for(LIB["dirt"])
    state = np.array([[0.0, 0.0, 0.4, 1.2, -0.3, 0.8]])
    inertia, m = ROBOT.yaw_inertia_kgm2, ROBOT.mass_kg

    def energy(s: np.ndarray) -> float:
        return 0.5 * m * (s[0, 3] ** 2 + s[0, 4] ** 2) + 0.5 * inertia * s[0, 5] ** 2

    e = [energy(state)]
    for _ in range(3000):
        state = model.step(state, np.zeros((1, 2)), c, 0.002)
        e.append(energy(state))
    assert np.all(np.diff(e) <= 1e-12)
    assert e[-1] < 1e-8 * e[0]


def test_turning_resistance_moment_at_full_sliding() -> None:
    """A yawing robot with wheels still, sliding fully: the lateral forces' moment is the point-
    contact turning resistance mu_lat W l / 2 (Wong's mu W l / 4 is for a uniform track)."""
    mode = ground(mu_lateral=0.6, mu_peak=0.6, shear_slip=0.001, turning_resistance_m=0.0)
    model = SkidModel(ROBOT, regularization_mps=1e-6)
    state = np.array([[0, 0, 0, 0, 0, 2.0]])
    # at pure yaw the contact slip is perpendicular to the radius: its lateral share is b / h
    b, h = ROBOT.wheelbase_m / 2, ROBOT.wheel_offset_m
    expected = -0.6 * ROBOT.mass_kg * GRAVITY_MPS2 * (b / h) * ROBOT.wheelbase_m / 2
    moment = model.turning_resistance_moment(state, np.zeros((1, 2)), coeffs_for(mode))
    assert moment[0] == pytest.approx(expected, rel=1e-3)


def test_buoyancy_takes_weight_off_the_wheels() -> None:
    model = SkidModel(ROBOT)
    dry = coeffs_for(ground())
    afloat = coeffs_for(ground(buoyancy_fraction=0.75))
    state = np.array([[0, 0, 0, 0.0, 0.0, 0.0]])
    fx_dry, _ = model.contact_forces(state, np.array([[5.0, 5.0]]), dry)
    fx_wet, _ = model.contact_forces(state, np.array([[5.0, 5.0]]), afloat)
    np.testing.assert_allclose(fx_wet, 0.25 * fx_dry, rtol=1e-12)


@pytest.mark.parametrize("name", ["concrete", "shallow_water", "surf"])
def test_external_wrench_gravity_on_a_slope_beyond_grip_slides_down(name: str) -> None:
    """Downhill gravity (what the water leaves of it) as an external force and the wheels' load
    times cos(a): below the terrain's climb limit the robot holds on still wheels, above it slides."""
    model = SkidModel(ROBOT)
    mode = replace(LIB[name], rolling_resistance=0.0)
    c = coeffs_for(mode)
    limit = math.radians(mode.max_climb_slope_deg)
    weight = ROBOT.mass_kg * GRAVITY_MPS2 * (1 - mode.buoyancy_fraction)
    for slope, holds in ((0.6 * limit, True), (1.3 * limit, False)):
        wrench = np.array([[-weight * math.sin(slope), 0.0, 0.0]])
        state = np.zeros((1, 6))
        for _ in range(1000):
            state = model.step(state, np.zeros((1, 2)), c, 0.002, wrench, np.array([math.cos(slope)]))
        assert (abs(state[0, 0]) < 0.01) == holds


def test_vectorized_equals_per_robot() -> None:
    model = SkidModel(ROBOT)
    modes = [LIB[n] for n in ("concrete", "soft_sand", "vegetation", "surf", "deep_water")]
    rng = np.random.default_rng(7)
    states = rng.normal(size=(len(modes), 6)) * [5, 5, 3, 0.5, 0.2, 0.5]
    omega = rng.normal(size=(len(modes), 2)) * 5
    wrench = rng.normal(size=(len(modes), 3)) * 10
    together = model.step(states, omega, coeffs_for(modes), 0.01, wrench)
    deriv = model.derivatives(states, omega, coeffs_for(modes), wrench)
    for i, mode in enumerate(modes):
        alone = model.step(states[i : i + 1], omega[i : i + 1], coeffs_for(mode), 0.01, wrench[i : i + 1])
        np.testing.assert_allclose(together[i], alone[0], rtol=1e-13, atol=1e-15)
        np.testing.assert_allclose(
            deriv[i],
            model.derivatives(states[i : i + 1], omega[i : i + 1], coeffs_for(mode), wrench[i : i + 1])[0],
            rtol=1e-13,
            atol=1e-15,
        )


@pytest.mark.slow
def test_fixed_step_converges_to_the_adaptive_solution() -> None:
    """Smaller steps come closer to the adaptive (LSODA) answer, within millimetres on a 6 s run."""
    model = SkidModel(ROBOT)
    mode = ground(mu_lateral=0.3, turning_resistance_m=0.05, shear_slip=0.05)
    t = np.linspace(0.0, 6.0, 601)
    left = np.clip(t, 0, 1) * 5.0
    right = np.clip(t, 0, 1) * 5.0 + 3.0 * np.sin(np.pi * np.clip(t - 2.0, 0, 2) / 2) ** 2
    wheels = WheelInput.from_speeds(t, left, right)
    c = coeffs_for(mode)
    s0 = np.zeros((1, 6))
    exact = model.simulate_adaptive(
        s0, wheels.smooth_speed_at, c, np.array([0.0, 6.0]), rtol=1e-8, atol=1e-10
    )[-1, 0]
    errors = []
    for dt in (0.01, 0.005, 0.0025):
        _, states = model.simulate_fixed(s0, lambda a, b: wheels.mean_speeds(a, b)[None], c, 6.0, dt)
        errors.append(np.hypot(*(states[-1, 0, :2] - exact[:2])))
    assert errors[2] < errors[1] < errors[0]
    # converging, down to the floor of resampling the wheel input per step (about 0.15 mm here):
    # a quarter of the step takes at least 30% off
    assert errors[2] < 0.7 * errors[0]
    assert errors[2] < 0.002


def test_a_wheel_input_drives_a_fixed_step_run_as_its_per_step_travel_does() -> None:
    """Handing `simulate_fixed` the wheel input (every step's travel looked up at once) gives the
    run that asking for each step's mean speed gives, float for float: the same steps, the last
    one short, on a rear-heavy robot whose loads shift."""
    model = SkidModel(replace(ROBOT, com_x_m=-0.05))
    t = np.linspace(0.0, 3.0, 301)
    wheels = WheelInput.from_speeds(t, 4.0 + np.sin(3 * t), 4.0 - 2.0 * np.cos(2 * t))
    c = coeffs_for(ground(mu_lateral=0.4, turning_resistance_m=0.03))
    s0 = np.zeros((2, 6))
    t_a, looked_up = model.simulate_fixed(s0, wheels, c, 2.995, 0.007)
    t_b, per_step = model.simulate_fixed(s0, lambda a, b: wheels.mean_speeds(a, b)[None], c, 2.995, 0.007)
    assert np.array_equal(t_a, t_b) and t_a[-1] == 2.995
    assert np.array_equal(looked_up, per_step)
    assert np.ptp(looked_up[:, 0, 2]) > 0.3  # it turned: the loads shifted side to side


def _step_by_step(model, state0, wheels, c, t_end_s, dt_s, wrench, load_transfer):
    """`simulate_fixed` as it was written before it was compiled: `step` after `step`."""
    n_steps = int(np.ceil(t_end_s / dt_s - 1e-9))
    times = np.minimum(np.arange(n_steps + 1) * dt_s, t_end_s)
    table = wheels.step_speeds(times)
    states = [np.array(state0, dtype=np.float64)]
    accel = None
    for k in range(n_steps):
        h = times[k + 1] - times[k]
        new = model.step(states[-1], table[k], c, h, wrench, ground_accel_mps2=accel)
        if load_transfer:
            accel = model.ground_accel(states[-1], new, h, wrench)
        states.append(new)
    return times, np.array(states)


@pytest.mark.parametrize("com", [(0.0, 0.0), (-0.05, 0.0), (0.03, -0.02)], ids=["centred", "rear", "off"])
@pytest.mark.parametrize("load_transfer", [True, False], ids=["transfer", "static"])
@pytest.mark.parametrize("pushed", [False, True], ids=["free", "wrench"])
def test_the_compiled_fixed_step_run_is_step_after_step(com, load_transfer, pushed) -> None:
    """`simulate_fixed` (one compiled loop, `skid_run`) gives the states `step` gives called step
    after step: every terrain of the library at once, on centred and off-centre robots, with and
    without load transfer and an external wrench. Float for float where numpy's expm1 is libm's
    (its SIMD one, on some processors, differs in the last bit now and then)."""
    model = SkidModel(replace(ROBOT, com_x_m=com[0], com_y_m=com[1]))
    modes = list(LIB.values())
    c = coeffs_for(modes)
    s0 = np.zeros((len(modes), 6))
    s0[:, 2] = np.linspace(-1.0, 1.0, len(modes))
    s0[:, 3] = 0.2
    t = np.linspace(0.0, 5.0, 501)
    wheels = WheelInput.from_speeds(t, 4.0 + 3.0 * np.sin(1.3 * t), 4.0 - 5.0 * np.cos(0.7 * t))
    wrench = np.array([1.5, -0.7, 0.3]) if pushed else None
    t_a, compiled = model.simulate_fixed(s0, wheels, c, 4.993, 0.01, wrench, load_transfer)
    t_b, stepped = _step_by_step(model, s0, wheels, c, 4.993, 0.01, wrench, load_transfer)
    assert np.array_equal(t_a, t_b)
    x = -np.geomspace(1e-6, 50.0, 20_001)
    if np.array_equal(np.expm1(x), [math.expm1(v) for v in x]):
        assert np.array_equal(compiled, stepped)
    else:
        np.testing.assert_allclose(compiled, stepped, rtol=1e-9, atol=1e-12)
    assert np.ptp(stepped[:, :, 2]) > 1.0  # it turned


def test_deep_water_has_no_traction_but_drags() -> None:
    model = SkidModel(ROBOT)
    c = coeffs_for(LIB["deep_water"])
    state = np.array([[0, 0, 0, 1.0, 0.0, 0.0]])
    for _ in range(100):
        state = model.step(state, np.array([[10.0, 10.0]]), c, 0.01)
    # quadratic drag alone: u(t) = u0 / (1 + c u0 t / m)
    cd = LIB["deep_water"].drag_n_s2_per_m2
    assert state[0, 3] == pytest.approx(1.0 / (1 + cd * 1.0 * 1.0 / ROBOT.mass_kg), rel=0.02)


def test_spin_and_lateral_friction_share_one_friction_ellipsoid() -> None:
    """Pivoting with the wheels turning exactly as fast as the body spins (no longitudinal slip),
    each patch slides sideways at b r and spins at rho r; at full sliding they share mu_lat N, so
    the yaw moment is mu_lat W sqrt(b^2 + rho^2), rho = turning_resistance_m / mu_lat."""
    mu, turn = 0.5, 0.06
    mode = ground(mu_lateral=mu, turning_resistance_m=turn, shear_slip=1e-4, rolling_resistance=0.0)
    model = SkidModel(ROBOT, regularization_mps=1e-9)
    r, a, b = 1.5, ROBOT.track_width_m / 2, ROBOT.wheelbase_m / 2
    wheel = a * r / ROBOT.wheel_radius_m
    d = model.derivatives(np.array([[0, 0, 0, 0, 0, r]]), np.array([[-wheel, wheel]]), coeffs_for(mode))[0]
    rho = turn / mu
    expected = -mu * ROBOT.mass_kg * GRAVITY_MPS2 * math.hypot(b, rho)
    assert d[5] * ROBOT.yaw_inertia_kgm2 == pytest.approx(expected, rel=1e-3)
    assert abs(d[3]) < 1e-9 and abs(d[4]) < 1e-9
