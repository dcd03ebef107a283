"""The history from the command line: `fit` and `diagnose` add to it by default (the
database named by --history, else $SHOCKDYNO_HISTORY, else recordings/history.sqlite),
`--no-history` adds nothing, a history that cannot take the result warns and the
command's own result stands; `history` names a damper it does not know, lists the ones
it does."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

import pytest

from inprocess import cli
from shockdyno.cli import main

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "recordings" / "examples" / "example.mcap"  # imported: no damper id, no date


@pytest.fixture(scope="module")
def tagged(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The shipped example imported again with a damper id, as a shop's import would be."""
    out = tmp_path_factory.mktemp("rec") / "s46-0421.mcap"
    manifest = REPO / "recordings" / "examples" / "csv" / "manifest.csv"
    args = ["import", str(manifest), "-o", str(out), "--meta", "damper_id=S46-0421",
            "--meta", "operator=jd"]  # fmt: skip
    assert main(args) == 0
    return out


def test_fit_and_diagnose_add_to_the_history_named_by_the_environment(
    tagged: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    db = tmp_path / "shop" / "history.sqlite"
    monkeypatch.setenv("SHOCKDYNO_HISTORY", str(db))
    # In this process (the variable is read when the command runs): what it says and adds.
    fit = cli("fit", str(tagged), "--json", str(tmp_path / "f.json"), "--terms", "none")
    assert fit.returncode == 0, fit.stderr
    assert f"history: the fit of {tagged} (S46-0421) kept in {db}" in fit.stderr
    diag = ["diagnose", str(tagged), "--json", str(tmp_path / "d.json"), "--workers", "1"]
    assert main(diag) == 0
    con = sqlite3.connect(db)
    rows = con.execute(
        "SELECT r.damper_id, r.operator, s.kind, s.result_file FROM recordings r "
        "JOIN results s USING (sha256) ORDER BY s.kind"
    ).fetchall()
    gas = con.execute("SELECT gas_clicks, gas_force_n, gas_force_sd_n, source FROM gas_forces")
    gas_rows = gas.fetchall()
    con.close()
    assert rows == [
        ("S46-0421", "jd", "diagnose", str(tmp_path / "d.json")),
        ("S46-0421", "jd", "fit", str(tmp_path / "f.json")),
    ]
    # an imported recording: its gas force estimated (report/gas.py), with its σ
    ((g, force, sd, source),) = gas_rows
    assert (g, source) == (0, "estimated") and 225 < force < 240 and 0 < sd < 20


def test_no_history_adds_nothing_and_a_broken_history_only_warns(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    db = tmp_path / "history.sqlite"
    out = tmp_path / "fit.json"
    args = ["fit", str(EXAMPLE), "--json", str(out), "--terms", "none", "--history", str(db)]
    assert main([*args, "--no-history"]) == 0
    assert out.exists() and not db.exists()
    db.write_text("someone's notes, not a database\n")
    assert main([*args, "--force"]) == 0  # the fit is written; the history says why not
    err = capsys.readouterr().err
    assert "warning: history not updated" in err and "not an SQLite database" in err
    assert json.loads(out.read_text())["clicks"]
    assert db.read_text() == "someone's notes, not a database\n"


def test_history_lists_dampers_and_names_an_unknown_one(
    tagged: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    db = tmp_path / "history.sqlite"
    assert main(["history", "S46-0421", "--history", str(db)]) == 2
    assert "no history at" in capsys.readouterr().err
    for rec in (tagged, EXAMPLE):
        fit = ["fit", str(rec), "--json", str(tmp_path / f"{rec.stem}.json"), "--terms", "none"]
        assert main([*fit, "--history", str(db)]) == 0
    capsys.readouterr()
    assert main(["history", "--list", "--history", str(db)]) == 0
    listed = capsys.readouterr().out
    assert "2 dampers" in listed and "S46-0421: 1 recordings" in listed
    assert "(no damper id): 1 recordings" in listed
    assert main(["history", "S46-9999", "--history", str(db)]) == 2
    err = capsys.readouterr().err
    assert "no recording of damper 'S46-9999'" in err and "S46-0421" in err
    assert err.count("\n") == 1
    assert main(["history", "--history", str(db)]) == 2
    assert "give a damper id" in capsys.readouterr().err
    assert main(["history", "S46-0421", "--history", str(db)]) == 0
    assert "one recording: nothing to compare yet" in capsys.readouterr().out
