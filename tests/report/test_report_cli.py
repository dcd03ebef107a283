"""`shockdyno report`: a page for a recording with the sections that apply; refusals."""

from __future__ import annotations

from pathlib import Path

import pytest
from doc_samples import diagnosis, ride
from test_report_build import parse

from shockdyno.cli import main
from shockdyno.report.diagnose_section import render_diagnose
from shockdyno.report.html import Page
from shockdyno.report.ride_section import render_ride


def _sections(index: Path) -> list[str]:
    return parse(index).headings


def test_full_page_has_every_section_and_only_local_files(full_report: Path) -> None:
    page = parse(full_report)
    for heading in (
        "Recording",
        "Click chart",
        "Summary",
        "Fit and validation",
        "Diagnosis",
        "Ride study",
        "Loops per click",
    ):
        assert heading in page.headings
    out = full_report.parent
    for src in page.images + [a for a in page.links if not a.startswith("#")]:
        assert "://" not in src  # nothing fetched from the network: it works offline
        assert (out / src).is_file(), src
    text = full_report.read_text(encoding="utf-8")
    assert "S46 &lt;#7&gt;" in text  # the title comes from the metadata, escaped
    # E_t, E_x and E_ẋ are defined on the page, the gas force is marked and named:
    for term in ("E_t (time)", "E_x (displacement)", "E_ẋ (velocity)", "static gas force"):
        assert term in text
    # 22 clicks would give 22 loop figures: they sit in collapsed blocks.
    assert text.count("<details>") >= 3
    # No absolute path of this machine: the spec and the recording (a tmp path here, out
    # of the working directory) are named by their last parts (issue 20).
    from shockdyno.model import default_spec_path

    assert str(default_spec_path().parent) not in text and "/tmp/" not in text
    assert "…/rec" in text or "sweep.mcap" in text


def test_diagnose_section_renders_the_documented_keys(full_report: Path) -> None:
    page = parse(full_report)
    text = full_report.read_text(encoding="utf-8")
    assert "Oil compressibility explains most of the rebound mismatch." in text
    assert (
        "Still unexplained: in rebound at -30 to -10 mm, -0.28 to -0.12 m/s "
        "(0.5 Hz; 20 % of the structure)." in text
    )
    findings = next(t for t in page.tables if t[0][1][:2] == ["round", "physics"])
    rows = {cells[1]: (cls, cells) for cls, cells in findings[1:]}  # finding_cells' columns
    assert set(rows) == {"compressibility", "thermal"}
    cls, cells = rows["compressibility"]
    assert cls == "" and cells[2] == "yes" and cells[7] == "sensor_lag"
    assert "bulk_modulus_pa = 1.2e+09 ± 1e+08 Pa" in cells[6]
    assert rows["thermal"][0] == "dim"  # not claimed: shown, but greyed
    where = next(t for t in page.tables if t[0][1][0] == "stroke")
    assert where[1][1][1] == "-30 to -10 mm"
    per_test = next(t for t in page.tables if t[0][1][:2] == ["test", "clicks"] and
                    "E_t before" in t[0][1])  # fmt: skip
    # E_t 0.0625 -> 0.0125 is a fall of 80 %:
    assert per_test[1][1][3:] == ["0.0625", "0.0125", "-80.0 %"]


def test_diagnose_section_says_what_the_file_lacks() -> None:
    # Straight onto a page: the document is the variable, not the recording. (A garbled
    # one never gets here: reading it is the error, test_documents.py.)
    page = Page("diagnose only")
    render_diagnose(page, diagnosis(verdict={"text": "only a verdict", "physics": [],
                                             "unexplained": []}))  # fmt: skip
    text = page.render()
    assert ">Diagnosis</h2>" in text and "only a verdict" in text
    assert "Physics named: –." in text and "not significant (p = 0.5;" in text
    assert "Not in the diagnose file: findings, tests." in text
    assert "Damper spec" not in text and "Still unexplained" not in text


def test_ride_section_of_a_file_without_runs_or_fitted_clicks() -> None:
    page = Page("ride only")
    render_ride(page, ride())  # a linear damper: no click settings
    text = page.render()
    assert "The car: sprung mass 500 kg, unsprung mass 60 kg, spring 60 kN/m" in text
    assert "The ride file has no runs (key &#x27;rms&#x27;)." in text
    assert "Interpolated" not in text and "Table 7 analogue" not in text


