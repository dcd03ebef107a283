"""The batch table's calibration column tells a spec's error from a finding, as the verdict
does: a value beyond a damper's tolerance, or left at an end of the calibration's range, is
not a calibration."""

from __future__ import annotations

from types import SimpleNamespace

from shockdyno.batch.jobs import _from_diag
from shockdyno.batch.table import Row
from shockdyno.report.documents import Calibration


def _cal(name: str, spec: float, fitted: float, **flags: bool) -> Calibration:
    return Calibration(
        parameter=name, spec_value=spec, fitted=fitted, sd=0.01, unit="", moved=True, **flags
    )


def test_findings_are_marked_and_calibrations_are_not() -> None:
    verdict = SimpleNamespace(
        physics=("friction",),
        calibration=(
            _cal("gas_pressure_pa", 1.6e6, 1.0e6),
            _cal("friction_n", 35.0, 94.5, beyond_tolerance=True),
            _cal("friction_velocity_m_s", 1e-3, 1.01e-5, at_range_end=True),
            Calibration(
                parameter="bleed_land_m",
                spec_value=5e-3,
                fitted=5e-3,
                sd=0.0,
                unit="m",
                moved=False,
            ),
        ),
    )
    row = Row(path="r.mcap", name="r", sha256="", kind="diagnose", status="done")
    _from_diag(row, SimpleNamespace(verdict=verdict, tests=[]))  # type: ignore[arg-type]
    assert row.calibration == (
        "gas_pressure_pa=0.625x;friction_n=2.7x (finding);friction_velocity_m_s=0.0101x (finding)"
    )
    assert row.physics == "friction"
