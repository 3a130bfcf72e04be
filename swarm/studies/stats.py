"""Statistics for Monte Carlo studies: how sure are we that a mission succeeds, and how many robots it needs.

A study runs the mission many times at each point of a parameter sweep (swarm size 10..60, say) and
records a boolean `success` per run. The questions users ask are binomial ones:

- what is the success probability at this point, with a confidence interval? `wilson_interval` /
  `wilson_intervals`: the Wilson (1927) score interval, which Brown, Cai & DasGupta (2001,
  "Interval estimation for a binomial proportion", Statistical Science 16(2)) recommend over the
  Wald interval: it never leaves [0, 1], is not degenerate at 0 or n successes, and its coverage
  stays close to nominal at the small run counts and high success rates studies produce;
- how many runs are needed for an interval this narrow? `runs_for_width`, solved exactly for the
  Wilson width rather than with the Wald shortcut z² p(1-p) / (w/2)²;
- what is the smallest swarm that succeeds with probability `target`, with `confidence`?
  `required_value`: the smallest swept value whose Wilson lower bound reaches the target, with a
  note a person can act on when none does or the answer is not clear-cut.

`k_out_of_n` is the closed form of the simplest attrition mission (k of n robots must survive, each
independently), which the test suite uses to check the study machinery against a known truth.
`distribution` summarises a per-run quantity (e.g. completion time, NaN when never completed).

Does the simulation deliver what the plan promised? `mean_interval` is the Student t interval of a
per-run mean (mines found, robots lost); `agreement` says whether the plan's number lies inside it,
or where it lies outside it, promising more than the runs give (optimistic) or less (conservative).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from numbers import Real

import numpy as np
from scipy.stats import binom, chi2, norm
from scipy.stats import t as student_t

from swarm.errors import SwarmError

__all__ = [
    "RequiredAnswer",
    "StatsInputError",
    "agreement",
    "count_mean_interval",
    "distribution",
    "k_out_of_n",
    "mean_interval",
    "required_value",
    "runs_for_lower_bound",
    "runs_for_width",
    "wilson_interval",
    "wilson_intervals",
]


class StatsInputError(SwarmError, ValueError):
    """A statistics argument out of its domain (a confidence of 1.2, more successes than runs, ...).

    A `SwarmError` so the CLI reports it in one line; a `ValueError` for callers that expect one.
    """


def _z(confidence: float) -> float:
    """Two-sided normal quantile for `confidence`, checked to lie strictly inside (0, 1)."""
    if not (isinstance(confidence, Real) and 0.0 < confidence < 1.0):
        raise StatsInputError(f"confidence must be strictly between 0 and 1, found {confidence!r}")
    return float(norm.ppf(0.5 + confidence / 2.0))


def _check_probability(name: str, p: float, *, open_interval: bool = False) -> None:
    ok = isinstance(p, Real) and (0.0 < p < 1.0 if open_interval else 0.0 <= p <= 1.0)
    if not ok:
        bounds = "strictly between 0 and 1" if open_interval else "between 0 and 1"
        raise StatsInputError(f"{name} must be {bounds}, found {p!r}")


def _wilson(successes: np.ndarray, runs: np.ndarray, z: float) -> tuple[np.ndarray, np.ndarray]:
    """Wilson bounds for (possibly fractional) counts, unchecked.

    Written as centre (k + z²/2) / (n + z²) ± z sqrt(k(n-k)/n + z²/4) / (n + z²), which is the
    textbook form multiplied through by n: no division by n in the centre, exact at k = 0 and k = n
    (set explicitly, since sqrt(z²/4) need not round to z/2), and runs = 0 gives the vacuous (0, 1).
    """
    k = np.asarray(successes, dtype=float)
    n = np.asarray(runs, dtype=float)
    k, n = np.broadcast_arrays(k, n)
    z2 = z * z
    with np.errstate(divide="ignore", invalid="ignore"):
        spread = np.where(n > 0, k * (n - k) / np.where(n > 0, n, 1.0), 0.0)
        centre = (k + z2 / 2.0) / (n + z2)
        half = z * np.sqrt(np.maximum(spread, 0.0) + z2 / 4.0) / (n + z2)
    lower = np.where(k <= 0, 0.0, np.clip(centre - half, 0.0, 1.0))
    upper = np.where(k >= n, 1.0, np.clip(centre + half, 0.0, 1.0))
    empty = n <= 0
    return np.where(empty, 0.0, lower), np.where(empty, 1.0, upper)


def wilson_interval(successes: int, runs: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval for `successes` out of `runs`; (0, 1) when there are no runs.

    Preferred over Wald's p ± z sqrt(p(1-p)/n) because Wald collapses to a point at 0 or n successes,
    exactly where a study of a reliable mission lands.
    """
    z = _z(confidence)
    for name, x in (("successes", successes), ("runs", runs)):
        if not isinstance(x, int | np.integer) or isinstance(x, bool):
            raise StatsInputError(f"{name} must be an integer, found {x!r}")
    if not 0 <= successes <= runs:
        raise StatsInputError(f"need 0 <= successes <= runs, found successes={successes}, runs={runs}")
    lower, upper = _wilson(np.asarray(successes), np.asarray(runs), z)
    return float(lower), float(upper)


