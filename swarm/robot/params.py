"""Robot parameters from YAML, and inertia from geometry as the thesis computes it (ch. 2.2)."""

from __future__ import annotations

from dataclasses import dataclass, fields
from functools import cached_property
from pathlib import Path

from swarm.errors import InputError
from swarm.files import read_yaml

GRAVITY_MPS2 = 9.80665


@dataclass(frozen=True)
class RobotParams:
    """Geometry and mass of a four-wheel skid-steered robot (SI units).

    `track_width_m` is the thesis's axle length d (left-right wheel-centre distance);
    `wheelbase_m` is the front-rear axle distance, which sets where the four contacts are.
    `length_m`, `width_m`, `height_m` are the box body a, b, c of eq. 2.13.
    """

    name: str
    mass_kg: float
    wheel_mass_kg: float
    wheel_radius_m: float
    track_width_m: float
    wheelbase_m: float
    length_m: float
    width_m: float
    height_m: float
    encoder_ticks_per_wheel_rev: int = 1960
    n_wheels: int = 4

    @property
    def body_mass_kg(self) -> float:
        return self.mass_kg - self.n_wheels * self.wheel_mass_kg

    @property
    def thesis_yaw_inertia_kgm2(self) -> float:
        """The thesis's I_R: the whole mass M as a uniform box, M/12 (a^2 + b^2) (eq. 2.13)."""
        return box_yaw_inertia(self.mass_kg, self.length_m, self.width_m)

    @property
    def wheel_spin_inertia_kgm2(self) -> float:
        """One wheel as the thesis's thin cylinder, I_w = m_w r^2 (section 2.2.2)."""
        return cylinder_inertia(self.wheel_mass_kg, self.wheel_radius_m)

    @property
    def wheel_offset_m(self) -> float:
        """Distance h from a wheel's centre to the robot's vertical axis through the centre of mass."""
        return float(((self.track_width_m / 2) ** 2 + (self.wheelbase_m / 2) ** 2) ** 0.5)

    @property
    def wheel_inertia_about_robot_kgm2(self) -> float:
        """The thesis's wheel inertia moved to the robot axis: I_w + m_w h^2 (section 2.2.2)."""
        return parallel_axis(self.wheel_spin_inertia_kgm2, self.wheel_mass_kg, self.wheel_offset_m)

    @cached_property
    def yaw_inertia_kgm2(self) -> float:
        """Yaw inertia for the `skid` model: the body without wheels as a box, plus each wheel by
        the parallel-axis theorem, so no mass is counted twice (the thesis boxes the whole mass)."""
        body = box_yaw_inertia(self.body_mass_kg, self.length_m, self.width_m)
        return body + self.n_wheels * self.wheel_inertia_about_robot_kgm2

    @property
    def weight_n(self) -> float:
        return self.mass_kg * GRAVITY_MPS2


def box_yaw_inertia(mass_kg: float, length_m: float, width_m: float) -> float:
    """Uniform box about its vertical axis: M/12 (a^2 + b^2)."""
    return mass_kg / 12.0 * (length_m**2 + width_m**2)


def cylinder_inertia(mass_kg: float, radius_m: float) -> float:
    """The thesis's wheel approximation: I_w = m_w r^2 (a thin-walled cylinder about its axis)."""
    return mass_kg * radius_m**2


def parallel_axis(inertia_cm_kgm2: float, mass_kg: float, offset_m: float) -> float:
    """Parallel-axis theorem: I = I_cm + m h^2."""
    return inertia_cm_kgm2 + mass_kg * offset_m**2


_FLOAT_KEYS = (
    "mass_kg",
    "wheel_mass_kg",
    "wheel_radius_m",
    "track_width_m",
    "wheelbase_m",
    "length_m",
    "width_m",
    "height_m",
)


def robot_from_dict(data: object, source: str | Path = "<robot>") -> RobotParams:
    """Validate a mapping of robot keys (as in robot.yaml) and build `RobotParams`."""
    if not isinstance(data, dict):
        raise InputError(source, "(top level)", type(data).__name__, "a mapping of robot keys")
    known = {f.name for f in fields(RobotParams)}
    for key in data:
        if key not in known:
            raise InputError(source, str(key), key, f"one of {sorted(known)}")
    values: dict[str, object] = {"name": str(data.get("name", Path(str(source)).stem))}
    for key in _FLOAT_KEYS:
        if key not in data:
            raise InputError(source, key, "nothing", "a positive number")
        value = data[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
            raise InputError(source, key, value, "a positive number")
        values[key] = float(value)
    for key in ("encoder_ticks_per_wheel_rev", "n_wheels"):
        if key in data:
            value = data[key]
            if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
                raise InputError(source, key, value, "a positive integer")
            values[key] = value
    if values.get("n_wheels", 4) not in (2, 4):
        raise InputError(source, "n_wheels", values["n_wheels"], "2 or 4")
    if values["wheel_mass_kg"] * values.get("n_wheels", 4) >= values["mass_kg"]:  # type: ignore[operator]
        raise InputError(
            source, "wheel_mass_kg", values["wheel_mass_kg"], "wheels lighter than the whole robot"
        )
    return RobotParams(**values)  # type: ignore[arg-type]


def load_robot(path: str | Path) -> RobotParams:
    """Read a robot YAML file; bad keys or values raise `InputError` naming file and key."""
    return robot_from_dict(read_yaml(path, "robot YAML file"), path)
