"""A recording cut off mid-test (SIGKILL, power loss, damage) still yields every completed test."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from rec_helpers import (
    SAMPLES_PER_TEST,
    TESTS,
    block,
    chunk_offsets,
    meta,
    seq_range,
    write_small,
)

from shockdyno.cli import main
from shockdyno.record import RecordingWriter, open_recording

HERE = Path(__file__).parent

CHILD = textwrap.dedent(
    """
    import sys, time
    sys.path.insert(0, sys.argv[2])
    from rec_helpers import block, meta
    from shockdyno.record import RecordingWriter
    w = RecordingWriter(sys.argv[1], metadata={"damper_id": "K"}, rig_toml="x = 1\\n")
    for k in range(3):
        w.begin_test(meta(k, k))
        w.write_samples(block(k * 10000, 5000))
        w.end_test(meta(k, k))
    w.begin_test(meta(3, 3))
    s = 30000
    for _ in range(400):  # ~2.4 MB of samples: some chunks of the open test reach the disk
        w.write_samples(block(s, 150))
        s += 150
    print("mid-test", flush=True)
    time.sleep(60)
    """
)


def test_sigkill_mid_test_keeps_the_completed_tests(tmp_path: Path) -> None:
    path = tmp_path / "killed.mcap"
    with subprocess.Popen(
        [sys.executable, "-c", CHILD, str(path), str(HERE)], stdout=subprocess.PIPE, text=True
    ) as child:
        try:
            assert child.stdout is not None
            assert child.stdout.readline().strip() == "mid-test"
            os.kill(child.pid, signal.SIGKILL)
            child.wait(timeout=30)
        finally:
            if child.poll() is None:
                child.kill()
                child.wait()
    assert child.returncode == -signal.SIGKILL
    rec = open_recording(path)
    assert rec.truncated
    assert [m.clicks for m in rec.tests] == [0, 1, 2]
    assert rec.completed_keys() == {(k, 2, 1.0) for k in range(3)}
    assert rec.metadata["damper_id"] == "K" and rec.rig_toml == "x = 1\n"
    for k, data in enumerate(rec.load_all()):
        assert np.array_equal(data.force, block(k * 10000, 5000).force_n)
    # the open test's flushed chunks are there, marked as interrupted, never as complete
    assert [m.status for m in rec.interrupted] == ["interrupted"]
    partial = rec.samples(rec.interrupted[0])
    assert 0 < len(partial) < 400 * 150
    assert np.array_equal(partial.seq, np.arange(30000, 30000 + len(partial)))
    # resuming writes the rest into a part file; the set then has every test complete
    with RecordingWriter(path, metadata={"damper_id": "K"}, resume=True) as w:
        w.begin_test(meta(3, 3))
        w.write_samples(block(0, 700))
        w.end_test(meta(3, 3))
    rec = open_recording(path)
    assert [m.clicks for m in rec.tests] == [0, 1, 2, 3]
    assert rec.completed_keys() == {(k, 2, 1.0) for k in range(4)}
    assert rec.truncated and [p.truncated for p in rec.parts] == [True, False]


def test_info_reports_a_truncated_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "cut.mcap"
    write_small(path)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) * 2 // 3])
    assert main(["info", str(path), "--json", str(tmp_path / "info.json")]) == 0
    out = capsys.readouterr().out
    assert "TRUNCATED" in out
    doc = json.loads((tmp_path / "info.json").read_text())
    assert doc["truncated"] is True
    assert doc["totals"]["complete"] == len(rec_tests := open_recording(path).tests) >= 1
    assert [t["samples"] for t in doc["tests"]] == [SAMPLES_PER_TEST] * len(rec_tests)


def test_every_cut_point_reads_without_error_and_loses_at_most_the_open_test(
    tmp_path: Path,
) -> None:
    full = tmp_path / "full.mcap"
    write_small(full)
    data = full.read_bytes()
    cut = tmp_path / "cut.mcap"
    seen = []
    for end in np.linspace(0, len(data), 41).astype(int):
        cut.write_bytes(data[:end])
        rec = open_recording(cut)
        assert rec.truncated == (end < len(data))
        n = len(rec.tests)
        seen.append(n)
        for k, test in enumerate(rec.load_all()):
            lo, _ = seq_range(k)
            assert np.array_equal(test.x, block(lo, SAMPLES_PER_TEST).displacement_m)
    assert seen == sorted(seen)  # a longer file never yields fewer tests
    assert seen[-1] == len(TESTS) and seen[0] == 0


@pytest.mark.parametrize("damaged", [0, 1])  # chunk 0 also holds the channel definitions
def test_a_damaged_chunk_costs_only_that_chunk_and_its_test_reads_as_damaged(
    tmp_path: Path, damaged: int
) -> None:
    """Issue 46.5: a test whose samples were in the damaged chunk is not "complete with 0
    samples": it is `damaged`, left out of every analysis and named, and a resumed sweep
    runs it again."""
    path = tmp_path / "d.mcap"
    write_small(path)
    good = open_recording(path)
    data = bytearray(path.read_bytes())
    # Each test's samples fill one big chunk; its closing event and end record follow in
    # small chunks of their own (each event is synced as it is written).
    chunks = [c for c in chunk_offsets(bytes(data)) if c[1] > 10_000]
    assert len(chunks) == len(TESTS)
    off, length = chunks[damaged]
    data[off + length // 2] ^= 0xFF
    path.write_bytes(bytes(data))
    rec = open_recording(path)
    assert rec.parts[0].bad_chunks == 1
    assert not rec.parts[0].truncated  # the footer is intact
    assert [m.index for m in rec.tests] == [m.index for m in good.tests]
    assert [m.index for m in rec.damaged] == [damaged]
    hurt = rec.tests[damaged]
    assert hurt.status == "damaged" and hurt.extra["recorded_status"] == "complete"
    assert hurt.extra["damage"] == f"0 of its {SAMPLES_PER_TEST} samples read"
    note = rec.loss_note()
    assert note is not None and f"test {damaged}: 0 of its {SAMPLES_PER_TEST}" in note
    loaded = rec.load_all()
    assert [t.meta.index for t in loaded] == [m.index for m in good.tests if m.index != damaged]
    for test in loaded:
        lo, _ = seq_range(test.meta.index)
        assert np.array_equal(test.force, block(lo, SAMPLES_PER_TEST).force_n)
    _, clicks, freq = TESTS[damaged]
    assert (clicks, 2, freq) not in rec.completed_keys()  # --resume runs it again
    assert len(rec.completed_keys()) == len(TESTS) - 1


def test_a_partly_lost_test_and_an_undecodable_sample_message_read_as_damaged(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """32 bytes overwritten in the middle of a test (a chunk of its messages lost), and a
    sample message that cannot be decoded (its chunk's CRC is good): both tests are short
    of the samples they wrote, and say so."""
    from shockdyno.record import schemas

    encode = schemas.encode_samples
    calls = [0]

    def one_broken(test, part, velocity):  # type: ignore[no-untyped-def]
        calls[0] += 1
        data = encode(test, part, velocity)
        return data[:-1] if calls[0] == 55 else data  # in the third test

    monkeypatch.setattr(schemas, "encode_samples", one_broken)
    path = tmp_path / "d.mcap"
    with RecordingWriter(path, metadata={}, chunk_size=4096, max_block_samples=250) as w:
        for k in range(3):
            w.begin_test(meta(k, k))
            for i in range(20):
                w.write_samples(block(k * 10_000 + i * 250, 250))
            w.end_test(meta(k, k))
    data = bytearray(path.read_bytes())
    middle = [c for c in chunk_offsets(bytes(data)) if c[1] > 2000][5]
    data[middle[0] + middle[1] // 2 : middle[0] + middle[1] // 2 + 32] = b"\x55" * 32
    path.write_bytes(bytes(data))
    rec = open_recording(path)
    assert rec.parts[0].bad_chunks == 1 and rec.parts[0].bad_messages == 1
    assert [m.status for m in rec.tests] == ["damaged", "complete", "damaged"]
    lost = rec.tests[0].extra["damage"]
    assert lost.endswith("of its 5000 samples read") and not lost.startswith("0 ")
    assert rec.tests[2].extra["damage"] == "4750 of its 5000 samples read"
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "(1 complete, 0 aborted, 2 damaged)" in out
    assert out.count(" damaged ") == 2  # the status column, each test
