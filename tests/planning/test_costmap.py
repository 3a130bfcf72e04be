"""The planner's cost map: terrain cost from the skid model, impassable ground, the footprint."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from conftest import CELL_M, WALL_COL, wall_map

from swarm.planning.costmap import (
    BRINK_MARGIN_M,
    FREE,
    IMPASSABLE_TERRAIN,
    NO_TRACTION,
    TOO_STEEP,
    CostMap,
    EndpointError,
    NoPathError,
    build_costmap,
    mode_speeds,
    robot_half_width_m,
)
from swarm.planning.costmap import KEEP_OUT as KEEP_OUT_CODE
from swarm.planning.router import Router
from swarm.robot.terrain import load_library
from swarm.world.beachmap import BeachMap


def test_mode_speeds_one_vectorized_run_cost_per_metre(robot):
    lib = load_library()
    speeds = mode_speeds(lib, robot)
    cost = dict(zip(speeds.names, speeds.cost_per_m, strict=True))
    speed = dict(zip(speeds.names, speeds.speed_mps, strict=True))
    # the fastest dry, passable mode is the reference at exactly 1.0 per metre
    assert cost[speeds.reference_mode] == pytest.approx(1.0)
    assert not lib[speeds.reference_mode].is_water
    assert all(c >= 1.0 - 1e-12 for n, c in cost.items() if lib[n].passable and not lib[n].is_water)
    # cost is time: reference speed over the mode's speed
    assert cost["soft_sand"] == pytest.approx(speeds.reference_speed_mps / speed["soft_sand"])
    # soft sand, vegetation and surf are dearer than hard pack
    for dear in ("soft_sand", "vegetation", "surf"):
        assert cost[dear] > cost["wet_hard_sand"] > 0
    # deep water: no traction, no progress: impassable for ground planning
    assert speed["deep_water"] < 0.05 * speeds.nominal_wheel_speed_mps
    assert math.isinf(cost["deep_water"])


def test_half_width_is_the_wider_of_body_and_wheels(robot):
    assert robot_half_width_m(robot) == pytest.approx(max(robot.width_m, robot.track_width_m) / 2)


def test_reasons_for_impassable_cells(wall_costmap):
    cm = wall_costmap
    assert (cm.reason[:, WALL_COL][cm.terrain[:, WALL_COL] == 2] == IMPASSABLE_TERRAIN).all()
    assert (cm.reason[:3, :] == NO_TRACTION).all()
    # keep-out: exactly the cells whose interior the square (4..9, 14..18) meets
    rows, cols = np.nonzero(cm.reason == KEEP_OUT_CODE)
    assert (rows.min(), rows.max(), cols.min(), cols.max()) == (28, 35, 8, 17)
    assert cm.reason[20, 5] == FREE


def test_footprint_inflation_is_exact(wall_costmap):
    """A cell is blocked iff some point of it is closer than half-width + margin to impassable
    ground or the map edge: brute force over cell squares."""
    cm = wall_costmap
    rows, cols = cm.shape
    imp = np.argwhere(cm.reason != FREE)
    radius = cm.half_width_m + cm.resolution_m / 2
    for r in range(rows):
        for c in range(cols):
            gap = np.hypot(
                np.maximum(np.abs(imp[:, 0] - r) - 1, 0), np.maximum(np.abs(imp[:, 1] - c) - 1, 0)
            ).min()
            edge = min(r, c, rows - 1 - r, cols - 1 - c)  # cells between this one and the edge
            clearance = min(gap, edge) * CELL_M
            assert cm.clearance_m[r, c] == pytest.approx(clearance), (r, c)
            assert cm.blocked[r, c] == (clearance < radius), (r, c)


def test_slope_steeper_than_the_mode_allows_is_impassable(robot):
    lib = load_library()
    limit = lib["soft_sand"].max_climb_slope_deg
    rows, cols = 20, 20
    elevation = np.zeros((rows, cols), dtype=np.float32)
    x = np.arange(cols) * 0.5
    # a ramp a little steeper than soft sand allows in columns 8..11, gentle elsewhere
    steep = math.tan(math.radians(limit + 3))
    gentle = math.tan(math.radians(limit - 5))
    elevation[:] = np.where((x >= 4) & (x < 6), steep, gentle).cumsum() * 0.5
    bm = BeachMap("slope", 0.5, (0.0, 0.0), ("soft_sand",), np.zeros((rows, cols), np.int8), elevation)
    cm = build_costmap(bm, robot)
    too_steep = cm.reason == TOO_STEEP
    assert too_steep.any()
    assert (bm.slope_deg[too_steep] > limit).all()
    assert (bm.slope_deg[~too_steep] <= limit).all()
    with pytest.raises(EndpointError, match=r"slope, steeper than the robot can climb on soft_sand"):
        r, c = np.argwhere(too_steep)[0]
        cm.check_endpoints(cm.center_of(r, c), (1.0, 1.0))


def _gap_m(cells: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Brute force: the gap (cell units) from every cell's square to the nearest of `cells`."""
    r, c = np.indices(shape)
    out = np.full(shape, np.inf)
    for rr, cc in cells:
        out = np.minimum(out, np.hypot(np.maximum(np.abs(r - rr) - 1, 0), np.maximum(np.abs(c - cc) - 1, 0)))
    return out


