"""Calibration apart from physics: a spec value that is merely wrong is calibrated and
said so (DIAG.json `verdict.calibration`), never claimed as missing physics."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

from inprocess import cli
from shockdyno.diagnose.engine import diagnose
from shockdyno.diagnose.settings import Settings
from shockdyno.diagnose.verdict import to_json
from shockdyno.model.terms.gas_spring import GasSpring
from shockdyno.record import open_recording

REPO = Path(__file__).resolve().parents[2]
SPEC = REPO / "sim" / "ohlins-s46.toml"
pytestmark = pytest.mark.timeout(300)


def _spec_with(tmp: Path, key: str, value: float) -> Path:
    """The damper's spec with another value of `key` (a top-level number): the rig's
    damper is not what it says."""
    text, n = re.subn(rf"^{key} = [0-9.e-]+", f"{key} = {value!r}", SPEC.read_text(), flags=re.M)
    assert n == 1
    out = tmp / f"{key}-{value:.6g}.toml"
    out.write_text(text)
    return out


def _spec_with_gas_length(tmp: Path, length_m: float) -> Path:
    return _spec_with(tmp, "gas_length_m", length_m)


@pytest.fixture(scope="module")
def clean(tmp_path_factory: pytest.TempPathFactory) -> Path:
    rec = tmp_path_factory.mktemp("cal") / "clean.mcap"
    cmd = ["sweep", "--rig", str(REPO / "rigs" / "sim.toml"), "--start-sim"]
    cmd += ["--speed", "50", "--clicks", "0,14", "-o", str(rec), "--seed", "31"]
    done = cli(*cmd)  # in this process: a `shockdyno` process costs a second to start
    assert done.returncode == 0, done.stderr
    return rec


def _diagnose(rec: Path, spec: Path, **settings: Any) -> dict[str, Any]:
    tests = open_recording(rec).load_all()
    return to_json(diagnose(tests, settings=Settings(n_boot=199, **settings), spec_path=str(spec)))


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


# Calibration with limits (issue 44): a spec value moves freely within the tolerance a
# damper departs from its drawing by (a calibration); a move beyond it is held at the edge
# while the search runs, so what it could not take is offered to the physics terms, and a
# move the final refit still asks for is reported as a finding, never as calibrated.
RIG_FRICTION_N = 35.0  # the sim rig's damper: the spec's Coulomb friction


def test_a_spec_value_beyond_its_tolerance_is_held_while_the_search_runs(
    clean: Path, tmp_path: Path
) -> None:
    # The spec says a third of the rig damper's Coulomb friction: 3x is beyond the 0.5-2x
    # a damper departs from its drawing by. Before, the calibration took all of it in the
    # baseline ("No mismatch beyond noise") and no physics was ever tried in its place.
    spec_n = RIG_FRICTION_N / 3
    d = _diagnose(clean, _spec_with(tmp_path, "friction_n", spec_n), candidates=("friction",))
    # Held at 2x, the baseline leaves structure, and the search tries physics on it.
    assert d["mismatch"]["significant"], d["verdict"]["text"]
    assert any(f["physics"] == "friction" for f in d["findings"]), d["findings"]
    row = _row(d, "friction_n")
    assert row["asked"] / spec_n == pytest.approx(3.0, rel=0.1), row
    text = d["verdict"]["text"]
    assert "Calibrated, not physics: the spec's Coulomb friction" not in text, text
    # The mismatch is the held baseline's, and says so: the spec within its tolerance.
    assert text.startswith(
        "Mismatch, with the spec's Coulomb friction held within its tolerance: "
    ), text
    if d["verdict"]["physics"] == ["friction"] and not row["beyond_tolerance"]:
        assert "Held within its tolerance" in text and "claimed friction" in text, text
    else:
        # Nothing took its place: the final refit frees it, the model keeps what the
        # recording asks, and the move is a finding (on some recordings the held search
        # takes a bleed land beside it, which the freed refit drops again).
        assert row["fitted"] / spec_n == pytest.approx(3.0, rel=0.1), (row, text)
        assert row["beyond_tolerance"], row
        assert "A finding, not a calibration" in text and "while the search ran" in text, text


def test_a_freed_value_is_refitted_with_the_final_budget(clean: Path, tmp_path: Path) -> None:
    # The value the verdict reports is the final refit's, with its own budget
    # (Settings.final_nfev), however short the search's refits are (max_nfev). Given the
    # search's 15 evaluations when nothing was claimed, a freed value stayed where the
    # search had held it: on sim-rig recordings made under load the held search took a
    # 28 mm bleed land beside the held friction, and the freed refit moved it by 1e-4 of
    # the spec's (the test above then failed in full-suite runs, not alone: the recording
    # varies from run to run, the diagnosis of one recording does not). Cut to one
    # evaluation the search's refits cannot move at all, so only the final refit's own
    # budget can free it, on any recording.
    spec_n = RIG_FRICTION_N / 3
    spec = _spec_with(tmp_path, "friction_n", spec_n)
    d = _diagnose(clean, spec, candidates=(), calibrations=(), max_nfev=1)
    row = _row(d, "friction_n")
    assert row["asked"] / spec_n == pytest.approx(3.0, rel=0.1), row
    assert row["fitted"] == pytest.approx(row["asked"], rel=0.01), (row, d["verdict"]["text"])
    assert row["beyond_tolerance"], row


def test_a_spec_value_within_its_tolerance_is_calibrated_and_not_held(
    clean: Path, tmp_path: Path
) -> None:
    # 1.6x is a spec's error: calibrated freely, said so, nothing held or asked.
    spec_n = RIG_FRICTION_N / 1.6
    d = _diagnose(clean, _spec_with(tmp_path, "friction_n", spec_n))
    row = _row(d, "friction_n")
    assert row["fitted"] / spec_n == pytest.approx(1.6, rel=0.05), row
    assert not row["beyond_tolerance"] and "asked" not in row, row
    assert d["verdict"]["physics"] == [], d["verdict"]["text"]
    assert "Coulomb friction is 1.6× too small" in d["verdict"]["text"]
    assert "Held within" not in d["verdict"]["text"]


def test_a_held_value_reads_as_a_finding_or_as_the_claim_that_took_its_place() -> None:
    from types import SimpleNamespace

    from shockdyno.diagnose.diagnosis import CalibrationRow
    from shockdyno.diagnose.verdict import calibration_text
    from shockdyno.fit.parameters import spec_global

    g = spec_global("friction_n")

    def row(fitted: float) -> CalibrationRow:
        return CalibrationRow(
            "friction_n", 35.0, fitted, 0.5, g.unit, 0.05, g.fallback, g.tolerance, 94.5
        )

    friction = SimpleNamespace(physics="friction", claimed=True)
    # Held while the search ran, nothing took its place, freed again: a finding.
    stuck = row(94.5)
    assert stuck.beyond
    text = calibration_text(SimpleNamespace(calibration=[stuck], trials=[]))  # type: ignore[arg-type]
    assert text.startswith("A finding, not a calibration: the spec's Coulomb friction is 2.7×")
    assert "held within it while the search ran" in text and "Calibrated" not in text
    assert "no candidate physics took its place" in text
    # Held, a claim made, and the value still beyond: the text must not say nothing took it.
    text = calibration_text(
        SimpleNamespace(calibration=[stuck], trials=[friction])  # type: ignore[arg-type]
    )
    assert "the claimed friction did not take all of its place" in text
    assert "no candidate physics" not in text
    # Held, and the claimed friction took its place: the row is a calibration again.
    taken = row(38.5)
    assert not taken.beyond
    text = calibration_text(
        SimpleNamespace(calibration=[taken], trials=[friction])  # type: ignore[arg-type]
    )
    assert "Held within its tolerance while the search ran: a fit found the spec's" in text
    assert "2.7× too small" in text and "the claimed friction took its place" in text
    assert "now 1.1× the spec's" in text
