"""Recording: write rate, bytes per sample and bulk read into NumPy of a full sweep.

A synthetic full sweep (22 clicks x 0.5 / 1 / 1.5 Hz, 30 mm, 1 kHz; per test 1 ramp-in,
2 warm-up, 5 measured and 1 ramp-out cycles) with forces from the damper model plus DAQ-like
noise is written in blocks of 50 samples (a 20 Hz DAQ poll) with each candidate encoding, then
read back into NumPy arrays (t, x, force, temperature per test). The baseline is one JSON
message per sample on a jsonschema channel, measured in the same run. All candidates use the
same MCAP writer settings (zstd chunks of 1 MiB) and the same front-to-back chunk reader.
Times are the best of 3 runs (1 run for the slow JSON candidates); the machine is shared.
Aim (issue 4): reading the full sweep into NumPy in < 1 s.

Issue 12 (Foxglove-native recordings) compares format 2 (the current writer: blocks carry a
float32 display velocity, log_time is wall-clock time) with format 1 (shockdyno 0.1.0's blocks,
written here with the old encoder) in the same run, and measures the per-sample plot channel
that was considered instead: format 2 plus one float32 message per sample (x, v, F, T), with
and without MCAP message indexes. Aims: read < 1 s, file <= 1.5x format 1.
"""

from __future__ import annotations

import json
import math
import os
import struct
import tempfile
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path

import numpy as np
from mcap.records import Chunk, Message
from mcap.stream_reader import StreamReader, breakup_chunk
from mcap.writer import IndexType, Writer

from shockdyno.model import force_from_displacement, load_spec
from shockdyno.record import RecordingWriter, TestMeta, open_recording
from shockdyno.record import schemas as s
from shockdyno.samples import SampleBlock

RATE = 1000.0
BLOCK = 50
FREQS = (0.5, 1.0, 1.5)


def make_sweep() -> list[tuple[TestMeta, SampleBlock]]:
    spec = load_spec()
    rng = np.random.default_rng(4)
    tests = []
    seq0 = 0
    for clicks in range(22):
        a_bc, a_bt = spec.bleed_areas(clicks, 0)
        for k, f in enumerate(FREQS):
            n = round(9 / f * RATE)
            seq = np.arange(seq0, seq0 + n, dtype=np.int64)
            t = seq / RATE
            x = 0.03 * np.sin(2 * np.pi * f * (t - t[0]))
            force = force_from_displacement(spec, t, x, a_bc, a_bt)
            # A 16-bit DAQ's quantised readings, as the frame codec scales them to SI
            x_q = np.round((x + rng.normal(0, 5e-6, n)) / 2e-6) * 2e-6
            f_q = np.round((force + rng.normal(0, 2.0, n)) / 0.1) * 0.1
            temp = np.round((40 + 0.01 * (t - t[0]) + rng.normal(0, 0.05, n)) / 0.01) * 0.01
            block = SampleBlock(seq, t, x_q, f_q, temp, np.zeros(n, np.uint16))
            meta = TestMeta(len(tests), clicks, 0, f, 0.03, RATE, 2, 5, status="complete")
            tests.append((meta, block))
            seq0 += n + 500
            del k
    return tests


def blocks(b: SampleBlock) -> list[SampleBlock]:
    return [b.slice(lo, lo + BLOCK) for lo in range(0, len(b), BLOCK)]


# -- baseline: one JSON message per sample --------------------------------------------------

JSON_SAMPLE_SCHEMA = json.dumps(
    {
        "type": "object",
        "properties": {
            k: {"type": "number"}
            for k in ("test", "seq", "t_s", "displacement_m", "force_n", "temperature_c", "status")
        },
    }
).encode()


def write_json(
    path: Path, sweep: list[tuple[TestMeta, list[SampleBlock]]], per_block: bool
) -> None:
    with open(path, "wb") as f:
        w = Writer(f)
        w.start()
        sid = w.register_schema("shockdyno.Sample", "jsonschema", JSON_SAMPLE_SCHEMA)
        ch = w.register_channel("/dyno/samples", "json", sid)
        i = 0
        for test, (_, bl) in enumerate(sweep):
            for b in bl:
                cols = (b.seq, b.t_s, b.displacement_m, b.force_n, b.temperature_c, b.status)
                if per_block:
                    names = ("seq", "t_s", "displacement_m", "force_n", "temperature_c", "status")
                    obj = {
                        "test": test,
                        **{k: c.tolist() for k, c in zip(names, cols, strict=True)},
                    }
                    ns = round(float(b.t_s[0]) * 1e9)
                    w.add_message(ch, ns, json.dumps(obj).encode(), ns, i)
                    i += 1
                    continue
                for s, t, x, fo, te, st in zip(*(c.tolist() for c in cols), strict=True):
                    obj = {
                        "test": test,
                        "seq": s,
                        "t_s": t,
                        "displacement_m": x,
                        "force_n": fo,
                        "temperature_c": te,
                        "status": st,
                    }
                    ns = round(t * 1e9)
                    w.add_message(ch, ns, json.dumps(obj).encode(), ns, i)
                    i += 1
            w.flush()
            os.fsync(f.fileno())
        w.finish()


