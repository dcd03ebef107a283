"""A command's one-line errors start with the command as typed, as argparse's own do:
`shockdyno rig jog: error: ...`, not `shockdyno rig: error: ...` (issue 48's new-user
review), and a command without subcommands keeps its `shockdyno sweep: error: ...`."""

from __future__ import annotations

from pathlib import Path

import pytest

from shockdyno.cli import main

REPO = Path(__file__).resolve().parents[1]
SIM_RIG = REPO / "rigs" / "sim.toml"


def _one_line(capsys: pytest.CaptureFixture[str]) -> str:
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    return lines[0]


def test_rig_jog_errors_name_the_subcommand(capsys: pytest.CaptureFixture[str]) -> None:
    # Refused before anything connects: the target is outside the rig's travel.
    assert main(["rig", "jog", "--rig", str(SIM_RIG), "--to-mm", "999"]) == 2
    line = _one_line(capsys)
    assert line.startswith("shockdyno rig jog: error: target +999.00 mm from centre"), line
    # argparse's usage errors of the same subcommand begin the same way.
    with pytest.raises(SystemExit):
        main(["rig", "jog", "--rig", str(SIM_RIG)])
    assert "shockdyno rig jog: error:" in capsys.readouterr().err


def test_a_command_without_subcommands_keeps_its_prefix(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    missing = tmp_path / "no-such-rig.toml"
    assert main(["sweep", "--rig", str(missing), "-o", str(tmp_path / "x.mcap")]) == 2
    assert _one_line(capsys).startswith("shockdyno sweep: error: ")
