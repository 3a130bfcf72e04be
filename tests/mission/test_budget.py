"""The plan's budget: expected losses against the hazard formulas, the detection a criterion needs
against the binomial, and a search design that uses extra robots instead of idling them."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, stats
from scipy.stats import binom

from swarm.mission import budget, exposure, load_mission
from swarm.mission.schema import LateralRange
from swarm.mission.surf_speed import SurfZone
from swarm.planning import build_costmap

MINE_CLEAR = "missions/mine_clear.yaml"


@pytest.fixture(scope="module")
def mission():
    return load_mission(MINE_CLEAR)


@pytest.fixture(scope="module")
def costmap(mission):
    return build_costmap(mission.beach_map, mission.robot_params, mission.terrain_library)


def test_losses_follow_the_hazard_formulas(mission, costmap) -> None:
    hz = mission.hazards
    exposure = budget.Exposure(
        sea_s=1000.0, surf_s=120.0, beach_s=5000.0, driven_m={"wet_hard_sand": 1000.0, "rock": 200.0}
    )
    losses = budget.robot_losses(mission, costmap, exposure)
    mtbf = hz.attrition.mtbf_h * 3600
    for phase, t in (("sea", 1000.0), ("surf", 120.0), ("beach", 5000.0)):
        assert losses[phase]["failure"] == pytest.approx(1 - math.exp(-t / mtbf))
    hit = hz.surf.impact_damage_probability()
    assert losses["surf"]["wave_impact"] == pytest.approx(1 - (1 - hit) ** (120.0 / hz.surf.wave_period_s))
    assert losses["beach"]["rock"] == pytest.approx(1 - math.exp(-hz.rocks.damage_per_km * 0.2))
    # immobilization: per km x mode factor x (1 + (slip/0.3)^2), slip from the steady mode speeds
    names = list(costmap.speeds.names)
    slip = {
        n: 1 - costmap.speeds.speed_mps[names.index(n)] / costmap.speeds.nominal_wheel_speed_mps
        for n in names
    }
    rate = sum(
        hz.immobilization.per_km
        * km
        * hz.immobilization.mode_factors.get(c, 1.0)
        * (1 + (slip[c] / 0.3) ** 2)
        for c, km in (("wet_hard_sand", 1.0), ("rock", 0.2))
    )
    assert losses["beach"]["immobilized"] == pytest.approx(1 - math.exp(-rate))
    # independent competing risks
    survive = math.prod(1 - p for phase in losses.values() for p in phase.values())
    assert budget.lost_probability(losses) == pytest.approx(1 - survive)


def test_hidden_rocks_are_met_per_metre_on_land_as_the_simulator_lays_them(costmap) -> None:
    """Hidden rocks are a Poisson field over the land (`swarm.sim.hazards.hidden_rocks_in_cells`),
    met within `ROCK_CONTACT_M` of a robot's centre, each disabling it with the collision
    probability: on top of the rock ground's damage per km, a hazard per metre on every land class
    and none in the water. full_conops's 0.5 rocks a hectare took 0.29 robots a run in 100 runs
    where the plan, without them, expected 0.01."""
    mission = load_mission(MINE_CLEAR, {"hazards.rocks.hidden_per_ha": 4.0})
    rocks = mission.hazards.rocks
    water = next(c for c in costmap.terrain_classes if mission.terrain_library[c].is_water)
    exposure = budget.Exposure(
        sea_s=0.0, surf_s=0.0, beach_s=0.0, driven_m={"soft_sand": 3000.0, "rock": 200.0, water: 500.0}
    )
    losses = budget.robot_losses(mission, costmap, exposure)
    met = 4.0 / 1e4 * 2 * 0.25 * 3200.0  # rocks met on the 3.2 km of land
    hazard = rocks.damage_per_km * 0.2 + met * rocks.collision_damage_probability
    assert losses["beach"]["rock"] == pytest.approx(1 - math.exp(-hazard))
    none = budget.robot_losses(load_mission(MINE_CLEAR), costmap, exposure)
    assert none["beach"]["rock"] == pytest.approx(1 - math.exp(-rocks.damage_per_km * 0.2))


def _missed(w: float, y: float, ahead: float) -> float:
    """The inverse-cube sensor's miss of a mine at offset y from a straight approach from afar to
    `ahead` short of it: the rate W^2/(8 pi) / r^3 integrated numerically along the track."""
    from scipy import integrate

    look, _ = integrate.quad(lambda s: (s * s + y * y) ** -1.5, ahead, np.inf)
    return math.exp(-(w**2) / (8 * math.pi) * look)


def test_a_mine_met_undetected_is_rare_with_an_inverse_cube_sensor(mission) -> None:
    """A mine the robot meets lies anywhere within the trigger radius r of its track; at offset y
    the robot is on it sqrt(r^2 - y^2) short of abreast, having looked at it all the way from
    afar: the miss averaged over y, by numerical integration of the rate."""
    from scipy import integrate

    w, r = mission.tasks_of("search")[0].sensor.width_m, budget.TRIGGER_RADIUS_M
    mean, _ = integrate.quad(lambda y: _missed(w, y, math.sqrt(r * r - y * y)), 0.0, r)
    assert budget.undetected_at_contact(mission) == pytest.approx(mean / r, rel=1e-3)
    # off the line the robot is on it sooner along the track, having looked longer: missed less
    # than dead ahead
    assert budget.undetected_at_contact(mission) < _missed(w, 0.0, r)


def test_a_mine_met_undetected_with_a_tabulated_curve_misses_by_the_curve_near_zero() -> None:
    """A robot closing on a mine draws down to its least distance, an offset within the trigger
    radius r = 0.25 m: missed with 1 - p averaged over [0, r]. For p = 0.9 - 0.1 x near zero
    that is 1 - (0.9 - 0.1 r / 2)."""
    curve = {"range_m": [0.0, 1.0, 2.0], "probability": [0.9, 0.8, 0.0]}
    m = load_mission(
        MINE_CLEAR, {"tasks.0.sensor.lateral_range": curve, "tasks.0.sensor.sweep_width_m": None}
    )
    assert budget.undetected_at_contact(m) == pytest.approx(1.0 - (0.9 - 0.1 * 0.25 / 2), rel=1e-3)


@pytest.mark.parametrize("mines", [10, 20, 200])
def test_the_detection_a_criterion_needs_is_the_binomial_quantile(mines) -> None:
    p = budget.detection_needed(0.85, mines, confidence=0.95)
    need = math.ceil(0.85 * mines)
    assert binom.sf(need - 1, mines, p) == pytest.approx(0.95, abs=1e-4)
    assert budget.p_criterion_met(0.85, mines, p) == pytest.approx(0.95, abs=1e-4)
    assert binom.sf(need - 1, mines, p - 0.01) < 0.95
    # more mines, a tighter binomial: less margin above the criterion is needed
    assert budget.detection_needed(0.85, 2 * mines) < p


def _design(mission, robots: int, **kw):
    task = mission.tasks_of("search")[0]
    args = {
        "area_m2": 80_000.0,
        "speed_mps": 0.55,
        "start_s": 1300.0,
        "loss_before_end": 0.2,
        "reach": 0.95,
        "row_m": 900.0,
    }
    args.update(kw)
    return budget.design_search(mission, task, robots=robots, **args)


def test_extra_robots_tighten_the_search_then_cover_losses_then_shorten_it(mission) -> None:
    small, big, huge = (_design(mission, n) for n in (12, 24, 96))
    for d, n in ((small, 12), (big, 24), (huge, 96)):
        assert d.searchers + d.reserves == n
        # as tight as the criterion needs, and no tighter than the searchers can sweep in time
        koopman = budget.nominal_detection("inverse_cube", 3.0, d.spacing_m)
        assert koopman * 0.95 >= d.target_detection - 1e-6 or d.spacing_m == pytest.approx(d.min_spacing_m)
        assert d.run_time_s(80_000.0, d.spacing_m) <= (d.window_s[1] - d.window_s[0]) * (1 - 0.2 / 2) + 1e-6
    # 12 robots cannot sweep tight enough: all search, none wait, and the plan says so
    assert small.reserves == 0 and "cannot sweep" in small.note
    assert small.spacing_m > big.spacing_m
    # 96 robots: the criterion's spacing, the expected losses in reserve, the rest shorten the runs
    assert huge.reserves == math.ceil(96 * 0.2)
    assert huge.search_time_s < big.search_time_s
    assert huge.spacing_m >= big.spacing_m - 1e-9


@pytest.mark.parametrize("spacing", [1.0, 2.0, 3.0, 4.0, 6.0, 9.0])
def test_a_tabulated_curve_s_parallel_sweep_is_koopman_s_for_his_curves(spacing: float) -> None:
    """The parallel sweep of a tabulated curve is Koopman's closed form when the table is his
    curve: a definite range gives min(1, W/S); the inverse cube, tabulated finely far out, gives
    erf(sqrt(pi) W / (2 S)) (the table cut at 200 W keeps all but W / (800 pi) of W)."""
    w = 4.0
    definite = LateralRange(range_m=[0.0, w / 2, w / 2 + 1e-9], probability=[1.0, 1.0, 0.0])
    assert budget.parallel_sweep_detection(definite, spacing, samples=20000) == pytest.approx(
        min(1.0, w / spacing), abs=2e-4
    )
    x = np.concatenate([[0.0], np.geomspace(1e-3, 200 * w, 4000)])
    cube = LateralRange(
        range_m=x.tolist(), probability=(-np.expm1(-(w**2) / (4 * np.pi * np.maximum(x, 1e-9) ** 2))).tolist()
    )
    assert budget.parallel_sweep_detection(cube, spacing) == pytest.approx(
        budget.nominal_detection("inverse_cube", w, spacing), abs=2e-3
    )


def test_nominal_detection_follows_the_sensor_s_own_curve() -> None:
    """A curve whose tails overlap at S = W falls short of the cookie cutter's min(1, W/S) there; an
    undone strip swept from twice the spacing keeps what the curve keeps (the plan's after-losses)."""
    curve = LateralRange(range_m=[0.0, 0.5, 1.0, 1.5, 2.0], probability=[1.0, 0.95, 0.8, 0.4, 0.0])
    w = 2.0 * np.trapezoid(curve.probability, curve.range_m)
    assert w == pytest.approx(2.65)
    at_w = budget.nominal_detection("cookie_cutter", w, w, curve)
    assert at_w < budget.nominal_detection("cookie_cutter", w, w) - 0.05
    # beyond twice the reach no mine sees two tracks: W / S exactly
    assert budget.nominal_detection("cookie_cutter", w, 5.0, curve) == pytest.approx(w / 5.0, abs=1e-6)
    # at 2S = 2.08 m a mine midway between two tracks sees both at 1.04 m: 1 - (1 - p(1.04))^2 < 1
    assert budget.nominal_detection("cookie_cutter", w, 2.08, curve) < 0.97


@pytest.mark.parametrize("ratio", [0.8, 1.0, 1.25, 1.5, 2.0, 2.5])
def test_an_undone_lane_keeps_what_its_neighbours_definite_range_reaches(ratio: float) -> None:
    """Cookie cutter, W = ratio x S: the neighbours' tracks at +-S see the undone strip from
    S - W/2 outward, so it keeps (W - S) / S of its detection, clipped to [0, 1]; the neighbours'
    own strips lose nothing while W >= S."""
    spacing = 2.0
    kept = budget.undone_lane_kept("cookie_cutter", ratio * spacing, spacing)
    assert kept == pytest.approx(min(1.0, max(0.0, ratio - 1.0)), abs=0.02)


@pytest.mark.parametrize("spacing", [1.5, 2.2, 3.0])
def test_an_undone_lane_keeps_what_the_inverse_cube_rates_of_the_others_give(spacing: float) -> None:
    """Inverse cube, the lattice's rate in closed form: sum_k c / (y - kS)^2 = c pi^2 / (S^2
    sin^2(pi y / S)), c = W^2 / (4 pi); without the undone lane, less c / y^2. The lost detection
    integrated over y by scipy, over the lane's S times Koopman's erf(sqrt(pi) W / (2 S))."""
    w = 3.0
    c = w**2 / (4.0 * math.pi)

    def lost(y: float) -> float:
        full = c * (math.pi / spacing) ** 2 / math.sin(math.pi * y / spacing) ** 2
        return math.exp(-(full - c / y**2)) - math.exp(-full)

    total = sum(integrate.quad(lost, a, a + spacing, limit=200)[0] for a in spacing * np.arange(0.5, 80.0))
    total += integrate.quad(lost, 1e-9, spacing / 2.0, limit=200)[0]
    nominal = budget.nominal_detection("inverse_cube", w, spacing)
    assert budget.undone_lane_kept("inverse_cube", w, spacing) == pytest.approx(
        1.0 - 2.0 * total / (spacing * nominal), abs=0.01
    )


@pytest.mark.parametrize(("lost", "undone"), [(0.0, 0.5), (0.4, 0.5), (0.4, 1.0)])
def test_an_undone_band_keeps_what_its_driven_neighbours_reach(lost: float, undone: float) -> None:
    """Cookie cutter, W = 2S: each track sees one lane over, so an undone lane's strip is seen
    half from each side. Alone it keeps everything; beside one undone lane, half (its driven side);
    between two, nothing. A searcher lost before its track (`left` = 1) leaves its whole band, and
    where a lane of it is left undone the rest of the band is too (the pieces nobody reaches lie
    together): of two lanes each keeps the half its other side gives, of three the edges keep
    that and the middle nothing; a lane of the bands beside is undone where its searcher was lost
    (`lost`), had not driven it (`left`) and nobody took it over (`undone`), a lane on a band's
    edge then losing its other half: two-lane bands keep (1 - q) / 2, three-lane ones
    2 (1 - q) / 2 / 3, a one-lane band (1 - q)^2 + q (1 - q), with q = `lost` x `left` x `undone`."""
    s = 2.0
    q = lost * undone

    def kept(lanes: int) -> float:
        return budget.undone_band_kept(
            "cookie_cutter", 2 * s, s, lanes=lanes, left=1.0, undone=undone, lost=lost
        )

    assert kept(2) == pytest.approx((1.0 - q) / 2.0, abs=0.01)
    assert kept(3) == pytest.approx(2.0 * (1.0 - q) / 2.0 / 3.0, abs=0.01)
    assert kept(1) == pytest.approx((1.0 - q) ** 2 + q * (1.0 - q), abs=0.01)


@pytest.mark.parametrize(
    ("model", "w", "s", "curve"),
    [
        ("cookie_cutter", 2.65, 1.3, LateralRange(range_m=[0, 1, 2], probability=[1, 0.8, 0])),
        ("inverse_cube", 3.0, 1.9, None),
    ],
)
def test_an_undone_band_with_nothing_else_undone_keeps_what_one_lane_keeps(model, w, s, curve) -> None:
    """With its neighbours always driven (one-lane bands and no neighbouring searcher lost) an
    undone lane keeps `undone_lane_kept`; with more of its band undone around it (wider bands, a
    searcher lost earlier in its band), or more lost beside it, less."""
    alone = budget.undone_lane_kept(model, w, s, curve)

    def kept(**kw) -> float:
        return budget.undone_band_kept(model, w, s, curve, **{"lanes": 4.0, "left": 0.6, "undone": 0.5, **kw})

    assert kept(lanes=1.0, lost=0.0) == pytest.approx(alone, abs=1e-3)  # a wider lattice
    assert kept(lanes=1.0, lost=0.5, undone=0.0) == pytest.approx(alone, abs=1e-3)
    assert kept(lanes=6.0) < kept(lanes=3.0) < kept(lanes=1.0, lost=0.0) <= alone + 1e-3
    assert kept(lost=0.5, undone=0.8) < kept(lost=0.5, undone=0.2)
    assert kept(lost=0.5) < kept(lost=0.0)
    assert kept(left=0.9) < kept(left=0.3)  # lost earlier, more of the band is left


def test_the_takeovers_run_into_the_search_window_s_slack(mission) -> None:
    """The search must be done `WINDOW_SLACK` of its window before the clearance's retreat; the
    lost tracks' takeovers may run on until the retreat."""
    (task,) = [t for t in mission.tasks if t.type == "search"]
    start, end = budget.search_window_s(mission, task, 600.0)
    until = budget.takeover_end_s(mission, task)
    retreat = budget.RETREAT_FACTOR * (task.clearance.standoff_m + budget.STANDOFF_MARGIN_M)
    assert until == pytest.approx(task.clearance.at_s - retreat / mission.robot.wheel_speed_mps - 30.0)
    assert end == pytest.approx(until - budget.WINDOW_SLACK * (until - start))


@pytest.mark.parametrize("spacing", [1.5, 2.0, 3.0])
def test_the_lanes_swept_before_have_found_part_of_what_lies_under_a_lane(spacing: float) -> None:
    """A mine under a lane has met the inverse-cube rates of the lanes swept before it, at S, 2S,
    ... on one side: sum_k c / (k S)^2 = c pi^2 / (6 S^2), c = W^2 / (4 pi), so it has been found
    with 1 - exp(-pi W^2 / (24 S^2)) (to the 60 lanes summed: W^2 / (240 pi S^2)). A definite range
    has found it when a lane before lies within W/2; a tabulated curve with 1 - prod(1 - p(kS));
    random search has no lanes."""
    w = 3.0
    cube = 1.0 - math.exp(-math.pi * w**2 / (24.0 * spacing**2))
    got = budget.found_by_lanes_before("inverse_cube", w, spacing)
    assert got == pytest.approx(cube, abs=w**2 / (240.0 * math.pi * spacing**2))
    assert budget.found_by_lanes_before("cookie_cutter", w, spacing) == (1.0 if spacing <= w / 2 else 0.0)
    curve = LateralRange(range_m=[0.0, 1.0, 2.0, 4.0], probability=[1.0, 0.8, 0.4, 0.0])
    p = np.interp(spacing * np.arange(1, 4), curve.range_m, curve.probability, right=0.0)
    assert budget.found_by_lanes_before("cookie_cutter", w, spacing, curve) == pytest.approx(
        1.0 - np.prod(1.0 - p)
    )
    assert budget.found_by_lanes_before("random", w, spacing) == 0.0


def test_the_mean_distance_between_two_points_of_the_tracks() -> None:
    """Two points uniform on a line of length L lie L/3 apart on average; on two parallel lines
    of length L a distance D apart (a point on each line half the time), the mean over the pairs of
    points evenly spaced along them, computed directly."""
    from swarm.mission.exposure import mean_distance_apart

    line = np.array([[0.0, 0.0], [300.0, 0.0], [900.0, 0.0]])
    assert mean_distance_apart([line]) == pytest.approx(300.0, rel=0.01)
    other = np.array([[0.0, 40.0], [900.0, 40.0]])
    x = np.linspace(0.0, 900.0, 301)
    dx = x[:, None] - x[None, :]
    across = np.hypot(dx, 40.0).mean()
    assert mean_distance_apart([line, other]) == pytest.approx((np.abs(dx).mean() + across) / 2, rel=0.01)
    assert mean_distance_apart([np.array([[5.0, 5.0]])]) == 0.0


def test_unreachable_criterion_is_said(mission) -> None:
    d = _design(mission, 24, reach=0.5)
    assert "no spacing reaches" in d.note and d.spacing_m == pytest.approx(d.min_spacing_m)


@pytest.mark.parametrize("spacing_m", [4.4, 3.0, 2.0])
def test_tightening_a_definite_range_search_always_closes_the_tracks_in(spacing_m: float) -> None:
    """A cookie-cutter sensor's formula promises everything at S <= W, so it cannot say how much
    tighter to go when edges and blocked ground keep the tracks short of the target: the planner
    once asked for the same spacing again, for ever. Every answer must be strictly tighter (by the
    shortfall's ratio at least), or None at the tightest spacing allowed."""
    d = budget.SearchDesign(
        searchers=6, reserves=0, spacing_m=spacing_m, spacing_from="planned", window_s=(0.0, 1000.0),
        search_time_s=0.0, speed_mps=0.5, target_detection=0.94, mines_expected=6.0,
        min_spacing_m=1.0, overhead=1.0,
    )  # fmt: skip
    seen = [spacing_m]
    while (nxt := d.tighten("cookie_cutter", 3.0, seen[-1], 0.9)) is not None:
        assert d.min_spacing_m <= nxt <= max(seen[-1] * 0.9 / 0.94, d.min_spacing_m) + 1e-12
        seen.append(nxt)
        assert len(seen) < 100
    assert seen[-1] == pytest.approx(d.min_spacing_m, rel=1e-2)


def test_tightening_with_the_previous_layout_reaches_the_target_in_a_few_layouts() -> None:
    """Near the target each ratio step gains less (full_conops stopped 1.6 points short after the
    planner's eight layouts). With the previous layout the secant through both is used: on a
    detection that saturates like the edges make it, e(S) = 0.996 - 0.03 (S - 1), the target is met
    within six layouts, where the ratio steps alone take more than eight."""

    def expected(s: float) -> float:
        return 0.996 - 0.03 * (s - 1.0)

    def layouts(secant: bool) -> int:
        d = budget.SearchDesign(
            searchers=6, reserves=0, spacing_m=2.7, spacing_from="planned", window_s=(0.0, 1000.0),
            search_time_s=0.0, speed_mps=0.5, target_detection=0.9695, mines_expected=14.0,
            min_spacing_m=1.0, overhead=1.0,
        )  # fmt: skip
        s, before, k = 2.7, None, 1
        while (
            nxt := d.tighten("cookie_cutter", 2.65, s, expected(s), before if secant else None)
        ) is not None:
            before, s, k = (s, expected(s)), nxt, k + 1
            assert k < 100
        assert expected(s) >= d.target_detection - 1e-3 or s == pytest.approx(d.min_spacing_m)
        return k

    assert layouts(secant=True) <= 6 < 8 < layouts(secant=False)


def test_a_surer_search_asks_for_more_detection_and_tighter_tracks(mission) -> None:
    """`detection_confidence`: the search is designed to meet its criterion with that probability
    over the mine field's draw; asking 0.99 instead of 0.95 raises the per-mine detection it aims
    for (the binomial's tail, checked) and so tightens the spacing."""
    task = mission.tasks_of("search")[0]
    sure = task.model_copy(update={"detection_confidence": 0.99})
    args = {"robots": 96, "area_m2": 80_000.0, "speed_mps": 0.55, "start_s": 1300.0,
            "loss_before_end": 0.2, "reach": 0.99, "row_m": 900.0}  # fmt: skip
    usual = budget.design_search(mission, task, **args)
    surer = budget.design_search(mission, sure, **args)
    assert surer.target_detection > usual.target_detection
    assert surer.spacing_m < usual.spacing_m
    n = round(usual.mines_expected)
    need = math.ceil(mission.success.min_detection_fraction * n - 1e-9)
    assert binom.sf(need - 1, n, surer.target_detection) == pytest.approx(0.99, abs=1e-4)


def test_a_poisson_mine_count_is_averaged_over() -> None:
    """With a mine density each run draws its own count N ~ Poisson(lambda). If every mine must be
    found, P(met) = E[p^N] = exp(-lambda (1 - p)), the Poisson generating function. At full_conops's
    0.9 criterion and lambda = 14 the plan's old binomial at N = 14 (one miss allowed) promised more
    than the runs gave: a run with 7 mines must find all 7."""
    for lam, p in ((14.0, 0.985), (3.0, 0.9), (40.0, 0.99)):
        got = budget.p_criterion_met(1.0, lam, p, poisson=True)
        assert got == pytest.approx(math.exp(-lam * (1.0 - p)), rel=1e-9)
    mixed = budget.p_criterion_met(0.9, 14.0, 0.985, poisson=True)
    fixed = budget.p_criterion_met(0.9, 14.0, 0.985)
    assert mixed < fixed - 0.005
    need = budget.detection_needed(0.9, 14.0, 0.95, poisson=True)
    assert budget.p_criterion_met(0.9, 14.0, need, poisson=True) == pytest.approx(0.95, abs=1e-4)
    assert need > budget.detection_needed(0.9, 14.0, 0.95)


def test_the_work_left_over_is_the_mean_of_its_positive_part() -> None:
    """E[max(D, 0)] of a normal D: sd / sqrt(2 pi) at mean 0, the mean itself far above 0, nothing
    far below, and 1,000,000 draws agree in between; above max(mean, 0) always (Jensen). The plan
    once left over the positive part of the mean run's work: full_conops's lost tracks less its
    slack, 6,650 s with a standard deviation of 9,070 s over the runs, leave 7,870 s on average."""
    assert budget.expected_excess(0.0, 3.0) == pytest.approx(3.0 / math.sqrt(2.0 * math.pi), rel=1e-12)
    assert budget.expected_excess(50.0, 3.0) == pytest.approx(50.0, rel=1e-12)
    assert budget.expected_excess(-50.0, 3.0) == pytest.approx(0.0, abs=1e-12)
    assert budget.expected_excess(-2.0, 0.0) == 0.0 and budget.expected_excess(2.0, 0.0) == 2.0
    d = np.random.default_rng(5).normal(6650.0, 9070.0, 1_000_000)
    got = budget.expected_excess(6650.0, 9070.0)
    assert got == pytest.approx(np.maximum(d, 0.0).mean(), rel=2e-3)
    assert got > 6650.0 + 1000.0


@pytest.mark.parametrize("poisson", [False, True])
def test_the_markers_are_the_mean_of_the_smaller_of_two_random_counts(poisson: bool) -> None:
    """Each robot of the team that lasts marks one mine found: E[min(found, lasting)], both counts
    random. Checked against 400,000 drawn runs (mines found binomial, or Poisson for a density;
    each robot lasting by its own chance), and two closed forms: a team that surely lasts gives
    E[min(X, r)] = sum_{k=1..r} P(X >= k), and a surely found field of m mines with one robot
    lasting with chance q gives q when m >= 1. Where the two counts are close (full_conops: 12.2
    found and 14.2 lasting on average) the mean of the smaller is well below the smaller mean."""
    rng = np.random.default_rng(3)
    chances = rng.uniform(0.3, 0.9, 20)
    mines, p = 14.0, 0.9
    draws = 400_000
    found = rng.poisson(mines * p, draws) if poisson else rng.binomial(14, p, draws)
    lasting = (rng.random((draws, len(chances))) < chances).sum(axis=1)
    drawn = np.minimum(found, lasting).mean()
    got = budget.expected_markers(mines, p, chances, poisson=poisson)
    assert got == pytest.approx(drawn, abs=4.0 * np.minimum(found, lasting).std() / math.sqrt(draws))
    assert got < min(mines * p, chances.sum()) - 0.5
    sure = budget.expected_markers(mines, p, np.ones(5), poisson=poisson)
    sf = (lambda k: stats.poisson.sf(k - 1, mines * p)) if poisson else (lambda k: binom.sf(k - 1, 14, p))
    assert sure == pytest.approx(sum(sf(k) for k in range(1, 6)), rel=1e-12)
    assert budget.expected_markers(3.0, 1.0, [0.4]) == pytest.approx(0.4, rel=1e-12)
    assert budget.expected_markers(3.0, 0.8, []) == 0.0


def test_the_simulator_s_step_and_contact_radii_are_the_budget_s() -> None:
    """The budget's mine model hears a find at the end of a simulator step and turns the robot away
    at the simulator's substep toward the side-step's first point, within the simulator's trigger
    radius; its rock model counts the simulator's hidden-rock contact radius. They live in the
    simulator, above this layer, so they are checked here."""
    from swarm.sim.env import SimConfig
    from swarm.sim.hazards import ROCK_CONTACT_M
    from swarm.sim.mines import DEFAULT_TRIGGER_RADIUS_M
    from swarm.sim.routes import SIDESTEP_CLEAR_M

    assert SimConfig().dt_s == budget.REACTION_S
    assert SimConfig().substep_s == budget.SUBSTEP_S
    assert budget.SIDESTEP_M == SIDESTEP_CLEAR_M
    assert budget.TRIGGER_RADIUS_M == DEFAULT_TRIGGER_RADIUS_M
    assert budget.ROCK_CONTACT_M == ROCK_CONTACT_M


def test_the_policy_s_takeover_pieces_and_standoff_margin_are_the_budget_s() -> None:
    """The off-plan driving counts a trip to each piece of a lost track and waits outside a found
    mine's standoff and margin before marking it, as the scripted policy does."""
    from swarm.sim import policy

    assert budget.TAKEOVER_PIECE_M == policy.TAKEOVER_PIECE_M
    assert budget.STANDOFF_MARGIN_M == policy.STANDOFF_MARGIN_M


@pytest.mark.parametrize("speed", [0.3, 0.54])
def test_a_robot_told_of_a_mine_ahead_turns_away_in_place(mission, speed) -> None:
    """Told of a mine just ahead, the robot pivots (the side-step begins abreast of it) and then
    drives off to the side: in the first step it runs on less than a step's travel (the wheels
    turning it brake it), it never gets a step's travel ahead, and it moves ever further aside, out
    of the trigger radius; a slower robot runs on less."""
    path = budget.turn_away_path(mission, speed, "wet_hard_sand")
    step = budget.REACTION_S * speed
    assert 0.0 < path[0, 0] < step
    assert path[:, 0].max() < step
    assert np.all(np.diff(path[:, 1]) > 0) and path[-1, 1] > budget.TRIGGER_RADIUS_M
    slower = budget.turn_away_path(mission, speed / 2, "wet_hard_sand")
    assert slower[:, 0].max() < path[:, 0].max()


@pytest.mark.parametrize("speed", [0.3, 0.54, 0.8])
def test_a_mine_found_too_late_to_turn_counts_as_met_undetected(mission, speed) -> None:
    """A find is heard at the end of a step and the robot turns away from the next, so a mine is
    met unless found before the last end of a step from which the turn keeps the robot off it:
    missed more than one the robot only has to see before it is on it (at no speed), and less
    than the least-looked-at case (at the trigger radius's edge, told a step's travel beyond the
    run-on), by numerical integration of the rate; faster is riskier."""
    w, r = mission.tasks_of("search")[0].sensor.width_m, budget.TRIGGER_RADIUS_M
    path = budget.turn_away_path(mission, speed, "wet_hard_sand")
    run_on = path[path[:, 1] < r, 0].max()
    got = budget.undetected_at_contact(mission, speed, "wet_hard_sand")
    assert budget.undetected_at_contact(mission) < got < _missed(w, r, r + run_on + budget.REACTION_S * speed)
    assert budget.undetected_at_contact(mission, speed + 0.1, "wet_hard_sand") > got


def test_expected_losses_by_cause_count_a_robot_once() -> None:
    """Losses by phase in order: a robot lost at sea is not lost again ashore; within a phase the
    causes share the phase's loss by their hazards; the whole is P(lost)."""
    losses = {"sea": {"failure": 0.1}, "surf": {"wave_impact": 0.2, "failure": 0.05}, "beach": {"mine": 0.3}}
    got = budget.expected_by_cause(losses)
    assert got["sea"]["failure"] == pytest.approx(0.1)
    surf = 0.9 * (1 - 0.8 * 0.95)
    assert sum(got["surf"].values()) == pytest.approx(surf)
    assert got["surf"]["wave_impact"] / got["surf"]["failure"] == pytest.approx(
        math.log(0.8) / math.log(0.95)
    )
    assert got["beach"]["mine"] == pytest.approx((0.9 - surf) * 0.3)
    total = sum(v for phase in got.values() for v in phase.values())
    assert total == pytest.approx(budget.lost_probability(losses))
    assert budget.expected_by_cause({"sea": {"failure": 1.0}, "beach": {"mine": 0.5}})["beach"]["mine"] == 0.0


def test_the_way_back_to_sea_uses_the_same_rates(mission, costmap) -> None:
    """The return's loss is 1 - prod(1 - p) over the drive and the swim out, shared by cause; a
    mission without a return has none."""
    way = budget.Exposure(sea_s=0.0, surf_s=200.0, beach_s=600.0, driven_m={"soft_sand": 300.0})
    back = load_mission(MINE_CLEAR, {"phases.return_to_sea.enabled": True})
    parts = budget.robot_losses(back, costmap, way)
    got = budget.return_losses(back, costmap, way)
    assert sum(got.values()) == pytest.approx(
        1 - math.prod(1 - p for c in parts.values() for p in c.values())
    )
    assert set(got) == {c for part in parts.values() for c in part}
    assert (
        budget.return_losses(load_mission(MINE_CLEAR, {"phases.return_to_sea.enabled": False}), costmap, way)
        == {}
    )


def _extras(overrides: dict, *done: tuple[float, float]) -> tuple[list, list, exposure.Trips]:
    """Each robot's off-plan metres in mine_clear's plan, its role, and the search's trips; with
    `done`, also each with the takers doing those shares of the work (`off_plan_driving`'s)."""
    import shapely

    from swarm.mission.plan import plan_mission

    m = load_mission(MINE_CLEAR, overrides)
    plan = plan_mission(m, seed=m.seed, workers=1)
    cm = plan.costmap
    zone = SurfZone(m, cm)
    ashore = exposure.nearest_ashore(m, cm, zone.heights > 0)
    area = shapely.union_all(budget.mine_areas(m))
    by_task = {s.task: s for s in plan.search}
    ways = exposure.ways_in(m, cm, plan.robots, zone, ashore, area, by_task)
    extra, trips = exposure.off_plan_driving(m, cm, plan, ways)
    shares = [exposure.off_plan_driving(m, cm, plan, ways, {"beach_search": d}) for d in done]
    return extra, [rp.role for rp in plan.robots], trips["beach_search"], *shares


@pytest.mark.slow
def test_reserves_drive_more_the_more_searchers_are_expected_lost() -> None:
    """Off-plan driving goes to the search's reserves: with the robots failing four times as often
    they take over more track, and drive to more of its pieces, and fewer last to mark the mines
    found. With no hazards the plan keeps no reserves, and the searchers drive only to the mines
    they find, to mark them, every one."""
    fixed = {"swarm.count": 24, "tasks.0.track_spacing_m": 2.0}  # the same tracks
    (base, roles, trips), (worse, worse_roles, worse_trips), (calm, calm_roles, calm_trips) = (
        _extras({**fixed, **more})
        for more in ({}, {"hazards.attrition.mtbf_h": 2.5}, {"hazards.enabled": False})
    )
    total = [sum(sum(more.metres.values()) for more in extra) for extra in (calm, base, worse)]
    assert 0 < total[0] < total[1] < total[2]
    assert calm_trips.to_pieces_m == 0 < trips.to_pieces_m < worse_trips.to_pieces_m
    assert calm_trips.to_marks_m > trips.to_marks_m > worse_trips.to_marks_m > 0
    for extra, who in ((base, roles), (worse, worse_roles)):
        assert "spare" in who
        assert all(not more.metres for more, role in zip(extra, who, strict=True) if role == "search")
    assert "spare" not in calm_roles


def test_the_takers_drive_only_the_work_they_get_done() -> None:
    """mine_clear at 15 robots planned 13.2 km of takeovers and marks where 16 runs drove 7.9 km:
    the survivors there run out of time for the lost tracks, and mark only once they are done. With
    the budget's shares of that work done, the takers drive the lost track and the trips to its
    pieces in the first share, the trips to the marks in the second: nothing when neither is done,
    all of it when both are, linearly between; the trips the work's time is weighed from stay whole."""
    extra, roles, trips, none, half, marks = _extras({"swarm.count": 15}, (0.0, 0.0), (0.5, 1.0), (1.0, 0.0))

    def total(out: tuple) -> float:
        return sum(sum(more.metres.values()) for more in out[0])

    def inside(out: tuple) -> float:
        return sum(more.inside_m for more in out[0])

    def swash(out: tuple) -> float:
        return sum(more.swash_s for more in out[0])

    whole = total((extra,))
    assert whole > 0 and total(none) == 0.0 and inside(none) == 0.0
    track = whole - trips.to_pieces_m - trips.to_marks_m  # the lost track itself
    assert total(half) == pytest.approx(0.5 * (track + trips.to_pieces_m) + trips.to_marks_m)
    assert total(marks) == pytest.approx(track + trips.to_pieces_m)
    assert all(out[1]["beach_search"] == trips for out in (none, half, marks))
    # the lanes run down to the waterline: the takers' time among the breakers scales alike
    assert swash((extra,)) > 0 and swash(none) == 0.0
    assert swash(half) == pytest.approx(0.5 * swash(marks) + swash((extra,)) - swash(marks))
    # 15 robots keep no reserves: the searchers that last take the work over, in equal shares
    assert set(roles) == {"search"} and all(more.metres for more in extra)


def test_a_budget_pass_counts_the_takeovers_its_losses_leave_time_for() -> None:
    """The loss budget's passes (`BUDGET_PASSES`): at 12 robots the survivors leave some lost
    track undone and seldom mark, so a budget that counts the work done drives less and loses fewer
    robots to getting stuck than one pass that counts all of it (2.27 against 2.51 immobilized;
    100 runs: 2.28); at 24, with reserves to spare, one pass is the answer."""
    from swarm.mission import plan as planning

    def immobilized(count: int, passes: int) -> tuple[float, float]:
        m = load_mission(MINE_CLEAR, {"swarm.count": count})
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(planning, "BUDGET_PASSES", passes)
            b = planning.plan_mission(m, seed=m.seed, workers=1).budget
        return b["expected_losses"]["beach"]["immobilized"], b["expected_lost"]

    once, passes = immobilized(12, 1), immobilized(12, planning.BUDGET_PASSES)
    assert passes[0] < once[0] - 0.1 and passes[1] < once[1]
    assert immobilized(24, 1) == immobilized(24, planning.BUDGET_PASSES)


def test_the_exposure_counts_a_track_as_the_robots_drive_it(costmap) -> None:
    """A laid track across blocked ground (a boulder, a log) is driven around it: the plan's
    exposure measures the stitched track (the simulator's `Router.stitch`), which is longer, free
    everywhere and between the same ends; a route with nothing in its way is measured as laid."""
    import dataclasses

    from swarm.mission.exposure import drivable
    from swarm.mission.plan import RobotPlan
    from swarm.planning.router import Router

    cm = costmap
    rows, cols = np.nonzero(cm.blocked)
    # a blocked cell with free cells 6 m to either side of it along x: a track over it
    for r, c in zip(rows.tolist(), cols.tolist(), strict=True):
        x, y = (float(v) for v in cm.center_of(r, c))
        a, b = np.array([x - 6.0, y]), np.array([x + 6.0, y])
        if cm.free_at(*a) and cm.free_at(*b) and not cm.segments_free(a[None], b[None])[0]:
            break
    else:
        pytest.fail("no blocked cell with free ground on both sides")
    # the ground route ends where the track starts; the plan's track_m goes on from there
    ground = np.array([a - [0.0, 20.0], a])
    if not cm.free_at(*ground[0]) or not cm.segments_free(ground[:-1], ground[1:]).all():
        ground = np.array([a - [0.5, 0.0], a])
    rp = RobotPlan(
        id="r", role="search", task="t", launch_m=(0.0, 0.0), release_s=0.0,
        sea_leg_m=np.array([ground[0], ground[0]]), ground_m=ground, track_m=b[None],
        eta_s=0.0, sea_time_s=0.0, ground_time_s=0.0, length_m=0.0,
    )  # fmt: skip
    out = drivable(rp, Router(cm, seed=0))
    laid = float(np.hypot(*(b - a)))
    legs = np.diff(out.track_m, axis=0)
    assert float(np.hypot(legs[:, 0], legs[:, 1]).sum()) > laid + 0.1
    assert np.allclose(out.track_m[0], a) and np.allclose(out.track_m[-1], b)
    assert cm.segments_free(out.track_m[:-1], out.track_m[1:]).all()
    assert np.array_equal(out.ground_m, ground)
    assert cm.segments_free(ground[:-1], ground[1:]).all()
    station = dataclasses.replace(rp, role="landing", task=None, track_m=np.empty((0, 2)))
    assert np.array_equal(drivable(station, Router(cm, seed=0)).ground_m, ground)  # nothing in its way


@pytest.mark.parametrize("h", [1e-8, 0.05, 0.7, 3.0, 40.0])
def test_driven_share_is_the_truncated_exponentials_mean(h) -> None:
    """E[share driven | lost on the stretch] under an even hazard h, against the integral."""
    num = integrate.quad(lambda s: s * h * math.exp(-h * s), 0.0, 1.0)[0]
    den = -math.expm1(-h)
    assert budget.driven_share(h) == pytest.approx(num / den, rel=1e-6)
    assert budget.driven_share(math.inf) == 0.0


def test_track_left_counts_the_way_to_the_track_whole_and_after_it_nothing() -> None:
    """Lost before the track starts: all of it left; on it: 1 - driven_share of it; after it
    (the rest of its window, its slack): none. At sea and in the surf: all of it."""
    before, on = {"failure": 0.1}, {"immobilized": 0.2}
    beach = {"failure": 1 - 0.9 * 0.7, "immobilized": 0.2}
    losses = {"sea": {"failure": 0.05}, "surf": {}, "beach": beach}
    going = 0.95
    lost_before = going * 0.1
    lost_on = going * 0.9 * 0.2
    want = 0.05 + lost_before + lost_on * (1 - budget.driven_share(-math.log(0.8)))
    assert budget.track_left(losses, before, on) == pytest.approx(want)
    # what is lost after the track leaves nothing: more hazard after it changes nothing
    more = {"sea": losses["sea"], "surf": {}, "beach": {**beach, "failure": 0.9}}
    assert budget.track_left(more, before, on) == pytest.approx(want)
    # a small hazard on the track alone leaves about half of it
    small = {"sea": {}, "surf": {}, "beach": {"failure": 1e-4}}
    assert budget.track_left(small, {}, {"failure": 1e-4}) == pytest.approx(0.5e-4, rel=1e-3)


@pytest.mark.slow
def test_every_robot_launched_ends_lost_expended_or_back_at_sea() -> None:
    """With a return to sea, the plan accounts for every robot: the expected lost, the markers the
    clearance expends, and those back at sea (the middle of each range) add up to the swarm, and
    so do the most back with the fewest expended less the losses of the extra robots on the way
    back. The markers are a robot of the
    search team on each mine found: at least the reserves that last, at most every robot of the
    team that lasts (a searcher marks only once the lost tracks are done; both counts random, so
    a little below the smaller of their means), and the fewer are
    expended, the more come back. Without marks nobody is expended. The plan once counted only the
    reserves, so full_conops (none) sent every survivor home (23.6 back) where 100 simulated runs
    expend 7.4 a run and bring 16.2 back."""
    from swarm.mission.plan import plan_mission

    back = {"phases.return_to_sea.enabled": True}
    for count in (24, 12):  # 12: every robot searches, none waits in reserve
        m = load_mission(MINE_CLEAR, {**back, "swarm.count": count})
        plan = plan_mission(m, seed=m.seed, workers=1)
        b = plan.budget
        (s,) = plan.search
        (team,) = b["search"].values()
        assert (s.design["reserves"] > 0) == (count == 24)
        least, most = b["expected_expended"]
        fewest, most_back = b["expected_recovered"]
        on_the_way = sum(b["expected_losses"]["return"].values())
        lasting = count - b["expected_lost"] + on_the_way  # every robot here is the team's
        assert b["expected_lost"] + (least + most) / 2 + (fewest + most_back) / 2 == pytest.approx(count)
        # a marker more is a robot less setting off, back at the way back's rate
        rate = on_the_way / (lasting - (least + most) / 2)
        assert most_back - fewest == pytest.approx((most - least) * (1 - rate))
        assert b["expected_lost"] + least + most_back == pytest.approx(count - (most - least) / 2 * rate)
        found = s.design["mines_expected"] * team["expected_detection_after_losses"]
        # the mean of the smaller count, at most the smaller mean (`expected_markers`' own test)
        assert min(found, lasting) - 1.0 < most <= min(found, lasting)
        assert 0 <= least <= min(s.design["reserves"], found)
        assert (least > 0) == (count == 24)
    unmarked = load_mission(MINE_CLEAR, {**back, "tasks.0.mark": False, "tasks.0.clearance": None})
    b = plan_mission(unmarked, seed=unmarked.seed, workers=1).budget
    assert b["expected_expended"] == [0.0, 0.0]
    low, high = b["expected_recovered"]
    assert low == high
    assert b["expected_lost"] + high == pytest.approx(24)


def test_the_trips_search_at_random_only_what_a_robot_can_reach() -> None:
    """Koopman's random search, 1 - exp(-W L / A), of what the tracks left up to the ground's reach:
    nothing beyond the dense lanes' detection, nothing without trips."""
    w, length, area = 2.0, 1000.0, 20_000.0
    koopman = 1.0 - math.exp(-w * length / area)
    assert budget.with_trips(0.9, 1.0, w, length, area) == pytest.approx(1.0 - 0.1 * (1.0 - koopman))
    assert budget.with_trips(0.9, 0.95, w, length, area) == pytest.approx(0.9 + 0.05 * koopman)
    assert budget.with_trips(0.9, 0.95, w, 0.0, area) == 0.9
    assert budget.with_trips(0.96, 0.95, w, length, area) == 0.96  # the tracks already reach further
    assert budget.with_trips(0.9, 0.95, w, 1e9, area) == pytest.approx(0.95)


def test_the_smaller_of_two_random_counts_is_its_drawn_mean() -> None:
    """The stations the spares take over: E[min(open, spares ashore)], both Poisson binomials.
    Checked against 400,000 drawn runs, and two closed forms: one event each gives p q; a side
    that surely has r gives sum_{k=1..r} P(A >= k)."""
    rng = np.random.default_rng(5)
    a, b = rng.uniform(0.1, 0.6, 8), rng.uniform(0.5, 0.95, 8)
    draws = 400_000
    drawn = np.minimum((rng.random((draws, 8)) < a).sum(axis=1), (rng.random((draws, 8)) < b).sum(axis=1))
    got = budget.expected_fewer(a, b)
    assert got == pytest.approx(drawn.mean(), abs=4.0 * drawn.std() / math.sqrt(draws))
    assert got < min(a.sum(), b.sum())
    assert budget.expected_fewer([0.3], [0.7]) == pytest.approx(0.21, rel=1e-12)
    tail = budget.poisson_binomial_pmf(a)[::-1].cumsum()[::-1]
    assert budget.expected_fewer(a, np.ones(3)) == pytest.approx(tail[1:4].sum(), rel=1e-12)
    assert budget.expected_fewer(a, []) == 0.0


RELAY = "missions/relay.yaml"


def _takeovers(overrides: dict | None = None):
    """relay's plan, and its spares' drives to lost robots' stations (`station_takeovers`)."""
    from swarm.mission.plan import pickup_points, plan_mission
    from swarm.planning.router import Router

    m = load_mission(RELAY, overrides or {})
    plan = plan_mission(m, seed=m.seed, workers=1)
    cm = plan.costmap
    zone = SurfZone(m, cm)
    ashore = exposure.nearest_ashore(m, cm, zone.heights > 0)
    ways = exposure.ways_in(m, cm, plan.robots, zone, ashore, None, {})
    router = Router(cm, seed=m.seed)
    way_out = exposure.WayOut(m, cm, pickup_points(m, np.array([rp.launch_m for rp in plan.robots])))

    def back_from(start):
        return exposure.way_back(m, cm, start, way_out, router.fork(), zone)

    return m, plan, exposure.station_takeovers(m, cm, plan, ways, router, None, back_from)


@pytest.mark.slow
def test_spares_drive_to_the_stations_of_lost_robots_and_back_from_there() -> None:
    """relay's spares take the lost relays' places: only spares drive there, more when robots fail
    more often, none with the hazards off; a spare goes back to sea from a station with the chance
    it holds one (at most once), each station's in proportion to the drives there."""
    _, plan, base = _takeovers()
    _, _, worse = _takeovers({"hazards.attrition.mtbf_h": 2.5})
    _, _, calm = _takeovers({"hazards.enabled": False})
    roles = [rp.role for rp in plan.robots]
    assert "spare" in roles and "relay" in roles

    def metres(t) -> float:
        return sum(sum(d.metres.values()) for d in t.driving)

    assert 0 < metres(base) < metres(worse)
    assert 0 < base.expected < worse.expected <= roles.count("spare") * 1.5
    assert metres(calm) == 0 and calm.expected == 0 and not any(calm.returns)
    for role, d, back in zip(roles, base.driving, base.returns, strict=True):
        if role != "spare":
            assert not d.metres and not back
            continue
        held = sum(chance for chance, _ in back)
        assert 0 < held <= 1
        assert len(back) == roles.count("relay")


@pytest.mark.slow
def test_the_plan_s_station_takeovers_are_the_simulator_s() -> None:
    """The takeovers the plan counts are those the scripted policy makes: relay, 32 runs of its
    plan, takeover events against `Takeovers.expected` within four standard errors (3.7 expected;
    48 runs gave 3.8)."""
    from swarm.sim.run import simulate_batch

    m, plan, takeovers = _takeovers()
    logs = simulate_batch(m, list(range(300, 332)), plan=plan)
    counts = np.array(
        [sum(e["kind"] == "takeover" and e["item"] == "route" for e in log.events) for log in logs]
    )
    assert takeovers.expected == pytest.approx(
        counts.mean(), abs=4.0 * counts.std(ddof=1) / math.sqrt(len(counts))
    )


@pytest.mark.slow
def test_the_budget_counts_the_spares_drives_to_the_stations() -> None:
    """relay's plan counts its spares getting stuck on the way to the lost relays' stations and on
    the way back from them (0.08 robots a run without, against 0.14 its runs' hazard integrates)."""
    from swarm.mission import plan as planning

    m = load_mission(RELAY)
    counted = planning.plan_mission(m, seed=m.seed, workers=1).budget
    with_them = counted["expected_losses"]
    with pytest.MonkeyPatch.context() as mp:

        def none(mission, cm, plan, ways, *args, **kw):
            return exposure.Takeovers([exposure.OffPlan({}, 0.0, 0.0, 0.0)] * len(ways), [[]] * len(ways))

        mp.setattr(exposure, "station_takeovers", none)
        left_out = planning.plan_mission(m, seed=m.seed, workers=1).budget
    without = left_out["expected_losses"]
    assert counted["station_takeovers"] > 3.0 and left_out["station_takeovers"] == 0.0
    for phase in ("beach", "return"):
        assert with_them[phase]["immobilized"] > without[phase]["immobilized"] + 0.01
    assert with_them["surf"] == without["surf"] and with_them["sea"] == without["sea"]
