"""A finished test is judged by its own samples against its plan."""

from __future__ import annotations

import numpy as np
import pytest

from shockdyno.rig.config import VerifyConfig
from shockdyno.run.verify import measure_sine, plan_mismatch

RATE = 1000.0


def run(f: float, a: float, centre: float = 0.0, cycles: int = 4, ramp: int = 1, noise=1e-6):
    """A drive profile: ramp in over `ramp` cycles, `cycles` full, ramp out; with noise."""
    total = (2 * ramp + cycles) / f
    t = np.arange(0, total, 1 / RATE)
    env = np.clip(np.minimum(t * f / ramp, (total - t) * f / ramp), 0, 1)
    x = centre + a * env * np.sin(2 * np.pi * f * t)
    x += np.random.default_rng(0).normal(0, noise, t.size)
    return t, x, (ramp / f, (ramp + cycles) / f)


@pytest.mark.parametrize("cycles", [1, 2, 9])
def test_the_planned_sine_matches(cycles):
    t, x, window = run(1.5, 0.03, cycles=cycles)
    m = measure_sine(t, x, window, 0.03, 1.5)
    assert m is not None and abs(m.frequency_hz - 1.5) < 0.003
    assert abs(m.amplitude_m - 0.03) < 1e-4 and abs(m.centre_m) < 1e-4
    assert plan_mismatch(m, 1.5, 0.03, VerifyConfig()) is None


@pytest.mark.parametrize(
    ("actual", "words"),
    [
        ({"f": 3.0}, "ran at 3 Hz"),
        ({"f": 1.02}, "ran at 1.02 Hz"),
        ({"a": 0.02}, "amplitude 20 mm"),
        ({"centre": 0.005}, "off the stroke centre"),
    ],
)
def test_a_sine_other_than_planned_is_named(actual, words):
    f, a = actual.get("f", 1.0), actual.get("a", 0.03)
    t, x, _ = run(f, a, centre=actual.get("centre", 0.0), cycles=int(4 * f))
    planned_window = (1.0, 5.0)  # the 1 Hz plan's full-amplitude cycles
    m = measure_sine(t, x, planned_window, 0.03, 1.0)
    why = plan_mismatch(m, 1.0, 0.03, VerifyConfig())
    assert why is not None and words in why


def test_no_motion_cannot_pass():
    t = np.arange(0, 5, 1 / RATE)
    m = measure_sine(t, np.zeros_like(t), (1.0, 4.0), 0.03, 1.0)
    assert plan_mismatch(m, 1.0, 0.03, VerifyConfig()) is not None
