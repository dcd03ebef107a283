"""The cycle cutter against a closed form: a ram that is exactly its plan."""

from __future__ import annotations

import numpy as np
import pytest

from shockdyno.live.cycles import CycleCutter, planned_position
from shockdyno.record.types import TestMeta
from shockdyno.rig.frames import STATUS_MOTION
from shockdyno.samples import SampleBlock

FS, F, A, RAMP, WARMUP, MEASURED = 1000.0, 2.5, 0.025, 2, 1, 3
T0 = 0.5  # the drive's start: the first sample with the motion bit


def _stream() -> SampleBlock:
    seq = np.arange(0, int(FS * 4.0), dtype=np.int64)
    t = seq / FS
    n = WARMUP + MEASURED
    x = planned_position(t, T0, A, F, n, RAMP)
    end = T0 + (n + 2 * RAMP) / F
    status = np.where((t >= T0) & (t < end), STATUS_MOTION, 0).astype(np.uint16)
    return SampleBlock(seq, t, x, 3000 * x, np.full(t.size, 40.0), status)


def _cut(sizes: np.ndarray) -> list:
    stream = _stream()
    cutter = CycleCutter()
    cutter.actuator({"cmd_ramp_cycles": RAMP, "cmd_amplitude_m": A})
    meta = TestMeta(index=4, clicks=7, gas_clicks=0, frequency_hz=F, amplitude_m=A,
                    sample_rate_hz=FS, warmup_cycles=WARMUP, measured_cycles=MEASURED)  # fmt: skip
    cutter.begin(meta)
    cycles, lo = [], 0
    for size in sizes:
        stretch, done = cutter.feed(stream.slice(lo, lo + int(size)))
        if stretch.commanded_m is not None:
            np.testing.assert_allclose(stretch.commanded_m, stretch.displacement_m, atol=1e-15)
        cycles += done
        lo += int(size)
        if lo >= len(stream):
            break
    return cycles


def test_cycles_of_an_exact_plan_are_the_plan_whatever_the_blocks():
    rng = np.random.default_rng(5)
    even = _cut(np.full(400, 50))
    ragged = _cut(rng.integers(1, 120, 3000))
    assert [c.part for c in even] == (
        ["ramp-in"] * RAMP + ["warm-up"] * WARMUP + ["measured"] * MEASURED + ["ramp-out"] * RAMP
    )
    for a, b in zip(even, ragged, strict=True):
        np.testing.assert_array_equal(a.t_s, b.t_s)
        np.testing.assert_array_equal(a.velocity_m_s, b.velocity_m_s)
    for c in even:
        assert c.t_start_s == pytest.approx(T0 + c.index / F)
        assert len(c.t_s) == FS / F
        assert c.commanded_m is not None
        np.testing.assert_allclose(c.commanded_m, c.displacement_m, atol=1e-15)
        if c.part in ("warm-up", "measured"):
            # dx/dt of A sin(ωt) is Aω cos(ωt): the central difference within 0.1 %, and
            # 0.2 % at the ramp's end (the envelope's kink lies within its ±2 samples).
            w = 2 * np.pi * F
            v = A * w * np.cos(w * (c.t_s - T0))
            np.testing.assert_allclose(c.velocity_m_s[2:], v[2:], atol=1e-3 * A * w)
            np.testing.assert_allclose(c.velocity_m_s[:2], v[:2], atol=2e-3 * A * w)


def test_without_the_motion_bit_the_measured_window_places_the_cycles():
    stream = _stream()
    stream = SampleBlock(stream.seq, stream.t_s, stream.displacement_m, stream.force_n,
                         stream.temperature_c, np.zeros(len(stream), np.uint16))  # fmt: skip
    cutter = CycleCutter()
    cutter.actuator({"cmd_ramp_cycles": RAMP})
    m_start = T0 + (RAMP + WARMUP) / F
    meta = TestMeta(index=0, clicks=0, gas_clicks=0, frequency_hz=F, amplitude_m=A,
                    sample_rate_hz=FS, warmup_cycles=WARMUP, measured_cycles=MEASURED,
                    measured_start_s=m_start)  # fmt: skip
    cutter.begin(meta)
    _, cycles = cutter.feed(stream)
    assert [c.t_start_s for c in cycles] == pytest.approx([T0 + k / F for k in range(8)])
    assert all(c.commanded_m is None for c in cycles)  # no plan without the drive's start
