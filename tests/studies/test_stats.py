"""Study statistics against references: scipy's Wilson interval, the textbook formula, exact binomial
coverage, and a synthetic attrition study whose answer is known in closed form."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.stats import binom, binomtest, norm

from swarm.errors import SwarmError
from swarm.studies.stats import (
    StatsInputError,
    agreement,
    count_mean_interval,
    distribution,
    k_out_of_n,
    mean_interval,
    required_value,
    runs_for_lower_bound,
    runs_for_width,
    wilson_interval,
    wilson_intervals,
)

Z95 = float(norm.ppf(0.975))  # 1.959963984540054


# --- Wilson interval ---------------------------------------------------------------------------


def _grid() -> list[tuple[int, int, float]]:
    cases = []
    for n in (1, 2, 5, 10, 37, 100, 1000):
        for k in sorted({0, 1, n // 3, n // 2, n - 1, n}):
            for c in (0.8, 0.9, 0.95, 0.99):
                cases.append((k, n, c))
    return cases


@pytest.mark.parametrize(("k", "n", "c"), _grid())
def test_wilson_matches_scipy_reference(k: int, n: int, c: float) -> None:
    ref = binomtest(k, n).proportion_ci(confidence_level=c, method="wilson")
    lower, upper = wilson_interval(k, n, c)
    assert lower == pytest.approx(ref.low, abs=1e-12)
    assert upper == pytest.approx(ref.high, abs=1e-12)
    assert 0.0 <= lower <= k / n <= upper <= 1.0


def test_wilson_exact_at_the_ends() -> None:
    # at 0 and n successes the interval touches 0 and 1 exactly (Wald would collapse to a point)
    assert wilson_interval(0, 20)[0] == 0.0
    assert wilson_interval(20, 20)[1] == 1.0
    # k = n: lower bound n / (n + z²), from the textbook form with p = 1
    assert wilson_interval(20, 20)[0] == pytest.approx(20 / (20 + Z95**2), rel=1e-12)


def test_wilson_hand_worked_case() -> None:
    # k = 8, n = 10, p = 0.8, z = 1.959964, z² = 3.841459
    # textbook: (p + z²/2n ± z sqrt(p(1-p)/n + z²/4n²)) / (1 + z²/n)
    #   z²/2n = 0.1920730;  p(1-p)/n = 0.016;  z²/4n² = 0.0096036;  sqrt(0.0256036) = 0.1600114
    #   z * 0.1600114 = 0.3136166;  1 + z²/n = 1.3841459
    #   lower = (0.8 + 0.1920730 - 0.3136166) / 1.3841459 = 0.6784564 / 1.3841459 = 0.4901625
    #   upper = (0.8 + 0.1920730 + 0.3136166) / 1.3841459 = 1.3056896 / 1.3841459 = 0.9433178
    lower, upper = wilson_interval(8, 10, 0.95)
    assert lower == pytest.approx(0.4901625, abs=5e-7)
    assert upper == pytest.approx(0.9433178, abs=5e-7)


def test_wilson_no_runs_is_vacuous() -> None:
    assert wilson_interval(0, 0) == (0.0, 1.0)
    lower, upper = wilson_intervals(np.array([0, 3]), np.array([0, 4]))
    assert (lower[0], upper[0]) == (0.0, 1.0)
    assert (lower[1], upper[1]) == pytest.approx(wilson_interval(3, 4))


def test_wilson_intervals_match_scalar() -> None:
    rng = np.random.default_rng(3)
    n = rng.integers(1, 500, size=200)
    k = rng.integers(0, n + 1)
    lower, upper = wilson_intervals(k, n, 0.9)
    expected = np.array([wilson_interval(int(a), int(b), 0.9) for a, b in zip(k, n, strict=True)])
    np.testing.assert_allclose(lower, expected[:, 0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(upper, expected[:, 1], rtol=0, atol=1e-15)


@pytest.mark.parametrize(
    ("k", "n", "c"), [(5, 4, 0.95), (-1, 4, 0.95), (2, 4, 1.0), (2, 4, 0.0), (2, 4, 95), (2.5, 4, 0.95)]
)
def test_wilson_rejects_bad_input(k: float, n: int, c: float) -> None:
    with pytest.raises(StatsInputError) as err:
        wilson_interval(k, n, c)  # type: ignore[arg-type]
    assert isinstance(err.value, SwarmError)
    assert isinstance(err.value, ValueError)


def test_wilson_coverage_near_nominal() -> None:
    p, n, trials = 0.9, 50, 20_000
    k = np.random.default_rng(12345).binomial(n, p, size=trials)
    lower, upper = wilson_intervals(k, np.full(trials, n), 0.95)
    simulated = float(np.mean((lower <= p) & (p <= upper)))
    # exact coverage: the binomial probability of the counts whose interval covers p. At this (n, p)
    # it is 0.9703 (Wilson's coverage oscillates with n and p around the nominal level)
    counts = np.arange(n + 1)
    lo, hi = wilson_intervals(counts, np.full(n + 1, n), 0.95)
    exact = float(binom.pmf(counts, n, p)[(lo <= p) & (p <= hi)].sum())
    assert 0.93 <= exact <= 0.975
    assert abs(simulated - exact) < 4.0 * math.sqrt(exact * (1.0 - exact) / trials)
    assert 0.93 <= simulated <= 0.975
    # the reason for Wilson: Wald's p ± z sqrt(p(1-p)/n) covers far less than 95% here
    ph = counts / n
    half = Z95 * np.sqrt(ph * (1.0 - ph) / n)
    wald = float(binom.pmf(counts, n, p)[(ph - half <= p) & (p <= ph + half)].sum())
    assert wald < 0.9


# --- runs needed -------------------------------------------------------------------------------


def _width(p_hat: float, n: int, c: float = 0.95) -> float:
    lower, upper = wilson_intervals(np.array([p_hat * n]), np.array([n]), c)
    return float(upper[0] - lower[0])


@pytest.mark.parametrize("p_hat", [0.0, 0.02, 0.3, 0.5, 0.77, 0.95, 1.0])
@pytest.mark.parametrize("width", [0.02, 0.1, 0.25, 0.6])
@pytest.mark.parametrize("c", [0.9, 0.95, 0.99])
def test_runs_for_width_is_the_smallest(p_hat: float, width: float, c: float) -> None:
    n = runs_for_width(p_hat, width, c)
    assert _width(p_hat, n, c) <= width
    if n > 1:
        assert _width(p_hat, n - 1, c) > width


def test_runs_for_width_closed_forms() -> None:
    # p_hat = 1/2: width = z / sqrt(n + z²) <= 0.1  <=>  n >= (z / 0.1)² - z² = 384.146 - 3.841 = 380.30
    assert runs_for_width(0.5, 0.1) == math.ceil((Z95 / 0.1) ** 2 - Z95**2) == 381
    wald = math.ceil(Z95**2 * 0.25 / 0.05**2)
    assert wald == 385  # the Wald shortcut asks for more
    # p_hat = 0: the interval is [0, z² / (n + z²)], at most w wide once n >= z² (1 / w - 1)
    n = runs_for_width(0.0, 0.1)
    assert n == math.ceil(Z95**2 * (1 / 0.1 - 1))
    assert wilson_interval(0, n)[1] <= 0.1 < wilson_interval(0, n - 1)[1]
    assert runs_for_width(1.0, 0.1) == n
    # a width wider than any interval needs one run
    assert runs_for_width(0.5, 1.0) == 1


@pytest.mark.parametrize(("p_hat", "width"), [(0.5, 0.0), (0.5, 1.5), (-0.1, 0.1), (1.1, 0.1)])
def test_runs_for_width_rejects_bad_input(p_hat: float, width: float) -> None:
    with pytest.raises(StatsInputError):
        runs_for_width(p_hat, width)


@pytest.mark.parametrize(("p_hat", "target"), [(1.0, 0.95), (0.97, 0.95), (0.93, 0.9), (0.6, 0.5)])
def test_runs_for_lower_bound_is_the_smallest(p_hat: float, target: float) -> None:
    n = runs_for_lower_bound(p_hat, target)
    assert n is not None

    def lower(m: int) -> float:
        return float(wilson_intervals(np.array([p_hat * m]), np.array([m]))[0][0])

    assert lower(n) >= target > lower(n - 1)
    if p_hat == 1.0:  # lower bound n / (n + z²) >= t  <=>  n >= z² t / (1 - t)
        assert n == math.ceil(Z95**2 * target / (1 - target))
    assert runs_for_lower_bound(target, target) is None
    assert runs_for_lower_bound(target - 0.01, target) is None


# --- required value ----------------------------------------------------------------------------


def _reach_probability(p_true: float, runs: int, target: float, confidence: float) -> float:
    """Exact probability that a point with true success rate p_true has Wilson lower bound >= target."""
    counts = np.arange(runs + 1)
    lower, _ = wilson_intervals(counts, np.full(runs + 1, runs), confidence)
    return float(binom.pmf(counts, runs, p_true)[lower >= target].sum())


def test_required_value_recovers_closed_form_answer() -> None:
    # each robot survives with p = 0.9, the mission needs 20 survivors, sizes 20..40, 400 runs each
    sizes = np.arange(20, 41)
    runs, target, confidence = 400, 0.9, 0.95
    truth = np.array([k_out_of_n(int(n), 20, 0.9) for n in sizes])
    smallest_true = int(sizes[np.argmax(truth >= target)])  # 24 (P = 0.915)
    comfortable = int(sizes[np.argmax(truth >= target + 0.05)])  # 25 (P = 0.967)
    assert (smallest_true, comfortable) == (24, 25)

    # the claim "answer in [smallest_true, comfortable]" fails only if a size with P < target reaches it
    # or every size in the band misses; its exact probability, independently over sizes:
    reach = np.array([_reach_probability(p, runs, target, confidence) for p in truth])
    below = sizes < smallest_true
    band = (sizes >= smallest_true) & (sizes <= comfortable)
    p_claim = float(np.prod(1.0 - reach[below]) * (1.0 - np.prod(1.0 - reach[band])))
    assert p_claim > 0.9999

    successes = np.random.default_rng(20240601).binomial(runs, truth)
    answer = required_value(sizes, successes, np.full(sizes.size, runs), target, confidence, name="size")
    assert answer.value is not None and answer.index is not None
    assert smallest_true <= answer.value <= comfortable
    assert sizes[answer.index] == answer.value

    # and it is exactly the smallest size whose reference (scipy) Wilson lower bound reaches the target
    ref_lower = np.array(
        [binomtest(int(k), runs).proportion_ci(confidence, method="wilson").low for k in successes]
    )
    np.testing.assert_allclose(answer.lower_bounds, ref_lower, atol=1e-12)
    assert answer.value == sizes[np.argmax(ref_lower >= target)]
    assert "smallest swept size" in answer.note
    json.dumps(answer.to_dict())


def test_required_value_none_reaches_names_the_best() -> None:
    values = [10, 20, 40, 30]  # unsorted on purpose
    successes = [100, 170, 189, 185]
    runs = [200, 200, 200, 200]
    answer = required_value(values, successes, runs, target=0.95, name="size")
    assert answer.value is None and answer.index is None
    lower = np.array([wilson_interval(k, n)[0] for k, n in zip(successes, runs, strict=True)])
    np.testing.assert_allclose(answer.lower_bounds, lower)
    best = int(np.argmax(lower))
    assert values[best] == 40
    assert "none of the swept sizes reaches 0.95" in answer.note
    assert f"the best, 40, has lower bound {lower[best]:.3f}" in answer.note
    # 189/200 = 0.945 is below 0.95: more runs there cannot help
    assert "will not help" in answer.note


def test_required_value_names_a_key_s_values_in_the_plural() -> None:
    answer = required_value([1.0, 2.0], [0, 1], [40, 40], target=0.95, name="hazards.attrition.mtbf_h")
    assert answer.note.startswith("none of the swept values of hazards.attrition.mtbf_h reaches 0.95")
    assert answer.note.endswith("sweep larger values of hazards.attrition.mtbf_h")


def test_required_value_none_reaches_suggests_runs() -> None:
    # 58/60 observed (0.967) but the lower bound is only 0.886: more runs at 60 would settle it
    answer = required_value([50, 60], [50, 58], [60, 60], target=0.95)
    assert answer.value is None
    need = runs_for_lower_bound(58 / 60, 0.95)
    assert need is not None and need > 60
    assert f"about {need} runs at 60" in answer.note
    assert f"{answer.lower_bounds[1]:.3f}" in answer.note


def test_required_value_not_monotone() -> None:
    values = [50, 30, 40, 20]
    successes = [150, 199, 198, 120]  # 30 and 40 reach 0.95; 50 falls back
    runs = [200, 200, 200, 200]
    answer = required_value(values, successes, runs, target=0.95, name="size")
    lower = answer.lower_bounds
    assert lower[1] >= 0.95 and lower[2] >= 0.95 and lower[0] < 0.95 and lower[3] < 0.95
    assert answer.value == 30 and answer.index == 1
    assert "not monotone" in answer.note
    assert "30 reaches it but 50" in answer.note


def test_required_value_monotone_and_largest_notes() -> None:
    answer = required_value([10, 20, 30], [100, 199, 200], [200, 200, 200], target=0.95)
    assert answer.value == 20
    assert "also met at every larger value" in answer.note
    answer = required_value([10, 20, 30], [100, 150, 200], [200, 200, 200], target=0.95)
    assert answer.value == 30
    assert "largest" in answer.note


@pytest.mark.parametrize(
    ("values", "successes", "runs"),
    [([], [], []), ([1, 2], [1], [1, 1]), ([1, 1], [1, 1], [2, 2]), ([1, 2], [3, 1], [2, 2])],
)
def test_required_value_rejects_bad_input(values: list, successes: list, runs: list) -> None:
    with pytest.raises(StatsInputError):
        required_value(values, successes, runs)


# --- closed form and summaries -----------------------------------------------------------------


@pytest.mark.parametrize(
    ("n", "k", "p"), [(20, 20, 0.9), (30, 20, 0.9), (10, 3, 0.25), (7, 0, 0.5), (5, 6, 0.9)]
)
def test_k_out_of_n_matches_direct_sum(n: int, k: int, p: float) -> None:
    direct = sum(math.comb(n, j) * p**j * (1 - p) ** (n - j) for j in range(max(k, 0), n + 1))
    assert k_out_of_n(n, k, p) == pytest.approx(direct, rel=1e-12, abs=1e-15)


def test_k_out_of_n_edges() -> None:
    assert k_out_of_n(10, 0, 0.3) == 1.0
    assert k_out_of_n(10, 11, 0.99) == 0.0
    assert k_out_of_n(10, 10, 0.9) == pytest.approx(0.9**10, rel=1e-12)
    with pytest.raises(StatsInputError):
        k_out_of_n(10, 5, 1.5)


def test_distribution_with_nan() -> None:
    x = np.array([3.0, np.nan, 1.0, 7.0, np.nan, 5.0, 2.0])
    done = x[~np.isnan(x)]
    d = distribution(x)
    assert d["count"] == 7 and d["completed"] == 5
    assert d["mean"] == pytest.approx(18.0 / 5.0)
    assert d["median"] == 3.0
    assert d["p10"] == pytest.approx(np.nanpercentile(x, 10)) == pytest.approx(1.4)  # 1 + 0.4 * (2 - 1)
    assert d["p90"] == pytest.approx(np.percentile(done, 90)) == pytest.approx(6.2)  # 5 + 0.6 * (7 - 5)
    assert (d["min"], d["max"]) == (1.0, 7.0)
    json.dumps(d)


def test_distribution_all_nan_and_empty() -> None:
    for sample in (np.array([np.nan, np.nan]), np.array([])):
        d = distribution(sample)
        assert d["completed"] == 0 and d["count"] == sample.size
        assert all(d[key] is None for key in ("mean", "median", "p10", "p90", "min", "max"))
        json.dumps(d)


# --- a plan's expectation against its runs -------------------------------------------------------


def test_the_mean_interval_is_student_s_t_interval() -> None:
    """1..5: mean 3, s.d. sqrt(2.5), t(0.975, 4) = 2.7764 (a t table): 3 ± 2.7764 sqrt(2.5 / 5)."""
    low, high = mean_interval([1, 2, 3, 4, 5])
    assert (low, high) == pytest.approx((3 - 1.96324, 3 + 1.96324), abs=1e-5)
    # wider at higher confidence; t(0.995, 4) = 4.6041
    assert mean_interval([1, 2, 3, 4, 5], 0.99) == pytest.approx((3 - 3.25557, 3 + 3.25557), abs=1e-4)
    assert mean_interval([7.0]) is None and mean_interval([]) is None  # no spread to measure
    assert mean_interval([4.0, 4.0, 4.0]) is None  # every run the same: no spread to measure
    # a share cannot pass 1: 0.9, 1, 1 is 0.967 ± 4.3027 * 0.0333, cut at 1
    low, high = mean_interval([0.9, 1.0, 1.0], within=(0.0, 1.0))
    assert low == pytest.approx(0.96667 - 0.14342, abs=1e-4) and high == 1.0
    with pytest.raises(StatsInputError, match="confidence"):
        mean_interval([1, 2], 1.0)


def test_counts_that_are_all_alike_get_garwood_s_poisson_interval() -> None:
    """Exact Poisson 95% limits from a table (Garwood 1936): 0 -> 0 to 3.689, 2 -> 0.2422 to
    7.2247, 15 -> 8.3954 to 24.740; the mean of n runs is the total's limits over n."""
    assert count_mean_interval([0] * 10) == pytest.approx((0.0, 3.689 / 10), abs=1e-4)
    assert count_mean_interval([1, 1]) == pytest.approx((0.2422 / 2, 7.2247 / 2), abs=1e-4)
    assert count_mean_interval([5, 5, 5]) == pytest.approx((8.3954 / 3, 24.740 / 3), abs=1e-4)
    assert count_mean_interval([5, 5, 5], within=(0.0, 6.0))[1] == 6.0  # no more than were launched
    assert count_mean_interval([1, 2, 3, 4, 5]) == mean_interval([1, 2, 3, 4, 5])  # spread: the t interval
    assert count_mean_interval([3]) is None


