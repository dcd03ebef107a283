"""`shockdyno rig check | jog | tare` against the simulated rig on its real wires.

What the drive did is seen from outside the command: the simulated drive's register
writes are logged at the server, and a second DAQ client records the ram's LVDT trace.
"""

from __future__ import annotations

import json
import socket
import threading
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from shockdyno.cli import main
from shockdyno.model.composite import DamperModel, ModelInputs
from shockdyno.model.spec import default_spec_path
from shockdyno.rig.config import RigConfig, load_rig
from shockdyno.rig.daq import SerialDaq
from shockdyno.samples import SampleBlock

REPO = Path(__file__).resolve().parents[2]
SIM_RIG = REPO / "rigs" / "sim.toml"
PARKED_M = 0.065 - 0.075  # rigs/sim.toml: simulation.initial_position_m - rig.stroke_centre_m


def rig_file(sim: Any, folder: Path, text: str | None = None, name: str = "rig.toml") -> Path:
    """rigs/sim.toml (or `text`) pointed at this simulated rig's ports."""
    text = (text or SIM_RIG.read_text()).replace("port = 5020", f"port = {sim.modbus_port}")
    text = text.replace("socket://127.0.0.1:5021", f"socket://127.0.0.1:{sim.serial_port}")
    # Its DAQ runs `speed` times real time: the frame rate the session checks says so.
    text = text.replace("[daq]\n", f"[daq]\ntime_scale = {sim.speed}\n", 1)
    path = folder / name
    path.write_text(text)
    return path


def log_writes(sim: Any) -> list[tuple[int, list[int]]]:
    """Every Modbus write the simulated drive receives from now on (address, words)."""
    writes: list[tuple[int, list[int]]] = []
    inner = sim.registers.write

    def write(registers: list[int], start: int, address: int, values: list[int]) -> Any:
        writes.append((address, list(values)))
        return inner(registers, start, address, values)

    sim.registers.write = write
    return writes


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Watcher:
    """A second DAQ client: the ram's LVDT trace, independent of the command under test."""

    def __init__(self, rig: RigConfig) -> None:
        self.daq = SerialDaq(rig.daq, rig.stroke_centre_m)
        self.blocks: list[SampleBlock] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            block = self.daq.read()
            if len(block):
                self.blocks.append(block)

    def stop(self) -> SampleBlock:
        self._stop.set()
        self._thread.join(5)
        self.daq.close()
        return SampleBlock.concat(self.blocks)


