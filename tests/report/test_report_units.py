"""`report --units imperial`: every number and label of the page in in/s, lbf, in, °F; the
click chart at 1, 2, 3, 5, 10 in/s equal to the SI chart converted and to the damper
model where the sine passes those speeds; the CSV names its units; the interactive
plots' data inline, decimated, in the page's units."""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import numpy as np
import pytest
from test_clickchart import expected_branch
from test_report_build import parse

from report_helpers import AMPLITUDE_M
from shockdyno.record import open_recording
from shockdyno.record.types import TestData as Recorded  # aliased: pytest collects Test*
from shockdyno.report import summarise
from shockdyno.report.clickchart import click_chart
from shockdyno.report.gas import with_gas_force
from shockdyno.report.interactive import LOOP_POINTS
from shockdyno.units import IMPERIAL

LBF = 4.4482216152605  # N per lbf, written out: not taken from the code under test
INCH = 0.0254
IMPERIAL_SPEEDS_IN_S = (10, 5, 3, 2, 1)

# SI units as a page would print them; none may be left on the imperial page.
SI_LABELS = [
    r"mm/s",
    r"\(N[;)]",
    r"\d N\b",
    r"\bN\)",
    r"\(mm[,;)]",
    r"\d mm\b",
    r"°C",
    r"(?<!√)\(m/s[,)]",  # √(m/s): the unit of the paper's E_x, not a display quantity
]


def visible_text(index: Path) -> str:
    """The page's text as a reader sees it: no script, style or tags."""
    html = index.read_text(encoding="utf-8")
    html = re.sub(r"<(script|style)\b.*?</\1>", " ", html, flags=re.S)
    return re.sub(r"<[^>]+>", " ", html)


@pytest.fixture(scope="module")
def tests_of(recording: Path) -> list[Recorded]:
    return open_recording(recording).load_all()


def _table(index: Path, first_header: str, contains: str) -> list[list[str]]:
    page = parse(index)
    for table in page.tables:
        header = table[0][1]
        if header[0] == first_header and contains in header:
            return [header] + [cells for _, cells in table[1:]]
    raise AssertionError(f"no table with {contains!r}")


def test_imperial_page_shows_in_s_and_lbf_and_no_si_label(imperial_report: Path) -> None:
    text = visible_text(imperial_report)
    for label in ("in/s", "lbf", "(in)", "°F", "Measured (lbf; velocity in in/s)"):
        assert label in text, label
    left = {p: re.findall(r".{30}" + p + r".{10}", text) for p in SI_LABELS}
    assert {p: hits for p, hits in left.items() if hits} == {}
    # The interactive plots' axis labels are page text too (checked in a browser in
    # test_report_units_browser.py): imperial, and no SI one among them.
    assert "velocity v (in/s, + compression)" in text and "force F (lbf)" in text
    assert "displacement x (in, + compression)" in text


def test_imperial_click_chart_is_the_si_chart_converted(
    imperial_report: Path, tests_of: list[Recorded]
) -> None:
    rows = _table(imperial_report, "clicks", "comp 1")
    header = rows[0]
    assert header == ["clicks"] + [f"reb {v}" for v in IMPERIAL_SPEEDS_IN_S] + [
        f"comp {v}" for v in reversed(IMPERIAL_SPEEDS_IN_S)
    ]
    speeds_m_s = tuple(v * INCH for v in (1, 2, 3, 5, 10))
    si = click_chart(tests_of, None, speeds_m_s)  # in N, at the imperial speeds
    # damping force: each test's gas force (estimated from its reversals) removed
    gas_n = {
        (t.meta.clicks, t.meta.gas_clicks): t.meta.gas_force_n for t in with_gas_force(tests_of)
    }
    seen = 0
    for cells in rows[1:]:
        clicks = int(cells[0])
        for name, cell in zip(header[1:], cells[1:], strict=True):
            word, speed = name.split()
            v = (1.0 if word == "comp" else -1.0) * float(speed) * INCH
            target = min(si.velocities_m_s, key=lambda t: abs(t - v))
            reading = si.measured[(clicks, 0)][target]
            shown = float(cell.rstrip("*"))
            assert cell.endswith("*") == reading.extrapolated, (clicks, name)
            assert shown == pytest.approx(reading.force_n / LBF, abs=0.51), (clicks, name)
            # Physics: where the sine passes v, the damper model's force (N -> lbf).
            reached = [f for f in (1.0, 1.5) if abs(v) < AMPLITUDE_M * 2 * np.pi * f]
            if reached:
                model_n = np.mean([expected_branch(clicks, f, v) for f in reached])
                want = (model_n - (gas_n[(clicks, 0)] or 0.0)) / LBF
                assert shown == pytest.approx(want, rel=0.01, abs=1.0), (clicks, name)
                seen += 1
    assert seen >= 20  # most of the 3 x 10 cells are measured, not extrapolated


