"""Radio links (path loss, budget, range, shadowing) and relay placement (range, connectivity,
redundancy, standable ground, fewest relays, clear failures)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.stats import norm
from shapely.geometry import Polygon

from swarm.errors import SwarmError
from swarm.planning.radio import (
    RadioParams,
    comm_range_m,
    crossover_distance_m,
    friis_loss_db,
    link_closes,
    link_margin_db,
    outage_probability,
    path_loss_db,
    received_power_dbm,
    shadowing_db,
    two_ray_loss_db,
)
from swarm.planning.relay import (
    RelayError,
    StandGrid,
    plan_relays,
    single_loss_cuts,
    standable_grid,
    terminals_connected,
)
from swarm.robot.terrain import load_library
from swarm.world.beachmap import BeachMap, Region

# radio ------------------------------------------------------------------------------------------


def test_friis_against_hand_values() -> None:
    # lambda = c / 2.4 GHz = 0.1249135 m; 20 log10(4 pi 10 / 0.1249135) = 60.0520 dB
    assert float(friis_loss_db(10.0, 2.4e9)) == pytest.approx(60.0520, abs=1e-4)
    # 25 m: 68.0108 dB; doubling the distance adds 6.02 dB
    assert float(friis_loss_db(25.0, 2.4e9)) == pytest.approx(68.0108, abs=1e-4)
    assert float(friis_loss_db(50.0, 2.4e9) - friis_loss_db(25.0, 2.4e9)) == pytest.approx(6.0206, abs=1e-4)


def test_two_ray_against_hand_values() -> None:
    # 40 log10(100) - 20 log10(0.5 * 0.5) = 80 + 12.0412 dB; gains are in the budget, not the loss
    assert float(two_ray_loss_db(100.0, 0.5, 0.5)) == pytest.approx(92.0412, abs=1e-4)
    # doubling the distance adds 12.04 dB (d^-4)
    step = two_ray_loss_db(400.0, 1.0, 2.0) - two_ray_loss_db(200.0, 1.0, 2.0)
    assert float(step) == pytest.approx(12.0412, abs=1e-4)


def test_crossover_is_where_the_models_meet() -> None:
    radio = RadioParams(tx_height_m=0.5, rx_height_m=0.8)
    dc = radio.crossover_m
    assert dc == pytest.approx(4 * math.pi * 0.5 * 0.8 / (299_792_458.0 / 2.4e9))
    assert dc == crossover_distance_m(0.5, 0.8, 2.4e9)
    friis = float(friis_loss_db(dc, radio.frequency_hz))
    two_ray = float(two_ray_loss_db(dc, 0.5, 0.8))
    assert friis == pytest.approx(two_ray, abs=1e-9)
    below, above = path_loss_db([dc * (1 - 1e-9), dc * (1 + 1e-9)], radio)
    assert below == pytest.approx(above, abs=1e-6)
    # the piecewise model picks Friis below, two-ray above
    assert float(path_loss_db(dc / 3, radio)) == pytest.approx(float(friis_loss_db(dc / 3, 2.4e9)))
    assert float(path_loss_db(dc * 3, radio)) == pytest.approx(float(two_ray_loss_db(dc * 3, 0.5, 0.8)))


def test_link_budget() -> None:
    radio = RadioParams(tx_power_dbm=20.0, tx_gain_dbi=3.0, rx_gain_dbi=5.0, sensitivity_dbm=-95.0)
    d = 150.0
    assert float(received_power_dbm(d, radio)) == pytest.approx(
        20.0 + 3.0 + 5.0 - float(path_loss_db(d, radio))
    )
    assert float(link_margin_db(d, radio)) == pytest.approx(
        float(received_power_dbm(d, radio)) - (-95.0 + radio.fade_margin_db)
    )


def test_comm_range_solves_the_budget_in_the_two_ray_region() -> None:
    radio = RadioParams()
    d = comm_range_m(radio)
    assert d > radio.crossover_m
    assert float(link_margin_db(d, radio)) == pytest.approx(0.0, abs=1e-9)
    assert float(link_margin_db(d * (1 - 1e-6), radio)) > 0 > float(link_margin_db(d * (1 + 1e-6), radio))
    # closed form: 40 log10 d = P_tx + G_t + G_r - required + 20 log10(h_t h_r)
    budget = radio.tx_power_dbm + radio.tx_gain_dbi + radio.rx_gain_dbi - radio.required_dbm
    closed = 10 ** ((budget + 20 * math.log10(radio.tx_height_m * radio.rx_height_m)) / 40)
    assert d == pytest.approx(closed, rel=1e-10)


def test_comm_range_solves_the_budget_in_the_friis_region() -> None:
    radio = RadioParams(tx_power_dbm=0.0, tx_height_m=10.0, rx_height_m=10.0, sensitivity_dbm=-80.0)
    d = comm_range_m(radio)
    assert d < radio.crossover_m
    budget = radio.tx_power_dbm + radio.tx_gain_dbi + radio.rx_gain_dbi - radio.required_dbm
    closed = radio.wavelength_m / (4 * math.pi) * 10 ** (budget / 20)
    assert d == pytest.approx(closed, rel=1e-10)


def test_comm_range_impossible_budget_raises() -> None:
    with pytest.raises(SwarmError, match="does not close"):
        comm_range_m(RadioParams(tx_power_dbm=-200.0))
    with pytest.raises(SwarmError):
        RadioParams(frequency_hz=0.0)
    with pytest.raises(SwarmError):
        path_loss_db(0.0, RadioParams())


def test_shadowing_draws_from_the_generator() -> None:
    a = shadowing_db(np.random.default_rng(5), 6.0, size=50_000)
    b = shadowing_db(np.random.default_rng(5), 6.0, size=50_000)
    assert np.array_equal(a, b)
    assert abs(a.mean()) < 4 * 6.0 / math.sqrt(len(a))
    assert a.std() == pytest.approx(6.0, rel=0.02)


def test_outage_at_comm_range_matches_monte_carlo() -> None:
    radio = RadioParams()
    d = comm_range_m(radio)
    p = float(outage_probability(d, radio))
    assert p == pytest.approx(norm.cdf(-radio.fade_margin_db / radio.shadowing_sigma_db))
    n = 100_000
    closes = link_closes(np.full(n, d), radio, np.random.default_rng(8))
    assert abs((1 - closes.mean()) - p) <= 4 * math.sqrt(p * (1 - p) / n)


# relay placement ------------------------------------------------------------------------------


def components_ok(plan, removed=()) -> bool:
    """Independent check: every terminal in the source's component once `removed` are gone."""
    n = plan.n_terminals + plan.n_relays
    keep = np.ones(n, bool)
    keep[list(removed)] = False
    e = plan.edges[keep[plan.edges[:, 0]] & keep[plan.edges[:, 1]]]
    graph = coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    return bool((labels[: plan.n_terminals] == labels[0]).all())