def test_check_healthy_rig_reads_everything_and_writes_nothing(
    sim_rig_factory: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim = sim_rig_factory(speed=1.0)  # the frame rate is judged against the nominal 1 kHz
    rig = rig_file(sim, tmp_path)
    writes = log_writes(sim)
    out = tmp_path / "check.json"
    assert main(["rig", "check", "--rig", str(rig), "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "all well" in text
    doc = json.loads(out.read_text())
    assert doc["ok"] and doc["problems"] == []
    daq = {f["what"]: f["value"] for f in doc["daq"]}
    # The ram stands where the rig file parks it, seen by the LVDT and by the drive.
    assert daq["LVDT"].startswith(f"{PARKED_M * 1e3:+.2f} mm")
    drive = {f["what"]: f["value"] for f in doc["drive"]}
    assert drive["drive position"] == f"{PARKED_M * 1e3:+.2f} mm from centre"
    rate = float(daq["frame rate"].split()[0])
    assert 950 < rate < 1050
    every = len(load_rig(rig).registers.registers)
    assert len([f for f in doc["drive"] if f["what"].startswith("register ")]) == every
    # Read only: no write reached the drive, it stayed disabled and the ram did not move.
    assert writes == []
    enabled, position = sim.call(lambda: (sim.engine.drive.enabled, sim.engine.drive.position_m))
    assert not enabled
    assert position == pytest.approx(0.065, abs=1e-5)


def test_check_lists_what_is_wrong(
    sim_rig_factory: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A rig file that says 500 frames/s and a stroke centre 60 mm off: both named, exit 1."""
    sim = sim_rig_factory(speed=1.0)
    text = SIM_RIG.read_text().replace("sample_rate_hz = 1000.0", "sample_rate_hz = 500.0")
    text = text.replace("stroke_centre_m = 0.075", "stroke_centre_m = 0.125")
    rig = rig_file(sim, tmp_path, text)
    assert main(["rig", "check", "--rig", str(rig), "--json", "-"]) == 1
    doc = json.loads(capsys.readouterr().out)
    problems = " | ".join(doc["problems"])
    assert "frame rate" in problems and "daq.sample_rate_hz" in problems
    assert "drive position: -60.00 mm from centre is outside the travel ±45 mm" in problems
    assert "LVDT:" in problems


def test_check_dead_or_wrong_port_is_one_line(
    sim_rig_factory: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim = sim_rig_factory(speed=1.0)
    good = SIM_RIG.read_text()
    dead = good.replace("port = 5020", f"port = {free_port()}")
    wrong = good.replace("port = 5020", f"port = {sim.serial_port}")  # the DAQ's, not Modbus
    for text, said in ((dead, "cannot connect"), (wrong, "not answering")):
        rig = rig_file(sim, tmp_path, text)
        assert main(["rig", "check", "--rig", str(rig)]) == 3
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and said in err and "Traceback" not in err
    no_daq = good.replace("socket://127.0.0.1:5021", f"socket://127.0.0.1:{free_port()}")
    path = tmp_path / "no-daq.toml"
    path.write_text(no_daq.replace("port = 5020", f"port = {sim.modbus_port}"))
    assert main(["rig", "check", "--rig", str(path)]) == 3
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "DAQ" in err and "cannot open" in err


def test_jog_reaches_target_and_ends_centred_and_disabled(
    sim_rig_factory: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim = sim_rig_factory(speed=20.0)
    rig = rig_file(sim, tmp_path)
    watcher = Watcher(sim.rig_config())
    try:
        assert main(["rig", "jog", "--rig", str(rig), "--to-mm", "12"]) == 0
    finally:
        trace = watcher.stop()
    out = capsys.readouterr().out
    assert "ended: centred and disabled" in out
    x = trace.displacement_m
    # From the parked -10 mm to centre, +12 mm, held, back to centre; never beyond.
    assert x.max() == pytest.approx(0.012, abs=3e-4)
    held = x > 0.0115
    assert held.sum() >= 0.4 * sim.rig.daq.sample_rate_hz  # the 0.5 s hold, on the DAQ clock
    assert abs(x[-50:].mean()) < 1e-3
    v = (x[20:] - x[:-20]) * sim.rig.daq.sample_rate_hz / 20  # over 20 ms: LVDT noise 0.1 mm/s
    assert np.abs(v).max() < 1.2 * sim.rig.ramp.move_velocity_m_s  # slow, at the ramp speed
    enabled, position = sim.call(lambda: (sim.engine.drive.enabled, sim.engine.drive.position_m))
    assert not enabled
    assert position == pytest.approx(sim.rig.stroke_centre_m, abs=1e-3)


@pytest.mark.parametrize("how", [["--to-mm", "60"], ["--by-mm", "-40"]])
def test_jog_beyond_travel_is_refused_before_moving(
    how: list[str], sim_rig_factory: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim = sim_rig_factory(speed=20.0)
    rig = rig_file(sim, tmp_path)
    writes = log_writes(sim)
    assert main(["rig", "jog", "--rig", str(rig), *how]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "outside the rig's travel of ±45 mm" in err
    assert writes == []  # --by-mm reads where the ram is; nothing is written


def uncharged_spec(folder: Path) -> Path:
    """The shipped damper with its gas at atmospheric pressure: no force at rest, as a load
    cell with nothing mounted carries none."""
    text = default_spec_path().read_text()
    assert text.count("gas_pressure_pa = 1.6e6 ") == 1
    path = folder / "uncharged.toml"
    path.write_text(text.replace("gas_pressure_pa = 1.6e6 ", "gas_pressure_pa = 101325.0 "))
    return path


def _tare(sim: Any, tmp_path: Path, name: str, capsys: Any) -> tuple[float, float, Path]:
    rig = rig_file(sim, tmp_path, name=f"{name}.toml")
    copy = tmp_path / f"{name}-tared.toml"
    args = ["rig", "tare", "--rig", str(rig), "--seconds", "0.5", "--write", str(copy)]
    assert main(args) == 0
    out = capsys.readouterr().out
    reads = out.split("load cell reads ")[1]
    mean, se = float(reads.split()[0]), float(reads.split("±")[1].split()[0])
    return mean, se, copy


def test_tare_measures_a_known_offset(
    sim_rig_factory: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Two simulated rigs, same seed and parked position, nothing on the load cell (a damper
    without gas charge: no force at rest), one load cell 17.5 N off zero: the tares differ
    by 17.5 N within their own standard errors (a zero error: under the 30 N of a load)."""
    offset = 17.5
    text = SIM_RIG.read_text().replace(
        "[simulation]\n", f"[simulation]\nload_cell_offset_n = {offset}\n"
    )
    (tmp_path / "offset.toml").write_text(text)
    spec = uncharged_spec(tmp_path)
    plain = sim_rig_factory(speed=20.0, seed=4, spec_path=spec)
    shifted = sim_rig_factory(rig=tmp_path / "offset.toml", speed=20.0, seed=4, spec_path=spec)
    writes = log_writes(shifted)
    m0, se0, _ = _tare(plain, tmp_path, "plain", capsys)
    m1, se1, copy = _tare(shifted, tmp_path, "shifted", capsys)
    assert m1 - m0 == pytest.approx(offset, abs=4 * np.hypot(se0, se1) + 0.05)
    # And the true load cell reads what the damper's model says it carries at rest there:
    # the gas force on the rod at the parked position, none without a charge.
    at_rest = np.full(50, PARKED_M)
    still = np.zeros(50)
    model = DamperModel(plain.spec, (), {})
    force = model.evaluate(
        ModelInputs.single(at_rest, still, still, 1e-3), *plain.true_bleed_areas(10)
    ).force
    assert m0 == pytest.approx(float(force[-1]), abs=4 * se0 + 0.05)
    assert 0 < se1 < 0.2  # 2 N noise over thousands of samples
    assert writes == []  # the drive stayed disabled
    # The copy zeroes the load cell: its offset is minus what it read.
    assert load_rig(copy).daq.calibration.force_offset_n == pytest.approx(-m1, abs=6e-3)
    rig = tmp_path / "shifted.toml"
    before = rig.read_text()
    # Never over the rig file itself, and not over an existing copy without --force.
    for target, force in ((rig, ["--force"]), (copy, [])):
        assert main(["rig", "tare", "--rig", str(rig), "--write", str(target), *force]) == 2
        assert capsys.readouterr().err.count("\n") == 1
    assert rig.read_text() == before


def test_tare_refuses_the_gas_force_of_a_mounted_damper(
    sim_rig_factory: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The simulated rig's damper is mounted, its gas pushing the rod out: a load, not a
    zero (issue 47.7: the tare proposed force_offset_n = -230.9, cancelling it). Refused
    in one line saying how to tare; nothing written; --unloaded tares it anyway, warned."""
    sim = sim_rig_factory(speed=20.0, seed=5)
    rig = rig_file(sim, tmp_path)
    copy = tmp_path / "tared.toml"
    args = ["rig", "tare", "--rig", str(rig), "--seconds", "0.5", "--write", str(copy)]
    assert main(args) == 3
    captured = capsys.readouterr()
    (line,) = captured.err.splitlines()
    reading = float(line.split("load cell reads ")[1].split()[0])
    # the gas force at the parked position, from the model the sim's damper runs
    still = np.zeros(50)
    at_rest = ModelInputs.single(np.full(50, PARKED_M), still, still, 1e-3)
    gas = float(
        DamperModel(sim.spec, (), {}).evaluate(at_rest, *sim.true_bleed_areas(10)).force[-1]
    )
    assert 200 < gas < 240 and reading == pytest.approx(gas, abs=1.0)
    assert "unbolt the damper's upper eye (or tare before mounting it)" in line
    assert "gas force" in line and "--unloaded" in line
    assert captured.out == "" and not copy.exists()
    assert main([*args, "--unloaded"]) == 0
    out = capsys.readouterr().out
    assert "warning:" in out and "--unloaded" in out
    assert load_rig(copy).daq.calibration.force_offset_n == pytest.approx(-reading, abs=1.0)


def test_check_over_modbus_rtu(
    sim_rig_factory: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The rig file's transport decides: RTU framing (over a socket, as behind a serial server)."""
    sim = sim_rig_factory(speed=1.0, modbus="rtu")
    text = SIM_RIG.read_text().replace(
        'transport = "tcp"\nhost = "127.0.0.1"\nport = 5020',
        f'transport = "rtu"\nserial_port = "socket://127.0.0.1:{sim.modbus_port}"\n'
        "baudrate = 115200",
    )
    assert 'transport = "rtu"' in text
    rig = rig_file(sim, tmp_path, text)
    writes = log_writes(sim)
    assert main(["rig", "check", "--rig", str(rig), "--json", "-"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["ok"] and "modbus rtu socket://" in doc["drive"][0]["value"]
    assert writes == []


def test_check_reads_a_faster_than_real_time_sim_by_its_time_scale(
    sim_rig_factory: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A simulated rig at 5x real time sends 5 kHz of 1 kHz frames: the rig file that says
    so (daq.time_scale, as a sweep needs it) passes the rate check ('BAD' before)."""
    sim = sim_rig_factory(speed=5.0)
    rig = rig_file(sim, tmp_path)
    assert main(["rig", "check", "--rig", str(rig), "--json", "-"]) == 0
    daq = {f["what"]: f for f in json.loads(capsys.readouterr().out)["daq"]}
    rate = daq["frame rate"]
    assert rate["ok"] and "x daq.time_scale 5" in rate["value"], rate
    assert 4750 < float(rate["value"].split()[0]) < 5250
