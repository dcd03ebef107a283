"""Constant-velocity strokes (model/stroke.py) against their closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from shockdyno.model.stroke import Stroke, quarter_constant, unit_shape


def _motion(stroke: Stroke, cycles: float = 2.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    period = stroke.period_s
    t = np.linspace(0.0, cycles * period, 400_001)
    x = stroke.amplitude_m * stroke.shape(t / period)
    v = np.gradient(x, t)
    return x, v, np.gradient(v, t)


@pytest.mark.parametrize("accel", [None, 0.5, 2.0, 20.0])
def test_the_stroke_moves_at_v_between_reversals_and_reverses_at_a(accel: float | None) -> None:
    s = Stroke("triangle" if accel is None else "trapezoid", 0.03, 0.1, accel)
    x, v, a = _motion(s)
    assert np.max(np.abs(x)) == pytest.approx(0.03, rel=1e-9)
    assert np.max(np.abs(v)) == pytest.approx(0.1, rel=1e-6)
    # The share of the travel at constant velocity, 1 - v²/(2aA), read off the motion.
    at_v = np.abs(np.abs(v) - 0.1) < 1e-6
    travel = np.abs(x[at_v])
    assert np.max(travel) == pytest.approx(0.03 * s.constant_share, rel=1e-3)
    if accel is not None:
        inner = np.abs(a[5:-5])
        assert np.max(inner) == pytest.approx(accel, rel=1e-3)
        assert s.period_s == pytest.approx(4 * 0.03 / 0.1 + 2 * 0.1 / accel)
    else:
        assert s.period_s == pytest.approx(4 * 0.03 / 0.1)


def test_a_drive_told_amplitude_frequency_and_acceleration_finds_the_same_stroke() -> None:
    s = Stroke("trapezoid", 0.02, 0.25, 8.0)
    constant = quarter_constant(s.frequency_hz, s.amplitude_m, s.accel_m_s2)
    phase = np.linspace(0, 3, 3001)
    assert np.allclose(unit_shape(phase, constant), s.shape(phase), atol=1e-12)
    # No trapezoid at that acceleration reaches the amplitude in the period: refused (NaN).
    assert np.isnan(quarter_constant(10.0, 0.03, 1.0))


def test_whole_cycles_start_and_end_at_the_centre_moving_in_compression() -> None:
    s = Stroke("trapezoid", 0.03, 0.1, 1.0)
    assert s.shape(np.array([0.0, 1.0, 2.0])) == pytest.approx([0.0, 0.0, 0.0], abs=1e-15)
    assert s.shape(np.array([0.25, 0.75])) == pytest.approx([1.0, -1.0])
    assert s.shape(np.array([0.01]))[0] > 0
