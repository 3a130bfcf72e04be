"""Uniform and normal draws of many runs, each from its own generator, in one compiled loop.

Every run of a batch keeps its own random streams (`swarm.sim.world`), so a step of 1000 runs
used to make 1000 small `Generator.random` calls from Python per stream. numba draws from a numpy
`Generator` with the same bit generator and the same conversion to doubles, advancing the
generator's own state, so a run's numbers are the ones `gens[b].random(out=...)` would give
(`tests/sim/test_draws.py`). The generators go in as a `numba.typed.List` (`World.stream_typed`);
a plain list is drawn from run by run.
"""

from __future__ import annotations

from collections.abc import Sequence

import numba
import numpy as np
from numba.typed import List


def fill_uniform(
    gens: Sequence[np.random.Generator], runs: np.ndarray, starts: np.ndarray, out: np.ndarray
) -> None:
    """`out[starts[k]:starts[k + 1]]` (a flat float64 array) from generator `gens[runs[k]]`, k in
    order: the draws of `gens[runs[k]].random(out=out[starts[k]:starts[k + 1]])`, run after run."""
    _fill(gens, runs, starts, out, _fill_uniform, "random")


def fill_normal(
    gens: Sequence[np.random.Generator], runs: np.ndarray, starts: np.ndarray, out: np.ndarray
) -> None:
    """`fill_uniform` of standard normals: the draws of `gens[runs[k]].standard_normal(...)`."""
    _fill(gens, runs, starts, out, _fill_normal, "standard_normal")


def _fill(gens, runs: np.ndarray, starts: np.ndarray, out: np.ndarray, compiled, method: str) -> None:
    """A typed list through the compiled loop, any other sequence run by run with `method`."""
    if isinstance(gens, List):
        compiled(gens, runs, starts, out)
        return
    for k, b in enumerate(runs.tolist()):
        lo, hi = int(starts[k]), int(starts[k + 1])
        if hi > lo:
            getattr(gens[b], method)(out=out[lo:hi])


@numba.njit(cache=True)
def _fill_uniform(gens, runs, starts, out):
    for k in range(runs.shape[0]):
        g = gens[runs[k]]
        for i in range(starts[k], starts[k + 1]):
            out[i] = g.random()


@numba.njit(cache=True)
def _fill_normal(gens, runs, starts, out):
    for k in range(runs.shape[0]):
        g = gens[runs[k]]
        for i in range(starts[k], starts[k + 1]):
            out[i] = g.standard_normal()