def test_ground_above_land_too_steep_to_climb_is_kept_a_brink_margin_farther_off(robot):
    """A dune face (steep soft sand rising north, flat on top), a boulder and steep surf (south):
    every cell within the footprint of any impassable cell is blocked, and so is every cell above
    the face (north of it) within the footprint plus `BRINK_MARGIN_M` of it, and no other cell.
    Below the face, beside the boulder and by the steep surf (robots swim in through it) only the
    footprint counts. Brute force over cell squares."""
    cell, rows, cols = 0.5, 50, 30
    lib = load_library()
    terrain = np.full((rows, cols), 1, np.int8)  # wet hard sand
    terrain[:6] = 0  # surf along the south edge
    terrain[18:] = 2  # soft sand: the dune from its foot
    terrain[12, 5] = 3  # a boulder
    y = np.arange(rows) * cell
    grade = np.where(y < 3.0, math.tan(math.radians(lib["surf"].max_climb_slope_deg + 4)), 0.02)
    face = (y >= 10.0) & (y < 13.0)
    grade = np.where(face, math.tan(math.radians(lib["soft_sand"].max_climb_slope_deg + 4)), grade)
    elevation = np.repeat((np.cumsum(grade) * cell)[:, None], cols, axis=1).astype(np.float32)
    classes = ("surf", "wet_hard_sand", "soft_sand", "boulder")
    bm = BeachMap("dune", cell, (0.0, 0.0), classes, terrain, elevation)
    cm = build_costmap(bm, robot)
    steep_sand = (cm.reason == TOO_STEEP) & (terrain == 2)
    assert steep_sand.any() and ((cm.reason == TOO_STEEP) & (terrain == 0)).any()
    top = np.argwhere(steep_sand)[:, 0].max()

    radius = cm.half_width_m + cm.resolution_m / 2
    r, c = np.indices(cm.shape)
    edge = np.minimum.reduce([r, c, rows - 1 - r, cols - 1 - c])
    near_any = np.minimum(_gap_m(np.argwhere(cm.reason != FREE), cm.shape), edge) * cell < radius
    brink = (_gap_m(np.argwhere(steep_sand), cm.shape) * cell < radius + BRINK_MARGIN_M) & (r > top)
    assert (cm.blocked == (near_any | brink)).all()
    assert (brink & ~near_any).any()  # the brink reaches past the footprint above the face
    below = (_gap_m(np.argwhere(steep_sand), cm.shape) * cell < radius + BRINK_MARGIN_M) & (r < top)
    assert (below & ~near_any).any() and not cm.blocked[below & ~near_any].any()
    boulder_gap = _gap_m(np.array([[12, 5]]), cm.shape) * cell
    beside_boulder = (boulder_gap >= radius) & (boulder_gap < radius + BRINK_MARGIN_M)
    assert beside_boulder.any() and not cm.blocked[beside_boulder].any()
    assert (build_costmap(bm, robot, brink_margin_m=0.0).blocked == near_any).all()

    # a point on the brink, clear of the footprint: the one line says why, and a robot may still
    # be sent there (to mark a mine), driving in off the route's end
    row = int(np.flatnonzero(brink[:, 20] & ~near_any[:, 20])[0])
    point = cm.center_of(row, 20)
    assert cm.on_brink(*point) and not cm.on_brink(*cm.center_of(top + 12, 20))
    with pytest.raises(EndpointError, match=r"keeps the centre .* from ground too steep to climb") as err:
        cm.check_endpoints(point, cm.center_of(top + 12, 20))
    assert "soft_sand on a" in str(err.value) and "\n" not in str(err.value)
    route = Router(cm, seed=0).route(np.array(cm.center_of(top + 12, 20)), np.array(point))
    np.testing.assert_array_equal(route[-1], point)
    assert cm.is_free(route[:-1, 0], route[:-1, 1]).all()
    # a route handed on with its brink point twice (a taker's piece) stitches to it once
    start = np.array(cm.center_of(top + 12, 20))
    pts, where = Router(cm, seed=0).stitch(np.array([start, point, point]))
    np.testing.assert_array_equal(pts[-1], point)
    assert where[2] == where[1] == len(pts) - 1


