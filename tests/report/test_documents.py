"""DIAG.json and RIDE.json read as typed documents: an old file reads, a newer one's extra
keys are skipped, a garbled value is one line naming the file and the key."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from doc_samples import MINIMAL_RIDE, REGION, diag

from shockdyno.cli import main
from shockdyno.errors import ConfigError
from shockdyno.report.documents import (
    DiagnosisDoc,
    RideDoc,
    RunRms,
    read_diagnosis,
    read_ride,
    typed,
)
from shockdyno.report.ride_section import paper_ratios

# What the first `diagnose` wrote (33e648a): no mismatch.tested, no text_imperial,
# calibration or sensor in the verdict, no spec, recording or figures in info.
FIRST_DIAG: dict[str, Any] = {
    "mismatch": {"significant": True, "p_value": 0.001, "noise_floor_n": 2.1,
                 "structured_rms_n": 13.0, "structured_share": 0.38, "effective_values": 110,
                 "where": [REGION], "axes": {"stroke": {"rebound": 1.0}}},
    "findings": [{"physics": "friction", "round": 1, "claimed": True, "p_value": 0.001,
                  "heldout_gain": 0.9, "heldout_detail": "", "lr_n2": 9.4e4, "effect_rms_n": 15.5,
                  "effect_peak_n": 137.0, "ambiguous_with": [], "why_not": "",
                  "parameters": {"breakaway_n": {"value": 24.0, "sd": None, "unit": "N"}}}],
    "verdict": {"physics": ["friction"], "unexplained": [], "indistinguishable": [],
                "text": "Claimed friction.", "remaining_rms_n": 0.8, "remaining_p_value": 0.02},
    "tests": [{"index": 0, "clicks": 0, "frequency_hz": 0.5, "E_t_before": 0.023,
               "E_t_after": None}],
    "info": {"wall_s": 30.2, "n_tests": 1, "single_frequency": True, "skipped": [],
             "final_terms": ["friction"]},
}  # fmt: skip


def _write(tmp_path: Path, doc: object, name: str = "DIAG.json") -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    return path


def test_a_first_version_diag_reads_with_the_defaults_that_show_nothing(tmp_path: Path) -> None:
    doc = read_diagnosis(_write(tmp_path, FIRST_DIAG), "--diagnose")
    assert doc.mismatch.tested and doc.mismatch.where[0].x_range_m == (0.0156, 0.0292)
    assert doc.verdict.text_imperial is None and doc.verdict.calibration == ()
    assert doc.info.spec is None and doc.info.recording is None
    assert doc.info.figures == {} and doc.info.figures_units is None  # None: SI
    f = doc.findings[0]
    assert f.parameters["breakaway_n"].sd is None and not f.parameters["breakaway_n"].fixed
    assert doc.tests[0].E_t_after is None


def test_keys_a_newer_writer_adds_are_skipped(tmp_path: Path) -> None:
    newer = copy.deepcopy(FIRST_DIAG)
    newer["schema"] = "shockdyno.diagnose/9"
    newer["mismatch"]["where"][0]["curvature"] = [1, 2]
    newer["findings"][0]["prior"] = {"kind": "flat"}
    newer["info"]["spec"] = {"path": "a.toml", "name": "a", "default": False, "sha": "9f"}
    doc = read_diagnosis(_write(tmp_path, newer), "--diagnose")
    assert doc.info.spec is not None and doc.info.spec.name == "a"
    assert doc == read_diagnosis(_write(tmp_path, newer, "again.json"), "--diagnose")


@pytest.mark.parametrize(
    ("part", "value", "key", "said"),
    [
        ("findings", [{**FIRST_DIAG["findings"][0], "p_value": "low"}],
         "findings[0].p_value", "must be a number, got 'low'"),
        ("findings", [{"p_value": "low"}], "findings[0].p_value", "must be a number"),
        ("mismatch", {**FIRST_DIAG["mismatch"], "where": [{**REGION, "x_range_m": [0.01]}]},
         "mismatch.where[0].x_range_m", "must be a list [a number, a number], got [0.01]"),
        ("tests", "oops", "tests", "must be a list, got 'oops'"),
        ("info", {"figures_units": "metric"}, "info.figures_units", "must be one of"),
        ("verdict", None, "verdict", "must be a table, got null"),
    ],
)  # fmt: skip
def test_a_garbled_value_is_one_line_naming_file_and_key(
    tmp_path: Path, part: str, value: object, key: str, said: str
) -> None:
    path = _write(tmp_path, FIRST_DIAG | {part: value})
    with pytest.raises(ConfigError) as err:
        read_diagnosis(path, "--diagnose")
    line = str(err.value)
    assert line.startswith(f"--diagnose: {path}: {key}: ") and said in line
    assert "\n" not in line


def test_a_missing_key_is_named(tmp_path: Path) -> None:
    path = _write(tmp_path, {k: v for k, v in FIRST_DIAG.items() if k != "verdict"})
    with pytest.raises(ConfigError, match=r"DIAG\.json: verdict: missing$"):
        read_diagnosis(path, "--diagnose")


def test_the_wrong_kind_of_file_is_still_named_as_such(tmp_path: Path) -> None:
    path = _write(tmp_path, MINIMAL_RIDE, "RIDE.json")
    with pytest.raises(ConfigError, match=r"is a ride study .*; expected a diagnosis"):
        read_diagnosis(path, "--diagnose")
    with pytest.raises(ConfigError, match=r"is a diagnosis .*; expected a ride study"):
        read_ride(_write(tmp_path, FIRST_DIAG), "--ride")


def test_a_ride_file_reads_and_a_garbled_run_is_named(tmp_path: Path) -> None:
    run = {"clicks": None, "road": "A", "speed_kmh": 20, "rms_ms2": 0.2, "rms_wk_ms2": 0.15,
           "paper_rms_ms2": None, "tyre_leaves_road": False, "stroke_exceeds_travel": False,
           "max_abs_stroke_m": 0.01}  # fmt: skip
    doc = read_ride(_write(tmp_path, MINIMAL_RIDE | {"rms": [run]}, "RIDE.json"), "--ride")
    assert doc.rms[0].clicks is None and doc.rms[0].speed_kmh == 20.0
    assert doc.damper.settings == () and doc.fit_recording is None
    bad = MINIMAL_RIDE | {"rms": [run, run | {"rms_ms2": "fast"}]}
    path = _write(tmp_path, bad, "BAD.json")
    with pytest.raises(
        ConfigError, match=r"^--ride: .*BAD\.json: rms\[1\]\.rms_ms2: must be a number"
    ):
        read_ride(path, "--ride")


def test_a_writers_dict_reads_as_its_file_would() -> None:
    # ride/plots.py and batch hold `to_json()` dicts, numpy numbers and all.
    run = {"clicks": 5, "road": "A", "speed_kmh": 20.0, "rms_ms2": np.float64(0.25),
           "rms_wk_ms2": 0.2, "paper_rms_ms2": 0.025, "tyre_leaves_road": False,
           "stroke_exceeds_travel": False}  # fmt: skip
    doc = typed(MINIMAL_RIDE | {"rms": [run]}, RideDoc, "ride")
    assert doc.rms[0].rms_ms2 == 0.25
    assert typed(doc, RideDoc, "ride") is doc
    assert paper_ratios(doc.rms) == pytest.approx([10.0])
    assert isinstance(doc.rms[0], RunRms)
    assert isinstance(typed(diag(), DiagnosisDoc, "diagnosis"), DiagnosisDoc)


def test_report_with_a_garbled_diagnosis_is_one_line_and_writes_nothing(
    small_recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = _write(tmp_path, diag(findings=[{**FIRST_DIAG["findings"][0], "p_value": "low"}]),
                 "BAD.json")  # fmt: skip
    out = tmp_path / "out"
    code = main(["report", str(small_recording), "--diagnose", str(bad), "-o", str(out)])
    err = capsys.readouterr().err.strip()
    assert code != 0
    assert err.endswith(f"--diagnose: {bad}: findings[0].p_value: must be a number, got 'low'")
    assert "\n" not in err and "Traceback" not in err
    assert not (out / "index.html").exists()