def read_json(path: Path, per_block: bool) -> list[dict[str, np.ndarray]]:
    by_test: dict[int, dict[str, list[float]]] = {}
    keys = ("t_s", "displacement_m", "force_n", "temperature_c")
    with open(path, "rb") as f:
        for rec in StreamReader(f, emit_chunks=True).records:
            if not isinstance(rec, Chunk):
                continue
            for r in breakup_chunk(rec, validate_crc=True):
                if not isinstance(r, Message):
                    continue
                obj = json.loads(r.data)
                cols = by_test.setdefault(obj["test"], {k: [] for k in keys})
                for k in keys:
                    if per_block:
                        cols[k].extend(obj[k])
                    else:
                        cols[k].append(obj[k])
    return [{k: np.array(v) for k, v in cols.items()} for _, cols in sorted(by_test.items())]


# -- candidates: CDR blocks through RecordingWriter / open_recording ------------------------


def write_cdr(
    path: Path, sweep: list[tuple[TestMeta, list[SampleBlock]]], max_block: int, comp: str
) -> None:
    with RecordingWriter(
        path, metadata={"bench": "1"}, max_block_samples=max_block, compression=comp
    ) as w:
        for meta, bl in sweep:
            w.begin_test(meta)
            for b in bl:
                w.write_samples(b)
            w.end_test(meta)


def encode_format1(test: int, b: SampleBlock) -> bytes:
    """shockdyno 0.1.0's SampleBlock: the format 2 message without its velocity array."""
    n = len(b)
    cols = [
        np.ascontiguousarray(c, d).tobytes()
        for c, d in zip(
            (b.seq, b.t_s, b.displacement_m, b.force_n, b.temperature_c, b.status),
            ("<i8", "<f8", "<f8", "<f8", "<f8", "<u2"),
            strict=True,
        )
    ]
    pad = struct.pack("<I4x", n)
    return b"".join(
        (
            b"\x00\x01\x00\x00",
            struct.pack("<II", test, n),
            cols[0],
            pad,
            cols[1],
            pad,
            cols[2],
            pad,
            cols[3],
            pad,
            cols[4],
            struct.pack("<I", n),
            cols[5],
        )
    )


class Format1Writer(RecordingWriter):
    """RecordingWriter as of 0.1.0: the same merging, chunking and per-test fsync, but blocks
    without velocity (its sample flush, restored here so the write rates compare like for like;
    log_time differs only by a constant, which costs nothing; the channel keeps the new
    schema record, a few hundred bytes per file)."""

    def _flush_samples(self) -> None:
        if not self._pending:
            return
        merged = SampleBlock.concat(self._pending)
        self._pending, self._pending_n = [], 0
        test = self._test_serial if self._open is not None else s.NO_TEST
        for lo in range(0, len(merged), self._max_block):
            part = merged.slice(lo, lo + self._max_block)
            self._emit(self._ch_samples, float(part.t_s[0]), encode_format1(test, part))


def write_format1(path: Path, sweep: list[tuple[TestMeta, list[SampleBlock]]]) -> None:
    with Format1Writer(path, metadata={"bench": "1"}) as w:
        for meta, bl in sweep:
            w.begin_test(meta)
            for b in bl:
                w.write_samples(b)
            w.end_test(meta)


PLOT_DTYPE = np.dtype([("cdr", "<u4"), ("x", "<f4"), ("v", "<f4"), ("f", "<f4"), ("t", "<f4")])


def write_plot_channel(
    path: Path, sweep: list[tuple[TestMeta, list[SampleBlock]]], indexed: bool
) -> None:
    """The rejected alternative alone: one CDR message (x, v, F, T as float32) per sample, which
    Foxglove plots against its timeline. Same zstd chunks; with or without message indexes."""
    index = IndexType.ALL if indexed else IndexType.ATTACHMENT | IndexType.METADATA
    with open(path, "wb") as f:
        w = Writer(f, index_types=index)
        w.start()
        sid = w.register_schema("shockdyno/msg/Sample", "ros2msg", b"float32 x")
        ch = w.register_channel("/dyno/sample", "cdr", sid)
        i = 0
        for _, bl in sweep:
            for b in bl:
                rows = np.zeros(len(b), PLOT_DTYPE)
                rows["cdr"] = 0x100
                rows["x"], rows["f"], rows["t"] = b.displacement_m, b.force_n, b.temperature_c
                rows["v"] = s.display_velocity(b.t_s, b.displacement_m)
                raw = rows.tobytes()
                size = PLOT_DTYPE.itemsize
                for k, ns in enumerate((np.round(b.t_s * 1e9)).astype(np.int64).tolist()):
                    w.add_message(ch, ns, raw[k * size : (k + 1) * size], ns, i)
                    i += 1
            w.flush()
            os.fsync(f.fileno())
        w.finish()


def read_cdr(path: Path) -> list[dict[str, np.ndarray]]:
    rec = open_recording(path)
    return [
        {"t_s": d.t, "displacement_m": d.x, "force_n": d.force, "temperature_c": d.temperature}
        for d in rec.load_all()
    ]


