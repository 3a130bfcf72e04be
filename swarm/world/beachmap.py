"""`BeachMap`: a gridded beach (terrain class and elevation per cell) with named shapely regions.

Grid convention (the map file format's): row 0 is the southern edge at `origin_m[1]`, column 0
the western edge at `origin_m[0]`; cell (row, col) covers x in [x0 + col * cell, x0 + (col+1) *
cell) and y likewise. World x is east, y north (README: Beach maps). Every terrain class names a
mode of the terrain library, so the map tells the dynamics which coefficients apply where.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from shapely.geometry.base import BaseGeometry

from swarm.robot.terrain import TerrainLibrary, TerrainTable

#: What a region is for. Planners and missions look regions up by kind.
REGION_KINDS = (
    "launch",
    "landing_zone",
    "search_area",
    "keep_out",
    "rally",
    "observation_point",
    "beacon",
    "relay_source",
    "relay_sink",
)


@dataclass(frozen=True)
class Region:
    """A named area or point on the map (a launch point, a landing zone, a keep-out zone...)."""

    name: str
    kind: str
    geometry: BaseGeometry
    properties: Mapping[str, object] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class BeachMap:
    name: str
    cell_m: float
    origin_m: tuple[float, float]
    terrain_classes: tuple[str, ...]
    terrain: np.ndarray  # int8 (rows, cols), index into terrain_classes
    elevation_m: np.ndarray  # float32 (rows, cols), metres above mean sea level
    regions: Mapping[str, Region] = field(default_factory=dict)
    #: the coordinate reference the map is placed in (an EPSG code of a projected CRS in metres, its
    #: axes east and north, e.g. 32610 for UTM zone 10N), or None: a local frame on no real beach
    crs: int | None = None
    #: the projected coordinates (easting, northing) of the map point `origin_m` (with a `crs`)
    crs_origin_m: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        if self.terrain.shape != self.elevation_m.shape or self.terrain.ndim != 2:
            raise ValueError(
                f"terrain {self.terrain.shape} and elevation {self.elevation_m.shape} must be one 2-D shape"
            )
        if self.terrain.size and (self.terrain.min() < 0 or self.terrain.max() >= len(self.terrain_classes)):
            raise ValueError("terrain holds a class index outside terrain_classes")

    # geometry of the grid ------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int]:
        return self.terrain.shape  # type: ignore[return-value]

    @property
    def width_m(self) -> float:
        """East-west extent."""
        return self.shape[1] * self.cell_m

    @property
    def height_m(self) -> float:
        """North-south extent."""
        return self.shape[0] * self.cell_m

    @property
    def bounds_m(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax), as shapely orders them."""
        x0, y0 = self.origin_m
        return x0, y0, x0 + self.width_m, y0 + self.height_m

    def contains(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        xmin, ymin, xmax, ymax = self.bounds_m
        x, y = np.asarray(x), np.asarray(y)
        return (x >= xmin) & (x < xmax) & (y >= ymin) & (y < ymax)

    def cell_of(self, x: np.ndarray | float, y: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """(row, col) of the cells holding world points, clipped to the grid."""
        col = np.floor((np.asarray(x) - self.origin_m[0]) / self.cell_m).astype(np.intp)
        row = np.floor((np.asarray(y) - self.origin_m[1]) / self.cell_m).astype(np.intp)
        return np.clip(row, 0, self.shape[0] - 1), np.clip(col, 0, self.shape[1] - 1)

    def center_of(self, row: np.ndarray | int, col: np.ndarray | int) -> tuple[np.ndarray, np.ndarray]:
        """World (x, y) of cell centres."""
        x = self.origin_m[0] + (np.asarray(col) + 0.5) * self.cell_m
        y = self.origin_m[1] + (np.asarray(row) + 0.5) * self.cell_m
        return x, y

    # what is where ---------------------------------------------------------------------------
    def terrain_at(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        """Terrain class index under world points (the nearest cell at the map's edge)."""
        row, col = self.cell_of(x, y)
        return self.terrain[row, col]

    def elevation_at(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        row, col = self.cell_of(x, y)
        return self.elevation_m[row, col]

    @cached_property
    def gradient(self) -> tuple[np.ndarray, np.ndarray]:
        """(d elevation / dx, d elevation / dy) per cell, central differences (one-sided at edges)."""
        d_dy, d_dx = np.gradient(self.elevation_m.astype(np.float64), self.cell_m)
        return d_dx, d_dy

    @cached_property
    def slope_deg(self) -> np.ndarray:
        """Steepest slope per cell, degrees."""
        d_dx, d_dy = self.gradient
        return np.degrees(np.arctan(np.hypot(d_dx, d_dy)))

    def terrain_table(self, library: TerrainLibrary) -> TerrainTable:
        """Coefficient columns in this map's class order, so `table.gather(map.terrain_at(x, y))`
        gives per-robot coefficients."""
        return library.table(self.terrain_classes)

    def regions_of_kind(self, kind: str) -> list[Region]:
        return [r for r in self.regions.values() if r.kind == kind]

    def class_index(self, name: str) -> int:
        return self.terrain_classes.index(name)

    # a summary for people and `swarm map info` --------------------------------------------------
    def summary(self, library: TerrainLibrary | None = None) -> dict:
        """JSON-ready facts: size, cell, origin, cells and fraction of each terrain class,
        elevation range, steepest slope, and each region's kind, shape, area, length and position
        (its centroid; the point itself for a point). With `library`, also the fraction of cells
        no robot can cross (modes with `passable: false`)."""
        rows, cols = self.shape
        counts = np.bincount(self.terrain.ravel().astype(np.intp), minlength=len(self.terrain_classes))
        total = max(int(counts.sum()), 1)
        out: dict[str, object] = {
            "name": self.name,
            "rows": rows,
            "cols": cols,
            "cell_m": float(self.cell_m),
            "origin_m": [float(v) for v in self.origin_m],
            "width_m": float(self.width_m),
            "height_m": float(self.height_m),
            "bounds_m": [float(v) for v in self.bounds_m],
            "terrain_classes": list(self.terrain_classes),
            "terrain_cells": {c: int(n) for c, n in zip(self.terrain_classes, counts, strict=True)},
            "terrain_fractions": {
                c: float(n) / total for c, n in zip(self.terrain_classes, counts, strict=True)
            },
        }
        if self.crs is not None:
            origin = self.crs_origin_m if self.crs_origin_m is not None else self.origin_m
            out["crs"] = f"EPSG:{self.crs}"
            out["crs_origin_m"] = [float(v) for v in origin]
        if library is not None:
            blocked = [
                i for i, c in enumerate(self.terrain_classes) if c in library and not library[c].passable
            ]
            out["impassable_fraction"] = float(counts[blocked].sum()) / total
        out["elevation_min_m"] = float(self.elevation_m.min())
        out["elevation_max_m"] = float(self.elevation_m.max())
        out["max_slope_deg"] = float(self.slope_deg.max())
        out["regions"] = [
            {
                "name": r.name,
                "kind": r.kind,
                "geometry": r.geometry.geom_type,
                "area_m2": float(r.geometry.area),
                "length_m": float(r.geometry.length) if r.geometry.geom_type.endswith("LineString") else 0.0,
                "position_m": [float(r.geometry.centroid.x), float(r.geometry.centroid.y)],
            }
            for r in self.regions.values()
        ]
        return out
