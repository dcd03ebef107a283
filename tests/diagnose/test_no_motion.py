"""No motion is not structure (issue 21.6): a parked ram is refused by its amplitude
against the LVDT's own noise, and a test of fewer than two cycles has no cycle-to-cycle
noise to test against, so diagnose claims nothing from it."""

from __future__ import annotations

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
    assert main(["diagnose", str(rec), "--json", str(out)]) != 0
    err = capsys.readouterr().err
    assert "two whole cycles" in err and "nothing can be claimed" in err and not out.exists()
    fit = tmp_path / "fit.json"
    assert main(["fit", str(rec), "--json", str(fit)]) == 0
    assert "fewer than two" in capsys.readouterr().out
