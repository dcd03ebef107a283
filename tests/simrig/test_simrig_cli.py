"""`shockdyno sim-rig` as a user runs it."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import serial

from shockdyno.cli import main
from shockdyno.rig.frames import FrameDecoder

REPO = Path(__file__).resolve().parents[2]
EXE = Path(sys.executable).parent / "shockdyno"


def test_prints_one_line_per_endpoint_and_serves_frames(tmp_path: Path) -> None:
    rig = tmp_path / "rig.toml"
    text = (REPO / "rigs" / "sim.toml").read_text()
    rig.write_text(text.replace("port = 5020", "port = 0").replace(":5021", ":0"))
    proc = subprocess.Popen(
        [str(EXE), "sim-rig", "--rig", str(rig), "--serial", "both", "--duration", "2.5"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        lines = [proc.stdout.readline().strip() for _ in range(3)]
        assert lines[0].startswith("modbus tcp://127.0.0.1:")
        assert lines[1].startswith("serial socket://127.0.0.1:")
        assert lines[2].startswith("serial /dev/pts/")
        port = serial.serial_for_url(lines[1].split(" ", 1)[1], timeout=0.3)
        dec = FrameDecoder()
        got = sum(len(dec.feed(port.read(2000))) for _ in range(3))
        port.close()
        assert got > 50 and dec.corrupt_frames == 0
    finally:
        _, err = proc.communicate(timeout=20)
    assert proc.returncode == 0, err


def test_user_mistakes_are_one_line(capsys) -> None:
    assert main(["sim-rig", "--rig", "nowhere.toml"]) == 2
    assert capsys.readouterr().err == "shockdyno sim-rig: error: rig file not found: nowhere.toml\n"
    assert main(["sim-rig", "--fault", "meteor@3"]) == 2
    assert "unknown fault 'meteor'" in capsys.readouterr().err
    assert main(["sim-rig", "--speed", "-1"]) == 2
    assert (
        capsys.readouterr().err
        == "shockdyno sim-rig: error: --speed must be a number > 0, got -1\n"
    )
