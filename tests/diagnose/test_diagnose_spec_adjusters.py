"""`diagnose` refuses a spec whose adjusters are not the recording's, as `fit` does: each
bleed area's trend follows the adjuster on its path, which only the spec names, so the
diagnosis of a one-rod recording with a two-adjuster spec read every click against the
wrong adjuster and still printed a verdict."""

from __future__ import annotations

from pathlib import Path

import pytest

from shockdyno.cli import main

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "recordings" / "examples" / "example.mcap"
TWO = REPO / "sim" / "two-adjuster.toml"


def test_a_spec_of_other_adjusters_is_refused_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "d.json"
    argv = ["diagnose", str(EXAMPLE), "--spec", str(TWO), "--json", str(out), "--no-history"]
    assert main(argv) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if "error" in line]
    assert len(err) == 1 and "name adjusters none (one rod adjuster)" in err[0], err
    assert "has compression, rebound" in err[0] and "Traceback" not in err[0]
    assert not out.exists()
