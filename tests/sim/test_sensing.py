"""Mine detection: straight passes reproduce each lateral-range curve, a lawnmower at spacing S
reproduces the sweep-width coverage formulas, false alarms follow their Poisson rate, and mines
already found or gone are not reported again.

Statistical checks use 4-sigma bounds (binomial or Poisson): a correct implementation fails one
with chance < 1e-4; the seeds are fixed, so the outcome is reproducible."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree
from shapely.geometry import box

from swarm.mission.budget import parallel_sweep_detection
from swarm.mission.schema import LateralRange, Sensor
from swarm.planning.coverage import detection_probability
from swarm.planning.detection import INVERSE_CUBE_FLOOR, inverse_cube_look
from swarm.sim import pair_kernels
from swarm.sim.mines import MineField
from swarm.sim.sensing import (
    Detection,
    MineSensor,
    lateral_range_curve,
    max_range_m,
)

COOKIE = Sensor(model="cookie_cutter", sweep_width_m=4.0)
CUBE = Sensor(model="inverse_cube", sweep_width_m=2.0)
RANDOM = Sensor(model="random_search", sweep_width_m=4.0)
TABLE = Sensor(
    model="inverse_cube",
    lateral_range=LateralRange(range_m=[0.0, 1.0, 3.0, 4.0, 6.0], probability=[0.9, 0.8, 0.3, 0.0, 0.0]),
)


def _binomial_ok(hits: int, trials: int, p: float) -> bool:
    return abs(hits / trials - p) <= 4.0 * math.sqrt(p * (1.0 - p) / trials) + 1e-12


def _drive(
    sensor: MineSensor,
    start: np.ndarray,
    velocity: np.ndarray,
    steps: int,
    rng: np.random.Generator,
    sensing: np.ndarray | None = None,
) -> list[Detection]:
    """Move every robot `steps` times by `velocity` (n, 2) per step, sensing all the way."""
    n = len(start)
    sensing = np.ones(n, bool) if sensing is None else sensing
    step_m = np.linalg.norm(velocity, axis=1)
    found: list[Detection] = []
    xy = start.copy()
    for k in range(steps + 1):
        found += sensor.update(xy, sensing, step_m if k else np.zeros(n), float(k), rng)
        xy = xy + velocity
    return found


# the curves ------------------------------------------------------------------------------------


def test_lateral_range_curves_and_their_ranges() -> None:
    x = np.array([0.0, 1.0, 1.999, 2.0, 2.001, -1.5, 10.0])
    np.testing.assert_array_equal(lateral_range_curve(COOKIE)(x), [1, 1, 1, 1, 0, 1, 0])
    np.testing.assert_array_equal(lateral_range_curve(RANDOM)(x), lateral_range_curve(COOKIE)(x))
    assert max_range_m(COOKIE) == max_range_m(RANDOM) == 2.0
    w = CUBE.width_m
    with np.errstate(divide="ignore"):
        koopman = 1.0 - np.exp(-(w**2) / (4 * math.pi * x**2))
    np.testing.assert_allclose(lateral_range_curve(CUBE)(x), koopman)
    r = max_range_m(CUBE)
    assert lateral_range_curve(CUBE)(np.array([r]))[0] == pytest.approx(INVERSE_CUBE_FLOOR, rel=1e-9)
    assert r / w == pytest.approx(8.92, abs=0.01)  # R / W = 1 / sqrt(-4 pi ln(1 - 1e-3))
    table = lateral_range_curve(TABLE)
    np.testing.assert_allclose(
        table(np.array([0.0, 0.5, 2.0, -2.0, 3.5, 4.0, 7.0])), [0.9, 0.85, 0.55, 0.55, 0.15, 0, 0]
    )
    assert max_range_m(TABLE) == 4.0  # p is 0 from 4 m on


@pytest.mark.parametrize("sensor", [COOKIE, CUBE, TABLE], ids=["cookie_cutter", "inverse_cube", "table"])
def test_a_lateral_range_curve_pickles_to_the_same_curve(sensor: Sensor) -> None:
    """An environment holds its sensor's curve: a closure made pickling mine_clear's env fail."""
    import pickle

    x = np.linspace(-12.0, 12.0, 97)
    copy = pickle.loads(pickle.dumps(lateral_range_curve(sensor)))
    np.testing.assert_array_equal(copy(x), lateral_range_curve(sensor)(x))


# straight passes ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("sensor", "offsets"),
    [
        (COOKIE, [0.0, 1.5, 1.99, 2.3]),
        (CUBE, [0.3, 1.0, 2.0, 4.0]),
        (TABLE, [0.5, 2.0, 3.5, 4.5]),
    ],
    ids=["cookie_cutter", "inverse_cube", "tabulated"],
)
def test_straight_passes_reproduce_the_lateral_range_curve(sensor: Sensor, offsets: list[float]) -> None:
    """Many robots, each passing its own mine at a lateral offset x: found fraction = p(x)."""
    per_offset = 1500
    x = np.repeat(offsets, per_offset)
    m = len(x)
    lane = 100.0 * np.arange(m)  # lanes far apart: each robot only ever sees its own mine
    mines = np.column_stack([np.zeros(m), lane])
    field = MineField(mines)
    ms = MineSensor(sensor, field, m)
    reach = max_range_m(sensor) + 1.0
    start = np.column_stack([np.full(m, -reach), lane + x])
    step = 0.37  # not a divisor of anything: closest approach falls between steps
    found = _drive(
        ms, start, np.tile([step, 0.0], (m, 1)), math.ceil(2 * reach / step), np.random.default_rng(1)
    )
    assert all(d.robot == d.mine for d in found)  # robot k passes mine k only
    assert all(d.xy == (0.0, float(lane[d.mine])) for d in found)
    hit = np.zeros(m, bool)
    hit[[d.mine for d in found]] = True
    np.testing.assert_array_equal(hit, field.detected)
    p = lateral_range_curve(sensor)(np.asarray(offsets))
    for k, pk in enumerate(p):
        got = int(hit[k * per_offset : (k + 1) * per_offset].sum())
        assert _binomial_ok(got, per_offset, float(pk)), (offsets[k], got / per_offset, pk)


def test_a_fast_robot_cannot_step_over_a_mine() -> None:
    """One 20 m step past a mine 1 m abeam: the closest approach is on the segment, not at its ends."""
    field = MineField(np.array([[0.0, 0.0]]))
    ms = MineSensor(COOKIE, field, 1)
    rng = np.random.default_rng(0)
    assert ms.update(np.array([[-10.0, 1.0]]), np.ones(1, bool), np.zeros(1), 0.0, rng) == []
    assert ms.update(np.array([[10.0, 1.0]]), np.ones(1, bool), np.array([20.0]), 1.0, rng) == []
    assert ms.passes_in_progress == 1
    found = ms.update(np.array([[30.0, 1.0]]), np.ones(1, bool), np.array([20.0]), 2.0, rng)
    assert [(d.robot, d.mine, d.t_s) for d in found] == [(0, 0, 2.0)]


# parallel tracks ---------------------------------------------------------------------------------


def _truncated_sweep(sensor: Sensor, spacing: float) -> float:
    """Expected found fraction for infinitely many tracks, the curve cut at max_range_m."""
    p = lateral_range_curve(sensor)
    r = max_range_m(sensor)
    x = (np.arange(20000) + 0.5) / 20000 * spacing
    k = np.arange(-math.ceil(r / spacing) - 1, math.ceil(r / spacing) + 2)
    lateral = np.abs(x[:, None] + k[None, :] * spacing)
    miss = np.prod(1.0 - np.where(lateral <= r, p(lateral), 0.0), axis=1)
    return float(1.0 - miss.mean())


def _lawnmower_finds(sensor: Sensor, spacing: float, mines: int, seed: int) -> int:
    """Mines found of `mines` uniform over a 100 m square by one robot per track, tracks north-south
    at `spacing` reaching well past the field on every side."""
    rng = np.random.default_rng(seed)
    side = 100.0
    field = MineField(rng.uniform(0.0, side, size=(mines, 2)))
    r = max_range_m(sensor)
    tracks_x = np.arange(-r - spacing, side + r + spacing, spacing) + 0.123
    n = len(tracks_x)
    ms = MineSensor(sensor, field, n)
    start = np.column_stack([tracks_x, np.full(n, -r - 1.0)])
    _drive(ms, start, np.tile([0.0, 0.9], (n, 1)), math.ceil((side + 2 * r + 2) / 0.9), rng)
    return int(field.detected.sum())


@pytest.mark.parametrize(
    ("sensor", "spacing", "model"),
    [
        (CUBE, 2.5, "inverse_cube"),
        (CUBE, 1.5, "inverse_cube"),
        (COOKIE, 5.0, "cookie_cutter"),
        (COOKIE, 3.0, "cookie_cutter"),
    ],
)
def test_a_lawnmower_reproduces_the_sweep_width_coverage(sensor: Sensor, spacing: float, model: str) -> None:
    m = 4000
    found = _lawnmower_finds(sensor, spacing, m, seed=2)
    formula = detection_probability(model, sensor.width_m, spacing)
    expected = _truncated_sweep(sensor, spacing)
    # the cut at max_range_m costs the inverse cube a little, the cookie cutter nothing
    assert expected == pytest.approx(formula, abs=0.01 if model == "inverse_cube" else 1e-9)
    assert expected <= formula + 1e-9
    assert _binomial_ok(found, m, expected), (found / m, expected, formula)
    assert abs(found / m - formula) <= 4.0 * math.sqrt(formula * (1 - formula) / m) + 0.01


@pytest.mark.parametrize("spacing", [2.0, 3.5, 8.0])
def test_a_lawnmower_with_a_tabulated_curve_finds_the_planner_s_parallel_sweep(spacing: float) -> None:
    """One draw per pass: tracks closer than the curve's reach each draw for a mine between them,
    and the planner's `parallel_sweep_detection` says so (the cookie cutter's min(1, W/S) at the
    curve's W would promise more wherever the tails overlap; at 8 m, beyond twice the reach, W/S)."""
    m = 4000
    found = _lawnmower_finds(TABLE, spacing, m, seed=3)
    r = max_range_m(TABLE)
    assert TABLE.lateral_range is not None
    planned = parallel_sweep_detection(TABLE.lateral_range, spacing)
    assert planned == pytest.approx(_truncated_sweep(TABLE, spacing), abs=1e-6)
    if spacing >= 2 * r:
        assert planned == pytest.approx(TABLE.width_m / spacing, abs=1e-6)
    else:
        assert planned < min(1.0, TABLE.width_m / spacing) - 0.01
    assert _binomial_ok(found, m, planned), (found / m, planned)


