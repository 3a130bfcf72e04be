"""Search coverage: boustrophedon tracks cover what the cookie-cutter model promises, the tracks
split into balanced contiguous runs, and the detection formulas match hand values and Monte Carlo."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
import shapely
from scipy.integrate import quad
from shapely import affinity
from shapely.geometry import LineString, Polygon, box

from swarm.errors import SwarmError
from swarm.planning.coverage import (
    MIN_PIECE_M,
    boustrophedon,
    default_track_angle_deg,
    detection_probability,
    inverse_cube_lateral_range,
    split_tracks,
    swath_coverage,
    track_length_m,
)

RECT = box(0.0, 0.0, 100.0, 37.0)  # 37 m is not a multiple of the spacings below
L_SHAPE = Polygon([(0, 0), (100, 0), (100, 50), (50, 50), (50, 100), (0, 100)])
U_SHAPE = Polygon([(0, 0), (90, 0), (90, 80), (60, 80), (60, 30), (30, 30), (30, 80), (0, 80)])
SHAPES = {
    "rectangle": RECT,
    "L": L_SHAPE,
    "rotated L": affinity.rotate(L_SHAPE, 33.0),
    "U": U_SHAPE,
    "triangle": Polygon([(0, 0), (80, 10), (20, 60)]),
}


def _direction_deg(track: LineString) -> float:
    (x0, y0), (x1, y1) = track.coords
    return math.degrees(math.atan2(y1 - y0, x1 - x0)) % 180.0


# tracks -----------------------------------------------------------------------------------------


def test_rectangle_tracks_run_along_the_long_side_spacing_apart() -> None:
    spacing = 5.0
    tracks = boustrophedon(RECT, spacing)
    assert len(tracks) == math.ceil(37.0 / spacing)
    assert all(_direction_deg(t) == pytest.approx(0.0, abs=1e-9) for t in tracks)
    ys = sorted(t.coords[0][1] for t in tracks)
    assert np.allclose(np.diff(ys), spacing)
    assert ys[0] - 0.0 == pytest.approx(37.0 - ys[-1])  # centred: equal margins
    assert ys[0] <= spacing / 2
    # back and forth: each track starts where the last one ended, one spacing over
    for a, b in itertools.pairwise(tracks):
        assert math.dist(a.coords[-1], b.coords[0]) == pytest.approx(spacing)


def test_default_angle_follows_the_minimum_rotated_rectangle() -> None:
    tilted = affinity.rotate(RECT, 20.0, origin="centroid")
    assert default_track_angle_deg(tilted) == pytest.approx(20.0, abs=1e-6)
    tracks = boustrophedon(tilted, 4.0)
    assert all(_direction_deg(t) == pytest.approx(20.0, abs=1e-6) for t in tracks)
    assert all(_direction_deg(t) == pytest.approx(70.0, abs=1e-6) for t in boustrophedon(RECT, 4.0, 70.0))


@pytest.mark.parametrize("name", list(SHAPES))
@pytest.mark.parametrize("angle", [None, 0.0, 33.0, 90.0])
@pytest.mark.parametrize(("spacing", "width"), [(5.0, 5.0), (5.0, 6.5), (7.3, 7.3)])
def test_cookie_cutter_promise_is_kept_when_spacing_at_most_width(name, angle, spacing, width) -> None:
    polygon = SHAPES[name]
    tracks = boustrophedon(polygon, spacing, angle)
    promised = detection_probability("cookie_cutter", width, spacing)
    assert promised == 1.0
    assert swath_coverage(polygon, tracks, width) >= promised - 1e-9


@pytest.mark.parametrize("name", ["rectangle", "L", "rotated L"])
@pytest.mark.parametrize(("spacing", "width"), [(5.0, 3.0), (8.0, 2.0), (6.0, 5.5)])
def test_cookie_cutter_fraction_when_spacing_exceeds_width(name, spacing, width) -> None:
    polygon = SHAPES[name]
    tracks = boustrophedon(polygon, spacing)
    promised = detection_probability("cookie_cutter", width, spacing)
    assert promised == pytest.approx(width / spacing)
    assert swath_coverage(polygon, tracks, width) >= promised - 1e-9


@pytest.mark.parametrize("name", list(SHAPES))
def test_every_point_within_half_a_spacing_and_tracks_hug_the_polygon(name) -> None:
    polygon = SHAPES[name]
    spacing = 6.0
    tracks = boustrophedon(polygon, spacing)
    rng = np.random.default_rng(3)
    xmin, ymin, xmax, ymax = polygon.bounds
    pts = rng.uniform((xmin, ymin), (xmax, ymax), (4000, 2))
    inside = shapely.points(pts)[shapely.contains_xy(polygon, pts[:, 0], pts[:, 1])]
    nearest = shapely.distance(inside[:, None], np.asarray(tracks, dtype=object)[None, :]).min(axis=1)
    assert nearest.max() <= spacing / 2 + 1e-9
    grown = polygon.buffer(spacing / 2 + 1e-6)
    assert all(grown.contains(t) for t in tracks)


def test_u_shape_is_swept_arm_by_arm() -> None:
    """The route finishes one arm of the U before crossing to the other (boustrophedon cells)."""
    tracks = boustrophedon(U_SHAPE, 10.0, 0.0)
    arm = [0 if t.centroid.y < 30 else (1 if t.centroid.x < 30 else 2) for t in tracks]
    changes = sum(a != b for a, b in itertools.pairwise(arm))
    assert changes == 2  # base, then one arm, then the other
    hops = [math.dist(a.coords[-1], b.coords[0]) for a, b in itertools.pairwise(tracks)]
    assert sorted(hops)[-1] < 60.0


def test_boustrophedon_rejects_bad_input() -> None:
    with pytest.raises(SwarmError):
        boustrophedon(LineString([(0, 0), (1, 1)]), 1.0)
    with pytest.raises(SwarmError):
        boustrophedon(RECT, 0.0)


# splitting among searchers --------------------------------------------------------------------


def _route_position(tracks: list[LineString], piece: LineString) -> tuple[float, float]:
    """Where `piece` starts and ends along the route (the tracks end to end), metres; raises if it
    is not a stretch of one track."""
    offset = 0.0
    for t in tracks:
        a, b = shapely.Point(piece.coords[0]), shapely.Point(piece.coords[-1])
        if t.distance(a) < 1e-9 and t.distance(b) < 1e-9:
            return offset + t.project(a), offset + t.project(b)
        offset += t.length
    raise AssertionError(f"{piece} is not on any track")


@pytest.mark.parametrize("name", list(SHAPES))
@pytest.mark.parametrize("n", [1, 2, 3, 4, 7])
def test_split_is_contiguous_complete_and_equal(name, n) -> None:
    tracks = boustrophedon(SHAPES[name], 9.0)
    runs = split_tracks(tracks, n, min_piece_m=0.0)
    assert len(runs) == n
    # every piece is a stretch of a track, and the pieces follow one another along the route with
    # no gap and no overlap, from its start to its end
    spans = [_route_position(tracks, piece) for run in runs for piece in run]
    assert spans[0][0] == pytest.approx(0.0, abs=1e-9)
    assert spans[-1][1] == pytest.approx(track_length_m(tracks), rel=1e-12)
    for (_, end), (start, _) in itertools.pairwise(spans):
        assert start == pytest.approx(end, abs=1e-6)
    # each run is as long to drive as the next (its tracks, the drives between them and the drive
    # into its first track), to within the longest drive between two tracks, where cuts fall back
    joins = [math.dist(a.coords[-1], b.coords[0]) for a, b in itertools.pairwise(tracks)]
    total = track_length_m(tracks) + sum(joins)
    ends = [None, *(run[-1].coords[-1] for run in runs[:-1])]
    for before, run in zip(ends, runs, strict=True):
        drive = track_length_m(run) + sum(
            math.dist(a.coords[-1], b.coords[0]) for a, b in itertools.pairwise(run)
        )
        drive += 0.0 if before is None else math.dist(before, run[0].coords[0])
        assert abs(drive - total / n) <= max(joins, default=0.0) + 1e-6


def test_split_keeps_no_sliver_and_more_searchers_shorten_the_longest_run() -> None:
    tracks = boustrophedon(box(0, 0, 1000, 20), 2.5)
    total = track_length_m(tracks)
    joins = sum(math.dist(a.coords[-1], b.coords[0]) for a, b in itertools.pairwise(tracks))
    longest = [max(track_length_m(r) for r in split_tracks(tracks, n)) for n in (8, 16, 32)]
    for n, top in zip((8, 16, 32), longest, strict=True):
        assert top <= (total + joins) / n + MIN_PIECE_M + 1e-9
    assert longest[1] <= 0.55 * longest[0] and longest[2] <= 0.55 * longest[1]
    for run in split_tracks(tracks, 13):
        assert all(t.length >= MIN_PIECE_M - 1e-9 for t in run)


def test_split_with_more_searchers_than_tracks() -> None:
    """Two 50 m tracks 5 m apart among four searchers: 105 m to drive, cut every 26.25 m through
    the tracks; the cut that falls in the 5 m drive between them moves to the second's start."""
    tracks = boustrophedon(box(0, 0, 50, 10), 5.0)
    runs = split_tracks(tracks, 4)
    assert [round(track_length_m(r), 9) for r in runs] == [26.25, 23.75, 23.75, 26.25]
    assert split_tracks([], 3) == [[], [], []]
    with pytest.raises(SwarmError):
        split_tracks(tracks, 0)


