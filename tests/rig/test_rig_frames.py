"""The DAQ frame codec, byte by byte: sync, CRC, resync, accounting, seq unwrap."""

from __future__ import annotations

import itertools
import struct

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from shockdyno.rig.frames import FRAME_LEN, FrameDecoder, crc16, crc16_rows, encode_frames


def frames(n: int, start: int = 0) -> tuple[bytes, np.ndarray]:
    seq = np.arange(start, start + n, dtype=np.int64)
    load = (seq * 7919 % 100_000 - 50_000).astype(np.int32)
    data = encode_frames(seq, load, -(seq.astype(np.int32)), (seq % 300).astype(np.int16), seq % 16)
    return data, load


def test_crc16_check_value() -> None:
    # CRC-16/CCITT-FALSE's published check value.
    assert crc16(b"123456789") == 0x29B1
    rows = np.random.default_rng(1).integers(0, 256, (50, 14), dtype=np.uint8)
    assert [int(c) for c in crc16_rows(rows)] == [crc16(bytes(r)) for r in rows]


def test_frame_layout_is_as_documented() -> None:
    data = encode_frames(
        np.array([0x1234]), np.array([-2]), np.array([100000]), np.array([-5]), np.array([9])
    )
    assert len(data) == FRAME_LEN
    sync, seq, load, lvdt, temp, status, crc = struct.unpack("<2sHiihHH", data)
    assert (sync, seq, load, lvdt, temp, status) == (b"\xa5\x5a", 0x1234, -2, 100000, -5, 9)
    assert crc == crc16(data[2:16])


def test_byte_by_byte_feed_equals_bulk_feed() -> None:
    data, load = frames(40)
    bulk = FrameDecoder().feed(data)
    dec = FrameDecoder()
    got = [dec.feed(data[i : i + 1]) for i in range(len(data))]
    seq = np.concatenate([g.seq for g in got])
    assert np.array_equal(seq, bulk.seq) and np.array_equal(seq, np.arange(40))
    assert np.array_equal(np.concatenate([g.load for g in got]), load)
    assert (dec.dropped_frames, dec.corrupt_frames, dec.garbage_bytes) == (0, 0, 0)


def test_sequence_counter_unwraps_across_65536() -> None:
    data, _ = frames(20, start=65530)
    out = FrameDecoder().feed(data)
    assert np.array_equal(out.seq, np.arange(65530, 65550))


def test_resynchronises_after_leading_garbage_without_counting_frames() -> None:
    data, _ = frames(10)
    junk = b"\x00\xa5\x5a\xa5" + bytes(range(30))
    dec = FrameDecoder()
    out = dec.feed(junk + data[5:] + data)  # starts mid-frame, then whole frames
    assert len(out) >= 19
    assert dec.corrupt_frames == 0


@pytest.mark.parametrize("pos", range(FRAME_LEN))
def test_any_damaged_byte_rejects_only_that_frame(pos: int) -> None:
    data, load = frames(5)
    bad = bytearray(data)
    bad[2 * FRAME_LEN + pos] ^= 0x41
    dec = FrameDecoder()
    out = dec.feed(bytes(bad))
    assert list(out.seq) == [0, 1, 3, 4]
    assert list(out.load) == [load[0], load[1], load[3], load[4]]
    assert (dec.corrupt_frames, dec.dropped_frames) == (1, 0)


def test_dropped_frames_are_counted_from_sequence_gaps() -> None:
    data, _ = frames(10)
    cut = data[: 3 * FRAME_LEN] + data[6 * FRAME_LEN :]  # frames 3, 4, 5 never sent
    dec = FrameDecoder()
    out = dec.feed(cut)
    assert list(out.seq) == [0, 1, 2, 6, 7, 8, 9]
    assert (dec.dropped_frames, dec.corrupt_frames) == (3, 0)


def test_inserted_garbage_is_not_a_lost_frame() -> None:
    data, _ = frames(6)
    noisy = data[: 2 * FRAME_LEN] + b"\xa5\x5a\x01\x02garbage" + data[2 * FRAME_LEN :]
    dec = FrameDecoder()
    assert len(dec.feed(noisy)) == 6
    assert (dec.dropped_frames, dec.corrupt_frames, dec.garbage_bytes) == (
        0,
        0,
        11,
    )  # 2 sync + 2 + 7 bytes


def test_sync_pattern_inside_a_payload_is_not_a_frame_start() -> None:
    load = np.array([struct.unpack("<i", b"\xa5\x5a\xa5\x5a")[0]] * 3, np.int32)
    seq = np.arange(3)
    data = encode_frames(seq, load, load, np.zeros(3, np.int16), np.zeros(3, np.uint16))
    dec = FrameDecoder()
    out = dec.feed(data)
    assert list(out.seq) == [0, 1, 2] and np.all(out.load == load)
    assert dec.garbage_bytes == 0


@settings(max_examples=60, deadline=None)
@given(
    flips=st.lists(st.tuples(st.integers(0, 30 * FRAME_LEN - 1), st.integers(1, 255)), max_size=8),
    cuts=st.lists(st.integers(1, 30 * FRAME_LEN - 1), max_size=6),
)
def test_corruption_never_reaches_the_caller_and_every_frame_is_accounted(
    flips: list[tuple[int, int]], cuts: list[int]
) -> None:
    n = 30
    data, load = frames(n)
    bad = bytearray(data)
    for pos, x in flips:
        bad[pos] ^= x
    # Two intact frames close the accounting (a last frame after a gap waits for the next
    # one to confirm its sequence number: frames.Plausible)
    bad += frames(2, start=n)[0]
    dec = FrameDecoder()
    bounds = [0, *sorted(cuts), len(bad)]
    got = [dec.feed(bytes(bad[a:b])) for a, b in itertools.pairwise(bounds)]
    seq = np.concatenate([g.seq for g in got])
    loads = np.concatenate([g.load for g in got])
    assert np.all(np.diff(seq) > 0)
    clean = seq[seq < n]
    assert np.array_equal(loads[: clean.size], load[clean])  # only intact frames come out
    damaged = {p // FRAME_LEN for p, _ in flips}
    assert set(range(n)) - damaged <= set(clean.tolist())
    # Frames before the first good one are unknowable; every later one is accounted for.
    assert len(seq) + dec.dropped_frames + dec.corrupt_frames == n + 2 - seq[0]
    assert dec.dropped_frames == 0
