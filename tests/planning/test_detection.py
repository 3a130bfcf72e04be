"""Expected detection of tracks as driven: against Koopman's closed forms where they hold, and the
parts of a track a robot cannot drive left out."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, box

from swarm.mission import load_mission
from swarm.planning import build_costmap
from swarm.planning.coverage import detection_probability
from swarm.planning.detection import (
    INVERSE_CUBE_FLOOR,
    LateralRangeCurve,
    clip_tracks,
    detection_map,
    drivable_segments,
    expected_detection,
    inverse_cube_look,
    inverse_cube_range_m,
    segment_distance,
)

AREA = box(0.0, 0.0, 200.0, 60.0)


def _lattice(spacing: float, reach: float = 40.0) -> np.ndarray:
    """Parallel tracks along x every `spacing`, running `reach` past the area on every side: from
    inside the area they look endless."""
    ys = np.arange(-reach, 60.0 + reach + 1e-9, spacing) + spacing / 3.0
    return np.array([[[-reach, y], [200.0 + reach, y]] for y in ys])


@pytest.mark.parametrize("ratio", [0.5, 1.0, 1.5])
def test_endless_parallel_tracks_give_koopmans_erf(ratio) -> None:
    """Inverse cube over an endless lattice: erf(sqrt(pi)/2 W/S), less the tails cut at the range
    where a pass detects with 1e-3 (at most W^2 / (2 pi R) of W: a few tenths of a percent)."""
    width, spacing = 3.0, 3.0 / ratio
    p = expected_detection(AREA, _lattice(spacing), "inverse_cube", width)
    koopman = detection_probability("inverse_cube", width, spacing_m=spacing)
    cut = width**2 / (2 * math.pi * inverse_cube_range_m(width)) / spacing
    assert koopman - cut - 2e-3 <= p <= koopman + 2e-3


@pytest.mark.parametrize("ratio", [0.4, 0.8])
def test_cookie_cutter_lattice_covers_w_over_s(ratio) -> None:
    width, spacing = 4.0, 4.0 / ratio
    p = expected_detection(AREA, _lattice(spacing), "cookie_cutter", width)
    assert p == pytest.approx(min(1.0, width / spacing), abs=3e-3)


def test_one_straight_pass_is_the_lateral_range_curve() -> None:
    w = 3.0
    track = np.array([[[-500.0, 0.0], [500.0, 0.0]]])
    x = np.array([0.3, 0.8, 1.5, 3.0, 6.0])
    pts = np.column_stack([np.zeros_like(x), x])
    p = detection_map(pts, track, "inverse_cube", w)
    np.testing.assert_allclose(p, -np.expm1(-(w**2) / (4 * math.pi * x**2)), rtol=1e-4)  # 1 km, not endless
    # the look of a whole pass is 2 / x^2
    np.testing.assert_allclose(inverse_cube_look(track[:, 0], track[:, 1], pts), 2 / x**2, rtol=1e-4)
    # a tabulated curve is drawn once per pass at the closest approach
    table = LateralRangeCurve((0.0, 1.0, 2.0), (0.9, 0.5, 0.0))
    np.testing.assert_allclose(detection_map(pts, track, "inverse_cube", w, table), table(x))


def test_a_tabulated_curve_draws_once_per_pass_however_the_track_bends() -> None:
    """The simulator draws once per pass, at its closest approach; a pass is a track's run within
    the curve's range. A draw per segment would find a mine off a corner with 1 - (1 - p)^2."""
    curve = LateralRangeCurve((0.0, 0.5, 1.0, 1.5, 2.0), (1.0, 0.95, 0.8, 0.4, 0.0))
    assert curve.max_range_m == 2.0
    corner = np.array([[[-20.0, 0.0], [0.0, 0.0]], [[0.0, 0.0], [0.0, 20.0]]])
    mine = np.array([[1.0, -1.0]])  # sqrt(2) m from the corner, abeam neither leg
    p = float(np.interp(math.sqrt(2.0), [1.0, 1.5], [0.8, 0.4]))
    np.testing.assert_allclose(detection_map(mine, corner, "cookie_cutter", 2.65, curve), [p])
    # the same corner in half-metre pieces, as a route's samples come: still one pass
    out = np.linspace([-20.0, 0.0], [0.0, 0.0], 41)
    up = np.linspace([0.0, 0.0], [0.0, 20.0], 41)
    pts = np.vstack([out, up[1:]])
    pieces = np.stack([pts[:-1], pts[1:]], axis=1)
    np.testing.assert_allclose(detection_map(mine, pieces, "cookie_cutter", 2.65, curve), [p])
    # a hairpin leaves the range between its legs: two passes, each 1.5 m off
    hairpin = np.array([[[0.0, 0.0], [50.0, 0.0]], [[50.0, 0.0], [50.0, 3.0]], [[50.0, 3.0], [0.0, 3.0]]])
    np.testing.assert_allclose(
        detection_map(np.array([[10.0, 1.5]]), hairpin, "cookie_cutter", 2.65, curve), [1.0 - 0.6**2]
    )
    # two tracks, even end to end in the list, are two passes when the second does not start
    # where the first ends
    apart = np.array([[[0.0, 0.0], [20.0, 0.0]], [[0.0, 3.0], [20.0, 3.0]]])
    np.testing.assert_allclose(
        detection_map(np.array([[10.0, 1.5]]), apart, "cookie_cutter", 2.65, curve), [1.0 - 0.6**2]
    )


