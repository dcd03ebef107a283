"""No motion is not structure (issue 21.6): a parked ram is refused by its amplitude
against the LVDT's own noise, and a test of fewer than two cycles has no cycle-to-cycle
noise to test against, so diagnose claims nothing from it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from shockdyno.cli import main


def _import(tmp: Path, x: np.ndarray, f: np.ndarray, hz: float) -> Path:
    t = np.arange(x.size) / 1000.0
    rows = [f"{a:.4f},{b:.9f},{c:.3f}" for a, b, c in zip(t, x, f, strict=True)]
    (tmp / "d.csv").write_text("time_s,displacement_m,force_N\n" + "\n".join(rows) + "\n")
    (tmp / "m.csv").write_text(f"file,clicks,frequency_hz,amplitude_m\nd.csv,5,{hz},0.03\n")
    rec = tmp / "r.mcap"
    assert main(["import", str(tmp / "m.csv"), "-o", str(rec)]) == 0
    return rec


def test_a_parked_ram_is_refused_not_diagnosed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rng = np.random.default_rng(1)
    n = 6000
    x = 1e-6 * rng.standard_normal(n)  # ±1 µm LVDT noise, no motion
    f = 230 + 2 * rng.standard_normal(n) + 15 * np.sin(2 * np.pi * np.arange(n) / 1000)
    rec = _import(tmp_path, x, f, 1.0)
    capsys.readouterr()
    for command in ("fit", "diagnose"):
        out = tmp_path / f"{command}.json"
        assert main([command, str(rec), "--json", str(out)]) != 0
        last = capsys.readouterr().err.strip().splitlines()[-1]  # after the progress lines
        assert "error:" in last and "no motion" in last and "µm of LVDT noise" in last
        assert not out.exists()


def test_fewer_than_two_cycles_is_said_and_claims_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rng = np.random.default_rng(2)
    t = np.arange(600) / 1000.0  # 0.6 s of a 1 Hz test: 0.6 of a cycle
    x = 0.03 * np.sin(2 * np.pi * t) + 1e-6 * rng.standard_normal(t.size)
    v = 0.03 * 2 * np.pi * np.cos(2 * np.pi * t)
    f = 230 + 3000 * v + 2 * rng.standard_normal(t.size)
    rec = _import(tmp_path, x, f, 1.0)
    capsys.readouterr()
    out = tmp_path / "d.json"
    report = tmp_path / "report"
    args = ["diagnose", str(rec), "--json", str(out), "--terms", "sensor_lag"]
    assert main([*args, "--report", str(report)]) == 0  # a warning, not an error
    printed = capsys.readouterr()
    assert "fewer than two whole cycles" in printed.err and "not tested" in printed.out
    doc = json.loads(out.read_text())
    # The 0.6 cycle used to read "13.7 N RMS repeats every cycle, p = 0.001" (issue 20):
    # now no statistic at all, no finding, and the reason, per test.
    assert doc["mismatch"]["tested"] is False and doc["mismatch"]["significant"] is False
    assert doc["mismatch"]["p_value"] is None and doc["mismatch"]["structured_rms_n"] is None
    assert doc["findings"] == [] and doc["verdict"]["physics"] == []
    assert [(t["index"], t["clicks"]) for t in doc["short_tests"]] == [(0, 5)]
    assert doc["short_tests"][0]["cycles"] == pytest.approx(0.6)
    verdict = doc["verdict"]["text"]
    assert verdict.startswith("Nothing claimed: no test has two whole cycles")
    assert "no cycle-to-cycle noise" in verdict and "repeats every cycle" not in verdict
    page = (report / "index.html").read_text(encoding="utf-8")
    assert "Nothing claimed: no test has two whole cycles" in page
    fit = tmp_path / "fit.json"
    assert main(["fit", str(rec), "--json", str(fit)]) == 0
    out = capsys.readouterr().out
    # fit uses the short test (one cycle still constrains it) and says so, not "skipped"
    assert "note: test 0 (5 clicks" in out and "fitted anyway" in out and "skipped" not in out


def test_a_short_test_beside_whole_ones_is_left_out_and_the_rest_diagnosed_as_before(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A recording cut short in its last test: that test is named and claims nothing, and
    the tests of whole cycles give exactly the diagnosis they give on their own."""
    from dataclasses import replace

    from report_helpers import make_test, write_recording

    rng = np.random.default_rng(3)
    whole = make_test(0, 7, 1.0, cycles=3)
    whole = replace(whole, force=whole.force + 3 * rng.standard_normal(whole.force.size))
    cut = make_test(1, 14, 1.5, cycles=1, t0=float(whole.t[-1]) + 1.0)
    docs = {}
    for name, tests in (("alone", [whole]), ("with_cut", [whole, cut])):
        rec = write_recording(tmp_path / f"{name}.mcap", tests, {"damper_id": name})
        out = tmp_path / f"{name}.json"
        assert main(["diagnose", str(rec), "--json", str(out), "--terms", "sensor_lag"]) == 0
        docs[name] = json.loads(out.read_text())
    err = capsys.readouterr().err
    assert err.count("1 test of fewer than two whole cycles") == 1
    alone, mixed = docs["alone"], docs["with_cut"]
    assert alone["short_tests"] == [] and mixed["mismatch"]["tested"] is True
    assert [(t["index"], t["clicks"]) for t in mixed["short_tests"]] == [(1, 14)]
    assert mixed["short_tests"][0]["cycles"] == pytest.approx(1.0, abs=0.01)
    for key in ("p_value", "structured_rms_n", "noise_floor_n"):
        assert mixed["mismatch"][key] == alone["mismatch"][key]
    assert [t["index"] for t in mixed["tests"]] == [0]
    assert "Left out, nothing claimed from them" in mixed["verdict"]["text"]
    assert "test 1 (14 clicks, 1.5 Hz)" in mixed["verdict"]["text"]
    # What stands before the note is the verdict of the whole tests alone.
    assert mixed["verdict"]["text"].startswith(alone["verdict"]["text"].split(" Calibrated")[0])
    # --units imperial: the terminal's noise in lbf, the SI number converted; JSON still SI.
    from shockdyno.units import N_PER_LBF

    rec, out = tmp_path / "alone.mcap", tmp_path / "imperial.json"
    argv = ["diagnose", str(rec), "--json", str(out), "--terms", "sensor_lag"]
    assert main([*argv, "--units", "imperial"]) == 0
    printed = capsys.readouterr().out
    noise = alone["mismatch"]["noise_floor_n"]
    assert f"noise {noise / N_PER_LBF:.3g} lbf" in printed and " N " not in printed
    assert json.loads(out.read_text())["mismatch"] == alone["mismatch"]
