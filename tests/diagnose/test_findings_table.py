"""The findings table reads one way on the terminal, on diagnose's page and in the report's
diagnosis section: all take their cells from the DIAG.json finding through
report/findings_table.finding_cells."""

from __future__ import annotations

import re
from html import unescape

from shockdyno.commands.diagnose import _summary
from shockdyno.report.diagnose_section import render_diagnose
from shockdyno.report.documents import DiagnosisDoc, Finding, typed
from shockdyno.report.findings_table import FINDING_COLUMNS, finding_cells, render_findings
from shockdyno.report.html import Page
from shockdyno.units import IMPERIAL, SI

ROWS = [
    {"round": 1, "physics": "compressibility", "claimed": True, "p_value": 0.0011,
     "heldout_gain": 0.37, "effect_peak_n": 44.48, "ambiguous_with": ["sensor_lag"],
     "why_not": "", "parameters": {"air_fraction": {"value": 0.02, "sd": 0.001, "unit": "1"}}},
    {"round": 1, "physics": "thermal", "claimed": False, "p_value": 0.41, "heldout_gain": None,
     "effect_peak_n": 4.448, "ambiguous_with": [],
     "why_not": "its own force peaks at 4.4 N, too small to matter",
     "parameters": {"breakaway_n": {"value": 44.48, "sd": None, "unit": "N", "fixed": True}}},
]  # fmt: skip
FINDINGS = tuple(typed(f, Finding, "finding") for f in ROWS)


def test_cells_in_si_and_imperial() -> None:
    si = [finding_cells(f, SI) for f in FINDINGS]
    assert len(si[0]) == len(FINDING_COLUMNS)
    assert si[0] == ("1", "compressibility", "yes", "0.0011", "0.37", "44.5",
                     "air_fraction = 0.02 ± 0.001 1", "sensor_lag", "")  # fmt: skip
    assert si[1][2:5] == ("", "0.41", "–")  # not scored held out
    imperial = [finding_cells(f, IMPERIAL) for f in FINDINGS]
    assert imperial[0][5] == "10"  # 44.48 N is 10.0 lbf
    assert imperial[1][6] == "breakaway_n = 10 ± – lbf"
    assert "lbf" in imperial[1][8] and "N" not in imperial[1][8].split()


def test_the_terminal_shows_the_same_cells() -> None:
    table = _summary(FINDINGS, SI)
    rows = list(zip(*(list(c.cells) for c in table.columns), strict=True))
    for row, f in zip(rows, FINDINGS, strict=True):
        rnd, physics, claimed, p, gain, peak, _, alike, why_not = finding_cells(f, SI)
        assert row[:2] == (rnd, physics) and row[3:6] == (p, gain, peak)
        assert ("yes" in row[2]) == bool(claimed)
        assert row[6] == (why_not or f"alike: {alike}")


def test_the_report_section_and_diagnose_page_show_the_same_cells() -> None:
    doc = typed(
        {"mismatch": {"significant": True, "p_value": 0.001, "noise_floor_n": 2.0,
                      "structured_share": 0.3, "where": []},
         "findings": ROWS, "verdict": {"text": "t", "physics": [], "unexplained": []},
         "tests": []},
        DiagnosisDoc, "sample",
    )  # fmt: skip
    for draw in (render_diagnose, lambda page, doc, u: render_findings(page, doc.findings, u)):
        page = Page("t")
        draw(page, doc, IMPERIAL)
        rows = re.findall(r"<tr[^>]*>(<td.*?)</tr>", page.render())
        cells = [tuple(unescape(c) for c in re.findall(r"<td[^>]*>(.*?)</td>", r)) for r in rows]
        assert cells == [finding_cells(f, IMPERIAL) for f in FINDINGS]
