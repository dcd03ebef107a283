"""Real-data-like input: one imported 300 Hz test of slider-crank motion with a
temperature channel, whose force lags its motion by 15 ms like the real slider-crank
recordings' load cells (11-18 ms), so the loop opens by ~90 N at zero velocity on a
100-600 N damper.
The diagnosis must run on it and say what one frequency can and cannot separate."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from inprocess import cli
from shockdyno.model import DamperModel, ModelInputs, differentiate, load_spec
from shockdyno.model.terms import make_term

FS = 300.0


def slider_crank(t: np.ndarray, f_hz: float, crank_m: float, rod_m: float) -> np.ndarray:
    th = 2 * np.pi * f_hz * t
    x = crank_m * np.cos(th) + np.sqrt(rod_m**2 - (crank_m * np.sin(th)) ** 2)
    return x - float(np.mean(x))


@pytest.fixture(scope="module")
def imported(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, float, float]:
    root = tmp_path_factory.mktemp("crank")
    spec = load_spec()
    a_bc, a_bt = (float(a) for a in spec.bleed_areas(21))
    t = np.arange(int(12 * FS)) / FS
    x = slider_crank(t, 1.0, 0.016, 0.07)
    v, a = differentiate(t, x)
    model = DamperModel(spec, (make_term("sensor_lag"),), {"sensor_lag.load_cell_lag_s": 0.015})
    inputs = ModelInputs(x, v, a, np.zeros(1, dtype=np.intp), np.array([1 / FS]), periodic=True)
    force = model.force(inputs, a_bc, a_bt)
    rng = np.random.default_rng(2)
    force = force + 3.0 * rng.standard_normal(t.size)
    temp = 35.0 + 4.0 * t / t[-1] + 0.05 * rng.standard_normal(t.size)
    lines = ["time_s,displacement_m,force_N,temperature_C"]
    lines += [
        f"{ti:.5f},{xi:.6f},{fi:.2f},{ci:.2f}"
        for ti, xi, fi, ci in zip(t, x, force, temp, strict=True)
    ]
    (root / "run1.csv").write_text("\n".join(lines) + "\n")
    (root / "manifest.csv").write_text(
        "file,clicks,frequency_hz,amplitude_m,motion\nrun1.csv,21,1.0,0.016,imported\n"
    )
    rec = root / "run1.mcap"
    done = cli("import", str(root / "manifest.csv"), "-o", str(rec))  # in this process
    assert done.returncode == 0, done.stderr
    # How far the loop opens at zero velocity: force at the top reversals less the bottom's.
    turn = np.flatnonzero(np.diff(np.sign(v)) != 0)
    top = [force[i] for i in turn if x[i] > 0]
    bottom = [force[i] for i in turn if x[i] < 0]
    return rec, float(np.mean(top) - np.mean(bottom)), float(np.max(np.abs(force)))


def test_the_fixture_looks_like_the_real_data_it_stands_for(
    imported: tuple[Path, float, float],
) -> None:
    _, opening, peak = imported
    assert 60.0 < opening < 300.0 and peak < 650.0


def test_a_single_imported_test_is_diagnosed_with_what_one_frequency_cannot_separate(
    imported: tuple[Path, float, float], tmp_path: Path
) -> None:
    rec, _, _ = imported
    report = tmp_path / "diag"
    # In this process: what it writes (a `shockdyno` process costs a second to start).
    done = cli("diagnose", str(rec), "--json", "-", "--report", str(report))
    assert done.returncode == 0, done.stderr
    doc = json.loads(done.stdout)
    assert doc["info"]["single_frequency"] is True
    assert doc["mismatch"]["significant"]
    claimed = doc["verdict"]["physics"]
    assert claimed and claimed[0] in ("compressibility", "sensor_lag")
    assert "One frequency only" in doc["verdict"]["text"]
    assert (report / "index.html").exists() and (report / "diagnose-loops.png").stat().st_size > 0
    t = doc["tests"][0]
    assert t["E_t_after"] < 0.5 * t["E_t_before"]