def wilson_intervals(
    successes: np.ndarray, runs: np.ndarray, confidence: float = 0.95
) -> tuple[np.ndarray, np.ndarray]:
    """Vectorized `wilson_interval`: (lower, upper) arrays of the broadcast shape of the inputs.

    Counts may be fractional (p_hat * n), so planning code can ask what interval an observed rate
    would have at a run count not yet made; rows with runs == 0 get (0, 1).
    """
    z = _z(confidence)
    k = np.asarray(successes, dtype=float)
    n = np.asarray(runs, dtype=float)
    if k.size and n.size:
        kb, nb = np.broadcast_arrays(k, n)
        if not (np.all(np.isfinite(kb)) and np.all(np.isfinite(nb))):
            raise StatsInputError("successes and runs must be finite")
        if np.any(kb < 0) or np.any(kb > nb):
            raise StatsInputError("need 0 <= successes <= runs in every row")
    return _wilson(k, n, z)


def _width(p_hat: float, n: int, z: float) -> float:
    lower, upper = _wilson(np.asarray(p_hat * n), np.asarray(n), z)
    return float(upper - lower)


def runs_for_width(p_hat: float, width: float, confidence: float = 0.95) -> int:
    """Smallest number of runs whose Wilson interval at observed rate `p_hat` is at most `width` wide.

    `width` is the full width (upper - lower). At fixed p_hat the Wilson width
    2z sqrt(p(1-p) n + z²/4) / (n + z²) decreases strictly in n (its derivative has the sign of
    p(1-p)(z² - n) - z²/2 < 0), so setting it equal to `width` gives a quadratic in n whose larger root,
    rounded up, is the answer; the result is then checked against the interval itself so floating
    point cannot put it one off. This is the exact Wilson answer, smaller than Wald's at p_hat = 1/2
    (381 against 385 for a width of 0.1) and finite and sensible at p_hat = 0 or 1, where Wald says 0.
    """
    z = _z(confidence)
    _check_probability("p_hat", p_hat)
    if not (isinstance(width, Real) and 0.0 < width <= 1.0):
        raise StatsInputError(f"width must be in (0, 1], found {width!r}")
    a = p_hat * (1.0 - p_hat)
    z2 = z * z
    # width² (n + z²)² = 4 z² (a n + z²/4)  ->  w² n² + (2 w² z² - 4 z² a) n + (w² z⁴ - z⁴) = 0
    qa = width * width
    qb = 2.0 * qa * z2 - 4.0 * z2 * a
    qc = qa * z2 * z2 - z2 * z2
    root = (-qb + math.sqrt(max(qb * qb - 4.0 * qa * qc, 0.0))) / (2.0 * qa)
    n = max(1, math.ceil(root))
    while _width(p_hat, n, z) > width:
        n += 1
    while n > 1 and _width(p_hat, n - 1, z) <= width:
        n -= 1
    return n


def runs_for_lower_bound(p_hat: float, target: float, confidence: float = 0.95) -> int | None:
    """Smallest number of runs at which an observed rate `p_hat` has a Wilson lower bound >= `target`.

    None when p_hat <= target: no number of runs lifts the lower bound past the observed rate. The
    lower bound L solves (p_hat - L)² n = z² L (1 - L) below p_hat and rises strictly with n, so
    L = target exactly at n = z² t (1 - t) / (p_hat - t)²; rounded up and checked against the interval.
    """
    z = _z(confidence)
    _check_probability("p_hat", p_hat)
    _check_probability("target", target, open_interval=True)
    if p_hat <= target:
        return None
    n = max(1, math.ceil(z * z * target * (1.0 - target) / (p_hat - target) ** 2))

    def lower(m: int) -> float:
        return float(_wilson(np.asarray(p_hat * m), np.asarray(m), z)[0])

    while lower(n) < target:
        n += 1
    while n > 1 and lower(n - 1) >= target:
        n -= 1
    return n


