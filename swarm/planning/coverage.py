"""Searching an area for mines: boustrophedon tracks, shared among searchers, and what they find.

Tracks. `boustrophedon(polygon, spacing_m)` lays parallel tracks ``spacing_m`` apart across a
search polygon (Choset, "Coverage path planning: the boustrophedon cellular decomposition", 2000):
the polygon is cut into bands one spacing wide, each band's connected piece gets one track along
its middle through the whole extent of the piece, and the pattern is centred so the outer tracks
sit at most half a spacing in from the edges. Every point of the polygon is therefore within
``spacing_m / 2`` of a track, measured across the tracks, which is what makes a sensor of sweep
width ``W >= spacing_m`` cover all of it. Where the boundary slants or turns a concave corner a
track may run up to ``spacing_m / 2`` outside the polygon. Pieces are grouped into cells that
one back-and-forth sweep can cover (a cell ends where the polygon splits or merges across the
sweep, Choset's critical points); tracks alternate direction within a cell and cells follow one
another nearest first, so the list is one route. `split_tracks` cuts that route into contiguous
runs of equal length, one per searcher, cutting through tracks where need be.

Detection (Koopman, *Search and Screening*, 1946/1980; Washburn, *Search and Detection*, 4th ed.,
2002, ch. 2). A sensor's lateral range curve p(x) is the chance of detecting a mine passed at
lateral distance x; its sweep width is W = integral of p(x) dx. For tracks at spacing S,
`detection_probability` gives the expected fraction of uniformly scattered mines found:

- ``"cookie_cutter"`` (definite range law: detect surely within R, never beyond, W = 2R): the
  fraction of the area within R of a track, min(1, W / S);
- ``"inverse_cube"`` (Koopman's inverse cube law for a sensor looking down from height h: glimpse
  rate proportional to h / r^3, lateral range curve p(x) = 1 - exp(-W^2 / (4 pi x^2)), whose
  integral is W): over infinitely many parallel tracks the target at offset x is missed with
  probability prod_k exp(-W^2 / (4 pi (x + kS)^2)); averaged over x this is
  P = erf(sqrt(pi) / 2 * W / S);
- ``"random"`` (Koopman's random search: the track wanders over the area A, total length L):
  P = 1 - exp(-W L / A).

`swath_coverage(polygon, tracks, W)` measures what a cookie-cutter sensor of width W actually
covers: the area of the union of the tracks buffered by W/2 (round ends: a disc swept along the
track), inside the polygon, over the polygon's area.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import shapely
from scipy.special import erf
from shapely import affinity
from shapely.geometry import LineString, Polygon, box
from shapely.geometry.base import BaseGeometry
from shapely.ops import substring

from swarm.errors import SwarmError

#: Sensor models `detection_probability` knows.
DETECTION_MODELS = ("cookie_cutter", "inverse_cube", "random")


def _check_polygon(polygon: BaseGeometry) -> BaseGeometry:
    if polygon.geom_type not in ("Polygon", "MultiPolygon") or polygon.is_empty or polygon.area <= 0:
        raise SwarmError(f"coverage: the search area must be a polygon with area, found {polygon.geom_type}")
    if not polygon.is_valid:
        polygon = shapely.make_valid(polygon)
    return polygon


def _positive(name: str, value: float | None) -> float:
    if value is None or not (math.isfinite(value) and value > 0):
        raise SwarmError(f"coverage: {name} must be a positive number, found {value!r}")
    return float(value)


def default_track_angle_deg(polygon: BaseGeometry) -> float:
    """Direction of the longest side of the polygon's minimum rotated rectangle, degrees CCW from
    +x in [0, 180): tracks along it need the fewest turns."""
    rect = shapely.minimum_rotated_rectangle(polygon)
    coords = np.asarray(rect.exterior.coords) if rect.geom_type == "Polygon" else np.asarray(rect.coords)
    sides = np.diff(coords, axis=0)
    if len(sides) == 0:
        return 0.0
    dx, dy = sides[int(np.argmax(np.hypot(sides[:, 0], sides[:, 1])))]
    return float(math.degrees(math.atan2(dy, dx)) % 180.0)


def _pieces(geom: BaseGeometry) -> list[Polygon]:
    if geom.is_empty:
        return []
    parts = getattr(geom, "geoms", [geom])
    return [p for p in parts if p.geom_type == "Polygon" and p.area > 0]


def boustrophedon(
    polygon: BaseGeometry, spacing_m: float, angle_deg: float | None = None
) -> list[LineString]:
    """Parallel back-and-forth tracks `spacing_m` apart over `polygon`, in driving order.

    `angle_deg` is the track direction, counter-clockwise from +x (east); by default the longest
    side of the polygon's minimum rotated rectangle. See the module docstring for the guarantee
    (every point within spacing/2 of a track, across the tracks) and the ordering.
    """
    polygon = _check_polygon(polygon)
    spacing = _positive("spacing_m", spacing_m)
    angle = default_track_angle_deg(polygon) if angle_deg is None else float(angle_deg)
    pivot = polygon.centroid
    flat = affinity.rotate(polygon, -angle, origin=pivot)  # tracks along +x in this frame
    xmin, ymin, xmax, ymax = flat.bounds
    height = ymax - ymin
    n_lines = max(1, math.ceil(height / spacing - 1e-9))
    first = ymin + (height - (n_lines - 1) * spacing) / 2.0

    # each band's connected pieces: (y, x0, x1, piece), west to east
    bands: list[list[tuple[float, float, float, Polygon]]] = []
    for k in range(n_lines):
        y = first + k * spacing
        band = box(xmin - 1.0, y - spacing / 2.0, xmax + 1.0, y + spacing / 2.0)
        pieces = []
        for piece in _pieces(flat.intersection(band)):
            x0, _, x1, _ = piece.bounds
            if x1 > x0:
                pieces.append((y, x0, x1, piece))
        bands.append(sorted(pieces, key=lambda p: p[1]))

    cells = _cells(bands)
    ordered = _route(cells)
    tracks = [LineString([(a, y), (b, y)]) for y, a, b in ordered]
    return [affinity.rotate(t, angle, origin=pivot) for t in tracks]


def _cells(bands: list[list[tuple[float, float, float, Polygon]]]) -> list[list[tuple[float, float, float]]]:
    """Group band pieces into boustrophedon cells: a piece continues the cell of the piece below
    it when each touches exactly one piece of the other band; otherwise a new cell starts."""
    cells: list[list[tuple[float, float, float]]] = []
    previous: list[tuple[tuple[float, float, float, Polygon], int]] = []
    for pieces in bands:
        current = []
        touches_up = [
            [q for q, (p, _) in enumerate(previous) if p[3].intersects(piece[3])] for piece in pieces
        ]
        for i, piece in enumerate(pieces):
            below = touches_up[i]
            cell = -1
            if len(below) == 1:
                q = below[0]
                if sum(q in t for t in touches_up) == 1:
                    cell = previous[q][1]
            if cell < 0:
                cells.append([])
                cell = len(cells) - 1
            cells[cell].append(piece[:3])
            current.append((piece, cell))
        previous = current
    return cells


def _route(cells: list[list[tuple[float, float, float]]]) -> list[tuple[float, float, float]]:
    """Tracks in driving order: the first cell from its first track, then each next cell the one
    whose nearer end is closest to where the last track ended; tracks alternate direction."""
    out: list[tuple[float, float, float]] = []
    left = list(range(len(cells)))
    here: tuple[float, float] | None = None
    while left:
        best = None
        for c in left:
            rows = cells[c]
            for flip_rows in (False, True):
                first = rows[-1] if flip_rows else rows[0]
                for flip_x in (False, True):
                    start = (first[2] if flip_x else first[1], first[0])
                    d = 0.0 if here is None else math.dist(here, start)
                    key = (d, c, flip_rows, flip_x)
                    if best is None or key < best:
                        best = key
        _, c, flip_rows, flip_x = best
        left.remove(c)
        rows = cells[c][::-1] if flip_rows else cells[c]
        for i, (y, a, b) in enumerate(rows):
            reverse = flip_x != (i % 2 == 1)
            out.append((y, b, a) if reverse else (y, a, b))
        y, _, b = out[-1]
        here = (b, y)
    return out


def track_length_m(tracks: list[LineString]) -> float:
    return float(sum(t.length for t in tracks))


#: `split_tracks` never leaves a piece of track shorter than this at a cut (m): a cut that would
#: falls back to the nearer end of the track.
MIN_PIECE_M = 5.0


def split_tracks(
    tracks: list[LineString], n: int, min_piece_m: float = MIN_PIECE_M
) -> list[list[LineString]]:
    """Cut the ordered tracks into `n` contiguous runs of equal length to drive.

    The route (the tracks in driving order, with the drive from each track's end to the next one's
    start) is cut at every n-th of its length, through a track where need be, so each searcher
    drives as far as the next and doubling the searchers halves the search time, however few
    tracks there are. A cut within `min_piece_m` of a track's end, or in the drive between two
    tracks, moves to a track's end (no slivers); runs that end up with no track come last, empty.
    """
    if n < 1:
        raise SwarmError(f"coverage: need at least one searcher, found {n}")
    if not tracks:
        return [[] for _ in range(n)]
    lengths = np.array([t.length for t in tracks], dtype=np.float64)
    # the drive from one track's end to the next one's start counts toward the run it leads into
    joins = np.array([0.0, *(math.dist(a.coords[-1], b.coords[0]) for a, b in itertools.pairwise(tracks))])
    starts = np.cumsum(joins + np.concatenate([[0.0], lengths[:-1]]))  # where each track starts
    ends = starts + lengths
    total = float(ends[-1])
    cuts = [0.0]
    for c in total * np.arange(1, n) / n:
        j = int(np.clip(np.searchsorted(ends, c, side="left"), 0, len(tracks) - 1))
        if c <= starts[j] or c - starts[j] < min_piece_m:
            c = starts[j]  # in the drive to track j, or just into it: cut at its start
        elif ends[j] - c < min_piece_m:
            c = ends[j]
        cuts.append(max(float(c), cuts[-1]))
    cuts.append(total)
    runs: list[list[LineString]] = []
    for a, b in itertools.pairwise(cuts):
        run = []
        for j, t in enumerate(tracks):
            lo, hi = max(a, starts[j]), min(b, ends[j])
            if hi - lo <= 1e-9:
                continue
            if lo - starts[j] <= 1e-9 and ends[j] - hi <= 1e-9:
                run.append(t)
            else:
                run.append(substring(t, lo - starts[j], hi - starts[j]))
        runs.append(run)
    full = [r for r in runs if r]
    return full + [[] for _ in range(n - len(full))]


def detection_probability(
    model: str,
    sweep_width_m: float,
    spacing_m: float | None = None,
    track_length_m: float | None = None,
    area_m2: float | None = None,
) -> float:
    """Expected fraction of the mines in the area found (module docstring for the formulas).

    ``"cookie_cutter"`` and ``"inverse_cube"`` need `spacing_m` (parallel tracks);
    ``"random"`` needs `track_length_m` and `area_m2`.
    """
    w = _positive("sweep_width_m", sweep_width_m)
    if model == "cookie_cutter":
        return min(1.0, w / _positive("spacing_m", spacing_m))
    if model == "inverse_cube":
        return float(erf(math.sqrt(math.pi) / 2.0 * w / _positive("spacing_m", spacing_m)))
    if model == "random":
        length = _positive("track_length_m", track_length_m)
        return float(-math.expm1(-w * length / _positive("area_m2", area_m2)))
    raise SwarmError(f"coverage: unknown detection model {model!r}, expected one of {list(DETECTION_MODELS)}")


def inverse_cube_lateral_range(x_m: np.ndarray | float, sweep_width_m: float) -> np.ndarray:
    """Koopman's inverse-cube lateral range curve p(x) = 1 - exp(-W^2 / (4 pi x^2)); its integral
    over x is W."""
    x = np.asarray(x_m, dtype=np.float64)
    with np.errstate(divide="ignore"):
        return -np.expm1(-(sweep_width_m**2) / (4.0 * math.pi * x**2))


def swath_coverage(polygon: BaseGeometry, tracks: list[LineString], sweep_width_m: float) -> float:
    """Fraction of `polygon` within sweep_width/2 of a track: the area of the union of the track
    buffers (round ends) intersected with the polygon, over the polygon's area."""
    polygon = _check_polygon(polygon)
    w = _positive("sweep_width_m", sweep_width_m)
    if not tracks:
        return 0.0
    swath = shapely.union_all(shapely.buffer(np.asarray(tracks, dtype=object), w / 2.0))
    return float(swath.intersection(polygon).area / polygon.area)
