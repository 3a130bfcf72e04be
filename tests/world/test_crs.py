"""Maps placed on the Earth: the crs keys, a DEM's .prj, and plan.geojson in WGS84 longitude and
latitude (RFC 7946), checked against an independent UTM inverse (Snyder 1987), not pyproj."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from swarm.cli import main
from swarm.errors import InputError
from swarm.world.io import load_map, map_from_dem, save_map

REPO = Path(__file__).resolve().parents[2]
GENTLE = REPO / "maps" / "gentle_fine.yaml"


def utm_to_lonlat(easting: float, northing: float, zone: int) -> tuple[float, float]:
    """Snyder, Map Projections: A Working Manual (USGS PP 1395, 1987), eqs. 8-18 to 8-25: the
    inverse transverse Mercator on WGS84, northern hemisphere, k0 = 0.9996."""
    a, f, k0 = 6378137.0, 1 / 298.257223563, 0.9996
    e2 = f * (2 - f)
    ep2 = e2 / (1 - e2)
    x, y = easting - 500000.0, northing
    mu = (y / k0) / (a * (1 - e2 / 4 - 3 * e2**2 / 64 - 5 * e2**3 / 256))
    e1 = (1 - math.sqrt(1 - e2)) / (1 + math.sqrt(1 - e2))
    phi1 = (
        mu
        + (3 * e1 / 2 - 27 * e1**3 / 32) * math.sin(2 * mu)
        + (21 * e1**2 / 16 - 55 * e1**4 / 32) * math.sin(4 * mu)
        + (151 * e1**3 / 96) * math.sin(6 * mu)
        + (1097 * e1**4 / 512) * math.sin(8 * mu)
    )
    c1 = ep2 * math.cos(phi1) ** 2
    t1 = math.tan(phi1) ** 2
    n1 = a / math.sqrt(1 - e2 * math.sin(phi1) ** 2)
    r1 = a * (1 - e2) / (1 - e2 * math.sin(phi1) ** 2) ** 1.5
    d = x / (n1 * k0)
    lat = phi1 - (n1 * math.tan(phi1) / r1) * (
        d**2 / 2
        - (5 + 3 * t1 + 10 * c1 - 4 * c1**2 - 9 * ep2) * d**4 / 24
        + (61 + 90 * t1 + 298 * c1 + 45 * t1**2 - 252 * ep2 - 3 * c1**2) * d**6 / 720
    )
    lon0 = math.radians(6 * zone - 183)
    lon = lon0 + (
        d
        - (1 + 2 * t1 + c1) * d**3 / 6
        + (5 - 2 * c1 + 28 * t1 - 3 * c1**2 + 8 * ep2 + 24 * t1**2) * d**5 / 120
    ) / math.cos(phi1)
    return math.degrees(lon), math.degrees(lat)


def _metres_apart(a: tuple[float, float], b: tuple[float, float]) -> float:
    lat = math.radians((a[1] + b[1]) / 2)
    return math.hypot((a[0] - b[0]) * 111_320 * math.cos(lat), (a[1] - b[1]) * 110_574)


@pytest.mark.slow
def test_a_plan_on_a_placed_map_lands_on_its_beach(tmp_path, capsys) -> None:
    bm = load_map(GENTLE)
    assert bm.crs == 32610 and bm.crs_origin_m is not None  # UTM zone 10N, Santa Cruz Main Beach
    out = tmp_path / "plan"
    args = ["plan", str(REPO / "missions" / "mine_clear.yaml"), "--set", "swarm.count=3", "--workers", "1"]
    assert main([*args, "--out", str(out)]) == 0
    capsys.readouterr()
    plan = json.loads((out / "plan.json").read_text())
    geo = json.loads((out / "plan.geojson").read_text())
    assert geo["properties"]["map_crs"] == "EPSG:32610" and "WGS84" in geo["properties"]["coordinates"]
    robot = plan["robots"][0]
    route = next(f for f in geo["features"] if f["properties"].get("id") == robot["id"])
    x, y = robot["launch_m"]
    expected = utm_to_lonlat(
        bm.crs_origin_m[0] + x - bm.origin_m[0], bm.crs_origin_m[1] + y - bm.origin_m[1], 10
    )
    got = tuple(route["geometry"]["coordinates"][0])
    assert _metres_apart(got, expected) < 1.0, (got, expected)
    assert -122.03 < got[0] < -122.0 and 36.95 < got[1] < 36.97  # Monterey Bay, not the Gulf of Guinea
    # every position is longitude, latitude
    for f in geo["features"]:
        pts = np.array(_positions(f["geometry"]))
        assert (np.abs(pts[:, 0] + 122.02) < 0.02).all() and (np.abs(pts[:, 1] - 36.96) < 0.02).all()


def _positions(geometry: dict) -> list:
    out: list = []

    def walk(c):
        if isinstance(c[0], int | float):
            out.append(c)
        else:
            for x in c:
                walk(x)

    walk(geometry["coordinates"])
    return out


def test_without_a_crs_the_geojson_stays_in_metres_and_says_so(tmp_path, capsys) -> None:
    out = tmp_path / "plan"
    assert main(["plan", str(REPO / "missions" / "landing.yaml"), "--workers", "1", "--out", str(out)]) == 0
    capsys.readouterr()
    geo = json.loads((out / "plan.geojson").read_text())
    assert "map metres" in geo["properties"]["coordinates"] and "map_crs" not in geo["properties"]
    plan = json.loads((out / "plan.json").read_text())
    route = next(f for f in geo["features"] if f["properties"].get("id") == "robot_0")
    assert route["geometry"]["coordinates"][0] == plan["robots"][0]["launch_m"]


def test_crs_keys_round_trip_and_bad_ones_are_one_line(tmp_path) -> None:
    bm = load_map(GENTLE)
    save_map(bm, tmp_path / "copy.yaml")
    back = load_map(tmp_path / "copy.yaml")
    assert back.crs == bm.crs and back.crs_origin_m == pytest.approx(bm.crs_origin_m)
    text = GENTLE.read_text()
    for bad, key in (
        ("crs: 4326", "crs"),  # geographic, in degrees: not a map in metres
        ("crs: 99999999", "crs"),
        ("crs: utm", "crs"),
    ):
        path = tmp_path / "bad.yaml"
        path.write_text(
            text.replace("crs: 32610", bad).replace(
                "grid: gentle_fine.npz", f"grid: {GENTLE.with_suffix('.npz')}"
            )
        )
        with pytest.raises(InputError) as err:
            load_map(path)
        assert f": {key}:" in str(err.value) and "EPSG code of a projected" in str(err.value)


UTM10_WKT = (
    'PROJCS["WGS_1984_UTM_Zone_10N",GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",'
    '6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],'
    'PROJECTION["Transverse_Mercator"],PARAMETER["False_Easting",500000.0],PARAMETER["False_Northing",0.0],'
    'PARAMETER["Central_Meridian",-123.0],PARAMETER["Scale_Factor",0.9996],PARAMETER["Latitude_Of_Origin",0.0],'
    'UNIT["Meter",1.0]]'
)


def test_a_dem_with_a_prj_is_placed_in_its_crs(tmp_path) -> None:
    asc = tmp_path / "survey.asc"
    rows = "\n".join(" ".join(f"{-2.0 + 0.1 * r:.2f}" for _ in range(6)) for r in range(5))
    asc.write_text(
        f"ncols 6\nnrows 5\nxllcorner 597000\nyllcorner 4051000\ncellsize 2\nNODATA_value -9999\n{rows}\n"
    )
    assert map_from_dem(asc, "survey").crs is None
    (tmp_path / "survey.prj").write_text(UTM10_WKT)
    bm = map_from_dem(asc, "survey")
    assert bm.crs == 32610 and bm.crs_origin_m == bm.origin_m == (597000.0, 4051000.0)
    (tmp_path / "survey.prj").write_text("not a coordinate system")
    with pytest.raises(InputError, match=r"survey\.prj"):
        map_from_dem(asc, "survey")
