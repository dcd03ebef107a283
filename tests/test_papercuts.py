"""The papercuts of issue 47.8, each as a user meets it: the wrong kind of file named in
one line, help that says a default once, a sweep refused before its simulated rig starts,
an unreachable rig with a hint, no abort reason on a complete test's export, and the
model table that says it shows raw force."""

from __future__ import annotations

import argparse
import csv
import re
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest

from report_helpers import sweep_tests, write_recording
from rig_files import rig_on_closed_ports
from shockdyno.cli import build_parser, main
from shockdyno.fit.result import FitResult
from shockdyno.model.spec import default_spec_path

REPO = Path(__file__).resolve().parents[1]
CLI = [sys.executable, "-m", "shockdyno.cli"]
EXAMPLE = REPO / "recordings" / "examples" / "example.mcap"
SIM_RIG = REPO / "rigs" / "sim.toml"


def _one_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    return err.strip()


def test_import_of_a_recording_says_what_it_is(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "x.mcap"
    assert main(["import", str(EXAMPLE), "-o", str(out)]) == 2
    line = _one_line(capsys)
    assert "is an MCAP recording; import reads a manifest CSV" in line and "utf-8" not in line
    assert not out.exists()


@pytest.mark.parametrize(
    "command",
    [
        ["fit", "{f}", "--json", "{o}/x.json"],
        ["diagnose", "{f}", "--json", "{o}/x.json"],
        ["report", "{f}", "-o", "{o}/page"],
        ["info", "{f}"],
        ["export", "{f}", "--csv", "{o}/csv"],
    ],
)
def test_a_fit_given_as_a_recording_is_named_a_fit_result(
    command: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    fit = tmp_path / "FIT.json"
    FitResult.from_spec(default_spec_path(), (0, 10)).save(fit)
    args = [a.format(f=fit, o=tmp_path) for a in command]
    assert main(args) == 2
    line = _one_line(capsys)
    assert f"{fit}: not an MCAP file, but a fit result (FIT.json, from shockdyno fit)" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["FIT.json"]


def test_a_manifest_given_to_fit_is_named_a_csv(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    manifest = REPO / "recordings" / "examples" / "csv" / "manifest.csv"
    assert main(["fit", str(manifest), "--json", str(tmp_path / "x.json")]) == 2
    assert "but a CSV file (a manifest CSV becomes a recording with shockdyno import)" in (
        _one_line(capsys)
    )


def _helps(parser: argparse.ArgumentParser, name: str = "shockdyno") -> list[tuple[str, str]]:
    out = [(name, parser.format_help())]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child_name, child in action.choices.items():
                out += _helps(child, f"{name} {child_name}")
    return out


def test_every_help_says_a_default_once() -> None:
    # `fit --help` read "seed of the GA (default 0) (default 0)".
    twice = re.compile(r"\(default ([^)]*)\)\s+\(default \1\)")
    for name, text in _helps(build_parser()):
        flat = " ".join(text.split())
        assert not twice.search(flat), f"{name}: {twice.search(flat)}"
    fit = dict(_helps(build_parser()))["shockdyno fit"]
    assert "seed of the GA (default 0)" in " ".join(fit.split())


def test_sweep_start_sim_refuses_an_existing_recording_before_the_rig_starts(
    tmp_path: Path,
) -> None:
    out = tmp_path / "old.mcap"
    out.write_bytes(b"an earlier recording")
    args = ["sweep", "--rig", str(SIM_RIG), "--start-sim", "--clicks", "0", "--freq", "1"]
    done = subprocess.run([*CLI, *args, "-o", str(out)], capture_output=True, text=True,
                          timeout=120, cwd=REPO)  # fmt: skip
    assert done.returncode == 2
    assert done.stdout == ""  # no endpoint printed: the simulated rig never started
    assert done.stderr.strip().endswith("exists: use --force to overwrite or --resume to continue")
    assert out.read_bytes() == b"an earlier recording"


def test_an_unreachable_rig_says_what_to_try(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim = rig_on_closed_ports(tmp_path, simulated=True)
    out = tmp_path / "new.mcap"
    assert main(["sweep", "--rig", str(sim), "--clicks", "0", "--freq", "1", "-o", str(out)]) == 3
    line = _one_line(capsys)
    assert "cannot connect; is the simulated rig running?" in line
    assert f"shockdyno sim-rig --rig {sim}" in line and "--start-sim" in line
    for command in ("check", "tare"):
        assert main(["rig", command, "--rig", str(sim)]) == 3
        assert f"shockdyno sim-rig --rig {sim}" in _one_line(capsys)
    real = rig_on_closed_ports(tmp_path, simulated=False)
    assert main(["rig", "check", "--rig", str(real)]) == 3
    line = _one_line(capsys)
    assert "is the drive powered" in line and "sim-rig" not in line


def test_export_csv_gives_no_abort_reason_to_a_complete_test(tmp_path: Path) -> None:
    # A sweep stores its motion check's note in abort_reason on complete tests as well.
    complete, aborted = sweep_tests((3,), (1.0, 1.5))
    complete = replace(
        complete, meta=replace(complete.meta, abort_reason="1 Hz run: measured 1 Hz")
    )
    aborted = replace(
        aborted, meta=replace(aborted.meta, status="aborted", abort_reason="operator Ctrl-C")
    )
    rec = write_recording(tmp_path / "rec.mcap", [complete, aborted], {"damper_id": "x"})
    assert main(["export", str(rec), "--csv", str(tmp_path / "csv")]) == 0
    rows = list(csv.DictReader((tmp_path / "csv" / "manifest.csv").read_text().splitlines()))
    assert [(r["status"], r["abort_reason"]) for r in rows] == [
        ("complete", ""),
        ("aborted", "operator Ctrl-C"),
    ]
    only_complete = write_recording(tmp_path / "one.mcap", [complete], {"damper_id": "x"})
    assert main(["export", str(only_complete), "--csv", str(tmp_path / "csv1")]) == 0
    assert "abort_reason" not in (tmp_path / "csv1" / "manifest.csv").read_text()


def test_the_model_table_says_it_is_raw_force(capsys: pytest.CaptureFixture[str]) -> None:
    # The sweep's lines show damping force (gas removed), the table raw force: it says so.
    assert main(["demo", "--table"]) == 0
    flat = " ".join(capsys.readouterr().out.split())
    assert "raw: the 231 N gas force included (damping force = this − 231 N" in flat
