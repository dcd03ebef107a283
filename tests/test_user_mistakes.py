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
