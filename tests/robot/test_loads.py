"""Where the weight sits: centre-of-mass offset, wheel loads, load transfer, and the robot YAML keys."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swarm.errors import InputError
from swarm.robot.params import GRAVITY_MPS2, load_robot, robot_from_dict, wheel_loads
from swarm.robot.skid import SkidModel, coeffs_for
from swarm.robot.terrain import load_library

ROOT = Path(__file__).resolve().parents[2]
ROBOT = load_robot(ROOT / "swarm" / "data" / "robots" / "skid4.yaml")
LIB = load_library()
BASE = ROBOT.wheelbase_m
TRACK = ROBOT.track_width_m


def contact_positions(robot) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) of the contacts from the centre of mass, shaped like wheel_loads: (side, axle)."""
    (front, rear), (left, right) = robot.contact_x_m, robot.contact_y_m
    return np.array([[front, rear], [front, rear]]), np.array([[left, left], [right, right]])


@settings(max_examples=60, deadline=None)
@given(
    xc=st.floats(-0.14, 0.14),
    yc=st.floats(-0.29, 0.29),
    ax=st.floats(-3.0, 3.0),
    ay=st.floats(-3.0, 3.0),
    h=st.floats(0.05, 0.2),
)
def test_loads_carry_the_weight_and_balance_the_moments(
    xc: float, yc: float, ax: float, ay: float, h: float
) -> None:
    """Vertical equilibrium: the loads sum to the weight. Pitch and roll about the centre of mass:
    the loads' moments balance the ground force m a acting h below it (zero at rest)."""
    robot = replace(ROBOT, com_x_m=xc, com_y_m=yc, com_height_m=h)
    weight = robot.mass_kg * GRAVITY_MPS2
    x, y = contact_positions(robot)
    for accel in (None, np.array([[ax, ay]])):
        loads = wheel_loads(robot, np.array([weight]), accel)[..., 0]
        if accel is not None and loads.min() == 0.0:
            continue  # a wheel lifted: the clamp breaks the linear balance, by design
        fx, fy = (0.0, 0.0) if accel is None else (robot.mass_kg * ax, robot.mass_kg * ay)
        assert loads.sum() == pytest.approx(weight, rel=1e-12)
        # pitch: sum N x = -h Fx (ground force forward at the ground pitches the nose up)
        assert np.sum(loads * x) == pytest.approx(-h * fx, abs=1e-9 * weight)
        assert np.sum(loads * y) == pytest.approx(-h * fy, abs=1e-9 * weight)


def test_centred_robot_loads_each_wheel_with_a_quarter() -> None:
    loads = wheel_loads(ROBOT, np.array([100.0]))
    np.testing.assert_allclose(loads, 25.0)


def test_rear_heavy_robot_loads_its_rear_wheels_by_the_lever_rule() -> None:
    """CoM 6.7 cm behind the wheel centre on a 0.3 m wheelbase: the rear axle carries
    (l/2 + 0.067) / l of the weight, 72%."""
    robot = replace(ROBOT, com_x_m=-0.067)
    loads = wheel_loads(robot, np.array([robot.weight_n]))[..., 0]
    rear = loads[:, 1].sum() / robot.weight_n
    assert rear == pytest.approx((BASE / 2 + 0.067) / BASE)
    assert np.all(loads[:, 1] > loads[:, 0])
    assert loads[0, 1] == pytest.approx(loads[1, 1])  # centred across: both sides alike


def test_braking_moves_m_a_h_over_l_to_the_front_axle() -> None:
    robot = replace(ROBOT, com_height_m=0.15)
    decel = 2.0
    still = wheel_loads(robot, np.array([robot.weight_n]))[..., 0]
    braking = wheel_loads(robot, np.array([robot.weight_n]), np.array([[-decel, 0.0]]))[..., 0]
    moved = braking[:, 0].sum() - still[:, 0].sum()
    assert moved == pytest.approx(robot.mass_kg * decel * 0.15 / BASE)
    assert braking[:, 1].sum() == pytest.approx(still[:, 1].sum() - moved)


def test_left_turn_moves_load_to_the_outer_right_wheels() -> None:
    """Centripetal acceleration to the left (a left turn) loads the outside: m a_y h / t."""
    loads = wheel_loads(ROBOT, np.array([ROBOT.weight_n]), np.array([[0.0, 1.0]]))[..., 0]
    moved = loads[1].sum() - ROBOT.weight_n / 2
    assert moved == pytest.approx(ROBOT.mass_kg * 1.0 * ROBOT.wheel_radius_m / TRACK)


