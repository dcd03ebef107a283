"""Gas pressure per test: a manifest column and a sweep flag, read by the model."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from inprocess import cli
from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.problem import prepared_inputs
from shockdyno.model import DamperModel, load_spec
from shockdyno.model.composite import ATMOSPHERE_PA
from shockdyno.record import open_recording

REPO = Path(__file__).resolve().parents[2]


def _csv(path: Path, t: np.ndarray, x: np.ndarray, f: np.ndarray) -> None:
    rows = [f"{a:.4f},{b:.6f},{c:.2f}" for a, b, c in zip(t, x, f, strict=True)]
    path.write_text("time_s,displacement_m,force_N\n" + "\n".join(rows) + "\n")


def test_the_manifest_column_reaches_the_model(tmp_path: Path) -> None:
    t = np.arange(3000) / 1000.0
    x = 0.03 * np.sin(2 * np.pi * t)
    _csv(tmp_path / "a.csv", t, x, 300 * np.cos(2 * np.pi * t))
    _csv(tmp_path / "b.csv", t, x, 300 * np.cos(2 * np.pi * t))
    (tmp_path / "m.csv").write_text(
        "file,clicks,frequency_hz,amplitude_m,gas_pressure_pa\n"
        "a.csv,5,1,0.03,1.0e6\nb.csv,5,1,0.03,2.0e6\n"
    )
    rec = tmp_path / "r.mcap"
    done = cli("import", str(tmp_path / "m.csv"), "-o", str(rec))
    assert done.returncode == 0, done.stderr
    tests = open_recording(rec).load_all()
    assert [tt.meta.gas_pressure_pa for tt in tests] == [1.0e6, 2.0e6]
    prepared, _ = prepare_tests(tests)
    inputs = prepared_inputs(prepared)
    spec = load_spec()
    ev = DamperModel(spec).evaluate(inputs, 1e-6, 1e-6)
    second = int(inputs.starts[1])
    # At mid-stroke at rest the gas force scales with each test's charge about their mean.
    gas = ev.components["gas"] + ATMOSPHERE_PA * spec.rod_area_m2
    mid = np.argmin(np.abs(inputs.x[:second]))
    mid2 = second + np.argmin(np.abs(inputs.x[second:]))
    assert gas[mid2] / gas[mid] == pytest.approx(2.0, rel=0.02)
    assert gas[mid] == pytest.approx(spec.gas_pressure_pa * spec.rod_area_m2 / 1.5, rel=0.02)


def test_the_sweep_flag_is_stored_with_every_test(tmp_path: Path) -> None:
    rec = tmp_path / "s.mcap"
    cmd = ["sweep", "--rig", str(REPO / "rigs" / "sim.toml"), "--start-sim"]
    cmd += ["--speed", "50", "--clicks", "7", "--freq", "1.5", "--cycles", "2"]
    cmd += ["--gas-pressure-bar", "16", "-o", str(rec)]
    done = cli(*cmd)  # in this process: a `shockdyno` process costs a second to start
    assert done.returncode == 0, done.stderr
    assert [t.gas_pressure_pa for t in open_recording(rec).tests] == [1.6e6]
    bad = cli(*cmd[:-2], "--gas-pressure-bar", "900", "-o", str(tmp_path / "x.mcap"))
    assert bad.returncode != 0 and "gas pressure must be" in bad.stderr
    assert "Traceback" not in bad.stderr
