"""Dyno tests made from the damper model: known motion, so peaks have known answers."""

from __future__ import annotations

from functools import cache

import numpy as np
from numpy.typing import NDArray

from shockdyno.model import damper_force, load_spec
from shockdyno.model.spec import DamperSpec
from shockdyno.record.types import TestData, TestMeta

AMPLITUDE_M = 0.03
RATE_HZ = 1000.0
WARMUP = 1
CYCLES = 2


@cache
def spec() -> DamperSpec:
    return load_spec()


def temperature_at(t: NDArray[np.float64]) -> NDArray[np.float64]:
    """A slow warm-up: 40 °C rising 0.5 °C/s."""
    return 40.0 + 0.5 * t


def make_test(
    index: int,
    clicks: int,
    frequency_hz: float,
    *,
    status: str = "complete",
    t0: float = 0.0,
    cycles: int = CYCLES,
) -> TestData:
    """A sine test on the model damper: warm-up cycle, then measured cycles."""
    n = round((WARMUP + cycles) / frequency_hz * RATE_HZ)
    t = t0 + np.arange(n) / RATE_HZ
    w = 2 * np.pi * frequency_hz
    x = AMPLITUDE_M * np.sin(w * (t - t0))
    v = AMPLITUDE_M * w * np.cos(w * (t - t0))
    a = -AMPLITUDE_M * w * w * np.sin(w * (t - t0))
    a_bc, a_bt = spec().bleed_areas(clicks, 0)
    force = damper_force(spec(), x, v, a, a_bc, a_bt)
    # A knock as the actuator takes up the slack, before the measured window: peaks that
    # forget the window would show it.
    force[:3] += (2500.0, -2500.0, 2500.0)
    meta = TestMeta(
        index=index,
        clicks=clicks,
        gas_clicks=0,
        frequency_hz=frequency_hz,
        amplitude_m=AMPLITUDE_M,
        sample_rate_hz=RATE_HZ,
        warmup_cycles=WARMUP,
        measured_cycles=cycles,
        measured_start_s=t0 + WARMUP / frequency_hz,
        measured_end_s=t0 + (WARMUP + cycles) / frequency_hz,
        status=status,
    )
    return TestData(meta, t, x, force, temperature_at(t))
