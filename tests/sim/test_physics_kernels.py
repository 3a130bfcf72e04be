"""The fused numba kernels (`swarm.sim.physics_kernels`) give the numpy path's results bit for bit:
every field of every step equal (np.array_equal), on random swarms over land, water, surf and
obstacles, upright and inverted, lone runs and batches of runs, one substep or several."""

from __future__ import annotations

import importlib.resources
from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pytest

from swarm.robot.params import load_robot
from swarm.robot.terrain import default_library
from swarm.sim import physics_kernels
from swarm.sim.physics import Physics, PhysicsStep, SeaState
from swarm.world.beachmap import BeachMap

ROBOT = load_robot(Path(str(importlib.resources.files("swarm") / "data" / "robots" / "skid4.yaml")))
CLASSES = (
    "deep_water",
    "surf",
    "shallow_water",
    "wet_hard_sand",
    "soft_sand",
    "concrete",
    "boulder",
    "driftwood",
)


def rough_beach(rng: np.random.Generator, rows: int = 50, cols: int = 40) -> BeachMap:
    """Sea to the south rising to land, every class in patches, and a bumpy surface (slopes)."""
    y = (np.arange(rows) + 0.5) * 0.5
    elevation = np.repeat((0.08 * (y - 8.0))[:, None], cols, axis=1) + rng.normal(0.0, 0.05, (rows, cols))
    terrain = rng.integers(0, len(CLASSES), (rows // 5, cols // 5)).repeat(5, 0).repeat(5, 1)
    terrain[y < 3.0] = 0  # open sea along the south edge
    return BeachMap(
        name="rough",
        cell_m=0.5,
        origin_m=(0.0, 0.0),
        terrain_classes=CLASSES,
        terrain=terrain.astype(np.int8),
        elevation_m=elevation.astype(np.float32),
    )


def pair(bm: BeachMap, sea: SeaState, substep_s: float) -> tuple[Physics, Physics]:
    """The same physics with the kernels and with the numpy path."""
    lib = default_library()
    kw = {"jet_thrust_max_n": 30.0, "substep_s": substep_s}
    fused, reference = Physics(bm, lib, ROBOT, sea, **kw), Physics(bm, lib, ROBOT, sea, fused=False, **kw)
    assert fused._fused and not reference._fused
    return fused, reference


def random_swarm(rng: np.random.Generator, n: int, bm: BeachMap) -> tuple[np.ndarray, ...]:
    """States over the map and a little off it, fast and at rest; commands forward, back, zero."""
    height, width = bm.shape[0] * bm.cell_m, bm.shape[1] * bm.cell_m
    state = np.column_stack(
        [
            rng.uniform(-1.0, width + 1.0, n),
            rng.uniform(-1.0, height + 1.0, n),
            rng.uniform(-20.0, 20.0, n),
            rng.normal(0.0, 1.0, (n, 3)),
        ]
    )
    state[rng.random(n) < 0.1, 3:] = 0.0
    wheels = rng.uniform(-10.0, 10.0, (n, 2))
    wheels[rng.random(n) < 0.1] = 0.0
    jet = rng.uniform(-50.0, 50.0, n)
    jet[rng.random(n) < 0.2] = 0.0
    return state, wheels, jet, rng.random(n) < 0.3


def assert_identical(a: PhysicsStep, b: PhysicsStep) -> None:
    for f in fields(PhysicsStep):
        x, y = getattr(a, f.name), getattr(b, f.name)
        assert x.dtype == y.dtype and np.array_equal(x, y), f.name


@pytest.mark.parametrize(("dt_s", "substep_s"), [(0.1, 0.1), (0.2, 0.1), (0.5, 0.1), (0.25, 0.1)])
@pytest.mark.parametrize("seed", [0, 1])
def test_the_kernels_step_a_lone_run_as_the_numpy_path(dt_s: float, substep_s: float, seed: int) -> None:
    rng = np.random.default_rng(seed)
    bm = rough_beach(rng)
    fused, reference = pair(bm, SeaState(1.2, 7.0, 0.3), substep_s)
    n = 300
    state, wheels, jet, inverted = random_swarm(rng, n, bm)
    s_fused, s_ref = state, state.copy()
    blocked = hits = 0
    for k in range(12):
        active = rng.random(n) < 0.9 if k % 3 else None
        a = fused.step(s_fused, wheels, jet, inverted, 0.37 + k * dt_s, dt_s, 1.1, active=active)
        b = reference.step(s_ref, wheels, jet, inverted, 0.37 + k * dt_s, dt_s, 1.1, active=active)
        assert_identical(a, b)
        s_fused, s_ref = a.state, b.state
        blocked += (a.obstacle_hit >= 0).sum()
        hits += a.wave_hits.sum()
    assert blocked > 0 and hits > 0  # exercised obstacles and breakers


@pytest.mark.parametrize("dt_s", [0.1, 0.5])
def test_the_kernels_step_a_batch_of_runs_as_the_numpy_path(dt_s: float) -> None:
    rng = np.random.default_rng(3)
    bm = rough_beach(rng)
    fused, reference = pair(bm, SeaState(0.8, 5.0, -0.2, wave_skew=0.3), 0.1)
    runs, per_run = 6, 40
    state, wheels, jet, inverted = random_swarm(rng, runs * per_run, bm)
    run = np.repeat(np.arange(runs, dtype=np.intp), per_run)
    t0, phase = rng.uniform(0.0, 30.0, runs), rng.uniform(0.0, 5.0, runs)
    for k in range(10):
        active = rng.random(runs * per_run) < 0.8
        args = (wheels, jet, inverted, t0 + k * dt_s, dt_s, phase)
        a = fused.step(state, *args, active=active, run=run)
        b = reference.step(state, *args, active=active, run=run)
        assert_identical(a, b)
        state = a.state


def test_the_kernels_leave_their_input_alone() -> None:
    rng = np.random.default_rng(4)
    bm = rough_beach(rng)
    fused, _ = pair(bm, SeaState(1.0, 8.0, 0.1), 0.1)
    state, wheels, jet, inverted = random_swarm(rng, 50, bm)
    before = state.copy()
    fused.step(state, wheels, jet, inverted, 0.0, 0.5, 0.0)
    assert np.array_equal(state, before)


def test_the_wave_table_is_the_sea_states_shape_and_crests() -> None:
    sea = SeaState(1.0, 7.0, 0.0, wave_skew=0.4)
    t0, phase, dt, n_sub = 12.3, 0.8, 4.0, 7  # a crest at 14.8 s
    shapes, crests = physics_kernels.wave_table(np.array([t0]), np.array([phase]), 7.0, 0.4, dt, n_sub)
    for k in range(n_sub):
        assert shapes[k, 0] == sea.wave_shape(t0 + dt * k / n_sub, phase)
        passed = sea.crests_by(t0 + dt * (k + 1) / n_sub, phase) > sea.crests_by(t0 + dt * k / n_sub, phase)
        assert crests[k, 0] == passed
    assert crests.sum() == 1


def test_a_robot_the_kernels_do_not_cover_steps_with_the_numpy_path() -> None:
    rng = np.random.default_rng(5)
    bm = rough_beach(rng)
    offset = replace(ROBOT, com_x_m=0.03)  # loads shared unevenly: not the kernels' case
    physics = Physics(bm, default_library(), offset, SeaState(1.0, 8.0, 0.1), jet_thrust_max_n=30.0)
    assert not physics._fused
    state, wheels, jet, inverted = random_swarm(rng, 20, bm)
    assert np.isfinite(physics.step(state, wheels, jet, inverted, 0.0, 0.5, 0.0).state).all()