# detection models -----------------------------------------------------------------------------


def test_detection_formulas_against_hand_values() -> None:
    # cookie-cutter: W/S capped at 1
    assert detection_probability("cookie_cutter", 4.0, spacing_m=10.0) == pytest.approx(0.4)
    assert detection_probability("cookie_cutter", 12.0, spacing_m=10.0) == 1.0
    # inverse cube, erf(sqrt(pi)/2 W/S): W = S gives erf(0.886227) = 0.789909
    assert detection_probability("inverse_cube", 10.0, spacing_m=10.0) == pytest.approx(0.7899086, abs=1e-7)
    assert detection_probability("inverse_cube", 5.0, spacing_m=10.0) == pytest.approx(0.4691159, abs=1e-7)
    # Koopman random search, 1 - exp(-W L / A): W 2 m, L 1 km, A 1 ha -> 1 - e^-0.2 = 0.181269
    p = detection_probability("random", 2.0, track_length_m=1000.0, area_m2=10_000.0)
    assert p == pytest.approx(0.1812692, abs=1e-7)
    # small coverage: P ~ W L / A; large: P -> 1
    assert detection_probability("random", 1.0, track_length_m=1.0, area_m2=1e6) == pytest.approx(
        1e-6, rel=1e-6
    )
    assert detection_probability("random", 10.0, track_length_m=1e4, area_m2=1e3) == pytest.approx(1.0)


