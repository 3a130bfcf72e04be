"""The mine field: where the mines lie (drawn from the mission's hazards.mines) and what has
happened to each: detected, marked by a loitering robot, set off, cleared."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from swarm.mission.budget import mine_areas
from swarm.mission.schema import Mission
from swarm.planning import CostMap

#: A robot sets off a mine when the mine lies under its footprint: within this many metres of
#: its centre (about half the skid4 body width; a pressure fuze under a wheel or the hull).
DEFAULT_TRIGGER_RADIUS_M = 0.25


@dataclass
class MineField:
    """Mines (m,) at `positions_m`; the flags change as the simulation runs."""

    positions_m: np.ndarray  # (m, 2) float64
    trigger_probability: float = 0.5
    trigger_radius_m: float = DEFAULT_TRIGGER_RADIUS_M
    detected: np.ndarray = field(default=None)  # type: ignore[assignment]
    marked: np.ndarray = field(default=None)  # type: ignore[assignment]
    exploded: np.ndarray = field(default=None)  # type: ignore[assignment]
    cleared: np.ndarray = field(default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        self.positions_m = np.asarray(self.positions_m, dtype=np.float64).reshape(-1, 2)
        m = len(self.positions_m)
        for name in ("detected", "marked", "exploded", "cleared"):
            if getattr(self, name) is None:
                setattr(self, name, np.zeros(m, dtype=bool))

    def __len__(self) -> int:
        return len(self.positions_m)

    @property
    def active(self) -> np.ndarray:
        """Mines still in the ground: neither set off nor cleared."""
        return ~(self.exploded | self.cleared)


def sample_in(
    polygons: list[BaseGeometry],
    count: int,
    rng: np.random.Generator,
    where: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
) -> np.ndarray:
    """`count` points uniform over the union of `polygons`, and where `where(x, y)` is true when it
    is given (rejection from the bounding box)."""
    if count == 0:
        return np.empty((0, 2))
    area = shapely.union_all(polygons)
    x0, y0, x1, y1 = area.bounds
    shapely.prepare(area)
    out: list[np.ndarray] = []
    have = 0
    while have < count:
        batch = max(64, 2 * (count - have))
        pts = rng.uniform((x0, y0), (x1, y1), size=(batch, 2))
        inside = shapely.contains_xy(area, pts[:, 0], pts[:, 1])
        if where is not None:
            inside &= where(pts[:, 0], pts[:, 1])
        keep = pts[inside]
        out.append(keep)
        have += len(keep)
    return np.vstack(out)[:count]


def lay_mines(mission: Mission, rng: np.random.Generator, ground: CostMap | None = None) -> MineField:
    """Draw the mine field of one run: `count` mines (or `density_per_ha` x area, a Poisson count)
    uniform over the mine areas, and with `ground` only where the ground can be crossed: a mine is
    laid where people and vehicles go, not in a boulder, a driftwood log, a dune face too steep to
    climb or a keep-out zone the mission excludes from the search (the planner's expected detection
    averages over the same ground). No mines without a count, a density or an area."""
    spec = mission.hazards.mines
    areas = mine_areas(mission)
    if not areas or (spec.count is None and spec.density_per_ha is None):
        return MineField(np.empty((0, 2)), spec.trigger_probability)
    if spec.count is not None:
        count = spec.count
    else:
        assert spec.density_per_ha is not None
        hectares = shapely.union_all(areas).area / 1e4
        count = int(rng.poisson(spec.density_per_ha * hectares))
    where = None if ground is None else ground.ground_free
    return MineField(sample_in(areas, count, rng, where), spec.trigger_probability)
