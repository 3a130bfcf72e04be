"""World physics: equals the bare `skid` model on flat dry ground, and adds slopes, water, waves,
jet, obstacles and power with the invariants and closed forms the module docstring promises."""

from __future__ import annotations

import importlib.resources
import math
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from swarm.mission.schema import SurfHazard
from swarm.robot.params import GRAVITY_MPS2, load_robot
from swarm.robot.skid import SkidModel
from swarm.robot.terrain import TerrainLibrary, default_library
from swarm.sim.physics import (
    ETA_DRIVE,
    ETA_JET,
    JET_NOZZLE_AREA_M2,
    SEAWATER_DENSITY_KGPM3,
    Physics,
    PhysicsStep,
    SeaState,
    jet_power_w,
)
from swarm.world.beachmap import BeachMap

ROBOT = load_robot(Path(str(importlib.resources.files("swarm") / "data" / "robots" / "skid4.yaml")))
LIBRARY = default_library()
CALM = SeaState(wave_height_m=0.0, wave_period_s=8.0, longshore_current_mps=0.0)
WEIGHT_N = ROBOT.mass_kg * GRAVITY_MPS2
DEEP_DRAG = LIBRARY["deep_water"].drag_n_s2_per_m2


def beach(
    classes: tuple[str, ...], terrain: np.ndarray, elevation: np.ndarray, cell_m: float = 0.5
) -> BeachMap:
    return BeachMap(
        name="synthetic",
        cell_m=cell_m,
        origin_m=(0.0, 0.0),
        terrain_classes=classes,
        terrain=np.asarray(terrain, dtype=np.int8),
        elevation_m=np.asarray(elevation, dtype=np.float32),
    )


def uniform(cls: str, elevation_m: float = 0.0, shape: tuple[int, int] = (40, 40)) -> BeachMap:
    return beach((cls,), np.zeros(shape), np.full(shape, elevation_m))


def slope_map(grad: float, cls: str = "wet_hard_sand", rows: int = 240, cols: int = 20) -> BeachMap:
    """Elevation rising northward with d z / d y = grad (a plane; 0.5 m cells, 120 m long)."""
    y = (np.arange(rows) + 0.5) * 0.5
    return beach((cls,), np.zeros((rows, cols)), np.repeat((grad * y)[:, None], cols, axis=1))


def run(
    physics: Physics,
    state: np.ndarray,
    wheels: np.ndarray | float = 0.0,
    jet: np.ndarray | float = 0.0,
    steps: int = 1,
    dt_s: float = 0.5,
    inverted: np.ndarray | bool = False,
    t0_s: float = 0.0,
    wave_phase_s: float = 0.0,
) -> tuple[np.ndarray, list[PhysicsStep]]:
    """`steps` env steps with constant commands; returns the final state and every step's result."""
    n = state.shape[0]
    wheels = np.broadcast_to(np.asarray(wheels, dtype=float), (n, 2))
    jet = np.broadcast_to(np.asarray(jet, dtype=float), (n,))
    inverted = np.broadcast_to(np.asarray(inverted, dtype=bool), (n,))
    out = []
    for k in range(steps):
        r = physics.step(state, wheels, jet, inverted, t0_s + k * dt_s, dt_s, wave_phase_s)
        state = r.state
        out.append(r)
    return state, out


def at_rest(x: float, y: float, heading: float = 0.0) -> np.ndarray:
    return np.array([[x, y, heading, 0.0, 0.0, 0.0]])


# --- flat dry ground: nothing but the skid model ---------------------------------------------------