def check_plan(plan, grid: StandGrid | None = None) -> None:
    nodes = plan.nodes_m
    lengths = np.hypot(*(nodes[plan.edges[:, 0]] - nodes[plan.edges[:, 1]]).T)
    assert np.allclose(lengths, plan.hop_lengths_m)
    relayed = plan.edges.max(axis=1) >= plan.n_terminals
    assert (lengths[relayed] <= plan.range_m + 1e-9).all()
    assert components_ok(plan)
    if plan.redundancy == 2:
        for relay in range(plan.n_terminals, len(nodes)):
            assert components_ok(plan, [relay]), f"losing relay {relay} cuts the network"
    if grid is not None and plan.n_relays:
        assert grid.is_standable(plan.positions_m).all()
        # on cell centres
        offsets = (plan.positions_m - np.asarray(grid.origin_m)) / grid.cell_m - 0.5
        assert np.allclose(offsets, np.round(offsets))


def test_straight_gap_needs_ceil_d_over_r_minus_one_relays() -> None:
    plan = plan_relays((0.0, 0.0), [(1000.0, 0.0)], range_m=150.0)
    assert plan.n_relays == math.ceil(1000 / 150) - 1 == 6
    check_plan(plan)
    assert plan.hop_lengths_m.max() == pytest.approx(1000 / 7)
    assert plan.min_slack_m == pytest.approx(150 - 1000 / 7)


def test_straight_gap_on_a_grid_snaps_to_standable_cells() -> None:
    grid = StandGrid(np.ones((60, 1200), bool), 1.0, (-100.0, -30.0))
    plan = plan_relays((0.0, 0.0), [(1000.0, 0.0)], range_m=150.0, grid=grid)
    assert plan.n_relays == 6
    check_plan(plan, grid)


def test_in_range_needs_no_relays() -> None:
    plan = plan_relays((0.0, 0.0), [(100.0, 0.0), (0.0, 140.0)], range_m=150.0, redundancy=2)
    assert plan.n_relays == 0
    check_plan(plan)