# false alarms ------------------------------------------------------------------------------------


def test_false_alarms_follow_the_poisson_rate_along_the_track() -> None:
    rate_per_km = 40.0
    sensor = Sensor(model="inverse_cube", sweep_width_m=3.0, false_alarms_per_km=rate_per_km)
    ms = MineSensor(sensor, MineField(np.empty((0, 2))), 50)
    rng = np.random.default_rng(3)
    n, steps, step = 50, 400, 1.5
    start = np.column_stack([np.zeros(n), 1000.0 * np.arange(n)])
    velocity = np.tile([step, 0.0], (n, 1))
    alarms = []
    xy = start.copy()
    for k in range(1, steps + 1):
        xy = xy + velocity
        alarms += [(d, xy[d.robot].copy()) for d in ms.update(xy, np.ones(n, bool), np.full(n, step), k, rng)]
    expected = rate_per_km * n * steps * step / 1000.0  # 1200
    assert abs(len(alarms) - expected) < 4.0 * math.sqrt(expected)
    assert all(d.mine == -1 and d.false_alarm for d, _ in alarms)
    # uniform in the disc of radius min(max_range_m, W) = W around the robot: E[r^2] = R^2 / 2
    radius = min(max_range_m(sensor), sensor.width_m)
    r2 = np.array([np.sum((np.asarray(d.xy) - at) ** 2) for d, at in alarms]) / radius**2
    assert r2.max() <= 1.0
    assert abs(r2.mean() - 0.5) < 4.0 * math.sqrt(1.0 / 12.0 / len(r2))  # r^2 / R^2 ~ U(0, 1)


