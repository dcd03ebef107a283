"""The HTML report: links resolve to real PNGs, the table shows the right numbers."""

from __future__ import annotations

import struct
import zlib
from dataclasses import replace
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from report_helpers import AMPLITUDE_M, make_test, spec, temperature_at
from shockdyno.errors import ConfigError
from shockdyno.record.types import TestData as Recorded  # aliased: pytest collects Test*
from shockdyno.report import build_report, summarise
from shockdyno.report.clickchart import spec_static_force_n
from shockdyno.report.gas import with_gas_force
from shockdyno.report.html import SUMMARY_HEADER

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


class _Page(HTMLParser):
    """Collects links, images and tables (cells as text) of a page."""

    def __init__(self) -> None:
        super().__init__()
        self.links: list[str] = []
        self.images: list[str] = []
        self.tables: list[list[tuple[str, list[str]]]] = []  # rows as (class, cells)
        self.headings: list[str] = []
        self.ids: set[str] = set()
        self._cell: list[str] | None = None
        self._row: tuple[str, list[str]] | None = None
        self._heading: list[str] | None = None

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if a.get("id"):
            self.ids.add(str(a["id"]))
        if tag == "a" and a.get("href"):
            self.links.append(str(a["href"]))
        elif tag == "img":
            self.images.append(str(a["src"]))
        elif tag == "table":
            self.tables.append([])
        elif tag == "tr":
            self._row = (a.get("class") or "", [])
        elif tag in ("td", "th"):
            self._cell = []
        elif tag in ("h2", "h3"):
            self._heading = []

    def handle_endtag(self, tag: str) -> None:
        if tag in ("td", "th") and self._cell is not None and self._row is not None:
            self._row[1].append("".join(self._cell))
            self._cell = None
        elif tag == "tr" and self._row is not None:
            self.tables[-1].append(self._row)
            self._row = None
        elif tag in ("h2", "h3") and self._heading is not None:
            self.headings.append("".join(self._heading))
            self._heading = None

    def handle_data(self, data: str) -> None:
        if self._cell is not None:
            self._cell.append(data)
        if self._heading is not None:
            self._heading.append(data)


def parse(index: Path) -> _Page:
    page = _Page()
    page.feed(index.read_text(encoding="utf-8"))
    return page


def png_size(path: Path) -> tuple[int, int]:
    """Width and height from a PNG's IHDR chunk, checking its CRC."""
    raw = path.read_bytes()
    assert raw[:8] == PNG_SIGNATURE, path
    length, kind = struct.unpack(">I4s", raw[8:16])
    assert kind == b"IHDR" and length == 13
    body = raw[16:29]
    assert struct.unpack(">I", raw[29:33])[0] == zlib.crc32(kind + body)
    assert raw.endswith(b"IEND\xaeB`\x82"), f"{path} is cut short"
    width, height = struct.unpack(">II", body[:8])
    return width, height


def summary_table(page: _Page) -> list[tuple[str, dict[str, str]]]:
    for table in page.tables:
        header = table[0][1]
        if header == SUMMARY_HEADER:
            return [(cls, dict(zip(header, cells, strict=True))) for cls, cells in table[1:]]
    raise AssertionError("no summary table")


@pytest.fixture(scope="module")
def sweep() -> list[Recorded]:
    tests = []
    for clicks in (0, 10, 21):
        for f in (1.0, 1.5):
            tests.append(make_test(len(tests), clicks, f))
    # Stopped by a safety event after half a cycle of its measured window:
    cut = make_test(len(tests), 21, 0.5, status="aborted")
    keep = cut.t < 3.0
    tests.append(
        replace(
            cut,
            t=cut.t[keep],
            x=cut.x[keep],
            force=cut.force[keep],
            temperature=None if cut.temperature is None else cut.temperature[keep],
        )
    )
    return tests


