"""Robot parameters from YAML, inertia from geometry as the thesis computes it (ch. 2.2), and how
the weight shares between the wheels.

[Wong08] J. Y. Wong, Theory of Ground Vehicles, 4th ed., Wiley, 2008, sec. 3.1 (normal loads on
the axles, longitudinal load transfer). [Gillespie92] T. D. Gillespie, Fundamentals of Vehicle
Dynamics, SAE, 1992, ch. 2 (axle loads under acceleration) and ch. 6 (lateral load transfer).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np
from pydantic import Field, field_validator, model_validator

from swarm.files import read_yaml
from swarm.inputs import InputModel, expected, validate

GRAVITY_MPS2 = 9.80665
#: What a robot file may describe: a ground vehicle (a main battle tank is 60 t and 10 m long, its
#: road wheels 0.4 m in radius). Past these a footprint in map cells no longer fits an integer.
MAX_MASS_KG = 100_000.0
MAX_SIZE_M = 20.0
MAX_WHEEL_RADIUS_M = 2.0


@dataclass(frozen=True)
class RobotParams:
    """Geometry and mass of a four-wheel skid-steered robot (SI units).

    `track_width_m` is the thesis's axle length d (left-right wheel-centre distance);
    `wheelbase_m` is the front-rear axle distance, which sets where the four contacts are.
    `length_m`, `width_m`, `height_m` are the box body a, b, c of eq. 2.13.

    The centre of mass sits `com_x_m` ahead of and `com_y_m` left of the wheel centre (the middle
    of the four wheel contacts, where poses are measured), `com_height_m` above the ground (default
    the axle height, `wheel_radius_m`). It sets how the weight shares between the wheels and how
    acceleration moves it (`wheel_loads`). `measured_yaw_inertia_kgm2`, when known (a swing test,
    a CAD model), replaces the box-and-cylinders estimate.
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
    com_x_m: float = 0.0
    com_y_m: float = 0.0
    com_height_m: float | None = None
    measured_yaw_inertia_kgm2: float | None = None
    #: the robot file gave the centre of mass (else calibration may fit it)
    com_stated: bool = False

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
        """Yaw inertia about the centre of mass for the `skid` model: the measured one if given,
        else the body without wheels as a box plus each wheel by the parallel-axis theorem, so no
        mass is counted twice (the thesis boxes the whole mass)."""
        if self.measured_yaw_inertia_kgm2 is not None:
            return self.measured_yaw_inertia_kgm2
        body = box_yaw_inertia(self.body_mass_kg, self.length_m, self.width_m)
        return body + self.n_wheels * self.wheel_inertia_about_robot_kgm2

    @property
    def com_height_or_axle_m(self) -> float:
        return self.wheel_radius_m if self.com_height_m is None else self.com_height_m

    @property
    def contact_x_m(self) -> tuple[float, float]:
        """Body x of the front and rear axles' contacts, measured from the centre of mass."""
        half = self.wheelbase_m / 2
        return half - self.com_x_m, -half - self.com_x_m

    @property
    def contact_y_m(self) -> tuple[float, float]:
        """Body y of the left and right sides' contacts, measured from the centre of mass."""
        half = self.track_width_m / 2
        return half - self.com_y_m, -half - self.com_y_m

    @property
    def static_load_shares(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """Shares of the weight on (front, rear) axles and (left, right) sides at rest.

        Lever rule about the centre of mass: N_f (l/2 - x_c) = N_r (l/2 + x_c), likewise across
        the track [Wong08, sec. 3.1]. The four-contact problem is statically indeterminate; with
        a rigid chassis on equally stiff contacts each wheel's load is the product of its axle's
        and its side's share, which balances both moments.
        """
        half_l, half_t = self.wheelbase_m / 2, self.track_width_m / 2
        front = (half_l + self.com_x_m) / self.wheelbase_m
        left = (half_t + self.com_y_m) / self.track_width_m
        return (front, 1.0 - front), (left, 1.0 - left)

    @property
    def weight_n(self) -> float:
        return self.mass_kg * GRAVITY_MPS2


def wheel_loads(
    robot: RobotParams,
    support_n: np.ndarray,
    ground_accel_mps2: np.ndarray | None = None,
) -> np.ndarray:
    """Normal load on each contact, shape (2 sides [left, right], 2 axles [front, rear], n).

    `support_n` (n,) is the weight the ground carries (m g cos(slope), less buoyancy or wave
    lift). `ground_accel_mps2` (n, 2) is the in-plane force the ground exerts per unit mass, in
    the body frame: the centre of mass's acceleration minus gravity's in-plane part (on a slope)
    and any other external force per mass. That force acts at the ground, h below the centre of
    mass, and its pitch and roll moments shift load between the axles and the sides: accelerating
    at a_x unloads the front axle by m a_x h / l and loads the rear as much, a_y (to the left)
    moves m a_y h / t to the right side [Wong08, sec. 3.1; Gillespie92, ch. 2 and 6]. No load goes
    negative: a wheel that lifts off carries nothing.
    """
    (front, rear), (left, right) = robot.static_load_shares
    support = np.reshape(support_n, -1)
    # (side, axle, 1) shares: whole-array operations, the same floats as side by side and axle by axle
    loads = support * np.array([[[left * front], [left * rear]], [[right * front], [right * rear]]])
    if ground_accel_mps2 is None:
        return loads
    acc = np.reshape(ground_accel_mps2, (-1, 2))
    mh = robot.mass_kg * robot.com_height_or_axle_m
    to_rear = mh * acc[:, 0] / robot.wheelbase_m  # total moved from the front axle to the rear
    to_right = mh * acc[:, 1] / robot.track_width_m  # total moved from the left side to the right
    loads += to_rear * np.array([[[-left], [left]], [[-right], [right]]])
    loads += to_right * np.array([[[-front], [-rear]], [[front], [rear]]])
    return np.maximum(loads, 0.0, out=loads)


def box_yaw_inertia(mass_kg: float, length_m: float, width_m: float) -> float:
    """Uniform box about its vertical axis: M/12 (a^2 + b^2)."""
    return mass_kg / 12.0 * (length_m**2 + width_m**2)


def cylinder_inertia(mass_kg: float, radius_m: float) -> float:
    """The thesis's wheel approximation: I_w = m_w r^2 (a thin-walled cylinder about its axis)."""
    return mass_kg * radius_m**2


def parallel_axis(inertia_cm_kgm2: float, mass_kg: float, offset_m: float) -> float:
    """Parallel-axis theorem: I = I_cm + m h^2."""
    return inertia_cm_kgm2 + mass_kg * offset_m**2


class RobotFile(InputModel):
    """A robot YAML file as written (swarm/data/robots/skid4.yaml); `RobotParams` is what it means."""

    name: str | None = Field(None, min_length=1, description="Default: the file's stem.")
    mass_kg: float = Field(gt=0, le=MAX_MASS_KG, description="The whole robot, wheels included.")
    wheel_mass_kg: float = Field(gt=0, description="One wheel.")
    wheel_radius_m: float = Field(gt=0, le=MAX_WHEEL_RADIUS_M)
    track_width_m: float = Field(
        gt=0, le=MAX_SIZE_M, description="Left-right wheel-centre distance (the thesis's d)."
    )
    wheelbase_m: float = Field(gt=0, le=MAX_SIZE_M, description="Front-rear axle distance.")
    length_m: float = Field(gt=0, le=MAX_SIZE_M, description="Body box length a (eq. 2.13).")
    width_m: float = Field(gt=0, le=MAX_SIZE_M, description="Body box width b (eq. 2.13).")
    height_m: float = Field(gt=0, le=MAX_SIZE_M, description="Body box height c (eq. 2.13).")
    encoder_ticks_per_wheel_rev: int = Field(1960, gt=0, le=2**31 - 1)
    n_wheels: int = 4
    com_x_m: float | None = None
    com_y_m: float | None = None
    com_height_m: float | None = Field(None, gt=0, le=MAX_SIZE_M)
    measured_yaw_inertia_kgm2: float | None = Field(None, gt=0)

    @field_validator("n_wheels")
    @classmethod
    def _two_or_four(cls, n: int) -> int:
        if n not in (2, 4):
            raise expected("2 or 4", found=n)
        return n

    @model_validator(mode="after")
    def _consistent(self) -> RobotFile:
        for key, span in (("com_x_m", "wheelbase_m"), ("com_y_m", "track_width_m")):
            value, half = getattr(self, key), getattr(self, span) / 2
            if value is not None and not abs(value) < half:
                words = f"a number within +-{half:g} m (half the {span}: over the wheels)"
                raise expected(words, found=value, key=key)
        if self.wheel_mass_kg * self.n_wheels >= self.mass_kg:
            raise expected(
                "wheels lighter than the whole robot", found=self.wheel_mass_kg, key="wheel_mass_kg"
            )
        return self


def robot_from_dict(data: object, source: str | Path = "<robot>") -> RobotParams:
    """Validate a mapping of robot keys (`RobotFile`) and build `RobotParams`."""
    f = validate(RobotFile, data, source)
    values = f.model_dump(exclude_none=True)
    values["name"] = f.name or Path(str(source)).stem
    values["com_stated"] = f.com_x_m is not None or f.com_y_m is not None
    return RobotParams(**values)


def load_robot(path: str | Path) -> RobotParams:
    """Read a robot YAML file; bad keys or values raise `InputError` naming file and key."""
    return robot_from_dict(read_yaml(path, "robot YAML file"), path)
