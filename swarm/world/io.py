"""Beach-map files: the map YAML with its `.npz` grid, GeoJSON regions, ESRI ASCII DEM import.

The map file, `maps/NAME.yaml`::

    name: demo_beach
    cell_m: 1.0                    # square cells, metres
    origin_m: [0.0, 0.0]           # (x, y) of the south-west corner of cell (row 0, col 0)
    terrain_classes: [deep_water, surf, shallow_water, wet_hard_sand, soft_sand, vegetation]
    grid: demo_beach.npz           # relative to this file
    regions:
      launch_1: {kind: launch, point: [10.0, 2.0]}
      landing_a:
        kind: landing_zone
        polygon: [[20.0, 20.0], [40.0, 20.0], [40.0, 30.0], [20.0, 30.0]]
        properties: {priority: 1}
      fence: {kind: keep_out, line: [[0.0, 35.0], [60.0, 35.0]]}

- `grid` names an `.npz` holding exactly two arrays of one 2-D shape (rows, cols): `terrain`
  (int8, an index into `terrain_classes`) and `elevation_m` (float32, metres above mean sea
  level, finite). Row 0 is the southern edge at `origin_m[1]`, column 0 the western edge at
  `origin_m[0]`; x is east, y north (README: Beach maps).
- Every terrain class names a mode of the terrain library (`swarm.robot.terrain`).
- A region is `kind` (one of `REGION_KINDS`) and exactly one of `point: [x, y]`,
  `line: [[x, y], ...]`, `polygon: [[x, y], ...]` (exterior ring; optional `holes:` list of
  rings) or `geometry:` (any GeoJSON geometry object), plus optional `properties:`. Regions must
  be valid shapes (shapely `is_valid`) inside the map bounds.
- Or `regions: NAME.geojson` (relative to the YAML): a GeoJSON FeatureCollection whose features
  carry `name` and `kind` in their properties; the other properties become the region's.

Coordinates everywhere in the map's files are the map's metres (x east, y north, the same frame as
`origin_m`). A map may say where it lies on the Earth: `crs:` an EPSG code of a projected CRS in
metres (e.g. 32610, UTM zone 10N), and `origin_easting_m:`/`origin_northing_m:` the projected
coordinates of `origin_m` (default: `origin_m` itself, a map drawn in its CRS's own coordinates, as
an imported DEM is). A plan on such a map writes its GeoJSON in WGS84 longitude and latitude
(`swarm.world.crs`); the region GeoJSON written here stays in map metres.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
import shapely
import yaml
from pydantic import Field, PlainValidator, model_validator
from shapely.errors import ShapelyError
from shapely.geometry import LineString, Point, Polygon, box, mapping, shape
from shapely.geometry.base import BaseGeometry
from shapely.validation import explain_validity

from swarm.errors import InputError
from swarm.files import atomic_path, read_json, read_npz, read_text, write_text_atomic
from swarm.inputs import XY, InputModel, expected, load_model
from swarm.robot.terrain import TerrainLibrary, load_library
from swarm.world.beachmap import REGION_KINDS, BeachMap, Region

GRID_ARRAYS = {"terrain": np.dtype(np.int8), "elevation_m": np.dtype(np.float32)}
#: Elevations a map may hold (m): the Earth's surface lies within 11 km of sea level (Mariana
#: Trench -10.9 km, Everest 8.8 km); 3e38 once made every slope 90 degrees.
MAX_ELEVATION_M = 12_000.0
_GEOMETRY_KEYS = ("point", "line", "polygon", "geometry")


class RegionSpec(InputModel):
    """One region of the map YAML: its kind and exactly one geometry (module docstring)."""

    kind: Literal[REGION_KINDS]  # type: ignore[valid-type]
    point: XY | None = None
    line: list[XY] | None = Field(None, min_length=2)
    polygon: list[XY] | None = Field(None, min_length=3, description="The exterior ring.")
    holes: list[Annotated[list[XY], Field(min_length=3)]] | None = None
    geometry: dict[str, Any] | None = Field(None, description="A GeoJSON geometry object.")
    properties: dict[str, Any] | None = None

    @model_validator(mode="after")
    def _one_geometry(self) -> RegionSpec:
        given = [k for k in _GEOMETRY_KEYS if getattr(self, k) is not None]
        if len(given) != 1:
            raise expected("exactly one of point, line, polygon, geometry", found=given or "no geometry")
        if self.holes is not None and given[0] != "polygon":
            raise expected("holes only with 'polygon'", found="holes", key="holes")
        clash = sorted({"name", "kind"} & set(self.properties or {}))
        if clash:
            raise expected(
                "property names other than 'name' and 'kind'", found=clash[0], key=f"properties.{clash[0]}"
            )
        return self

    @property
    def geometry_key(self) -> str:
        return next(k for k in _GEOMETRY_KEYS if getattr(self, k) is not None)


def _epsg(value: object) -> int | None:
    """`crs:` as the EPSG code of a projected CRS in metres (`swarm.world.crs.check_crs`)."""
    from swarm.world.crs import check_crs

    if value is None:
        return None
    try:
        return check_crs("", "crs", value)
    except InputError as exc:
        raise expected(exc.expected, found=exc.found) from None


class MapFile(InputModel):
    """The map YAML as written (module docstring); `load_map` turns it into a `BeachMap`."""

    name: str = Field(min_length=1, description="The map's name.")
    cell_m: float = Field(gt=0, description="Side of a square cell.")
    origin_m: XY = Field(description="(x, y) of the south-west corner of cell (row 0, col 0).")
    terrain_classes: list[str] = Field(min_length=1, max_length=127, description="Terrain-mode names.")
    grid: str = Field(min_length=1, description="The .npz grid file, relative to the map YAML.")
    regions: str | dict[str, RegionSpec] | None = None
    crs: Annotated[int | None, PlainValidator(_epsg)] = Field(
        None, description="EPSG code, projected, metres."
    )
    origin_easting_m: float | None = None
    origin_northing_m: float | None = None

    @model_validator(mode="before")
    @classmethod
    def _regions_kind(cls, data: object) -> object:
        """One message for a `regions:` that is neither form (a union's errors would name one)."""
        if isinstance(data, dict) and not isinstance(data.get("regions"), str | dict | None):
            raise expected(
                "a mapping of region names to regions, or a .geojson file name",
                found=data["regions"],
                key="regions",
            )
        return data

    @model_validator(mode="after")
    def _checks(self) -> MapFile:
        for i, cls in enumerate(self.terrain_classes):
            if self.terrain_classes.index(cls) != i:
                raise expected("each terrain class listed once", found=cls, key=f"terrain_classes[{i}]")
        given = [k for k in ("origin_easting_m", "origin_northing_m") if getattr(self, k) is not None]
        if given and self.crs is None:
            raise expected("a 'crs:' EPSG code beside it", found=getattr(self, given[0]), key=given[0])
        if len(given) == 1:
            other = ({"origin_easting_m", "origin_northing_m"} - set(given)).pop()
            raise expected(f"'{other}:' beside '{given[0]}:'", found="nothing", key=other)
        return self


# --- small checks ---------------------------------------------------------------------------------


def _is_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _xy(source: str | Path, where: str, value: object) -> tuple[float, float]:
    if not isinstance(value, list | tuple) or len(value) != 2 or not all(_is_number(v) for v in value):
        raise InputError(source, where, value, "a pair [x, y] of finite numbers (metres)")
    return float(value[0]), float(value[1])


def _check_properties(source: str | Path, where: str, value: object) -> dict:
    if value is None:
        return {}
    if not isinstance(value, Mapping) or not all(isinstance(k, str) for k in value):
        raise InputError(source, where, value, "a mapping with string keys")
    clash = sorted({"name", "kind"} & set(value))
    if clash:
        raise InputError(
            source, f"{where}.{clash[0]}", clash[0], "property names other than 'name' and 'kind'"
        )
    return dict(value)


def _check_geometry(
    source: str | Path, where: str, geom: BaseGeometry, bounds: tuple[float, float, float, float] | None
) -> BaseGeometry:
    if geom.is_empty:
        raise InputError(source, where, geom.geom_type + " EMPTY", "a non-empty geometry")
    if shapely.has_z(geom):
        raise InputError(source, where, "3-D coordinates", "2-D [x, y] coordinates (metres)")
    if not np.isfinite(shapely.get_coordinates(geom)).all():
        raise InputError(source, where, "non-finite coordinates", "finite [x, y] coordinates (metres)")
    with np.errstate(all="ignore"):  # GEOS on coordinates near the float limit: the bounds refuse them
        valid = geom.is_valid
        reason = None if valid else explain_validity(geom)
    if not valid:
        raise InputError(source, where, reason, "a valid geometry (shapely is_valid)")
    if bounds is not None and not box(*bounds).covers(geom):
        found = "extent (" + ", ".join(f"{b:g}" for b in geom.bounds) + ")"
        expected = "a region inside the map bounds (" + ", ".join(f"{b:g}" for b in bounds) + ")"
        raise InputError(source, where, found, expected)
    return geom


def _check_kind(source: str | Path, where: str, kind: object) -> str:
    if kind not in REGION_KINDS:
        raise InputError(source, where, kind, f"one of {', '.join(REGION_KINDS)}")
    return str(kind)


def _region_from_spec(
    source: str | Path, name: str, spec: RegionSpec, bounds: tuple[float, float, float, float] | None
) -> Region:
    """A region of the map YAML (already validated as a `RegionSpec`) as a shapely shape."""
    key = spec.geometry_key
    at = f"regions.{name}.{key}"
    if key == "point":
        geom: BaseGeometry = Point(spec.point)
    elif key == "line":
        geom = LineString(spec.line)
    elif key == "polygon":
        geom = Polygon(spec.polygon, spec.holes or [])
    else:
        geom = _shape(source, at, spec.geometry)
    _check_geometry(source, at, geom, bounds)
    return Region(name=name, kind=spec.kind, geometry=geom, properties=dict(spec.properties or {}))


def _shape(source: str | Path, where: str, value: object) -> BaseGeometry:
    if not isinstance(value, Mapping) or "type" not in value:
        raise InputError(source, where, value, "a GeoJSON geometry object {type: ..., coordinates: ...}")
    try:
        return shape(value)
    except (ShapelyError, ValueError, TypeError, KeyError, IndexError, AttributeError) as exc:
        raise InputError(source, where, f"{value.get('type')}: {exc}", "a GeoJSON geometry object") from None


# --- GeoJSON ---------------------------------------------------------------------------------------


def regions_to_geojson(beach_map: BeachMap) -> dict:
    """The map's regions as a GeoJSON FeatureCollection (a dict ready for `json.dumps`).

    Coordinates are the map's metres (x east, y north), not WGS84 longitude and latitude; no CRS
    is given. Each feature's properties are `name`, `kind` and the region's own properties.
    """
    features = [
        {
            "type": "Feature",
            "geometry": _plain(mapping(region.geometry)),
            "properties": {"name": region.name, "kind": region.kind, **_plain(dict(region.properties))},
        }
        for region in beach_map.regions.values()
    ]
    return {"type": "FeatureCollection", "name": beach_map.name, "features": features}


def export_geojson(beach_map: BeachMap, path: str | Path) -> None:
    """Write the regions as GeoJSON (map metres, no CRS), atomically."""
    write_text_atomic(path, json.dumps(regions_to_geojson(beach_map), indent=1) + "\n")


def regions_from_geojson(
    data: object, source: str | Path, bounds: tuple[float, float, float, float] | None = None
) -> dict[str, Region]:
    """Regions from a GeoJSON FeatureCollection dict (features with properties `name` and `kind`)."""
    if not isinstance(data, Mapping) or data.get("type") != "FeatureCollection":
        found = data.get("type") if isinstance(data, Mapping) else type(data).__name__
        raise InputError(source, "type", found, "a GeoJSON FeatureCollection")
    features = data.get("features")
    if not isinstance(features, list):
        raise InputError(source, "features", features, "a list of GeoJSON features")
    regions: dict[str, Region] = {}
    for i, feature in enumerate(features):
        where = f"features[{i}]"
        if not isinstance(feature, Mapping) or feature.get("type") != "Feature":
            raise InputError(source, f"{where}.type", feature, "a GeoJSON Feature")
        props = feature.get("properties")
        if not isinstance(props, Mapping):
            raise InputError(source, f"{where}.properties", props, "a mapping with 'name' and 'kind'")
        name = props.get("name")
        if not isinstance(name, str) or not name:
            raise InputError(source, f"{where}.properties.name", name, "a region name (a non-empty string)")
        if name in regions:
            raise InputError(source, f"{where}.properties.name", name, "a name no other feature has")
        kind = _check_kind(source, f"{where}.properties.kind", props.get("kind"))
        geom = _shape(source, f"{where}.geometry", feature.get("geometry"))
        _check_geometry(source, f"{where}.geometry ({name})", geom, bounds)
        rest = {k: v for k, v in props.items() if k not in ("name", "kind")}
        regions[name] = Region(name=name, kind=kind, geometry=geom, properties=rest)
    return regions


def load_geojson_regions(
    path: str | Path, bounds: tuple[float, float, float, float] | None = None
) -> dict[str, Region]:
    """Regions from a GeoJSON file (map metres), checked against `bounds` when given."""
    path = Path(path)
    return regions_from_geojson(read_json(path, "GeoJSON file"), path, bounds)


# --- the map file ----------------------------------------------------------------------------------


#: The fewest rows and columns a grid may have: slopes and gradients need a neighbour each way.
MIN_GRID_CELLS = 2
GRID_EXPECTED = f"a 2-D grid of at least {MIN_GRID_CELLS} x {MIN_GRID_CELLS} cells (rows, cols)"
#: The ESRI ASCII grid's NODATA value when the header has no NODATA_value line.
ESRI_NODATA = -9999.0


def _load_grid(path: Path) -> tuple[np.ndarray, np.ndarray]:
    arrays = read_npz(path, "an .npz grid (numpy.savez) holding arrays 'terrain' and 'elevation_m'")
    names = sorted(arrays)
    for name in GRID_ARRAYS:
        if name not in arrays:
            raise InputError(
                path, name, f"arrays {names}", "arrays 'terrain' (int8) and 'elevation_m' (float32)"
            )
    extra = sorted(set(arrays) - set(GRID_ARRAYS))
    if extra:
        raise InputError(path, extra[0], f"arrays {names}", "only arrays 'terrain' and 'elevation_m'")
    for name, dtype in GRID_ARRAYS.items():
        a = arrays[name]
        if not isinstance(a, np.ndarray):
            raise InputError(path, name, "a member that is not a .npy array", f"a {dtype} array")
        if a.dtype != dtype:
            raise InputError(path, name, f"dtype {a.dtype}", f"dtype {dtype}")
        if a.ndim != 2 or min(a.shape) < MIN_GRID_CELLS:
            raise InputError(path, name, f"shape {a.shape}", GRID_EXPECTED)
    terrain, elevation = arrays["terrain"], arrays["elevation_m"]
    if terrain.shape != elevation.shape:
        raise InputError(
            path, "elevation_m", f"shape {elevation.shape}", f"the shape of 'terrain', {terrain.shape}"
        )
    _check_elevation(path, elevation)
    return terrain, elevation


def _check_elevation(path: str | Path, elevation: np.ndarray) -> None:
    """Finite elevations on Earth (`MAX_ELEVATION_M`), the first bad cell named: read and written
    alike, so no map is written that could not be read back."""
    bad = ~np.isfinite(elevation)
    count = f"{bad.sum()} non-finite values"
    _refuse_cells(path, "elevation_m", bad, lambda r, c: count, "finite elevations (m)")
    far = np.abs(elevation) > MAX_ELEVATION_M
    on_earth = f"an elevation on Earth, within +-{MAX_ELEVATION_M:g} m"
    _refuse_cells(path, "elevation_m", far, lambda r, c: float(elevation[r, c]), on_earth)


def _refuse_cells(
    path: str | Path, name: str, bad: np.ndarray, found: Callable[[int, int], object], expected: str
) -> None:
    """An `InputError` at the first cell of grid `name` that `bad` marks (row-major), if any."""
    if bad.any():
        row, col = (int(i) for i in np.argwhere(bad)[0])
        raise InputError(path, f"{name}[{row}, {col}]", found(row, col), expected)


def load_map(path: str | Path, library: TerrainLibrary | None = None) -> BeachMap:
    """Read and check a map YAML (`MapFile`), its `.npz` grid and its regions (see the module
    docstring). Terrain classes must be modes of `library` (default: `load_library()`, the bundled
    modes)."""
    path = Path(path)
    f = load_model(path, MapFile, "map YAML file")
    library = load_library() if library is None else library
    for i, cls in enumerate(f.terrain_classes):
        if cls not in library:
            raise InputError(path, f"terrain_classes[{i}]", cls, f"a terrain mode, one of {sorted(library)}")

    grid_path = path.parent / f.grid
    if not grid_path.is_file():
        raise InputError(path, "grid", f.grid, "an existing .npz file (relative to the map YAML)")
    terrain, elevation = _load_grid(grid_path)
    n = len(f.terrain_classes)
    bad = (terrain < 0) | (terrain >= n)
    expected = f"a class index in 0..{n - 1} (terrain_classes of {path.name})"
    _refuse_cells(grid_path, "terrain", bad, lambda r, c: int(terrain[r, c]), expected)

    rows, cols = terrain.shape
    x0, y0 = f.origin_m
    bounds = (x0, y0, x0 + cols * f.cell_m, y0 + rows * f.cell_m)
    if not all(math.isfinite(b) for b in bounds):
        raise InputError(
            path, "cell_m", f.cell_m, f"a cell size whose {cols} x {rows} grid has finite bounds"
        )
    if isinstance(f.regions, str):
        regions = load_geojson_regions(path.parent / f.regions, bounds)
    else:
        regions = {
            name: _region_from_spec(path, name, spec, bounds) for name, spec in (f.regions or {}).items()
        }
    crs_origin = None
    if f.crs is not None:
        crs_origin = f.origin_m if f.origin_easting_m is None else (f.origin_easting_m, f.origin_northing_m)
    return BeachMap(
        name=f.name,
        cell_m=f.cell_m,
        origin_m=f.origin_m,
        terrain_classes=tuple(f.terrain_classes),
        terrain=terrain,
        elevation_m=elevation,
        regions=regions,
        crs=f.crs,
        crs_origin_m=crs_origin,
    )


def _plain(value: object) -> object:
    """YAML/JSON-ready copy: numpy scalars and arrays to Python, tuples to lists."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return _plain(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    return value


def _ring(coords) -> list[list[float]]:
    pts = [[float(x), float(y)] for x, y, *_ in coords]
    return pts[:-1] if len(pts) > 1 and pts[0] == pts[-1] else pts


class _MapDumper(yaml.SafeDumper):
    """Block mappings; coordinate lists ([x, y] and [[x, y], ...]) and name lists on one flow line."""


def _represent_list(dumper: yaml.SafeDumper, data: list) -> yaml.Node:
    def scalar(v: object) -> bool:
        return not isinstance(v, list | dict)

    flow = all(scalar(v) or (isinstance(v, list) and all(scalar(w) for w in v)) for v in data)
    return dumper.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=flow)


_MapDumper.add_representer(list, _represent_list)


def _region_to_inline(region: Region) -> dict:
    geom = region.geometry
    out: dict[str, object] = {"kind": region.kind}
    if geom.geom_type == "Point":
        out["point"] = [float(geom.x), float(geom.y)]
    elif geom.geom_type == "LineString":
        out["line"] = [[float(x), float(y)] for x, y, *_ in geom.coords]
    elif geom.geom_type == "Polygon":
        out["polygon"] = _ring(geom.exterior.coords)
        if geom.interiors:
            out["holes"] = [_ring(r.coords) for r in geom.interiors]
    else:
        out["geometry"] = _plain(mapping(geom))
    if region.properties:
        out["properties"] = _plain(dict(region.properties))
    return out


def _check_map_for_saving(beach_map: BeachMap, path: Path) -> tuple[np.ndarray, np.ndarray]:
    if not isinstance(beach_map.name, str) or not beach_map.name.strip():
        raise InputError(path, "name", beach_map.name, "a non-empty string")
    if not _is_number(beach_map.cell_m) or beach_map.cell_m <= 0:
        raise InputError(path, "cell_m", beach_map.cell_m, "a positive number of metres")
    _xy(path, "origin_m", [float(v) for v in beach_map.origin_m])
    if len(beach_map.terrain_classes) > 127 or len(set(beach_map.terrain_classes)) != len(
        beach_map.terrain_classes
    ):
        raise InputError(path, "terrain_classes", beach_map.terrain_classes, "at most 127 distinct names")
    terrain = np.asarray(beach_map.terrain)
    if not np.issubdtype(terrain.dtype, np.integer):
        raise InputError(path, "terrain", f"dtype {terrain.dtype}", "integer class indices")
    elevation = np.asarray(beach_map.elevation_m, dtype=np.float32)
    if terrain.ndim != 2 or min(terrain.shape) < MIN_GRID_CELLS:
        raise InputError(path, "terrain", f"shape {terrain.shape}", GRID_EXPECTED)
    if elevation.ndim == 2:
        _check_elevation(path, elevation)
    for rname, region in beach_map.regions.items():
        where = f"regions.{rname}"
        if rname != region.name:
            raise InputError(path, where, region.name, f"a region whose name is its key, {rname!r}")
        _check_kind(path, f"{where}.kind", region.kind)
        _check_geometry(path, where, region.geometry, beach_map.bounds_m)
        _check_properties(path, f"{where}.properties", dict(region.properties))
    return terrain.astype(np.int8), elevation


def save_map(beach_map: BeachMap, path: str | Path, *, regions_geojson: str | None = None) -> None:
    """Write `path` (the map YAML) and the `.npz` grid beside it (same stem), atomically, YAML last.

    Regions go inline in the YAML, or, with `regions_geojson="NAME.geojson"`, to that GeoJSON file
    beside the YAML (which then refers to it). Everything is checked before anything is written.
    """
    path = Path(path)
    terrain, elevation = _check_map_for_saving(beach_map, path)
    npz_path = path.with_suffix(".npz")
    if npz_path == path:
        raise InputError(path, "(file name)", path.name, "a map YAML name ending in .yaml")
    doc: dict[str, object] = {
        "name": beach_map.name,
        "cell_m": float(beach_map.cell_m),
        "origin_m": [float(v) for v in beach_map.origin_m],
        "terrain_classes": list(beach_map.terrain_classes),
        "grid": npz_path.name,
    }
    if beach_map.crs is not None:
        doc["crs"] = int(beach_map.crs)
        if beach_map.crs_origin_m is not None and tuple(beach_map.crs_origin_m) != tuple(beach_map.origin_m):
            doc["origin_easting_m"] = float(beach_map.crs_origin_m[0])
            doc["origin_northing_m"] = float(beach_map.crs_origin_m[1])
    if regions_geojson is not None:
        if Path(regions_geojson).name != regions_geojson or not regions_geojson.endswith(
            (".geojson", ".json")
        ):
            raise InputError(path, "regions", regions_geojson, "a file name ending in .geojson (no folder)")
        doc["regions"] = regions_geojson
    else:
        doc["regions"] = {name: _region_to_inline(r) for name, r in beach_map.regions.items()}
    header = (
        f"# Beach map '{beach_map.name}': {terrain.shape[1]} x {terrain.shape[0]} cells (cols x rows) of "
        f"{float(beach_map.cell_m):g} m.\n"
        f"# Grid in {npz_path.name}: 'terrain' int8 (index into terrain_classes), 'elevation_m' float32;\n"
        "# row 0 at the southern edge origin_m[1], column 0 at the western edge origin_m[0];\n"
        "# x east, y north, metres.\n"
    )
    text = header + yaml.dump(doc, Dumper=_MapDumper, sort_keys=False, allow_unicode=True, width=100)

    with atomic_path(npz_path) as tmp, open(tmp, "xb") as fh:
        np.savez_compressed(fh, terrain=terrain, elevation_m=elevation)
        fh.flush()
        os.fsync(fh.fileno())
    if regions_geojson is not None:
        export_geojson(beach_map, path.parent / regions_geojson)
    write_text_atomic(path, text)


# --- ESRI ASCII grids (DEMs) -----------------------------------------------------------------------

_ESRI_KEYS = (
    "ncols",
    "nrows",
    "xllcorner",
    "xllcenter",
    "yllcorner",
    "yllcenter",
    "cellsize",
    "nodata_value",
)


def read_esri_ascii(
    path: str | Path, fill: float | None = None
) -> tuple[np.ndarray, float, tuple[float, float]]:
    """Read an ESRI ASCII grid (`.asc`): (elevation float32 with row 0 south, cell_m, origin_m).

    Header keys (any case, any order): `ncols`, `nrows`, `xllcorner` or `xllcenter`, `yllcorner`
    or `yllcenter`, `cellsize`, optional `NODATA_value` (-9999 without one, the format's
    default). The grid has at least 2 x 2 cells. The file lists the northern row first;
    the array returned has row 0 at the south, like a map grid. `origin_m` is the south-west
    corner of the grid (a `*center` header is moved half a cell). NODATA cells become NaN and are
    an error unless `fill` gives the elevation to put there.
    """
    path = Path(path)
    if fill is not None and not (_is_number(fill) and abs(fill) <= MAX_ELEVATION_M):
        raise InputError(
            path, "fill", fill, f"an elevation (m) on Earth for NODATA cells, within +-{MAX_ELEVATION_M:g} m"
        )
    lines = read_text(path, "ESRI ASCII grid").splitlines()
    header: dict[str, tuple[float, int]] = {}
    first_data = len(lines)
    for i, line in enumerate(lines):
        parts = line.split()
        if not parts:
            continue
        if not parts[0][0].isalpha() or parts[0].lower() in ("nan", "inf", "-inf"):
            first_data = i
            break
        key = parts[0].lower()
        if key not in _ESRI_KEYS:
            raise InputError(path, f"line {i + 1}", parts[0], f"a header key, one of {', '.join(_ESRI_KEYS)}")
        if key in header:
            raise InputError(path, f"line {i + 1}", parts[0], "each header key once")
        try:
            (value,) = (float(p) for p in parts[1:])
        except ValueError:
            raise InputError(path, f"line {i + 1}", line.strip(), f"'{parts[0]} NUMBER'") from None
        header[key] = (value, i + 1)

    def get(key: str) -> float:
        return header[key][0]

    for key in ("ncols", "nrows", "cellsize"):
        if key not in header:
            raise InputError(path, key, "nothing", f"a '{key}' header line")
    for axis in ("x", "y"):
        n = sum(f"{axis}ll{k}" in header for k in ("corner", "center"))
        if n != 1:
            found = "nothing" if n == 0 else "both"
            raise InputError(path, f"{axis}llcorner", found, f"one of {axis}llcorner or {axis}llcenter")
    ncols, nrows = get("ncols"), get("nrows")
    for key, n in (("ncols", ncols), ("nrows", nrows)):
        if n != int(n) or n < MIN_GRID_CELLS:
            raise InputError(path, key, n, f"a whole number >= {MIN_GRID_CELLS} (slopes need neighbours)")
    ncols, nrows = int(ncols), int(nrows)
    cell = get("cellsize")
    if not math.isfinite(cell) or cell <= 0:
        raise InputError(path, "cellsize", cell, "a positive number of metres")
    for key in ("xllcorner", "xllcenter", "yllcorner", "yllcenter"):
        if key in header and not math.isfinite(get(key)):
            raise InputError(path, key, get(key), "a finite coordinate (metres)")
    x0 = get("xllcorner") if "xllcorner" in header else get("xllcenter") - cell / 2
    y0 = get("yllcorner") if "yllcorner" in header else get("yllcenter") - cell / 2

    body = lines[first_data:]
    try:
        values = np.array(" ".join(body).split(), dtype=np.float64)
    except ValueError:
        for j, line in enumerate(body):
            for token in line.split():
                try:
                    float(token)
                except ValueError:
                    raise InputError(path, f"line {first_data + j + 1}", token, "a number") from None
        raise  # pragma: no cover - the loop above finds the token
    if values.size != nrows * ncols:
        raise InputError(
            path, "(data)", f"{values.size} values", f"nrows x ncols = {nrows} x {ncols} = {nrows * ncols}"
        )
    nodata = get("nodata_value") if "nodata_value" in header else ESRI_NODATA
    gap = values == nodata
    for bad, want in (
        (~np.isfinite(values), f"a finite elevation (m), or NODATA_value {nodata:g} for a cell without data"),
        (~gap & (np.abs(values) > MAX_ELEVATION_M), f"an elevation on Earth, within +-{MAX_ELEVATION_M:g} m"),
    ):
        if bad.any():
            at = int(np.argmax(bad))
            ends = np.cumsum([len(line.split()) for line in body])
            line = first_data + int(np.searchsorted(ends, at, side="right")) + 1
            raise InputError(path, f"line {line}", float(values[at]), want)
    grid = values.reshape(nrows, ncols)[::-1].copy()  # northern row first in the file
    grid[gap.reshape(nrows, ncols)[::-1]] = np.nan
    missing = np.isnan(grid)
    if missing.any():
        if fill is None:
            raise InputError(
                path,
                "NODATA_value",
                f"{int(missing.sum())} cells without data",
                "a DEM with no gaps, or a fill elevation (e.g. --fill)",
            )
        grid[missing] = fill
    return grid.astype(np.float32), float(cell), (float(x0), float(y0))


#: Classes `classify_by_elevation` assigns, in the map's class order (deepest first).
DEM_CLASSES = ("deep_water", "surf", "shallow_water", "wet_hard_sand", "soft_sand", "vegetation")


def classify_by_elevation(
    elevation_m: np.ndarray,
    *,
    surf_depth_m: float = 2.0,
    shallow_depth_m: float = 0.3,
    runup_m: float = 1.5,
    dune_m: float = 3.0,
) -> tuple[tuple[str, ...], np.ndarray]:
    """A simple terrain classification from elevation z (m above mean sea level) alone:

    ===================================  ==============
    z < -surf_depth_m                    deep_water
    -surf_depth_m <= z < -shallow_depth  surf
    -shallow_depth_m <= z < 0            shallow_water
    0 <= z < runup_m                     wet_hard_sand
    runup_m <= z < dune_m                soft_sand
    z >= dune_m                          vegetation
    ===================================  ==============

    Defaults: waves break in water about 1.3 breaker heights deep (H_b / 0.78), so 2 m of depth
    holds the surf of breakers up to about 1.5 m; 0.3 m is about where the wheels still reach the
    bottom; 1.5 m of run-up and a 3 m dune toe fit a mesotidal sandy beach. Set them from the
    site's tide range and waves (`functools.partial(classify_by_elevation, runup_m=2.2)`).
    Returns (class names, int8 class index per cell).
    """
    if not 0 <= shallow_depth_m <= surf_depth_m or not 0 <= runup_m <= dune_m:
        raise ValueError("need 0 <= shallow_depth_m <= surf_depth_m and 0 <= runup_m <= dune_m")
    edges = np.array([-surf_depth_m, -shallow_depth_m, 0.0, runup_m, dune_m])
    classes = np.searchsorted(edges, np.asarray(elevation_m, dtype=np.float64), side="right")
    return DEM_CLASSES, classes.astype(np.int8)


def map_from_dem(
    asc_path: str | Path,
    name: str,
    classify: Callable[[np.ndarray], tuple[Sequence[str], np.ndarray]] = classify_by_elevation,
    *,
    fill: float | None = None,
    library: TerrainLibrary | None = None,
) -> BeachMap:
    """A `BeachMap` from an ESRI ASCII DEM: elevation from the file, terrain from `classify`
    (default `classify_by_elevation`), no regions. The DEM must be in metres in a projected
    frame (x east, y north), e.g. UTM; `fill` is the elevation given to NODATA cells. A `.prj`
    beside it (same stem, ESRI's WKT) gives the map its `crs`, in whose coordinates it stays."""
    from swarm.world.crs import crs_from_prj

    elevation, cell_m, origin = read_esri_ascii(asc_path, fill=fill)
    prj = Path(asc_path).with_suffix(".prj")
    crs = crs_from_prj(prj) if prj.is_file() else None
    classes, terrain = classify(elevation)
    classes = tuple(classes)
    library = load_library() if library is None else library
    for cls in classes:
        if cls not in library:
            raise InputError(asc_path, "terrain class", cls, f"a terrain mode, one of {sorted(library)}")
    terrain = np.asarray(terrain)
    if terrain.shape != elevation.shape:
        raise ValueError(f"classify returned shape {terrain.shape} for a grid of {elevation.shape}")
    return BeachMap(
        name=name,
        cell_m=cell_m,
        origin_m=origin,
        terrain_classes=classes,
        terrain=terrain.astype(np.int8),
        elevation_m=elevation,
        regions={},
        crs=crs,
        crs_origin_m=None if crs is None else origin,
    )