@pytest.mark.parametrize("redundancy", [1, 2])
def test_terminals_on_masts_in_reach_link_directly(redundancy: int) -> None:
    # sink 0 is 300 m from the source, inside the masts' 350 m; sink 1, 380 m out, is not: only
    # its link takes relays (3 a chain, hops of 95 m), and no robot's loss can cut the direct one
    sinks = [(300.0, 0.0), (0.0, 380.0)]
    plan = plan_relays((0.0, 0.0), sinks, range_m=100.0, terminal_range_m=350.0, redundancy=redundancy)
    check_plan(plan)
    assert [0, 1] in plan.edges.tolist()
    assert plan.n_relays == 3 * redundancy
    assert not single_loss_cuts(plan) or redundancy == 1
    # the same sinks with masts no higher than a robot's: both links take relays
    low = plan_relays((0.0, 0.0), sinks, range_m=100.0, redundancy=redundancy)
    assert [0, 1] not in low.edges.tolist() and low.n_relays > plan.n_relays
    with pytest.raises(SwarmError, match=r"terminal_range_m must be a positive number, found 0\.0"):
        plan_relays((0.0, 0.0), sinks, range_m=100.0, terminal_range_m=0.0)


def test_many_sinks_all_connected_every_hop_in_range() -> None:
    rng = np.random.default_rng(17)
    for _ in range(5):
        sinks = rng.uniform(-400.0, 400.0, (5, 2))
        plan = plan_relays((0.0, 0.0), sinks, range_m=90.0)
        check_plan(plan)
        for s in range(1, plan.n_terminals):
            assert terminals_connected(plan.n_terminals + plan.n_relays, plan.edges, s + 1)


def test_steiner_hub_saves_a_relay() -> None:
    sinks = [(300.0, 0.0), (150.0, 260.0)]
    with_hub = plan_relays((0.0, 0.0), sinks, range_m=100.0)
    without = plan_relays((0.0, 0.0), sinks, range_m=100.0, hubs=False)
    assert with_hub.n_relays == 4 < without.n_relays == 5
    assert len(with_hub.hubs) == 1
    check_plan(with_hub)
    check_plan(without)


@pytest.mark.parametrize("grid", [False, True])
def test_redundancy_two_survives_any_single_loss(grid: bool) -> None:
    stand = StandGrid(np.ones((400, 900), bool), 1.0, (-50.0, -200.0)) if grid else None
    sinks = [(700.0, 0.0), (400.0, 180.0)]
    single = plan_relays((0.0, 0.0), sinks, range_m=120.0, grid=stand)
    double = plan_relays((0.0, 0.0), sinks, range_m=120.0, grid=stand, redundancy=2)
    check_plan(single, stand)
    check_plan(double, stand)
    assert single_loss_cuts(single)  # a tree: any chain relay is a cut
    assert single_loss_cuts(double) == []
    # relays of the two chains stay apart
    d = np.hypot(*(double.positions_m[:, None, :] - double.positions_m[None, :, :]).transpose(2, 0, 1))
    assert d[~np.eye(len(d), dtype=bool)].min() >= 2.0 - 1e-9


def test_detour_round_a_lagoon() -> None:
    stand = np.ones((200, 400), bool)
    rows, cols = np.mgrid[0:200, 0:400]
    stand[(cols - 200) ** 2 + (rows - 100) ** 2 < 70**2] = False  # a lagoon 140 m across
    grid = StandGrid(stand, 1.0, (0.0, 0.0))
    plan = plan_relays((20.0, 100.0), [(380.0, 100.0)], range_m=60.0, grid=grid)
    check_plan(plan, grid)
    assert plan.n_relays <= 7
    double = plan_relays((20.0, 100.0), [(380.0, 100.0)], range_m=60.0, grid=grid, redundancy=2)
    check_plan(double, grid)


def test_impossible_gap_says_which_hop() -> None:
    stand = np.ones((200, 400), bool)
    stand[:, 150:300] = False  # a river mouth 150 m wide, range 60 m
    grid = StandGrid(stand, 1.0, (0.0, 0.0))
    with pytest.raises(RelayError) as err:
        plan_relays((20.0, 100.0), [(380.0, 100.0)], range_m=60.0, grid=grid)
    message = str(err.value)
    assert isinstance(err.value, SwarmError)
    assert "source (20.0, 100.0) to sink 0 (380.0, 100.0)" in message
    assert "hop 4 of 6, from a relay near (200.0, 100.0) to a relay near (260.0, 100.0)" in message
    # going round is no better: the last standable column before the river, 151 m from the next
    assert "ends near (149.5, " in message and "151.0 m from standable ground at (300.5, " in message


def test_detour_along_a_thin_causeway() -> None:
    """A one-cell-wide causeway 500 m across water, off the coarse lattice's rows."""
    stand = np.zeros((200, 600), bool)
    stand[:, :50] = True
    stand[:, 550:] = True
    stand[101, :] = True
    grid = StandGrid(stand, 1.0, (0.0, 0.0))
    for redundancy in (1, 2):
        plan = plan_relays((20.0, 30.0), [(580.0, 170.0)], range_m=60.0, grid=grid, redundancy=redundancy)
        check_plan(plan, grid)
        on_causeway = plan.positions_m[(plan.positions_m[:, 0] > 50) & (plan.positions_m[:, 0] < 550)]
        assert np.allclose(on_causeway[:, 1], 101.5)


