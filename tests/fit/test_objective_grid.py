"""The objective's samples: for the diagnosis, a grid that meets every cycle at the same
phase, and grids that differ from test to test."""

from __future__ import annotations

import numpy as np

from shockdyno.fit.prepare import locked_step, prepare_tests
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model.spec import load_spec


def test_the_locked_step_meets_each_cycle_at_the_same_phase() -> None:
    assert locked_step(2000.0, 10) == 10  # 0.5 Hz at 1 kHz: every 10th sample repeats
    assert locked_step(1000.0, 10) == 10
    # 1.5 Hz: 666.7 samples. Every 10th sample drifts 3.3 ms a cycle; every 9th, 0.67 ms.
    k = locked_step(2000.0 / 3.0, 10)
    assert k == 9
    drift = (2000.0 / 3.0) % k
    assert min(drift, k - drift) < 0.7
    assert locked_step(0.0, 10) == 10 and locked_step(2000.0, 1) == 1


def test_phase_locked_grids_are_staggered_over_the_tests() -> None:
    tests = synthetic_sweep(load_spec(), [2, 10], cycles=3)
    plain, _ = prepare_tests(tests, 100.0)
    locked, _ = prepare_tests(tests, 100.0, phase_locked=True)
    assert all(int(p.obj[0]) == 0 for p in plain)
    offsets = [int(p.obj[0]) for p in locked]
    steps = [int(p.obj[1] - p.obj[0]) for p in locked]
    # Five tests in a row start at five different samples of their step.
    assert len(set(offsets[:5])) == 5
    assert all(0 <= o < s for o, s in zip(offsets, steps, strict=True))
    for p, s in zip(locked, steps, strict=True):
        assert np.all(np.diff(p.obj) == s)  # still uniform: stateful terms step it
