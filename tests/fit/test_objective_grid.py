"""The objective's samples: for the diagnosis, a grid that meets every cycle at the same
phase."""

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


def test_phase_locked_grids_keep_the_step_that_repeats_each_cycle() -> None:
    tests = synthetic_sweep(load_spec(), [2, 10], cycles=3)
    plain, _ = prepare_tests(tests, 100.0)
    locked, _ = prepare_tests(tests, 100.0, phase_locked=True)
    for p, q in zip(plain, locked, strict=True):
        f = p.data.meta.frequency_hz
        assert int(q.obj[0]) == 0 and np.all(np.diff(q.obj) == np.diff(q.obj)[0])
        step = int(q.obj[1] - q.obj[0])
        assert step == (9 if f == 1.5 else 10)
        assert int(p.obj[1] - p.obj[0]) == 10  # the fit's own grid is left as it was
