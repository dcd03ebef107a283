"""A recording written with the project's writer, and the page `shockdyno report` makes of it
with a fit, a diagnosis and a ride study: shared by the CLI and browser tests.

Each is made once per test run, not once per test process: under pytest-xdist the modules
that read them run on different workers, and each worker made its own (the full page, about
5 s of CPU, two or three times a run). The first worker to ask makes it in the run's common
temporary folder while the others wait, then read it; no test writes into them."""

from __future__ import annotations

import fcntl
import json
import os
import shutil
from collections.abc import Callable
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


Made = Callable[[str, Callable[[Path], None]], Path]


@pytest.fixture(scope="session")
def made_once(tmp_path_factory: pytest.TempPathFactory) -> Made:
    """made_once(NAME, make): the folder NAME, filled by make(folder) once per test run."""
    if not os.environ.get("PYTEST_XDIST_WORKER"):  # one process: its own folders

        def here(name: str, make: Callable[[Path], None]) -> Path:
            folder = tmp_path_factory.mktemp(name)
            make(folder)
            return folder

        return here
    shared = tmp_path_factory.getbasetemp().parent / "report-fixtures"  # this run's workers'
    shared.mkdir(exist_ok=True)

    def once(name: str, make: Callable[[Path], None]) -> Path:
        folder = shared / name
        with (shared / f"{name}.lock").open("w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file is closed
            if not (shared / f"{name}.done").exists():
                shutil.rmtree(folder, ignore_errors=True)  # what a failed make left
                folder.mkdir()
                make(folder)
                (shared / f"{name}.done").touch()
        return folder

    return once


@pytest.fixture(scope="session")
def recording(made_once: Made) -> Path:
    def make(d: Path) -> None:
        write_recording(d / "sweep.mcap", sweep_tests(CLICKS), {"damper_id": "S46 <#7>"})

    return made_once("rec", make) / "sweep.mcap"


@pytest.fixture(scope="session")
def small_recording(made_once: Made) -> Path:
    """One test: for checks of the command's behaviour, not of the figures."""

    def make(d: Path) -> None:
        write_recording(d / "one.mcap", sweep_tests((7,), (1.5,)), {"damper_id": "one"})

    return made_once("rec-one", make) / "one.mcap"


@pytest.fixture(scope="session")
def inputs(made_once: Made) -> dict[str, Path]:
    def make(d: Path) -> None:
        FitResult.from_spec(default_spec_path(), CLICKS).save(d / "fit.json")
        (d / "diag.json").write_text(json.dumps(DIAGNOSE_SAMPLE))
        (d / "ride.json").write_text(json.dumps(RIDE_SAMPLE))

    d = made_once("inputs", make)
    return {"fit": d / "fit.json", "diagnose": d / "diag.json", "ride": d / "ride.json"}


@pytest.fixture(scope="session")
def full_report(recording: Path, inputs: dict[str, Path], made_once: Made) -> Path:
    def make(d: Path) -> None:
        # The results are written by hand, not made from this recording: said, and allowed.
        args = ["report", str(recording), "-o", str(d / "report"), "--allow-other-recording"]
        for flag, path in inputs.items():
            args += [f"--{flag}", str(path)]
        assert main(args) == 0

    return made_once("full", make) / "report" / "index.html"


@pytest.fixture(scope="session")
def imperial_report(recording: Path, inputs: dict[str, Path], made_once: Made) -> Path:
    """The page of `recording` with the fit and the ride study in in/s, lbf, in, °F."""

    def make(d: Path) -> None:
        args = ["report", str(recording), "-o", str(d / "report"), "--units", "imperial"]
        args += ["--allow-other-recording", "--fit", str(inputs["fit"]),
                 "--ride", str(inputs["ride"])]  # fmt: skip
        assert main(args) == 0

    return made_once("imperial", make) / "report" / "index.html"
