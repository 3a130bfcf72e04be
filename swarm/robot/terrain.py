"""Terrain modes: the ground coefficients the `skid` model uses, with where each default comes from.

A terrain mode is what the wheels feel on one surface: peak traction, how much slip builds it
(Janosi-Hanamoto), lateral friction, rolling resistance, effective rolling radius, and in water how
much of the weight the water carries and how hard it drags. The map (issue 3) names a mode per cell,
so the simulator gathers per-robot coefficient arrays from `TerrainTable` by cell class.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path

import numpy as np
import yaml

from swarm.errors import InputError
from swarm.files import read_yaml

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


def _check_positive(source: str | Path, where: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value < 1e3:
        raise InputError(source, where, value, "a number in (0, 1000)")
    return float(value)


def _check_offset(source: str | Path, where: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not abs(value) < 10:
        raise InputError(source, where, value, "an offset in metres, within +-10")
    return float(value)


def _check_value(source: str | Path, where: str, value: object, name: str) -> float:
    lo, hi = _BOUNDS[name]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(source, where, value, f"a number: {COEFFICIENTS[name]}")
    if not lo <= value <= hi:
        raise InputError(source, where, value, f"a number in [{lo}, {hi}]: {COEFFICIENTS[name]}")
    return float(value)


def library_from_dict(data: object, source: str | Path, base: TerrainLibrary | None = None) -> TerrainLibrary:
    """Build modes from `{"modes": {name: {...}}}`.

    A name already in `base` overrides only the keys it gives; a new name takes every coefficient
    from the mode named by its `like:` key (in `base` or earlier in the same file), or must give
    all of them.
    """
    if not isinstance(data, dict) or not isinstance(data.get("modes"), dict):
        raise InputError(
            source,
            "modes",
            data if not isinstance(data, dict) else data.get("modes"),
            "a mapping 'modes:' of terrain-mode names to coefficient mappings",
        )
    extra = set(data) - {"modes", "fitted"}
    if extra:
        raise InputError(source, sorted(extra)[0], sorted(extra)[0], "only the keys 'modes' (and 'fitted')")
    allowed = {*COEFFICIENTS, *MODEL_PARAMS, "description", "passable", "sources", "like", "uncertainty"}
    modes: list[TerrainMode] = []
    for name, spec in data["modes"].items():
        where = f"modes.{name}"
        if not isinstance(spec, dict):
            raise InputError(source, where, spec, "a mapping of coefficients")
        for key in spec:
            if key not in allowed:
                raise InputError(source, f"{where}.{key}", key, f"one of {sorted(allowed)}")
        parent: TerrainMode | None = None
        if "like" in spec:
            # a mode defined earlier in this file, else one of the base library
            known = {**(dict(base) if base is not None else {}), **{m.name: m for m in modes}}
            if not isinstance(spec["like"], str) or spec["like"] not in known:
                raise InputError(
                    source, f"{where}.like", spec["like"], f"a known terrain mode {sorted(known)}"
                )
            parent = known[spec["like"]]
        elif base is not None and name in base:
            parent = base[name]
        values: dict[str, object] = {}
        for coef in COEFFICIENTS:
            if coef in spec:
                values[coef] = _check_value(source, f"{where}.{coef}", spec[coef], coef)
            elif parent is not None:
                values[coef] = getattr(parent, coef)
            elif coef in (
                "turning_resistance_m",
                "rolling_radius_scale",
                "buoyancy_fraction",
                "drag_n_s2_per_m2",
            ):
                continue  # dataclass defaults: dry land, nominal radius
            else:
                raise InputError(
                    source, f"{where}.{coef}", "nothing", f"{COEFFICIENTS[coef]} (or 'like: MODE')"
                )
        sources = dict(parent.sources) if parent is not None else {}
        if "sources" in spec:
            if not isinstance(spec["sources"], dict):
                raise InputError(
                    source, f"{where}.sources", spec["sources"], "a mapping coefficient -> source"
                )
            sources.update({str(k): str(v) for k, v in spec["sources"].items()})
        uncertainty = dict(parent.uncertainty) if parent is not None else {}
        if "uncertainty" in spec:
            given = spec["uncertainty"]
            if not isinstance(given, dict) or any(k not in COEFFICIENTS for k in given):
                raise InputError(
                    source, f"{where}.uncertainty", given, f"a mapping with keys from {list(COEFFICIENTS)}"
                )
            uncertainty.update(
                {k: _check_positive(source, f"{where}.uncertainty.{k}", v) for k, v in given.items()}
            )
        description = str(spec.get("description", parent.description if parent else ""))
        passable = spec.get("passable", parent.passable if parent else True)
        if not isinstance(passable, bool):
            raise InputError(source, f"{where}.passable", passable, "true or false")
        model_params = {k: dict(v) for k, v in (parent.model_params.items() if parent else [])}
        for model, keys in MODEL_PARAMS.items():
            if model not in spec:
                continue
            given = spec[model]
            if not isinstance(given, dict) or any(k not in keys for k in given):
                raise InputError(source, f"{where}.{model}", given, f"a mapping with keys from {list(keys)}")
            check = _check_offset if model == "skid" else _check_positive
            model_params[model] = {k: check(source, f"{where}.{model}.{k}", v) for k, v in given.items()}
        modes.append(
            TerrainMode(
                name=str(name),
                description=description,
                passable=passable,
                sources=sources,
                model_params=model_params,
                uncertainty=uncertainty,
                **values,
            )
        )
    return TerrainLibrary(modes)


def default_library() -> TerrainLibrary:
    """The bundled modes with their literature defaults (swarm/data/terrain_modes.yaml)."""
    ref = resources.files("swarm") / "data" / "terrain_modes.yaml"
    return library_from_dict(yaml.safe_load(ref.read_text()), "swarm/data/terrain_modes.yaml")


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
