"""Writer -> MCAP file -> reader gives back exactly what was written."""

from __future__ import annotations

import os
import signal
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rec_helpers import SAMPLES_PER_TEST, TESTS, block, meta, seq_range, write_small

from shockdyno.errors import RecordingError
from shockdyno.record import RecordingWriter, open_recording
from shockdyno.samples import SampleBlock


def test_samples_metadata_events_round_trip(tmp_path: Path) -> None:
    path = tmp_path / "sweep.mcap"
    write_small(path)
    rec = open_recording(path)
    assert not rec.truncated
    assert rec.metadata["damper_id"] == "S46-0042"
    assert rec.metadata["notes"] == "new shims, ä ok"
    assert rec.metadata["format_version"] == "2"
    assert rec.rig_toml == '[rig]\nname = "sim"\n'
    assert [(m.index, m.clicks, m.frequency_hz) for m in rec.tests] == TESTS
    assert rec.completed_keys() == {(c, 2, f) for _, c, f in TESTS}
    for k, data in enumerate(rec.load_all()):
        truth = block(seq_range(k)[0], SAMPLES_PER_TEST)
        assert np.array_equal(data.t, truth.t_s)
        assert np.array_equal(data.x, truth.displacement_m)
        assert np.array_equal(data.force, truth.force_n)
        assert data.temperature is not None
        assert np.array_equal(data.temperature, truth.temperature_c)
        full = rec.samples(k)
        assert np.array_equal(full.seq, truth.seq)
        assert np.array_equal(full.status, truth.status)
        assert data.meta.dropped_frames == 0
        assert data.meta.warmup_cycles == 2 and data.meta.measured_cycles == 5
    assert rec.events == [
        (seq_range(k)[1] / 1000.0, "info", f"test {i} done") for k, (i, _, _) in enumerate(TESTS)
    ]
    t, fields = rec.actuator[1]
    assert t == seq_range(1)[0] / 1000.0
    assert fields == {"enable": True, "amplitude_m": 0.03, "mode": "sine"}


def test_load_accepts_the_meta_and_rejects_a_bad_index(tmp_path: Path) -> None:
    path = tmp_path / "r.mcap"
    write_small(path)
    rec = open_recording(path)
    assert rec.load(rec.tests[2]).meta.clicks == 3
    with pytest.raises(RecordingError, match="no test 3"):
        rec.load(3)


def test_dropped_frames_are_counted_from_sequence_gaps(tmp_path: Path) -> None:
    path = tmp_path / "gaps.mcap"
    m = meta(0, 5)
    with RecordingWriter(path, metadata={}) as w:
        w.begin_test(m)
        # 3 frames lost inside a block, 2 between blocks (seq 100, 101)
        w.write_samples(block(0, 100, drop=(10, 11, 50)))
        w.write_samples(block(102, 50))
        w.end_test(replace(m, corrupt_frames=1, measured_start_s=0.02, measured_end_s=0.12))
    rec = open_recording(path)
    (t,) = rec.tests
    assert t.dropped_frames == 5
    assert t.corrupt_frames == 1
    data = rec.load(0)
    assert data.t.size == 147
    win = data.measured()
    assert win.t[0] == pytest.approx(0.02) and win.t[-1] == pytest.approx(0.12)


def test_final_meta_wins_and_aborted_tests_are_listed(tmp_path: Path) -> None:
    path = tmp_path / "a.mcap"
    m0, m1 = meta(0, 0), meta(1, 1)
    with RecordingWriter(path, metadata={}) as w:
        w.begin_test(m0)
        w.write_samples(block(0, 300))
        w.write_event(0.299, "safety", "force limit 5000 N exceeded")
        w.end_test(replace(m0, status="aborted", abort_reason="force limit"))
        w.begin_test(m1)
        w.write_samples(block(400, 300))
        w.end_test(replace(m1, cycle_start_s=(0.4, 0.5, 0.6)))
    rec = open_recording(path)
    assert [m.status for m in rec.tests] == ["aborted", "complete"]
    assert rec.tests[0].abort_reason == "force limit"
    assert rec.tests[1].cycle_start_s == (0.4, 0.5, 0.6)
    assert rec.completed_keys() == {(1, 2, 1.0)}
    assert rec.events == [(0.299, "safety", "force limit 5000 N exceeded")]


def test_close_during_a_test_keeps_it_as_aborted(tmp_path: Path) -> None:
    path = tmp_path / "c.mcap"
    with RecordingWriter(path, metadata={}) as w:
        w.begin_test(meta(0, 7))
        w.write_samples(block(0, 1234))
    rec = open_recording(path)
    assert [m.status for m in rec.tests] == ["aborted"]
    assert rec.load(0).t.size == 1234
    assert rec.completed_keys() == set()


def test_samples_outside_tests_do_not_join_a_test(tmp_path: Path) -> None:
    path = tmp_path / "o.mcap"
    with RecordingWriter(path, metadata={}) as w:
        w.write_samples(block(0, 10))  # centring the stroke before the first test
        w.begin_test(meta(0, 0))
        w.write_samples(block(10, 20))
        w.end_test(meta(0, 0))
        w.write_samples(block(30, 10))
    rec = open_recording(path)
    assert np.array_equal(rec.samples(0).seq, np.arange(10, 30))


