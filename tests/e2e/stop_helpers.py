"""A sweep in a real child process against a simulated rig in this process, watched by an
independent Modbus client: what the drive does is seen on the wire, not taken from the host."""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from shockdyno.errors import RecordingError, RigFault
from shockdyno.record import open_recording
from shockdyno.rig.actuator import ActuatorStatus, ModbusActuator

REPO = Path(__file__).resolve().parents[2]
SIM_RIG = REPO / "rigs" / "sim.toml"
CLI = [sys.executable, "-m", "shockdyno.cli"]


def rig_file_for(sim: Any, folder: Path, text: str | None = None) -> Path:
    """rigs/sim.toml (or `text`) pointed at this simulated rig's ports."""
    text = (text or SIM_RIG.read_text()).replace("port = 5020", f"port = {sim.modbus_port}")
    text = text.replace("socket://127.0.0.1:5021", f"socket://127.0.0.1:{sim.serial_port}")
    # Its DAQ runs `speed` times real time: the frame rate the session checks says so.
    text = text.replace("[daq]\n", f"[daq]\ntime_scale = {sim.speed}\n", 1)
    path = folder / "rig.toml"
    path.write_text(text)
    return path


def spawn_sweep(
    rig: Path, out: Path, *extra: str, log: Path | None = None
) -> subprocess.Popen[bytes]:
    cmd = [*CLI, "sweep", "--rig", str(rig), "--clicks", "0,10", "--freq", "1",
           "--cycles", "3", "--warmup-cycles", "1", "-o", str(out), *extra]  # fmt: skip
    sink = log.open("wb") if log is not None else subprocess.PIPE
    return subprocess.Popen(cmd, cwd=REPO, stdout=sink, stderr=sink, stdin=subprocess.DEVNULL)


def still_running(proc: subprocess.Popen[bytes]) -> None:
    """Fail, with the child's own last words, if the sweep has already ended.

    Reading its pipes to the end also closes them: a failing test leaves no open file for
    the garbage collector to warn about in whichever test runs next."""
    if proc.poll() is None:
        return
    _, err = proc.communicate()
    last = (err or b"").decode(errors="replace").strip().splitlines()[-1:] or ["(no stderr)"]
    raise AssertionError(
        f"the sweep ended (exit {proc.returncode}) before it could be stopped: {last[0]}"
    )


def reap(proc: subprocess.Popen[bytes]) -> None:
    """However the test went: the child is gone and its pipes are closed."""
    if proc.poll() is None:
        proc.kill()
    proc.communicate()


class Probe:
    """A second Modbus master that only reads the drive's status."""

    def __init__(self, sim: Any) -> None:
        self.act = ModbusActuator(sim.rig_config())
        self.act.connect()
        self.centre = sim.rig.stroke_centre_m

    def status(self) -> ActuatorStatus | None:
        try:
            return self.act.status()
        except RigFault:
            return None

    def wait_for(self, done: Callable[[ActuatorStatus], bool], limit_s: float) -> float | None:
        """Seconds until done(status), or None if it never happened within limit_s."""
        t0 = time.monotonic()
        while time.monotonic() - t0 < limit_s:
            st = self.status()
            if st is not None and done(st):
                return time.monotonic() - t0
            time.sleep(0.01)
        return None

    def close(self) -> None:
        self.act.close()


def wait_running(probe: Probe, proc: subprocess.Popen[bytes], limit_s: float) -> None:
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline:
        still_running(proc)
        st = probe.status()
        if st is not None and st.running:
            return
        time.sleep(0.02)
    raise AssertionError(f"the ram was not running within {limit_s} s")


def wait_complete_tests(path: Path, n: int, proc: subprocess.Popen[bytes], limit_s: float) -> None:
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline:
        still_running(proc)
        if path.exists():
            try:
                if sum(m.status == "complete" for m in open_recording(path).tests) >= n:
                    return
            except RecordingError:
                pass
        time.sleep(0.1)
    raise AssertionError(f"no {n} complete tests within {limit_s} s")


def wait_test_running(path: Path, proc: subprocess.Popen[bytes], limit_s: float) -> None:
    """Until the recording shows a test begun and started (its start event is on disk)."""
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline:
        still_running(proc)
        if path.exists():
            try:
                rec = open_recording(path)
                if rec.interrupted and any(k == "start" for _, k, _ in rec.events):
                    return
            except RecordingError:
                pass
        time.sleep(0.05)
    raise AssertionError(f"no test running within {limit_s} s")
