"""One path over a `CostMap` with OMPL: a point robot in the plane, the footprint in the grid.

The state space is `RealVectorStateSpace(2)` over the map's bounds. A state is valid when its cell
is not `blocked` (the footprint-inflated grid); OMPL checks motions at points `resolution_m`
apart, which the inflation margin covers (see `swarm.planning.costmap`). A motion is checked in
one compiled pass over those points (`_motion_free`: the points and the answer of OMPL's
`DiscreteMotionValidator`, without a Python call per point). The objective is path
length (OMPL's own) or terrain cost: an `ob.OptimizationObjective` subclass whose `motionCost`
is the exact integral of cost per metre along the segment, with `min_cost_per_m x distance` as
its admissible heuristic.

Reproducibility: OMPL's random seed is set before any planner object exists, from the caller's
seed (`numpy.random.SeedSequence`), and an iteration budget stops the planner after a fixed
number of iterations; simplification runs to convergence, never against the clock.

Roadmaps (PRM, PRMstar): OMPL grows the roadmap (a fixed number of samples and expansion steps,
so it is reproducible), which is then kept as numpy arrays. A query joins the start and goal to
their nearest roadmap vertices they can reach in a straight line and runs scipy's Dijkstra over
the graph; OMPL's PathSimplifier then smooths the route. OMPL's own PRM query races a solution
thread against roadmap growth on the clock, so it would neither repeat nor run with a Python cost
function; the arrays also travel to worker processes, where OMPL objects cannot.

OMPL objects live only inside these functions; results are numpy arrays.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cache, cached_property

import numba
import numpy as np

from swarm.planning.costmap import CostMap, NoPathError, format_point
from swarm.planning.profiles import DEFAULT_PROFILE, PlannerProfile, setter_name


@dataclass(frozen=True, eq=False)
class PathResult:
    """A planned path and how it was found."""

    waypoints_m: np.ndarray  # (k, 2) world x, y
    length_m: float
    cost: float  # integral of terrain cost per metre (1.0 a metre on the fastest dry mode, concrete)
    time_s: float  # driving time at the nominal wheel speed: cost / reference speed
    solve_ms: float  # planner (or roadmap query) time
    simplify_ms: float  # simplification and interpolation
    iterations: int  # planner iterations used (roadmap: 0)
    planner: str
    profile: str
    objective: str
    seed: int  # the OMPL seed this path was planned with
    status: str

    def as_dict(self) -> dict:
        return {
            "waypoints_m": np.round(self.waypoints_m, 4).tolist(),
            "length_m": round(self.length_m, 4),
            "cost": round(self.cost, 4),
            "time_s": round(self.time_s, 2),
            "solve_ms": round(self.solve_ms, 3),
            "simplify_ms": round(self.simplify_ms, 3),
            "iterations": self.iterations,
            "planner": self.planner,
            "profile": self.profile,
            "objective": self.objective,
            "ompl_seed": self.seed,
            "status": self.status,
        }


@dataclass(frozen=True, eq=False)
class Roadmap:
    """A PRM roadmap as arrays: vertices, undirected edges and their objective costs."""

    vertices_m: np.ndarray  # (n, 2)
    edges: np.ndarray  # (m, 2) vertex indices, i < j
    weights: np.ndarray  # (m,) objective cost of each edge
    objective: str
    planner: str
    build_ms: float
    seed: int

    @cached_property
    def tree(self):
        from scipy.spatial import cKDTree

        return cKDTree(self.vertices_m)

    @property
    def n_vertices(self) -> int:
        return len(self.vertices_m)


def ompl_seed(seq: np.random.SeedSequence) -> int:
    """A non-zero 31-bit seed for OMPL's RNG from a numpy SeedSequence."""
    return int(seq.generate_state(1, np.uint32)[0]) % 2_147_483_646 + 1


@contextmanager
def _ompl_quiet():
    """OMPL logs warnings to stderr; the library does not print."""
    from ompl import util as ou

    level = ou.getLogLevel()
    ou.setLogLevel(ou.LOG_ERROR)
    try:
        yield
    finally:
        ou.setLogLevel(level)