def test_parallel_sweeps_beat_random_search_for_the_same_track_length() -> None:
    """Koopman's ordering for the same effort (L = A / S): random <= inverse cube <= cookie-cutter."""
    area = 1e4
    for ratio in np.linspace(0.05, 3.0, 40):
        spacing, width = 10.0, 10.0 * ratio
        length = area / spacing
        random = detection_probability("random", width, track_length_m=length, area_m2=area)
        inverse = detection_probability("inverse_cube", width, spacing_m=spacing)
        cookie = detection_probability("cookie_cutter", width, spacing_m=spacing)
        assert random <= inverse + 1e-12 <= cookie + 2e-12


def test_inverse_cube_lateral_range_curve_integrates_to_the_sweep_width() -> None:
    width = 7.0
    half, _ = quad(lambda x: float(inverse_cube_lateral_range(x, width)), 0.0, np.inf, limit=200)
    assert 2 * half == pytest.approx(width, rel=1e-6)


@pytest.mark.parametrize("ratio", [0.4, 1.0, 1.7])
def test_inverse_cube_formula_matches_monte_carlo(ratio: float) -> None:
    """Mines uniform across one spacing of infinitely many parallel tracks (2K+1 simulated), each
    detected with probability 1 - prod_k (1 - p(x_k)), drawn with a seeded Generator."""
    rng = np.random.default_rng(2024)
    spacing, n, k_tracks = 10.0, 20_000, 200
    width = ratio * spacing
    offset = rng.uniform(0.0, spacing, n)
    lateral = np.abs(offset[:, None] - spacing * np.arange(-k_tracks, k_tracks + 1)[None, :])
    glimpses = (width**2 / (4 * math.pi)) * (1.0 / lateral**2).sum(axis=1)
    detected = rng.random(n) < -np.expm1(-glimpses)
    expected = detection_probability("inverse_cube", width, spacing_m=spacing)
    # tracks beyond +-K add at most 2 W^2 / (4 pi S^2 (K - 1)) to the exponent
    tail = 2 * width**2 / (4 * math.pi * spacing**2 * (k_tracks - 1))
    sigma = math.sqrt(expected * (1 - expected) / n)
    assert abs(detected.mean() - expected) <= 4 * sigma + tail


def test_inverse_cube_over_boustrophedon_tracks_matches_monte_carlo() -> None:
    """The same law over real tracks: mines in the middle of a 600 m square, far from its edges."""
    rng = np.random.default_rng(99)
    spacing, width = 10.0, 8.0
    tracks = boustrophedon(box(0, 0, 600, 600), spacing, 0.0)
    n = 20_000
    mines = rng.uniform(250.0, 350.0, (n, 2))
    lateral = shapely.distance(shapely.points(mines)[:, None], np.asarray(tracks, dtype=object)[None, :])
    detected = rng.random(n) < -np.expm1(-(width**2 / (4 * math.pi)) * (1.0 / lateral**2).sum(axis=1))
    expected = detection_probability("inverse_cube", width, spacing_m=spacing)
    # missing tracks beyond the edges (>= 250 m away on both sides) add to the exponent at most
    tail = 2 * (width**2 / (4 * math.pi)) * (1 / 250.0**2 + 1 / (spacing * 250.0))
    sigma = math.sqrt(expected * (1 - expected) / n)
    assert abs(detected.mean() - expected) <= 4 * sigma + tail


def test_detection_rejects_bad_input() -> None:
    with pytest.raises(SwarmError, match="unknown detection model"):
        detection_probability("glimpse", 1.0, spacing_m=1.0)
    with pytest.raises(SwarmError, match="spacing_m"):
        detection_probability("inverse_cube", 1.0)
    with pytest.raises(SwarmError, match="area_m2"):
        detection_probability("random", 1.0, track_length_m=10.0)
    with pytest.raises(SwarmError, match="sweep_width_m"):
        detection_probability("cookie_cutter", -1.0, spacing_m=1.0)


def test_swath_coverage_edge_cases() -> None:
    assert swath_coverage(RECT, [], 3.0) == 0.0
    one = [LineString([(0, 18.5), (100, 18.5)])]
    assert swath_coverage(RECT, one, 10.0) == pytest.approx(10.0 / 37.0, rel=1e-9)
