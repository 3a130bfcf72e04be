"""Planner profiles (`planners/*.yaml`): which OMPL planner, its settings, the objective, the budget.

```yaml
description: fast feasible paths for many robots
planner: RRTConnect          # an OMPL geometric planner (PLANNERS)
params:                      # planner settings: each key calls the planner's setter (range -> setRange)
  range: 25.0
objective: length            # length | terrain_cost
budget:
  iterations: 20000          # planner iterations: reproducible (same seed, same path)
  time_s: 2.0                # optional wall-clock cap: stops earlier on a slow machine, not reproducible
simplify: true               # OMPL's PathSimplifier, run to convergence
interpolate_m: 2.0           # resample to at most this spacing (null: keep the planner's vertices)
roadmap:                     # PRM and PRMstar only: one roadmap per map serves every robot
  grow_iterations: 30000     # roadmap samples (reproducible)
  expand_iterations: 10000   # random-bounce expansion steps for narrow passages
  connect_neighbours: 15     # roadmap vertices a start or goal tries to connect to
```

An iteration is one evaluation of the planner's termination condition, which every OMPL planner
makes once per loop iteration; counting them makes a run independent of the machine's speed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from swarm.errors import InputError
from swarm.files import read_yaml

#: OMPL geometric planners a profile may name (those the ompl Python bindings provide).
PLANNERS = (
    "RRTConnect",
    "RRT",
    "RRTstar",
    "InformedRRTstar",
    "SORRTstar",
    "BITstar",
    "AORRTC",
    "FMT",
    "BFMT",
    "KPIECE1",
    "BKPIECE1",
    "LBKPIECE1",
    "PRM",
    "PRMstar",
)
#: Planners that build a roadmap once and answer many queries from it.
ROADMAP_PLANNERS = ("PRM", "PRMstar")
OBJECTIVES = ("length", "terrain_cost")
_KEYS = (
    "name",
    "description",
    "planner",
    "params",
    "objective",
    "budget",
    "simplify",
    "interpolate_m",
    "roadmap",
)
_BUDGET_KEYS = ("iterations", "time_s")
_ROADMAP_KEYS = ("grow_iterations", "expand_iterations", "connect_neighbours")


@dataclass(frozen=True)
class RoadmapSettings:
    grow_iterations: int = 30000
    expand_iterations: int = 10000
    connect_neighbours: int = 15


@dataclass(frozen=True)
class PlannerProfile:
    """How to plan one path: see the module docstring for the YAML form."""

    name: str
    planner: str
    objective: str = "length"
    params: dict[str, float | int | bool] = field(default_factory=dict)
    iterations: int | None = 20000
    time_s: float | None = None
    simplify: bool = True
    interpolate_m: float | None = None
    roadmap: RoadmapSettings | None = None
    description: str = ""
    source: str = "<profile>"

    def __post_init__(self) -> None:
        if self.planner in ROADMAP_PLANNERS and self.roadmap is None:
            object.__setattr__(self, "roadmap", RoadmapSettings())

    @property
    def reproducible(self) -> bool:
        """Same seed, same path: an iteration budget and no wall-clock cap."""
        return self.iterations is not None and self.time_s is None

    @property
    def budget_text(self) -> str:
        parts = []
        if self.iterations is not None:
            parts.append(f"{self.iterations} iterations")
        if self.time_s is not None:
            parts.append(f"{self.time_s:g} s")
        return " or ".join(parts)

    def as_dict(self) -> dict:
        out: dict[str, object] = {"name": self.name}
        if self.description:
            out["description"] = self.description
        out.update(planner=self.planner, params=dict(self.params), objective=self.objective)
        budget: dict[str, object] = {}
        if self.iterations is not None:
            budget["iterations"] = self.iterations
        if self.time_s is not None:
            budget["time_s"] = self.time_s
        out.update(budget=budget, simplify=self.simplify, interpolate_m=self.interpolate_m)
        if self.roadmap is not None:
            out["roadmap"] = {k: getattr(self.roadmap, k) for k in _ROADMAP_KEYS}
        return out


#: The profile `swarm path` uses without --profile: the same as planners/fast.yaml.
DEFAULT_PROFILE = PlannerProfile(
    name="fast",
    description="fast feasible paths for many robots (RRT-Connect, shortcut and smoothed)",
    planner="RRTConnect",
    params={"range": 25.0},
    objective="length",
    iterations=20000,
    simplify=True,
    interpolate_m=2.0,
    source="(built-in default, as planners/fast.yaml)",
)


def _number(source: str, where: str, value: object, lo: float, what: str, *, integer: bool = False) -> float:
    ok = not isinstance(value, bool) and isinstance(value, int if integer else (int, float))
    if not ok or not math.isfinite(value) or value < lo:  # type: ignore[arg-type]
        kind = "a whole number" if integer else "a number"
        raise InputError(source, where, value, f"{what}, {kind} >= {lo:g}")
    return value  # type: ignore[return-value]


def setter_name(param: str) -> str:
    """`samples_per_batch` -> `setSamplesPerBatch`: the OMPL setter a profile parameter calls."""
    return "set" + "".join(p[:1].upper() + p[1:] for p in param.split("_"))


def check_planner_params(planner: str, params: dict, source: str) -> None:
    """Apply `params` to a throwaway planner, so a bad name or value fails when the profile loads."""
    from ompl import base as ob
    from ompl import geometric as og

    space = ob.RealVectorStateSpace(2)
    bounds = ob.RealVectorBounds(2)
    bounds.setLow(0.0)
    bounds.setHigh(1.0)
    space.setBounds(bounds)
    si = ob.SpaceInformation(space)
    instance = getattr(og, planner)(si)
    skip = {
        "setup",
        "setName",
        "setProblemDefinition",
        "setProjectionEvaluator",
        "setDefaultConnectionStrategy",
    }
    known = sorted(
        "".join("_" + c.lower() if c.isupper() else c for c in m[3:]).lstrip("_")
        for m in dir(instance)
        if m.startswith("set") and m not in skip
    )
    for key, value in params.items():
        setter = getattr(instance, setter_name(str(key)), None)
        if setter is None or setter_name(str(key)) in skip:
            raise InputError(source, f"params.{key}", key, f"a {planner} setting, one of {known}")
        if not isinstance(value, (bool, int, float)) or (
            isinstance(value, float) and not math.isfinite(value)
        ):
            raise InputError(source, f"params.{key}", value, "a number or true/false")
        try:
            setter(value)
        except (TypeError, ValueError):
            doc = (setter.__doc__ or "").split("\n")[0]
            raise InputError(source, f"params.{key}", value, f"a value {planner}.{doc} accepts") from None


def profile_from_dict(
    data: object, source: str | Path = "<profile>", name: str | None = None
) -> PlannerProfile:
    """Validate a profile mapping (see the module docstring); errors name the key and what it needs."""
    source = str(source)
    if not isinstance(data, dict):
        raise InputError(
            source, "(top level)", type(data).__name__, "a mapping with 'planner:' and 'objective:'"
        )
    for key in data:
        if key not in _KEYS:
            raise InputError(source, str(key), key, f"one of the keys {', '.join(_KEYS)}")
    planner = data.get("planner")
    if planner not in PLANNERS:
        raise InputError(source, "planner", planner, f"an OMPL planner, one of {', '.join(PLANNERS)}")
    objective = data.get("objective", "length")
    if objective not in OBJECTIVES:
        raise InputError(source, "objective", objective, "length or terrain_cost")
    params = data.get("params") or {}
    if not isinstance(params, dict):
        raise InputError(source, "params", params, "a mapping of planner settings (e.g. range: 25.0)")
    check_planner_params(planner, params, source)

    budget = data.get("budget", {"iterations": 20000})
    if not isinstance(budget, dict) or not budget:
        raise InputError(source, "budget", budget, "a mapping with 'iterations:' and/or 'time_s:'")
    for key in budget:
        if key not in _BUDGET_KEYS:
            raise InputError(source, f"budget.{key}", key, "iterations or time_s")
    iterations = budget.get("iterations")
    if iterations is not None:
        iterations = int(
            _number(source, "budget.iterations", iterations, 1, "planner iterations", integer=True)
        )
    time_s = budget.get("time_s")
    if time_s is not None:
        time_s = float(_number(source, "budget.time_s", time_s, 0.001, "seconds"))

    simplify = data.get("simplify", True)
    if not isinstance(simplify, bool):
        raise InputError(source, "simplify", simplify, "true or false")
    interpolate_m = data.get("interpolate_m")
    if interpolate_m is not None:
        interpolate_m = float(_number(source, "interpolate_m", interpolate_m, 0.01, "waypoint spacing (m)"))

    roadmap = None
    spec = data.get("roadmap")
    if spec is not None:
        if planner not in ROADMAP_PLANNERS:
            raise InputError(
                source, "roadmap", "a roadmap section", f"planner {' or '.join(ROADMAP_PLANNERS)}"
            )
        if not isinstance(spec, dict):
            raise InputError(source, "roadmap", spec, f"a mapping with keys from {', '.join(_ROADMAP_KEYS)}")
        for key in spec:
            if key not in _ROADMAP_KEYS:
                raise InputError(source, f"roadmap.{key}", key, f"one of {', '.join(_ROADMAP_KEYS)}")
        values = {
            k: int(
                _number(
                    source, f"roadmap.{k}", spec[k], 0 if k == "expand_iterations" else 1, k, integer=True
                )
            )
            for k in spec
        }
        roadmap = RoadmapSettings(**values)

    description = data.get("description", "")
    if not isinstance(description, str):
        raise InputError(source, "description", description, "a line of text")
    pname = data.get("name", name if name is not None else Path(source).stem)
    if not isinstance(pname, str) or not pname.strip():
        raise InputError(source, "name", pname, "a non-empty profile name")
    return PlannerProfile(
        name=pname,
        description=description,
        planner=planner,
        params=dict(params),
        objective=objective,
        iterations=iterations,
        time_s=time_s,
        simplify=simplify,
        interpolate_m=interpolate_m,
        roadmap=roadmap,
        source=source,
    )


def load_profile(path: str | Path) -> PlannerProfile:
    """Read a planner profile YAML; bad keys or values raise `InputError` naming file and key."""
    path = Path(path)
    return profile_from_dict(read_yaml(path, "planner profile YAML file"), path, name=path.stem)