def seed_ompl(seed: int) -> None:
    """Seed OMPL's global RNG; planners and simplifiers created after this draw from it.

    OMPL logs an error when re-seeded after sampling started, yet re-seeds the seed generator
    anyway: in one process, the same seed before the same calls gives the same samples.
    """
    from ompl import util as ou

    level = ou.getLogLevel()
    ou.setLogLevel(ou.LOG_NONE)
    try:
        ou.RNG.setSeed(int(seed))
    finally:
        ou.setLogLevel(level)


#: Planners that ask a motion for its last valid state (`checkMotion` with `lastValid`), which a
#: Python motion validator cannot hand back through the bindings, so they keep OMPL's own
#: validator: the KPIECE family, and PRM's roadmap expansion (random bounce motions; its growth
#: checks on the grid, `build_roadmap`).
LAST_VALID_PLANNERS = frozenset({"KPIECE1", "BKPIECE1", "LBKPIECE1", "PRM", "PRMstar"})


def _padded_grid(cm: CostMap) -> tuple[np.ndarray, int, float, float, float]:
    """The blocked grid flattened with one extra blocked row and column (a state on the map's north
    or east edge, x = xmax, reads it), its row stride, 1 / cell size and the origin."""
    padded = np.pad(cm.blocked, ((0, 1), (0, 1)), constant_values=True)
    return padded.ravel().astype(np.uint8), padded.shape[1], 1.0 / cm.cell_m, *map(float, cm.origin_m)


def _validity_checker(cm: CostMap) -> Callable[[object], bool]:
    flat, stride, inv, ox, oy = _padded_grid(cm)
    blocked = flat.tobytes()

    def valid(state) -> bool:
        # OMPL keeps states inside the bounds, so both indices are >= 0
        return not blocked[int((state[1] - oy) * inv) * stride + int((state[0] - ox) * inv)]

    return valid


@numba.njit(cache=True)
def _motion_free(blocked, stride, inv, ox, oy, x1, y1, x2, y2, longest) -> bool:
    """OMPL's `DiscreteMotionValidator.checkMotion(s1, s2)` over the grid: s2 and the points j / nd
    of the way for j = 1 .. nd - 1, nd = ceil(|s2 - s1| / longest valid segment), each
    interpolated as `RealVectorStateSpace.interpolate` does; so the same points and the same
    answer (it only says whether all are valid, not in which order they were looked at)."""
    if _blocked_at(blocked, stride, inv, ox, oy, x2, y2):
        return False
    dx, dy = x1 - x2, y1 - y2
    nd = math.ceil(math.sqrt(dx * dx + dy * dy) / longest)
    for j in range(1, nd):
        t = float(j) / float(nd)
        if _blocked_at(blocked, stride, inv, ox, oy, x1 + (x2 - x1) * t, y1 + (y2 - y1) * t):
            return False
    return True


@numba.njit(cache=True, inline="always")
def _blocked_at(blocked, stride, inv, ox, oy, x, y) -> bool:
    """`_validity_checker`'s lookup, negated: the padded grid's cell under a state in the bounds."""
    return blocked[int((y - oy) * inv) * stride + int((x - ox) * inv)]


@cache
def _grid_motion_validator_class():
    from ompl import base as ob

    class GridMotionValidator(ob.MotionValidator):
        """A motion checked in one compiled pass (`_motion_free`), not a Python call per point."""

        def __init__(self, si, cm: CostMap) -> None:
            super().__init__(si)
            self._grid = _padded_grid(cm)
            self._longest = si.getStateSpace().getLongestValidSegmentLength()

        def checkMotion(self, s1, s2) -> bool:
            return bool(_motion_free(*self._grid, s1[0], s1[1], s2[0], s2[1], self._longest))

    return GridMotionValidator


def _check_motions_on_grid(si, cm: CostMap) -> None:
    si.setMotionValidator(_grid_motion_validator_class()(si, cm))
    si.setup()


