"""Map files: the YAML + .npz round trip, inline and GeoJSON regions, ESRI ASCII DEMs, errors."""

from __future__ import annotations

import io
import json
import math
from pathlib import Path

import numpy as np
import pytest
import shapely
import yaml
from shapely.geometry import LineString, MultiPolygon, Point, Polygon, box

from swarm.errors import InputError, OutputError
from swarm.world import BeachMap, Region, load_map, save_map
from swarm.world.io import (
    DEM_CLASSES,
    classify_by_elevation,
    export_geojson,
    load_geojson_regions,
    map_from_dem,
    read_esri_ascii,
    regions_from_geojson,
    regions_to_geojson,
)

CLASSES = ("deep_water", "surf", "wet_hard_sand", "soft_sand", "boulder", "vegetation")
ORIGIN = (100.0, -20.0)
CELL = 0.5
ROWS, COLS = 40, 60  # 20 m north-south, 30 m east-west: x 100..130, y -20..0


def regions() -> dict[str, Region]:
    out = [
        Region("launch_1", "launch", Point(101.25, -19.5)),
        Region("landing", "landing_zone", Polygon([(105, -12), (115, -12), (115, -6), (105, -6)])),
        Region(
            "search",
            "search_area",
            Polygon([(110, -10), (128, -10), (128, -1), (110, -1)], [[(118, -6), (120, -6), (120, -4)]]),
            {"priority": 2, "sensor": "magnetometer", "tags": ["a", "b"]},
        ),
        Region("fence", "keep_out", LineString([(100, -3), (112.5, -2.25), (130, -3)])),
        Region(
            "mines",
            "keep_out",
            MultiPolygon([box(121, -15, 123, -13), box(125, -15, 127, -12)]),
            {"source": "survey 2026-03"},
        ),
        Region("rally", "rally", Point(129.0, -0.5)),
    ]
    return {r.name: r for r in out}


def make_map(name: str = "test_beach", with_regions: bool = True, seed: int = 7) -> BeachMap:
    rng = np.random.default_rng(seed)
    terrain = rng.integers(0, len(CLASSES), size=(ROWS, COLS)).astype(np.int8)
    elevation = rng.normal(0.0, 2.0, size=(ROWS, COLS)).astype(np.float32)
    return BeachMap(
        name=name,
        cell_m=CELL,
        origin_m=ORIGIN,
        terrain_classes=CLASSES,
        terrain=terrain,
        elevation_m=elevation,
        regions=regions() if with_regions else {},
    )


def same_regions(a: dict[str, Region], b: dict[str, Region]) -> None:
    assert list(a) == list(b)
    for name in a:
        ra, rb = a[name], b[name]
        assert ra.name == rb.name == name
        assert ra.kind == rb.kind
        assert dict(ra.properties) == dict(rb.properties)
        assert ra.geometry.geom_type == rb.geometry.geom_type
        assert shapely.equals_exact(ra.geometry, rb.geometry, tolerance=0.0), name
        assert ra.geometry.wkb == rb.geometry.wkb, name


def same_map(a: BeachMap, b: BeachMap) -> None:
    assert a.name == b.name
    assert a.cell_m == b.cell_m
    assert tuple(a.origin_m) == tuple(b.origin_m)
    assert a.terrain_classes == b.terrain_classes
    assert b.terrain.dtype == np.int8
    assert b.elevation_m.dtype == np.float32
    assert np.array_equal(a.terrain, b.terrain)
    assert np.array_equal(a.elevation_m, b.elevation_m)
    same_regions(dict(a.regions), dict(b.regions))


# --- round trips ---------------------------------------------------------------------------------


