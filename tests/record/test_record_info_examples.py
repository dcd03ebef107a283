"""`shockdyno info` and the example files shipped in recordings/examples/."""

from __future__ import annotations

import itertools
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from rec_helpers import block, meta

from shockdyno import progress as progress_module
from shockdyno.cli import main
from shockdyno.record import RecordingWriter, open_recording

EXAMPLES = Path(__file__).resolve().parents[2] / "recordings" / "examples"
FIXTURES = Path(__file__).resolve().parent / "fixtures"


def test_info_json_of_a_resumed_set_with_faults(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "s.mcap"
    with RecordingWriter(path, metadata={"damper_id": "D7", "operator": "li"}) as w:
        w.begin_test(meta(0, 0))
        w.write_samples(block(0, 2001, drop=(5, 6)))
        w.end_test(replace(meta(0, 0), corrupt_frames=3))
        w.begin_test(meta(1, 1))
        w.write_samples(block(3000, 500))
        w.write_event(3.4, "fault", "drive fault 0x21")
        w.end_test(replace(meta(1, 1), status="aborted"))
    with RecordingWriter(path, metadata={"damper_id": "D7"}, resume=True) as w:
        w.begin_test(meta(1, 1))
        w.write_samples(block(0, 1000))
        w.end_test(meta(1, 1))
    out = tmp_path / "info.json"
    assert main(["info", str(path), "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "fault: drive fault 0x21" in text and "aborted" in text
    doc = json.loads(out.read_text())
    assert doc["truncated"] is False and len(doc["files"]) == 2
    assert doc["metadata"]["operator"] == "li"
    assert doc["totals"] == {
        "tests": 3,
        "complete": 2,
        "aborted": 1,
        "damaged": 0,
        "interrupted": 0,
        "samples": 1999 + 500 + 1000,
        "duration_s": pytest.approx(2.0 + 0.499 + 0.999),
        "dropped_frames": 2,
        "corrupt_frames": 3,
    }
    assert [t["status"] for t in doc["tests"]] == ["complete", "aborted", "complete"]
    assert doc["event_counts"] == {"fault": 1}
    assert main(["info", str(path), "--json", "-"]) == 0
    assert json.loads(capsys.readouterr().out)["totals"]["tests"] == 3


def test_info_on_a_missing_file_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info", "/nonexistent/x.mcap"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no such recording" in err


def test_shipped_example_reimports_and_exports_byte_for_byte(tmp_path: Path) -> None:
    shipped = open_recording(EXAMPLES / "example.mcap")
    fresh = tmp_path / "example.mcap"
    assert main(["import", str(EXAMPLES / "csv" / "manifest.csv"), "-o", str(fresh)]) == 0
    again = open_recording(fresh)
    assert [m.clicks for m in shipped.tests] == [m.clicks for m in again.tests] == [0, 21]
    for a, b in zip(shipped.load_all(), again.load_all(), strict=True):
        assert np.array_equal(a.force, b.force) and np.array_equal(a.t, b.t)
    assert main(["export", str(EXAMPLES / "example.mcap"), "--csv", str(tmp_path / "out")]) == 0
    for name in ("s46_c00_1hz.csv", "s46_c21_1hz.csv"):
        assert (tmp_path / "out" / name).read_bytes() == (EXAMPLES / "csv" / name).read_bytes()


def test_format_1_recordings_read_as_before(tmp_path: Path) -> None:
    """The fixture is example.mcap as shockdyno 0.1.0 wrote it (SampleBlock without velocity,
    DAQ time as log_time): it reads to the same tests, samples and metadata as a fresh import."""
    old = open_recording(FIXTURES / "format1_example.mcap")
    assert old.metadata["format_version"] == "1"
    assert old.parts[0].wall_clock_origin_ns is None and not old.truncated
    assert old.parts[0].bad_messages == 0
    fresh = tmp_path / "example.mcap"
    assert main(["import", str(EXAMPLES / "csv" / "manifest.csv"), "-o", str(fresh)]) == 0
    new = open_recording(fresh)
    assert new.metadata["format_version"] == "2"
    assert new.parts[0].wall_clock_origin_ns is not None
    assert old.tests == new.tests
    for i in range(len(new.tests)):
        a, b = old.samples(i), new.samples(i)
        for name in ("seq", "t_s", "displacement_m", "force_n", "temperature_c", "status"):
            assert np.array_equal(getattr(a, name), getattr(b, name)), name


def test_import_reports_progress_per_file_and_test_in_plain_lines(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    # As if the files were large: plain lines start after 2 s; each look at the clock is 3 s on
    ticks = itertools.count()
    monkeypatch.setattr(progress_module, "monotonic", lambda: 3.0 * next(ticks))
    out = tmp_path / "example.mcap"
    assert main(["import", str(EXAMPLES / "csv" / "manifest.csv"), "-o", str(out)]) == 0
    captured = capsys.readouterr()
    assert captured.err.splitlines() == [
        "import: read s46_c00_1hz.csv",
        "import: read s46_c21_1hz.csv",
        "import: write test 1/2",
        "import: write test 2/2",
    ]
    assert "import:" not in captured.out and "\x1b[" not in captured.err


def test_a_quick_import_prints_only_its_result(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "example.mcap"
    assert main(["import", str(EXAMPLES / "csv" / "manifest.csv"), "-o", str(out)]) == 0
    assert capsys.readouterr().err == ""
