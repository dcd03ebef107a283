"""Calibration apart from physics: a spec value that is merely wrong is calibrated and
said so (DIAG.json `verdict.calibration`), never claimed as missing physics."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from shockdyno.diagnose.engine import diagnose
from shockdyno.diagnose.settings import Settings
from shockdyno.diagnose.verdict import to_json
from shockdyno.model.terms.gas_spring import GasSpring
from shockdyno.record import open_recording

REPO = Path(__file__).resolve().parents[2]
SPEC = REPO / "sim" / "ohlins-s46.toml"
CLI = [sys.executable, "-m", "shockdyno.cli"]
pytestmark = pytest.mark.timeout(300)


def _spec_with_gas_length(tmp: Path, length_m: float) -> Path:
    """The damper's spec with another gas column: the rig's damper is not what it says."""
    text, n = re.subn(
        r"^gas_length_m = [0-9.e-]+", f"gas_length_m = {length_m!r}", SPEC.read_text(), flags=re.M
    )
    assert n == 1
    out = tmp / f"gas-{length_m}.toml"
    out.write_text(text)
    return out


@pytest.fixture(scope="module")
def clean(tmp_path_factory: pytest.TempPathFactory) -> Path:
    rec = tmp_path_factory.mktemp("cal") / "clean.mcap"
    cmd = [*CLI, "sweep", "--rig", str(REPO / "rigs" / "sim.toml"), "--start-sim"]
    cmd += ["--speed", "50", "--clicks", "0,14", "-o", str(rec), "--seed", "31"]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=120, cwd=REPO)
    assert done.returncode == 0, done.stderr
    return rec


def _diagnose(rec: Path, spec: Path) -> dict:  # type: ignore[type-arg]
    tests = open_recording(rec).load_all()
    return to_json(diagnose(tests, settings=Settings(n_boot=199), spec_path=str(spec)))


def _row(d: dict, name: str) -> dict:  # type: ignore[type-arg]
    return next(r for r in d["verdict"]["calibration"] if r["parameter"] == name)


def test_a_wrong_gas_volume_is_calibration_not_physics(clean: Path, tmp_path: Path) -> None:
    # The rig's damper has the spec's 50 mm gas column; this spec says 50/1.4 mm.
    d = _diagnose(clean, _spec_with_gas_length(tmp_path, 0.050 / 1.4))
    assert d["verdict"]["physics"] == [], d["verdict"]["text"]
    assert not any(f["claimed"] for f in d["findings"])
    gas = _row(d, "gas_volume_m3")
    assert gas["moved"]
    assert gas["fitted"] / gas["spec_value"] == pytest.approx(1.4, rel=0.03)
    assert "gas volume is 1.4× too small" in d["verdict"]["text"]
    assert "Nothing claimed" in d["verdict"]["text"]


def test_the_right_spec_moves_nothing_worth_a_word(clean: Path) -> None:
    d = _diagnose(clean, SPEC)
    assert d["verdict"]["physics"] == []
    gas = _row(d, "gas_volume_m3")
    assert not gas["moved"]
    assert gas["fitted"] / gas["spec_value"] == pytest.approx(1.0, abs=0.03)
    assert "Calibrated" not in d["verdict"]["text"]
    # Every calibrated global is listed with its spec value, fit and unit.
    names = {r["parameter"] for r in d["verdict"]["calibration"]}
    assert {"gas_pressure_pa", "friction_n", "gas_volume_m3"} <= names
    assert all(r["unit"] for r in d["verdict"]["calibration"])


def test_a_rate_beyond_a_spec_error_is_left_to_the_search(clean: Path, tmp_path: Path) -> None:
    # The spec claims three times the real gas column: the rate would need a volume
    # 1/3 of the spec's, outside what a spec gets wrong.
    d = _diagnose(clean, _spec_with_gas_length(tmp_path, 0.150))
    assert GasSpring.calibrates is not None and GasSpring.calibrates.within[0] > 1 / 3
    assert not any(r["parameter"] == "gas_volume_m3" for r in d["verdict"]["calibration"])
    assert any("beyond a spec's error" in n for n in d["info"]["skipped"])
    assert d["mismatch"]["significant"]