@dataclass(frozen=True)
class RequiredAnswer:
    """What `required_value` found.

    value/index: the smallest swept value (and its index in the input order) whose Wilson lower
    bound reaches the target, or None when none does; lower_bounds: the lower bound at every point,
    in input order; note: one or two sentences a person can act on.
    """

    value: float | None
    index: int | None
    lower_bounds: np.ndarray
    note: str

    def to_dict(self) -> dict[str, object]:
        """JSON-ready form, for summary.json."""
        return {
            "value": self.value,
            "index": self.index,
            "lower_bounds": [float(x) for x in self.lower_bounds],
            "note": self.note,
        }


def _fmt_value(x: float) -> str:
    return f"{x:g}"


def _pct(confidence: float) -> str:
    return f"{100.0 * confidence:g}%"


def required_value(
    values: Sequence[float],
    successes: Sequence[int],
    runs: Sequence[int],
    target: float = 0.95,
    confidence: float = 0.95,
    *,
    name: str = "value",
) -> RequiredAnswer:
    """Smallest swept value (e.g. swarm size) whose success probability is >= `target` with `confidence`.

    A point qualifies when the lower end of its two-sided Wilson interval reaches the target, so a
    point that merely observed a high rate over few runs does not. The smallest qualifying value is
    reported even when a larger one falls short again (noise, or a real non-monotone effect such as
    congestion); the note says so, because then the answer is less settled than it looks. `name` is
    what the values are ("swarm size"), used in the note.
    """
    z = _z(confidence)
    _check_probability("target", target, open_interval=True)
    v = np.asarray(values, dtype=float)
    k = np.asarray(successes)
    n = np.asarray(runs)
    if v.ndim != 1 or k.shape != v.shape or n.shape != v.shape:
        raise StatsInputError(
            f"values, successes and runs must be equal-length 1-D sequences, "
            f"found lengths {v.shape}, {k.shape}, {n.shape}"
        )
    if v.size == 0:
        raise StatsInputError("values is empty: nothing was swept")
    if not np.all(np.isfinite(v)):
        raise StatsInputError("values must be finite numbers")
    if len(np.unique(v)) != v.size:
        raise StatsInputError("values must be distinct: merge the runs of repeated points first")
    for label, arr in (("successes", k), ("runs", n)):
        if not (np.issubdtype(arr.dtype, np.integer) or arr.dtype == bool):
            raise StatsInputError(f"{label} must be integer counts, found dtype {arr.dtype}")
    if np.any(k < 0) or np.any(k > n):
        raise StatsInputError("need 0 <= successes <= runs at every point")

    lower, _ = _wilson(k, n, z)
    order = np.argsort(v, kind="stable")
    reached = lower >= target
    plural = f"{name}s" if name.replace(" ", "").isalpha() else f"values of {name}"
    goal = f"{target:g} at {_pct(confidence)} confidence"

    hits = [int(i) for i in order if reached[i]]
    if not hits:
        best = int(max(order, key=lambda i: (lower[i], v[i])))
        ki, ni = int(k[best]), int(n[best])
        head = (
            f"none of the swept {plural} reaches {goal}: the best, {_fmt_value(v[best])}, "
            f"has lower bound {lower[best]:.3f} ({ki}/{ni} successes)"
        )
        p_hat = ki / ni if ni else 0.0
        need = runs_for_lower_bound(p_hat, target, confidence) if ni else None
        if ni == 0:
            tail = "; it has no runs yet: run the study there"
        elif need is None:
            tail = (
                f"; its observed rate {p_hat:.3f} is not above {target:g}, so more runs there will not "
                f"help: sweep larger {plural}"
            )
        else:
            tail = (
                f"; run more points or more runs (about {need} runs at {_fmt_value(v[best])} would bring "
                f"the lower bound to {target:g} if its observed rate {p_hat:.3f} held)"
            )
        return RequiredAnswer(None, None, lower, head + tail)

    idx = hits[0]
    head = (
        f"{_fmt_value(v[idx])} is the smallest swept {name} that reaches {goal} "
        f"(lower bound {lower[idx]:.3f}, {int(k[idx])}/{int(n[idx])} successes)"
    )
    larger = [int(i) for i in order if v[i] > v[idx]]
    misses = [i for i in larger if not reached[i]]
    if not larger:
        tail = f"; it is the largest swept {name}, so nothing above it was checked"
    elif not misses:
        tail = f"; also met at every larger {name}"
    else:
        shown = ", ".join(f"{_fmt_value(v[i])} (lower bound {lower[i]:.3f})" for i in misses[:5])
        more = f" and {len(misses) - 5} more" if len(misses) > 5 else ""
        verb = "does" if len(misses) == 1 else "do"
        tail = (
            f"; not monotone: {_fmt_value(v[idx])} reaches it but {shown}{more} {verb} not; "
            f"more runs at these {plural} would show whether that is noise"
        )
    return RequiredAnswer(float(v[idx]), idx, lower, head + tail)


