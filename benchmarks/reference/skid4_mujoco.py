"""Independent MuJoCo reference simulator of the skid4 robot, used as held-out ground truth.

The sample runs in ``swarm/data/robot-runs`` came from a rigid-body engine with Coulomb friction
contacts and velocity-controlled wheel motors. This module rebuilds such an engine from the robot's
YAML values, with per-surface contact parameters fitted to those samples (``surfaces.yaml``), so
that drive patterns with no recorded run can still be given a physically plausible "truth" that
is independent of the project's own (simpler) robot model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import yaml

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
ROBOT_YAML = REPO / "swarm" / "data" / "robots" / "skid4.yaml"
SURFACES_YAML = HERE / "surfaces.yaml"

WHEEL_WIDTH_M = 0.08
KV = 50.0  # N m per rad/s: stiff enough that measured wheel speed tracks the command closely
MAX_TORQUE = 60.0  # N m per wheel, well above what traction can ever need
# Reflected motor inertia behind the 98:1 gearbox; also keeps the stiff velocity servo stable
# under semi-implicit Euler when a wheel leaves the ground on lumps.
ARMATURE = 0.1
# Semi-implicit Euler, not implicit(fast): with stiff velocity actuators the implicit integrators
# let the chassis run ahead of its wheels while accelerating (checked against RK4).
TIMESTEP_S = 0.001
HFIELD_SIZE_M = 40.0  # half-extent of the soft-sand heightfield; runs start at its centre
HFIELD_CELLS = 801  # 0.1 m grid


@dataclass(frozen=True)
class Surface:
    """Contact parameters of one ground surface (MuJoCo wheel-ground pair, condim 6).

    Why these knobs: in MuJoCo's elliptic cone the sliding, torsional and rolling components share
    one cone per contact. ``torsional`` (m) resists each wheel's yaw, so it sets how far a
    skid-steer turn gets for given wheel speeds (less on sand, which turns more); ``rolling`` (m)
    resists wheel spin and, by taking its share of the cone, leaves less traction, which gives the
    steady longitudinal slip of sand. ``timeconst``/``dampratio`` are the contact's solref
    (softness). ``lump_rms_m``/``lump_wavelength_m`` describe the random heightfield of soft sand
    (0 = flat plane) that makes the heading wander.
    """

    sliding: float = 1.0
    torsional: float = 0.005
    rolling: float = 0.0001
    timeconst: float = 0.02
    dampratio: float = 1.0
    lump_rms_m: float = 0.0
    lump_wavelength_m: float = 1.0

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Surface:
        names = {f.name for f in fields(cls)}
        return cls(**{k: float(v) for k, v in d.items() if k in names})


def load_robot(path: Path = ROBOT_YAML) -> dict[str, float]:
    """Robot geometry and masses, read from the project's robot YAML so the two never diverge."""
    with path.open() as f:
        return yaml.safe_load(f)


def load_surfaces(path: Path = SURFACES_YAML) -> dict[str, Surface]:
    """Fitted surfaces from ``surfaces.yaml`` (key ``surfaces``)."""
    with path.open() as f:
        data = yaml.safe_load(f)
    return {name: Surface.from_dict(v) for name, v in data["surfaces"].items()}


def _lumps(surface: Surface, seed: int) -> tuple[np.ndarray, float]:
    """Smooth random bumps of the surface's wavelength: (heights scaled to [0, 1], their range in m).

    The range is set so that the heights' RMS about their mean is ``lump_rms_m``.
    """
    rng = np.random.default_rng(seed)
    n = HFIELD_CELLS
    noise = rng.standard_normal((n, n))
    cell = 2 * HFIELD_SIZE_M / (n - 1)
    # Gaussian low-pass of white noise; kernel std = wavelength / (2 pi).
    k = np.fft.fftfreq(n, d=cell)
    kx, ky = np.meshgrid(k, k)
    sigma = surface.lump_wavelength_m / (2 * math.pi)
    filt = np.exp(-2 * (math.pi * sigma) ** 2 * (kx**2 + ky**2))
    field = np.real(np.fft.ifft2(np.fft.fft2(noise) * filt))
    span = float(field.max() - field.min())
    return (field - field.min()) / span, surface.lump_rms_m * span / float(field.std())


