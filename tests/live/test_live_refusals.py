"""The live view's failures: a busy port stops the sweep before the drive is touched; a
viewer that fails or falls behind never stops or slows the sweep."""

from __future__ import annotations

import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from inprocess import cli
from shockdyno.live.publisher import LivePublisher
from shockdyno.live.server import LiveServer
from shockdyno.record.types import TestMeta
from shockdyno.samples import SampleBlock
from shockdyno.simrig import start_sim_rig

REPO = Path(__file__).resolve().parents[2]
SIM_RIG = REPO / "rigs" / "sim.toml"
CLI = [sys.executable, "-m", "shockdyno.cli"]


def _rig_file(sim, folder: Path) -> Path:
    text = SIM_RIG.read_text().replace("port = 5020", f"port = {sim.modbus_port}")
    text = text.replace("socket://127.0.0.1:5021", f"socket://127.0.0.1:{sim.serial_port}")
    text = text.replace("[daq]\n", f"[daq]\ntime_scale = {sim.speed}\n", 1)
    path = folder / "rig.toml"
    path.write_text(text)
    return path


def test_a_busy_port_is_one_line_and_the_drive_is_never_enabled(tmp_path, monkeypatch):
    with socket.socket() as busy, start_sim_rig(SIM_RIG, speed=4) as sim:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        writes: list[tuple[int, list[int]]] = []  # every Modbus write the drive receives
        real_write = sim.registers.write

        def write(registers, start, address, values):  # type: ignore[no-untyped-def]
            writes.append((address, list(values)))
            return real_write(registers, start, address, values)

        monkeypatch.setattr(sim.registers, "write", write)
        out = tmp_path / "x.mcap"
        proc = subprocess.run(
            [*CLI, "sweep", "--rig", str(_rig_file(sim, tmp_path)), "--clicks", "0",
             "--freq", "1", "--cycles", "1", "-o", str(out), "--live", "--live-port", str(port)],
            cwd=REPO, capture_output=True, text=True, timeout=60,
        )  # fmt: skip
        time.sleep(0.5)  # a write on its way would have arrived
        assert proc.returncode == 2, proc.stderr
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and "Traceback" not in proc.stderr
        assert f"--live-port {port}" in lines[0] and "in use" in lines[0]
        assert writes == [] and not sim.engine.drive.enabled
        assert not out.exists()


def test_a_bad_live_host_is_one_line(tmp_path):
    proc = cli("sweep", "--rig", str(SIM_RIG), "--start-sim", "--clicks", "0", "--freq", "1",
               "-o", str(tmp_path / "x.mcap"), "--live", "--live-host", "192.0.2.1")  # fmt: skip
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    # An address of no interface here (TEST-NET-1: binding to it sends nothing anywhere).
    assert len(lines) == 1 and "error: --live-host 192.0.2.1: cannot listen there" in lines[0]
    assert "modbus" not in proc.stdout  # the simulated rig never started


def _meta() -> TestMeta:
    return TestMeta(index=0, clicks=0, gas_clicks=0, frequency_hz=1.0, amplitude_m=0.03,
                    sample_rate_hz=1000.0, warmup_cycles=1, measured_cycles=1)  # fmt: skip


def _block(lo: int, n: int = 50) -> SampleBlock:
    seq = np.arange(lo, lo + n, dtype=np.int64)
    t = seq / 1000.0
    x = 0.03 * np.sin(2 * np.pi * t)
    return SampleBlock(seq, t, x, 1e4 * x, np.full(n, 40.0), np.ones(n, np.uint16))


class _StuckServer:
    """A server whose send never returns until released: the slowest viewer possible."""

    def __init__(self) -> None:
        self.release = threading.Event()
        self.stopped = False
        self.warnings = []

    warnings: list[str]

    def watched(self, topic: str) -> bool:
        return True

    def warn(self, text: str) -> None:
        self.warnings.append(text)

    def send(self, topic: str, log_time_ns: int, payload: bytes) -> None:
        self.release.wait()

    def stop(self) -> None:
        self.stopped = True


def test_a_stuck_viewer_never_holds_the_caller_and_drops_are_counted():
    server = _StuckServer()
    live = LivePublisher(server, warn=lambda text: None, max_samples=1000)  # type: ignore[arg-type]
    live.begin_test(_meta())
    for i in range(200):  # 10 000 samples: 10 s of a 1 kHz DAQ, with nobody reading
        live.write_samples(_block(50 * i))  # returns although the thread is stuck
    live.end_test(_meta())
    # What it costs the loop per call is measured in benchmarks/bench_live.py.
    assert live.counts.refused_samples >= 10_000 - 1000 - 50
    server.release.set()
    live.close(drain_s=5.0)
    c = live.counts
    assert c.samples + c.dropped_samples == 10_000  # every sample accounted for
    # The viewers were told (Foxglove's problems list), with the count at the time.
    assert server.warnings and "samples dropped so far" in server.warnings[-1]
    assert "dropped" in live.summary() and server.stopped


class _FailingServer(_StuckServer):
    def send(self, topic: str, log_time_ns: int, payload: bytes) -> None:
        raise RuntimeError("client misbehaved")


def test_a_failing_viewer_is_one_warning_and_the_calls_go_on():
    warned: list[str] = []
    server = _FailingServer()
    live = LivePublisher(server, warn=warned.append)  # type: ignore[arg-type]
    live.begin_test(_meta())
    for i in range(100):
        live.write_samples(_block(50 * i))
        time.sleep(0.001)
    live.write_event(5.0, "info", "still going")
    live.end_test(_meta())
    live.close()
    assert len(warned) == 1 and "client misbehaved" in warned[0]
    assert "the sweep goes on" in warned[0]
    assert live.counts.dropped_samples > 0 and server.stopped


def test_the_server_closes_at_teardown_and_the_port_is_free_again():
    server = LiveServer("127.0.0.1", 0)
    port = server.port
    server.stop()  # its listener closes in the server's own thread, a few ms later
    deadline = time.monotonic() + 2.0
    while True:
        with socket.socket() as again:
            try:
                again.bind(("127.0.0.1", port))  # nothing listens there any more
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise
        time.sleep(0.01)


@pytest.mark.parametrize("port", [-1, 70000])
def test_a_port_out_of_range_is_refused(port):
    from shockdyno.errors import ConfigError

    with pytest.raises(ConfigError, match="--live-port"):
        LiveServer("127.0.0.1", port)


def test_live_port_without_live_is_refused(tmp_path):
    proc = cli("sweep", "--rig", str(SIM_RIG), "--start-sim", "--clicks", "0", "--freq", "1",
               "-o", str(tmp_path / "x.mcap"), "--live-port", "9000")  # fmt: skip
    assert proc.returncode == 2
    assert proc.stderr.strip().endswith("error: --live-port is for the live view: add --live")
    assert "modbus" not in proc.stdout and not (tmp_path / "x.mcap").exists()


def test_an_existing_recording_is_refused_before_the_live_view_starts(tmp_path):
    out = tmp_path / "x.mcap"
    out.write_bytes(b"")
    proc = cli("sweep", "--rig", str(SIM_RIG), "--clicks", "0", "--freq", "1", "-o", str(out),
               "--live")  # fmt: skip
    assert proc.returncode == 2 and "exists: use --force" in proc.stderr
    assert "live view" not in proc.stdout  # no URL to open for a sweep that never runs
