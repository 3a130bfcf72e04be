"""Route following over many robots: the batched shortcuts agree with the plain per-robot rules."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree
from shapely.geometry import LineString, Point

from swarm.robot.driving import CAPTURE_M, FINAL_CAPTURE_M, LOOKAHEAD_M, PASS_CROSS_TRACK_M
from swarm.sim.hazards import _armed_near, contact_reach2
from swarm.sim.routes import Routes, pairwise_sum
from swarm.sim.runview import AVOID_MINE_M


def _random_routes(rng: np.random.Generator, n: int) -> tuple[Routes, np.ndarray]:
    routes = Routes(n)
    for i in range(n):
        k = int(rng.integers(0, 6))
        if k:
            routes.set(i, rng.uniform(0.0, 40.0, size=(k, 2)))
            routes.cursor[i] = routes.start[i] + int(rng.integers(0, k + 1))
    return routes, rng.uniform(0.0, 40.0, size=(n, 2))


def _targets(routes: Routes, xy: np.ndarray) -> np.ndarray:
    """The steering rule as first written in numpy: `LOOKAHEAD_M` ahead of the projection on the
    current leg, capped at its end; the robot's own position when its route is done."""
    out = xy.copy()
    idx = np.flatnonzero(routes.cursor < routes.end)
    cur_index = routes.cursor[idx]
    cur = routes.points[cur_index]
    prev = routes.points[np.where(cur_index > routes.start[idx], cur_index - 1, cur_index)]
    leg = cur - prev
    length = np.hypot(leg[:, 0], leg[:, 1])
    unit = leg / np.maximum(length, 1e-12)[:, None]
    rel = xy[idx] - prev
    along = rel[:, 0] * unit[:, 0] + rel[:, 1] * unit[:, 1]
    ahead = np.clip(along, 0.0, length) + LOOKAHEAD_M
    on_leg = (length > 0) & (ahead < length)
    frac = np.where(on_leg, ahead / np.maximum(length, 1e-12), 1.0)
    out[idx] = np.where(on_leg[:, None], prev + (cur - prev) * frac[:, None], cur)
    return out


def test_steer_points_are_the_targets_and_the_ends_of_finished_routes() -> None:
    rng = np.random.default_rng(3)
    for _ in range(20):
        routes, xy = _random_routes(rng, 30)
        done = routes.done()
        goal = xy.copy()
        has = routes.end > routes.start
        goal[has] = routes.points[routes.end[has] - 1]
        want = np.where(done[:, None], goal, _targets(routes, xy))
        assert np.array_equal(routes.steer_points(xy), want)


def _advance_every_robot(routes: Routes, xy: np.ndarray, mask: np.ndarray) -> None:
    """The waypoint rule as first written: every robot of `mask` looked at again in each round."""
    for _ in range(4):
        idx = np.flatnonzero(mask & (routes.cursor < routes.end))
        if not len(idx):
            return
        cur = routes.cursor[idx]
        wp = routes.points[cur]
        final = cur == routes.end[idx] - 1
        hit = np.hypot(*(wp - xy[idx]).T) < np.where(final, FINAL_CAPTURE_M, CAPTURE_M)
        prev = np.where((cur > routes.start[idx])[:, None], routes.points[np.maximum(cur - 1, 0)], wp)
        leg = wp - prev
        length = np.hypot(leg[:, 0], leg[:, 1])
        unit = leg / np.maximum(length, 1e-12)[:, None]
        rel = xy[idx] - prev
        along = rel[:, 0] * unit[:, 0] + rel[:, 1] * unit[:, 1]
        cross = unit[:, 0] * rel[:, 1] - unit[:, 1] * rel[:, 0]
        hit |= ~final & (length > 0) & (along >= length) & (np.abs(cross) <= PASS_CROSS_TRACK_M)
        hit |= ~final & (length == 0) & (cur > routes.start[idx])  # a repeated waypoint
        if not hit.any():
            return
        routes.cursor[idx[hit]] += 1