def test_ride_section_flags_runs_and_explains_the_paper_gap(full_report: Path) -> None:
    page = parse(full_report)
    text = full_report.read_text(encoding="utf-8")
    table = next(t for t in page.tables if t[0][1][:2] == ["km/h", "damper"])
    rows = {cells[1]: (cls, cells[2:]) for cls, cells in table[1:]}
    assert rows["5 clicks"][1][1].endswith(" TS") and not rows["5 clicks"][1][0].endswith("S")
    # Only the flagged cells are shaded, not their rows:
    assert text.count('<td class="flag">') == 2
    assert rows["7 clicks"][1][1].endswith(" S") and not rows["7 clicks"][1][0].endswith("S")
    assert "2 of 4 runs are outside the model" in text
    assert "Interpolated from the fit" in text and "7 clicks" in text
    # 0.252 / 0.028 = 9.0 and 3.524 / 0.309 = 11.4: computed from the file, not quoted.
    assert "Ours are 9.0-11.4× the paper" in text
    # The page states the car it ran (issue 20), read from the file, not Table 5's.
    assert "sprung mass 400 kg, unsprung mass 45 kg, spring 35 kN/m, tyre 250 kN/m" in text
    assert text.index("Ours are 9.0") > text.index("km/h")  # beside (after) the table


def test_recording_without_fit_gets_a_measured_click_chart(recording: Path, tmp_path: Path) -> None:
    out = tmp_path / "plain"
    assert main(["report", str(recording), "-o", str(out)]) == 0
    headings = _sections(out / "index.html")
    assert "Click chart" in headings and "Fit and validation" not in headings
    assert "Fitted model" not in (out / "index.html").read_text(encoding="utf-8")
    assert (out / "click_chart.csv").is_file()


def test_existing_page_is_refused_without_force(
    small_recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    recording = small_recording
    out = tmp_path / "again"
    assert main(["report", str(recording), "-o", str(out)]) == 0
    before = (out / "index.html").read_bytes()
    capsys.readouterr()
    assert main(["report", str(recording), "-o", str(out), "--title", "second"]) == 2
    err = capsys.readouterr().err.strip()
    assert "--force" in err and "\n" not in err
    assert (out / "index.html").read_bytes() == before
    assert main(["report", str(recording), "-o", str(out), "--title", "second", "--force"]) == 0
    assert "<h1>second</h1>" in (out / "index.html").read_text(encoding="utf-8")


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--fit", "nope.json"], "--fit: nope.json not found"),
        (["--diagnose", "nope.json"], "--diagnose: nope.json not found"),
        (["--ride", "BAD"], "--ride:"),
        (["--ride", "LIST"], "is JSON of another kind; expected a ride study"),
    ],
)
def test_bad_inputs_are_one_line(
    recording: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    extra: list[str],
    message: str,
) -> None:
    (tmp_path / "BAD").write_text("{not json")
    (tmp_path / "LIST").write_text("[]")
    extra = [str(tmp_path / e) if e in ("BAD", "LIST") else e for e in extra]
    code = main(["report", str(recording), "-o", str(tmp_path / "out"), *extra])
    err = capsys.readouterr().err.strip()
    assert code == 2 and message in err
    assert "\n" not in err and "Traceback" not in err
    assert not (tmp_path / "out" / "index.html").exists()


def test_not_a_recording_and_output_over_input_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], recording: Path
) -> None:
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"hello, this is a text file and no recording")
    assert main(["report", str(junk), "-o", str(tmp_path / "o")]) != 0
    assert "not an MCAP file" in capsys.readouterr().err
    junk.write_bytes(b"hello")  # too short to tell: nothing readable
    assert main(["report", str(junk), "-o", str(tmp_path / "o")]) != 0
    assert "no test could be read" in capsys.readouterr().err
    assert not (tmp_path / "o" / "index.html").exists()
    # A JSON input named like the page's own CSV, in the output directory:
    out = tmp_path / "o2"
    out.mkdir()
    (out / "click_chart.csv").write_text("{}")
    code = main(["report", str(recording), "--ride", str(out / "click_chart.csv"), "-o", str(out)])
    assert code == 2 and "overwrite its input" in capsys.readouterr().err
    assert (out / "click_chart.csv").read_text() == "{}"
