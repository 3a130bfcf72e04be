"""A second, independent reference engine: Bullet (PyBullet) driving Clearpath's Husky A200.

Different engine (Bullet's sequential-impulse solver, not MuJoCo's convex optimisation), different
robot (Clearpath's published Husky description, not skid4): 56.6 kg, 0.512 m wheelbase, 0.571 m
track, 0.165 m wheels, and a centre of mass 6.9 cm to the right of the wheel centre and 19 cm up, as
the description gives it. See README.md for where every number comes from.
"""

from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pybullet as pb

HERE = Path(__file__).resolve().parent

# Clearpath husky_description (husky.urdf.xacro, wheel.urdf.xacro), BSD licence: the published values.
BASE_X, BASE_Y, BASE_Z = 0.9874, 0.5709, 0.2475  # chassis box (m)
WHEELBASE, TRACK = 0.5120, 0.5708
WHEEL_VERTICAL_OFFSET = 0.03282  # wheel axles above base_link (the bottom plate's centre)
WHEEL_LENGTH, WHEEL_RADIUS = 0.1143, 0.1651
BODY_MASS = 46.034
BODY_COM = (-0.00065, -0.085, 0.062)  # from base_link
BODY_INERTIA = (0.6022, 1.7386, 2.0296)  # ixx, iyy, izz about the body's centre of mass
WHEEL_MASS = 2.637
WHEEL_INERTIA = (0.02467, 0.04411, 0.02467)  # about the wheel's own axes, spin axis y

TIMESTEP_S = 0.001
MAX_WHEEL_TORQUE_NM = 120.0  # velocity servo force limit, well above what traction needs
TICKS_PER_REV = 1960  # the encoder log format the project reads; same resolution as skid4


@dataclass(frozen=True)
class Surface:
    """Bullet contact parameters of one ground: Coulomb friction (lateralFriction, both tangent
    directions), rollingFriction and spinningFriction (m: moment per unit normal force), and the
    contact's stiffness and damping (soft contacts sink, for sand)."""

    friction: float
    rolling_m: float
    spinning_m: float
    stiffness: float
    damping: float


#: Chosen from the terrain literature the project cites (not fitted to any run):
#: concrete mu 0.9 [Wong08 Table 1.3]; wet hard sand mu 0.7 with c_rr ~0.04 [Wong08 Table 1.1];
#: soft sand mu 0.55, c_rr ~0.2 and a soft, sinking contact. Rolling friction r * c_rr.
SURFACES: dict[str, Surface] = {
    "concrete": Surface(friction=0.9, rolling_m=0.002, spinning_m=0.01, stiffness=3e6, damping=3e4),
    "hardsand": Surface(friction=0.7, rolling_m=0.007, spinning_m=0.015, stiffness=1e6, damping=2e4),
    "softsand": Surface(friction=0.55, rolling_m=0.03, spinning_m=0.015, stiffness=2e5, damping=8e3),
}


def _urdf() -> str:
    """The Husky as a URDF: the published chassis boxes, inertial and wheel values, no meshes.

    Wheels collide as spheres of the wheel radius: one contact at the tyre's crown. Bullet's
    cylinder-plane contact jumps between the two rim edges, which turned the square's corners
    anywhere from 30 to 75 degrees for the same commands.
    """
    cx, cy, cz = BODY_COM
    ixx, iyy, izz = BODY_INERTIA
    wxx, wyy, wzz = WHEEL_INERTIA
    wheels = []
    for name, x, y in (
        ("front_left", WHEELBASE / 2, TRACK / 2),
        ("front_right", WHEELBASE / 2, -TRACK / 2),
        ("rear_left", -WHEELBASE / 2, TRACK / 2),
        ("rear_right", -WHEELBASE / 2, -TRACK / 2),
    ):
        wheels.append(f"""
  <link name="{name}_wheel">
    <inertial><mass value="{WHEEL_MASS}"/><origin xyz="0 0 0"/>
      <inertia ixx="{wxx}" ixy="0" ixz="0" iyy="{wyy}" iyz="0" izz="{wzz}"/>
    </inertial>
    <collision><origin xyz="0 0 0"/><geometry><sphere radius="{WHEEL_RADIUS}"/></geometry></collision>
  </link>
  <joint name="{name}_joint" type="continuous">
    <parent link="base_link"/><child link="{name}_wheel"/>
    <origin xyz="{x} {y} {WHEEL_VERTICAL_OFFSET}"/><axis xyz="0 1 0"/>
  </joint>""")
    return f"""<?xml version="1.0"?>
<robot name="husky">
  <link name="base_link">
    <inertial><mass value="{BODY_MASS}"/><origin xyz="{cx} {cy} {cz}"/>
      <inertia ixx="{ixx}" ixy="0" ixz="0" iyy="{iyy}" iyz="0" izz="{izz}"/></inertial>
    <collision><origin xyz="0 0 {BASE_Z / 4}"/>
      <geometry><box size="{BASE_X} {BASE_Y} {BASE_Z / 2}"/></geometry></collision>
    <collision><origin xyz="0 0 {BASE_Z * 3 / 4}"/>
      <geometry><box size="{BASE_X * 4 / 5} {BASE_Y} {BASE_Z / 2}"/></geometry></collision>
  </link>{"".join(wheels)}
</robot>
"""