def test_the_mean_interval_covers_the_true_mean_at_its_confidence() -> None:
    """Normal runs, 8 at a time: the t interval is exact, so 95% of them cover the mean (the normal
    quantile's narrower interval would cover about 91%)."""
    rng = np.random.default_rng(7)
    trials = 4000
    covered = sum(
        lo <= 0.9 <= hi for lo, hi in (mean_interval(rng.normal(0.9, 0.05, 8)) for _ in range(trials))
    )
    se = math.sqrt(0.95 * 0.05 / trials)
    assert abs(covered / trials - 0.95) < 4 * se


def test_agreement_says_which_way_a_plan_misses() -> None:
    assert agreement(0.95, (0.94, 0.96), more_is_better=True) == "agrees"
    assert agreement(0.94, (0.94, 0.96), more_is_better=True) == "agrees"  # the ends are inside
    # more found than the runs find: optimistic; fewer: conservative
    assert agreement(0.97, (0.94, 0.96), more_is_better=True) == "optimistic"
    assert agreement(0.90, (0.94, 0.96), more_is_better=True) == "conservative"
    # fewer lost than the runs lose: optimistic; more: conservative
    assert agreement(8.0, (9.0, 10.0), more_is_better=False) == "optimistic"
    assert agreement(11.0, (9.0, 10.0), more_is_better=False) == "conservative"
    assert agreement(None, (9.0, 10.0), more_is_better=False) is None
    assert agreement(9.5, None, more_is_better=False) is None
