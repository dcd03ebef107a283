"""Replay through the live view, and the sweep's wait for a temperature band."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from inprocess import cli
from shockdyno.errors import RigFault
from shockdyno.run.session import RigSession
from shockdyno.run.sweep import wait_for_temperature
from shockdyno.simrig import start_sim_rig

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "recordings" / "examples" / "example.mcap"
CLI = [sys.executable, "-m", "shockdyno.cli"]


def _replay(path: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    """A `shockdyno replay` process: its pace is the process's own."""
    cmd = [*CLI, "replay", str(path), *extra]
    return subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=60)


def test_replay_prints_one_line_per_test_with_the_recorded_peaks():
    res = cli("replay", str(EXAMPLE), "--fast")  # in this process: what it prints
    assert res.returncode == 0, res.stderr
    lines = [ln for ln in res.stdout.splitlines() if ln.startswith("test ")]
    assert len(lines) == 2
    assert "clicks=0" in lines[0] and "clicks=21" in lines[1]
    # 0 clicks (bleed shut) is the stiffer setting: larger peak compression force.
    fc = [float(ln.split("Fc=")[1].split("N")[0]) for ln in lines]
    assert fc[0] > fc[1] > 0
    assert "\x1b[" not in res.stdout  # plain text into a pipe


def test_replay_paces_the_recording_by_its_own_time():
    import time

    t0 = time.monotonic()
    res = _replay(EXAMPLE, "--speed", "2")  # 4.0 s of recording at 2x: about 2 s
    elapsed = time.monotonic() - t0
    assert res.returncode == 0, res.stderr
    assert elapsed >= 1.9


def test_replay_of_a_cut_off_recording_plays_what_survived(tmp_path):
    data = EXAMPLE.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(len(data) * 0.8)])
    res = cli("replay", str(cut), "--fast")
    assert res.returncode == 0, res.stderr
    assert "cut off" in res.stdout
    assert 1 <= sum(ln.startswith("test ") for ln in res.stdout.splitlines()) <= 2


@pytest.mark.parametrize("speed", ["-1", "0"])
def test_replay_refuses_a_speed_that_is_not_positive_in_one_line(speed):
    res = cli("replay", str(EXAMPLE), "--speed", speed)
    assert res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1
    assert "--fast" in res.stderr  # 0 used to mean "as fast as it can": say where that went


def test_temperature_band_wait_on_the_simulated_rig():
    sim = start_sim_rig(REPO / "rigs" / "sim.toml", speed=20, seed=3)
    with sim, RigSession(sim.rig_config()) as session:
        ambient = session.read_temperature_c()
        messages: list[str] = []
        got = wait_for_temperature(
            session, (ambient - 5, ambient + 5), 5.0, messages.append, sleep=lambda s: None
        )
        assert got == pytest.approx(ambient, abs=0.5) and not messages
        with pytest.raises(RigFault, match="did not reach"):
            wait_for_temperature(
                session, (ambient + 30, ambient + 40), 3.0, messages.append, sleep=lambda s: None
            )
        assert len(messages) == 1 and "waiting for damper temperature" in messages[0]


def test_sim_rig_on_a_busy_port_is_a_one_line_fault(capfd):
    import socket

    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        with pytest.raises(RigFault, match=f"cannot listen for Modbus on 127.0.0.1:{port}"):
            start_sim_rig(REPO / "rigs" / "sim.toml", modbus_port=port)
    assert capfd.readouterr().err == ""  # no library log lines beside the error