def test_segment_cost_is_the_exact_integral(robot):
    rng = np.random.default_rng(3)
    terrain = rng.integers(0, 2, size=(40, 60)).astype(np.int8)
    bm = BeachMap(
        "mix", 0.5, (10.0, -5.0), ("wet_hard_sand", "soft_sand"), terrain, np.zeros((40, 60), np.float32)
    )
    cm = build_costmap(bm, robot)
    p0 = rng.uniform((10, -5), (40, 15), size=(200, 2))
    p1 = np.clip(p0 + rng.normal(0, 6, size=(200, 2)), (10, -5), (40 - 1e-9, 15 - 1e-9))
    p1[:5] = p0[:5] + np.array([1.0, 0.0])  # axis-aligned
    p0[5], p1[5] = (10.5, -4.5), (20.5, 5.5)  # through cell corners
    exact = cm.segments_cost(p0, p1)
    fast = cm.segment_cost_function()
    for a, b, e in zip(p0, p1, exact, strict=True):
        n = 20000
        t = (np.arange(n) + 0.5) / n
        pts = a + t[:, None] * (b - a)
        r, c = cm.cell_of(pts[:, 0], pts[:, 1])
        dense = cm.cost_per_m[r, c].astype(float).mean() * np.hypot(*(b - a))
        assert e == pytest.approx(dense, rel=2e-3, abs=1e-9)
        assert fast(a[0], a[1], b[0], b[1]) == pytest.approx(e, rel=1e-12, abs=1e-12)


def _numpy_traverse(cm, p0, p1):
    """The vectorized numpy `_walk_segments` replaced, kept as its reference: every cell each
    segment crosses, with the length inside it, as (segment, row, col, length) pieces."""
    p0 = np.asarray(p0, dtype=np.float64).reshape(-1, 2)
    p1 = np.asarray(p1, dtype=np.float64).reshape(-1, 2)
    n = len(p0)
    g0 = (p0 - cm.origin_m) / cm.cell_m
    g1 = (p1 - cm.origin_m) / cm.cell_m
    d = g1 - g0
    lo = np.floor(np.minimum(g0, g1)).astype(np.int64)
    hi = np.ceil(np.maximum(g0, g1)).astype(np.int64)
    counts = np.maximum(hi - lo - 1, 0)
    pieces = [np.arange(n, dtype=np.int64), np.arange(n, dtype=np.int64)]
    params = [np.zeros(n), np.ones(n)]
    for axis in (0, 1):
        c = counts[:, axis]
        total = int(c.sum())
        if not total:
            continue
        seg = np.repeat(np.arange(n, dtype=np.int64), c)
        first = np.repeat(np.cumsum(c) - c, c)
        line = np.repeat(lo[:, axis] + 1, c) + (np.arange(total) - first)
        pieces.append(seg)
        params.append((line - g0[seg, axis]) / d[seg, axis])
    seg = np.concatenate(pieces)
    t = np.clip(np.concatenate(params), 0.0, 1.0)
    order = np.lexsort((t, seg))
    seg, t = seg[order], t[order]
    same = seg[1:] == seg[:-1]
    s, ta, tb = seg[:-1][same], t[:-1][same], t[1:][same]
    mid = 0.5 * (ta + tb)
    xy = g0[s] + mid[:, None] * d[s]
    col = np.clip(np.floor(xy[:, 0]).astype(np.intp), 0, cm.shape[1] - 1)
    row = np.clip(np.floor(xy[:, 1]).astype(np.intp), 0, cm.shape[0] - 1)
    return s, row, col, (tb - ta) * np.hypot(d[s, 0], d[s, 1]) * cm.cell_m