def build_mjcf(
    robot: dict[str, float], surface: Surface, timestep: float = TIMESTEP_S, relief_m: float = 0.0
) -> str:
    """MJCF text of the robot on one surface; wheels touch the ground only through explicit pairs.

    ``relief_m`` > 0 makes the ground a heightfield of that height range (data set afterwards).
    """
    r = robot["wheel_radius_m"]
    half_track = robot["track_width_m"] / 2
    half_base = robot["wheelbase_m"] / 2
    mw = robot["wheel_mass_kg"]
    ballast_kg = float(robot.get("ballast_kg", 0.0))
    m_body = robot["mass_kg"] - 4 * mw - ballast_kg
    lx, ly, lz = robot["length_m"] / 2, robot["width_m"] / 2, robot["height_m"] / 2
    z0 = r + relief_m + 0.005  # just above the highest possible ground; reset() lets it settle

    if relief_m > 0:
        asset = (
            f'<hfield name="sand" nrow="{HFIELD_CELLS}" ncol="{HFIELD_CELLS}" '
            f'size="{HFIELD_SIZE_M} {HFIELD_SIZE_M} {relief_m} 0.1"/>'
        )
        ground = '<geom name="ground" type="hfield" hfield="sand" contype="0" conaffinity="0"/>'
    else:
        asset = ""
        ground = '<geom name="ground" type="plane" size="0 0 1" contype="0" conaffinity="0"/>'

    # an optional payload: a small dense box inside the chassis, `ballast_x_m` ahead of the wheel
    # centre, that moves the centre of mass (the rear-heavy held-out variant, make_variant.py)
    ballast = (
        f'<geom name="ballast" type="box" size="0.05 0.1 0.03" pos="{robot.get("ballast_x_m", 0.0)} 0 0" '
        f'mass="{ballast_kg}" contype="0" conaffinity="0"/>'
        if ballast_kg > 0
        else ""
    )
    sol = f"{surface.timeconst} {surface.dampratio}"
    fric = f"{surface.sliding} {surface.sliding} {surface.torsional} {surface.rolling} {surface.rolling}"
    wheels, pairs, acts = [], [], []
    for name, x, y in (
        ("fl", half_base, half_track),
        ("rl", -half_base, half_track),
        ("fr", half_base, -half_track),
        ("rr", -half_base, -half_track),
    ):
        wheels.append(
            f'<body name="{name}" pos="{x} {y} 0">'
            f'<joint name="{name}" type="hinge" axis="0 1 0" armature="{ARMATURE}"/>'
            f'<geom name="{name}" type="cylinder" size="{r} {WHEEL_WIDTH_M / 2}" zaxis="0 1 0" '
            f'mass="{mw}" contype="0" conaffinity="0"/></body>'
        )
        pairs.append(f'<pair geom1="{name}" geom2="ground" condim="6" friction="{fric}" solref="{sol}"/>')
        acts.append(
            f'<velocity name="{name}" joint="{name}" kv="{KV}" forcelimited="true" '
            f'forcerange="-{MAX_TORQUE} {MAX_TORQUE}"/>'
        )
    return f"""
<mujoco model="skid4">
  <option timestep="{timestep}" cone="elliptic" integrator="Euler"/>
  <asset>{asset}</asset>
  <worldbody>
    {ground}
    <body name="chassis" pos="0 0 {z0}">
      <freejoint name="root"/>
      <geom name="chassis" type="box" size="{lx} {ly} {lz}" mass="{m_body}"
            contype="0" conaffinity="0"/>
      {ballast}
      {"".join(wheels)}
    </body>
  </worldbody>
  <contact>{"".join(pairs)}</contact>
  <actuator>{"".join(acts)}</actuator>
</mujoco>
"""