def test_imperial_csv_says_its_units(imperial_report: Path, tests_of: list[Recorded]) -> None:
    with (imperial_report.parent / "click_chart.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == [
        "clicks",
        "gas_clicks",
        "velocity_in_s",
        "source",
        "force_lbf",
        "extrapolated",
        "n_tests",
        "gas_removed",
        "gas_force_lbf",
    ]
    assert sorted({float(r["velocity_in_s"]) for r in rows}) == [
        -10,
        -5,
        -3,
        -2,
        -1,
        1,
        2,
        3,
        5,
        10,
    ]
    si = click_chart(tests_of, None, tuple(v * INCH for v in (1, 2, 3, 5, 10)))
    for r in rows:
        if r["source"] != "measured":
            continue
        v = float(r["velocity_in_s"]) * INCH
        target = min(si.velocities_m_s, key=lambda t: abs(t - v))
        force_n = si.measured[(int(r["clicks"]), 0)][target].force_n
        assert float(r["force_lbf"]) == pytest.approx(force_n / LBF, abs=0.006)


def test_imperial_summary_is_converted(imperial_report: Path, tests_of: list[Recorded]) -> None:
    rows = _table(imperial_report, "test", "F comp (lbf)")
    header = rows[0]
    assert header[4:10] == [
        "A (in)",
        "F comp (lbf)",
        "F reb (lbf)",
        "v comp (in/s)",
        "v reb (in/s)",
        "T (°F)",
    ]
    by_index = {int(cells[0]): dict(zip(header, cells, strict=True)) for cells in rows[1:]}
    for test in with_gas_force(tests_of):  # the page's peaks are damping force
        s = summarise(test, gas_force_n=test.meta.gas_force_n)
        row = by_index[test.meta.index]
        assert float(row["A (in)"]) == pytest.approx(AMPLITUDE_M / INCH, abs=0.006)
        assert float(row["F comp (lbf)"]) == pytest.approx(
            s.peak_compression_force_n / LBF, abs=0.06
        )
        assert float(row["v reb (in/s)"]) == pytest.approx(
            s.peak_rebound_velocity_m_s / INCH, abs=6e-4
        )
        assert s.temperature_c is not None
        assert float(row["T (°F)"]) == pytest.approx(s.temperature_c * 1.8 + 32, abs=0.06)


def test_interactive_data_is_inline_decimated_and_in_page_units(imperial_report: Path) -> None:
    html = imperial_report.read_text(encoding="utf-8")
    assert html.count("var uPlot=function()") == 1  # the library once, however many plots
    assert not re.search(r"""(src|href)=["']?[a-z]+://""", html)  # nothing fetched
    raw = re.search(r'<script type="application/json" id="sd-data">(.*?)</script>', html, re.S)
    assert raw is not None
    data = json.loads(raw.group(1))
    loops = data["loops"]
    assert len(loops) == 6  # 3 clicks x 2 frequencies, each stored once
    for loop in loops.values():
        assert len(loop["x"]) == len(loop["v"]) == len(loop["f"]) <= LOOP_POINTS + 1
        # One 30 mm sine cycle in inches: ±1.18 in, peak velocity Aω in in/s.
        assert max(abs(x) for x in loop["x"]) == pytest.approx(AMPLITUDE_M / INCH, rel=0.01)
    peak_v = max(max(abs(v) for v in loop["v"]) for loop in loops.values())
    assert peak_v == pytest.approx(AMPLITUDE_M * 2 * np.pi * 1.5 / INCH, rel=0.01)
    labels = {s["label"] for chart in data["charts"] for s in chart["series"]}
    assert {"click 0", "click 10", "click 21"} <= labels  # overlays name their clicks
    assert {"1 in/s", "10 in/s"} <= labels and "static gas force" in labels
    units = {(c["x_unit"], c["y_unit"]) for c in data["charts"]}
    assert units <= {("in", "lbf"), ("in/s", "lbf"), ("", "lbf")}
    assert IMPERIAL.force_label == "lbf"
    # The interactive click chart and peak plot show damping force (gas removed, as their
    # PNGs) and read out each value's cycle-to-cycle band on hover, in lbf.
    assert '<div class="sd-ylab">damping force (lbf, gas removed)</div>' in html
    assert '<div class="sd-ylab">peak damping force (lbf, gas removed)</div>' in html
    notes = [n for c in data["charts"] for s in c["series"] for n in s.get("notes") or []]
    spreads = [float(m) for n in notes for m in re.findall(r"±([0-9.]+) lbf \(2 SD, cycles\)", n)]
    assert len(spreads) >= 20 and all(0 <= s < 50 for s in spreads)


def test_si_page_keeps_si(full_report: Path) -> None:
    text = visible_text(full_report)
    assert "Measured (N; velocity in mm/s)" in text and "comp 25" in text
    assert "in/s" not in text and "lbf" not in text


def test_fit_report_takes_units(tmp_path: Path) -> None:
    from shockdyno.cli import main

    example = Path(__file__).parents[2] / "recordings" / "examples" / "example.mcap"
    out = tmp_path / "report"
    args = ["fit", str(example), "--json", str(tmp_path / "fit.json"), "--report", str(out)]
    assert main([*args, "--units", "imperial"]) == 0
    text = visible_text(out / "index.html")
    assert "Measured (lbf; velocity in in/s)" in text and "mm/s" not in text
    # The JSON stays SI: the same fit as without --units (timings aside).
    assert main(["fit", str(example), "--json", str(tmp_path / "si.json")]) == 0
    imperial, si = (json.loads((tmp_path / n).read_text()) for n in ("fit.json", "si.json"))
    assert imperial["clicks"] == si["clicks"] and imperial["globals"] == si["globals"]
