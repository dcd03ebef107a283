"""Mistakes a user makes get one line and a non-zero exit, never a traceback (issue 21.7,
21.8): bad seeds, an empty --terms list in fit and diagnose alike, a cut-off recording."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from shockdyno.cli import main

REPO = Path(__file__).resolve().parents[1]
EXAMPLE = REPO / "recordings" / "examples" / "example.mcap"


@pytest.mark.parametrize("command", ["fit", "diagnose", "ride", "sweep", "sim-rig"])
@pytest.mark.parametrize("seed", ["-1", "4294967296", "x"])
def test_a_bad_seed_is_one_line(
    command: str, seed: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as ex:
        main([command, "--seed", seed])
    assert ex.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert "--seed" in err[-1] and "a seed is" in err[-1]


@pytest.mark.parametrize("command", ["fit", "diagnose"])
@pytest.mark.parametrize(("terms", "said"), [("", "empty list"), (",", "empty list"),
                                             ("friction,,thermal", "empty name")])  # fmt: skip
def test_one_terms_grammar_and_an_empty_list_is_an_error(
    command: str, terms: str, said: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "x.json"
    assert main([command, str(EXAMPLE), "--terms", terms, "--json", str(out)]) == 2
    err = capsys.readouterr().err
    assert said in err and err.count("\n") == 1 and not out.exists()


def test_diagnose_with_no_candidates_is_an_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["diagnose", str(EXAMPLE), "--terms", "none", "--json", str(tmp_path / "d")]) == 2
    assert "at least one candidate" in capsys.readouterr().err


@pytest.mark.parametrize("workers", ["0", "-2"])
def test_diagnose_needs_a_worker(
    workers: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "d.json"
    assert main(["diagnose", str(EXAMPLE), "--workers", workers, "--json", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--workers must be at least 1" in err and err.count("\n") == 1 and not out.exists()


@pytest.mark.parametrize("command", ["fit", "diagnose"])
def test_a_cut_off_recording_says_what_it_lost(
    command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rec = tmp_path / "cut.mcap"
    data = EXAMPLE.read_bytes()
    rec.write_bytes(data[: int(len(data) * 0.75)])  # test 0 whole, test 1 lost
    out = tmp_path / "out.json"
    assert main([command, str(rec), "--json", str(out)]) == 0
    err = capsys.readouterr().err
    assert "warning:" in err and "cut off" in err and "1 tests read" in err
    doc = json.loads(out.read_text())
    assert "cut off" in doc["info"]["recording_loss"]


def test_a_whole_recording_has_no_loss_note(tmp_path: Path) -> None:
    rec = tmp_path / "whole.mcap"
    shutil.copy(EXAMPLE, rec)
    out = tmp_path / "fit.json"
    assert main(["fit", str(rec), "--json", str(out)]) == 0
    assert "recording_loss" not in json.loads(out.read_text())["info"]


def _results(tmp_path: Path) -> dict[str, Path]:
    """A real fit, a diagnosis-shaped and a ride-shaped JSON, and the example recording."""
    from shockdyno.fit.result import FitResult
    from shockdyno.model import default_spec_path

    fit = tmp_path / "FIT.json"
    FitResult.from_spec(default_spec_path(), (0, 10)).save(fit)
    diag = tmp_path / "DIAG.json"
    diag.write_text(json.dumps({"mismatch": {}, "findings": [], "verdict": {}}))
    ride = tmp_path / "RIDE.json"
    ride.write_text(json.dumps({"rms": [], "flags": {}}))
    return {"rec": EXAMPLE, "fit": fit, "diag": diag, "ride": ride}


@pytest.mark.parametrize(
    ("argv", "given", "said"),
    [
        (["ride", "--fit", "{rec}"], "rec", "is an MCAP recording; expected a fit result"),
        (["ride", "--fit", "{diag}"], "diag", "is a diagnosis (DIAG.json"),
        (["report", "{rec}", "--diagnose", "{fit}"], "fit", "is a fit result (FIT.json"),
        (["report", "{rec}", "--ride", "{diag}"], "diag", "expected a ride study"),
        (["report", "{rec}", "--fit", "{ride}"], "ride", "is a ride study (RIDE.json"),
        (["diagnose", "{rec}", "--fit", "{rec}"], "rec", "is an MCAP recording"),
    ],
)
def test_a_wrong_result_file_is_named_in_one_short_line(
    argv: list[str], given: str, said: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`ride --fit demo.mcap` printed an 11.9 MB "line" of the recording's bytes, and
    `report --diagnose FIT.json` exited 0 with empty rows (issue 20)."""
    paths = _results(tmp_path)
    args = [a.format(**{k: str(v) for k, v in paths.items()}) for a in argv]
    out = tmp_path / "out"
    args += ["-o", str(out)] if argv[0] == "report" else ["--json", str(tmp_path / "o.json")]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert said in err and str(paths[given]) in err, err
    assert "\n" not in err and len(err) < 300 and "Traceback" not in err
    assert not out.exists() and not (tmp_path / "o.json").exists()