def test_advance_passes_the_waypoints_the_every_robot_rule_passes() -> None:
    rng = np.random.default_rng(4)
    for _ in range(30):
        n = 30
        a, b = Routes(n), Routes(n)
        for i in range(n):  # short legs along a line, so a robot may pass several in one step
            k = int(rng.integers(0, 8))
            if k:
                pts = np.cumsum(rng.uniform(0.2, 1.5, size=(k, 2)), axis=0)
                a.set(i, pts)
                b.set(i, pts)
        xy = rng.uniform(0.0, 8.0, size=(n, 2))
        mask = rng.random(n) < 0.8
        for _ in range(3):
            _advance_every_robot(a, xy, mask)
            b.advance(xy, mask)
            assert np.array_equal(a.cursor, b.cursor)
            xy = xy + rng.normal(0.0, 1.0, size=(n, 2))


def test_advance_decides_as_the_square_roots_on_the_boundaries() -> None:
    """Robots on the capture circles and on the line through a leg's end, a rounding either side:
    the shortcut on squared distances decides as `hypot` and the leg's frame do."""
    rng = np.random.default_rng(8)
    n = 400
    a, b = Routes(n), Routes(n)
    xy = np.empty((n, 2))
    for i in range(n):
        pts = np.cumsum(rng.uniform(0.5, 3.0, size=(3, 2)), axis=0)
        a.set(i, pts)
        b.set(i, pts)
        a.cursor[i] = b.cursor[i] = a.start[i] + int(rng.integers(1, 3))
        cur = pts[a.cursor[i] - a.start[i]]
        final = a.cursor[i] == a.end[i] - 1
        if i % 2:  # on its waypoint's capture circle
            radius = FINAL_CAPTURE_M if final else CAPTURE_M
            angle = rng.uniform(0.0, 2.0 * np.pi)
            xy[i] = cur + radius * np.array([np.cos(angle), np.sin(angle)])
        else:  # level with the end of its leg, beside it
            leg = cur - pts[a.cursor[i] - a.start[i] - 1]
            normal = np.array([-leg[1], leg[0]]) / np.hypot(*leg)
            xy[i] = cur + rng.uniform(-1.5, 1.5) * PASS_CROSS_TRACK_M * normal
        xy[i] = np.nextafter(xy[i], xy[i] + rng.choice([-1.0, 0.0, 1.0], size=2))
    mask = np.ones(n, bool)
    before = a.cursor.copy()
    _advance_every_robot(a, xy, mask)
    b.advance(xy, mask)
    assert np.array_equal(a.cursor, b.cursor)
    assert 0 < np.count_nonzero(a.cursor > before) < n  # some passed, some did not


def test_may_pass_holds_every_robot_steer_clear_would_re_lay() -> None:
    rng = np.random.default_rng(5)
    for _ in range(30):
        routes, xy = _random_routes(rng, 25)
        point = rng.uniform(0.0, 40.0, size=2)
        robots = np.arange(25)
        flagged = set(routes.may_pass(robots, xy, point, 1.0).tolist())
        for i in robots:
            before = (routes.start[i], routes.end[i])
            routes.steer_clear(int(i), xy[i], point[None], 1.0)
            if (routes.start[i], routes.end[i]) != before:
                assert i in flagged


def test_the_armed_mine_check_is_true_wherever_the_tree_finds_a_contact() -> None:
    """The dense check that lets the mine contacts skip a run (`_armed_near` at `contact_reach2`)
    never misses a contact the k-d tree finds, robots exactly at the radius included; and a mine
    that can no longer go off is never a contact."""
    rng = np.random.default_rng(6)
    for _ in range(200):
        points = rng.uniform(0.0, 5.0, size=(int(rng.integers(1, 8)), 2))
        xy = rng.uniform(0.0, 5.0, size=(int(rng.integers(1, 6)), 2))
        r = float(rng.uniform(0.05, 1.0))
        if rng.random() < 0.3:  # a robot exactly at the radius of a point
            xy[0] = points[0] + [r, 0.0]
        sel, runs = np.arange(len(xy)), np.zeros(len(xy), np.intp)
        live = np.ones((1, len(points)), bool)
        near = _armed_near(xy, sel, runs, points[None], live, np.array([contact_reach2(r)]))
        found = cKDTree(points).query_ball_point(xy, r, return_length=True) > 0
        assert (near | ~found).all()
        assert not _armed_near(xy, sel, runs, points[None], ~live, np.array([contact_reach2(r)])).any()


