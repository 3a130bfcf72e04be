"""Expected detection of a search plan, from its tracks as they will be driven over the ground.

`coverage.detection_probability` is Koopman's answer for infinitely many, infinitely long parallel
tracks over ground that can be driven everywhere. A real plan has track ends and outer edges,
stretches of track that cannot be driven (a driftwood log, a dune too steep to climb, a keep-out
zone) and mines that lie there all the same. `expected_detection` averages the sensor's detection
probability over the area where the mines may lie, at quasi-random points (scipy's scrambled
Sobol sequence with a fixed seed: the same plan gives the same number), against the track
segments a robot can actually drive:

- ``inverse_cube``: Koopman's detection rate c h / r^3 integrated along every segment (closed
  form, `inverse_cube_look`), p = 1 - exp(-W^2 / (8 pi) * sum integral ds / r^3); a straight pass
  at lateral distance x gives exactly 1 - exp(-W^2 / (4 pi x^2)). Segments beyond the range where
  a whole pass would detect with probability `INVERSE_CUBE_FLOOR` are cut, as the simulator cuts
  them (`inverse_cube_range_m`).
- ``cookie_cutter`` and ``random_search``: detected within W/2 of a segment;
- a tabulated lateral-range curve (`LateralRangeCurve`): one draw per pass at its closest
  approach, p = 1 - prod (1 - p(x_k)), where a pass is a run of joined segments of one track
  within the curve's range, as the simulator draws (`swarm.sim.sensing`). A draw per segment
  would count a pass again at every bend: a mine 1.5 m off the corner of a track was counted
  found with 1 - 0.6^2 = 0.64 where the curve says 0.4 (tests/planning/test_detection.py).

This is what the simulator does along the driven path (`swarm.sim.sensing`), so a plan that is
driven as planned finds, on average, the fraction this module predicts.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numba
import numpy as np
import shapely
from scipy.stats import qmc
from shapely.geometry import LineString
from shapely.geometry.base import BaseGeometry

from swarm.planning.costmap import CostMap

#: The inverse-cube curve is cut where a whole pass detects with less than this probability.
INVERSE_CUBE_FLOOR = 1e-3
#: Lateral distances below this count as this (m): the inverse-cube rate is singular on the track.
MIN_LATERAL_M = 0.05
#: Quasi-random points over the mine area: 2**SOBOL_POWER drawn in its bounding box.
SOBOL_POWER = 15


@dataclass(frozen=True)
class LateralRangeCurve:
    """A tabulated lateral-range curve: p(x) linear between its points, 0 beyond the last."""

    range_m: tuple[float, ...]
    probability: tuple[float, ...]

    @classmethod
    def of(cls, curve) -> LateralRangeCurve:
        """From a mission's `lateral_range:` (`swarm.mission.schema.LateralRange`)."""
        return cls(tuple(map(float, curve.range_m)), tuple(map(float, curve.probability)))

    def __call__(self, x: np.ndarray) -> np.ndarray:
        return np.interp(np.abs(np.asarray(x, dtype=np.float64)), self.range_m, self.probability, right=0.0)

    @property
    def max_range_m(self) -> float:
        """Where p falls to 0 for good: the simulator ends a pass beyond it (`swarm.sim.sensing`)."""
        last = max((k for k, p in enumerate(self.probability) if p > 0), default=0)
        return float(self.range_m[min(last + 1, len(self.range_m) - 1)])


def inverse_cube_range_m(sweep_width_m: float) -> float:
    """Lateral distance at which a whole inverse-cube pass detects with `INVERSE_CUBE_FLOOR`."""
    return sweep_width_m / math.sqrt(-4.0 * math.pi * math.log1p(-INVERSE_CUBE_FLOOR))


