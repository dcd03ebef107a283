"""`shockdyno ride` end to end: JSON fields, report files, one-line errors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from shockdyno.cli import main
from shockdyno.fit.result import FitResult
from shockdyno.fit.trend import AreaTrend
from shockdyno.model import default_spec_path
from shockdyno.report.documents import RideDoc, ride_text
from shockdyno.schema import convert

FAST = ["--duration-s", "3", "--warmup-s", "1", "--dt-ms", "1"]


@pytest.fixture()
def fit_file(tmp_path: Path, true_fit: FitResult) -> Path:
    path = tmp_path / "fit.json"
    true_fit.save(path)
    return path


def test_ride_writes_the_documented_json_and_report(fit_file: Path, tmp_path: Path) -> None:
    out, report = tmp_path / "ride.json", tmp_path / "report"
    code = main(
        ["ride", "--fit", str(fit_file), "--clicks", "5,15", "--roads", "a,C",
         "--speeds-kmh", "20,120", "--json", str(out), "--report", str(report), *FAST]
    )  # fmt: skip
    assert code == 0
    doc = json.loads(out.read_text())
    # One definition (report/documents.py RideDoc): read strictly, every key the study
    # wrote is declared, and the typed document written again is the file byte for byte.
    typed = convert(doc, RideDoc, str(out))
    assert ride_text(typed) == out.read_text() and typed.damper.settings and typed.roads
    lo, hi = doc["road_band_rad_per_m"]
    assert 0 < lo < hi
    assert doc["dt_s"] == 1e-3 and doc["duration_s"] == 3.0
    assert doc["step_check"]["max_relative_change"] < 1e-3
    keys = {(e["clicks"], e["road"], e["speed_kmh"]) for e in doc["rms"]}
    assert keys == {(c, r, v) for c in (5, 15) for r in "AC" for v in (20.0, 120.0)}
    for e in doc["rms"]:
        assert 0 < e["rms_wk_ms2"] < e["rms_ms2"] * 1.1
    # The paper's Table 7 value rides along where the paper has one.
    a20 = next(e for e in doc["rms"] if (e["clicks"], e["road"], e["speed_kmh"]) == (5, "A", 20))
    assert a20["paper_rms_ms2"] == 0.028
    lengths = {r["speed_kmh"]: r["length_m"] for r in doc["roads"]}
    assert lengths[120.0] == pytest.approx(120 / 3.6 * 3.0)
    names = {p.name for p in report.iterdir()}
    assert {"fig19_psd.png", "fig20_rms_vs_speed.png", "table7.md", "psd.csv"} <= names
    assert (report / "fig17_traces_low_speed.png").stat().st_size > 10_000
    assert "5 clicks" in (report / "table7.md").read_text()
    # The report is one page, with the figures and Table 7 on it:
    page = (report / "index.html").read_text(encoding="utf-8")
    assert "Table 7 analogue" in page and "fig19_psd.png" in page
    # Every run is checked against the tyre and the travel, and listed when flagged:
    flags = doc["flags"]
    assert flags["travel_m"] == 0.05 and flags["interpolated_clicks"] == []
    for e in doc["rms"]:
        assert e["stroke_exceeds_travel"] == (e["max_abs_stroke_m"] > 0.05)
        listed = {"clicks": e["clicks"], "road": e["road"], "speed_kmh": e["speed_kmh"]}
        assert (listed in flags["stroke_exceeds_travel"]) == e["stroke_exceeds_travel"]
        assert (listed in flags["tyre_leaves_road"]) == e["tyre_leaves_road"]


def test_flags_and_interpolated_clicks_reach_console_json_and_report(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A fit of clicks 5 and 15 with a trend: 10 clicks comes from the trend. Road E at
    # 120 km/h throws the wheel off the road and strokes the damper beyond 20 mm.
    fit = FitResult.from_spec(default_spec_path(), (5, 15))
    a = np.array([[c.clicks, c.a_bc_m2, c.a_bt_m2] for c in fit.clicks])
    fit.trend = {
        name: AreaTrend(1, tuple(np.polyfit(a[:, 0], a[:, k], 1)), (5, 15), 0.0, 1.0, "line")
        for k, name in ((1, "A_bc"), (2, "A_bt"))
    }
    fit_path = tmp_path / "fit.json"
    fit.save(fit_path)
    out, report = tmp_path / "ride.json", tmp_path / "rep"
    code = main(
        ["ride", "--fit", str(fit_path), "--clicks", "10", "--roads", "A,E",
         "--speeds-kmh", "120", "--travel-mm", "20", "--json", str(out),
         "--report", str(report), "--no-step-check", *FAST]
    )  # fmt: skip
    assert code == 0
    printed = capsys.readouterr().out
    doc = json.loads(out.read_text())
    runs = {e["road"]: e for e in doc["rms"]}
    assert runs["E"]["tyre_leaves_road"] and runs["E"]["stroke_exceeds_travel"]
    assert not runs["A"]["tyre_leaves_road"]
    assert runs["A"]["stroke_exceeds_travel"] == (runs["A"]["max_abs_stroke_m"] > 0.02)
    assert doc["flags"]["interpolated_clicks"] == [10]
    assert "the tyre leaves the road in 1 of 2 runs" in printed
    assert "exceeds its travel (±20 mm" in printed
    assert "10 clicks are interpolated from the fit's trend" in printed
    page = (report / "index.html").read_text(encoding="utf-8")
    assert "runs are outside the model" in page and "Interpolated from the fit" in page
    assert '<td class="flag">' in page and " TS</td>" in page


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--fit", "missing.json"], "--fit: missing.json not found"),
        (["--roads", "A,Q"], "road class 'Q'"),
        (["--clicks", "5,x"], "--clicks"),
        (["--clicks", "30"], "30 clicks is outside the fitted range"),
        (["--speeds-kmh", "0"], "speed"),
        (["--band-rad-per-m", "1"], "two numbers"),
        (["--dt-ms", "nan"], "finite"),
        ([], "--fit FIT.json is required"),
    ],
)
def test_user_mistakes_give_one_line_and_exit_2(
    args: list[str],
    message: str,
    fit_file: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    base = ["ride", "--json", str(tmp_path / "r.json"), *FAST]
    if "--fit" not in args and args:
        base += ["--fit", str(fit_file)]
    code = main([*base, *args])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert message in err and "\n" not in err and "Traceback" not in err


def test_installed_command_runs_the_linear_check(tmp_path: Path) -> None:
    out = tmp_path / "lin.json"
    exe = Path(sys.executable).with_name("shockdyno")
    proc = subprocess.run(
        [str(exe), "ride", "--linear-damper-ns-m", "2000", "--roads", "B",
         "--speeds-kmh", "60", "--json", str(out), "--no-step-check", *FAST],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(out.read_text())
    assert doc["damper"] == {"kind": "linear", "c_ns_m": 2000.0}
    assert doc["rms"][0]["clicks"] is None and doc["step_check"] is None
    # Progress off a terminal: one plain line per stage on stderr, stdout keeps the result
    stages = [ln for ln in proc.stderr.splitlines() if ln.startswith("ride: ")]
    assert stages == ["ride: integrate 1 runs x 3000 steps", "ride: RMS, Wk RMS and spectra"]
    assert "\x1b[" not in proc.stderr and "ride: " not in proc.stdout