def test_the_range_cut_is_where_a_pass_detects_with_the_floor() -> None:
    r = inverse_cube_range_m(3.0)
    assert -math.expm1(-(3.0**2) / (4 * math.pi * r * r)) == pytest.approx(INVERSE_CUBE_FLOOR)


@pytest.fixture(scope="module")
def small_costmap():
    m = load_mission("missions/landing.yaml")
    return build_costmap(m.beach_map, m.robot_params, m.terrain_library)


def test_only_drivable_ground_counts_and_clipping_keeps_a_margin(small_costmap) -> None:
    cm = small_costmap
    x0, y0, x1, y1 = cm.bounds_m
    tracks = [LineString([(x0 + 1, y), (x1 - 1, y)]) for y in np.arange(y0 + 2.5, y1 - 2, 3.0)]  # mid-cell
    segs = drivable_segments(tracks, cm)
    assert len(segs)
    # every point of every segment kept is free; every free sample of the tracks is in a segment
    t = np.linspace(0, 1, 50)
    pts = (segs[:, None, 0, :] * (1 - t[None, :, None]) + segs[:, None, 1, :] * t[None, :, None]).reshape(
        -1, 2
    )
    assert cm.is_free(pts[:, 0], pts[:, 1]).all()
    kept = shapely.MultiLineString([s.tolist() for s in segs])
    for line in tracks:
        samples = np.array([line.interpolate(d).coords[0] for d in np.arange(0, line.length, 0.5)])
        free = cm.is_free(samples[:, 0], samples[:, 1])
        row, col = cm.cell_of(samples[:, 0], samples[:, 1])
        inner = free & (cm.clearance_m[row, col] >= cm.inflation_m + cm.cell_m)  # well inside free ground
        if inner.any():
            assert shapely.distance(shapely.points(samples[inner]), kept).max() < 1e-6
    clipped = clip_tracks(tracks, cm, margin_m=1.0, min_length_m=2.0)
    assert 0 < sum(c.length for c in clipped) < kept.length
    for c in clipped:
        assert c.length >= 2.0
        s = np.array([c.interpolate(d).coords[0] for d in np.linspace(0, c.length, 20)])
        row, col = cm.cell_of(s[:, 0], s[:, 1])
        assert (cm.clearance_m[row, col] >= cm.inflation_m + 1.0).all()


def test_the_inverse_cube_map_is_its_definition_in_numpy_float_for_float() -> None:
    """The compiled sum (segments beyond reach skipped) gives the floats of the definition: every
    segment's `inverse_cube_look` where `segment_distance` is within reach, summed over segments
    block by block as numpy sums a (segments x points) array."""
    rng = np.random.default_rng(5)
    points = rng.uniform(0.0, 400.0, (5000, 2))  # 400 segments to a block: three blocks
    a = rng.uniform(0.0, 150.0, (900, 2))
    b = a + rng.normal(0.0, 4.0, (900, 2))
    b[:3] = a[:3]  # segments of no length look at nothing
    width = 3.0
    reach = inverse_cube_range_m(width)
    block = 2_000_000 // len(points)
    exposure = np.zeros(len(points))
    for s in range(0, len(a), block):
        sa, sb = a[s : s + block, None, :], b[s : s + block, None, :]
        d = segment_distance(sa, sb, points[None, :, :])
        exposure += np.where(d <= reach, inverse_cube_look(sa, sb, points[None, :, :]), 0.0).sum(axis=0)
    want = -np.expm1(-(width**2) / (8.0 * math.pi) * exposure)
    got = detection_map(points, np.stack([a, b], axis=1), "inverse_cube", width)
    assert np.array_equal(got, want)
    assert 0.05 < np.mean(got > 0) < 0.95  # near and far points both
