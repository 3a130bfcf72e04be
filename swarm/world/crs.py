"""Where a map lies on the Earth: map metres to the map's projected CRS (an EPSG code) and on to
WGS84 longitude and latitude, the only coordinates RFC 7946 GeoJSON may carry (pyproj does the
geodesy). A map's x and y run east and north in its CRS: projected = crs_origin_m + (xy - origin_m).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pyproj import CRS, Transformer
from pyproj.exceptions import CRSError

from swarm.errors import InputError
from swarm.files import read_text
from swarm.world.beachmap import BeachMap

WGS84 = 4326


def check_crs(source: str | Path, key: str, epsg: object) -> int:
    """`epsg` as the code of a projected CRS in metres, or an `InputError` naming `key`."""
    expected = "an EPSG code of a projected coordinate system in metres, e.g. 32610 (UTM zone 10N)"
    if isinstance(epsg, bool) or not isinstance(epsg, int):
        raise InputError(source, key, epsg, expected)
    try:
        crs = CRS.from_epsg(epsg)
    except CRSError:
        raise InputError(source, key, epsg, expected) from None
    units = {a.unit_name for a in crs.axis_info}
    if not crs.is_projected or units != {"metre"}:
        raise InputError(source, key, f"EPSG:{epsg} ({crs.name})", expected)
    return epsg


def crs_from_prj(path: str | Path) -> int:
    """The EPSG code of the CRS an ESRI `.prj` file describes (its WKT)."""
    text = read_text(path, "projection file (.prj)")
    try:
        epsg = CRS.from_wkt(text.strip()).to_epsg(min_confidence=70)
    except CRSError as exc:
        raise InputError(path, "(WKT)", str(exc).splitlines()[0][:80], "a WKT coordinate system") from None
    if epsg is None:
        raise InputError(path, "(WKT)", "a CRS with no EPSG code", "a CRS pyproj can name by EPSG code")
    return check_crs(path, "(WKT)", epsg)


def projected(beach_map: BeachMap, xy: np.ndarray) -> np.ndarray:
    """Map points (n, 2) in the map's CRS (easting, northing)."""
    if beach_map.crs is None:
        raise ValueError(f"map '{beach_map.name}' has no crs")
    origin = beach_map.crs_origin_m if beach_map.crs_origin_m is not None else beach_map.origin_m
    return np.asarray(xy, dtype=np.float64) - np.asarray(beach_map.origin_m) + np.asarray(origin)


def to_lonlat(beach_map: BeachMap, xy: np.ndarray) -> np.ndarray:
    """Map points (n, 2) as WGS84 (longitude, latitude), degrees."""
    en = projected(beach_map, np.asarray(xy, dtype=np.float64).reshape(-1, 2))
    lon, lat = Transformer.from_crs(beach_map.crs, WGS84, always_xy=True).transform(en[:, 0], en[:, 1])
    return np.column_stack([lon, lat])
