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

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from pydantic import Field, model_validator

from swarm.errors import InputError
from swarm.files import read_yaml
from swarm.inputs import InputModel, expected, validate

#: OMPL geometric planners a profile may name (those the ompl Python bindings provide). Not AORRTC:
#: in ompl 2.0.1 it crashes the interpreter on a beach-sized map and when destroyed before setup
#: (upstream ompl/ompl#1420, fix pending in #1471).
PLANNERS = (
    "RRTConnect",
    "RRT",
    "RRTstar",
    "InformedRRTstar",
    "SORRTstar",
    "BITstar",
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
            out["roadmap"] = dataclasses.asdict(self.roadmap)
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
        if key == "range" and value < 0:  # OMPL takes any number, and reads every one <= 0 as 0
            expected = "metres >= 0 (0: OMPL's default from the map's size)"
            raise InputError(source, "params.range", value, expected)
        try:
            setter(value)
        except (TypeError, ValueError, RuntimeError):  # RuntimeError: OMPL's own range checks
            doc = (setter.__doc__ or "").split("\n")[0]
            raise InputError(source, f"params.{key}", value, f"a value {planner}.{doc} accepts") from None


class _Budget(InputModel):
    iterations: int | None = Field(None, ge=1, description="Planner iterations (reproducible).")
    time_s: float | None = Field(None, ge=0.001, description="Wall-clock cap (not reproducible).")

    @model_validator(mode="after")
    def _some(self) -> _Budget:
        if self.iterations is None and self.time_s is None:
            raise expected("a mapping with 'iterations:' and/or 'time_s:'", found={})
        return self


class _Roadmap(InputModel):
    grow_iterations: int = Field(30000, ge=1)
    expand_iterations: int = Field(10000, ge=0)
    connect_neighbours: int = Field(15, ge=1)


class ProfileFile(InputModel):
    """A planner profile YAML as written (the module docstring); `PlannerProfile` is what it means."""

    name: str | None = Field(None, min_length=1)
    description: str = ""
    planner: Literal[PLANNERS]  # type: ignore[valid-type]
    params: dict[str, Any] | None = None  # values are checked by the planner's setters
    objective: Literal[OBJECTIVES] = "length"  # type: ignore[valid-type]
    budget: _Budget | None = None
    simplify: bool = True
    interpolate_m: float | None = Field(None, ge=0.01)
    roadmap: _Roadmap | None = None

    @model_validator(mode="after")
    def _roadmap_planner(self) -> ProfileFile:
        if self.roadmap is not None and self.planner not in ROADMAP_PLANNERS:
            raise expected(f"planner {' or '.join(ROADMAP_PLANNERS)}", "a roadmap section", "roadmap")
        return self


def profile_from_dict(
    data: object, source: str | Path = "<profile>", name: str | None = None
) -> PlannerProfile:
    """Validate a profile mapping (see the module docstring); errors name the key and what it needs."""
    source = str(source)
    f = validate(ProfileFile, data, source)
    params = dict(f.params or {})
    check_planner_params(f.planner, params, source)
    budget = f.budget or _Budget(iterations=20000)
    roadmap = None if f.roadmap is None else RoadmapSettings(**f.roadmap.model_dump())
    return PlannerProfile(
        name=f.name or (name if name is not None else Path(source).stem),
        description=f.description,
        planner=f.planner,
        params=params,
        objective=f.objective,
        iterations=budget.iterations,
        time_s=budget.time_s,
        simplify=f.simplify,
        interpolate_m=f.interpolate_m,
        roadmap=roadmap,
        source=source,
    )


def load_profile(path: str | Path) -> PlannerProfile:
    """Read a planner profile YAML; bad keys or values raise `InputError` naming file and key."""
    path = Path(path)
    return profile_from_dict(read_yaml(path, "planner profile YAML file"), path, name=path.stem)
