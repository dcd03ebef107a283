"""filters.delayed, every segment in one compiled pass, against the loop of np.interp it
replaced (kept as its fallback for values that are not finite): bit for bit, on segments
of one sample and more, delays that land on samples and between them, and delays longer
than a segment."""

from __future__ import annotations

import numpy as np
import pytest

from shockdyno.model.filters import _delayed_by_segment as by_loop
from shockdyno.model.filters import delayed


@pytest.mark.parametrize("seed", range(6))
def test_it_is_the_loop_bit_for_bit(seed: int) -> None:
    rng = np.random.default_rng(seed)
    sizes = rng.integers(1, 400, size=rng.integers(1, 40))
    sizes[: min(3, sizes.size)] = [1, 2, 3][: min(3, sizes.size)]
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.intp)
    dt = rng.choice([1e-3, 2e-3, 5e-3, 1 / 300, 1 / 1500], size=sizes.size)
    t = np.concatenate([np.arange(n) * d for n, d in zip(sizes, dt, strict=True)])
    values = 0.03 * np.sin(2 * np.pi * 1.3 * t + rng.uniform(0, 6)) + rng.normal(0, 1e-4, t.size)
    slope = rng.normal(0, 0.2, t.size)
    delays = [*rng.uniform(-0.02, 0.02, 4), 3e-3, -2e-3, 7e-3, 1e-3 / 3, 0.5, -0.7]
    for delay in delays:
        got = delayed(values, slope, float(delay), starts, dt)
        want = by_loop(values, slope, float(delay), starts, dt)
        assert got.tobytes() == want.tobytes(), delay


def test_a_delay_of_whole_samples_gives_the_samples_themselves() -> None:
    values = np.array([0.1, 0.7, -0.3, 0.2, 0.9, 0.4])
    starts = np.array([0, 3], dtype=np.intp)
    got = delayed(values, np.zeros(6), 1e-3, starts, np.array([1e-3, 1e-3]))
    assert got.tolist() == [0.1, 0.1, 0.7, 0.2, 0.2, 0.9]  # each segment's own start held


def test_values_that_are_not_finite_take_the_loop() -> None:
    values = np.array([0.0, 1.0, np.inf, 3.0, 4.0])
    starts = np.zeros(1, dtype=np.intp)
    got = delayed(values, np.zeros(5), 0.5e-3, starts, np.array([1e-3]))
    want = by_loop(values, np.zeros(5), 0.5e-3, starts, np.array([1e-3]))
    assert got.tobytes() == want.tobytes()
