"""DAQ frame decode rate vs the 1 kHz need and the 200 k frames/s aim.

Baseline (same run): a straightforward per-frame decoder (struct.unpack + table CRC per
frame), i.e. what the vectorised FrameDecoder replaces.

    .venv/bin/python benchmarks/bench_frames.py
"""

from __future__ import annotations

import struct
import time

import numpy as np

from shockdyno.rig.frames import _TABLE, FRAME_LEN, FrameDecoder, encode_frames

N = 300_000
READ = 1000  # frames per read: ~18 kB, what one bulk read at 50x real time returns


def stream(n: int) -> bytes:
    seq = np.arange(n, dtype=np.int64)
    rng = np.random.default_rng(0)
    return encode_frames(
        seq,
        rng.integers(-100_000, 100_000, n).astype(np.int32),
        rng.integers(0, 150_000, n).astype(np.int32),
        rng.integers(3000, 5000, n).astype(np.int16),
        (seq % 2).astype(np.uint16),
    )


def naive_decode(data: bytes) -> int:
    table = [int(v) for v in _TABLE]
    n = 0
    i = 0
    end = len(data) - FRAME_LEN
    while i <= end:
        if data[i] == 0xA5 and data[i + 1] == 0x5A:
            crc = 0xFFFF
            for byte in data[i + 2 : i + 16]:
                crc = ((crc << 8) & 0xFFFF) ^ table[((crc >> 8) ^ byte) & 0xFF]
            if crc == data[i + 16] | (data[i + 17] << 8):
                struct.unpack_from("<HiihH", data, i + 2)
                n += 1
                i += FRAME_LEN
                continue
        i += 1
    return n


def main() -> None:
    data = stream(N)
    chunk = READ * FRAME_LEN
    best = 0.0
    for _ in range(3):
        dec = FrameDecoder()
        t = time.perf_counter()
        got = sum(len(dec.feed(data[i : i + chunk])) for i in range(0, len(data), chunk))
        rate = got / (time.perf_counter() - t)
        best = max(best, rate)
        assert got == N and dec.corrupt_frames == 0
    sub = data[: 30_000 * FRAME_LEN]
    t = time.perf_counter()
    n = naive_decode(sub)
    naive = n / (time.perf_counter() - t)
    print(f"FrameDecoder: {best:,.0f} frames/s ({READ}-frame reads, best of 3)")
    print(f"baseline per-frame Python decoder: {naive:,.0f} frames/s -> {best / naive:.1f}x")
    print(f"vs the 1 kHz DAQ: {best / 1000:,.0f}x; vs the 200 k frames/s aim: {best / 200e3:.1f}x")


if __name__ == "__main__":
    main()
