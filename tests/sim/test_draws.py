"""Uniform draws of many runs in one compiled loop (`swarm.sim.draws`): each run's numbers and its
generator's state afterwards are those of its own `Generator.random` calls."""

from __future__ import annotations

import numpy as np
from numba.typed import List

from swarm.sim.draws import fill_normal, fill_uniform


def _generators(seed: int, k: int) -> list[np.random.Generator]:
    return [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(k)]


def test_each_run_draws_from_its_own_generator_as_numpy_would() -> None:
    runs = np.array([4, 0, 2, 2, 5])
    starts = np.array([0, 3, 3, 10, 11, 40])  # one run draws nothing, run 2 twice
    gens, ref = _generators(7, 6), _generators(7, 6)
    out = np.full(40, np.nan)
    fill_uniform(List(gens), runs, starts, out)
    expected = np.full(40, np.nan)
    for k, b in enumerate(runs):
        ref[b].random(out=expected[starts[k] : starts[k + 1]])
    assert np.array_equal(out, expected)
    # the generators moved on as the reference ones did (the compiled loop shares their state)
    assert [g.random() for g in gens] == [g.random() for g in ref]


def test_a_plain_list_gives_the_same_draws() -> None:
    runs, starts = np.array([1, 0]), np.array([0, 5, 9])
    typed, plain = np.empty(9), np.empty(9)
    fill_uniform(List(_generators(3, 2)), runs, starts, typed)
    fill_uniform(_generators(3, 2), runs, starts, plain)
    assert np.array_equal(typed, plain)


def test_normals_are_numpys_standard_normals_run_by_run() -> None:
    runs, starts = np.array([2, 0, 1]), np.array([0, 0, 700, 1001])  # the ziggurat's tails too
    typed, plain = np.empty(1001), np.empty(1001)
    gens = _generators(5, 3)
    fill_normal(List(gens), runs, starts, typed)
    ref = _generators(5, 3)
    fill_normal(ref, runs, starts, plain)
    assert np.array_equal(typed, plain)
    expected = np.concatenate(
        [_generators(5, 3)[b].standard_normal(starts[k + 1] - starts[k]) for k, b in enumerate(runs)]
    )
    assert np.array_equal(typed, expected)
    assert [g.random() for g in gens] == [g.random() for g in ref]