@pytest.fixture(scope="module")
def report(sweep: list[Recorded], tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("report") / "out"
    return build_report(sweep, out, title="S46 sweep <test>", metadata={"damper": "s46 #2"})


def test_every_link_resolves_to_a_valid_png_inside_the_report(report: Path) -> None:
    page = parse(report)
    out = report.parent
    assert page.images, "no figures"
    anchors = {link for link in page.links if link.startswith("#")}
    assert anchors and {a[1:] for a in anchors} <= page.ids
    assert set(page.links) - anchors == set(page.images) | {"click_chart.csv"}
    for src in page.images:
        path = (out / src).resolve()
        assert path.is_relative_to(out.resolve()), src
        width, height = png_size(path)
        assert 300 <= width <= 2000 and 300 <= height <= 2000, (src, width, height)
    names = {Path(s).name for s in page.images}
    # One loop figure per click setting, one overlay per frequency of complete tests, peaks:
    assert names == {
        "click_chart.png",
        "peaks.png",
        "overlay_1Hz.png",
        "overlay_1.5Hz.png",
        "loops_c00_g00.png",
        "loops_c10_g00.png",
        "loops_c21_g00.png",
    }
    # Nothing but the report's own files in the directory:
    assert {p.name for p in out.iterdir()} == names | {"index.html", "click_chart.csv"}
    assert "<title>S46 sweep &lt;test&gt;</title>" in report.read_text(encoding="utf-8")


def test_table_shows_peaks_computed_independently(report: Path, sweep: list[Recorded]) -> None:
    rows = summary_table(parse(report))
    assert len(rows) == len(sweep)
    for (cls, row), test in zip(rows, sweep, strict=True):
        meta = test.meta
        assert row["clicks"] == str(meta.clicks)
        assert float(row["f (Hz)"]) == pytest.approx(meta.frequency_hz)
        assert float(row["A (mm)"]) == pytest.approx(AMPLITUDE_M * 1e3)
        assert meta.measured_start_s is not None and meta.measured_end_s is not None
        window = (test.t >= meta.measured_start_s) & (test.t <= meta.measured_end_s)
        f = test.force[window]
        # Damping force: the gas force at mid-stroke removed, estimated from the reversals
        # (the recording has none measured). The isothermal gas spring's convexity puts the
        # mean of the two ends 1.3 N above its mid-stroke value at 30 mm.
        gas = spec_static_force_n(spec())
        assert float(row["F comp (N)"]) == pytest.approx(f.max() - gas, abs=2.0)
        assert float(row["F reb (N)"]) == pytest.approx(f.min() - gas, abs=2.0)
        assert f.max() > 300 and f.min() < -300  # a damper, not zeros
        t_mid = test.t[window].mean()
        assert float(row["T (°C)"]) == pytest.approx(temperature_at(t_mid), abs=0.051)
        assert row["dropped"] == "0"
        if meta.status == "complete":
            # Sine of amplitude A: peak velocity ±Aω exactly; the derivative filter is
            # within 0.1 % of it.
            v_peak = AMPLITUDE_M * 2 * np.pi * meta.frequency_hz
            vc = float(row["v comp (m/s)"])
            vr = float(row["v reb (m/s)"])
            assert vc == pytest.approx(v_peak, rel=2e-3)
            assert vr == pytest.approx(-v_peak, rel=2e-3)
            assert cls == "" and row["status"] == "complete"
        else:
            assert cls == "aborted" and row["status"] == "aborted"


def test_aborted_test_is_marked_in_its_figure_and_kept_out_of_the_overlays(
    report: Path,
) -> None:
    text = report.read_text(encoding="utf-8")
    assert "1 of 7 tests did not complete" in text
    page = parse(report)
    assert not any(name.startswith("overlay_0.5Hz") for name in page.images)
    assert "loops_c21_g00.png" in page.images


def test_table_values_are_those_of_summarise(report: Path, sweep: list[Recorded]) -> None:
    rows = summary_table(parse(report))
    for (_, row), test in zip(rows, with_gas_force(sweep), strict=True):
        assert test.meta.gas_force_source == "estimated"
        s = summarise(test, gas_force_n=test.meta.gas_force_n)
        assert float(row["F comp (N)"]) == pytest.approx(s.peak_compression_force_n, abs=0.051)
        assert float(row["v reb (m/s)"]) == pytest.approx(s.peak_rebound_velocity_m_s, abs=5.1e-5)
        assert int(row["samples"]) == s.n_samples


def test_extra_sections_and_tables(tmp_path: Path, report: Path) -> None:
    outside = tmp_path / "fit"
    outside.mkdir()
    fig_outside = outside / "trend.png"
    fig_outside.write_bytes((report.parent / "peaks.png").read_bytes())
    out = tmp_path / "rep"
    out.mkdir()
    fig_inside = out / "fit_overlay.png"
    fig_inside.write_bytes((report.parent / "overlay_1Hz.png").read_bytes())
    index = build_report(
        [make_test(0, 5, 1.0)],
        out,
        title="with fit",
        extra_sections=[("Fit", [("bleed trend", fig_outside), ("overlay", fig_inside)])],
        tables=[("Table 4 analogue", ["f (Hz)", "E_t <proposed>"], [["0.5", "0.031"]])],
    )
    page = parse(index)
    assert "Fit" in page.headings and "Table 4 analogue" in page.headings
    assert "fit_overlay.png" in page.images  # inside: linked where it is
    copied = [s for s in page.images if s.startswith("extra/")]
    assert len(copied) == 1  # outside: copied in, so the report stays self-contained
    assert (out / copied[0]).read_bytes() == fig_outside.read_bytes()
    extra = next(t for t in page.tables if t[0][1] == ["f (Hz)", "E_t <proposed>"])
    assert extra[1][1] == ["0.5", "0.031"]
    assert sorted(p.name for p in outside.iterdir()) == ["trend.png"]

    with pytest.raises(ConfigError, match=r"missing\.png"):
        build_report([], out, title="x", extra_sections=[("Fit", [("a", outside / "missing.png")])])


def test_rerun_overwrites_only_its_own_files(tmp_path: Path) -> None:
    out = tmp_path / "rep"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    tests = [make_test(0, 7, 1.5)]  # a single click: the colour scale must still work
    first = build_report(tests, out, title="one")
    files = sorted(p.name for p in out.iterdir())
    again = build_report(tests, out, title="two")
    assert first == again
    assert sorted(p.name for p in out.iterdir()) == files
    assert (out / "notes.txt").read_text() == "mine"
    assert "<h1>two</h1>" in again.read_text(encoding="utf-8")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]