def test_segment_walks_are_the_numpy_pieces_float_for_float(wall_costmap):
    """`segments_cost` and `segments_free` (one compiled pass) give exactly what the vectorized
    numpy pieces give: the cost float for float (the planner's objective and the sim's routes
    depend on it), on short and map-long segments, axis-aligned ones, ones through cell corners,
    zero-length ones and ones leaving the map."""
    cm = wall_costmap
    rng = np.random.default_rng(11)
    xmin, ymin, xmax, ymax = cm.bounds_m
    p0 = rng.uniform((xmin - 2, ymin - 2), (xmax + 2, ymax + 2), size=(400, 2))
    p1 = p0 + rng.normal(0.0, 4.0, size=(400, 2)) * rng.choice([0.1, 1.0, 10.0], size=(400, 1))
    p1[:20, 1] = p0[:20, 1]  # along x
    p1[20:40, 0] = p0[20:40, 0]  # along y
    p1[40:50] = p0[40:50]  # no length
    corners = cm.origin_m + cm.cell_m * rng.integers(0, 10, size=(20, 2)).astype(float)
    p0[50:70], p1[50:70] = corners, corners + cm.cell_m * np.array([3.0, 2.0])  # through corners
    # across the whole map, along one axis then the other and both ways: many crossings each
    across = [
        ((xmin, ymin), (xmax, ymin + 0.1)),
        ((xmax, ymin + 0.3), (xmin, ymin + 0.3)),
        ((xmin + 0.2, ymax), (xmin + 0.2, ymin)),
        ((xmin, ymin), (xmax, ymax)),
        ((xmax, ymax), (xmin, ymin)),
        ((xmin, ymax), (xmax, ymin)),
    ]
    p0[70:76], p1[70:76] = np.array([a for a, _ in across]), np.array([b for _, b in across])
    s, row, col, length = _numpy_traverse(cm, p0, p1)
    pieces = np.zeros(len(length))
    np.multiply(length, cm.cost_per_m[row, col], out=pieces, where=length > 0)
    cost = np.bincount(s, weights=pieces, minlength=len(p0))
    crossed = np.bincount(s, weights=cm.blocked[row, col] & (length > 0), minlength=len(p0)) > 0
    free = ~crossed & cm.is_free(p0[:, 0], p0[:, 1]) & cm.is_free(p1[:, 0], p1[:, 1])
    assert np.array_equal(cm.segments_cost(p0, p1), cost)
    assert np.array_equal(cm.segments_free(p0, p1), free)
    assert 50 < free.sum() < 350 and np.isinf(cost).sum() < len(cost)  # both answers, many times
    nowhere = np.array([[np.nan, 1.0], [2.0, np.inf]])  # an end off every grid: no walk, not free
    assert not cm.segments_free(nowhere, p0[:2]).any() and np.isnan(cm.segments_cost(nowhere, p0[:2])).all()


def test_point_problems_are_one_clear_line(wall_costmap):
    cm = wall_costmap
    cases = {
        (40.0, 5.0): "outside the map 'wall'",
        (15.2, 5.0): "is on boulder, impassable terrain",
        (6.0, 16.0): "inside keep-out zone 'minefield'",
        (14.8, 5.25): "too close to boulder (impassable) at (15.25, 5.25) for the robot's footprint",
        (5.0, 0.5): "deep_water, where the robot makes no progress",
        (9.2, 16.0): "too close to keep-out zone 'minefield'",
        (20.0, 19.9): "too close to the map edge",
    }
    for point, expected in cases.items():
        with pytest.raises(EndpointError) as err:
            cm.check_endpoints(point, (25.0, 10.0))
        message = str(err.value)
        assert message.startswith(f"start ({point[0]:g}, {point[1]:g}) ")
        assert expected in message
        assert "\n" not in message
    with pytest.raises(EndpointError, match=r"^goal \(15\.2, 5\) is on boulder"):
        cm.check_endpoints((3.0, 5.0), (15.2, 5.0))
    assert cm.point_problem(3.0, 5.0) is None


def test_no_path_when_the_wall_has_no_gap(robot):
    cm = build_costmap(wall_map(gap=False), robot)
    with pytest.raises(
        NoPathError, match=r"^no path from start \(3, 4\) to goal \(27, 4\): impassable ground"
    ):
        cm.check_endpoints((3.0, 4.0), (27.0, 4.0))


def test_keep_out_line_blocks_even_along_grid_lines(robot):
    from shapely.geometry import LineString

    from swarm.world.beachmap import Region

    fence = LineString([(0.0, 10.0), (30.0, 10.0)])  # exactly on a grid line
    bm = wall_map(keep_out=False)
    bm = BeachMap(
        bm.name,
        bm.cell_m,
        bm.origin_m,
        bm.terrain_classes,
        bm.terrain,
        bm.elevation_m,
        {"fence": Region("fence", "keep_out", fence)},
    )
    cm = build_costmap(bm, robot)
    assert (cm.reason[19:21, :] == KEEP_OUT_CODE).all()
    with pytest.raises(NoPathError):
        cm.check_endpoints((3.0, 5.0), (3.0, 15.0))