def fresh_write(write: Callable[[Path], None], path: Path) -> None:
    path.unlink(missing_ok=True)
    write(path)


def best_of(n: int, fn: Callable[[], object]) -> tuple[float, object]:
    best, out = float("inf"), None
    for _ in range(n):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


Read = Callable[[Path], object] | None


def main() -> None:
    t0 = time.perf_counter()
    raw = make_sweep()
    sweep = [(m, blocks(b)) for m, b in raw]
    n_samples = sum(len(b) for _, b in raw)
    print(
        f"sweep: {len(raw)} tests, {n_samples} samples ({n_samples / RATE:.0f} s at 1 kHz), "
        f"{sum(len(b) for _, b in sweep)} blocks of {BLOCK}; "
        f"built in {time.perf_counter() - t0:.1f} s"
    )
    truth_f = np.concatenate([b.force_n for _, b in raw])
    cdr = "cdr/1000, zstd"
    candidates: list[tuple[str, Callable[[Path], None], Read, int]] = [
        (
            "json/sample (baseline)",
            lambda p: write_json(p, sweep, False),
            lambda p: read_json(p, False),
            1,
        ),
        ("json/block of 50", lambda p: write_json(p, sweep, True), lambda p: read_json(p, True), 1),
        ("cdr/block of 50, zstd", lambda p: write_cdr(p, sweep, BLOCK, "zstd"), read_cdr, 3),
        (f"format 1: {cdr}", lambda p: write_format1(p, sweep), read_cdr, 3),
        ("format 2 (chosen), zstd", lambda p: write_cdr(p, sweep, 1000, "zstd"), read_cdr, 3),
        ("format 2, cdr/1000, lz4", lambda p: write_cdr(p, sweep, 1000, "lz4"), read_cdr, 3),
        ("format 2, uncompressed", lambda p: write_cdr(p, sweep, 1000, "none"), read_cdr, 3),
        ("msg/sample alone, indexed", lambda p: write_plot_channel(p, sweep, True), None, 1),
        ("msg/sample alone, no index", lambda p: write_plot_channel(p, sweep, False), None, 1),
    ]
    rows = []
    kept: dict[int, Path] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for k, (name, write, read, reps) in enumerate(candidates):
            path = Path(tmp) / f"c{k}.mcap"
            t_write, _ = best_of(reps, partial(fresh_write, write, path))
            size = path.stat().st_size
            t_read = float("nan")
            if read is not None:
                t_read, tests = best_of(reps, partial(read, path))
                assert isinstance(tests, list) and len(tests) == len(raw)
                got_f = np.concatenate([d["force_n"] for d in tests])
                assert np.array_equal(got_f, truth_f), name  # every candidate is lossless
            if k in (3, 4):
                kept[k] = path  # format 1 and 2: read again head to head below
            else:
                path.unlink()
            rows.append((name, n_samples / t_write, size / n_samples, t_read))
        # The machine is shared: read the two formats alternately, 7 times each, best of each,
        # so a burst of load elsewhere cannot favour one of them.
        h2h = {3: float("inf"), 4: float("inf")}
        for _ in range(7):
            for k in h2h:
                t_read, _ = best_of(1, partial(read_cdr, kept[k]))
                h2h[k] = min(h2h[k], t_read)
    base = rows[0]
    print(
        f"{'encoding':30} {'write samples/s':>16} {'x base':>7} {'bytes/sample':>13} "
        f"{'x base':>7} {'read sweep s':>13} {'x faster':>9}"
    )
    for name, wr, bps, rd in rows:
        read = f"{rd:13.3f} {base[3] / rd:9.1f}" if math.isfinite(rd) else f"{'-':>13} {'-':>9}"
        print(f"{name:30} {wr:16,.0f} {wr / base[1]:7.1f} {bps:13.2f} {bps / base[2]:7.2f} {read}")
    old, new = rows[3], rows[4]
    print(
        f"head to head, alternating reads: format 1 {h2h[3]:.3f} s, format 2 {h2h[4]:.3f} s "
        f"({h2h[4] / h2h[3]:.2f}x)"
    )
    plot_idx, plot_noidx = rows[7][2], rows[8][2]
    read_ok = "meets" if h2h[4] < 1.0 else "MISSES"
    size_ok = "meets" if new[2] <= 1.5 * old[2] else "MISSES"
    print(f"format 2 reads the full sweep in {h2h[4]:.3f} s: {read_ok} the < 1 s aim")
    print(
        f"format 2 / format 1: size {new[2] / old[2]:.2f}x ({size_ok} the <= 1.5x aim), "
        f"read time {h2h[4] / h2h[3]:.2f}x, write rate {new[1] / old[1]:.2f}x"
    )
    print(
        f"format 2 + a message per sample would be {(new[2] + plot_idx) / old[2]:.2f}x format 1 "
        f"indexed, {(new[2] + plot_noidx) / old[2]:.2f}x without message indexes"
    )


if __name__ == "__main__":
    main()
