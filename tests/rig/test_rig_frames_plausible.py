"""Frames that pass their CRC but cannot be true: out-of-range readings, a jumping counter."""

from __future__ import annotations

import numpy as np

from shockdyno.rig.config import load_rig
from shockdyno.rig.daq import plausible_counts
from shockdyno.rig.frames import FrameDecoder, Plausible, encode_frames

SIM = load_rig("rigs/sim.toml")


def frames(seq, lvdt=None) -> bytes:
    seq = np.asarray(seq, np.int64)
    n = seq.size
    lv = np.full(n, 75_000) if lvdt is None else np.asarray(lvdt)
    return encode_frames(seq, np.zeros(n, int), lv, np.full(n, 2500), np.zeros(n, int))


def test_a_reading_beyond_the_sensor_range_is_rejected_not_delivered():
    dec = FrameDecoder(plausible_counts(SIM.daq))
    lvdt = np.full(10, 75_000)
    lvdt[4] = -1_946_000_000  # -1946 m: a damaged frame whose CRC happened to match
    out = dec.feed(frames(np.arange(10), lvdt))
    assert out.seq.tolist() == [0, 1, 2, 3, 5, 6, 7, 8, 9]
    assert dec.rejected_frames == 1 and dec.corrupt_frames == 1 and dec.dropped_frames == 0


def test_sim_rig_ranges_follow_its_limits():
    p = plausible_counts(SIM.daq)
    assert p.lvdt == (75_000 - 180_000, 75_000 + 180_000)  # centre ± 4 x 45 mm in µm
    assert p.load == (-480_000, 480_000)  # ± 4 x 6 kN at 0.05 N/count


def test_a_damaged_counter_does_not_shift_the_time_base():
    dec = FrameDecoder(Plausible())
    seq = np.arange(100, 120)
    bad = seq.copy()
    bad[7] = 100  # went backwards: unwrapped, it would be +65 529 samples
    out = dec.feed(frames(bad))
    assert out.seq.tolist() == [s for i, s in enumerate(seq.tolist()) if i != 7]
    assert dec.rejected_frames == 1 and dec.corrupt_frames == 1


def test_a_jump_at_the_end_of_a_read_waits_for_the_next_frame():
    dec = FrameDecoder(Plausible())
    first = dec.feed(frames(np.arange(10)) + frames([40_000]))
    assert first.seq.tolist() == list(range(10))  # the jumping frame is held, not believed
    out = dec.feed(frames(np.arange(11, 20)))
    assert out.seq.tolist() == list(range(11, 20))
    assert dec.rejected_frames == 1


def test_a_real_restart_of_the_counter_is_believed_when_the_next_frame_continues_it():
    dec = FrameDecoder(Plausible())
    dec.feed(frames(np.arange(10)))
    out = dec.feed(frames(np.arange(30_000, 30_010)))
    assert out.seq[0] == 30_000 and np.all(np.diff(out.seq) == 1)
    assert dec.rejected_frames == 0 and dec.dropped_frames == 30_000 - 10


def test_a_counter_damaged_by_a_few_counts_is_caught_too():
    dec = FrameDecoder(Plausible())
    seq = np.arange(500, 540)
    bad = seq.copy()
    bad[10] += 100  # ahead by 100: a plain gap of 100 if believed, then the time base jumps
    out = dec.feed(frames(bad))
    assert out.seq.tolist() == [s for i, s in enumerate(seq.tolist()) if i != 10]
    assert dec.rejected_frames == 1


def test_a_small_real_gap_is_believed():
    dec = FrameDecoder(Plausible())
    seq = np.concatenate([np.arange(0, 10), np.arange(14, 30)])
    out = dec.feed(frames(seq))
    assert out.seq.tolist() == seq.tolist() and dec.dropped_frames == 4
