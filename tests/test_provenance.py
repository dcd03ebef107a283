"""Results carry their recording's hash (issue 21.4): a fit, diagnosis or ride of another
recording, or one that does not say which, is refused by `report`, `diagnose --fit` and
`batch report|diagnose --fit`; only --allow-other-recording accepts it, and the terminal and
the page say so. --force replaces outputs and waives no input check (issue 46.7). An
unusable fit (negative area, NaN) is refused in one line."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import pytest

from shockdyno.cli import main

REPO = Path(__file__).resolve().parents[1]
EXAMPLE = REPO / "recordings" / "examples" / "example.mcap"
MANIFEST = REPO / "recordings" / "examples" / "csv" / "manifest.csv"


@pytest.fixture(scope="module")
def two(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path]:
    """Recording A, its fit, and another recording B (imported from CSV)."""
    root = tmp_path_factory.mktemp("prov")
    a = root / "a.mcap"
    shutil.copy(EXAMPLE, a)
    b = root / "b.mcap"
    assert main(["import", str(MANIFEST), "-o", str(b)]) == 0
    fit = root / "a-fit.json"
    assert main(["fit", str(a), "--json", str(fit)]) == 0
    return a, b, fit


def test_the_fit_json_carries_the_recording_hash(two: tuple[Path, Path, Path]) -> None:
    a, _, fit = two
    info = json.loads(fit.read_text())["info"]["recording"]
    assert info == {"file": "a.mcap", "sha256": hashlib.sha256(a.read_bytes()).hexdigest()}


def test_report_refuses_a_fit_of_another_recording_unless_explicitly_allowed(
    two: tuple[Path, Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    a, b, fit = two
    out = tmp_path / "rep"
    for extra in ([], ["--force"]):  # --force replaces the page; it accepts no other input
        assert main(["report", str(b), "--fit", str(fit), "-o", str(out), *extra]) == 2
        err = capsys.readouterr().err
        assert "another recording" in err and "--allow-other-recording" in err
        assert err.count("\n") == 1 and not (out / "index.html").exists()
    allow = ["--allow-other-recording"]
    assert main(["report", str(b), "--fit", str(fit), "-o", str(out), *allow]) == 0
    assert "another recording" in capsys.readouterr().err  # said on the terminal
    assert "NOT CHECKED AGAINST THIS RECORDING" in (out / "index.html").read_text()
    ok = tmp_path / "ok"
    assert main(["report", str(a), "--fit", str(fit), "-o", str(ok)]) == 0
    assert "made from this recording" in (ok / "index.html").read_text()


def test_a_fit_that_does_not_name_its_recording_is_refused(
    two: tuple[Path, Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Removing info.recording from the JSON used to give 'not checked', exit 0."""
    a, _, fit = two
    doc = json.loads(fit.read_text())
    del doc["info"]["recording"]
    old = tmp_path / "old.json"
    old.write_text(json.dumps(doc))
    out = tmp_path / "rep"
    assert main(["report", str(a), "--fit", str(old), "-o", str(out), "--force"]) == 2
    assert "does not say which recording" in capsys.readouterr().err
    allow = ["--allow-other-recording"]
    assert main(["report", str(a), "--fit", str(old), "-o", str(out), *allow]) == 0
    assert "no info.recording" in (out / "index.html").read_text()


def test_batch_report_checks_the_fit_of_each_recording(
    two: tuple[Path, Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`batch report DIR --fit FIT.json` did not check at all: now a recording the fit is
    not of is a failed row, unless --allow-other-recording (and then its page says so)."""
    a, b, fit = two
    recs = tmp_path / "recs"
    recs.mkdir()
    for r in (a, b):
        shutil.copy(r, recs / r.name)
    out = tmp_path / "out"
    base = ["batch", "report", str(recs), "--fit", str(fit), "--workers", "1", "--out"]
    assert main([*base, str(out)]) == 3
    said = capsys.readouterr().out
    assert "1 done" in said and "failed" in said and "b.mcap" in said
    assert "another recording" in said and "--allow-other-recording" in said
    assert main([*base, str(tmp_path / "out2"), "--allow-other-recording"]) == 0
    assert "--allow-other-recording" in capsys.readouterr().err
    pages = sorted((tmp_path / "out2").glob("*/index.html"))
    assert [("NOT CHECKED AGAINST" in p.read_text()) for p in pages] == [False, True]


def test_diagnose_refuses_a_fit_of_another_recording(
    two: tuple[Path, Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _, b, fit = two
    out = tmp_path / "d.json"
    assert main(["diagnose", str(b), "--fit", str(fit), "--json", str(out)]) == 2
    assert "another recording" in capsys.readouterr().err and not out.exists()


def test_a_diagnosis_or_ride_of_another_recording_is_refused(
    two: tuple[Path, Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    a, b, fit = two
    diag = tmp_path / "d.json"
    assert main(["diagnose", str(a), "--json", str(diag)]) == 0
    assert json.loads(diag.read_text())["info"]["recording"]["file"] == "a.mcap"
    # Which spec the diagnosis used: on the terminal and in its JSON.
    assert "spec: built-in default sim/ohlins-s46.toml (ohlins-s46)" in capsys.readouterr().out
    used = json.loads(diag.read_text())["info"]["spec"]
    assert used == {"path": "sim/ohlins-s46.toml", "name": "ohlins-s46", "default": True}
    ride = tmp_path / "r.json"
    fast = ["--clicks", "21", "--roads", "A", "--speeds-kmh", "60", "--duration-s", "2"]
    fast += ["--warmup-s", "0.5", "--no-step-check"]
    assert main(["ride", "--fit", str(fit), *fast, "--json", str(ride)]) == 0
    assert json.loads(ride.read_text())["fit_recording"]["file"] == "a.mcap"
    capsys.readouterr()
    for flag, path in (("--diagnose", diag), ("--ride", ride)):
        assert main(["report", str(b), flag, str(path), "-o", str(tmp_path / "x")]) == 2
        assert "another recording" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("edit", "said"),
    [
        (lambda d: d["clicks"][0].update(A_bc_m2=-1e-6), "not a usable fit: A_bc at"),
        # NaN is not JSON this project writes (null is): refused as the file is read
        (lambda d: d["globals"].update(friction_n=float("nan")), "friction_n: must be a finite"),
    ],
)
def test_an_unusable_fit_is_refused_in_one_line(
    two: tuple[Path, Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str], edit, said
) -> None:
    a, _, fit = two
    doc = json.loads(fit.read_text())
    edit(doc)
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(doc))
    for args in (
        ["report", str(a), "--fit", str(bad), "-o", str(tmp_path / "rep")],
        ["diagnose", str(a), "--fit", str(bad), "--json", str(tmp_path / "d.json")],
        ["ride", "--fit", str(bad), "--clicks", "0", "--json", str(tmp_path / "r.json")],
    ):
        assert main(args) == 2, args
        err = capsys.readouterr().err
        assert said in err and err.count("\n") == 1, err
