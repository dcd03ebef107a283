"""A recording written with the project's writer, and the page `shockdyno report` makes of it
with a fit, a diagnosis and a ride study: shared by the CLI and browser tests."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from report_helpers import DIAGNOSE_SAMPLE, sweep_tests, write_recording
from shockdyno.cli import main
from shockdyno.fit.result import FitResult
from shockdyno.model import default_spec_path

CLICKS = (0, 10, 21)

# A ride result of the documented shape (docs/ride.md), by hand: one run flagged for each
# reason, a click interpolated from the trend, the paper's values where it has them.
RIDE_SAMPLE = {
    "schema": "shockdyno.ride/1",
    "quarter_car": {"sprung_mass_kg": 400.0, "unsprung_mass_kg": 45.0, "spring_n_m": 35000.0,
                    "tyre_n_m": 250000.0},
    "damper": {"settings": [{"clicks": 5, "source": "fit"}, {"clicks": 7, "source": "trend"}]},
    "flags": {"travel_m": 0.05},
    "rms": [
        {"clicks": 5, "road": "A", "speed_kmh": 20.0, "rms_ms2": 0.252, "rms_wk_ms2": 0.209,
         "paper_rms_ms2": 0.028, "tyre_leaves_road": False, "stroke_exceeds_travel": False},
        {"clicks": 5, "road": "E", "speed_kmh": 20.0, "rms_ms2": 3.524, "rms_wk_ms2": 2.602,
         "paper_rms_ms2": 0.309, "tyre_leaves_road": True, "stroke_exceeds_travel": True},
        {"clicks": 7, "road": "A", "speed_kmh": 20.0, "rms_ms2": 0.23, "rms_wk_ms2": 0.19,
         "paper_rms_ms2": None, "tyre_leaves_road": False, "stroke_exceeds_travel": False},
        {"clicks": 7, "road": "E", "speed_kmh": 20.0, "rms_ms2": 3.53, "rms_wk_ms2": 2.6,
         "paper_rms_ms2": None, "tyre_leaves_road": False, "stroke_exceeds_travel": True},
    ],
}  # fmt: skip


@pytest.fixture(scope="session")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("rec") / "sweep.mcap"
    return write_recording(path, sweep_tests(CLICKS), {"damper_id": "S46 <#7>"})


@pytest.fixture(scope="session")
def small_recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One test: for checks of the command's behaviour, not of the figures."""
    path = tmp_path_factory.mktemp("rec") / "one.mcap"
    return write_recording(path, sweep_tests((7,), (1.5,)), {"damper_id": "one"})


@pytest.fixture(scope="session")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("inputs")
    fit = d / "fit.json"
    FitResult.from_spec(default_spec_path(), CLICKS).save(fit)
    (d / "diag.json").write_text(json.dumps(DIAGNOSE_SAMPLE))
    (d / "ride.json").write_text(json.dumps(RIDE_SAMPLE))
    return {"fit": fit, "diagnose": d / "diag.json", "ride": d / "ride.json"}


@pytest.fixture(scope="session")
def full_report(
    recording: Path, inputs: dict[str, Path], tmp_path_factory: pytest.TempPathFactory
) -> Path:
    out = tmp_path_factory.mktemp("full") / "report"
    # The results are written by hand, not made from this recording: said, and allowed.
    args = ["report", str(recording), "-o", str(out), "--allow-other-recording"]
    for flag, path in inputs.items():
        args += [f"--{flag}", str(path)]
    assert main(args) == 0
    return out / "index.html"


@pytest.fixture(scope="session")
def imperial_report(
    recording: Path, inputs: dict[str, Path], tmp_path_factory: pytest.TempPathFactory
) -> Path:
    """The page of `recording` with the fit and the ride study in in/s, lbf, in, °F."""
    out = tmp_path_factory.mktemp("imperial") / "report"
    args = ["report", str(recording), "-o", str(out), "--units", "imperial"]
    args += ["--allow-other-recording", "--fit", str(inputs["fit"]), "--ride", str(inputs["ride"])]
    assert main(args) == 0
    return out / "index.html"