def test_misuse_is_a_recording_error(tmp_path: Path) -> None:
    with RecordingWriter(tmp_path / "m.mcap", metadata={}) as w:
        with pytest.raises(RecordingError, match="without begin_test"):
            w.end_test(meta(0, 0))
        w.begin_test(meta(0, 0))
        with pytest.raises(RecordingError, match="still open"):
            w.begin_test(meta(1, 0))
        bad = SampleBlock(
            np.arange(3), np.zeros(2), np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3, np.uint16)
        )
        with pytest.raises(RecordingError, match="differ in length"):
            w.write_samples(bad)
    with pytest.raises(RecordingError, match="closed"):
        w.write_event(0.0, "info", "late")


def test_existing_file_is_not_overwritten(tmp_path: Path) -> None:
    path = tmp_path / "x.mcap"
    write_small(path)
    before = path.read_bytes()
    with pytest.raises(RecordingError, match="exists"):
        RecordingWriter(path, metadata={})
    assert path.read_bytes() == before
    with RecordingWriter(path, metadata={"take": "2"}, overwrite=True):
        pass
    rec = open_recording(path)
    assert rec.metadata["take"] == "2" and rec.tests == []


def test_resume_writes_a_part_file_read_as_one_set(tmp_path: Path) -> None:
    path = tmp_path / "set.mcap"
    with RecordingWriter(path, metadata={"damper_id": "A"}, rig_toml="r = 1\n") as w:
        w.begin_test(meta(0, 0))
        w.write_samples(block(0, 100))
        w.end_test(meta(0, 0))
    for k in (1, 2):
        with RecordingWriter(path, metadata={"damper_id": "A"}, resume=True) as w:
            assert w.path == tmp_path / f"set.part{k + 1}.mcap"
            w.begin_test(meta(k, k))
            w.write_samples(block(0, 100 + k))  # a new DAQ session: seq starts again
            w.end_test(meta(k, k))
    rec = open_recording(path)
    assert [m.clicks for m in rec.tests] == [0, 1, 2]
    assert [rec.load(i).t.size for i in range(3)] == [100, 101, 102]
    assert rec.completed_keys() == {(0, 2, 1.0), (1, 2, 1.0), (2, 2, 1.0)}
    assert rec.metadata["damper_id"] == "A" and rec.rig_toml == "r = 1\n"
    assert len(rec.parts) == 3
    # overwriting the set removes its part files too
    with RecordingWriter(path, metadata={}, overwrite=True):
        pass
    assert sorted(p.name for p in tmp_path.iterdir()) == ["set.mcap"]


def test_missing_and_foreign_files_are_recording_errors(tmp_path: Path) -> None:
    with pytest.raises(RecordingError, match="no such recording"):
        open_recording(tmp_path / "nope.mcap")
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"time_s,force_N\n0,1\n")
    with pytest.raises(RecordingError, match="not an MCAP file"):
        open_recording(junk)


@settings(max_examples=25, deadline=None)
@given(
    sizes=st.lists(st.integers(1, 700), min_size=1, max_size=12),
    max_block=st.sampled_from([1, 7, 256, 1000]),
)
def test_any_blocking_reads_back_the_same_samples(sizes: list[int], max_block: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "h.mcap"
        with RecordingWriter(path, metadata={}, max_block_samples=max_block) as w:
            w.begin_test(meta(0, 0))
            s = 0
            for n in sizes:
                w.write_samples(block(s, n))
                s += n
            w.end_test(meta(0, 0))
        got = open_recording(path).samples(0)
    truth = block(0, sum(sizes))
    assert np.array_equal(got.seq, truth.seq)
    assert np.array_equal(got.force_n, truth.force_n)
    assert np.array_equal(got.temperature_c, truth.temperature_c)


def test_ctrl_c_inside_a_write_waits_until_the_record_is_whole(tmp_path: Path) -> None:
    path = tmp_path / "int.mcap"
    w = RecordingWriter(path, metadata={})
    w.begin_test(meta(0, 0))
    mcap_add = w._mcap.add_message

    def interrupted_add(*args: object, **kwargs: object) -> None:
        os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C arrives while the record is being built
        mcap_add(*args, **kwargs)  # type: ignore[arg-type]

    w._mcap.add_message = interrupted_add  # type: ignore[method-assign]
    # Ctrl-C as Python sets it up in a terminal: a shell's background job (no job
    # control) starts with SIGINT ignored, where there is nothing to test.
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            w.write_event(0.5, "prompt", "set clicks to 3")
    finally:
        signal.signal(signal.SIGINT, before)
    w._mcap.add_message = mcap_add  # type: ignore[method-assign]
    w.write_samples(block(0, 10))
    w.close()  # the open test is ended as aborted
    rec = open_recording(path)
    assert rec.events == [(0.5, "prompt", "set clicks to 3")]
    assert [m.status for m in rec.tests] == ["aborted"] and rec.load(0).t.size == 10


def test_typed_fields_are_read_from_an_older_recordings_extra(tmp_path: Path) -> None:
    """Before the typed fields, the abort reason, start temperature and a second dropped-
    frame count were strings in `extra`: such a recording reads into the typed fields."""
    path = tmp_path / "old.mcap"
    old = replace(
        meta(0, 0),
        status="aborted",
        dropped_frames=None,
        extra={"reason": "force limit", "start_temperature_c": "41.50", "dropped_frames": "3"},
    )
    with RecordingWriter(path, metadata={}) as w:
        w.begin_test(old)
        w.write_samples(block(0, 300))
        w.end_test(old)
    got = open_recording(path).tests[0]
    assert got.abort_reason == "force limit"
    assert got.start_temperature_c == 41.5
    assert got.dropped_frames == 3
    assert got.extra == {}
