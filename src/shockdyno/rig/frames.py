"""The DAQ's binary frame format: bytes <-> raw samples. No I/O here.

One frame, 18 bytes, little-endian:

    offset  size  field
    0       2     sync  0xA5 0x5A
    2       2     seq   uint16, +1 per sample, wraps at 65536 (the DAQ's clock)
    4       4     load  int32 load-cell counts
    8       4     lvdt  int32 LVDT counts (absolute ram position)
    12      2     temp  int16 temperature counts
    14      2     status uint16 bits (STATUS_* below)
    16      2     crc   CRC-16/CCITT-FALSE over bytes 2..15

The decoder works on whole buffers with NumPy (sync search, CRC of every candidate at
once), so it is fast enough for 10 kHz DAQs; it resynchronises after garbage, rejects
bad CRCs and never returns a frame that failed its check.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

SYNC = b"\xa5\x5a"
FRAME_LEN = 18
_BODY = slice(2, 16)  # bytes covered by the CRC

LOOKAHEAD = 3  # frames after a gap that judge whether its counter is believed
STATUS_MOTION = 1 << 0  # the drive's "motion active" output, wired to a DAQ digital input
STATUS_LOAD_OVERRANGE = 1 << 1
STATUS_LVDT_OVERRANGE = 1 << 2
STATUS_TEMP_FAULT = 1 << 3

FRAME_DTYPE = np.dtype(
    [
        ("sync", "<u2"),
        ("seq", "<u2"),
        ("load", "<i4"),
        ("lvdt", "<i4"),
        ("temp", "<i2"),
        ("status", "<u2"),
        ("crc", "<u2"),
    ]
)
assert FRAME_DTYPE.itemsize == FRAME_LEN


def _crc_table() -> NDArray[np.uint16]:
    table = np.zeros(256, np.uint16)
    for i in range(256):
        crc = i << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else (crc << 1)
        table[i] = crc & 0xFFFF
    return table


_TABLE = _crc_table()


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF); crc16(b"123456789") == 0x29B1."""
    crc = 0xFFFF
    for byte in data:
        crc = ((crc << 8) & 0xFFFF) ^ int(_TABLE[((crc >> 8) ^ byte) & 0xFF])
    return crc


def crc16_rows(rows: NDArray[np.uint8]) -> NDArray[np.uint16]:
    """CRC of every row of a (frames, bytes) array at once."""
    crc = np.full(rows.shape[0], 0xFFFF, np.uint16)
    for col in range(rows.shape[1]):
        idx = ((crc >> 8) ^ rows[:, col]) & 0xFF
        crc = ((crc << 8) & 0xFFFF).astype(np.uint16) ^ _TABLE[idx]
    return crc


def encode_frames(
    seq: NDArray[np.integer],
    load: NDArray[np.integer],
    lvdt: NDArray[np.integer],
    temp: NDArray[np.integer],
    status: NDArray[np.integer],
) -> bytes:
    """Frames for the given raw samples (seq is taken modulo 65536)."""
    n = len(seq)
    out = np.zeros(n, FRAME_DTYPE)
    out["sync"] = 0x5AA5  # bytes A5 5A little-endian
    out["seq"] = np.asarray(seq) & 0xFFFF
    out["load"] = load
    out["lvdt"] = lvdt
    out["temp"] = temp
    out["status"] = status
    raw = out.view(np.uint8).reshape(n, FRAME_LEN)
    out["crc"] = crc16_rows(raw[:, _BODY])
    return out.tobytes()


@dataclass(frozen=True)
class RawFrames:
    """Checked frames in arrival order, with the sequence counter unwrapped."""

    seq: NDArray[np.int64]
    load: NDArray[np.int32]
    lvdt: NDArray[np.int32]
    temp: NDArray[np.int16]
    status: NDArray[np.uint16]

    def __len__(self) -> int:
        return int(self.seq.size)


_EMPTY = RawFrames(
    np.zeros(0, np.int64),
    np.zeros(0, np.int32),
    np.zeros(0, np.int32),
    np.zeros(0, np.int16),
    np.zeros(0, np.uint16),
)


