"""Dyno tests made from the damper model: known motion, so peaks have known answers."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from shockdyno.model import damper_force, load_spec
from shockdyno.model.spec import DamperSpec
from shockdyno.record import RecordingWriter
from shockdyno.record.types import TestData, TestMeta
from shockdyno.samples import SampleBlock

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


def write_recording(path: Path, tests: list[TestData], metadata: dict[str, str]) -> Path:
    """Write tests into an MCAP recording with the project's writer (seq from t)."""
    with RecordingWriter(path, metadata=metadata, rig_toml='[rig]\nname = "test"\n') as w:
        for test in tests:
            seq = np.rint(test.t * RATE_HZ).astype(np.int64)
            n = seq.size
            temp = test.temperature if test.temperature is not None else np.full(n, np.nan)
            w.begin_test(test.meta)
            w.write_samples(SampleBlock(seq, seq / RATE_HZ, test.x, test.force, temp,
                                        np.zeros(n, np.uint16)))  # fmt: skip
            w.end_test(test.meta)
    return path


def sweep_tests(
    clicks: tuple[int, ...] = (0, 10, 21), freqs: tuple[float, ...] = (1.0, 1.5)
) -> list[TestData]:
    """A small sweep on the model damper, tests one after the other in time."""
    tests: list[TestData] = []
    t0 = 0.0
    for c in clicks:
        for f in freqs:
            test = make_test(len(tests), c, f, t0=t0)
            tests.append(test)
            t0 = float(test.t[-1]) + 1.0
    return tests


# What `shockdyno diagnose` will write (docs/diagnose.md, in progress elsewhere), by hand.
DIAGNOSE_SAMPLE: dict[str, object] = {
    "mismatch": {
        "significant": True,
        "p_value": 0.0003,
        "noise_floor_n": 4.2,
        "structured_share": 0.81,
        "where": [
            {"stroke": "rebound", "x_range_m": [-0.03, -0.01], "v_range_m_s": [-0.28, -0.12],
             "frequencies_hz": [1.0, 1.5], "share": 0.64},
            {"stroke": "compression", "x_range_m": [0.0, 0.03], "v_range_m_s": [0.0, 0.05],
             "frequencies_hz": [1.5], "share": 0.17},
        ],
    },
    "findings": [
        {"physics": "compressibility", "claimed": True, "p_value": 0.0011, "heldout_gain": 0.37,
         "parameters": {"bulk_modulus_pa": {"value": 1.2e9, "sd": 0.1e9, "unit": "Pa"}},
         "ambiguous_with": ["sensor_lag"]},
        {"physics": "thermal", "claimed": False, "p_value": 0.41, "heldout_gain": 0.01,
         "parameters": {}, "ambiguous_with": []},
    ],
    "verdict": {"physics": ["compressibility"],
                "unexplained": [{"stroke": "rebound", "x_range_m": [-0.03, -0.01],
                                 "v_range_m_s": [-0.28, -0.12], "frequencies_hz": [0.5],
                                 "share": 0.2}],
                "text": "Oil compressibility explains most of the rebound mismatch."},
    "tests": [
        {"index": 0, "clicks": 0, "frequency_hz": 1.0, "E_t_before": 0.0625, "E_t_after": 0.0125},
        {"index": 1, "clicks": 0, "frequency_hz": 1.5, "E_t_before": 0.08, "E_t_after": 0.02},
    ],
}  # fmt: skip
