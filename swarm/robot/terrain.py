"""Terrain modes: the ground coefficients the `skid` model uses, with where each default comes from.

A terrain mode is what the wheels feel on one surface: peak traction, how much slip builds it
(Janosi-Hanamoto), lateral friction, rolling resistance, effective rolling radius, and in water how
much of the weight the water carries and how hard it drags. The map (issue 3) names a mode per cell,
so the simulator gathers per-robot coefficient arrays from `TerrainTable` by cell class.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Annotated, Any

import numpy as np
from pydantic import AfterValidator, Field, create_model

from swarm.errors import InputError
from swarm.files import parse_yaml, read_yaml
from swarm.inputs import InputModel, expected, validate

#: The coefficients a mode carries, with what each must be. Order matters: it is the column
#: order of `TerrainTable` and of calibration vectors.
COEFFICIENTS: dict[str, str] = {
    "mu_peak": "peak longitudinal traction coefficient (traction / normal load), >= 0",
    "mu_lateral": "lateral (sideways sliding) friction coefficient, >= 0",
    "shear_slip": "Janosi-Hanamoto slip where traction reaches 1 - 1/e of its peak (K / contact length), > 0",
    "rolling_resistance": "rolling-resistance coefficient (force / normal load), >= 0",
    "turning_resistance_m": "spin (bore) friction of a patch at pure spin: yaw moment / normal load, m, >= 0",
    "rolling_radius_scale": "effective rolling radius / nominal wheel radius (sinkage), in (0, 1.5]",
    "buoyancy_fraction": "fraction of the robot's weight carried by water, in [0, 1]",
    "drag_n_s2_per_m2": "quadratic hydrodynamic drag 0.5 rho Cd A on the hull, N s^2/m^2, >= 0",
}

_BOUNDS: dict[str, tuple[float, float]] = {
    "mu_peak": (0.0, 5.0),
    "mu_lateral": (0.0, 5.0),
    "shear_slip": (1e-4, 5.0),
    "rolling_resistance": (0.0, 2.0),
    "turning_resistance_m": (0.0, 1.0),
    "rolling_radius_scale": (1e-3, 1.5),
    "buoyancy_fraction": (0.0, 1.0),
    "drag_n_s2_per_m2": (0.0, 1e5),
}


@dataclass(frozen=True)
class TerrainMode:
    """One surface's coefficients for the `skid` model, and the source of each default."""

    name: str
    mu_peak: float
    mu_lateral: float
    shear_slip: float
    rolling_resistance: float
    turning_resistance_m: float = 0.0
    rolling_radius_scale: float = 1.0
    buoyancy_fraction: float = 0.0
    drag_n_s2_per_m2: float = 0.0
    description: str = ""
    #: False for ground no robot can cross (boulders, driftwood logs): planners treat it as an obstacle.
    passable: bool = True
    sources: Mapping[str, str] = field(default_factory=dict)
    #: Fitted parameters of the thesis models on this ground: {"kinematic": {"alpha": .., "chi": ..},
    #: "lagrangian": {"robot_inertia_scale": .., "wheel_inertia_scale": ..}}
    model_params: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    #: One standard deviation of each default, where the source states a range: how far
    #: calibration may pull a coefficient from it before the prior pushes back.
    uncertainty: Mapping[str, float] = field(default_factory=dict)

    @property
    def is_water(self) -> bool:
        return self.buoyancy_fraction > 0.0 or self.drag_n_s2_per_m2 > 0.0

    @property
    def max_climb_slope_deg(self) -> float:
        """Steepest slope the wheels can climb at steady speed: tan(a) = mu_peak - c_rr.

        On a slope a, with W' the weight the water leaves (W (1 - buoyancy)), the wheels need
        W' sin(a) + c_rr W' cos(a) of traction and have mu_peak W' cos(a); W' cancels, so water
        changes the limit only through the coefficients. No traction (deep water): 0.
        """
        if self.buoyancy_fraction >= 1.0:
            return 0.0
        grip = self.mu_peak - self.rolling_resistance
        return math.degrees(math.atan(grip)) if grip > 0 else 0.0

    def coefficients(self) -> dict[str, float]:
        return {name: float(getattr(self, name)) for name in COEFFICIENTS}


@dataclass(frozen=True)
class TerrainTable:
    """Coefficients as columns over an ordered set of modes, for gathering by an int class array."""

    names: tuple[str, ...]
    columns: dict[str, np.ndarray]

    def gather(self, classes: np.ndarray) -> dict[str, np.ndarray]:
        """Per-robot coefficient arrays for robots standing on `classes` (int indices into names)."""
        idx = np.asarray(classes, dtype=np.intp)
        return {name: col[idx] for name, col in self.columns.items()}

    def index(self, name: str) -> int:
        return self.names.index(name)


