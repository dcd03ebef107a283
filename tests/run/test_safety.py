"""Soft limits are checked on every sample, across block boundaries."""

from __future__ import annotations

import numpy as np

from shockdyno.rig.config import Limits
from shockdyno.run.safety import LimitMonitor
from shockdyno.samples import SampleBlock

LIMITS = Limits(
    travel_m=0.04, force_n=5000.0, velocity_m_s=0.5, temperature_c=90.0, trip_margin=0.05
)


def block(
    start: int, x: np.ndarray, f: np.ndarray | None = None, temp: float = 40.0
) -> SampleBlock:
    n = x.size
    seq = np.arange(start, start + n, dtype=np.int64)
    return SampleBlock(
        seq,
        seq / 1000.0,
        x,
        np.zeros(n) if f is None else f,
        np.full(n, temp),
        np.zeros(n, np.uint16),
    )


def test_first_breaching_sample_is_reported_with_its_daq_time() -> None:
    f = np.zeros(100)
    f[37] = 5300.0  # beyond 5000 N × 1.05
    f[60] = -9000.0
    ev = LimitMonitor(LIMITS).check(block(2000, np.zeros(100), f))
    assert ev is not None and ev.kind == "force" and ev.t_s == 2.037
    assert "5300 N" in ev.message


def test_within_the_trip_margin_is_not_a_breach() -> None:
    x = np.full(50, 0.0415)  # beyond 40 mm, inside 42 mm
    assert LimitMonitor(LIMITS).check(block(0, x, np.full(50, 5200.0))) is None
    ev = LimitMonitor(LIMITS).check(block(0, np.full(50, 0.0421)))
    assert ev is not None and ev.kind == "travel"


def test_velocity_is_tracked_across_blocks() -> None:
    mon = LimitMonitor(LIMITS)
    t = np.arange(200) / 1000.0
    x = 0.6 * t  # 0.6 m/s > 0.525 m/s trip
    assert mon.check(block(0, x[:3])) is None  # too few samples for a velocity yet
    ev = mon.check(block(3, x[3:10]))
    assert ev is not None and ev.kind == "velocity" and ev.t_s == 0.005
    slow = LimitMonitor(LIMITS)
    xs = 0.5 * (t[:100] - 0.05)  # 0.5 m/s, inside the trip
    assert slow.check(block(0, xs[:50])) is None
    assert slow.check(block(50, xs[50:])) is None


def test_temperature_limit() -> None:
    ev = LimitMonitor(LIMITS).check(block(0, np.zeros(5), temp=91.0))
    assert ev is not None and ev.kind == "temperature" and ev.t_s == 0.0