def test_false_alarms_stay_in_the_clutter_area() -> None:
    sensor = Sensor(model="cookie_cutter", sweep_width_m=4.0, false_alarms_per_km=100.0)
    area = box(0.0, 0.0, 1e6, 1e6)
    n = 40
    ms = MineSensor(sensor, MineField(np.empty((0, 2))), n, clutter_area=area)
    rng = np.random.default_rng(4)
    # half the robots drive along the area's edge (half their disc inside), half 2.5 m outside it
    y = np.where(np.arange(n) < n // 2, 0.0, -2.5)
    base = np.column_stack([10.0 * np.arange(n), y])
    alarms: list[Detection] = []
    steps, step = 500, 1.0
    for k in range(1, steps + 1):
        alarms += ms.update(base + np.array([step * k, 0.0]), np.ones(n, bool), np.full(n, step), k, rng)
    assert all(d.robot < n // 2 for d in alarms)  # the disc (radius 2 m) of the others misses the area
    assert all(d.xy[1] >= 0.0 for d in alarms)
    expected = 100.0 * (n // 2) * steps * step / 1000.0  # redrawn, not dropped: the full rate
    assert abs(len(alarms) - expected) < 4.0 * math.sqrt(expected)


# what is not reported ----------------------------------------------------------------------------


def _lane_of_mines() -> MineField:
    return MineField(np.column_stack([np.arange(5) * 10.0, np.zeros(5)]))


def test_known_exploded_and_cleared_mines_are_not_reported() -> None:
    field = _lane_of_mines()
    field.detected[0] = True
    field.exploded[1] = True
    field.cleared[2] = True
    ms = MineSensor(COOKIE, field, 2)
    # two robots pass the lane together, 0.5 m to either side; the cookie cutter cannot miss
    start = np.array([[-5.0, 0.5], [-5.0, -0.5]])
    found = _drive(ms, start, np.tile([0.5, 0.0], (2, 1)), 130, np.random.default_rng(5))
    assert sorted(d.mine for d in found) == [3, 4]  # once each, though both robots passed them
    assert all(d.robot == 0 for d in found)  # same step: the lower robot index reports
    np.testing.assert_array_equal(field.detected, [True, False, False, True, True])
    # a second sweep finds nothing new
    again = MineSensor(COOKIE, field, 1)
    assert _drive(again, start[:1], np.array([[0.5, 0.0]]), 130, np.random.default_rng(6)) == []


def test_a_robot_that_is_not_sensing_reports_nothing() -> None:
    field = _lane_of_mines()
    sensor = Sensor(model="cookie_cutter", sweep_width_m=4.0, false_alarms_per_km=500.0)
    ms = MineSensor(sensor, field, 2)
    start = np.array([[-5.0, 0.5], [-5.0, 0.5]])
    sensing = np.array([False, True])
    found = _drive(ms, start, np.tile([0.5, 0.0], (2, 1)), 130, np.random.default_rng(7), sensing)
    assert found and all(d.robot == 1 for d in found)
    field2 = _lane_of_mines()
    ms2 = MineSensor(sensor, field2, 2)
    none = _drive(ms2, start, np.tile([0.5, 0.0], (2, 1)), 130, np.random.default_rng(7), np.zeros(2, bool))
    assert none == [] and not field2.detected.any()


def test_a_robot_lost_mid_pass_cannot_report_but_one_that_stops_sensing_does() -> None:
    rng = np.random.default_rng(8)
    on, off = np.ones(1, bool), np.zeros(1, bool)
    at = np.array([[0.0, 1.5]])  # 1.5 m abeam: p = 1 for the cookie cutter, outside early decision
    lost = MineSensor(COOKIE, MineField(np.array([[0.0, 0.0]])), 1)
    assert lost.update(at, on, np.zeros(1), 0.0, rng) == []
    assert lost.update(at, off, np.zeros(1), 1.0, rng) == []  # default: stopped sensing = lost
    assert lost.passes_in_progress == 0
    assert lost.update(at + np.array([50.0, 0.0]), on, np.zeros(1), 2.0, rng) == []
    stopped = MineSensor(COOKIE, MineField(np.array([[0.0, 0.0]])), 1)
    stopped.update(at, on, np.zeros(1), 0.0, rng)
    found = stopped.update(at, off, np.zeros(1), 1.0, rng, alive=np.ones(1, bool))
    assert [(d.robot, d.mine) for d in found] == [(0, 0)]
    dead = MineSensor(COOKIE, MineField(np.array([[0.0, 0.0]])), 1)
    dead.update(at, on, np.zeros(1), 0.0, rng)
    assert dead.update(at, off, np.zeros(1), 1.0, rng, alive=np.zeros(1, bool)) == []


def test_a_mine_on_the_track_is_found_before_the_robot_reaches_it() -> None:
    """A robot driving straight at a mine decides its pass (one draw, with the line's closest
    approach) when it comes within four trigger radii, not after it has driven over the mine:
    full_conops lost 1.5 robots and mines a run to mines set off before the pass's end found them."""
    field = MineField(np.array([[0.0, 0.0]]))
    ms = MineSensor(COOKIE, field, 1)
    on, rng = np.ones(1, bool), np.random.default_rng(0)
    found_at = None
    for k in range(40):
        x = -8.0 + 0.3 * k
        if ms.update(np.array([[x, 0.1]]), on, np.full(1, 0.3), float(k), rng):
            found_at = x
            break
    assert found_at is not None
    assert field.trigger_radius_m < -found_at <= ms.decide_m, found_at
    assert ms.decide_m == pytest.approx(4.0 * field.trigger_radius_m)


def test_early_decision_keeps_the_lateral_range_curve() -> None:
    """Straight passes at lateral offsets inside the early-decision distance are found with the
    curve's p(x) of their closest approach, as they were when drawn at the pass's end."""
    offsets = np.array([0.1, 0.4, 0.7])
    per_offset = 1000
    n = per_offset * len(offsets)
    lanes = np.arange(n) * 20.0  # each robot passes its own mine, far from the others
    field = MineField(np.column_stack([np.zeros(n), lanes]))
    ms = MineSensor(TABLE, field, n)
    lateral = np.repeat(offsets, per_offset)
    rng = np.random.default_rng(3)
    for step in range(21):
        xy = np.column_stack([np.full(n, -5.0 + 0.5 * step), lanes + lateral])
        ms.update(xy, np.ones(n, bool), np.full(n, 0.5), float(step), rng)
    p = lateral_range_curve(TABLE)(offsets)
    for k in range(len(offsets)):
        hits = int(field.detected[k * per_offset : (k + 1) * per_offset].sum())
        assert _binomial_ok(hits, per_offset, float(p[k])), (offsets[k], hits, p[k])


def test_a_robot_that_turns_onto_a_mine_it_passed_gets_the_closer_look() -> None:
    """A robot passes its mine 0.8 m off (the pass is decided there), then turns and drives at it,
    stopping 5 cm short. The pass detects with p at its least distance, not with the p of the
    line it was decided on: a decided pass that drew no more let full_conops's robots curve onto
    mines they had passed undetected and set them off."""
    n = 1000
    lanes = np.arange(n) * 20.0
    field = MineField(np.column_stack([np.zeros(n), lanes]))
    ms = MineSensor(TABLE, field, n)
    rng = np.random.default_rng(5)
    path = [(-5.0 + 0.25 * k, 0.8) for k in range(21)] + [(0.0, 0.8 - 0.15 * k) for k in range(1, 6)]
    for step, (x, y) in enumerate(path):
        xy = np.column_stack([np.full(n, x), lanes + y])
        ms.update(xy, np.ones(n, bool), np.full(n, 0.25), float(step), rng)
    closest = 0.8 - 0.15 * 5
    hits = int(field.detected.sum())
    p_closest, p_line = lateral_range_curve(TABLE)(np.array([closest, 0.8]))
    assert _binomial_ok(hits, n, float(p_closest)), (hits, p_closest, p_line)


def test_closer_looks_miss_as_one_look_at_the_least_distance() -> None:
    """Draws at x1 > x2 > ... with `closer_look` miss with prod (1 - q_k) = 1 - p(x_last):
    checked against the curve for random decreasing sequences."""
    ms = MineSensor(TABLE, MineField(np.zeros((1, 2))), 1)
    p = lateral_range_curve(TABLE)
    rng = np.random.default_rng(2)
    for _ in range(50):
        xs = np.sort(rng.uniform(0.0, 5.0, rng.integers(1, 6)))[::-1]
        before = np.concatenate([[np.inf], xs[:-1]])
        miss = np.prod(1.0 - ms.closer_look(xs, before))
        assert miss == pytest.approx(1.0 - float(p(xs[-1])), abs=1e-12)


def test_same_inputs_and_seed_give_the_same_detections() -> None:
    sensor = Sensor(model="inverse_cube", sweep_width_m=2.0, false_alarms_per_km=20.0)

    def run(seed: int) -> list[Detection]:
        layout = np.random.default_rng(0)
        field = MineField(layout.uniform(0, 60, size=(300, 2)))
        n = 30
        ms = MineSensor(sensor, field, n, clutter_area=box(0, 0, 60, 60))
        start = layout.uniform(0, 60, size=(n, 2))
        heading = layout.uniform(0, 2 * math.pi, n)
        velocity = 0.5 * np.column_stack([np.cos(heading), np.sin(heading)])
        return _drive(ms, start, velocity, 120, np.random.default_rng(seed))

    a, b, c = run(1), run(1), run(2)
    assert len(a) > 20 and any(d.false_alarm for d in a) and any(not d.false_alarm for d in a)
    assert a == b
    assert a != c


def test_mines_lie_only_on_ground_that_can_be_crossed() -> None:
    """mine_clear's search beach holds driftwood logs, dune faces too steep to climb and a keep-out
    zone (about 6% of it). Mines are laid only where the ground can be crossed, as many as asked,
    uniformly over that ground: the share falling in each half of the free ground matches its area."""
    from pathlib import Path

    import shapely

    from swarm.mission.budget import mine_areas
    from swarm.mission.load import load_mission
    from swarm.planning import build_costmap
    from swarm.planning.costmap import FREE
    from swarm.sim.mines import lay_mines

    mission = load_mission(
        Path(__file__).resolve().parents[2] / "missions" / "mine_clear.yaml", {"hazards.mines.count": 4000}
    )
    cm = build_costmap(mission.beach_map, mission.robot_params, mission.terrain_library)
    (area,) = mine_areas(mission)
    rows, cols = np.nonzero(np.ones(cm.shape, bool))
    x, y = cm.center_of(rows, cols)
    inside = shapely.contains_xy(area, x, y)
    assert (cm.reason[rows[inside], cols[inside]] != FREE).mean() > 0.03, "the test needs blocked ground"
    mines = lay_mines(mission, np.random.default_rng(3), cm).positions_m
    assert len(mines) == 4000
    assert cm.ground_free(mines[:, 0], mines[:, 1]).all()
    assert shapely.contains_xy(area, mines[:, 0], mines[:, 1]).all()
    free = inside & (cm.reason[rows, cols] == FREE)
    west = float(np.mean(x[free] < np.median(x[free])))
    share = float(np.mean(mines[:, 0] < np.median(x[free])))
    assert abs(share - west) <= 4 * math.sqrt(west * (1 - west) / len(mines))


@pytest.mark.parametrize("radius", [0.5, 7.0, 40.0])
def test_near_pairs_are_the_dense_checks_and_the_k_d_trees(radius: float) -> None:
    """The compiled grid search finds the pairs of a dense distance check, in its order, and the
    pairs of the k-d tree's sparse distance matrix that a large field used to take."""
    rng = np.random.default_rng(4)
    mines = rng.uniform(0, 300, size=(150, 2))
    points = np.concatenate([rng.uniform(-20, 320, size=(400, 2)), mines[:20] + 1e-3])
    r, j = pair_kernels.near_pairs(points, mines, radius)
    d2 = (points[:, None, 0] - mines[None, :, 0]) ** 2 + (points[:, None, 1] - mines[None, :, 1]) ** 2
    want_r, want_j = np.nonzero(d2 <= radius * radius)
    np.testing.assert_array_equal(r, want_r)
    np.testing.assert_array_equal(j, want_j)
    tree = cKDTree(points).sparse_distance_matrix(cKDTree(mines), radius, output_type="ndarray")
    np.testing.assert_array_equal(np.sort(r * 1000 + j), np.sort(tree["i"] * 1000 + tree["j"]))


def test_runs_near_pairs_are_the_dense_checks_of_each_run() -> None:
    """The batch's pairs: each point against its own run's target mines (NaN padding never near)."""
    rng = np.random.default_rng(6)
    mines = rng.uniform(0, 100, size=(3, 12, 2))
    mines[2, 8:] = np.nan
    target = rng.random((3, 12)) < 0.7
    run = np.sort(rng.integers(0, 3, 60))
    points = rng.uniform(0, 100, size=(60, 2))
    radius2 = rng.uniform(10, 30, 60) ** 2
    r, j = pair_kernels.runs_near_pairs(points, run, mines, target, radius2)
    pos = mines[run]
    d2 = (points[:, None, 0] - pos[:, :, 0]) ** 2 + (points[:, None, 1] - pos[:, :, 1]) ** 2
    want_r, want_j = np.nonzero((d2 <= radius2[:, None]) & target[run])
    np.testing.assert_array_equal(r, want_r)
    np.testing.assert_array_equal(j, want_j)


def test_pair_looks_are_the_inverse_cube_looks_bit_for_bit() -> None:
    """The compiled look of each (step, mine) pair is `inverse_cube_look` of the gathered pairs to
    the last bit: robots standing still (no look), mines on a step's line (the lateral floor),
    behind it, ahead of it and far off; each mine read from its own run's row."""
    rng = np.random.default_rng(9)
    start = rng.uniform(0, 50, size=(40, 2))
    end = start + rng.normal(0, 0.6, size=(40, 2))
    end[::5] = start[::5]  # standing still
    mines = rng.uniform(0, 50, size=(3, 10, 2))
    run = np.sort(rng.integers(0, 3, 40))
    r = np.repeat(np.arange(40), 10)
    j = np.tile(np.arange(10), 40)
    on_line = r % 7 == 0  # some mines exactly on the step's line, beside and beyond its ends
    mines_of = mines[run[r], j]
    t = rng.uniform(-2, 3, size=len(r))
    mines_of[on_line] = (start[r] + t[:, None] * (end[r] - start[r]))[on_line]
    pairs = np.arange(len(r))  # every pair its own step and "run" row, so the line points stay
    got = pair_kernels.pair_looks(start[r], end[r], mines_of[:, None], pairs, pairs, np.zeros_like(r))
    want = inverse_cube_look(start[r], end[r], mines_of)
    np.testing.assert_array_equal(got, want)  # the same floats, zeros where standing still
    assert (want[np.isin(r, np.arange(0, 40, 5))] == 0).all() and (want > 0).sum() > 300
    # the runs' own rows, as the sensors use them
    got = pair_kernels.pair_looks(start, end, mines, run, r, j)
    np.testing.assert_array_equal(got, inverse_cube_look(start[r], end[r], mines[run[r], j]))


def test_screened_pairs_are_numpys_steps_radii_and_pairs() -> None:
    """The compiled set-up of a batch's looks is, to the last bit, the numpy it replaced: each
    step's ends (a robot without a last position looks from where it is), each run's radius from
    its range and largest half step, no pairs for a run past the dense limit, and where each run's
    pairs start."""
    rng = np.random.default_rng(12)
    n, runs, width = 6, 4, 9
    xy = rng.uniform(0, 60, size=(runs * n, 2))
    last = xy + rng.normal(0, 0.8, size=xy.shape)
    last[::5] = np.nan
    robots = np.sort(rng.choice(runs * n, size=15, replace=False))
    range_m = rng.uniform(10, 30, size=runs)
    count = np.array([9, 7, 0, 9])
    mines = rng.uniform(0, 60, size=(runs, width, 2))
    mines[1, 7:] = np.nan
    target = rng.random((runs, width)) < 0.8
    dense_limit = 3 * 9  # a run with more than three screened robots is past it
    start, end, run, ids, dense, r, j, at = pair_kernels.screened_pairs(
        xy, last, robots, n, range_m, count, mines, target, dense_limit
    )
    # the numpy of SensorBatch._looks before
    want_run = robots // n
    want_end = xy[robots]
    want_start = np.where(np.isfinite(last[robots]), last[robots], want_end)
    mid = 0.5 * (want_start + want_end)
    half = 0.5 * np.sqrt(np.sum((want_end - want_start) ** 2, axis=1))
    cuts = np.flatnonzero(want_run[1:] != want_run[:-1]) + 1
    firsts = np.concatenate(([0], cuts))
    want_ids = want_run[firsts]
    counts = np.append(cuts, len(want_run)) - firsts
    radius = range_m[want_ids] + np.maximum.reduceat(half, firsts)
    want_dense = counts * count[want_ids] <= dense_limit
    radius2 = np.repeat(np.where(want_dense, radius * radius, -1.0), counts)
    want_r, want_j = pair_kernels.runs_near_pairs(mid, want_run, mines, target, radius2)
    want_at = np.append(np.searchsorted(want_run[want_r], want_ids), len(want_r))
    for got, want in ((start, want_start), (end, want_end), (run, want_run), (ids, want_ids),
                      (dense, want_dense), (r, want_r), (j, want_j), (at, want_at)):  # fmt: skip
        np.testing.assert_array_equal(got, want)
    assert len(r) > 5 and not dense.all() and dense.any()


def test_screen_is_the_bin_lookup_and_jump_check() -> None:
    rng = np.random.default_rng(8)
    n, size, offset, stride = 10, 7.5, 1 << 21, 1 << 44
    xy = rng.uniform(-50, 150, size=(40, 2))
    last = xy + rng.normal(0, 4, size=(40, 2))
    last[::7] = np.nan
    who = np.flatnonzero(rng.random(40) < 0.8)

    def keys_of(pts: np.ndarray, run: np.ndarray) -> np.ndarray:
        bins = np.floor(pts / size).astype(np.int64) + offset
        return run.astype(np.int64) * stride + (bins[:, 0] << 22) + bins[:, 1]

    keys = np.unique(keys_of(xy[who[::3]], who[::3] // n))
    key_at = np.searchsorted(keys, np.arange(len(xy) // n + 1) * stride)  # each run's keys start
    in_bins, jumped = pair_kernels.screen(xy, last, who, n, size, keys, key_at, offset, stride, 25.0)
    np.testing.assert_array_equal(in_bins, np.isin(keys_of(xy[who], who // n), keys))
    assert in_bins.any() and not in_bins.all()
    seg = xy[who] - last[who]
    with np.errstate(invalid="ignore"):
        np.testing.assert_array_equal(jumped, seg[:, 0] * seg[:, 0] + seg[:, 1] * seg[:, 1] > 25.0)
    no_keys = np.zeros_like(key_at)
    none, _ = pair_kernels.screen(xy, last, who, n, size, keys[:0], no_keys, offset, stride, 25.0)
    assert not none.any()
