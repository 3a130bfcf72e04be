"""Hazards as competing risks: each statistical check compares the simulated losses with the formula
they must follow, at 99.9% confidence (exact two-sided binomial test at alpha = 0.001, or a normal
bound of 3.29 standard errors). Seeds are fixed, so every run of these tests is the same."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
import shapely
from scipy.stats import binomtest

from swarm.mission.schema import (
    Attrition,
    Comms,
    Hazards,
    Immobilization,
    Phases,
    Rocks,
    SeaTransit,
    SurfCrossing,
    SurfHazard,
)
from swarm.robot.terrain import default_library
from swarm.sim.hazards import (
    _DROPOUT_COLUMN,
    _RATE_CAUSE_INDEX,
    _U_BOULDER,
    _U_WAVE,
    CAUSE_DESCRIPTIONS,
    CAUSES,
    N_UNIFORMS,
    NO_LOSS,
    RATE_CAUSES,
    ROCK_CONTACT_M,
    STUCK_AFTER_S,
    HazardInputs,
    HazardModel,
    Losses,
    _causes,
    hidden_rocks,
    hidden_rocks_in_cells,
)
from swarm.sim.mines import MineField

CLASSES = ("wet_hard_sand", "soft_sand", "rock", "boulder", "driftwood", "surf", "deep_water")
FIRM, SOFT, ROCK, BOULDER, DRIFTWOOD, SURF, DEEP = range(len(CLASSES))
LIBRARY = default_library()
#: Nothing but what a test turns on: random failures every 10^12 h, no driving hazard without distance.
QUIET = Hazards(attrition=Attrition(mtbf_h=1e12))
Z999 = 3.2905  # two-sided 99.9% normal quantile
ALPHA = 1e-3


def cause(name: str) -> int:
    return CAUSES.index(name)


def no_mines() -> MineField:
    return MineField(np.empty((0, 2)))


def make_model(
    n: int,
    hazards: Hazards = QUIET,
    phases: Phases | None = None,
    minefield: MineField | None = None,
    rocks: np.ndarray | None = None,
) -> HazardModel:
    return HazardModel(
        hazards,
        phases or Phases(),
        CLASSES,
        LIBRARY,
        minefield if minefield is not None else no_mines(),
        rocks if rocks is not None else np.empty((0, 2)),
        n,
    )


def make_inputs(n: int, **overrides: object) -> HazardInputs:
    """A swarm on firm sand, standing still, far from everything; `overrides` replace fields."""
    values: dict[str, object] = {
        "t_s": 100.0,
        "dt_s": 0.5,
        "alive": np.ones(n, dtype=bool),
        "at_sea": np.zeros(n, dtype=bool),
        "xy": np.column_stack([1000.0 + 10.0 * np.arange(n), np.full(n, 1000.0)]),
        "terrain": np.full(n, FIRM),
        "distance_m": np.zeros(n),
        "slip": np.zeros(n),
        "driving": np.zeros(n, dtype=bool),
        "wave_hits": np.zeros(n, dtype=bool),
        "obstacle_hit": np.full(n, -1),
        "energy_wh": np.full(n, 100.0),
        "sea_time_s": np.zeros(n),
        "surf_time_s": np.zeros(n),
        "isolated_s": np.zeros(n),
        "radio_ok": np.ones(n, dtype=bool),
    }
    values.update(overrides)
    return HazardInputs(**values)  # type: ignore[arg-type]


def run(model: HazardModel, inp: HazardInputs, steps: int, rng: np.random.Generator) -> np.ndarray:
    """Step `steps` times, removing the lost; (n,) cause of each robot (NO_LOSS: survived)."""
    fate = np.full(model.n, NO_LOSS)
    for _ in range(steps):
        losses = model.step(inp, rng)
        fate[losses.lost] = losses.cause[losses.lost]
        inp.alive = inp.alive & ~losses.lost
    return fate


def assert_binomial(k: int, n: int, p: float, what: str) -> None:
    test = binomtest(int(k), n, p)
    assert test.pvalue > ALPHA, f"{what}: {k}/{n} = {k / n:.4f}, expected {p:.4f} (p-value {test.pvalue:.2g})"


def test_causes_are_described() -> None:
    assert tuple(CAUSE_DESCRIPTIONS) == CAUSES
    assert all(CAUSE_DESCRIPTIONS.values())
    assert NO_LOSS not in range(len(CAUSES))
    assert RATE_CAUSES == ("failure", "immobilized", "rock", "cut_off")


# --- continuous hazards ----------------------------------------------------------------------------


def test_rates_follow_the_documented_formulas() -> None:
    per_km, damage_per_km, mtbf_h, dropout_per_h = 3.0, 7.0, 2.0, 0.5
    hz = Hazards(
        attrition=Attrition(mtbf_h=mtbf_h),
        immobilization=Immobilization(per_km=per_km),  # default mode factors: soft_sand 5
        rocks=Rocks(damage_per_km=damage_per_km),
        comms=Comms(dropout_per_h=dropout_per_h),
    )
    n = 8
    inp = make_inputs(
        n,
        terrain=np.array([FIRM, SOFT, ROCK, FIRM, DEEP, FIRM, FIRM, FIRM]),
        distance_m=np.array([0.25, 0.5, 0.4, 0.5, 0.5, 0.5, 0.5, 0.5]),
        slip=np.array([0.0, 0.3, 0.6, 0.0, 0.0, 0.0, 0.0, 1.5]),
        at_sea=np.array([0, 0, 0, 1, 0, 0, 0, 0], dtype=bool),
        alive=np.array([1, 1, 1, 1, 1, 0, 1, 1], dtype=bool),
        radio_ok=np.array([1, 1, 1, 1, 1, 1, 0, 1], dtype=bool),
    )
    rates = make_model(n, hz).rates_per_s(inp)
    per_m = per_km / 1000.0
    failure, dropout = 1.0 / (mtbf_h * 3600.0), dropout_per_h / 3600.0
    expected = np.array(
        [
            [failure, per_m * 1.0 * 1.0 * 0.25 / 0.5, 0.0, dropout],  # firm, no slip
            [failure, per_m * 5.0 * 2.0 * 0.5 / 0.5, 0.0, dropout],  # soft x5, slip 0.3 doubles
            [failure, per_m * 1.0 * 5.0 * 0.4 / 0.5, damage_per_km / 1000 * 0.4 / 0.5, dropout],  # rock
            [failure, 0.0, 0.0, dropout],  # at sea: no ground hazards
            [failure, 0.0, 0.0, dropout],  # swimming in deep water: nothing to get stuck in
            [0.0, 0.0, 0.0, 0.0],  # not alive
            [failure, per_m, 0.0, 0.0],  # radio already gone
            [failure, per_m * (1.0 + (1.0 / 0.3) ** 2), 0.0, dropout],  # slip clipped to 1
        ]
    )
    np.testing.assert_allclose(rates, expected, rtol=1e-12)


def test_survival_under_mtbf_is_exponential() -> None:
    n, dt, mean_life_s = 4000, 0.5, 36.0
    lam = 1.0 / mean_life_s
    steps = 72  # T = 36 s: one mean life
    model = make_model(n, Hazards(attrition=Attrition(mtbf_h=mean_life_s / 3600.0)))
    inp = make_inputs(n, dt_s=dt)
    inp.at_sea[: n // 2] = True  # random failure strikes at sea and ashore alike
    rng = np.random.default_rng(11)
    lost_at = np.full(n, steps * dt)  # restricted at T: survivors count T
    for k in range(1, steps + 1):
        losses = model.step(inp, rng)
        assert set(losses.cause[losses.lost]) <= {cause("failure")}
        lost_at[losses.lost] = k * dt
        inp.alive &= ~losses.lost
    T = steps * dt
    assert_binomial(inp.alive.sum(), n, math.exp(-lam * T), "surviving fraction vs exp(-T/MTBF)")
    for half in (slice(0, n // 2), slice(n // 2, n)):
        assert_binomial(inp.alive[half].sum(), n // 2, math.exp(-lam * T), "at sea / ashore")
    # the step a robot is lost in is the exponential loss time rounded up to the step's end:
    # E[min(step-end loss time, T)] = dt sum_{j<m} P(J > j) = dt (1 - q^m) / (1 - q), q = exp(-lam dt)
    q = math.exp(-lam * dt)
    expected = dt * (1.0 - q**steps) / (1.0 - q)
    assert abs(expected - (1.0 - math.exp(-lam * T)) / lam - dt / 2 * (1 - math.exp(-lam * T))) < 0.01
    se = lost_at.std(ddof=1) / math.sqrt(n)
    assert abs(lost_at.mean() - expected) < Z999 * se, (lost_at.mean(), expected, se)


@pytest.mark.parametrize(("steps", "dt"), [(20, 0.5), (1, 13.3)])
def test_competing_risks_split_by_rate(steps: int, dt: float) -> None:
    """Failure (a) and radio dropout (b): lost to each = share x (1 - exp(-(a + b) T)). One long step
    (a + b) dt = 1 checks the exact per-step combination: a naive sum(lambda) dt would lose them all."""
    n = 4000
    a, b = 1.0 / 40.0, 1.0 / 20.0
    hz = Hazards(attrition=Attrition(mtbf_h=1.0 / (a * 3600.0)), comms=Comms(dropout_per_h=b * 3600.0))
    model = make_model(n, hz)
    inp = make_inputs(n, dt_s=dt)
    rng = np.random.default_rng(12)
    dropped = np.zeros(n, dtype=bool)
    fate = np.full(n, NO_LOSS)
    for _ in range(steps):
        losses = model.step(inp, rng)
        assert not (losses.radio_dropped & ~losses.lost).any()
        dropped |= losses.radio_dropped
        fate[losses.lost] = losses.cause[losses.lost]
        inp.alive &= ~losses.lost
    lost = 1.0 - math.exp(-(a + b) * steps * dt)
    assert_binomial((fate == cause("failure")).sum(), n, a / (a + b) * lost, "lost to failure")
    assert_binomial((fate == cause("cut_off")).sum(), n, b / (a + b) * lost, "lost to radio dropout")
    np.testing.assert_array_equal(dropped, fate == cause("cut_off"))


def test_immobilization_per_km_scales_with_mode_factor_and_slip() -> None:
    """20 steps of 0.5 m: 10 m at 2 per km; soft sand x5; slip 0.3 doubles. Survival exp(-H)."""
    m = 4000
    per_m = 2.0 / 1000.0
    groups = [  # terrain, slip, at_sea, cumulative hazard over 10 m
        (FIRM, 0.0, False, per_m * 10.0),
        (SOFT, 0.0, False, per_m * 5.0 * 10.0),
        (FIRM, 0.3, False, per_m * 2.0 * 10.0),
        (FIRM, 0.0, True, 0.0),
        (DEEP, 0.0, False, 0.0),
    ]
    n = m * len(groups)
    hz = Hazards(attrition=Attrition(mtbf_h=1e12), immobilization=Immobilization(per_km=2.0))
    inp = make_inputs(
        n,
        terrain=np.repeat([g[0] for g in groups], m),
        slip=np.repeat([g[1] for g in groups], m),
        at_sea=np.repeat([g[2] for g in groups], m),
        distance_m=np.full(n, 0.5),
        driving=np.ones(n, dtype=bool),
    )
    fate = run(make_model(n, hz), inp, 20, np.random.default_rng(13))
    assert set(fate[fate != NO_LOSS]) == {cause("immobilized")}
    survivors = [int((fate[i * m : (i + 1) * m] == NO_LOSS).sum()) for i in range(len(groups))]
    for (terrain, slip, at_sea, h), alive in zip(groups, survivors, strict=True):
        assert_binomial(m - alive, m, 1.0 - math.exp(-h), f"class {terrain} slip {slip} at_sea {at_sea}")
    # the soft/firm ratio of the estimated cumulative hazards -ln(S) is the mode factor 5
    s_firm, s_soft = survivors[0] / m, survivors[1] / m
    log_ratio = math.log(math.log(s_soft) / math.log(s_firm))
    # delta method: var(-ln S_hat) = (1 - S) / (m S); var(ln H_hat) = var(H_hat) / H^2
    se = math.sqrt(sum((1 - s) / (m * s) / math.log(s) ** 2 for s in (s_firm, s_soft)))
    assert abs(log_ratio - math.log(5.0)) < Z999 * se, (math.exp(log_ratio), se)


@pytest.mark.parametrize("dt", [0.5, 0.2])  # 150 x 0.2 sums to 29.999999999999925
def test_stuck_rule_fires_after_30_s_of_spinning(dt: float) -> None:
    """Robot 0 spins on soft sand: lost at 30 s, not at 30 s - dt; robot 1's spin is broken once at
    10 s and restarts the clock; spinning in the surf, idling, or at sea never counts."""
    n = 5
    hz = Hazards(attrition=Attrition(mtbf_h=1e12), immobilization=Immobilization(per_km=0.0))
    model = make_model(n, hz)
    inp = make_inputs(
        n,
        dt_s=dt,
        terrain=np.array([SOFT, SOFT, SURF, SOFT, SOFT]),
        driving=np.array([1, 1, 1, 0, 1], dtype=bool),
        at_sea=np.array([0, 0, 0, 0, 1], dtype=bool),
        slip=np.full(n, 0.95),
        distance_m=np.zeros(n),
    )
    rng = np.random.default_rng(14)
    steps_30 = round(STUCK_AFTER_S / dt)
    lost_step = np.full(n, -1)
    for k in range(1, steps_30 + round(10.0 / dt) + 5):
        inp.slip[1] = 0.85 if k == round(10.0 / dt) else 0.95
        losses = model.step(inp, rng)
        lost_step[losses.lost] = k
        assert set(losses.cause[losses.lost]) <= {cause("immobilized")}
        inp.alive &= ~losses.lost
    assert lost_step[0] == steps_30  # 30 s, not 30 s - dt
    assert lost_step[1] == round(10.0 / dt) + steps_30
    assert (lost_step[2:] == -1).all()


# --- discrete events ------------------------------------------------------------------------------


def test_wave_hits_disable_with_the_logistic_probability() -> None:
    n, H, h50, spread = 4000, 2.6, 3.0, 0.4
    p = 1.0 / (1.0 + math.exp(-(H - h50) / spread))
    hz = Hazards(
        attrition=Attrition(mtbf_h=1e12),
        surf=SurfHazard(wave_height_m=H, damage_h50_m=h50, damage_spread_m=spread),
    )
    model = make_model(n, hz)
    inp = make_inputs(n, terrain=np.full(n, SURF))
    rng = np.random.default_rng(15)
    hits = 0
    for k in range(12):  # a breaker every 4th step: 3 hits, and no loss in between
        inp.wave_hits = np.full(n, k % 4 == 0)
        hits += k % 4 == 0
        losses = model.step(inp, rng)
        if k % 4:
            assert not losses.lost.any()
        assert set(losses.cause[losses.lost]) <= {cause("wave_impact")}
        inp.alive &= ~losses.lost
    assert hits == 3
    assert_binomial(n - inp.alive.sum(), n, 1.0 - (1.0 - p) ** 3, "lost to 3 breakers")


def _mines_under_robots(n: int, p: float, offset_m: float = 0.1) -> tuple[MineField, np.ndarray]:
    positions = np.column_stack([10.0 * np.arange(n), np.zeros(n)])
    return MineField(positions, trigger_probability=p), positions + np.array([offset_m, 0.0])


def test_mines_trigger_with_their_probability_on_first_contact_only() -> None:
    n, p = 4000, 0.3
    field, xy = _mines_under_robots(n, p)
    model = make_model(n, minefield=field)
    inp = make_inputs(n, xy=xy)
    rng = np.random.default_rng(16)
    losses = model.step(inp, rng)
    assert_binomial(losses.lost.sum(), n, p, "robots setting off the mine under them")
    assert (losses.cause[losses.lost] == cause("mine")).all()
    np.testing.assert_array_equal(losses.mine, np.where(losses.lost, np.arange(n), -1))
    np.testing.assert_array_equal(field.exploded, losses.lost)
    # the survivors stay on their mines: the pair had its one trial
    inp.alive &= ~losses.lost
    for _ in range(5):
        assert not model.step(inp, rng).lost.any()
    np.testing.assert_array_equal(field.exploded, losses.lost)


def test_two_new_mines_under_one_robot_are_two_trials() -> None:
    """P(lost) = 1 - (1 - p)^2, and the lower-index mine goes off first: share p / (1 - (1 - p)^2)."""
    n, p = 4000, 0.5
    centres = np.column_stack([10.0 * np.arange(n), np.zeros(n)])
    positions = np.empty((2 * n, 2))
    positions[0::2] = centres - np.array([0.1, 0.0])
    positions[1::2] = centres + np.array([0.1, 0.0])
    field = MineField(positions, trigger_probability=p)
    losses = make_model(n, minefield=field).step(make_inputs(n, xy=centres), np.random.default_rng(17))
    k = int(losses.lost.sum())
    assert_binomial(k, n, 1.0 - (1.0 - p) ** 2, "robots over two mines")
    first = int((losses.mine[losses.lost] % 2 == 0).sum())
    assert_binomial(first, k, p / (1.0 - (1.0 - p) ** 2), "the first mine of the two")
    assert field.exploded.sum() == k


def test_exploded_marked_and_cleared_mines_are_safe() -> None:
    field = MineField(np.array([[0.0, 0.0], [10.0, 0.0], [20.0, 0.0]]), trigger_probability=1.0)
    field.marked[1] = True
    field.cleared[2] = True
    n = 4
    model = make_model(n, minefield=field)
    xy = np.array([[0.1, 0.0], [100.0, 0.0], [10.0, 0.1], [20.0, 0.0]])
    inp = make_inputs(n, xy=xy)
    rng = np.random.default_rng(18)
    losses = model.step(inp, rng)
    np.testing.assert_array_equal(losses.cause, [cause("mine"), NO_LOSS, NO_LOSS, NO_LOSS])
    np.testing.assert_array_equal(field.exploded, [True, False, False])
    # robot 1 drives onto the exploded mine: nothing left to go off
    inp.alive[0] = False
    inp.xy[1] = [0.0, 0.0]
    for _ in range(3):
        assert not model.step(inp, rng).lost.any()


def test_two_robots_on_one_mine_in_one_step_lose_one_the_lowest_index() -> None:
    field = MineField(np.array([[0.0, 0.0]]), trigger_probability=1.0)
    model = make_model(3, minefield=field)
    xy = np.array([[50.0, 0.0], [0.2, 0.0], [0.0, 0.05]])  # robot 2 is closer; robot 1 has the lower index
    losses = model.step(make_inputs(3, xy=xy), np.random.default_rng(19))
    np.testing.assert_array_equal(losses.cause, [NO_LOSS, cause("mine"), NO_LOSS])
    np.testing.assert_array_equal(losses.mine, [-1, 0, -1])


def test_mine_trigger_radius_sea_and_the_dead() -> None:
    radius = 0.25
    field = MineField(np.array([[0.0, 0.0], [10.0, 0.0], [20.0, 0.0], [30.0, 0.0]]), 1.0, radius)
    xy = np.array([[radius - 0.01, 0.0], [10.0 + radius + 0.01, 0.0], [20.0, 0.0], [30.0, 0.0]])
    inp = make_inputs(4, xy=xy, at_sea=np.array([0, 0, 1, 0], dtype=bool))
    inp.alive[3] = False
    losses = make_model(4, minefield=field).step(inp, np.random.default_rng(20))
    np.testing.assert_array_equal(losses.cause, [cause("mine"), NO_LOSS, NO_LOSS, NO_LOSS])
    np.testing.assert_array_equal(field.exploded, [True, False, False, False])


def test_mine_contacts_match_brute_force_over_a_wide_field() -> None:
    """Mines over 20 km x 5 km (a coarse screening grid) and a dense cluster: with p = 1 a robot is
    lost exactly when, in index order, an active mine lies within the trigger radius."""
    rng = np.random.default_rng(32)
    mines = np.vstack(
        [rng.uniform((0.0, 0.0), (20_000.0, 5_000.0), (3000, 2)), rng.uniform(0.0, 3.0, (200, 2))]
    )
    field = MineField(mines.copy(), trigger_probability=1.0)
    n = 2000
    near_mine = mines[rng.integers(0, len(mines), n)] + rng.uniform(-0.4, 0.4, (n, 2))
    xy = np.where(rng.random((n, 1)) < 0.8, near_mine, rng.uniform((0.0, 0.0), (20_000.0, 5_000.0), (n, 2)))
    at_sea = rng.random(n) < 0.1
    xy[at_sea & (rng.random(n) < 0.5)] = np.nan  # the env may have no position for a robot at sea
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        losses = make_model(n, minefield=field).step(make_inputs(n, xy=xy, at_sea=at_sea), rng)
    exploded = np.zeros(len(mines), dtype=bool)
    expected = np.full(n, -1)
    for i in np.flatnonzero(~at_sea):
        hit = np.flatnonzero((np.hypot(*(mines - xy[i]).T) <= field.trigger_radius_m) & ~exploded)
        if hit.size:
            expected[i] = hit[0]
            exploded[hit[0]] = True
    assert (expected >= 0).sum() > 300  # plenty of contacts, and plenty of near misses
    np.testing.assert_array_equal(losses.mine, expected)
    np.testing.assert_array_equal(field.exploded, exploded)


def test_hidden_rocks_disable_on_first_contact_only() -> None:
    n, p = 4000, 0.3
    rocks = np.column_stack([10.0 * np.arange(n), np.zeros(n)])
    hz = Hazards(attrition=Attrition(mtbf_h=1e12), rocks=Rocks(collision_damage_probability=p))
    model = make_model(n, hz, rocks=rocks)
    inp = make_inputs(n, xy=rocks + np.array([ROCK_CONTACT_M - 0.01, 0.0]))
    inp.xy[n // 2 :] = rocks[n // 2 :] + np.array([0.0, ROCK_CONTACT_M + 0.01])  # just clear of their rocks
    rng = np.random.default_rng(21)
    losses = model.step(inp, rng)
    assert not losses.lost[n // 2 :].any()
    assert_binomial(losses.lost[: n // 2].sum(), n // 2, p, "robots touching a hidden rock")
    assert (losses.cause[losses.lost] == cause("rock")).all()
    inp.alive &= ~losses.lost
    for _ in range(3):  # still against their rocks: no new collision
        assert not model.step(inp, rng).lost.any()


def test_two_hidden_rocks_at_once_are_two_collisions() -> None:
    n, p = 4000, 0.3
    centres = np.column_stack([10.0 * np.arange(n), np.zeros(n)])
    rocks = np.vstack([centres - np.array([0.1, 0.0]), centres + np.array([0.1, 0.0])])
    hz = Hazards(attrition=Attrition(mtbf_h=1e12), rocks=Rocks(collision_damage_probability=p))
    losses = make_model(n, hz, rocks=rocks).step(make_inputs(n, xy=centres), np.random.default_rng(31))
    assert_binomial(losses.lost.sum(), n, 1.0 - (1.0 - p) ** 2, "robots touching two hidden rocks")


def test_boulder_collisions_damage_at_onset_driftwood_never() -> None:
    n, p = 4000, 0.3
    hz = Hazards(attrition=Attrition(mtbf_h=1e12), rocks=Rocks(collision_damage_probability=p))
    model = make_model(n + 1, hz)
    inp = make_inputs(n + 1, obstacle_hit=np.array([BOULDER] * n + [DRIFTWOOD]))
    rng = np.random.default_rng(22)
    first = model.step(inp, rng)
    inp.alive &= ~first.lost
    second = model.step(inp, rng)  # still pushing against it: the same collision
    assert not second.lost.any()
    inp.obstacle_hit = np.full(n + 1, -1)
    assert not model.step(inp, rng).lost.any()
    inp.obstacle_hit = np.array([BOULDER] * n + [DRIFTWOOD])  # a new collision
    third = model.step(inp, rng)
    assert_binomial(first.lost[:n].sum(), n, p, "first boulder collision")
    survivors = n - int(first.lost[:n].sum())
    assert_binomial(third.lost[:n].sum(), survivors, p, "second boulder collision")
    assert not (first.lost[n] or third.lost[n])  # driftwood
    assert set(first.cause[first.lost]) == {cause("rock")}


def test_rock_ground_damage_per_km() -> None:
    n, damage_per_km = 4000, 20.0
    hz = Hazards(
        attrition=Attrition(mtbf_h=1e12),
        rocks=Rocks(damage_per_km=damage_per_km),
        immobilization=Immobilization(per_km=0.0),
    )
    inp = make_inputs(n, terrain=np.full(n, ROCK), distance_m=np.full(n, 0.5))
    fate = run(make_model(n, hz), inp, 20, np.random.default_rng(23))  # 10 m of rock
    assert set(fate[fate != NO_LOSS]) == {cause("rock")}
    assert_binomial((fate != NO_LOSS).sum(), n, 1.0 - math.exp(-damage_per_km / 1000 * 10.0), "rock damage")


def test_hidden_rocks_are_a_poisson_process_over_the_land() -> None:
    land = shapely.box(0.0, 0.0, 100.0, 100.0)  # 1 ha
    hz = Hazards(rocks=Rocks(hidden_per_ha=50.0))
    rng = np.random.default_rng(24)
    draws = [hidden_rocks(hz, land, rng) for _ in range(200)]
    total = sum(len(d) for d in draws)  # Poisson(200 x 50)
    assert abs(total - 10_000) < Z999 * math.sqrt(10_000)
    counts = np.array([len(d) for d in draws])
    assert abs(counts.var(ddof=1) / counts.mean() - 1.0) < 0.35  # Poisson: variance = mean
    every = np.vstack(draws)
    assert every.shape[1] == 2 and shapely.contains_xy(land, every[:, 0], every[:, 1]).all()
    assert hidden_rocks(hz, None, rng).shape == (0, 2)
    assert hidden_rocks(Hazards(), land, rng).shape == (0, 2)


# --- deterministic rules ---------------------------------------------------------------------------


def test_battery_timeouts_and_isolation() -> None:
    phases = Phases(sea_transit=SeaTransit(time_limit_s=100.0), surf_crossing=SurfCrossing(time_limit_s=50.0))
    hz = Hazards(attrition=Attrition(mtbf_h=1e12), comms=Comms(isolation_limit_s=600.0))
    rows = [  # field overrides -> expected cause
        ({"energy_wh": 0.0}, "battery"),
        ({"energy_wh": -1.0, "at_sea": True}, "battery"),
        ({"energy_wh": 1e-9}, None),
        ({"at_sea": True, "sea_time_s": 100.5}, "sea_timeout"),
        ({"at_sea": True, "sea_time_s": 100.0}, None),
        ({"sea_time_s": 1e6}, None),  # ashore: the sea leg is over
        ({"terrain": SURF, "surf_time_s": 50.5}, "surf_timeout"),
        ({"terrain": SURF, "surf_time_s": 50.0}, None),
        ({"isolated_s": 600.0}, "cut_off"),
        ({"isolated_s": 599.5}, None),
        ({"at_sea": True, "isolated_s": 1e6}, None),  # at sea: out of range is normal
    ]
    n = len(rows)
    inp = make_inputs(n)
    for i, (fields, _) in enumerate(rows):
        for key, value in fields.items():
            getattr(inp, key)[i] = value
    losses = make_model(n, hz, phases).step(inp, np.random.default_rng(25))
    expected = [NO_LOSS if c is None else cause(c) for _, c in rows]
    np.testing.assert_array_equal(losses.cause, expected)
    assert not losses.radio_dropped.any()  # isolation is not a radio failure
    # no isolation limit: never cut off for it
    inp = make_inputs(1, isolated_s=np.array([1e9]))
    assert not make_model(1, QUIET).step(inp, np.random.default_rng(26)).lost.any()


def test_a_dead_radio_does_not_drop_out_again() -> None:
    n = 1000
    hz = Hazards(attrition=Attrition(mtbf_h=1e12), comms=Comms(dropout_per_h=3600.0 * 10))  # 10 per s
    inp = make_inputs(n, radio_ok=np.zeros(n, dtype=bool))
    model = make_model(n, hz)
    assert not model.rates_per_s(inp)[:, 3].any()
    assert not model.step(inp, np.random.default_rng(27)).lost.any()


def test_the_dead_are_never_lost_again() -> None:
    n = 50
    hz = Hazards(
        attrition=Attrition(mtbf_h=1e-9),
        comms=Comms(dropout_per_h=1e6, isolation_limit_s=1.0),
        surf=SurfHazard(wave_height_m=10.0, damage_h50_m=0.5, damage_spread_m=0.1),
        rocks=Rocks(collision_damage_probability=1.0),
    )
    xy = np.column_stack([10.0 * np.arange(n), np.zeros(n)])
    field = MineField(xy.copy(), trigger_probability=1.0)
    inp = make_inputs(
        n,
        alive=np.zeros(n, dtype=bool),
        xy=xy,
        wave_hits=np.ones(n, dtype=bool),
        obstacle_hit=np.full(n, BOULDER),
        energy_wh=np.zeros(n),
        surf_time_s=np.full(n, 1e6),
        isolated_s=np.full(n, 1e6),
    )
    model = make_model(n, hz, minefield=field, rocks=xy.copy())
    assert not model.rates_per_s(inp).any()
    for _ in range(3):
        losses = model.step(inp, np.random.default_rng(28))
        assert not losses.lost.any() and not losses.radio_dropped.any() and (losses.mine == -1).all()
    assert not field.exploded.any()


def test_resolution_order() -> None:
    """Mine, wave, rock collision, continuous, stuck, battery, sea timeout, surf timeout, isolation."""
    hz = Hazards(
        attrition=Attrition(mtbf_h=1e12),
        immobilization=Immobilization(per_km=1e9),  # any distance driven: certain (continuous)
        surf=SurfHazard(wave_height_m=10.0, damage_h50_m=0.5, damage_spread_m=0.1),  # p = 1
        rocks=Rocks(collision_damage_probability=1.0),
        comms=Comms(isolation_limit_s=10.0),
    )
    phases = Phases(sea_transit=SeaTransit(time_limit_s=10.0), surf_crossing=SurfCrossing(time_limit_s=10.0))
    n = 7
    field = MineField(np.array([[1000.0, 1000.0]]), trigger_probability=1.0)  # under robot 0
    inp = make_inputs(n)
    flat = inp.energy_wh.copy()
    flat[[0, 1, 2, 3, 4]] = 0.0
    inp.energy_wh = flat
    inp.wave_hits[[0, 1]] = True
    inp.obstacle_hit[[1, 2]] = BOULDER
    inp.distance_m[[2, 3]] = 1.0
    inp.at_sea[[4, 5]] = True
    inp.sea_time_s[[4, 5]] = 11.0
    inp.surf_time_s[[5, 6]] = 11.0
    inp.isolated_s[[6]] = 11.0
    losses = make_model(n, hz, phases, minefield=field).step(inp, np.random.default_rng(29))
    names = [CAUSES[c] for c in losses.cause]
    assert names == ["mine", "wave_impact", "rock", "immobilized", "battery", "sea_timeout", "surf_timeout"]


def test_stuck_comes_before_battery() -> None:
    hz = Hazards(attrition=Attrition(mtbf_h=1e12))
    model = make_model(1, hz)
    inp = make_inputs(1, terrain=np.array([SOFT]), driving=np.ones(1, bool), slip=np.ones(1))
    rng = np.random.default_rng(30)
    for _ in range(round(STUCK_AFTER_S / 0.5) - 1):
        assert not model.step(inp, rng).lost.any()
    inp.energy_wh = np.zeros(1)
    assert CAUSES[model.step(inp, rng).cause[0]] == "immobilized"


# --- determinism and inputs ------------------------------------------------------------------------


def _busy_run(
    n: int, seed: int, alive: np.ndarray | None = None, mines: int = 300
) -> tuple[list[Losses], np.ndarray]:
    """A few dozen steps with every hazard in play."""
    hz = Hazards(
        attrition=Attrition(mtbf_h=0.05),
        immobilization=Immobilization(per_km=50.0),
        rocks=Rocks(damage_per_km=50.0, collision_damage_probability=0.5),
        surf=SurfHazard(wave_height_m=2.5),
        comms=Comms(dropout_per_h=20.0),
    )
    setup = np.random.default_rng(1234)  # the same world for every call
    field = MineField(setup.uniform(0.0, 30.0, (mines, 2)), trigger_probability=0.5)
    rocks = setup.uniform(0.0, 30.0, (300, 2))
    model = make_model(n, hz, minefield=field, rocks=rocks)
    inp = make_inputs(
        n,
        xy=setup.uniform(0.0, 30.0, (n, 2)),
        terrain=setup.integers(0, 3, n),
        distance_m=np.full(n, 0.3),
        slip=setup.uniform(0.0, 0.5, n),
        driving=np.ones(n, dtype=bool),
    )
    if alive is not None:
        inp.alive = alive.copy()
    rng = np.random.default_rng(seed)
    out = []
    for k in range(40):
        inp.xy = inp.xy + setup.normal(0.0, 0.3, (n, 2))
        inp.wave_hits = setup.random(n) < 0.2
        inp.obstacle_hit = np.where(setup.random(n) < 0.1, BOULDER, -1)
        inp.t_s = 0.5 * (k + 1)
        losses = model.step(inp, rng)
        out.append(losses)
        inp.alive = inp.alive & ~losses.lost
    return out, field.exploded.copy()


def test_same_seed_same_losses() -> None:
    a, mines_a = _busy_run(200, seed=7)
    b, mines_b = _busy_run(200, seed=7)
    for la, lb in zip(a, b, strict=True):
        np.testing.assert_array_equal(la.cause, lb.cause)
        np.testing.assert_array_equal(la.mine, lb.mine)
        np.testing.assert_array_equal(la.radio_dropped, lb.radio_dropped)
    np.testing.assert_array_equal(mines_a, mines_b)
    lost = sum(int(ls.lost.sum()) for ls in a)
    causes = {CAUSES[c] for ls in a for c in ls.cause[ls.lost]}
    assert lost > 50 and {"failure", "immobilized", "rock", "wave_impact", "mine"} <= causes
    c, _ = _busy_run(200, seed=8)
    assert any((la.cause != lc.cause).any() for la, lc in zip(a, c, strict=True))


def test_a_robots_fate_does_not_depend_on_the_others_being_alive() -> None:
    """Robot 0 alone (the others dead from the start) meets the same fate as in the full swarm.
    No mines: the one thing robots share is the mine a robot sets off before another reaches it."""
    n = 200
    full, _ = _busy_run(n, seed=9, mines=0)
    for robot in (0, 57, 123):
        only = np.zeros(n, dtype=bool)
        only[robot] = True
        alone, _ = _busy_run(n, seed=9, alive=only, mines=0)
        fate_full = [(k, ls.cause[robot]) for k, ls in enumerate(full) if ls.lost[robot]]
        fate_alone = [(k, ls.cause[robot]) for k, ls in enumerate(alone) if ls.lost[robot]]
        assert fate_full and fate_full == fate_alone
        assert not any((ls.lost & ~only).any() for ls in alone)


def test_inputs_are_checked() -> None:
    model = make_model(4)
    with pytest.raises(ValueError, match="robots"):
        model.step(make_inputs(5), np.random.default_rng(0))
    with pytest.raises(ValueError, match="dt_s"):
        model.step(make_inputs(4, dt_s=0.0), np.random.default_rng(0))


def test_hidden_rocks_in_cells_are_the_same_poisson_process() -> None:
    """1 ha as 100 x 100 cells of 1 m: the count is Poisson(50), the rocks lie in their cells."""
    xs, ys = np.meshgrid(np.arange(100) + 0.5, np.arange(100) + 0.5)
    centers = np.column_stack([xs.ravel(), ys.ravel()])
    hz = Hazards(rocks=Rocks(hidden_per_ha=50.0))
    rng = np.random.default_rng(25)
    draws = [hidden_rocks_in_cells(hz, centers, 1.0, rng) for _ in range(200)]
    total = sum(len(d) for d in draws)
    assert abs(total - 10_000) < Z999 * math.sqrt(10_000)
    every = np.vstack(draws)
    assert ((every >= 0.0) & (every <= 100.0)).all()
    assert hidden_rocks_in_cells(Hazards(), centers, 1.0, rng).shape == (0, 2)


def test_a_batch_sees_its_fields_flags_as_their_owners_write_them_across_resets() -> None:
    """The mine fields' flags are written in place by the world (marks, clearances) after the
    model is made: a batch's mine contacts see them, and keep seeing each run's own when another
    run is reset with a larger field."""
    a = MineField(np.array([[0.0, 0.0], [10.0, 0.0]]), trigger_probability=1.0)
    b = MineField(np.array([[0.0, 0.0]]), trigger_probability=1.0)
    model = HazardModel(QUIET, Phases(), CLASSES, LIBRARY, [a, b], [np.empty((0, 2))] * 2, 1)
    a.marked[0] = True  # as the world marks a mine
    on_mine = make_inputs(2, xy=np.array([[0.1, 0.0], [0.1, 0.0]]))
    rngs = [np.random.default_rng(1), np.random.default_rng(2)]
    losses = model.step(on_mine, rngs, [0, 1])
    np.testing.assert_array_equal(losses.mine, [-1, 0])  # run 0's marked mine is safe
    assert b.exploded[0] and not a.exploded[0]
    c = MineField(np.array([[5.0, 5.0], [6.0, 5.0], [7.0, 5.0]]), trigger_probability=1.0)
    model.reset_runs([1], [c], [np.empty((0, 2))])  # a larger field: the batch's flags grow
    assert not model.step(on_mine, rngs, [0, 1]).lost.any()  # run 0's mark is still there
    a.marked[0] = False  # the marker leaves
    losses = model.step(on_mine, rngs, [0, 1])
    np.testing.assert_array_equal(losses.mine, [0, -1])
    assert a.exploded[0] and not c.exploded.any()


@pytest.mark.parametrize("isolating", [False, True])
def test_the_causes_pass_is_the_numpy_priority_rules(isolating: bool) -> None:
    """`_causes` (one compiled pass) gives every robot the cause the priority rules written as
    numpy masks give (lowest first, higher ones overwriting), and the same radio dropouts, on
    random robots where every rule fires and many overlap."""
    rng = np.random.default_rng(7)
    size = 4000
    on_map, alive, at_sea = (rng.random(size) < p for p in (0.7, 0.8, 0.3))
    isolated_s, surf_time_s, sea_time_s = (rng.uniform(0, 100, size) for _ in range(3))
    energy_wh = rng.uniform(-1, 5, size)
    stuck, cont, new_boulder, hidden, wave_hits = (rng.random(size) < p for p in (0.1, 0.1, 0.2, 0.05, 0.2))
    which = rng.integers(0, 4, size).astype(np.intp)
    u = rng.random((size, N_UNIFORMS))
    p_wave = rng.random(size)
    mine = np.where(rng.random(size) < 0.05, rng.integers(0, 9, size), -1).astype(np.int64)
    limits = {"isolation": 50.0, "surf": 60.0, "sea": 70.0, "collision": 0.4}

    cause = np.full(size, NO_LOSS, dtype=np.int64)
    if isolating:
        cause[on_map & (isolated_s >= limits["isolation"])] = CAUSES.index("cut_off")
    cause[alive & (surf_time_s > limits["surf"])] = CAUSES.index("surf_timeout")
    cause[alive & at_sea & (sea_time_s > limits["sea"])] = CAUSES.index("sea_timeout")
    cause[alive & (energy_wh <= 0.0)] = CAUSES.index("battery")
    cause[stuck] = CAUSES.index("immobilized")
    cause[cont] = _RATE_CAUSE_INDEX[which[cont]]
    cause[(new_boulder & (u[:, _U_BOULDER] < limits["collision"])) | hidden] = CAUSES.index("rock")
    cause[alive & wave_hits & (u[:, _U_WAVE] < p_wave)] = CAUSES.index("wave_impact")
    cause[mine >= 0] = CAUSES.index("mine")
    dropped = cont & (which == _DROPOUT_COLUMN) & (cause == CAUSES.index("cut_off"))

    got, got_dropped = np.full(size, NO_LOSS, dtype=np.int64), np.empty(size, bool)
    _causes(
        on_map, alive, at_sea, isolated_s, isolating, limits["isolation"], surf_time_s, limits["surf"],
        sea_time_s, limits["sea"], energy_wh, stuck, cont, which, new_boulder, u, limits["collision"],
        hidden, wave_hits, p_wave, mine, _RATE_CAUSE_INDEX, got, got_dropped,
    )  # fmt: skip
    assert np.array_equal(got, cause) and np.array_equal(got_dropped, dropped)
    assert len(np.unique(cause)) >= 9 and dropped.any()