def segment_distance(a: np.ndarray, b: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Distance from each point m to the segment a-b (rows; any of them may broadcast)."""
    v = b - a
    w = m - a
    vv = np.sum(v * v, axis=-1)
    t = np.clip(np.sum(w * v, axis=-1) / np.where(vv > 0, vv, 1.0), 0.0, 1.0)
    e = w - t[..., None] * v
    return np.sqrt(np.sum(e * e, axis=-1))


def inverse_cube_look(a: np.ndarray, b: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Integral of ds / r^3 along each segment a-b (rows; any may broadcast) for the point m: with x
    the distance from m to the segment's line and s the coordinate along it,
    [s / (x^2 sqrt(x^2 + s^2))] between the ends. A whole straight pass gives 2 / x^2."""
    v = b - a
    length = np.sqrt(np.sum(v * v, axis=-1))
    moving = length > 1e-12
    u = v / np.where(moving, length, 1.0)[..., None]
    w = m - a
    s0 = -np.sum(w * u, axis=-1)
    s1 = s0 + length
    x = np.maximum(np.abs(u[..., 0] * w[..., 1] - u[..., 1] * w[..., 0]), MIN_LATERAL_M)
    x2 = x * x
    out = (s1 / np.sqrt(x2 + s1 * s1) - s0 / np.sqrt(x2 + s0 * s0)) / x2
    return np.where(moving, out, 0.0)


def drivable_segments(
    tracks: list[LineString], cm: CostMap | None, step_m: float | None = None, margin_m: float = 0.0
) -> np.ndarray:
    """The stretches of `tracks` a robot can drive, as segments (k, 2, 2): each track sampled every
    `step_m` (half a cell by default), runs of samples on blocked cells, or within `margin_m` of
    them, dropped. Without a cost map the tracks' own segments."""
    out: list[np.ndarray] = []
    for t in tracks:
        xy = np.asarray(t.coords, dtype=np.float64)
        if len(xy) < 2:
            continue
        if cm is None:
            out.append(np.stack([xy[:-1], xy[1:]], axis=1))
            continue
        step = cm.cell_m / 2.0 if step_m is None else step_m
        for a, b in itertools.pairwise(xy):
            k = max(2, math.ceil(float(np.hypot(*(b - a))) / step) + 1)
            pts = a + (b - a) * np.linspace(0.0, 1.0, k)[:, None]
            ok = cm.is_free(pts[:, 0], pts[:, 1])
            if margin_m > 0:
                row, col = cm.cell_of(pts[:, 0], pts[:, 1])
                ok &= cm.clearance_m[row, col] >= cm.inflation_m + margin_m
            both = ok[:-1] & ok[1:]
            if both.any():
                out.append(np.stack([pts[:-1][both], pts[1:][both]], axis=1))
    if not out:
        return np.empty((0, 2, 2))
    return _merge_collinear(np.concatenate(out))


def clip_tracks(
    tracks: list[LineString], cm: CostMap, margin_m: float, min_length_m: float
) -> list[LineString]:
    """`tracks` cut to the ground a robot can drive with `margin_m` to spare (`drivable_segments`),
    in the same order, pieces shorter than `min_length_m` dropped: a track laid along the brink of
    a dune or a log is where a robot slides off and sticks."""
    out = []
    for t in tracks:
        for a, b in drivable_segments([t], cm, margin_m=margin_m):
            if float(np.hypot(*(b - a))) >= min_length_m:
                out.append(LineString([a, b]))
    return out


def _merge_collinear(seg: np.ndarray) -> np.ndarray:
    """Join consecutive segments that continue one another in a straight line (a sampled track
    back into one segment per drivable stretch), so the integral runs over few segments."""
    if len(seg) < 2:
        return seg
    d = seg[:, 1] - seg[:, 0]
    joins = np.all(np.abs(seg[1:, 0] - seg[:-1, 1]) < 1e-9, axis=1)
    cross = np.abs(d[1:, 0] * d[:-1, 1] - d[1:, 1] * d[:-1, 0])
    dot = np.sum(d[1:] * d[:-1], axis=1)
    same = joins & (cross <= 1e-9 * np.maximum(dot, 1e-12)) & (dot > 0)
    starts = np.flatnonzero(~np.concatenate([[False], same]))
    ends = np.concatenate([starts[1:], [len(seg)]]) - 1
    return np.stack([seg[starts, 0], seg[ends, 1]], axis=1)


def sample_points(area: BaseGeometry, ground: CostMap | None = None, power: int = SOBOL_POWER) -> np.ndarray:
    """Quasi-random points (scrambled Sobol, fixed seed) uniform over `area`, and over the ground
    that can be crossed in it when a cost map is given (where the simulator lays mines)."""
    x0, y0, x1, y1 = area.bounds
    pts = qmc.scale(qmc.Sobol(d=2, scramble=True, seed=0).random_base2(power), (x0, y0), (x1, y1))
    keep = shapely.contains_xy(area, pts[:, 0], pts[:, 1])
    if ground is not None:
        keep &= ground.ground_free(pts[:, 0], pts[:, 1])
    return pts[keep]


def detection_map(
    points: np.ndarray,
    segments: np.ndarray,
    model: str,
    sweep_width_m: float,
    lateral_range: LateralRangeCurve | None = None,
) -> np.ndarray:
    """Probability that each point is detected by sensors driven along `segments` (module
    docstring). Segments in track order: each that starts where the one before it ends continues
    its track (`drivable_segments` gives them so)."""
    n = len(points)
    if not len(segments) or not n:
        return np.zeros(n)
    a, b = segments[:, 0], segments[:, 1]
    if lateral_range is not None:
        return _pass_detection(np.asarray(points, dtype=np.float64), a, b, lateral_range)
    # a block of segments at a time against every point keeps memory at (block x points)
    block = max(1, 2_000_000 // max(n, 1))
    if model == "inverse_cube":
        exposure = _inverse_cube_exposure(points, a, b, inverse_cube_range_m(sweep_width_m), block)
        return -np.expm1(-(sweep_width_m**2) / (8.0 * math.pi) * exposure)
    reach = sweep_width_m / 2.0
    seen = np.zeros(n, bool)
    for s in range(0, len(segments), block):
        d = segment_distance(a[s : s + block, None, :], b[s : s + block, None, :], points[None, :, :])
        seen |= (d <= reach).any(axis=0)
    return seen.astype(np.float64)


def _pass_detection(points: np.ndarray, a: np.ndarray, b: np.ndarray, curve: LateralRangeCurve) -> np.ndarray:
    """A tabulated curve: one draw per pass at its closest approach. The (segment, point) pairs
    within the curve's range (shapely's tree); a pass is a run of them, for one point, over
    consecutive segments each starting where the one before it ends; it detects with p at its
    least distance, and passes miss independently."""
    reach = curve.max_range_m
    lines = shapely.linestrings(np.stack([a, b], axis=1))
    seg, pt = shapely.STRtree(shapely.points(points)).query(lines, predicate="dwithin", distance=reach)
    miss = np.ones(len(points))
    if not len(seg):
        return 1.0 - miss
    order = np.lexsort((seg, pt))
    seg, pt = seg[order], pt[order]
    d = segment_distance(a[seg], b[seg], points[pt])
    joined = np.zeros(len(a), bool)
    joined[1:] = np.hypot(*(a[1:] - b[:-1]).T) <= 1e-9 * (1.0 + np.abs(b[:-1]).max(axis=1))
    new = np.ones(len(seg), bool)
    new[1:] = (pt[1:] != pt[:-1]) | (seg[1:] != seg[:-1] + 1) | ~joined[seg[1:]]
    starts = np.flatnonzero(new)
    closest = np.minimum.reduceat(d, starts)
    np.multiply.at(miss, pt[starts], 1.0 - curve(closest))
    return 1.0 - miss


@numba.njit(cache=True, error_model="numpy")
def _inverse_cube_exposure(points, a, b, reach, block):
    """Sum over the segments a-b within `reach` of each point of `inverse_cube_look`: the numbers
    of `segment_distance` and `inverse_cube_look` operation for operation, summed as numpy sums a
    (block x points) array over its blocks of segments (each block's rows in order, then the
    blocks), so the same floats. A segment whose box, widened by the reach and a margin far above
    rounding, leaves a point out is skipped: it is beyond reach and adds 0."""
    m, n = a.shape[0], points.shape[0]
    margin = reach * (1.0 + 1e-9) + 1e-9
    lo_x = np.minimum(a[:, 0], b[:, 0]) - margin
    hi_x = np.maximum(a[:, 0], b[:, 0]) + margin
    lo_y = np.minimum(a[:, 1], b[:, 1]) - margin
    hi_y = np.maximum(a[:, 1], b[:, 1]) + margin
    out = np.zeros(n)
    for p in range(n):
        px, py = points[p, 0], points[p, 1]
        total = 0.0
        for first in range(0, m, block):
            part = 0.0
            for k in range(first, min(first + block, m)):
                if px < lo_x[k] or px > hi_x[k] or py < lo_y[k] or py > hi_y[k]:
                    continue
                ax, ay = a[k, 0], a[k, 1]
                vx, vy = b[k, 0] - ax, b[k, 1] - ay
                wx, wy = px - ax, py - ay
                # segment_distance
                vv = vx * vx + vy * vy
                t = (wx * vx + wy * vy) / (vv if vv > 0 else 1.0)
                t = min(max(t, 0.0), 1.0)
                ex, ey = wx - t * vx, wy - t * vy
                if not math.sqrt(ex * ex + ey * ey) <= reach:
                    continue
                # inverse_cube_look
                length = math.sqrt(vv)
                if not length > 1e-12:
                    continue  # a point segment looks at nothing
                ux, uy = vx / length, vy / length
                s0 = -(wx * ux + wy * uy)
                s1 = s0 + length
                x = max(abs(ux * wy - uy * wx), MIN_LATERAL_M)
                x2 = x * x
                part += (s1 / math.sqrt(x2 + s1 * s1) - s0 / math.sqrt(x2 + s0 * s0)) / x2
            total += part
        out[p] = total
    return out


def expected_detection(
    area: BaseGeometry,
    segments: np.ndarray,
    model: str,
    sweep_width_m: float,
    lateral_range: LateralRangeCurve | None = None,
    ground: CostMap | None = None,
) -> float:
    """Expected fraction of mines uniform over `area` (over its ground that can be crossed, with
    `ground`) detected by sensors along `segments`."""
    pts = sample_points(area, ground)
    if not len(pts):
        return 0.0
    return float(detection_map(pts, segments, model, sweep_width_m, lateral_range).mean())