def test_the_length_left_is_numpys_sum_of_the_legs_float_for_float() -> None:
    """`remaining_m` decides whether a marker makes it before a blast: it must be the very float
    the per-robot numpy (`np.hypot(legs).sum()`, pairwise summation) gave, on routes from none to
    hundreds of legs (past numpy's 128-element blocks and their halving)."""
    rng = np.random.default_rng(3)
    routes = Routes(60)
    for i in range(60):
        k = int(rng.integers(0, 700))
        routes.set(i, rng.uniform(-50.0, 900.0, size=(k, 2)))
        routes.cursor[i] = routes.start[i] + int(rng.integers(0, max(k // 3, 1)))
    xy = rng.uniform(0.0, 100.0, size=(60, 2))
    who = rng.permutation(60)[:45]
    got = routes.remaining_m(who, xy[who])
    for k, i in enumerate(who):
        rest = routes.remaining(i)
        legs = np.diff(np.vstack([xy[i][None], rest]), axis=0)
        assert got[k] == float(np.hypot(legs[:, 0], legs[:, 1]).sum())
    for n in [*range(300), 1000, 1031, 5000, 70_001]:
        a = rng.uniform(0.0, 10.0, size=n) * 10.0 ** rng.uniform(-3, 3)
        assert 0.0 + pairwise_sum(a, 0, n) == a.sum()
    assert len(routes.remaining_m(np.empty(0, np.intp), np.empty((0, 2)))) == 0


def test_the_rest_of_a_track_is_all_of_it_then_from_where_the_robot_stands_then_nothing() -> None:
    """A route to the track's first point (index 2) and along it: before the robot reaches the
    track, all of the track; on it, from where it stands (or the leg's start) on; driven to its
    end, nothing (a searcher lost after its track hands out no work)."""
    routes = Routes(1)
    pts = np.array([[0.0, 0.0], [5.0, 0.0], [10.0, 0.0], [10.0, 50.0], [12.0, 50.0], [12.0, 0.0]])
    routes.set(0, pts, sensing_from=2)
    here = np.array([10.0, 20.0])
    for cursor in (0, 1, 2):  # on its way, then on the leg into the track's first point
        routes.cursor[0] = cursor
        np.testing.assert_array_equal(routes.remaining_track(0, here), pts[2:])
    routes.cursor[0] = 3  # on the first lane, 20 m up it
    np.testing.assert_array_equal(routes.remaining_track(0, here), np.vstack([here, pts[3:]]))
    np.testing.assert_array_equal(routes.remaining_track(0), pts[2:])
    routes.cursor[0] = len(pts)
    assert routes.remaining_track(0, here).shape == (0, 2)
    routes.set(0, pts[:2])  # a route with no track
    assert routes.remaining_track(0, here).shape == (0, 2)


def test_a_searcher_side_stepping_on_its_track_leaves_the_leg_to_the_side_step() -> None:
    """20 m up its first lane a searcher side-steps a mine 40 m up: the re-laid route starts where
    it stands on the lane, so the rest of its track still starts there (it used to start at the
    side-step, and a searcher lost before it left those metres of lane to nobody). On its way to
    the lane, the track still starts at the lane's first point."""
    pts = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 100.0], [12.0, 100.0]])
    here, mine = np.array([10.0, 20.0]), np.array([[10.5, 40.0]])
    routes = Routes(1)
    routes.set(0, pts, sensing_from=1)
    routes.cursor[0] = 2  # on the lane
    whole = routes.remaining_track(0, here)
    routes.steer_clear(0, here, mine, 3.0)
    rest = routes.remaining_track(0, here)
    np.testing.assert_array_equal(rest[0], here)
    assert len(rest) == len(whole) + 2  # the two side-step points
    np.testing.assert_array_equal(rest[-2:], pts[-2:])
    np.testing.assert_array_equal(routes.remaining_track(0), rest)  # the route starts on the lane
    routes.cursor[0] += 1  # on to the first side-step point: from where it stands, as on any leg
    np.testing.assert_array_equal(routes.remaining_track(0, here)[1:], rest[1:])
    routes.set(0, pts, sensing_from=1)  # on its way to the lane
    routes.steer_clear(0, np.array([5.0, 0.0]), np.array([[7.0, 0.5]]), 1.0)
    track = routes.remaining_track(0, here)
    np.testing.assert_array_equal(track[0], pts[1])
    np.testing.assert_array_equal(track[-1], pts[-1])
    assert len(track) == len(pts) - 1