def test_terminal_far_from_standable_ground_says_so() -> None:
    stand = np.zeros((100, 100), bool)
    stand[:, 60:] = True  # beach from x = 60 m; the source is a boat at x = 0
    grid = StandGrid(stand, 1.0, (0.0, 0.0))
    with pytest.raises(RelayError, match=r"no standable cell lies within 40.0 m of source"):
        plan_relays((0.0, 50.0), [(95.0, 50.0)], range_m=40.0, grid=grid)
    with pytest.raises(RelayError, match="no cell of the map is standable"):
        plan_relays(
            (0.0, 0.0), [(500.0, 0.0)], range_m=40.0, grid=StandGrid(np.zeros((5, 5), bool), 1.0, (0, 0))
        )


def test_plan_with_a_radio_reports_margin() -> None:
    radio = RadioParams()
    plan = plan_relays((0.0, 0.0), [(1000.0, 0.0)], radio=radio)
    assert plan.range_m == pytest.approx(comm_range_m(radio))
    assert plan.n_relays == math.ceil(1000 / plan.range_m) - 1
    assert plan.min_margin_db == pytest.approx(float(link_margin_db(plan.hop_lengths_m, radio).min()))
    assert plan.min_margin_db >= 0


def test_bad_relay_requests() -> None:
    with pytest.raises(SwarmError, match="range_m or radio"):
        plan_relays((0, 0), [(10, 0)])
    with pytest.raises(SwarmError, match="redundancy"):
        plan_relays((0, 0), [(10, 0)], range_m=5.0, redundancy=3)
    with pytest.raises(SwarmError, match="sink"):
        plan_relays((0, 0), np.empty((0, 2)), range_m=5.0)


# standable ground from a map --------------------------------------------------------------------

CLASSES = ("wet_hard_sand", "shallow_water", "surf", "deep_water", "boulder", "soft_sand")


def beach_with_everything() -> BeachMap:
    """300 x 120 cells of 1 m: deep water y < 10, surf 10..20, shallow 20..30, sand above; a
    boulder field, a steep dune face, a keep-out square."""
    rows, cols = 120, 300
    terrain = np.zeros((rows, cols), dtype=np.int8)
    terrain[:10] = CLASSES.index("deep_water")
    terrain[10:20] = CLASSES.index("surf")
    terrain[20:30] = CLASSES.index("shallow_water")
    terrain[60:70, 100:120] = CLASSES.index("boulder")
    elevation = np.zeros((rows, cols), dtype=np.float32)
    elevation[80:, 200:230] = np.linspace(0.0, 30.0, 30)[None, :]  # 45 deg dune face
    keep_out = Polygon([(150.2, 40.2), (170.0, 40.2), (170.0, 60.0), (150.2, 60.0)])
    return BeachMap(
        name="everything",
        cell_m=1.0,
        origin_m=(0.0, 0.0),
        terrain_classes=CLASSES,
        terrain=terrain,
        elevation_m=elevation,
        regions={"mines": Region("mines", "keep_out", keep_out)},
    )


def test_standable_grid_from_a_beach_map() -> None:
    beach = beach_with_everything()
    library = load_library()
    grid = standable_grid(beach, library)
    ok = grid.standable
    assert not ok[:20].any()  # deep water and surf
    assert ok[20:30, :100].all()  # shallow water: wheels on the bottom
    assert not ok[60:70, 100:120].any()  # boulders
    assert ok[40:60, 0:100].all()
    climb = library["wet_hard_sand"].max_climb_slope_deg
    assert (beach.slope_deg[90, 210] > climb) and not ok[90, 210]  # the dune face
    assert not ok[40:60, 150:170].any()  # every cell the keep-out square touches, partial ones too
    assert ok[40:60, 149].all() and ok[39, 150:170].all() and ok[60, 150:170].all()


def test_relays_on_a_beach_map_stand_on_standable_cells() -> None:
    beach = beach_with_everything()
    grid = standable_grid(beach)
    source = (5.0, 2.0)  # a boat in deep water
    sinks = [(290.0, 110.0), (60.0, 115.0), (160.0, 50.0)]  # one inside the keep-out zone
    for redundancy in (1, 2):
        plan = plan_relays(source, sinks, range_m=35.0, grid=grid, redundancy=redundancy)
        check_plan(plan, grid)
        rows, cols = beach.cell_of(plan.positions_m[:, 0], plan.positions_m[:, 1])
        assert grid.standable[rows, cols].all()
        assert plan.n_relays >= sum(math.ceil(math.dist(source, s) / 35.0) - 1 for s in sinks[:1])