def _space_information(cm: CostMap, planners: Sequence[str] = ()):
    """OMPL's space over `cm` for `planners` to run in (none: only the path simplifier), with the
    grid motion validator unless one of them needs OMPL's own (`LAST_VALID_PLANNERS`)."""
    from ompl import base as ob

    space = ob.RealVectorStateSpace(2)
    bounds = ob.RealVectorBounds(2)
    xmin, ymin, xmax, ymax = cm.bounds_m
    bounds.setLow(0, xmin)
    bounds.setHigh(0, xmax)
    bounds.setLow(1, ymin)
    bounds.setHigh(1, ymax)
    space.setBounds(bounds)
    si = ob.SpaceInformation(space)
    si.setStateValidityChecker(_validity_checker(cm))
    si.setStateValidityCheckingResolution(cm.resolution_m / space.getMaximumExtent())
    si.setup()  # fixes the longest valid segment the motion validator reads
    if not LAST_VALID_PLANNERS.intersection(planners):
        _check_motions_on_grid(si, cm)
    return si


@cache
def _terrain_objective_class():
    from ompl import base as ob

    class TerrainCostObjective(ob.OptimizationObjective):
        """Integral of cost per metre along each motion; heuristic: cheapest metre x distance."""

        def __init__(self, si, cm: CostMap, goal_xy: Sequence[float] | None) -> None:
            super().__init__(si)
            self._segment = cm.segment_cost_function()
            self._cheapest = cm.min_cost_per_m
            self._goal = None if goal_xy is None else (float(goal_xy[0]), float(goal_xy[1]))
            self._state_cost = (cm.cost_per_m, cm.cell_of)

        def stateCost(self, s):
            cost, cell_of = self._state_cost
            r, c = cell_of(s[0], s[1])
            return ob.Cost(float(cost[r, c]))

        def motionCost(self, s1, s2):
            return ob.Cost(self._segment(s1[0], s1[1], s2[0], s2[1]))

        def motionCostHeuristic(self, s1, s2):
            return ob.Cost(self._cheapest * math.hypot(s1[0] - s2[0], s1[1] - s2[1]))

        def costToGo(self, s, goal):
            if self._goal is None:
                return ob.Cost(0.0)
            return ob.Cost(self._cheapest * math.hypot(s[0] - self._goal[0], s[1] - self._goal[1]))

    return TerrainCostObjective


def make_objective(si, cm: CostMap, objective: str, goal_xy: Sequence[float] | None = None):
    """OMPL's path-length objective, or the terrain-cost objective over `cm`."""
    from ompl import base as ob

    if objective == "length":
        return ob.PathLengthOptimizationObjective(si)
    return _terrain_objective_class()(si, cm, goal_xy)


def make_planner(si, profile: PlannerProfile):
    from ompl import geometric as og

    planner = getattr(og, profile.planner)(si)
    for key, value in profile.params.items():
        getattr(planner, setter_name(key))(value)
    planner.setName(profile.name)
    return planner


class _Counter:
    """A termination condition that fires after `limit` evaluations (planner iterations)."""

    def __init__(self, limit: int | None) -> None:
        self.limit = limit
        self.count = 0

    def __call__(self) -> bool:
        self.count += 1
        return self.limit is not None and self.count > self.limit


def _termination(iterations: int | None, time_s: float | None):
    from ompl import base as ob

    counter = _Counter(iterations)
    ptc = ob.PlannerTerminationCondition(counter)
    if time_s is not None:
        ptc = ob.plannerOrTerminationCondition(ptc, ob.timedPlannerTerminationCondition(time_s))
    return ptc, counter


def _states_xy(path) -> np.ndarray:
    return np.array([(s[0], s[1]) for s in path.getStates()], dtype=np.float64).reshape(-1, 2)


def _objective_value(cm: CostMap, objective: str, xy: np.ndarray) -> float:
    if objective == "length":
        return float(np.hypot(*np.diff(xy, axis=0).T).sum()) if len(xy) > 1 else 0.0
    return cm.path_cost(xy)