def test_offset_robot_state_round_trips_to_the_wheel_centre() -> None:
    model = SkidModel(replace(ROBOT, com_x_m=-0.05, com_y_m=0.02))
    pose = np.array([[1.0, -2.0, 0.7], [0.0, 0.0, -2.5]])
    state = model.state_at_rest(pose)
    assert np.hypot(*(state[:, :2] - pose[:, :2]).T) == pytest.approx(np.hypot(0.05, 0.02))
    np.testing.assert_allclose(model.wheel_centre_pose(state), pose, atol=1e-12)


def test_a_centred_offset_of_zero_is_todays_model() -> None:
    """The new keys at their defaults change nothing: same step, bit for bit."""
    offset = SkidModel(replace(ROBOT, com_x_m=1e-300))  # takes the per-contact load path
    plain = SkidModel(ROBOT)
    c = coeffs_for([LIB["concrete"], LIB["soft_sand"]])
    state = np.array([[0, 0, 0, 0.4, 0.02, 0.3], [1, 2, 3, 0.1, -0.05, -0.8]], dtype=float)
    omega = np.array([[3.0, 6.0], [-4.0, 4.0]])
    np.testing.assert_allclose(
        offset.step(state, omega, c, 0.01), plain.step(state, omega, c, 0.01), rtol=1e-12
    )
    np.testing.assert_allclose(
        offset.derivatives(state, omega, c), plain.derivatives(state, omega, c), rtol=1e-12
    )


def test_rear_heavy_robot_pivots_about_a_point_behind_the_wheel_centre() -> None:
    """On a pivot the heavier rear axle resists sliding more, so the turning centre moves toward
    it and the wheel centre swings on a circle around a point behind it (Wong & Chiang 2001)."""
    model = SkidModel(replace(ROBOT, com_x_m=-0.06))
    state = model.state_at_rest(np.zeros((1, 3)))
    c = coeffs_for(LIB["concrete"])
    poses = []
    for _ in range(int(4.0 / 0.005)):
        state = model.step(state, np.array([[-4.0, 4.0]]), c, 0.005)
        poses.append(model.wheel_centre_pose(state)[0])
    poses = np.array(poses)
    # heading turns left; the wheel centre moves, and moves forward-left at first (rotating about
    # a centre behind it), where a centred robot's stays put by symmetry
    assert poses[-1, 2] > 1.0
    assert np.hypot(poses[:, 0], poses[:, 1]).max() > 0.01
    assert poses[20, 1] > 0.0
    centred = SkidModel(ROBOT)
    s = centred.state_at_rest(np.zeros((1, 3)))
    for _ in range(200):
        s = centred.step(s, np.array([[-4.0, 4.0]]), c, 0.005)
    assert np.hypot(s[0, 0], s[0, 1]) < 1e-9


def test_measured_yaw_inertia_replaces_the_geometric_estimate() -> None:
    assert replace(ROBOT, measured_yaw_inertia_kgm2=4.4).yaw_inertia_kgm2 == 4.4
    assert ROBOT.yaw_inertia_kgm2 == pytest.approx(
        ROBOT.body_mass_kg / 12 * (ROBOT.length_m**2 + ROBOT.width_m**2)
        + 4 * ROBOT.wheel_inertia_about_robot_kgm2
    )


GEOMETRY = {
    "mass_kg": 30.0,
    "wheel_mass_kg": 1.5,
    "wheel_radius_m": 0.11,
    "track_width_m": 0.6,
    "wheelbase_m": 0.3,
    "length_m": 0.6,
    "width_m": 0.44,
    "height_m": 0.16,
}


def test_robot_yaml_reads_the_centre_of_mass_and_inertia_keys() -> None:
    robot = robot_from_dict(
        {
            **GEOMETRY,
            "com_x_m": -0.067,
            "com_y_m": 0.01,
            "com_height_m": 0.2,
            "measured_yaw_inertia_kgm2": 4.4,
        }
    )
    assert (robot.com_x_m, robot.com_y_m, robot.com_height_m) == (-0.067, 0.01, 0.2)
    assert robot.yaw_inertia_kgm2 == 4.4
    plain = robot_from_dict(GEOMETRY)
    assert (plain.com_x_m, plain.com_y_m, plain.com_height_or_axle_m) == (0.0, 0.0, 0.11)


@pytest.mark.parametrize(
    ("key", "value", "expected"),
    [
        ("com_x_m", 0.2, "within +-0.15 m"),
        ("com_y_m", -0.31, "within +-0.3 m"),
        ("com_x_m", "behind", "a number in metres"),
        ("com_height_m", 0, "a number in metres > 0"),
        ("measured_yaw_inertia_kgm2", -1.0, "a number in kg m^2 > 0"),
    ],
)
def test_robot_yaml_refuses_a_centre_of_mass_off_the_wheels(key: str, value: object, expected: str) -> None:
    with pytest.raises(InputError) as exc:
        robot_from_dict({**GEOMETRY, key: value}, "robot.yaml")
    assert exc.value.where == key
    assert expected in exc.value.expected
    assert "robot.yaml" in str(exc.value)