#: The default jet holds this multiple of the swim speed against deep-water drag.
JET_SPEED_MARGIN = 1.5
#: A robot's jet works above this submersion (its cell's buoyancy fraction): its intake is under
#: water. The simulator's controller turns the jet on there, and the plan's surf speeds assume it.
JET_SUBMERSION = 0.3
#: A robot's wheels find traction below this submersion: where it comes ashore. The simulator
#: starts its beach phase there, and the plan counts the breakers beyond it as the beach's.
GROUND_SUBMERSION = 0.3


class UnknownModeError(InputError, KeyError):
    """A mode name the library does not have: an input error, and a KeyError for Mapping.get."""

    __str__ = InputError.__str__


class TerrainLibrary(Mapping[str, TerrainMode]):
    """Named terrain modes; the bundled defaults plus whatever a user's YAML overrides or adds."""

    def __init__(self, modes: Iterable[TerrainMode]) -> None:
        self._modes = {m.name: m for m in modes}

    def __getitem__(self, name: str) -> TerrainMode:
        try:
            return self._modes[name]
        except KeyError:
            raise UnknownModeError("terrain library", "mode", name, f"one of {sorted(self._modes)}") from None

    def __contains__(self, name: object) -> bool:
        return name in self._modes

    def __iter__(self):
        return iter(self._modes)

    def __len__(self) -> int:
        return len(self._modes)

    def table(self, names: Sequence[str] | None = None) -> TerrainTable:
        """Columns for `names` in that order (all modes, in library order, when None)."""
        order = tuple(names) if names is not None else tuple(self._modes)
        modes = [self[n] for n in order]
        cols = {c: np.array([getattr(m, c) for m in modes], dtype=np.float64) for c in COEFFICIENTS}
        return TerrainTable(order, cols)

    def default_jet_thrust_n(self, swim_speed_mps: float) -> float:
        """Thrust that holds `JET_SPEED_MARGIN` x the swim speed against the hull's deep-water drag:
        margin for currents and surges (the mission schema's default for `robot.jet_thrust_n`)."""
        return float(self["deep_water"].drag_n_s2_per_m2 * (JET_SPEED_MARGIN * swim_speed_mps) ** 2)

    def merged(self, other: TerrainLibrary) -> TerrainLibrary:
        """This library with `other`'s modes replacing or adding to it."""
        return TerrainLibrary([*(m for n, m in self._modes.items() if n not in other), *other.values()])

    def to_yaml_dict(self) -> dict:
        return {"modes": {name: mode_to_dict(mode) for name, mode in self._modes.items()}}


def mode_to_dict(mode: TerrainMode) -> dict:
    out: dict[str, object] = {}
    if mode.description:
        out["description"] = mode.description
    if not mode.passable:
        out["passable"] = False
    out.update({k: round(v, 6) for k, v in mode.coefficients().items()})
    for model, params in mode.model_params.items():
        out[model] = {k: round(float(v), 6) for k, v in params.items()}
    if mode.uncertainty:
        out["uncertainty"] = {k: round(float(v), 6) for k, v in mode.uncertainty.items()}
    if mode.sources:
        out["sources"] = dict(mode.sources)
    return out


#: Parameters of the thesis models that calibration can fit per terrain mode.
MODEL_PARAMS: dict[str, tuple[str, ...]] = {
    "kinematic": ("heading_scale", "alpha", "chi"),
    "lagrangian": ("robot_inertia_scale", "wheel_inertia_scale"),
    # robot values a `skid` fit found because the robot file did not state them
    "skid": ("com_x_m", "com_y_m"),
}


def _within(words: str, inside: Callable[[float], bool]) -> Any:
    """A finite float that `inside` admits; anything else is an error expecting `words`."""

    def check(value: float) -> float:
        if not inside(value):
            raise expected(words)
        return value

    return Annotated[float, AfterValidator(check)]


def _optional_keys(name: str, types: Mapping[str, Any]) -> type[InputModel]:
    """A model whose keys are all optional. A key given as null is refused (pydantic validates a
    given value, never the default); `model_fields_set` tells which keys the file gave."""
    return create_model(name, __base__=InputModel, **{k: (t, None) for k, t in types.items()})


