"""Deterministic recordings for the record tests: every sample is a known function of its seq."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from shockdyno.record import RecordingWriter, TestMeta
from shockdyno.samples import SampleBlock

RATE = 1000.0


def block(seq0: int, n: int, *, drop: tuple[int, ...] = ()) -> SampleBlock:
    """n samples from seq0 on; seq numbers in `drop` are missing (dropped frames)."""
    seq = np.array([s for s in range(seq0, seq0 + n) if s not in drop], dtype=np.int64)
    t = seq / RATE
    x = 0.03 * np.sin(2 * np.pi * t) + seq * 1e-9
    force = 800.0 * np.cos(2 * np.pi * t) + (seq % 7) * 0.125
    temp = 40.0 + seq * 1e-4
    status = (seq % 3).astype(np.uint16)
    return SampleBlock(seq, t, x, force, temp, status)


def meta(index: int, clicks: int, freq: float = 1.0, **kw: object) -> TestMeta:
    return TestMeta(
        index=index,
        clicks=clicks,
        gas_clicks=2,
        frequency_hz=freq,
        amplitude_m=0.03,
        sample_rate_hz=RATE,
        warmup_cycles=2,
        measured_cycles=5,
        **kw,  # type: ignore[arg-type]
    )


TESTS = [(0, 0, 0.5), (1, 0, 1.0), (2, 3, 1.5)]  # (index, clicks, frequency)
SAMPLES_PER_TEST = 2500


def seq_range(k: int) -> tuple[int, int]:
    """seq range [lo, hi) of the k-th test written by write_small."""
    lo = k * (SAMPLES_PER_TEST + 100)
    return lo, lo + SAMPLES_PER_TEST


def write_small(
    path: Path,
    block_sizes: tuple[int, ...] = (17, 250, 3, 1000),
    gas_force_n: tuple[float | None, ...] = (),
) -> None:
    """Three tests of 2500 samples in irregular blocks, with events and actuator records;
    ``gas_force_n``: per test, a measured gas force to store with it."""
    with RecordingWriter(
        path,
        metadata={"damper_id": "S46-0042", "operator": "ana", "notes": "new shims, ä ok"},
        rig_toml='[rig]\nname = "sim"\n',
    ) as w:
        for k, (index, clicks, freq) in enumerate(TESTS):
            lo, hi = seq_range(k)
            gas = gas_force_n[k] if k < len(gas_force_n) else None
            m = meta(index, clicks, freq)
            if gas is not None:
                m = replace(m, gas_force_n=gas, gas_force_source="measured")
            w.begin_test(m)
            w.write_actuator(lo / RATE, {"enable": True, "amplitude_m": 0.03, "mode": "sine"})
            s, i = lo, 0
            while s < hi:
                n = min(block_sizes[i % len(block_sizes)], hi - s)
                w.write_samples(block(s, n))
                s, i = s + n, i + 1
            w.write_event(hi / RATE, "info", f"test {index} done")
            w.end_test(m)


def chunk_offsets(data: bytes) -> list[tuple[int, int]]:
    """(offset, length) of every top-level Chunk record, walking the MCAP record framing."""
    import struct

    pos, out = 8, []
    while pos + 9 <= len(data):
        op, length = data[pos], struct.unpack_from("<Q", data, pos + 1)[0]
        if op == 0x06:
            out.append((pos, 9 + length))
        if op == 0x02:  # footer
            break
        pos += 9 + length
    return out