def test_no_tests_gives_a_page_and_a_file_as_out_dir_is_refused(tmp_path: Path) -> None:
    index = build_report([], tmp_path / "empty", title="nothing yet")
    assert parse(index).images == []
    # A test stopped before its first sample: a row of dashes, no figure.
    test = make_test(0, 4, 1.5)
    stopped = replace(
        test,
        meta=replace(test.meta, status="aborted"),
        t=test.t[:0],
        x=test.x[:0],
        force=test.force[:0],
        temperature=None,
    )
    page = parse(build_report([stopped], tmp_path / "stopped", title="x"))
    assert page.images == []
    ((cls, row),) = summary_table(page)
    assert cls == "aborted" and row["samples"] == "0"
    assert row["F comp (N)"] == row["T (°C)"] == "–"
    (tmp_path / "afile").write_text("")
    with pytest.raises(ConfigError, match="afile"):
        build_report([], tmp_path / "afile", title="x")


def test_dropped_frames_counted_from_gaps_and_velocity_still_right() -> None:
    test = make_test(0, 3, 1.5)
    keep = np.ones(test.t.size, bool)
    keep[1200:1207] = False  # 7 frames lost inside the measured window
    keep[1500] = False
    gappy = replace(test, t=test.t[keep], x=test.x[keep], force=test.force[keep], temperature=None)
    s = summarise(gappy)
    assert s.dropped_frames == 8
    assert s.temperature_c is None
    v_peak = AMPLITUDE_M * 2 * np.pi * 1.5
    assert s.peak_compression_velocity_m_s == pytest.approx(v_peak, rel=2e-3)
    assert s.peak_rebound_velocity_m_s == pytest.approx(-v_peak, rel=2e-3)
    # The largest count known wins: a count stored with the recording over the gaps ...
    stored = replace(gappy, meta=replace(gappy.meta, dropped_frames=11))
    assert summarise(stored).dropped_frames == 11
    # ... and the gaps win over a stored count that missed some:
    low = replace(gappy, meta=replace(gappy.meta, dropped_frames=2))
    assert summarise(low).dropped_frames == 8