def test_yaml_npz_round_trip_is_exact(tmp_path):
    original = make_map()
    path = tmp_path / "beach.yaml"
    save_map(original, path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["beach.npz", "beach.yaml"]

    doc = yaml.safe_load(path.read_text())
    assert list(doc) == ["name", "cell_m", "origin_m", "terrain_classes", "grid", "regions"]
    assert doc["grid"] == "beach.npz"  # relative to the YAML
    assert doc["origin_m"] == list(ORIGIN)
    assert doc["regions"]["launch_1"] == {"kind": "launch", "point": [101.25, -19.5]}
    assert doc["regions"]["fence"]["line"] == [[100.0, -3.0], [112.5, -2.25], [130.0, -3.0]]
    assert doc["regions"]["search"]["holes"] == [[[118.0, -6.0], [120.0, -6.0], [120.0, -4.0]]]
    assert doc["regions"]["mines"]["geometry"]["type"] == "MultiPolygon"
    with np.load(tmp_path / "beach.npz") as npz:
        assert sorted(npz.files) == ["elevation_m", "terrain"]
        assert npz["terrain"].dtype == np.int8
        assert npz["elevation_m"].dtype == np.float32
        assert npz["terrain"].shape == (ROWS, COLS)

    loaded = load_map(path)
    same_map(original, loaded)
    # and again: what was loaded saves to the same bytes
    save_map(loaded, tmp_path / "again.yaml")
    assert (tmp_path / "again.yaml").read_text().replace("again.npz", "beach.npz") == path.read_text()
    same_map(original, load_map(tmp_path / "again.yaml"))


def test_map_in_another_folder_finds_its_grid(tmp_path, monkeypatch):
    (tmp_path / "maps").mkdir()
    save_map(make_map(), tmp_path / "maps" / "b.yaml")
    monkeypatch.chdir(tmp_path)
    same_map(make_map(), load_map("maps/b.yaml"))


def test_hand_written_inline_regions(tmp_path):
    save_map(make_map(with_regions=False), tmp_path / "m.yaml")
    text = (tmp_path / "m.yaml").read_text().replace("regions: {}\n", "")
    text += """regions:
  launch_1: {kind: launch, point: [101, -19]}
  landing:
    kind: landing_zone
    polygon: [[105, -12], [115, -12], [115, -6], [105, -6]]
    holes: [[[108, -10], [110, -10], [110, -8], [108, -8]]]
    properties: {priority: 1, note: dry sand}
  fence: {kind: keep_out, line: [[100, -3], [130, -3]]}
  pair:
    kind: observation_point
    geometry: {type: MultiPoint, coordinates: [[102, -2], [104, -2]]}
"""
    (tmp_path / "m.yaml").write_text(text)
    got = load_map(tmp_path / "m.yaml").regions
    assert list(got) == ["launch_1", "landing", "fence", "pair"]
    assert got["launch_1"].geometry.equals(Point(101, -19))
    assert got["landing"].kind == "landing_zone"
    assert got["landing"].geometry.area == pytest.approx(10 * 6 - 2 * 2)
    assert dict(got["landing"].properties) == {"priority": 1, "note": "dry sand"}
    assert got["fence"].geometry.length == pytest.approx(30.0)
    assert got["pair"].geometry.geom_type == "MultiPoint"
    assert len(got["pair"].geometry.geoms) == 2


def test_geojson_round_trip_of_regions(tmp_path):
    beach = make_map()
    fc = regions_to_geojson(beach)
    assert fc["type"] == "FeatureCollection"
    assert "crs" not in fc  # map metres, not WGS84: no CRS is claimed
    assert [f["properties"]["name"] for f in fc["features"]] == list(beach.regions)
    search = next(f for f in fc["features"] if f["properties"]["name"] == "search")
    assert search["properties"] == {
        "name": "search",
        "kind": "search_area",
        "priority": 2,
        "sensor": "magnetometer",
        "tags": ["a", "b"],
    }
    assert search["geometry"]["type"] == "Polygon"
    # through JSON text and back
    same_regions(dict(beach.regions), regions_from_geojson(json.loads(json.dumps(fc)), "mem"))
    export_geojson(beach, tmp_path / "r.geojson")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.geojson"]
    same_regions(dict(beach.regions), load_geojson_regions(tmp_path / "r.geojson", beach.bounds_m))


def test_map_with_regions_in_a_geojson_file(tmp_path):
    original = make_map()
    save_map(original, tmp_path / "m.yaml", regions_geojson="m_regions.geojson")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.npz", "m.yaml", "m_regions.geojson"]
    assert yaml.safe_load((tmp_path / "m.yaml").read_text())["regions"] == "m_regions.geojson"
    same_map(original, load_map(tmp_path / "m.yaml"))


def test_hand_written_geojson_file(tmp_path):
    save_map(make_map(with_regions=False), tmp_path / "m.yaml", regions_geojson="r.geojson")
    fc = {
        "type": "FeatureCollection",
        "features": [
            {
                "type": "Feature",
                "geometry": {"type": "Point", "coordinates": [110, -10]},
                "properties": {"name": "beacon_1", "kind": "beacon", "channel": 3},
            },
            {
                "type": "Feature",
                "geometry": {"type": "LineString", "coordinates": [[100, -1], [130, -1]]},
                "properties": {"name": "edge", "kind": "keep_out"},
            },
        ],
    }
    (tmp_path / "r.geojson").write_text(json.dumps(fc))
    got = load_map(tmp_path / "m.yaml").regions
    assert list(got) == ["beacon_1", "edge"]
    assert got["beacon_1"].kind == "beacon"
    assert dict(got["beacon_1"].properties) == {"channel": 3}
    assert got["edge"].geometry.length == pytest.approx(30.0)


# --- grid geometry ---------------------------------------------------------------------------------


def test_slope_of_a_plane_everywhere(tmp_path):
    beach = make_map(with_regions=False)
    rows, cols = np.mgrid[0:ROWS, 0:COLS]
    x, y = beach.center_of(rows, cols)
    plane = (0.1 * x + 0.05 * y).astype(np.float32)
    tilted = BeachMap("plane", CELL, ORIGIN, CLASSES, beach.terrain, plane)
    save_map(tilted, tmp_path / "plane.yaml")
    loaded = load_map(tmp_path / "plane.yaml")
    expected = math.degrees(math.atan(math.hypot(0.1, 0.05)))
    for m in (tilted, loaded):
        assert m.slope_deg.shape == (ROWS, COLS)
        np.testing.assert_allclose(m.slope_deg, expected, atol=2e-4)
        d_dx, d_dy = m.gradient
        np.testing.assert_allclose(d_dx, 0.1, atol=5e-5)
        np.testing.assert_allclose(d_dy, 0.05, atol=5e-5)


def test_cell_lookup_round_trip():
    beach = make_map(with_regions=False)
    rows, cols = np.mgrid[0:ROWS, 0:COLS]
    x, y = beach.center_of(rows, cols)
    assert x[0, 0] == ORIGIN[0] + CELL / 2 and y[0, 0] == ORIGIN[1] + CELL / 2  # row 0 is south
    assert y[-1, 0] == ORIGIN[1] + (ROWS - 0.5) * CELL
    r, c = beach.cell_of(x, y)
    assert np.array_equal(r, rows) and np.array_equal(c, cols)
    assert np.array_equal(beach.terrain_at(x, y), beach.terrain)
    assert np.array_equal(beach.elevation_at(x, y), beach.elevation_m)
    # a cell owns its south-west corner; its north-east corner belongs to the next cell
    r, c = beach.cell_of(ORIGIN[0] + 3 * CELL, ORIGIN[1] + 5 * CELL)
    assert (int(r), int(c)) == (5, 3)
    r, c = beach.cell_of(ORIGIN[0] + 3 * CELL - 1e-9, ORIGIN[1] + 5 * CELL - 1e-9)
    assert (int(r), int(c)) == (4, 2)
    # outside: clipped to the edge cells, and `contains` says so
    r, c = beach.cell_of(np.array([0.0, 1e6]), np.array([-1e6, 1e6]))
    assert r.tolist() == [0, ROWS - 1] and c.tolist() == [0, COLS - 1]
    assert beach.contains(np.array([100.0, 130.0, 129.99]), np.array([-20.0, -10.0, -0.01])).tolist() == [
        True,
        False,
        True,
    ]


# --- ESRI ASCII grids --------------------------------------------------------------------------------

ASC_CORNER = """ncols 4
nrows 3
xllcorner 500.0
yllcorner 1000.0
cellsize 2.0
NODATA_value -9999
1 2 3 4
5 6 7 8
9 10 11 12
"""

ASC_CENTER = """NCOLS         4
NROWS         3
XLLCENTER     501.0
YLLCENTER     1001.0
CELLSIZE      2
1 2 3 4 5 6
7 8
9 10 11 12
"""

SOUTH_FIRST = np.array([[9, 10, 11, 12], [5, 6, 7, 8], [1, 2, 3, 4]], dtype=np.float32)


@pytest.mark.parametrize("text", [ASC_CORNER, ASC_CENTER], ids=["corner", "center"])
def test_esri_ascii_rows_are_flipped_to_south_first(tmp_path, text):
    path = tmp_path / "dem.asc"
    path.write_text(text)
    elevation, cell_m, origin = read_esri_ascii(path)
    assert elevation.dtype == np.float32
    assert np.array_equal(elevation, SOUTH_FIRST)  # the file's last row is the southern one
    assert cell_m == 2.0
    assert origin == (500.0, 1000.0)  # the grid's south-west corner, whichever header


def test_esri_ascii_nodata(tmp_path):
    path = tmp_path / "dem.asc"
    path.write_text(ASC_CORNER.replace("1 2 3 4", "1 -9999 3 4"))
    with pytest.raises(InputError) as err:
        read_esri_ascii(path)
    assert err.value.source == str(path)
    assert err.value.where == "NODATA_value"
    assert "1 cells" in str(err.value)
    elevation, _, _ = read_esri_ascii(path, fill=-0.5)
    expected = SOUTH_FIRST.copy()
    expected[2, 1] = -0.5  # northern row, second column
    assert np.array_equal(elevation, expected)
    assert not np.isnan(elevation).any()


def test_esri_ascii_without_a_nodata_line_takes_the_format_s_default(tmp_path):
    """-9999 is the format's NODATA value when the header names none: a gap, not a 10 km pit."""
    path = tmp_path / "dem.asc"
    path.write_text(ASC_CORNER.replace("NODATA_value -9999\n", "").replace("1 2 3 4", "1 -9999 3 4"))
    with pytest.raises(InputError) as err:
        read_esri_ascii(path)
    assert err.value.where == "NODATA_value" and "1 cells" in str(err.value)
    elevation, _, _ = read_esri_ascii(path, fill=-0.5)
    assert elevation[2, 1] == np.float32(-0.5)


@pytest.mark.parametrize(
    ("text", "where"),
    [
        (ASC_CORNER.replace("cellsize 2.0\n", ""), "cellsize"),
        (ASC_CORNER.replace("cellsize 2.0", "cellsize -2"), "cellsize"),
        (ASC_CORNER.replace("nrows 3", "nrows 2.5"), "nrows"),
        (ASC_CORNER.replace("xllcorner 500.0\n", ""), "xllcorner"),
        (ASC_CORNER.replace("yllcorner 1000.0", "yllcorner 1000.0\nyllcenter 1001"), "yllcorner"),
        (ASC_CORNER.replace("9 10 11 12", "9 10 11"), "(data)"),
        (ASC_CORNER.replace("5 6 7 8", "5 6 x 8"), "line 8"),
        (ASC_CORNER.replace("cellsize 2.0", "cellsize 2.0\nbogus 3"), "line 6"),
        ("ncols 1\nnrows 1\nxllcorner 0\nyllcorner 0\ncellsize 1\n3\n", "ncols"),
        ("ncols 3\nnrows 1\nxllcorner 0\nyllcorner 0\ncellsize 1\n3 4 5\n", "nrows"),
    ],
    ids=[
        "no-cellsize",
        "negative-cell",
        "fractional-rows",
        "no-x",
        "both-y",
        "short",
        "token",
        "key",
        "one-cell",
        "one-row",
    ],
)
def test_esri_ascii_errors_name_file_and_key(tmp_path, text, where):
    path = tmp_path / "dem.asc"
    path.write_text(text)
    with pytest.raises(InputError) as err:
        read_esri_ascii(path)
    assert err.value.source == str(path)
    assert err.value.where == where
    assert "\n" not in str(err.value)


def test_map_from_dem_classifies_by_elevation(tmp_path):
    z_north_first = [[4.0, 2.0, 0.5], [-0.1, -1.0, -3.0]]
    path = tmp_path / "dem.asc"
    path.write_text(
        "ncols 3\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 5\n"
        + "\n".join(" ".join(str(v) for v in row) for row in z_north_first)
        + "\n"
    )
    beach = map_from_dem(path, "from_dem")
    assert beach.terrain_classes == DEM_CLASSES
    names = [[beach.terrain_classes[i] for i in row] for row in beach.terrain]
    assert names == [
        ["shallow_water", "surf", "deep_water"],  # south row: the file's last
        ["vegetation", "soft_sand", "wet_hard_sand"],
    ]
    assert beach.cell_m == 5.0 and beach.shape == (2, 3)
    assert beach.elevation_m[0, 2] == np.float32(-3.0)
    save_map(beach, tmp_path / "from_dem.yaml")
    same_map(beach, load_map(tmp_path / "from_dem.yaml"))
    # thresholds are the documented boundaries, lower edge inclusive
    classes, idx = classify_by_elevation(np.array([-2.0, -0.3, 0.0, 1.5, 3.0]), runup_m=1.5, dune_m=3.0)
    assert [classes[i] for i in idx] == ["surf", "shallow_water", "wet_hard_sand", "soft_sand", "vegetation"]


# --- bad map files ------------------------------------------------------------------------------------


def _edit_yaml(path: Path, edit) -> None:
    doc = yaml.safe_load(path.read_text())
    edit(doc)
    path.write_text(yaml.safe_dump(doc, sort_keys=False))


def _set(key, value):
    return lambda d: d.__setitem__(key, value)


def _set_region(name, spec):
    return lambda d: d["regions"].__setitem__(name, spec)


BOWTIE = [[105, -12], [115, -6], [115, -12], [105, -6]]
YAML_CASES = {
    "missing-key": (lambda d: d.pop("cell_m"), "cell_m", "nothing"),
    "unknown-key": (_set("colour", "red"), "colour", "no such key (known keys: name, cell_m, origin_m"),
    "name-type": (_set("name", 12), "name", "12"),
    "negative-cell": (_set("cell_m", -0.5), "cell_m", "-0.5"),
    "cell-text": (_set("cell_m", "1 m"), "cell_m", "'1 m'"),
    "origin": (_set("origin_m", [0.0]), "origin_m", "[0.0]"),
    "unknown-class": (lambda d: d["terrain_classes"].__setitem__(1, "lava"), "terrain_classes[1]", "lava"),
    "duplicate-class": (
        lambda d: d["terrain_classes"].__setitem__(1, "deep_water"),
        "terrain_classes[1]",
        "once",
    ),
    "classes-type": (_set("terrain_classes", "sand"), "terrain_classes", "sand"),
    "grid-missing": (_set("grid", "nowhere.npz"), "grid", "nowhere.npz"),
    "region-kind": (
        _set_region("landing", {"kind": "parking", "point": [110, -10]}),
        "regions.landing.kind",
        "parking",
    ),
    "region-no-kind": (_set_region("landing", {"point": [110, -10]}), "regions.landing.kind", "nothing"),
    "region-bowtie": (
        _set_region("landing", {"kind": "landing_zone", "polygon": BOWTIE}),
        "regions.landing.polygon",
        "Self-intersection",
    ),
    "region-outside": (
        _set_region("landing", {"kind": "landing_zone", "polygon": [[125, -5], [135, -5], [135, 5]]}),
        "regions.landing.polygon",
        "inside the map bounds",
    ),
    "point-outside": (_set_region("r", {"kind": "rally", "point": [99.9, -10]}), "regions.r.point", "99.9"),
    "point-arity": (_set_region("r", {"kind": "rally", "point": [110, -10, 3]}), "regions.r.point", "3"),
    "two-geometries": (
        _set_region("r", {"kind": "rally", "point": [110, -10], "line": [[101, -1], [102, -1]]}),
        "regions.r",
        "exactly one",
    ),
    "short-line": (_set_region("r", {"kind": "rally", "line": [[101, -1]]}), "regions.r.line", "at least 2"),
    "bad-geometry": (
        _set_region("r", {"kind": "rally", "geometry": {"type": "Blob", "coordinates": []}}),
        "regions.r.geometry",
        "Blob",
    ),
    "region-key": (
        _set_region("r", {"kind": "rally", "point": [110, -10], "color": 1}),
        "regions.r.color",
        "color",
    ),
    "properties-clash": (
        _set_region("r", {"kind": "rally", "point": [110, -10], "properties": {"kind": "x"}}),
        "regions.r.properties.kind",
        "kind",
    ),
    "regions-list": (_set("regions", [1, 2]), "regions", "[1, 2]"),
}


@pytest.mark.parametrize("case", list(YAML_CASES))
def test_bad_map_yaml_names_file_and_key(tmp_path, case):
    edit, where, found = YAML_CASES[case]
    path = tmp_path / "m.yaml"
    save_map(make_map(), path)
    _edit_yaml(path, edit)
    with pytest.raises(InputError) as err:
        load_map(path)
    assert err.value.source == str(path)
    assert err.value.where == where
    message = str(err.value)
    assert found in message
    assert message.startswith(f"{path}: {where}: ")
    assert "\n" not in message


def test_unparsable_yaml_names_the_line(tmp_path):
    path = tmp_path / "m.yaml"
    path.write_text("name: x\ncell_m: [1\norigin_m: 3\n")
    with pytest.raises(InputError) as err:
        load_map(path)
    assert err.value.source == str(path)
    assert err.value.where.startswith("line ")


def test_missing_map_file(tmp_path):
    with pytest.raises(InputError) as err:
        load_map(tmp_path / "none.yaml")
    assert err.value.source == str(tmp_path / "none.yaml")
    assert err.value.where == "(file)"


def test_terrain_classes_come_from_the_library_given(tmp_path):
    from swarm.robot.terrain import TerrainLibrary, load_library

    path = tmp_path / "m.yaml"
    save_map(make_map(), path)
    lib = load_library()
    small = TerrainLibrary([lib[c] for c in CLASSES if c != "boulder"])
    with pytest.raises(InputError) as err:
        load_map(path, small)
    assert err.value.where == f"terrain_classes[{CLASSES.index('boulder')}]"
    assert load_map(path, lib).terrain_classes == CLASSES


def _npz(**arrays):
    def write(path: Path) -> None:
        with open(path, "wb") as fh:
            np.savez(fh, **arrays)

    return write


GOOD_T = np.zeros((ROWS, COLS), np.int8)
GOOD_Z = np.zeros((ROWS, COLS), np.float32)
NAN_Z = GOOD_Z.copy()
NAN_Z[3, 4] = np.nan
SKY_Z = GOOD_Z.copy()
SKY_Z[1, 2] = 3e38  # once accepted: every slope 90 degrees
HIGH_T = GOOD_T.copy()
HIGH_T[2, 5] = len(CLASSES)
NPZ_CASES = {
    "missing-array": (_npz(terrain=GOOD_T, elevation=GOOD_Z), "elevation_m", "elevation"),
    "extra-array": (_npz(terrain=GOOD_T, elevation_m=GOOD_Z, slope=GOOD_Z), "slope", "slope"),
    "terrain-dtype": (_npz(terrain=GOOD_T.astype(np.int32), elevation_m=GOOD_Z), "terrain", "int32"),
    "elevation-dtype": (
        _npz(terrain=GOOD_T, elevation_m=GOOD_Z.astype(np.float64)),
        "elevation_m",
        "float64",
    ),
    "shapes": (_npz(terrain=GOOD_T, elevation_m=GOOD_Z[:-1]), "elevation_m", "(39, 60)"),
    "one-d": (_npz(terrain=GOOD_T.ravel(), elevation_m=GOOD_Z.ravel()), "terrain", "(2400,)"),
    "nan": (_npz(terrain=GOOD_T, elevation_m=NAN_Z), "elevation_m[3, 4]", "non-finite"),
    "off-earth": (_npz(terrain=GOOD_T, elevation_m=SKY_Z), "elevation_m[1, 2]", "within +-12000 m"),
    "class-index": (_npz(terrain=HIGH_T, elevation_m=GOOD_Z), "terrain[2, 5]", "6"),
    "negative-index": (_npz(terrain=-GOOD_T - 1, elevation_m=GOOD_Z), "terrain[0, 0]", "-1"),
}


@pytest.mark.parametrize("case", list(NPZ_CASES))
def test_bad_grid_names_npz_and_array(tmp_path, case):
    write, where, found = NPZ_CASES[case]
    path = tmp_path / "m.yaml"
    save_map(make_map(), path)
    write(tmp_path / "m.npz")
    with pytest.raises(InputError) as err:
        load_map(path)
    assert err.value.source == str(tmp_path / "m.npz")
    assert err.value.where == where
    assert found in str(err.value)
    assert "\n" not in str(err.value)


def _damaged(good: bytes) -> bytes:
    """The archive whole, its first member's compressed bytes overwritten (a bad sector)."""
    start = good.index(b"PK\x03\x04") + 200
    return good[:start] + bytes(64) + good[start + 64 :]


def _npy(_good: bytes) -> bytes:
    buf = io.BytesIO()
    np.save(buf, GOOD_Z)
    return buf.getvalue()


BROKEN_NPZ = {
    "truncated": (lambda good: good[:3000], "3000 bytes that are not a whole zip archive"),
    "empty": (lambda good: b"", "an empty file"),
    "text": (lambda good: b"not a zip", "9 bytes that are not a whole zip archive"),
    "npy": (_npy, "bytes that are not a whole zip archive"),
    "damaged": (_damaged, "a damaged archive"),
}


@pytest.mark.parametrize("case", sorted(BROKEN_NPZ))
def test_a_truncated_empty_or_foreign_grid_is_one_line_naming_it(tmp_path, case):
    """Issue 15: a truncated grid was a zipfile.BadZipFile traceback."""
    path = tmp_path / "m.yaml"
    save_map(make_map(), path)
    grid = tmp_path / "m.npz"
    corrupt, found = BROKEN_NPZ[case]
    grid.write_bytes(corrupt(grid.read_bytes()))
    with pytest.raises(InputError) as err:
        load_map(path)
    assert err.value.source == str(grid)
    assert err.value.where == "(file)"
    assert found in str(err.value.found)
    assert err.value.expected.startswith("an .npz grid (numpy.savez)")
    assert "\n" not in str(err.value)


def _feature(name, kind, geometry):
    return {"type": "Feature", "geometry": geometry, "properties": {"name": name, "kind": kind}}


POINT = {"type": "Point", "coordinates": [110, -10]}
GEOJSON_CASES = {
    "kind": (
        {"type": "FeatureCollection", "features": [_feature("a", "parking", POINT)]},
        "features[0].properties.kind",
    ),
    "name": (
        {"type": "FeatureCollection", "features": [_feature(None, "rally", POINT)]},
        "features[0].properties.name",
    ),
    "duplicate": (
        {
            "type": "FeatureCollection",
            "features": [_feature("a", "rally", POINT), _feature("a", "rally", POINT)],
        },
        "features[1].properties.name",
    ),
    "outside": (
        {
            "type": "FeatureCollection",
            "features": [_feature("a", "rally", {"type": "Point", "coordinates": [0, 0]})],
        },
        "features[0].geometry (a)",
    ),
    "not-collection": ({"type": "Feature"}, "type"),
    "features": ({"type": "FeatureCollection", "features": {}}, "features"),
}


@pytest.mark.parametrize("case", list(GEOJSON_CASES))
def test_bad_geojson_regions_name_file_and_feature(tmp_path, case):
    data, where = GEOJSON_CASES[case]
    save_map(make_map(), tmp_path / "m.yaml", regions_geojson="r.geojson")
    (tmp_path / "r.geojson").write_text(json.dumps(data))
    with pytest.raises(InputError) as err:
        load_map(tmp_path / "m.yaml")
    assert err.value.source == str(tmp_path / "r.geojson")
    assert err.value.where == where


def test_geojson_that_is_not_json(tmp_path):
    save_map(make_map(), tmp_path / "m.yaml", regions_geojson="r.geojson")
    (tmp_path / "r.geojson").write_text('{"type": "FeatureCollection",\n "features": [}')
    with pytest.raises(InputError) as err:
        load_map(tmp_path / "m.yaml")
    assert err.value.source == str(tmp_path / "r.geojson")
    assert err.value.where == "line 2"


# --- nothing half-written ------------------------------------------------------------------------------


def test_save_checks_everything_before_writing(tmp_path):
    bad = make_map()
    bad = BeachMap(
        bad.name,
        bad.cell_m,
        bad.origin_m,
        bad.terrain_classes,
        bad.terrain,
        bad.elevation_m,
        {**bad.regions, "far": Region("far", "rally", Point(500.0, 500.0))},
    )
    with pytest.raises(InputError) as err:
        save_map(bad, tmp_path / "m.yaml")
    assert err.value.where == "regions.far"
    assert list(tmp_path.iterdir()) == []
    wrong_kind = {"x": Region("x", "parking", Point(110.0, -10.0))}
    with pytest.raises(InputError, match=r"regions\.x\.kind"):
        save_map(
            BeachMap("b", CELL, ORIGIN, CLASSES, bad.terrain, bad.elevation_m, wrong_kind),
            tmp_path / "m.yaml",
        )
    nan_z = bad.elevation_m.copy()
    nan_z[0, 0] = np.nan
    with pytest.raises(InputError, match="elevation_m"):
        save_map(BeachMap("b", CELL, ORIGIN, CLASSES, bad.terrain, nan_z), tmp_path / "m.yaml")
    sky_z = bad.elevation_m.copy()
    sky_z[2, 3] = 3e38  # a map that could not be read back is not written either
    with pytest.raises(
        InputError, match=r"elevation_m\[2, 3\]: found 3\.\d+e\+38, expected an elevation on Earth"
    ):
        save_map(BeachMap("b", CELL, ORIGIN, CLASSES, bad.terrain, sky_z), tmp_path / "m.yaml")
    assert list(tmp_path.iterdir()) == []


def test_failed_save_leaves_the_old_map_and_no_temp_files(tmp_path, monkeypatch):
    path = tmp_path / "m.yaml"
    save_map(make_map(seed=1), path)
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}

    def broken(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(np, "savez_compressed", broken)
    with pytest.raises(OutputError) as err:
        save_map(make_map(seed=2), path)
    assert str(err.value) == (
        f"{tmp_path / 'm.npz'}: could not write it (No space left on device); nothing partial was left"
    )
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before
    same_map(make_map(seed=1), load_map(path))
