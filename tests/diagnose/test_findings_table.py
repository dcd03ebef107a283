"""The findings table reads one way on the terminal and on diagnose's page: both take their
cells from the DIAG.json finding through diagnose/verdict.finding_cells."""

from __future__ import annotations

from shockdyno.commands.diagnose import _summary
from shockdyno.diagnose.verdict import FINDING_COLUMNS, finding_cells
from shockdyno.units import IMPERIAL, SI

FINDINGS = [
    {"round": 1, "physics": "compressibility", "claimed": True, "p_value": 0.0011,
     "heldout_gain": 0.37, "effect_peak_n": 44.48, "ambiguous_with": ["sensor_lag"],
     "why_not": ""},
    {"round": 1, "physics": "thermal", "claimed": False, "p_value": 0.41, "heldout_gain": None,
     "effect_peak_n": 4.448, "ambiguous_with": [],
     "why_not": "its own force peaks at 4.4 N, too small to matter"},
]  # fmt: skip


def test_cells_in_si_and_imperial() -> None:
    si = [finding_cells(f, SI) for f in FINDINGS]
    assert len(si[0]) == len(FINDING_COLUMNS)
    assert si[0] == ("1", "compressibility", "yes", "0.0011", "0.37", "44.5", "sensor_lag", "")
    assert si[1][2:5] == ("", "0.41", "–")  # not scored held out
    imperial = [finding_cells(f, IMPERIAL) for f in FINDINGS]
    assert imperial[0][5] == "10"  # 44.48 N is 10.0 lbf
    assert "lbf" in imperial[1][7] and "N" not in imperial[1][7].split()


def test_the_terminal_shows_the_same_cells() -> None:
    table = _summary({"findings": FINDINGS}, SI)
    rows = list(zip(*(list(c.cells) for c in table.columns), strict=True))
    for row, f in zip(rows, FINDINGS, strict=True):
        rnd, physics, claimed, p, gain, peak, alike, why_not = finding_cells(f, SI)
        assert row[:2] == (rnd, physics) and row[3:6] == (p, gain, peak)
        assert ("yes" in row[2]) == bool(claimed)
        assert row[6] == (why_not or f"alike: {alike}")
