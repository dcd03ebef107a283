"""A test record of a damper with several adjusters carries every adjuster's clicks; one of
the one rod adjuster is written as it always was (no new key), and reads back alike."""

from __future__ import annotations

import pytest

from shockdyno.errors import RecordingError
from shockdyno.record import adjusters
from shockdyno.record.schemas import meta_from_json, meta_to_json
from shockdyno.record.types import TestData, TestMeta

ONE = TestMeta(index=0, clicks=7, gas_clicks=0, frequency_hz=1.0, amplitude_m=0.03,
               sample_rate_hz=1000.0)  # fmt: skip


def test_a_one_adjuster_record_has_no_new_key_and_reads_back_the_same() -> None:
    d = meta_to_json(ONE)
    assert "adjusters" not in d
    back = meta_from_json(d)
    assert back == ONE and back.setting == ()


def test_every_adjuster_round_trips_and_a_bad_one_is_a_recording_error() -> None:
    two = TestMeta(**{**meta_to_json(ONE), "adjusters": {"compression": 7, "rebound": 3}})
    d = meta_to_json(two)
    assert d["adjusters"] == {"compression": 7, "rebound": 3}
    assert meta_from_json(d).setting == (("compression", 7), ("rebound", 3))
    for bad in ({"compression": -1}, {"compression": "7"}, [7, 3], {"rebound": True}):
        with pytest.raises(RecordingError, match="adjusters must map names to clicks"):
            meta_from_json({**d, "adjusters": bad})


def test_lines_hold_the_other_adjusters_at_their_most_frequent_setting() -> None:
    import numpy as np

    def test(c: int, r: int) -> TestData:
        meta = TestMeta(**{**meta_to_json(ONE), "adjusters": {"compression": c, "rebound": r}})
        return TestData(meta, np.zeros(1), np.zeros(1), np.zeros(1))

    tests = [test(c, r) for c, r in ((10, 10), (0, 10), (20, 10), (10, 0), (10, 20))]
    lines = adjusters.lines(tests)
    assert [t.meta.clicks for t in lines["compression"]] == [10, 0, 20]
    assert [t.meta.clicks for t in lines["rebound"]] == [10, 0, 20]
    assert adjusters.held("rebound", {"compression": 10, "rebound": 10}) == "compression at 10"
    assert adjusters.lines([test(1, 1)][:0]) == {}


def test_the_csv_exchange_carries_every_adjuster(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from dataclasses import replace

    from report_helpers import make_test, write_recording
    from shockdyno.cli import main
    from shockdyno.record import open_recording

    tests = [
        replace(t, meta=replace(t.meta, adjusters={"compression": c, "rebound": r}))
        for t, (c, r) in zip(
            (make_test(0, 4, 1.0, cycles=1), make_test(1, 10, 1.0, cycles=1)),
            ((4, 10), (10, 0)),
            strict=True,
        )
    ]
    rec = write_recording(tmp_path / "two.mcap", tests, {"damper_id": "two"})
    out = tmp_path / "csv"
    assert main(["export", str(rec), "--csv", str(out)]) == 0
    header = (out / "manifest.csv").read_text().splitlines()[0].split(",")
    assert header[-2:] == ["clicks_compression", "clicks_rebound"]
    back = tmp_path / "back.mcap"
    assert main(["import", str(out / "manifest.csv"), "-o", str(back)]) == 0
    got = [m.adjusters for m in open_recording(back).tests]
    assert got == [{"compression": 4, "rebound": 10}, {"compression": 10, "rebound": 0}]
    # a recording of one rod adjuster exports no such column
    one = write_recording(tmp_path / "one.mcap", [make_test(0, 4, 1.0, cycles=1)], {})
    assert main(["export", str(one), "--csv", str(tmp_path / "one")]) == 0
    assert "clicks_" not in (tmp_path / "one" / "manifest.csv").read_text().splitlines()[0]
