"""The diagnosis in the page's units (issue 20): `report --diagnose DIAG.json --units
imperial` shows the section's forces, lengths, speeds and temperatures in lbf, in, in/s, °F,
each the SI page's number converted, and the verdict in the words diagnose wrote for
imperial; an older DIAG.json without them shows its SI words and says so. `diagnose --report
DIR --units imperial` draws its own page in the same units."""

from __future__ import annotations

import copy
import html
import json
import re
from pathlib import Path

import pytest
from test_report_build import parse
from test_report_units import LBF, SI_LABELS, visible_text

from report_helpers import DIAGNOSE_SAMPLE
from shockdyno.cli import main
from shockdyno.report.build import build_report
from shockdyno.units import IMPERIAL, SI

INCH = 0.0254
NUMBER = r"(-?\d+(?:\.\d+)?(?:e[-+]?\d+)?)"


@pytest.fixture(scope="module")
def diagnosed(recording: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A real DIAG.json of the simulated sweep, written by `diagnose --units imperial`
    (which changes the terminal and the --report page, not the JSON)."""
    d = tmp_path_factory.mktemp("diag-units")
    args = ["diagnose", str(recording), "--terms", "friction", "--json", str(d / "diag.json")]
    assert main([*args, "--report", str(d / "page"), "--units", "imperial"]) == 0
    return d / "diag.json"


@pytest.fixture(scope="module")
def pages(
    recording: Path, diagnosed: Path, tmp_path_factory: pytest.TempPathFactory
) -> dict[str, Path]:
    """The combined report of the sweep with that diagnosis, in SI and in imperial."""
    out = {}
    for name in ("si", "imperial"):
        d = tmp_path_factory.mktemp(f"report-{name}") / "report"
        args = ["report", str(recording), "--diagnose", str(diagnosed), "-o", str(d)]
        assert main([*args, "--units", name]) == 0
        out[name] = d / "index.html"
    return out


def _section(index: Path) -> str:
    """The diagnosis section's visible text: from its heading to the next one."""
    page = index.read_text(encoding="utf-8")
    start = page.index(">Diagnosis</h2>")
    end = page.find("<h2", start)
    part = re.sub(
        r"<(script|style)\b.*?</\1>", " ", page[start : end if end > 0 else None], flags=re.S
    )
    return html.unescape(re.sub(r"<[^>]+>", " ", part))


def _si_left(text: str) -> dict[str, list[str]]:
    hits = {p: re.findall(r".{0,30}" + p + r".{0,10}", text) for p in SI_LABELS}
    return {p: h for p, h in hits.items() if h}


def _range(cell: str, unit: str) -> tuple[float, float]:
    m = re.fullmatch(f"{NUMBER} to {NUMBER} {re.escape(unit)}", cell)
    assert m, (cell, unit)
    return float(m.group(1)), float(m.group(2))


def _where(index: Path) -> list[list[str]]:
    table = next(t for t in parse(index).tables if t[0][1][0] == "stroke")
    return [cells for _, cells in table[1:]]


def test_imperial_section_has_no_si_label_and_the_imperial_verdict(
    pages: dict[str, Path], diagnosed: Path
) -> None:
    verdict = json.loads(diagnosed.read_text())["verdict"]
    assert verdict["text"] != verdict["text_imperial"]
    imperial, si = _section(pages["imperial"]), _section(pages["si"])
    assert verdict["text_imperial"] in imperial and verdict["text"] not in imperial
    assert verdict["text"] in si and verdict["text_imperial"] not in si
    assert "lbf" in imperial and " in," in imperial and "in/s" in imperial
    assert _si_left(imperial) == {}
    assert "predates the imperial text" not in imperial
    # The figures are copied as drawn (by diagnose --units imperial): the SI page says so.
    assert json.loads(diagnosed.read_text())["info"]["figures_units"] == "imperial"
    assert "drawn in in, in/s, lbf, as diagnose --units imperial drew them" in si
    assert "are drawn in" not in imperial
    # The section is not the only thing that could be empty of SI: the SI page has them.
    assert _si_left(si)


def test_imperial_numbers_are_the_si_page_converted(
    pages: dict[str, Path], diagnosed: Path
) -> None:
    doc = json.loads(diagnosed.read_text())
    imperial, si = _section(pages["imperial"]), _section(pages["si"])
    floor_lbf = float(re.search(f"noise floor {NUMBER} lbf", imperial).group(1))  # type: ignore[union-attr]
    floor_n = float(re.search(f"noise floor {NUMBER} N", si).group(1))  # type: ignore[union-attr]
    assert floor_n == pytest.approx(doc["mismatch"]["noise_floor_n"], rel=5e-3)
    assert floor_lbf == pytest.approx(floor_n / LBF, rel=5e-3)
    rows_imp, rows_si = _where(pages["imperial"]), _where(pages["si"])
    assert len(rows_imp) == len(rows_si) == len(doc["mismatch"]["where"]) > 0
    for imp, s, region in zip(rows_imp, rows_si, doc["mismatch"]["where"], strict=True):
        assert imp[0] == s[0] == region["stroke"]
        x_in, x_mm = _range(imp[1], "in"), _range(s[1], "mm")
        v_in_s, v_m_s = _range(imp[2], "in/s"), _range(s[2], "m/s")
        for a, b, truth in zip(x_in, x_mm, region["x_range_m"], strict=True):
            assert b / 1e3 == pytest.approx(truth, rel=5e-3)
            assert a * INCH == pytest.approx(b / 1e3, rel=5e-3)
        for a, b, truth in zip(v_in_s, v_m_s, region["v_range_m_s"], strict=True):
            assert b == pytest.approx(truth, rel=5e-3)
            assert a * INCH == pytest.approx(b, rel=5e-3)
    # The verdict's imperial words carry the JSON's SI numbers converted.
    m = doc["mismatch"]
    assert f"Mismatch: {m['structured_rms_n'] / LBF:.3g} lbf RMS" in doc["verdict"]["text_imperial"]


def test_diagnose_page_takes_units(diagnosed: Path) -> None:
    doc = json.loads(diagnosed.read_text())
    index = diagnosed.parent / "page" / "index.html"
    text = html.unescape(visible_text(index))
    assert doc["verdict"]["text_imperial"] in text and _si_left(text) == {}
    table = next(t for t in parse(index).tables if t[0][1][0] == "round")
    header, cells = table[0][1], table[1][1]
    assert "peak effect (lbf)" in header
    shown = float(cells[header.index("peak effect (lbf)")])
    assert shown == pytest.approx(doc["findings"][0]["effect_peak_n"] / LBF, rel=5e-3)


# An older DIAG.json (no text_imperial) whose findings carry every kind of unit the
# section converts, and one it leaves alone.
OLD = copy.deepcopy(DIAGNOSE_SAMPLE)
OLD["findings"] = [  # type: ignore[index]
    {"physics": "friction", "claimed": True, "p_value": 0.001, "heldout_gain": 0.5,
     "effect_peak_n": 44.482216152605,
     "parameters": {"breakaway_n": {"value": 24.0, "sd": 1.5, "unit": "N"},
                    "stribeck_velocity_m_s": {"value": 0.0254, "sd": 0.00254, "unit": "m/s"},
                    "viscous_n_s_m": {"value": 400.0, "sd": 5.0, "unit": "N·s/m"}},
     "ambiguous_with": []},
    {"physics": "contact", "claimed": False, "p_value": 0.3, "heldout_gain": 0.0,
     "parameters": {"bump_onset_m": {"value": 0.0254, "sd": 0.001, "unit": "m"}},
     "ambiguous_with": []},
    {"physics": "thermal", "claimed": False, "p_value": 0.41, "heldout_gain": 0.01,
     "parameters": {"reference_c": {"value": 40.0, "sd": 5.0, "unit": "°C"},
                    "viscosity_coeff_per_k": {"value": 0.025, "sd": 0.002, "unit": "1/K"}},
     "ambiguous_with": []},
]  # fmt: skip
OLD["verdict"]["unexplained"] = [DIAGNOSE_SAMPLE["mismatch"]["where"][0] | {"rms_n": 8.9}]  # type: ignore[index]


def _old_page(tmp_path: Path, units: object) -> Path:
    return build_report([], tmp_path / str(units), title="t", diagnose=OLD, units=units)  # type: ignore[arg-type]


def test_an_older_diag_shows_its_si_words_with_a_note(tmp_path: Path) -> None:
    imperial_page = _old_page(tmp_path, IMPERIAL)
    imperial, si = _section(imperial_page), _section(_old_page(tmp_path, SI))
    words = OLD["verdict"]["text"]  # type: ignore[index]
    assert words in imperial and words in si
    assert "in SI units (N, mm, m/s): its DIAG.json predates the imperial text" in imperial
    assert "predates" not in si
    # Everything but that note is converted: drop it, and no SI label is left.
    note = imperial[imperial.index("The verdict above") :]
    assert _si_left(imperial.replace(note[: note.index("converted.") + 10], "")) == {}
    # 44.48 N = 10 lbf; 24 ± 1.5 N; 1 in/s; 400 N·s/m = 400 / 4.448 * 0.0254 lbf·s/in;
    # 25.4 mm = 1 in; 40 °C = 104 °F (a spread of 5 K is 9 °F); 1/K as stored.
    findings = next(t for t in parse(_old_page(tmp_path, IMPERIAL)).tables if "physics" in t[0][1])
    header, friction = findings[0][1], findings[1][1]
    assert friction[header.index("peak effect (lbf)")] == "10"
    assert f"breakaway_n = {24 / LBF:.4g} ± {1.5 / LBF:.2g} lbf" in imperial
    assert "stribeck_velocity_m_s = 1 ± 0.1 in/s" in imperial
    assert f"viscous_n_s_m = {400 / LBF * INCH:.4g} ± {5 / LBF * INCH:.2g} lbf·s/in" in imperial
    assert "bump_onset_m = 1 ± 0.039 in" in imperial
    assert "reference_c = 104 ± 9 °F" in imperial
    assert "viscosity_coeff_per_k = 0.025 ± 0.002 1/K" in imperial
    assert f"{8.9 / LBF:.3g} lbf RMS" in imperial and "8.9 N RMS" in si
    assert "breakaway_n = 24 ± 1.5 N" in si and "reference_c = 40 ± 5 °C" in si