@dataclass(frozen=True)
class Plausible:
    """What a frame may hold and still be believed, beyond its CRC.

    CRC-16 lets about 1 in 65 536 damaged frames through; at high byte error rates that is
    a frame every few seconds. A sensor cannot report beyond its range (it saturates and
    sets its over-range bit), so a reading outside it is damage. A frame whose sequence
    number does not follow on from its neighbours is out of order: believed, a damaged
    counter would shift the time base for the rest of the stream.
    """

    load: tuple[int, int] = (-(2**31), 2**31 - 1)  # counts, inclusive
    lvdt: tuple[int, int] = (-(2**31), 2**31 - 1)
    temp: tuple[int, int] = (-(2**15), 2**15 - 1)
    check_sequence: bool = True


class FrameDecoder:
    """Incremental decoder: feed it any chunks of bytes, get checked frames back.

    Accounting, from the sequence numbers: every gap between consecutive good frames is
    `missing` frames; as many of them as the skipped bytes could have held (at least one
    if any byte was skipped) count as `corrupt_frames`, the rest as `dropped_frames`.
    Skipped bytes that hold no missing frame (inserted garbage) count as `garbage_bytes`.
    """

    def __init__(self, plausible: Plausible | None = None) -> None:
        self.plausible = plausible or Plausible()
        self.rejected_frames = 0  # passed the CRC, failed a plausibility check
        self._tail = b""
        self._skipped = 0  # bytes skipped since the last good frame
        self._last_raw: int | None = None
        self._last_seq = -1
        self.frames = 0
        self.dropped_frames = 0
        self.corrupt_frames = 0
        self.garbage_bytes = 0

    @property
    def last_seq(self) -> int:
        """Unwrapped sequence number of the last good frame (-1 before the first)."""
        return self._last_seq

    def feed(self, data: bytes) -> RawFrames:
        """Decode the next bytes of the stream: the good frames now complete, as raw counts (a
        partial frame is kept for the next call); counts lost, damaged and implausible frames and
        skipped bytes."""
        buf = self._tail + data if self._tail else bytes(data)
        n = len(buf)
        if n < FRAME_LEN:
            self._tail = buf
            return _EMPTY
        arr = np.frombuffer(buf, np.uint8)
        last_start = n - FRAME_LEN  # last position where a whole frame fits
        head = arr[: last_start + 2]
        cand = np.flatnonzero((head[:-1] == 0xA5) & (head[1:] == 0x5A))
        if cand.size:
            rows = arr[cand[:, None] + np.arange(FRAME_LEN)]
            crc = rows[:, 16].astype(np.uint16) | (rows[:, 17].astype(np.uint16) << 8)
            good = cand[crc16_rows(rows[:, _BODY]) == crc]
        else:
            good = cand
        starts = self._believable_values(arr, self._non_overlapping(good))
        starts, held = self._believable_sequence(arr, starts)
        if held is not None:  # judged with the next bytes, by the frame that follows it
            consumed = int(starts[-1]) + FRAME_LEN if starts.size else 0
            keep_from = held
        elif starts.size:
            consumed = int(starts[-1]) + FRAME_LEN
            keep_from = max(consumed, n - (FRAME_LEN - 1))
        else:
            consumed = 0
            keep_from = n - (FRAME_LEN - 1)
        self._tail = buf[keep_from:]
        if not starts.size:
            self._skipped += keep_from
            return _EMPTY
        idx = starts[:, None] + np.arange(FRAME_LEN)
        frames = arr[idx].reshape(-1).view(FRAME_DTYPE)
        ends = np.concatenate(([0], starts[:-1] + FRAME_LEN))
        skipped = starts - ends
        skipped[0] += self._skipped
        self._skipped = keep_from - consumed
        seq_raw = frames["seq"].astype(np.int64)
        prev = np.concatenate(
            ([self._last_raw if self._last_raw is not None else -1], seq_raw[:-1])
        )
        step = ((seq_raw - prev - 1) % 65536) + 1
        if self._last_raw is None:  # the first frame ever only starts the clock
            step[0] = 1
            self.garbage_bytes += int(skipped[0])
            skipped[0] = 0
        missing = step - 1
        damaged = np.minimum(missing, -(-skipped // FRAME_LEN))
        self.dropped_frames += int((missing - damaged).sum())
        self.corrupt_frames += int(damaged.sum())
        self.garbage_bytes += int((skipped - damaged * FRAME_LEN).clip(min=0).sum())
        seq = self._last_seq + np.cumsum(step)
        if self._last_raw is None:
            seq = seq - seq[0] + int(seq_raw[0])
        self._last_raw = int(seq_raw[-1])
        self._last_seq = int(seq[-1])
        self.frames += int(starts.size)
        return RawFrames(
            seq.astype(np.int64),
            frames["load"].astype(np.int32),
            frames["lvdt"].astype(np.int32),
            frames["temp"].astype(np.int16),
            frames["status"].astype(np.uint16),
        )

    def _believable_values(
        self, arr: NDArray[np.uint8], starts: NDArray[np.intp]
    ) -> NDArray[np.intp]:
        if not starts.size:
            return starts
        rows = arr[starts[:, None] + np.arange(FRAME_LEN)].reshape(-1).view(FRAME_DTYPE)
        p = self.plausible
        ok = np.ones(starts.size, bool)
        for name, (lo, hi) in (("load", p.load), ("lvdt", p.lvdt), ("temp", p.temp)):
            ok &= (rows[name] >= lo) & (rows[name] <= hi)
        if ok.all():
            return starts
        self.rejected_frames += int((~ok).sum())
        return starts[ok]

    def _believable_sequence(
        self, arr: NDArray[np.uint8], starts: NDArray[np.intp]
    ) -> tuple[NDArray[np.intp], int | None]:
        """Drop a frame whose counter does not follow on: when the frames after it are closer
        to the frame before it than to it, it is out of order (a damaged counter, even one off
        by a few counts). A last frame after a gap is held back (returned as the offset to
        keep from) until the next read can judge it."""
        if not starts.size or not self.plausible.check_sequence:
            return starts, None
        raw = arr[starts[:, None] + np.array([2, 3])].astype(np.int64)
        seq = raw[:, 0] | (raw[:, 1] << 8)
        # The very first frame starts the clock: it is its own predecessor's successor.
        first = (int(seq[0]) - 1) % 65536 if self._last_raw is None else self._last_raw
        steps = (np.diff(seq, prepend=first) - 1) % 65536 + 1
        odd = np.flatnonzero(steps != 1)
        if not odd.size:
            return starts, None

        def step(a: int, b: int) -> int:
            return ((b - a - 1) % 65536) + 1

        keep = np.ones(starts.size, bool)
        for k in odd.tolist():
            j = k - 1
            while j >= 0 and not keep[j]:
                j -= 1
            prev = int(seq[j]) if j >= 0 else first
            gap = step(prev, int(seq[k]))
            if gap == 1:
                continue
            after = [int(v) for v in seq[k + 1 : k + 1 + LOOKAHEAD]]
            if not after:
                keep[k] = False
                return starts[keep], int(starts[k])
            # Believe k when most of the frames after it continue from it rather than from
            # the frame before it (two damaged counters in a row must not vouch for each other).
            votes = sum(step(int(seq[k]), f) < step(prev, f) for f in after)
            if 2 * votes <= len(after):
                keep[k] = False
                self.rejected_frames += 1
        return starts[keep], None

    @staticmethod
    def _non_overlapping(good: NDArray[np.intp]) -> NDArray[np.intp]:
        if good.size < 2 or bool(np.all(np.diff(good) >= FRAME_LEN)):
            return good
        # A false sync inside a good frame passed its CRC: keep frames greedily in order.
        keep: list[int] = []
        end = -1
        for p in good.tolist():
            if p >= end:
                keep.append(p)
                end = p + FRAME_LEN
        return np.asarray(keep, dtype=np.intp)