def _simplify(si, cm: CostMap, profile: PlannerProfile, path, goal_obj, objective):
    """OMPL's PathSimplifier, never making the path dearer by the profile's objective.

    `simplifyMax` (vertex reduction, shortcuts, B-spline smoothing, to convergence) judges by
    length and validity only: under terrain cost it may swap a detour round soft sand for a
    shorter, dearer straight line. So: simplify a copy fully, shortcut another copy with the
    objective-aware `partialShortcutPath`, and keep the cheapest of the three.
    """
    from ompl import geometric as og

    simplifier = og.PathSimplifier(si, goal_obj, objective)
    full = og.PathGeometric(path)
    simplifier.simplifyMax(full)
    candidates = [path, full]
    if profile.objective != "length":
        shortcut = og.PathGeometric(path)
        for _ in range(5):
            if not simplifier.partialShortcutPath(shortcut):
                break
        candidates.append(shortcut)
    values = [_objective_value(cm, profile.objective, _states_xy(c)) for c in candidates]
    return candidates[int(np.argmin(values))]


def _finish(si, cm: CostMap, profile: PlannerProfile, path, goal_obj, objective) -> tuple[np.ndarray, float]:
    """Simplify and interpolate a PathGeometric; return its waypoints and the time it took (ms)."""
    t0 = time.perf_counter()
    if profile.simplify and path.getStateCount() > 2:
        path = _simplify(si, cm, profile, path, goal_obj, objective)
    xy = _states_xy(path)
    if profile.interpolate_m is not None:
        xy = interpolate(xy, profile.interpolate_m)
    return xy, (time.perf_counter() - t0) * 1e3


def interpolate(xy: np.ndarray, spacing_m: float) -> np.ndarray:
    """Split every segment into equal pieces at most `spacing_m` long (the path itself unchanged)."""
    if len(xy) < 2:
        return xy
    seg = np.diff(xy, axis=0)
    pieces = np.maximum(np.ceil(np.hypot(*seg.T) / spacing_m).astype(np.int64), 1)
    owner = np.repeat(np.arange(len(seg)), pieces)
    first = np.repeat(np.cumsum(pieces) - pieces, pieces)
    frac = (np.arange(pieces.sum()) - first) / pieces[owner]
    return np.vstack([xy[owner] + frac[:, None] * seg[owner], xy[-1:]])


def _result(
    cm: CostMap,
    xy: np.ndarray,
    profile: PlannerProfile,
    seed: int,
    solve_ms: float,
    simplify_ms: float,
    iterations: int,
    status: str,
) -> PathResult:
    cost = cm.path_cost(xy)
    return PathResult(
        waypoints_m=xy,
        length_m=float(np.hypot(*np.diff(xy, axis=0).T).sum()) if len(xy) > 1 else 0.0,
        cost=cost,
        time_s=cost / cm.speeds.reference_speed_mps,
        solve_ms=solve_ms,
        simplify_ms=simplify_ms,
        iterations=iterations,
        planner=profile.planner,
        profile=profile.name,
        objective=profile.objective,
        seed=seed,
        status=status,
    )


def _state(space, xy: Sequence[float]):
    s = space.allocState()
    s[0], s[1] = float(xy[0]), float(xy[1])
    return s


def _plan_sampling(cm: CostMap, start, goal, profile: PlannerProfile, seed: int) -> PathResult:
    from ompl import geometric as og

    seed_ompl(seed)
    si = _space_information(cm, (profile.planner,))
    space = si.getStateSpace()
    ss = og.SimpleSetup(si)
    ss.setStartAndGoalStates(_state(space, start), _state(space, goal))
    objective = make_objective(si, cm, profile.objective, goal)
    ss.setOptimizationObjective(objective)
    ss.setPlanner(make_planner(si, profile))
    ptc, counter = _termination(profile.iterations, profile.time_s)
    t0 = time.perf_counter()
    status = ss.solve(ptc)
    solve_ms = (time.perf_counter() - t0) * 1e3
    if not ss.haveExactSolutionPath():
        raise NoPathError(
            f"planner profile '{profile.name}' ({profile.planner}) found no path from start "
            f"{format_point(start)} to goal {format_point(goal)} within its budget of "
            f"{profile.budget_text} ({status}); one exists for the robot: raise the budget or try "
            "another profile"
        )
    path = ss.getSolutionPath()
    xy, simplify_ms = _finish(si, cm, profile, path, ss.getGoal(), objective)
    return _result(
        cm,
        xy,
        profile,
        seed,
        solve_ms,
        simplify_ms,
        min(counter.count, profile.iterations or counter.count),
        str(status),
    )


