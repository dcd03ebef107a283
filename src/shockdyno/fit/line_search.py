"""Many independent one-variable minimisations at once.

Each click's bleed area in one direction is a 1-D problem on its own samples, so one
model call can evaluate a candidate for every problem: a coarse logarithmic grid finds
each problem's basin, then golden-section search narrows all brackets together. The cost
is one model evaluation per grid point or golden step, whatever the number of clicks.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
Objective = Callable[[FloatArray], FloatArray]  # candidate per problem -> objective per problem

_INV_PHI = (math.sqrt(5) - 1) / 2


def area_grid(a_max: float, decades: float = 4.0, points: int = 29) -> FloatArray:
    """0 and a log-spaced range up to a_max."""
    return np.concatenate(
        [[0.0], np.logspace(math.log10(a_max) - decades, math.log10(a_max), points)]
    )


def grid_search(fun: Objective, n: int, grid: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Bracket [lo, hi] around each problem's best grid point."""
    scores = np.stack([fun(np.full(n, g)) for g in grid])  # (grid, problems)
    best = np.argmin(scores, axis=0)
    lo = grid[np.maximum(best - 1, 0)]
    hi = grid[np.minimum(best + 1, grid.size - 1)]
    return lo, hi


def golden_search(
    fun: Objective, lo: FloatArray, hi: FloatArray, iterations: int = 40
) -> tuple[FloatArray, FloatArray]:
    """Minimum of each problem in its bracket: (argmin, objective there)."""
    a, b = lo.astype(float).copy(), hi.astype(float).copy()
    c = b - _INV_PHI * (b - a)
    d = a + _INV_PHI * (b - a)
    fc, fd = fun(c), fun(d)
    for _ in range(iterations):
        left = fc <= fd
        b = np.where(left, d, b)
        a = np.where(left, a, c)
        new = np.where(left, b - _INV_PHI * (b - a), a + _INV_PHI * (b - a))
        fnew = fun(new)
        c, d, fc, fd = (
            np.where(left, new, d),
            np.where(left, c, new),
            np.where(left, fnew, fd),
            np.where(left, fc, fnew),
        )
        # One of (c, d) is reused, the other is the new point: keep c < d.
        swap = c > d
        c, d = np.where(swap, d, c), np.where(swap, c, d)
        fc, fd = np.where(swap, fd, fc), np.where(swap, fc, fd)
    # The bracket ends (a grid point, e.g. 0) are candidates too.
    cand = np.stack([c, d, lo, hi])
    vals = np.stack([fc, fd, fun(lo), fun(hi)])
    pick = np.argmin(vals, axis=0)
    cols = np.arange(lo.size)
    return cand[pick, cols], vals[pick, cols]