def _deep(tmp_path: Path) -> dict[str, Path]:
    files = {
        "deep.toml": "a = " + "[" * 100_000 + "]" * 100_000 + "\n",
        "deep.json": "[" * 100_000 + "]" * 100_000,
    }
    fit = json.loads(json.dumps({"spec_path": "x.toml", "globals": {}, "clicks": []}))
    files["digits.json"] = json.dumps(fit).replace(
        '"globals": {}', '"globals": {"g": ' + "7" * 5000 + "}"
    )
    out = {}
    for name, text in files.items():
        (tmp_path / name).write_text(text)
        out[name] = tmp_path / name
    return out


def test_no_traceback_for_the_inputs_of_issue_46(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    """Issue 46.10: a rig TOML or fit JSON nested 100 000 deep (RecursionError), a
    5000-digit integer in a fit JSON, a NUL byte in a manifest's file name, `sim-rig
    --speed nan`, `--duration -1`, `--modbus-port 70000` ('port in use?')."""
    f = _deep(tmp_path)
    manifest = tmp_path / "m" / "manifest.csv"
    shutil.copytree(REPO / "recordings" / "examples" / "csv", manifest.parent)
    rows = manifest.read_text().splitlines()
    rows[1] = rows[1].replace(".csv", "\x00.csv", 1)
    manifest.write_text("\n".join(rows) + "\n")
    report = ["report", str(EXAMPLE), "-o", str(tmp_path / "r"), "--fit"]
    cases = [
        (["sweep", "--rig", str(f["deep.toml"]), "-o", str(tmp_path / "x.mcap")], "nested too"),
        ([*report, str(f["deep.json"])], "nested too deeply"),
        ([*report, str(f["digits.json"])], "4300 digits"),
        (["import", str(manifest), "-o", str(tmp_path / "i.mcap")], "NUL character"),
        (["sim-rig", "--speed", "nan", "--duration", "0.1"], "--speed must be a number > 0"),
        (["sim-rig", "--duration", "-1"], "--duration must be a number of seconds > 0"),
        (["sim-rig", "--modbus-port", "70000"], "--modbus-port must be 0-65535"),
        (["demo", "--speed", "nan", "--out-dir", str(tmp_path / "d")], "speed must be a number"),
    ]
    for args, said in cases:
        assert main(args) == 2, args
        err = capsys.readouterr().err
        assert said in err and err.count("\n") == 1 and "Traceback" not in err, (args, err)


def test_a_test_record_of_the_wrong_type_is_a_bad_message(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    """A /dyno/test record with frequency_hz "fast" was a TypeError in info and fit: it is
    a message that could not be read, and its test reads as interrupted."""
    import sys
    from dataclasses import replace

    sys.path.insert(0, str(REPO / "tests" / "record"))
    from rec_helpers import block, meta

    from shockdyno.record import RecordingWriter, open_recording

    path = tmp_path / "fast.mcap"
    with RecordingWriter(path, metadata={}) as w:
        for k in range(2):
            w.begin_test(meta(k, k))
            w.write_samples(block(k * 1000, 500))
            w.end_test(replace(meta(k, k), frequency_hz="fast") if k == 0 else meta(k, k))
    rec = open_recording(path)
    assert rec.parts[0].bad_messages == 1 and [m.index for m in rec.tests] == [1]
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "1 messages could not be read" in out and "interrupted" in out


def test_output_to_a_reader_that_goes_away_is_not_an_error() -> None:
    """`info REC | head` printed 'error: Broken pipe' and exited 2."""
    import subprocess
    import sys

    p = subprocess.Popen(
        [sys.executable, "-m", "shockdyno.cli", "info", str(EXAMPLE)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert p.stdout is not None and p.stderr is not None
    p.stdout.close()  # before it writes: its first write meets a closed pipe
    err = p.stderr.read()
    p.stderr.close()
    assert p.wait(timeout=60) == 0 and err == b""


def test_export_refuses_a_damper_no_dyno_measures(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    """Issue 46.11: a fit with a gas pressure of 1e300 Pa was written out as a damper
    table of 1.5e296 N."""
    from shockdyno.fit.result import FitResult
    from shockdyno.model.spec import default_spec_path

    fit = FitResult.from_spec(default_spec_path(), [0, 21])
    good, bad = tmp_path / "good.json", tmp_path / "bad.json"
    fit.save(good)
    doc = json.loads(good.read_text())
    doc["globals"]["gas_pressure_pa"] = 1e300
    bad.write_text(json.dumps(doc))
    assert main(["export", str(bad), "--damper-table", str(tmp_path / "t")]) == 2
    err = capsys.readouterr().err
    assert "beyond any damper dyno's 1e+06 N; not written" in err and err.count("\n") == 1
    assert not (tmp_path / "t").exists()
    assert main(["export", str(good), "--damper-table", str(tmp_path / "t")]) == 0


@pytest.mark.parametrize(
    "option", ["--amplitude-mm", "--gas-pressure-bar", "--reversal-accel-m-s2"]
)
@pytest.mark.parametrize("value", ["inf", "-inf", "nan", "0", "-5", "x"])
def test_a_sweep_quantity_that_is_no_positive_number_is_refused_by_the_parser(
    option: str, value: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """An infinite amplitude was let through to the plan, which said "must be > 0, got inf"."""
    with pytest.raises(SystemExit) as ex:
        main(["sweep", "--rig", "rigs/sim.toml", "-o", "never.mcap", f"{option}={value}"])
    assert ex.value.code == 2
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert option in last and ("finite number > 0" in last or "not a number" in last)