class Skid4Sim:
    """A built MuJoCo model of skid4 on one surface, reusable across runs of that surface."""

    def __init__(
        self,
        surface: Surface,
        seed: int = 0,
        robot: dict[str, float] | None = None,
        timestep: float = TIMESTEP_S,
    ) -> None:
        self.robot = robot or load_robot()
        self.surface = surface
        heights, relief = _lumps(surface, seed) if surface.lump_rms_m > 0 else (None, 0.0)
        self.model = mujoco.MjModel.from_xml_string(build_mjcf(self.robot, surface, timestep, relief))
        if heights is not None:
            self.model.hfield_data[:] = heights.ravel()
        self.data = mujoco.MjData(self.model)
        self._left = [self.model.actuator(n).id for n in ("fl", "rl")]
        self._right = [self.model.actuator(n).id for n in ("fr", "rr")]
        self._qv_left = [self.model.jnt_dofadr[self.model.joint(n).id] for n in ("fl", "rl")]
        self._qv_right = [self.model.jnt_dofadr[self.model.joint(n).id] for n in ("fr", "rr")]
        self._qp_left = [self.model.jnt_qposadr[self.model.joint(n).id] for n in ("fl", "rl")]
        self._qp_right = [self.model.jnt_qposadr[self.model.joint(n).id] for n in ("fr", "rr")]

    def reset(self, heading0_rad: float, settle_s: float = 0.5) -> None:
        """Place the robot at the origin with the given heading and let it settle on the ground."""
        mujoco.mj_resetData(self.model, self.data)
        q = self.data.qpos
        q[3:7] = [math.cos(heading0_rad / 2), 0.0, 0.0, math.sin(heading0_rad / 2)]
        mujoco.mj_forward(self.model, self.data)
        for _ in range(int(settle_s / self.model.opt.timestep)):
            mujoco.mj_step(self.model, self.data)
        self.data.time = 0.0

    def pose(self) -> tuple[float, float, float]:
        """(x, y, heading): heading is the yaw of the body's forward axis, CCW from +X."""
        q = self.data.qpos
        w, x, y, z = q[3:7]
        heading = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        return float(q[0]), float(q[1]), heading

    def run(
        self, t_s: np.ndarray, left: np.ndarray, right: np.ndarray, heading0_rad: float
    ) -> dict[str, np.ndarray]:
        """Drive with commands sampled at t_s (linear in between) and sample the state at t_s.

        Besides the pose and measured wheel speeds, left_rad/right_rad are the wheel angles turned
        since the start (mean of each side's two wheels), from which encoder ticks are taken.
        """
        t_s = np.asarray(t_s, dtype=float)
        self.reset(heading0_rad)
        m, d = self.model, self.data
        dt = m.opt.timestep
        x0, y0, _ = self.pose()
        qp_left0 = float(np.mean(d.qpos[self._qp_left]))
        qp_right0 = float(np.mean(d.qpos[self._qp_right]))
        n = len(t_s)
        keys = ("x_m", "y_m", "heading_rad", "left_radps", "right_radps", "left_rad", "right_rad")
        out = {k: np.zeros(n) for k in keys}
        t0 = float(t_s[0])
        sim_t = 0.0
        for i, ti in enumerate(t_s):
            target = ti - t0
            while sim_t < target - 1e-9:
                tc = t0 + sim_t + dt  # command at the end of the step (velocity servo target)
                d.ctrl[self._left] = np.interp(tc, t_s, left)
                d.ctrl[self._right] = np.interp(tc, t_s, right)
                mujoco.mj_step(m, d)
                sim_t += dt
            x, y, h = self.pose()
            if self.surface.lump_rms_m > 0 and max(abs(x), abs(y)) > HFIELD_SIZE_M - 1.0:
                raise ValueError(f"run leaves the {2 * HFIELD_SIZE_M:.0f} m soft-sand heightfield at t={ti}")
            out["x_m"][i], out["y_m"][i], out["heading_rad"][i] = x - x0, y - y0, h
            out["left_radps"][i] = float(np.mean(d.qvel[self._qv_left]))
            out["right_radps"][i] = float(np.mean(d.qvel[self._qv_right]))
            out["left_rad"][i] = float(np.mean(d.qpos[self._qp_left])) - qp_left0
            out["right_rad"][i] = float(np.mean(d.qpos[self._qp_right])) - qp_right0
        out["t_s"] = t_s.copy()
        return out


def simulate(
    t_s: np.ndarray,
    left_radps: np.ndarray,
    right_radps: np.ndarray,
    surface: str | Surface,
    heading0_rad: float,
    seed: int = 0,
) -> dict[str, np.ndarray]:
    """Simulate one run from the origin; returns t_s, x_m, y_m, heading_rad, left/right_radps
    (measured wheel speeds) and left/right_rad (wheel angles).

    ``surface`` is a name in ``surfaces.yaml`` (concrete, hardsand, softsand) or a Surface.
    ``seed`` only matters on lumpy surfaces (it draws the heightfield).
    """
    surf = load_surfaces()[surface] if isinstance(surface, str) else surface
    return Skid4Sim(surf, seed=seed).run(t_s, left_radps, right_radps, heading0_rad)