def robot_summary() -> dict[str, float]:
    """Whole-robot mass, centre of mass (from the wheel centre, and height above ground) and yaw
    inertia about it, from the published parts: what a robot YAML for the project states."""
    ground = WHEEL_VERTICAL_OFFSET - WHEEL_RADIUS  # ground z in base_link
    wheel_xy = [(sx * WHEELBASE / 2, sy * TRACK / 2) for sx in (1, -1) for sy in (1, -1)]
    mass = BODY_MASS + 4 * WHEEL_MASS
    com_x = BODY_MASS * BODY_COM[0] / mass
    com_y = BODY_MASS * BODY_COM[1] / mass
    com_z = (BODY_MASS * BODY_COM[2] + 4 * WHEEL_MASS * WHEEL_VERTICAL_OFFSET) / mass - ground
    izz = BODY_INERTIA[2] + BODY_MASS * ((BODY_COM[0] - com_x) ** 2 + (BODY_COM[1] - com_y) ** 2)
    izz += sum(WHEEL_INERTIA[0] + WHEEL_MASS * ((x - com_x) ** 2 + (y - com_y) ** 2) for x, y in wheel_xy)
    return {
        "mass_kg": mass,
        "com_x_m": com_x,
        "com_y_m": com_y,
        "com_height_m": com_z,
        "yaw_inertia_kgm2": izz,
    }


def simulate(
    t: np.ndarray, left_radps: np.ndarray, right_radps: np.ndarray, surface: str, heading0_rad: float
) -> dict[str, np.ndarray]:
    """Drive the Husky with wheel-speed commands sampled on the grid `t` (held between samples).

    Returns, on the same grid: the wheel centre's x_m, y_m (from the start) and heading_rad, each
    side's measured wheel speed (left/right_radps, the mean of its two joints) and angle
    (left/right_rad).
    """
    ground = SURFACES[surface]
    client = pb.connect(pb.DIRECT)
    try:
        pb.setGravity(0, 0, -9.80665, physicsClientId=client)
        pb.setPhysicsEngineParameter(fixedTimeStep=TIMESTEP_S, numSolverIterations=50, physicsClientId=client)
        plane = pb.createMultiBody(
            0, pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=client), physicsClientId=client
        )
        with tempfile.NamedTemporaryFile("w", suffix=".urdf", delete=False) as f:
            f.write(_urdf())
        z0 = WHEEL_RADIUS - WHEEL_VERTICAL_OFFSET + 0.002
        quat = pb.getQuaternionFromEuler((0, 0, heading0_rad))
        body = pb.loadURDF(
            f.name, (0, 0, z0), quat, flags=pb.URDF_USE_INERTIA_FROM_FILE, physicsClientId=client
        )
        Path(f.name).unlink()
        pb.changeDynamics(plane, -1, lateralFriction=1.0, physicsClientId=client)
        left_joints, right_joints = [], []
        for j in range(pb.getNumJoints(body, physicsClientId=client)):
            name = pb.getJointInfo(body, j, physicsClientId=client)[1].decode()
            (left_joints if "left" in name else right_joints).append(j)
            pb.changeDynamics(
                body,
                j,
                lateralFriction=ground.friction,
                rollingFriction=ground.rolling_m,
                spinningFriction=ground.spinning_m,
                contactStiffness=ground.stiffness,
                contactDamping=ground.damping,
                physicsClientId=client,
            )
            pb.setJointMotorControl2(
                body, j, pb.VELOCITY_CONTROL, targetVelocity=0, force=0, physicsClientId=client
            )
        # settle onto the ground before the run
        for _ in range(500):
            pb.stepSimulation(physicsClientId=client)
        inertial_pos = np.array(pb.getDynamicsInfo(body, -1, physicsClientId=client)[3])

        def pose() -> tuple[float, float, float]:
            pos, orn = pb.getBasePositionAndOrientation(body, physicsClientId=client)
            rot = np.array(pb.getMatrixFromQuaternion(orn)).reshape(3, 3)
            link = np.array(pos) - rot @ inertial_pos  # base_link frame origin: the wheel centre in x, y
            return float(link[0]), float(link[1]), math.atan2(rot[1, 0], rot[0, 0])

        def wheels(joints: list[int]) -> tuple[float, float]:
            states = pb.getJointStates(body, joints, physicsClientId=client)
            return float(np.mean([s[0] for s in states])), float(np.mean([s[1] for s in states]))

        x0, y0, _ = pose()
        angle0 = (wheels(left_joints)[0], wheels(right_joints)[0])
        sub = round((t[1] - t[0]) / TIMESTEP_S)
        out = {
            k: np.empty(len(t))
            for k in ("x_m", "y_m", "heading_rad", "left_radps", "right_radps", "left_rad", "right_rad")
        }
        for i in range(len(t)):
            x, y, h = pose()
            (al, wl), (ar, wr) = wheels(left_joints), wheels(right_joints)
            out["x_m"][i], out["y_m"][i], out["heading_rad"][i] = x - x0, y - y0, h
            out["left_rad"][i], out["right_rad"][i] = al - angle0[0], ar - angle0[1]
            out["left_radps"][i], out["right_radps"][i] = wl, wr
            if i == len(t) - 1:
                break
            for joints, cmd in ((left_joints, left_radps[i]), (right_joints, right_radps[i])):
                pb.setJointMotorControlArray(
                    body,
                    joints,
                    pb.VELOCITY_CONTROL,
                    targetVelocities=[float(cmd)] * len(joints),
                    forces=[MAX_WHEEL_TORQUE_NM] * len(joints),
                    physicsClientId=client,
                )
            for _ in range(sub):
                pb.stepSimulation(physicsClientId=client)
        out["heading_rad"] = np.unwrap(out["heading_rad"])
        return out
    finally:
        pb.disconnect(physicsClientId=client)