# --- roadmaps --------------------------------------------------------------------------------
def build_roadmap(cm: CostMap, profile: PlannerProfile, seed: int = 0) -> Roadmap:
    """Grow a PRM / PRMstar roadmap over `cm` with OMPL (iteration counts: reproducible).

    `seed` is the caller's seed (as `plan_path` takes it); OMPL's is derived from it.
    """
    from ompl import base as ob

    if profile.roadmap is None:
        raise ValueError(f"profile '{profile.name}' ({profile.planner}) does not build a roadmap")
    oseed = ompl_seed(np.random.SeedSequence(seed))
    t0 = time.perf_counter()
    with _ompl_quiet():
        seed_ompl(oseed)
        si = _space_information(cm, (profile.planner,))
        own = si.getMotionValidator()
        _check_motions_on_grid(si, cm)  # for the growth; the expansion needs OMPL's own
        planner = make_planner(si, profile)
        pdef = ob.ProblemDefinition(si)
        pdef.setOptimizationObjective(ob.PathLengthOptimizationObjective(si))
        planner.setProblemDefinition(pdef)
        planner.setup()
        planner.growRoadmapPtc(_termination(profile.roadmap.grow_iterations, None)[0])
        if profile.roadmap.expand_iterations:
            si.setMotionValidator(own)  # its bounce motions ask for their last valid state
            planner.expandRoadmapPtc(_termination(profile.roadmap.expand_iterations, None)[0])
        data = ob.PlannerData(si)
        planner.getPlannerData(data)
        n = data.numVertices()
        vertices = np.array(
            [(v[0], v[1]) for v in (data.getVertex(i).getState() for i in range(n))], dtype=np.float64
        ).reshape(-1, 2)
        pairs = [(i, j) for i in range(n) for j in data.getEdges(i) if i < j]
    edges = np.array(pairs, dtype=np.int64).reshape(-1, 2)
    weights = _edge_weights(cm, profile.objective, vertices[edges[:, 0]], vertices[edges[:, 1]])
    return Roadmap(
        vertices_m=vertices,
        edges=edges,
        weights=weights,
        objective=profile.objective,
        planner=profile.planner,
        build_ms=(time.perf_counter() - t0) * 1e3,
        seed=oseed,
    )


def _edge_weights(cm: CostMap, objective: str, p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
    w = np.hypot(*(p1 - p0).T) if objective == "length" else cm.segments_cost(p0, p1)
    return w + 1e-9  # scipy's sparse graphs drop explicit zeros


def _connections(cm: CostMap, roadmap: Roadmap, p: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Roadmap vertices the point reaches in a straight line, among its k nearest (then 4k)."""
    n = roadmap.n_vertices
    for kk in (k, 4 * k):
        kk = min(kk, n)
        _, idx = roadmap.tree.query(p, k=kk)
        idx = np.atleast_1d(idx)
        idx = idx[idx < n]
        ok = cm.segments_free(np.repeat(p[None, :], len(idx), axis=0), roadmap.vertices_m[idx])
        if ok.any() or kk == n:
            break
    idx = idx[ok]
    return idx, _edge_weights(
        cm, roadmap.objective, np.repeat(p[None, :], len(idx), axis=0), roadmap.vertices_m[idx]
    )


def roadmap_route(cm: CostMap, roadmap: Roadmap, start, goal, k: int = 15) -> np.ndarray:
    """The cheapest route start -> roadmap -> goal (scipy Dijkstra), as (m, 2) points."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import dijkstra

    start, goal = np.asarray(start, dtype=np.float64), np.asarray(goal, dtype=np.float64)
    n = roadmap.n_vertices
    s_idx, s_w = _connections(cm, roadmap, start, k)
    g_idx, g_w = _connections(cm, roadmap, goal, k)
    rows = [roadmap.edges[:, 0], np.full(len(s_idx), n), np.full(len(g_idx), n + 1)]
    cols = [roadmap.edges[:, 1], s_idx, g_idx]
    weights = [roadmap.weights, s_w, g_w]
    if cm.segments_free(start, goal)[0]:
        rows.append(np.array([n]))
        cols.append(np.array([n + 1]))
        weights.append(_edge_weights(cm, roadmap.objective, start[None, :], goal[None, :]))
    graph = csr_matrix(
        (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))), shape=(n + 2, n + 2)
    )
    dist, pred = dijkstra(graph, directed=False, indices=n, return_predecessors=True)
    if not np.isfinite(dist[n + 1]):
        raise NoPathError(
            f"the roadmap ({n} vertices) does not connect start {format_point(start)} to goal "
            f"{format_point(goal)}, though a path exists for the robot: raise roadmap.grow_iterations "
            "/ expand_iterations in the profile"
        )
    route = [n + 1]
    while route[-1] != n:
        route.append(int(pred[route[-1]]))
    route.reverse()
    points = np.vstack([roadmap.vertices_m, start, goal])
    return points[route]