def test_free_at_and_cell_at_are_is_free_and_cell_of_point_by_point(wall_costmap: CostMap) -> None:
    """The scalar test the simulator asks of one robot gives `is_free`'s answer everywhere: inside,
    on the map's edges and cell lines, just outside, and at NaN."""
    cm = wall_costmap
    x0, y0, x1, y1 = cm.bounds_m
    rng = np.random.default_rng(5)
    grid_lines = np.arange(x0 - 1, x1 + 1, cm.cell_m / 2)
    xs = np.concatenate([rng.uniform(x0 - 3, x1 + 3, 3000), grid_lines, [x0, x1, np.nan]])
    inside_y = rng.uniform(y0, y1, len(grid_lines))
    ys = np.concatenate([rng.uniform(y0 - 3, y1 + 3, 3000), inside_y, [y1, y0, y0]])
    with np.errstate(invalid="ignore"):  # NaN's cell is nonsense; its inside test says no
        want = cm.is_free(xs, ys)
    got = np.array([cm.free_at(float(x), float(y)) for x, y in zip(xs, ys, strict=True)])
    np.testing.assert_array_equal(got, want)
    assert want.any() and not want.all()
    rows, cols = cm.cell_of(xs[:-1], ys[:-1])
    cells = np.array([cm.cell_at(float(x), float(y)) for x, y in zip(xs[:-1], ys[:-1], strict=True)])
    np.testing.assert_array_equal(cells, np.column_stack([rows, cols]))


def test_a_leg_grazing_blocked_ground_is_driven_along_its_edge(robot):
    """A search lane under a shallow tongue of driftwood (full_conops' top lanes graze the
    vegetation's margin so for tens of metres): the stitched route keeps to the tongue's edge,
    on free ground, so the robot sweeps the lane's free ground up to the edge, where an OMPL
    path round the whole stretch drove metres inside it. A lagoon in the middle of a leg, too
    wide to hug, is still routed round."""
    rows, cols = 60, 200
    yy, xx = np.mgrid[0:rows, 0:cols] + 0.5
    terrain = np.zeros((rows, cols), np.int8)
    terrain[yy >= 40.0 - 8.0 * np.clip(1.0 - np.abs(xx - 100.0) / 80.0, 0.0, 1.0)] = 1  # apex y = 32 m
    bm = BeachMap(
        "band", 1.0, (0.0, 0.0), ("wet_hard_sand", "driftwood"), terrain, np.zeros((rows, cols), np.float32)
    )
    cm = build_costmap(bm, robot)
    a, b = np.array([10.5, 35.5]), np.array([190.5, 35.5])
    pts, where = Router(cm, seed=0).stitch(np.array([a, b]))
    assert where.tolist() == [0, len(pts) - 1]
    assert cm.is_free(pts[:, 0], pts[:, 1]).all() and cm.segments_free(pts[:-1], pts[1:]).all()
    route = shapely.LineString(pts)
    lane = np.linspace(a, b, 721)
    on_free = cm.is_free(lane[:, 0], lane[:, 1])
    assert not on_free.all()

    def edge_y(x: float) -> float:  # the highest free cell centre of the column
        c = int(x)
        return cm.center_of(int(np.flatnonzero(~cm.blocked[:, c])[-1]), c)[1]

    # every free point of the lane is on the route, and where the lane is blocked the route
    # keeps to the edge of the free ground, within a cell
    assert shapely.distance(route, shapely.points(lane[on_free])).max() < 0.5
    beside = shapely.points([(x, edge_y(x)) for x in lane[~on_free, 0]])
    assert shapely.distance(route, beside).max() < 1.0

    # a lagoon of driftwood 40 m across in the middle of a leg: round it, never through it
    terrain = np.zeros((rows, cols), np.int8)
    yy, xx = np.mgrid[0:rows, 0:cols]
    terrain[(xx - 100) ** 2 + (yy - 30) ** 2 < 20**2] = 1
    bm = BeachMap(
        "ring", 1.0, (0.0, 0.0), ("wet_hard_sand", "driftwood"), terrain, np.zeros((rows, cols), np.float32)
    )
    cm = build_costmap(bm, robot)
    pts, _ = Router(cm, seed=0).stitch(np.array([[10.5, 30.5], [190.5, 30.5]]))
    assert cm.is_free(pts[:, 0], pts[:, 1]).all()  # OMPL's path, checked at its own resolution
    assert np.hypot(*np.diff(pts, axis=0).T).sum() < 230.0  # round one side, not a wander