@pytest.mark.parametrize("ahead", [0.3, 0.7, 1.0])
def test_a_mine_found_just_ahead_is_side_stepped_from_where_the_robot_stands(ahead: float) -> None:
    """A pass is decided within four trigger radii (1 m) of the mine, so a searcher on its lane
    learns of a mine just ahead of it. The side-step's first point, abreast of the robot on the
    far side, used to lie within the capture radius: the robot passed it at once and steered for
    the second, cutting the corner from a heading straight at the mine (full_conops, 100 runs: 14
    robots lost to mines they had found a moment before, 3 since). It now lies beyond the
    capture radius, so the robot steers out to it first, and its way on never comes nearer the
    mine than where it stands."""
    routes = Routes(1)
    routes.set(0, np.array([[0.0, 0.0], [100.0, 0.0]]), sensing_from=0)
    routes.cursor[0] = 1
    here = np.array([[30.0, 0.05]])
    mine = np.array([[30.0 + ahead, 0.1]])
    routes.steer_clear(0, here[0], mine, AVOID_MINE_M)
    routes.advance(here, np.array([True]))
    rest = routes.remaining(0)
    assert np.hypot(*(rest[0] - here[0])) >= CAPTURE_M  # the side-step's first point is still ahead of it
    way = LineString(np.vstack([here, rest]))
    near = float(np.hypot(*(mine[0] - here[0])))
    assert way.distance(Point(mine[0])) == pytest.approx(near, abs=1e-9)
    assert LineString(rest).distance(Point(mine[0])) >= min(near, AVOID_MINE_M) - 1e-9


def test_a_route_re_laid_around_a_find_keeps_the_robot_on_its_lane() -> None:
    """A searcher pushed 2 m off a 400 m lane when a mine is found far ahead: its re-laid route
    starts abreast of it on the lane, so it steers back onto the lane (pure pursuit on the leg,
    `LOOKAHEAD_M` ahead), not for the side-step 300 m on, a line that runs metres off the lane it
    was to sweep (full_conops: 4-5 m, into a boulder's ring, stuck in 3 of 32 runs)."""
    lane = np.array([[0.0, 0.0], [400.0, 0.0], [400.0, 1.0], [0.0, 1.0]])
    routes = Routes(1)
    routes.set(0, lane, sensing_from=0)
    routes.cursor[0] = 1
    here = np.array([[50.0, -2.0]])
    routes.steer_clear(0, here[0], np.array([[350.0, -0.3]]), 1.0)
    np.testing.assert_array_equal(routes.remaining(0)[0], [50.0, 0.0])  # abreast, on the lane
    routes.advance(here, np.array([True]))
    aim = routes.steer_points(here)[0]
    assert aim[1] == pytest.approx(0.0) and 50.0 <= aim[0] <= 50.0 + LOOKAHEAD_M + 1e-9
    # back on the lane, it pursues the lane up to the side-step
    on = np.array([[50.0, 0.0]])
    routes.advance(on, np.array([True]))
    aim = routes.steer_points(on)[0]
    assert aim == pytest.approx([50.0 + LOOKAHEAD_M, 0.0], abs=0.01)
    assert routes.in_track()[0]  # and all of it is still its track
    np.testing.assert_array_equal(routes.remaining_track(0)[-3:], lane[1:])