def _plan_roadmap(
    cm: CostMap, start, goal, profile: PlannerProfile, seed: int, roadmap: Roadmap
) -> PathResult:
    from ompl import base as ob
    from ompl import geometric as og

    t0 = time.perf_counter()
    k = profile.roadmap.connect_neighbours if profile.roadmap else 15
    route = roadmap_route(cm, roadmap, start, goal, k)
    solve_ms = (time.perf_counter() - t0) * 1e3
    seed_ompl(seed)
    si = _space_information(cm)  # the roadmap answered: only the simplifier runs here
    space = si.getStateSpace()
    path = og.PathGeometric(si)
    for p in route:
        path.append(_state(space, p))
    goal_obj = ob.GoalState(si)
    goal_obj.setState(_state(space, goal))
    objective = make_objective(si, cm, profile.objective, goal)
    xy, simplify_ms = _finish(si, cm, profile, path, goal_obj, objective)
    return _result(cm, xy, profile, seed, solve_ms, simplify_ms, 0, "Exact solution (roadmap)")


# --- the entry points --------------------------------------------------------------------------
def plan_with_seed(
    cm: CostMap,
    start: Sequence[float],
    goal: Sequence[float],
    profile: PlannerProfile,
    ompl_seed_value: int,
    roadmap: Roadmap | None = None,
) -> PathResult:
    """Plan one path with OMPL seeded by `ompl_seed_value` (endpoints already checked)."""
    with _ompl_quiet():
        if profile.roadmap is not None:
            if roadmap is None:
                raise ValueError(f"profile '{profile.name}' needs a roadmap: build_roadmap(cm, profile)")
            return _plan_roadmap(cm, start, goal, profile, ompl_seed_value, roadmap)
        return _plan_sampling(cm, start, goal, profile, ompl_seed_value)


def plan_path(
    cm: CostMap,
    start: Sequence[float],
    goal: Sequence[float],
    profile: PlannerProfile = DEFAULT_PROFILE,
    *,
    seed: int = 0,
    roadmap: Roadmap | None = None,
) -> PathResult:
    """Plan one path from `start` to `goal` (world metres) with `profile`.

    Raises `EndpointError` (a point outside the map, on impassable ground, in a keep-out zone or
    too close to one for the footprint) or `NoPathError` (none exists, or the budget ran out),
    each one line naming the point and the reason. Same seed and profile (iteration budget),
    same path. A roadmap profile builds its roadmap from `seed` unless one is given.
    """
    cm.check_endpoints(start, goal)
    if profile.roadmap is not None and roadmap is None:
        roadmap = build_roadmap(cm, profile, seed)
    return plan_with_seed(cm, start, goal, profile, ompl_seed(np.random.SeedSequence(seed)), roadmap)