def k_out_of_n(n: int, k: int, p: float) -> float:
    """P(Binomial(n, p) >= k): a mission that needs k of n robots, each surviving independently with p.

    The closed form the study machinery is checked against; 1 for k <= 0 and 0 for k > n.
    """
    if not isinstance(n, int | np.integer) or n < 0:
        raise StatsInputError(f"n must be a non-negative integer, found {n!r}")
    if not isinstance(k, int | np.integer):
        raise StatsInputError(f"k must be an integer, found {k!r}")
    _check_probability("p", p)
    return float(binom.sf(k - 1, n, p))


def mean_interval(
    values: Sequence[float],
    confidence: float = 0.95,
    within: tuple[float, float] = (-math.inf, math.inf),
) -> tuple[float, float] | None:
    """The Student t interval of the mean of i.i.d. runs' values: the runs of a study are
    independent draws of the same mission, and their mean is what a plan predicts. Cut to
    `within`, the range the mean cannot leave (a share of the mines found: 0 to 1). None below two
    runs, and when every run gave the same value: the sample has no spread to measure, and an
    interval of zero width would call a plan a hair off optimistic or conservative (two runs that
    each lost one robot against a plan of 1.03)."""
    _z(confidence)  # checks the confidence
    x = np.asarray(values, dtype=float).ravel()
    if x.size < 2:
        return None
    mean, sem = float(np.mean(x)), float(np.std(x, ddof=1)) / math.sqrt(x.size)
    if sem == 0.0:
        return None
    low, high = student_t.interval(confidence, x.size - 1, loc=mean, scale=sem)
    return max(float(low), within[0]), min(float(high), within[1])


def count_mean_interval(
    counts: Sequence[int],
    confidence: float = 0.95,
    within: tuple[float, float] = (0.0, math.inf),
) -> tuple[float, float] | None:
    """The interval of the mean of runs' counts (robots lost a run): `mean_interval`, or where
    every run counted the same, Garwood's exact Poisson interval of the mean (the total L over n
    runs: chi2(a/2, 2L) / 2n to chi2(1 - a/2, 2L + 2) / 2n; Garwood, Biometrika 27, 1936), which
    still tells three runs that each lost 5 robots from a plan of 0.77, and two that each lost 1
    from a plan of 1.03 not. Cut to `within` (at most the robots launched). None below two runs."""
    x = np.asarray(counts, dtype=float).ravel()
    interval = mean_interval(x, confidence, within)
    if interval is not None or x.size < 2:
        return interval
    total, alpha = float(x.sum()), 1.0 - confidence
    low = float(chi2.ppf(alpha / 2, 2 * total)) / (2 * x.size) if total > 0 else 0.0
    high = float(chi2.ppf(1 - alpha / 2, 2 * total + 2)) / (2 * x.size)
    return max(low, within[0]), min(high, within[1])


def agreement(
    planned: float | None, interval: tuple[float, float] | None, *, more_is_better: bool
) -> str | None:
    """Where a plan's expected value lies against the runs' `mean_interval`: "agrees" inside it;
    outside, "optimistic" when it promises better than the runs give (more mines found, fewer robots
    lost: `more_is_better` says which way is better), else "conservative". None without either."""
    if planned is None or interval is None:
        return None
    low, high = interval
    if low <= planned <= high:
        return "agrees"
    above = planned > high
    return "optimistic" if above == more_is_better else "conservative"


def distribution(values: np.ndarray) -> dict[str, int | float | None]:
    """JSON-ready summary of a per-run sample in which NaN means "never completed".

    count is every run, completed the non-NaN ones; the statistics (mean, median, p10, p90, min,
    max) are over the completed runs only and None when there are none, so a report can show that
    a quantity was never reached instead of a misleading number.
    """
    x = np.asarray(values, dtype=float).ravel()
    done = x[~np.isnan(x)]
    out: dict[str, int | float | None] = {"count": int(x.size), "completed": int(done.size)}
    if done.size == 0:
        out.update(mean=None, median=None, p10=None, p90=None, min=None, max=None)
        return out
    p10, p50, p90 = np.percentile(done, [10.0, 50.0, 90.0])
    out.update(
        mean=float(np.mean(done)),
        median=float(p50),
        p10=float(p10),
        p90=float(p90),
        min=float(np.min(done)),
        max=float(np.max(done)),
    )
    return out