@pytest.mark.parametrize("dt_s", [0.5, 0.25])
def test_flat_dry_ground_is_the_skid_model_with_terrain_regathered_each_substep(dt_s: float) -> None:
    classes = ("concrete", "soft_sand", "dirt", "wet_hard_sand")
    rows = cols = 40
    terrain = (np.arange(cols)[None, :] // 5 + np.arange(rows)[:, None] // 7) % len(classes)
    bm = beach(classes, terrain, np.zeros((rows, cols)))
    physics = Physics(bm, LIBRARY, ROBOT, CALM, jet_thrust_max_n=30.0)
    rng = np.random.default_rng(7)
    n = 25
    state = np.column_stack(
        [
            rng.uniform(3, 17, n),
            rng.uniform(3, 17, n),
            rng.uniform(-np.pi, np.pi, n),
            rng.uniform(-0.5, 0.5, (n, 3)),
        ]
    )
    wheels = rng.uniform(-8, 8, (n, 2))
    model, table = SkidModel(ROBOT), bm.terrain_table(LIBRARY)
    ref, distance = state.copy(), np.zeros(n)
    substeps = math.ceil(dt_s / 0.1 - 1e-9)
    for _ in range(6):
        for _ in range(substeps):
            new = model.step(ref, wheels, table.gather(bm.terrain_at(ref[:, 0], ref[:, 1])), dt_s / substeps)
            distance += np.hypot(*(new[:, :2] - ref[:, :2]).T)
            ref = new
    got, results = run(physics, state, wheels, jet=25.0, steps=6, dt_s=dt_s)  # the jet is dry: no effect
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(sum(r.distance_m for r in results), distance, rtol=1e-12)
    last = results[-1]
    np.testing.assert_array_equal(last.terrain, bm.terrain_at(got[:, 0], got[:, 1]))
    assert not last.in_surf.any() and not any(r.wave_hits.any() for r in results)
    np.testing.assert_array_equal(last.submersion, 0.0)
    assert all(((r.slip >= 0) & (r.slip <= 1)).all() and (r.power_w >= 0).all() for r in results)


def test_input_arrays_are_not_modified() -> None:
    physics = Physics(uniform("concrete"), LIBRARY, ROBOT, CALM, jet_thrust_max_n=30.0)
    state, wheels = at_rest(10, 10), np.array([[4.0, 5.0]])
    before = state.copy(), wheels.copy()
    physics.step(state, wheels, np.zeros(1), np.array([True]), 0.0, 0.5, 0.0)
    np.testing.assert_array_equal(state, before[0])
    np.testing.assert_array_equal(wheels, before[1])


# --- an inverted robot ------------------------------------------------------------------------------


def test_inverted_robot_drives_the_upright_path_under_the_mirrored_negated_command() -> None:
    physics = Physics(slope_map(0.2), LIBRARY, ROBOT, CALM, jet_thrust_max_n=30.0)
    rng = np.random.default_rng(3)
    state = np.column_stack([np.full(6, 5.0), np.full(6, 40.0), rng.uniform(-3, 3, 6), np.zeros((6, 3))])
    cmd = rng.uniform(-6, 6, (6, 2))
    upright, _ = run(physics, state, cmd, steps=8)
    flipped, _ = run(physics, state, -cmd[:, ::-1], steps=8, inverted=True)
    np.testing.assert_array_equal(flipped, upright)
    # and the same command sends an inverted robot the other way: backwards, turning the same sense
    forward, _ = run(physics, at_rest(5, 40), np.array([[3.0, 4.0]]), steps=4)
    backward, _ = run(physics, at_rest(5, 40), np.array([[3.0, 4.0]]), steps=4, inverted=True)
    assert forward[0, 0] > 5.5 and backward[0, 0] < 4.5
    assert forward[0, 5] > 0 and backward[0, 5] > 0


# --- slopes -----------------------------------------------------------------------------------------


@pytest.mark.parametrize("buoyancy", [0.0, 0.5])
def test_locked_wheels_slide_down_a_slope_steeper_than_static_grip_at_kinetic_friction(
    buoyancy: float,
) -> None:
    """tan(a) = 1 beats locked-wheel grip (mu (1 - e^(-1/k)) + c_rr = 0.69 on wet hard sand): once
    sliding, a = (1 - b) g (sin a - (mu + c_rr) cos a), b the weight water carries. Short substeps:
    the secant-frozen friction of the linearly implicit step lags a saturated force by ~a dt / v."""
    mode = replace(LIBRARY["wet_hard_sand"], buoyancy_fraction=buoyancy)
    library = LIBRARY.merged(TerrainLibrary([mode]))
    slope = math.atan(1.0)
    physics = Physics(slope_map(1.0), library, ROBOT, CALM, jet_thrust_max_n=30.0, substep_s=0.005)
    state = at_rest(5.0, 110.0, math.pi / 2)  # facing uphill
    _, results = run(physics, state, 0.0, steps=8, dt_s=0.5)
    u = np.array([r.state[0, 3] for r in results])
    accel = (u[7] - u[3]) / 2.0  # between 2 s and 4 s, sliding at 4-9 m/s
    friction = mode.mu_peak + mode.rolling_resistance
    expected = -(1 - buoyancy) * GRAVITY_MPS2 * (math.sin(slope) - friction * math.cos(slope))
    assert accel == pytest.approx(expected, rel=0.01)
    assert results[-1].state[0, 1] < 110.0 - 5.0


def test_water_carries_the_whole_weight_of_a_floating_robot_on_a_sloping_bed() -> None:
    physics = Physics(slope_map(1.0, "deep_water"), LIBRARY, ROBOT, CALM, jet_thrust_max_n=30.0)
    assert not physics.surf_mask.any()
    state = at_rest(5.0, 60.0, 0.3)
    np.testing.assert_array_equal(run(physics, state, 0.0, steps=4)[0], state)


def test_locked_wheels_hold_on_a_slope_the_robot_could_climb() -> None:
    """tan(a) = 0.3, below the 0.61 climbing limit: the wheels at rest hold the robot; it creeps at
    the model's regularization speed scale (~mm/s), not sliding."""
    assert math.degrees(math.atan(0.3)) < LIBRARY["wet_hard_sand"].max_climb_slope_deg
    physics = Physics(slope_map(0.3), LIBRARY, ROBOT, CALM, jet_thrust_max_n=30.0)
    state, results = run(physics, at_rest(5.0, 60.0, math.pi / 2), 0.0, steps=40)
    assert abs(state[0, 1] - 60.0) < 0.05
    assert abs(state[0, 3]) < 0.003
    assert max(abs(r.state[0, 3]) for r in results) < 0.01


@pytest.mark.parametrize("wheel_radps", [1.0, 4.0, 10.0, 30.0])
def test_no_uphill_progress_above_the_climbing_limit(wheel_radps: float) -> None:
    """tan(a) = 0.7 > mu_peak: no wheel speed gives traction enough, so y never rises."""
    mode = LIBRARY["wet_hard_sand"]
    assert mode.mu_peak < 0.7 and math.degrees(math.atan(0.7)) > mode.max_climb_slope_deg
    physics = Physics(slope_map(0.7), LIBRARY, ROBOT, CALM, jet_thrust_max_n=30.0)
    _, results = run(physics, at_rest(5.0, 80.0, math.pi / 2), wheel_radps, steps=20)
    ys = np.array([r.state[0, 1] for r in results])
    assert ys.max() <= 80.0 + 1e-9
    assert ys[-1] < 80.0


def test_below_the_climbing_limit_the_same_command_climbs_at_the_energy_balance_power() -> None:
    """tan(a) = 0.4: the robot climbs; at steady speed the wheels' traction carries gravity and
    rolling resistance, so the wheel power is (W sin a + c_rr N u / sqrt(u^2 + reg^2)) w / eta."""
    mode = LIBRARY["wet_hard_sand"]
    physics = Physics(slope_map(0.4), LIBRARY, ROBOT, CALM, jet_thrust_max_n=30.0)
    wheel = 3.0
    state, results = run(physics, at_rest(5.0, 20.0, math.pi / 2), wheel, steps=40)
    assert state[0, 1] > 20.0 + 5.0
    slope = math.atan(0.4)
    u, reg = state[0, 3], SkidModel(ROBOT).regularization_mps
    traction = WEIGHT_N * (
        math.sin(slope) + mode.rolling_resistance * math.cos(slope) * u / math.hypot(u, reg)
    )
    w = wheel * ROBOT.wheel_radius_m * mode.rolling_radius_scale
    assert results[-1].power_w[0] == pytest.approx(traction * w / ETA_DRIVE, rel=1e-6)
    assert results[-1].slip[0] == pytest.approx((w - u) / w, rel=1e-6)


def test_cruise_power_on_flat_ground_is_rolling_resistance_times_wheel_speed() -> None:
    """The total contact force is zero at steady cruise; the motors still pay for rolling resistance."""
    mode = LIBRARY["concrete"]
    physics = Physics(uniform("concrete", shape=(20, 200)), LIBRARY, ROBOT, CALM, jet_thrust_max_n=30.0)
    state, results = run(physics, at_rest(2.0, 5.0), 5.0, steps=20)
    u, reg = state[0, 3], SkidModel(ROBOT).regularization_mps
    w = 5.0 * ROBOT.wheel_radius_m
    expected = WEIGHT_N * mode.rolling_resistance * u / math.hypot(u, reg) * w / ETA_DRIVE
    assert results[-1].power_w[0] == pytest.approx(expected, rel=1e-6)
    # a robot at rest with its wheels stopped draws nothing, and reports no slip below 5 cm/s
    _, idle = run(physics, at_rest(2.0, 5.0), np.array([[0.3, 0.3]]), steps=1)
    assert idle[0].slip[0] == 0.0


# --- water: current, drag, jet ----------------------------------------------------------------------


def floating_surf_library() -> TerrainLibrary:
    """A library whose "surf" floats like deep water: current without ground contact or waves."""
    return LIBRARY.merged(TerrainLibrary([replace(LIBRARY["deep_water"], name="surf")]))


def test_a_floating_robot_drifts_with_the_longshore_current() -> None:
    sea = SeaState(wave_height_m=0.0, wave_period_s=8.0, longshore_current_mps=0.4)
    physics = Physics(
        uniform("surf", -2.0, (40, 400)), floating_surf_library(), ROBOT, sea, jet_thrust_max_n=30.0
    )
    assert physics.surf_mask.all()
    state, results = run(physics, at_rest(10.0, 10.0, 0.7), 0.0, steps=300)
    heading = np.array([r.state[0, 2] for r in results])
    u, v = (np.array([r.state[0, i] for r in results]) for i in (3, 4))
    vx = u * np.cos(heading) - v * np.sin(heading)
    vy = u * np.sin(heading) + v * np.cos(heading)
    np.testing.assert_allclose(heading, 0.7, atol=1e-12)  # drag makes no moment
    assert np.all(np.diff(vx) >= -1e-12) and vx.max() <= 0.4 + 1e-12  # no overshoot
    np.testing.assert_allclose(vy, 0.0, atol=1e-12)
    assert vx[-1] == pytest.approx(0.4, abs=0.01)
    assert state[0, 0] > 10.0 + 30.0


def test_jet_terminal_speed_in_deep_water_is_sqrt_thrust_over_drag() -> None:
    sea = SeaState(wave_height_m=1.0, wave_period_s=8.0, longshore_current_mps=0.3)
    physics = Physics(uniform("deep_water", -5.0, (40, 400)), LIBRARY, ROBOT, sea, jet_thrust_max_n=30.0)
    assert not physics.surf_mask.any()  # 5 m is deeper than the 1.28 m breaker depth: no current
    state, _ = run(physics, at_rest(5.0, 10.0), 0.0, jet=30.0, steps=80)
    assert state[0, 3] == pytest.approx(math.sqrt(30.0 / DEEP_DRAG), rel=0.01)
    clipped, _ = run(physics, at_rest(5.0, 10.0), 0.0, jet=500.0, steps=80)
    np.testing.assert_array_equal(clipped, state)


def test_jet_power_is_the_actuator_disk_formula_on_the_thrust_delivered() -> None:
    classes = ("deep_water", "shallow_water", "concrete")
    bm = beach(classes, np.repeat(np.arange(3), 10)[None, :].repeat(10, axis=0), np.full((10, 30), -5.0))
    physics = Physics(bm, LIBRARY, ROBOT, CALM, jet_thrust_max_n=30.0)
    state = np.array([[2.5, 2.5, 0, 0, 0, 0], [7.5, 2.5, 0, 0, 0, 0], [12.5, 2.5, 0, 0, 0, 0]])
    per_n15 = 1.0 / math.sqrt(2 * SEAWATER_DENSITY_KGPM3 * JET_NOZZLE_AREA_M2) / ETA_JET
    r = physics.step(state, np.zeros((3, 2)), np.array([-20.0, 20.0, 20.0]), np.zeros(3, bool), 0.0, 0.1, 0.0)
    buoyancy = np.array([1.0, LIBRARY["shallow_water"].buoyancy_fraction, 0.0])
    np.testing.assert_allclose(r.power_w, (20.0 * buoyancy) ** 1.5 * per_n15, rtol=1e-12)
    np.testing.assert_allclose(r.submersion, buoyancy)
    r = physics.step(state, np.zeros((3, 2)), np.full(3, 100.0), np.zeros(3, bool), 0.0, 0.1, 0.0)
    assert r.power_w[0] == pytest.approx(30.0**1.5 * per_n15, rel=1e-12)
    np.testing.assert_allclose(jet_power_w(np.array([-30.0, 30.0])), r.power_w[0], rtol=1e-12)


# --- waves and the surf zone ------------------------------------------------------------------------


def wave_force_world(physics: Physics, heading: float, times: np.ndarray) -> np.ndarray:
    """World force on a floating robot at rest at each time: one substep from rest gives
    u_new = F dt / m exactly (no contact, drag secant zero at rest)."""
    dt = 0.01
    forces = []
    for t in times:
        r = physics.step(
            at_rest(10.0, 10.0, heading), np.zeros((1, 2)), np.zeros(1), np.zeros(1, bool), t, dt, 0.0
        )
        u, v = r.state[0, 3], r.state[0, 4]
        c, s = math.cos(heading), math.sin(heading)
        forces.append(ROBOT.mass_kg / dt * np.array([u * c - v * s, u * s + v * c]))
    return np.array(forces)


def test_wave_velocity_is_depth_limited_shallow_water_theory() -> None:
    sea = SeaState(wave_height_m=1.0, wave_period_s=8.0, longshore_current_mps=0.25)
    depth = np.array([0.4, 1.0, 1.2])
    bm = beach(("deep_water",), np.zeros((10, 3)), np.repeat(-depth[None, :], 10, axis=0), cell_m=1.0)
    physics = Physics(bm, LIBRARY, ROBOT, sea, jet_thrust_max_n=30.0)
    xy = np.array([[0.5, 5.0], [1.5, 5.0], [2.5, 5.0]])
    crest = physics.water_velocity_mps(xy, t_s=3.0 + 16.0, wave_phase_s=3.0)
    depth = -bm.elevation_m[5].astype(np.float64)  # as stored: float32
    height = np.minimum(1.0, 0.78 * depth)
    speed = height / 2 * np.sqrt(GRAVITY_MPS2 / depth)
    along = physics.shoreward[5, :]  # the smoothed uphill direction, here toward the shallow west
    np.testing.assert_allclose(np.hypot(*along.T), 1.0, rtol=1e-12)
    assert (along[:, 0] < -0.9).all()
    np.testing.assert_allclose(crest - [0.25, 0.0], speed[:, None] * along, rtol=1e-12, atol=1e-15)
    trough_t = 3.0 + math.acos(-0.5) / (2 * math.pi) * 8.0  # the trough: cos(phi) = -1 / (4 r), r = 0.5
    trough = physics.water_velocity_mps(xy, t_s=trough_t, wave_phase_s=3.0) - [0.25, 0.0]
    np.testing.assert_allclose(trough, -0.5 * speed[:, None] * along, rtol=1e-9)  # trough half the crest


def test_time_mean_wave_force_is_shoreward_with_skew_and_zero_without() -> None:
    times = np.arange(64) / 64 * 8.0
    bm = uniform("deep_water", -1.0)
    speed = 0.78 / 2 * math.sqrt(GRAVITY_MPS2 / 1.0)
    skewed = Physics(bm, LIBRARY, ROBOT, SeaState(1.0, 8.0, 0.0), jet_thrust_max_n=30.0)
    assert skewed.surf_mask.all()
    force = wave_force_world(skewed, 0.4, times)
    phi = 2 * np.pi * times / 8.0
    shape = (np.cos(phi) + 0.5 * np.cos(2 * phi)) / 1.5
    expected = DEEP_DRAG * speed**2 * np.mean(np.abs(shape) * shape)
    assert expected > 0.05 * DEEP_DRAG * speed**2  # <|s| s> = 0.084 at r = 0.5
    mean = force.mean(axis=0)
    assert mean[1] == pytest.approx(expected, rel=1e-9)
    assert abs(mean[0]) < 1e-9 * DEEP_DRAG * speed**2
    linear = Physics(bm, LIBRARY, ROBOT, SeaState(1.0, 8.0, 0.0, wave_skew=0.0), jet_thrust_max_n=30.0)
    force = wave_force_world(linear, 0.4, times)
    assert np.abs(force[:, 1]).max() == pytest.approx(DEEP_DRAG * speed**2, rel=1e-9)
    assert abs(force.mean(axis=0)[1]) < 1e-9 * DEEP_DRAG * speed**2


def test_surf_zone_and_shoreward_direction() -> None:
    classes = ("deep_water", "surf", "shallow_water", "wet_hard_sand")
    cols = 40
    x = np.arange(cols) + 0.5
    elevation = np.repeat((0.1 * (x - 30.0))[None, :], 30, axis=0)  # rising eastward, shore at x = 30
    terrain = np.select([x < 6, x < 12, x < 30], [0, 1, 0], 3)[None, :].repeat(30, axis=0)
    terrain[:, [28, 29, 34, 38]] = classes.index("shallow_water")  # swash at x = 34.5, a channel at 38.5
    elevation[:, 38] = 1.5
    bm = beach(classes, terrain, elevation, cell_m=1.0)
    physics = Physics(bm, LIBRARY, ROBOT, SeaState(1.0, 8.0, 0.0), jet_thrust_max_n=30.0)
    z = bm.elevation_m[0].astype(np.float64)
    shallow = (np.maximum(-z, 0.05) < 1.0 / 0.78) & (z < 1.0)
    expected = (terrain[0] == 1) | (np.isin(terrain[0], [0, 2]) & shallow)
    np.testing.assert_array_equal(physics.surf_mask, np.repeat(expected[None, :], 30, axis=0))
    assert physics.surf_mask[:, 5].sum() == 0 and physics.surf_mask[:, 8].all()  # "surf" though deep
    assert physics.surf_mask[:, 20].all() and physics.surf_mask[:, 34].all()  # below h_b; the swash
    assert physics.surf_mask[:, 30:].sum() == 30  # land and the channel 1.5 m up are not surf
    np.testing.assert_allclose(
        physics.shoreward[5:25, 5:30], np.broadcast_to([1.0, 0.0], (20, 25, 2)), atol=1e-9
    )
    flat = Physics(
        uniform("deep_water", -1.0), LIBRARY, ROBOT, SeaState(1.0, 8.0, 0.0), jet_thrust_max_n=30.0
    )
    np.testing.assert_array_equal(flat.shoreward, np.broadcast_to([0.0, 1.0], (40, 40, 2)))


@pytest.mark.parametrize(("dt_s", "period_s", "phase_s"), [(0.5, 7.3, 1.1), (0.3, 6.0, 0.0), (0.5, 6.0, 0.0)])
def test_wave_hits_count_every_crest_once(dt_s: float, period_s: float, phase_s: float) -> None:
    """A robot held in the surf is hit once per crest in (0, T_end], also with crests on step
    boundaries; a robot ashore never."""
    classes = ("deep_water", "concrete")
    terrain = np.zeros((20, 20))
    terrain[:, 10:] = 1
    bm = beach(classes, terrain, np.where(terrain == 0, -1.0, 1.0))
    physics = Physics(bm, LIBRARY, ROBOT, SeaState(1.0, period_s, 0.1), jet_thrust_max_n=30.0)
    state = np.array([[2.0, 5.0, 0, 0, 0, 0], [8.0, 5.0, 0, 0, 0, 0]])
    steps = 300
    hits = np.zeros(2, dtype=int)
    for k in range(steps):
        r = physics.step(state, np.zeros((2, 2)), np.zeros(2), np.zeros(2, bool), k * dt_s, dt_s, phase_s)
        hits += r.wave_hits
        np.testing.assert_array_equal(r.in_surf, [True, False])
    end_s = steps * dt_s
    crests = sum(0.0 < phase_s + k * period_s <= end_s + 1e-9 for k in range(-5, 100))
    assert hits.tolist() == [crests, 0]


# --- obstacles --------------------------------------------------------------------------------------


def test_no_robot_centre_ever_enters_an_obstacle_cell() -> None:
    rng = np.random.default_rng(11)
    classes = ("wet_hard_sand", "boulder", "driftwood", "soft_sand")
    rows = cols = 40
    terrain = rng.choice(4, size=(rows, cols), p=[0.6, 0.15, 0.1, 0.15])
    bm = beach(classes, terrain, rng.normal(0.0, 0.05, (rows, cols)) + 1.0)
    physics = Physics(bm, LIBRARY, ROBOT, CALM, jet_thrust_max_n=30.0)
    free = np.argwhere(np.isin(terrain, [0, 3]))
    n = 200
    pick = free[rng.choice(len(free), n, replace=False)]
    x, y = bm.center_of(pick[:, 0], pick[:, 1])
    state = np.column_stack([x, y, rng.uniform(-np.pi, np.pi, n), np.zeros((n, 3))])
    hits = 0
    for k in range(200):
        if k % 10 == 0:
            wheels = rng.uniform(-8, 8, (n, 2))
        r = physics.step(state, wheels, np.zeros(n), rng.random(n) < 0.1, k * 0.5, 0.5, 0.0)
        state = r.state
        assert not np.isin(bm.terrain_at(state[:, 0], state[:, 1]), [1, 2]).any()
        assert np.isin(r.obstacle_hit, [-1, 1, 2]).all()
        hits += int((r.obstacle_hit >= 0).sum())
    assert hits > 50  # the robots did run into things


def test_a_robot_driving_into_a_boulder_wall_stops_in_front_of_it() -> None:
    classes = ("concrete", "boulder")
    terrain = np.zeros((20, 40))
    terrain[:, 20] = 1  # x in [10, 10.5)
    physics = Physics(
        beach(classes, terrain, np.zeros((20, 40))), LIBRARY, ROBOT, CALM, jet_thrust_max_n=30.0
    )
    state, results = run(physics, at_rest(7.0, 5.0), 6.0, steps=12)
    first = next(k for k, r in enumerate(results) if r.obstacle_hit[0] >= 0)
    assert results[first].obstacle_hit[0] == 1
    assert 9.8 < state[0, 0] < 10.0
    assert results[-1].state[0, 3] == 0.0 and results[-1].slip[0] == pytest.approx(1.0)
    assert results[-1].distance_m[0] < 0.2


# --- bookkeeping: inactive robots, vectorization, sea state ------------------------------------------


def mixed_physics() -> tuple[BeachMap, Physics]:
    """Deep water, surf, sand and boulders on a slope rising northward."""
    classes = ("deep_water", "surf", "wet_hard_sand", "boulder")
    rows, cols = 60, 30
    y = (np.arange(rows) + 0.5) * 0.5
    elevation = np.repeat((0.06 * (y - 15.0))[:, None], cols, axis=1)
    terrain = np.select([y < 6, y < 15], [0, 1], 2)[:, None].repeat(cols, axis=1)
    terrain[40:44, 10:14] = 3
    bm = beach(classes, terrain, elevation)
    return bm, Physics(bm, LIBRARY, ROBOT, SeaState(1.0, 7.0, 0.3), jet_thrust_max_n=30.0)


def random_swarm(rng: np.random.Generator, n: int) -> tuple[np.ndarray, ...]:
    state = np.column_stack(
        [rng.uniform(1, 14, n), rng.uniform(1, 29, n), rng.uniform(-3, 3, n), rng.uniform(-0.3, 0.3, (n, 3))]
    )
    return state, rng.uniform(-8, 8, (n, 2)), rng.uniform(-40, 40, n), rng.random(n) < 0.3


def test_inactive_robots_come_back_unchanged_and_cost_nothing() -> None:
    _, physics = mixed_physics()
    rng = np.random.default_rng(5)
    state, wheels, jet, inverted = random_swarm(rng, 12)
    active = rng.random(12) < 0.5
    active[:2] = [True, False]
    state[np.flatnonzero(~active)[0]] = np.nan  # not on the map yet
    r = physics.step(state, wheels, jet, inverted, 1.0, 0.5, 0.2, active=active)
    np.testing.assert_array_equal(r.state[~active], state[~active])
    for name in ("power_w", "distance_m", "slip", "submersion"):
        np.testing.assert_array_equal(getattr(r, name)[~active], 0.0)
    assert not r.wave_hits[~active].any() and not r.in_surf[~active].any()
    np.testing.assert_array_equal(r.terrain[~active], -1)
    np.testing.assert_array_equal(r.obstacle_hit[~active], -1)
    alone = physics.step(state[active], wheels[active], jet[active], inverted[active], 1.0, 0.5, 0.2)
    np.testing.assert_array_equal(r.state[active], alone.state)
    np.testing.assert_array_equal(r.power_w[active], alone.power_w)
    none = physics.step(state, wheels, jet, inverted, 1.0, 0.5, 0.2, active=np.zeros(12, bool))
    np.testing.assert_array_equal(none.state, state)
    assert none.state is not state


def test_robots_off_the_map_read_the_nearest_edge_cell() -> None:
    rng = np.random.default_rng(2)
    classes = ("concrete", "soft_sand", "dirt", "wet_hard_sand", "deep_water")
    bm = beach(classes, rng.integers(0, 5, (12, 16)), np.full((12, 16), -0.5))
    physics = Physics(bm, LIBRARY, ROBOT, SeaState(1.0, 8.0, 0.2), jet_thrust_max_n=30.0)
    n = 400
    state = np.column_stack([rng.uniform(-10, 18, n), rng.uniform(-10, 16, n), np.zeros((n, 4))])
    r = physics.step(state, np.zeros((n, 2)), np.zeros(n), np.zeros(n, bool), 0.0, 0.01, 0.0)
    x, y = r.state[:, 0], r.state[:, 1]
    assert (~bm.contains(x, y)).sum() > n / 2
    np.testing.assert_array_equal(r.terrain, bm.terrain_at(x, y))
    np.testing.assert_array_equal(r.in_surf, physics.surf_mask[bm.cell_of(x, y)])
    np.testing.assert_array_equal(
        physics.water_velocity_mps(r.state[:, :2], 0.0, 0.0)[:, 0] != 0, physics.surf_mask[bm.cell_of(x, y)]
    )


def test_vectorized_step_equals_one_robot_at_a_time() -> None:
    bm, physics = mixed_physics()
    rng = np.random.default_rng(9)
    n = 16
    state, wheels, jet, inverted = random_swarm(rng, n)
    batch, singles = state.copy(), state.copy()
    for k in range(8):
        rb = physics.step(batch, wheels, jet, inverted, k * 0.5, 0.5, 1.3)
        batch = rb.state
        for i in range(n):
            ri = physics.step(
                singles[i : i + 1], wheels[i : i + 1], jet[i : i + 1], inverted[i : i + 1], k * 0.5, 0.5, 1.3
            )
            singles[i] = ri.state[0]
            for name in ("power_w", "distance_m", "slip", "submersion"):
                assert getattr(rb, name)[i] == pytest.approx(getattr(ri, name)[0], rel=1e-12, abs=1e-12)
            for name in ("terrain", "in_surf", "wave_hits", "obstacle_hit"):
                assert getattr(rb, name)[i] == getattr(ri, name)[0]
        np.testing.assert_allclose(batch, singles, rtol=0, atol=1e-12)
    assert (physics.surf_mask[bm.cell_of(batch[:, 0], batch[:, 1])]).any()  # exercised the surf


def test_sea_state_from_mission_and_default_jet_thrust() -> None:
    given = SimpleNamespace(
        hazards=SimpleNamespace(
            surf=SurfHazard(wave_height_m=1.5, wave_period_s=9.0, longshore_current_mps=-0.3)
        )
    )
    assert SeaState.from_mission(given) == SeaState(1.5, 9.0, -0.3)
    derived = SimpleNamespace(
        hazards=SimpleNamespace(surf=SurfHazard(wave_height_m=1.0, wave_angle_deg=10.0))
    )
    a = math.radians(10.0)
    expected = 1.17 * math.sqrt(9.80665 * 1.0) * math.sin(a) * math.cos(a)  # Longuet-Higgins 1970
    assert SeaState.from_mission(derived).longshore_current_mps == pytest.approx(expected, rel=1e-12)
    assert Physics.default_jet_thrust_n(LIBRARY, 0.5) == pytest.approx(DEEP_DRAG * 0.75**2, rel=1e-12)
    with pytest.raises(ValueError):
        SeaState(1.0, 0.0, 0.0)