def test_a_route_whose_track_starts_at_its_first_point_is_on_its_track() -> None:
    """A taker sent to a piece of track that starts where it stands gets such a route; until it is
    driven to its end the robot is on its track. A route without a track never is."""
    routes = Routes(2)
    pts = np.array([[0.0, 0.0], [0.0, 50.0], [2.0, 50.0]])
    routes.set(0, pts, sensing_from=0)
    routes.set(1, pts)
    for cursor in range(len(pts)):
        routes.cursor[:] = routes.start + cursor
        np.testing.assert_array_equal(routes.in_track(), [True, False])
    routes.cursor[:] = routes.end
    np.testing.assert_array_equal(routes.in_track(), [False, False])


def test_afloat_a_robot_set_off_its_leg_steers_along_the_leg_s_line_and_passes_it_abeam() -> None:
    """A leg straight ashore (north) and a robot the longshore current has set 20 m east of it. On
    its wheels it steers for the leg 1.5 m ahead of its projection, square across; afloat, for a
    point as far ahead as it is off the leg (a 45 degree closing course), on past the leg's end but
    the route's last, and it passes the leg's end once abeam of it, however far off."""
    route = np.array([[0.0, 0.0], [0.0, 50.0], [0.0, 100.0]])
    routes = Routes(2)
    routes.set(0, route)
    routes.set(1, route)
    routes.cursor[:] = routes.start + 1
    xy = np.array([[20.0, 10.0], [20.0, 10.0]])
    afloat = np.array([True, False])
    target = routes.steer_points(xy, afloat)
    np.testing.assert_allclose(target, [[0.0, 30.0], [0.0, 11.5]])
    d = target[0] - xy[0]
    assert np.degrees(np.arctan2(d[1], -d[0])) == pytest.approx(45.0)
    # near the leg's end: on along its line afloat, its end on wheels
    xy = np.array([[20.0, 49.0], [20.0, 49.0]])
    np.testing.assert_allclose(routes.steer_points(xy, afloat), [[0.0, 69.0], [0.0, 50.0]])
    # abeam of the end, 20 m off: afloat it is passed, on wheels the robot goes back for it
    xy = np.array([[20.0, 51.0], [20.0, 51.0]])
    routes.advance(xy, np.ones(2, bool), afloat)
    assert (routes.cursor - routes.start).tolist() == [2, 1]
    # on the route's last leg the last point is where it steers afloat too
    np.testing.assert_allclose(routes.steer_points(np.array([[20.0, 90.0]] * 2), afloat)[0], [0.0, 100.0])
    # close to the leg, afloat or not, the lookahead is the same 1.5 m
    near = np.array([[0.5, 60.0], [0.5, 60.0]])
    routes.cursor[:] = routes.start + 2
    np.testing.assert_allclose(routes.steer_points(near, afloat), [[0.0, 61.5], [0.0, 61.5]])


def test_a_waypoint_repeating_the_one_before_is_passed_with_it() -> None:
    """Paths joined end to start repeat their joint (a sea leg's last point is its ground path's
    first): a robot past the joint by the pass rule, not within the capture radius, went back for
    the repeat (and afloat, across the current); it is passed with the joint."""
    routes = Routes(1)
    routes.set(0, np.array([[0.0, 0.0], [0.0, 50.0], [0.0, 50.0], [0.0, 100.0]]))
    routes.cursor[0] = routes.start[0] + 1
    routes.advance(np.array([[1.5, 51.0]]), np.ones(1, bool))
    assert routes.cursor[0] - routes.start[0] == 3