_POSITIVE = _within("a number in (0, 1000)", lambda v: 0 < v < 1e3)
_OFFSET = _within("an offset in metres, within +-10", lambda v: abs(v) < 10)
#: A mode as a file writes it: every key optional, since a mode inherits what it leaves out.
ModeSpec = _optional_keys(
    "ModeSpec",
    {
        "description": str,
        "passable": bool,
        "like": Annotated[str, Field(min_length=1, description="The mode the other keys come from.")],
        **{
            name: _within(
                f"a number in [{lo:g}, {hi:g}]: {COEFFICIENTS[name]}", lambda v, lo=lo, hi=hi: lo <= v <= hi
            )
            for name, (lo, hi) in _BOUNDS.items()
        },
        **{
            model: _optional_keys(
                f"{model}_params", dict.fromkeys(keys, _OFFSET if model == "skid" else _POSITIVE)
            )
            for model, keys in MODEL_PARAMS.items()
        },
        "uncertainty": _optional_keys("uncertainty", dict.fromkeys(COEFFICIENTS, _POSITIVE)),
        "sources": dict[str, str],
    },
)


class TerrainFile(InputModel):
    """A terrain YAML file (swarm/data/terrain_modes.yaml, a calibrated swarm/data/terrain/*.yaml)."""

    modes: dict[str, ModeSpec]  # type: ignore[valid-type]
    #: what `swarm model calibrate` fitted, and how: a record for people, which nothing reads
    fitted: dict[str, Any] | None = None


def _own(spec: InputModel, key: str, inherited: Any) -> Any:
    """The value the file gave `key`, else the `inherited` one."""
    return getattr(spec, key) if key in spec.model_fields_set else inherited


#: Coefficients a new mode may leave out: the `TerrainMode` defaults (dry land, nominal radius).
_DEFAULTED = ("turning_resistance_m", "rolling_radius_scale", "buoyancy_fraction", "drag_n_s2_per_m2")


def library_from_dict(data: object, source: str | Path, base: TerrainLibrary | None = None) -> TerrainLibrary:
    """Build modes from `{"modes": {name: {...}}}` (`TerrainFile`).

    A name already in `base` overrides only the keys it gives; a new name takes every coefficient
    from the mode named by its `like:` key (in `base` or earlier in the same file), or must give
    all of them.
    """
    f = validate(TerrainFile, data, source)
    modes: list[TerrainMode] = []
    for name, spec in f.modes.items():
        where = f"modes.{name}"
        parent: TerrainMode | None = None
        if spec.like is not None:
            # a mode defined earlier in this file, else one of the base library
            known = {**(dict(base) if base is not None else {}), **{m.name: m for m in modes}}
            if spec.like not in known:
                raise InputError(source, f"{where}.like", spec.like, f"a known terrain mode {sorted(known)}")
            parent = known[spec.like]
        elif base is not None and name in base:
            parent = base[name]
        values: dict[str, float] = {}
        for coef in COEFFICIENTS:
            if coef in spec.model_fields_set or parent is not None:
                values[coef] = float(_own(spec, coef, getattr(parent, coef, None)))
            elif coef not in _DEFAULTED:
                raise InputError(
                    source, f"{where}.{coef}", "nothing", f"{COEFFICIENTS[coef]} (or 'like: MODE')"
                )
        model_params = {k: dict(v) for k, v in (parent.model_params.items() if parent else [])}
        for model in MODEL_PARAMS:
            if model in spec.model_fields_set:
                model_params[model] = getattr(spec, model).model_dump(exclude_unset=True)
        modes.append(
            TerrainMode(
                name=name,
                description=_own(spec, "description", parent.description if parent else ""),
                passable=_own(spec, "passable", parent.passable if parent else True),
                sources={**(parent.sources if parent else {}), **(spec.sources or {})},
                model_params=model_params,
                uncertainty={
                    **(parent.uncertainty if parent else {}),
                    **(spec.uncertainty.model_dump(exclude_unset=True) if spec.uncertainty else {}),
                },
                **values,
            )
        )
    return TerrainLibrary(modes)


def default_library() -> TerrainLibrary:
    """The bundled modes with their literature defaults (swarm/data/terrain_modes.yaml)."""
    ref = resources.files("swarm") / "data" / "terrain_modes.yaml"
    return library_from_dict(
        parse_yaml(ref.read_text(), "swarm/data/terrain_modes.yaml"), "swarm/data/terrain_modes.yaml"
    )


def load_library(path: str | Path | None = None) -> TerrainLibrary:
    """Defaults, with a user's terrain YAML (if given) overriding or adding modes."""
    base = default_library()
    if path is None:
        return base
    path = Path(path)
    return base.merged(library_from_dict(read_yaml(path, "terrain YAML file"), path, base))


def with_coefficients(mode: TerrainMode, **coeffs: float) -> TerrainMode:
    """A copy of `mode` with some coefficients replaced (calibration writes these)."""
    unknown = set(coeffs) - set(COEFFICIENTS)
    if unknown:
        raise ValueError(f"unknown coefficients {sorted(unknown)}")
    return replace(mode, **{k: float(v) for k, v in coeffs.items()})
