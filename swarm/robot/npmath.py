"""numpy's rules for scalars in compiled loops: `np.maximum`, `np.minimum` and `np.sign` of two
floats, NaN in, NaN out, where Python's `max`, `min` and a plain comparison would drop it. The
kernels that promise numpy's floats (the simulator's physics, the controller, route following) use
these, so a NaN state stays visible instead of turning into a command.
"""

from __future__ import annotations

from numba import njit


@njit(cache=True, error_model="numpy")
def maximum(a: float, b: float) -> float:
    """np.maximum: NaN if either is."""
    return a if a >= b or a != a else b


@njit(cache=True, error_model="numpy")
def minimum(a: float, b: float) -> float:
    """np.minimum: NaN if either is."""
    return a if a <= b or a != a else b


@njit(cache=True, error_model="numpy")
def sign(a: float) -> float:
    """np.sign: 0 for either zero, NaN for NaN."""
    if a > 0.0:
        return 1.0
    if a < 0.0:
        return -1.0
    return 0.0 if a == 0.0 else a
