"""The combined report's diagnosis section carries the residual maps and loops that
`diagnose --report` drew, copied into the report's own directory."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest

from shockdyno.cli import main
from shockdyno.errors import ConfigError
from shockdyno.report.documents import DiagnosisDoc, diagnosis_text
from shockdyno.schema import convert


@pytest.fixture(scope="module")
def diagnosed(recording: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("diag")
    args = ["diagnose", str(recording), "--terms", "friction", "--json", str(d / "diag.json")]
    assert main([*args, "--report", str(d / "diag-page")]) == 0
    return d / "diag.json"


def test_every_key_diagnose_writes_is_declared_by_its_typed_document(diagnosed: Path):
    """DIAG.json has one definition (report/documents.py) that its writer builds and every
    reader reads: read strictly, an undeclared key anywhere in the file is an error, and
    the typed document written again is the file, byte for byte."""
    text = diagnosed.read_text()
    doc = convert(json.loads(text), DiagnosisDoc, str(diagnosed))  # unknown keys refused
    assert doc.info.figures and doc.info.spec is not None and doc.info.recording is not None
    assert doc.findings and doc.verdict.calibration and doc.mismatch.axes
    assert diagnosis_text(doc) == text
    with pytest.raises(ConfigError, match=r"findings\[0\]\.prior"):  # one written untyped
        raw = json.loads(text)
        raw["findings"][0]["prior"] = 1
        convert(raw, DiagnosisDoc, str(diagnosed))


def _images(index: Path) -> list[str]:
    return re.findall(r'<img src="([^"]+)"', index.read_text())


def test_diagnose_json_names_its_figures_relative_to_itself(diagnosed: Path):
    figures = json.loads(diagnosed.read_text())["info"]["figures"]
    assert figures == {
        "residual_maps": "diag-page/diagnose-residual-maps.png",
        "loops": "diag-page/diagnose-loops.png",
    }


def test_report_carries_the_residual_maps_and_loops_inside_its_directory(
    recording: Path, diagnosed: Path, tmp_path: Path
):
    # The JSON and its figures moved together, elsewhere (a copy: the fixture is shared)
    moved = tmp_path / "moved"
    shutil.copytree(diagnosed.parent, moved)
    out = tmp_path / "report"
    assert (
        main(["report", str(recording), "--diagnose", str(moved / "diag.json"), "-o", str(out)])
        == 0
    )
    index = out / "index.html"
    html = index.read_text()
    section = html[html.index(">Diagnosis</h2>") :]
    shown = [src for src in _images(index) if "diagnose-" in src]
    assert len(shown) == 2 and all(src in section for src in shown)
    for src in shown:
        assert not src.startswith(("/", "..")) and (out / src).is_file()
        drawn = moved / "diag-page" / Path(src).name.split("_", 1)[1]  # extra/50_<name>
        assert (out / src).read_bytes() == drawn.read_bytes()
    assert "Residual maps" in section and "Residual loops" in section
    assert "No residual maps or loops" not in html


def test_a_diagnosis_without_figures_says_so_in_one_line(full_report: Path):
    html = full_report.read_text()  # DIAGNOSE_SAMPLE: no info.figures
    assert html.count("No residual maps or loops") == 1
    assert not [src for src in _images(full_report) if "diagnose-" in src]


def test_figures_moved_apart_from_the_json_are_named_as_missing(
    recording: Path, diagnosed: Path, tmp_path: Path
):
    lone = tmp_path / "diag.json"
    lone.write_text(diagnosed.read_text())
    out = tmp_path / "report"
    assert main(["report", str(recording), "--diagnose", str(lone), "-o", str(out)]) == 0
    html = (out / "index.html").read_text()
    assert "not found beside its JSON: diag-page/diagnose-residual-maps.png" in html
